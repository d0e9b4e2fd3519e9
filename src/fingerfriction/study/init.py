"""Build a study manifest from a folder of lab recordings (``fingerfriction init``).

The recordings are found by file-name patterns (:mod:`fingerfriction.study.patterns`);
what the files say about themselves (frame counts, frame rates, image sizes, sample
counts, sampling rates) is read from them (:func:`~fingerfriction.video.readers.probe_video`,
:func:`~fingerfriction.forces.readers.read_force_file`); what they cannot say (channel
names, volts and the amplifier's sensitivity, a rate the file lacks, the clock offsets,
the surface behind a token of the file name) comes from :class:`InitOptions`.
:func:`build_manifest` returns the manifest as a dict, the table of the trials found,
the paths it did not use and every problem, without writing anything.

Force-file options may differ per format (a lab with TDMS and CSV files names its
channels differently in each): :attr:`InitOptions.force` maps a format (``'csv'``,
``'tdms'``...) or ``None`` (every format) to manifest ``force`` fields.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from .._check import integer, option_message, positive
from ..forces.readers import FORCE_FORMATS, infer_force_format, read_force_file
from ..surfaces import SURFACE_NAMES, surface_from_spec
from ..video.readers import FPS_TOLERANCE, probe_video
from .manifest import Study, write_manifest
from .patterns import MatchResult, list_candidates, match_recordings
from .records import FORCE_READER_KEYS, MANIFEST_NAME

__all__ = ["InitOptions", "InitTrial", "InitResult", "build_manifest", "write_init", "FORCE_OPTION_KEYS",
           "parse_force_options", "parse_mapping"]

#: Manifest ``force`` fields that :attr:`InitOptions.force` may set: those the files do not
#: answer (every reader keyword of the manifest but ``format`` and ``n_samples``).
FORCE_OPTION_KEYS = tuple(k for k in FORCE_READER_KEYS if k not in ("format", "n_samples"))

#: video format names of the readers -> manifest ``video.format``
_VIDEO_FORMAT = {"tiff": "tiff", "cine": "cine", "mkv": "mkv", "avi": "avi", "mp4": "mp4", "mov": "mov"}


@dataclass(frozen=True)
class InitOptions:
    """What :func:`build_manifest` cannot read from the files.

    Parameters
    ----------
    video, forces : tuple of str
        File-name patterns (:mod:`fingerfriction.study.patterns`), relative to the study
        folder; one or more each.
    surfaces : dict
        File-name token -> surface: a built-in name (``'bump-2mm'``), a parametric spec
        (``'bump:W=3,H=0.5'``) or a CSV profile path. A token without an entry must
        itself be a name or a spec.
    fps : float or None
        Video frame rate in Hz for files that do not state it (TIFF); for a file that
        states one, a confirmation: a file whose rate (its frames' time stamps when it has
        them, else its header's setting) differs by more than
        :data:`~fingerfriction.video.reader_base.FPS_TOLERANCE` is a problem.
    video_t0_s : float
        Time in s of frame 0 on the trial's common clock (the clock offset).
    calibration_frame : int
        Index of the finger-free frame used for calibration.
    force : dict
        Format (``'csv'``, ``'tdms'``...) or None (all formats) -> dict of manifest
        ``force`` fields (:data:`FORCE_OPTION_KEYS`); a format's entry overrides None's.
    surface_height_mm : dict
        Surface (as in the trials' ``surface``) or None (all) -> the feature height H in
        mm used to calibrate the image scale; default the surface's own height.
    description : str
        Free text for the manifest.
    """

    video: tuple
    forces: tuple
    surfaces: Mapping = field(default_factory=dict)
    fps: float | None = None
    video_t0_s: float = 0.0
    calibration_frame: int = 0
    force: Mapping = field(default_factory=dict)
    surface_height_mm: Mapping = field(default_factory=dict)
    description: str = ""

    def __post_init__(self) -> None:
        for name in ("video", "forces"):
            v = getattr(self, name)
            object.__setattr__(self, name, (v,) if isinstance(v, str) else tuple(v))
        if self.fps is not None:
            object.__setattr__(self, "fps", positive("fps", self.fps, "Hz", what="frame rate"))
        t0 = float(self.video_t0_s)
        if not math.isfinite(t0):
            raise ValueError(f"video_t0_s must be a finite time in s, got {self.video_t0_s!r}")
        object.__setattr__(self, "video_t0_s", t0)
        if isinstance(self.calibration_frame, float):  # a frame index, never 3.0
            raise ValueError(f"calibration_frame must be an integer >= 0 (a frame index), got "
                             f"{self.calibration_frame!r}")
        integer("calibration_frame", self.calibration_frame, 0, what="(a frame index)")
        for fmt, opts in self.force.items():
            if fmt is not None and fmt not in FORCE_FORMATS:  # (the message names the format first)
                raise ValueError(f"force options for format {fmt!r}: {option_message(fmt, FORCE_FORMATS)}")
            unknown = set(opts) - set(FORCE_OPTION_KEYS)
            if unknown:
                raise ValueError(f"unknown force option(s) {sorted(unknown)}; "
                                 f"allowed: {', '.join(FORCE_OPTION_KEYS)}")
        for key, h in self.surface_height_mm.items():
            if isinstance(h, bool):
                raise ValueError(f"surface height must be a height in mm, got {h!r}")
            positive("surface height" + ("" if key is None else f" of {key!r}"), h, "mm", what="height")

    @classmethod
    def from_command_line(cls, *, video, forces, surface=None, channels=None, time=None, units=None,
                          sensitivity=None, gain=None, fs_hz=None, force_t0_s=None, fps=None,
                          video_t0_s=None, calibration_frame=None, surface_height_mm=None,
                          description=None) -> InitOptions:
        """The options of ``fingerfriction init`` as typed (repeatable options as lists of
        text: ``--surface TOKEN=SURFACE``, ``--channels [FORMAT:]F1,F2``...; see
        :func:`parse_force_options` and :func:`parse_mapping`). An option left None takes the
        field's default.

        Raises
        ------
        ValueError
            A malformed value, naming its option.
        """
        given = {k: v for k, v in (("video_t0_s", video_t0_s), ("calibration_frame", calibration_frame),
                                   ("description", description)) if v is not None}
        return cls(
            video=tuple(video or ()), forces=tuple(forces or ()),
            surfaces=parse_mapping(surface, "--surface"), fps=fps,
            force=parse_force_options(channels=channels, time=time, units=units, sensitivity=sensitivity,
                                      gain=gain, fs_hz=fs_hz, t0_s=force_t0_s),
            surface_height_mm=parse_mapping(surface_height_mm, "--surface-height-mm",
                                            convert=_number("--surface-height-mm"), allow_default=True),
            **given)

    def force_fields(self, fmt: str) -> dict:
        """The manifest ``force`` fields for files of format ``fmt``."""
        return {**dict(self.force.get(None, {})), **dict(self.force.get(fmt, {}))}


@dataclass(frozen=True)
class InitTrial:
    """One row of the table :func:`build_manifest` prints: a trial and what was read."""

    id: str
    subject: str
    surface: str
    speed_mm_s: float
    repetition: int
    video: str
    force: str
    n_frames: int | None = None
    fps: float | None = None
    size: str = ""
    n_samples: int | None = None
    fs_hz: float | None = None
    problem: str = ""


@dataclass(frozen=True)
class InitResult:
    """What :func:`build_manifest` found.

    Attributes
    ----------
    manifest : dict
        The manifest (``docs/study-format.md``) of the trials without problems.
    trials : tuple of InitTrial
        Every trial found, in order; those with a ``problem`` are not in the manifest.
    unmatched : tuple of patterns.Unmatched
        Paths not used, with the reason.
    problems : tuple of str
        One line per problem (a file that cannot be read, an unknown surface token...),
        naming the file and what is wrong.
    notes : tuple of str
        One line per thing worth knowing that is not a problem (a video whose header's
        frame rate disagrees with its time stamps, which were used).
    """

    manifest: dict
    trials: tuple
    unmatched: tuple
    problems: tuple
    notes: tuple = ()

    @property
    def n_ok(self) -> int:
        return sum(1 for t in self.trials if not t.problem)


def _surface_entry(token: str, options: InitOptions, surfaces_block: dict) -> tuple[str, float]:
    """(manifest ``surface`` value, feature height in mm) for a file-name token."""
    spec = options.surfaces.get(token, token)
    surf = surface_from_spec(spec)  # ValueError naming the spec and what is allowed
    if isinstance(spec, str) and (spec in SURFACE_NAMES or (":" in spec and not os.path.exists(spec))):
        value = spec  # a built-in name or a parametric spec goes into the trial directly
    else:  # a profile file: its samples go into the manifest's surfaces
        value = token
        surfaces_block[token] = surf.to_dict()
    return value, float(surf.max_height)


def _height(options: InitOptions, surface: str, default: float) -> float:
    h = options.surface_height_mm
    return float(h.get(surface, h.get(None, default)))


def _read_video(root: Path, rel: str, options: InitOptions, notes: list) -> dict:
    """The manifest's ``video`` entry of one file; the frame rate by the readers' rule
    (:func:`~fingerfriction.video.reader_base.frame_rate`: time stamps first), ``--fps`` being
    the rate of a file that states none or a confirmation of the one it states."""
    info = probe_video(root / rel)
    fps = info.fps
    if fps is None:
        if options.fps is None:
            raise ValueError(f"{rel}: the video does not state its frame rate; give it (--fps)")
        fps = options.fps
    elif options.fps is not None and abs(fps - options.fps) > FPS_TOLERANCE * fps:
        said = "its frames' time stamps say" if info.rate.source == "time stamps" else "the video states"
        header = (f" (its header: {info.rate.nominal:g})" if info.rate.note and info.rate.nominal else "")
        raise ValueError(f"{rel}: {said} {fps:.6g} fps{header} but --fps {options.fps:g} was given")
    if info.rate.note:
        notes.append(f"{rel}: {info.rate.note}")
    if options.calibration_frame >= info.n_frames:
        raise ValueError(f"{rel}: calibration frame {options.calibration_frame} is past its "
                         f"{info.n_frames} frames")
    return {"path": rel, "format": _VIDEO_FORMAT.get(info.format, info.format), "fps": float(f"{fps:.12g}"),
            "width": info.width, "height": info.height, "n_frames": info.n_frames,
            "t0_s": options.video_t0_s, "calibration_frame": options.calibration_frame}


def _read_force(root: Path, rel: str, options: InitOptions) -> dict:
    fmt = infer_force_format(rel)
    fields = options.force_fields(fmt)
    kw = {k: v for k, v in fields.items() if v is not None}
    rec = read_force_file(root / rel, format=fmt, **kw)
    entry = {"path": rel, "format": fmt, "fs_hz": float(f"{rec.fs_hz:.12g}"), "n_samples": rec.n_samples,
             "channels": dict(rec.channels), "units": rec.units,
             "t0_s": float(fields.get("t0_s", 0.0) or 0.0)}
    for key in ("sensitivity_n_per_v", "gain_v_per_n", "time", "delimiter"):
        if fields.get(key) is not None:
            entry[key] = fields[key]
    return entry


def build_manifest(root: str | os.PathLike, options: InitOptions, *, matches: MatchResult | None = None,
                   created_by: str = "") -> InitResult:
    """Find the trials of a folder of recordings and describe them as a manifest.

    Parameters
    ----------
    root : path-like
        The study folder: the patterns are relative to it, and so are the manifest's paths.
    options : InitOptions
    matches : MatchResult, optional
        A matching already done (default: :func:`~fingerfriction.study.patterns.match_recordings`
        on :func:`~fingerfriction.study.patterns.list_candidates`).
    created_by : str
        For the manifest's ``created_by``.

    Returns
    -------
    InitResult
        Nothing is written.

    Raises
    ------
    ValueError
        A missing folder; a malformed pattern (:class:`~fingerfriction.study.patterns.PatternError`).
    """
    root = Path(root)
    if not root.is_dir():
        raise ValueError(f"study folder {str(root)!r} does not exist or is not a folder")
    if matches is None:
        matches = match_recordings(list_candidates(root), options.video, options.forces)
    surfaces_block: dict = {}
    surface_of: dict[str, tuple[str, float] | str] = {}
    for t in matches.trials:
        if t.surface not in surface_of:
            try:
                surface_of[t.surface] = _surface_entry(t.surface, options, surfaces_block)
            except (ValueError, TypeError) as exc:
                surface_of[t.surface] = (f"surface {t.surface!r} of the file name: {exc}; "
                                         f"map it with --surface {t.surface}=NAME_OR_SPEC")
    rows, entries, problems, notes = [], [], [], []
    for t in matches.trials:
        base = dict(id=t.id, subject=t.subject, surface=t.surface, speed_mm_s=t.speed_mm_s,
                    repetition=t.repetition, video=t.video, force=t.force)
        surf = surface_of[t.surface]
        if isinstance(surf, str):
            problems.append(f"{t.video}: {surf}")
            rows.append(InitTrial(**base, problem=surf))
            continue
        value, height = surf
        errors, video, force = [], None, None
        try:
            video = _read_video(root, t.video, options, notes)
        except (ValueError, OSError) as exc:
            errors.append(_one_line(exc, t.video))
        try:
            force = _read_force(root, t.force, options)
        except (ValueError, OSError, TypeError) as exc:
            errors.append(_one_line(exc, t.force))
        row = dict(base, surface=value)
        if video:
            row.update(n_frames=video["n_frames"], fps=video["fps"],
                       size=f"{video['width']}x{video['height']}")
        if force:
            row.update(n_samples=force["n_samples"], fs_hz=force["fs_hz"])
        if errors:
            problems.extend(errors)
            rows.append(InitTrial(**row, problem="; ".join(errors)))
            continue
        rows.append(InitTrial(**row))
        entries.append({"id": t.id, "subject": t.subject, "surface": value, "speed_mm_s": t.speed_mm_s,
                        "repetition": t.repetition, "video": video, "force": force,
                        "calibration": {"surface_height_mm": _height(options, value, height)}})
    manifest = {"format": "fingerfriction-study", "schema_version": 1, "created_by": created_by,
                "description": options.description, "surfaces": surfaces_block, "trials": entries}
    return InitResult(manifest=manifest, trials=tuple(rows), unmatched=matches.unmatched,
                      problems=tuple(problems), notes=tuple(notes))


def write_init(result: InitResult, root: str | os.PathLike, *, dry_run: bool = False, overwrite: bool = False,
               skip_bad: bool = False) -> Path:
    """Write the manifest :func:`build_manifest` built, after the checks ``init`` makes.

    Parameters
    ----------
    result : InitResult
    root : path-like
        The study folder.
    dry_run : bool
        Make the checks, write nothing.
    overwrite : bool
        Replace an existing ``manifest.json``.
    skip_bad : bool
        Write the trials without problems when some have problems (default: refuse).

    Returns
    -------
    Path
        The manifest's path (written unless ``dry_run``).

    Raises
    ------
    ValueError
        No trial found; trials with problems (without ``skip_bad``); none without; an
        existing manifest (without ``overwrite``); a manifest the parser refuses.
    """
    target = Path(root) / MANIFEST_NAME
    n_bad = len(result.trials) - result.n_ok
    if not result.trials:
        raise ValueError(f"no trial found in {str(root)!r}: no video pattern and force pattern matched "
                         "a pair of files (see the files not used)")
    if n_bad and not skip_bad:
        raise ValueError(f"{n_bad} of {len(result.trials)} trials have problems (listed above); fix them, or "
                         f"give --skip-bad to write the {result.n_ok} others")
    if result.n_ok == 0:
        raise ValueError("no trial without problems: nothing to write")
    study = Study.from_dict(result.manifest)  # the parser's own checks, before anything is written
    if dry_run:
        return target
    if target.exists() and not overwrite:
        raise ValueError(f"{target} exists; give --overwrite to replace it")
    return write_manifest(study, root)


def _one_line(exc: BaseException, rel: str) -> str:
    msg = " ".join(str(exc).split()).strip("'\"")
    return msg if rel in msg else f"{rel}: {msg}"


# --------------------------------------------------------------------------------------
# command-line values -> options (the parsing behind `fingerfriction init`)
# --------------------------------------------------------------------------------------


def _split_format(value: str) -> tuple[str | None, str]:
    fmt, sep, rest = value.partition(":")
    if sep and fmt.lower() in FORCE_FORMATS:
        return fmt.lower(), rest
    return None, value


def _pair(value: str, option: str, convert) -> dict:
    parts = [p.strip() for p in value.split(",")]
    if len(parts) != 2 or not all(parts):
        raise ValueError(f"{option} takes two values F1,F2 separated by a comma, got {value!r}")
    return {"F1": convert(parts[0]), "F2": convert(parts[1])}


def _name_or_index(text: str):
    return int(text) if text.isdigit() else text


def _number(option: str):
    def convert(text: str) -> float:
        try:
            return float(text)
        except ValueError:
            raise ValueError(f"{option} must be a number, got {text!r}") from None
    return convert


def _one_or_pair(value: str, option: str) -> float | dict:
    return _pair(value, option, _number(option)) if "," in value else _number(option)(value)


def parse_force_options(*, channels=(), time=(), units=(), sensitivity=(), gain=(), fs_hz=(),
                        t0_s=()) -> dict:
    """Force-file options of the command line -> :attr:`InitOptions.force`.

    Every value may start with a format and a colon to apply to files of that format only
    (``tdms:Piezo/ai0,Piezo/ai1``); without one it applies to every format. Channels are
    ``F1,F2`` (names, or 0-based column indices for CSV); ``sensitivity`` (N/V) and
    ``gain`` (V/N) are one number for both channels or ``F1,F2``.

    Raises
    ------
    ValueError
        A malformed value, naming the option; the same option given twice for the same
        format.
    """
    spec = {
        "channels": (channels, "--channels", lambda v: _pair(v, "--channels", _name_or_index)),
        "time": (time, "--time", _name_or_index),
        "units": (units, "--units", str),
        "sensitivity_n_per_v": (sensitivity, "--sensitivity", lambda v: _one_or_pair(v, "--sensitivity")),
        "gain_v_per_n": (gain, "--gain", lambda v: _one_or_pair(v, "--gain")),
        "fs_hz": (fs_hz, "--fs-hz", _number("--fs-hz")),
        "t0_s": (t0_s, "--force-t0-s", _number("--force-t0-s")),
    }
    out: dict = {}
    for key, (values, option, convert) in spec.items():
        for value in values or ():
            fmt, rest = _split_format(str(value))
            entry = out.setdefault(fmt, {})
            if key in entry:
                where = f" for {fmt} files" if fmt else ""
                raise ValueError(f"{option} is given twice{where}: {entry[key]!r} and {rest!r}")
            entry[key] = convert(rest.strip())
    return out


def parse_mapping(values, option: str, *, convert=str, allow_default: bool = False) -> dict:
    """``KEY=VALUE`` command-line values -> dict (``None`` key for a bare ``VALUE`` when
    ``allow_default``)."""
    out: dict = {}
    for value in values or ():
        key, sep, rest = str(value).partition("=")
        if not sep:
            if not allow_default:
                raise ValueError(f"{option} takes KEY=VALUE, got {value!r}")
            key, rest = None, value
        elif not key.strip():
            raise ValueError(f"{option} takes KEY=VALUE, got {value!r}")
        k = key.strip() if key is not None else None
        if k in out:
            raise ValueError(f"{option} is given twice for {k or 'every key'!r}")
        out[k] = convert(rest.strip())
    return out
