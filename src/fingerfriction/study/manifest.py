"""The study manifest: a folder of trials described by ``manifest.json`` (schema v1); the
package's only manifest parser and the only resolver of manifest paths.

A *study* is a folder holding, per trial, one video file and one force file, listed in a
human-readable ``manifest.json`` (``docs/study-format.md`` is the reference). This module
reads, validates and writes that manifest:

* :class:`Study` (the whole manifest), :class:`TrialRecord`, :class:`VideoInfo`,
  :class:`ForceInfo` are frozen dataclasses validated in ``__post_init__``;
* :func:`load_manifest` reads a manifest and turns anything malformed into a one-line
  :class:`ManifestError` naming the file and the field (``manifest.json: trials[3].video.fps:
  must be a positive number, got -1``);
* :func:`write_manifest` writes it atomically (temporary file + ``os.replace``), with a
  deterministic layout (same study, same bytes);
* :func:`resolve_path` (and :meth:`Study.path`) turns a manifest path into an absolute
  one, refusing any path that escapes the study folder.
"""

from __future__ import annotations

import dataclasses
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .._atomic import atomic_write_bytes
from .._check import parse_json
from ..forces.readers import probe_force_file
from ..surfaces import SURFACE_NAMES, Surface, surface_from_spec
from ..video.readers import probe_video
from .records import (
    FORCE_FORMATS,
    MANIFEST_NAME,
    VIDEO_FORMATS,
    ForceInfo,
    ManifestError,
    Problem,
    ProblemCollector,
    VideoInfo,
    build_within,
    check_relpath,
    fail,
    is_long_id,
    mapping,
    number,
    problem_from_error,
    resolve_path,
    shown_id,
    string,
    validate_id,
)

__all__ = [
    "FORMAT_NAME",
    "SCHEMA_VERSION",
    "VIDEO_FORMATS",
    "FORCE_FORMATS",
    "ManifestError",
    "Problem",
    "VideoInfo",
    "ForceInfo",
    "TrialRecord",
    "Study",
    "validate_id",
    "resolve_path",
    "load_manifest",
    "read_manifest_json",
    "complete_from_files",
    "write_manifest",
    "manifest_bytes",
]

FORMAT_NAME = "fingerfriction-study"
SCHEMA_VERSION = 1


@dataclass(frozen=True)
class TrialRecord:
    """One trial of a study (one slide of one subject over one surface).

    Parameters
    ----------
    id : str
        Unique trial name (see :func:`validate_id`).
    subject : str
        Subject label.
    surface : str
        Key into :attr:`Study.surfaces` (a built-in name or a parametric spec need no
        entry there).
    speed_mm_s : float
        Nominal sliding speed in mm/s (the condition, > 0).
    repetition : int
        Repetition number (>= 1); 1 when the manifest does not say.
    video : VideoInfo
    force : ForceInfo
    calibration : dict or None
        ``{'surface_height_mm': H}``: the known feature height H in mm (> 0) used to
        calibrate the image scale; None (the field absent from the manifest): the
        surface's own feature height.
    truth : str or None
        Relative path of the ground-truth file (simulated studies only).
    """

    id: str
    subject: str
    surface: str
    speed_mm_s: float
    video: VideoInfo
    force: ForceInfo
    repetition: int = 1
    calibration: dict | None = None
    truth: str | None = None

    def __post_init__(self) -> None:
        validate_id(self.id)
        if not isinstance(self.subject, str) or not self.subject:
            raise fail("subject", f"must be a non-empty string, got {self.subject!r}")
        if not isinstance(self.surface, str) or not self.surface:
            raise fail("surface", f"must be a non-empty string, got {self.surface!r}")
        d = {"speed_mm_s": self.speed_mm_s, "repetition": self.repetition}
        object.__setattr__(self, "speed_mm_s", number(d, "speed_mm_s", "trial", positive=True))
        object.__setattr__(self, "repetition", number(d, "repetition", "trial", positive=True, integer=True))
        if not isinstance(self.video, VideoInfo):
            raise fail("video", f"must be a VideoInfo, got {type(self.video).__name__}")
        if not isinstance(self.force, ForceInfo):
            raise fail("force", f"must be a ForceInfo, got {type(self.force).__name__}")
        if self.calibration is not None:
            cal = mapping(self.calibration, "calibration")
            H = number(cal, "surface_height_mm", "calibration", positive=True)
            object.__setattr__(self, "calibration", {**cal, "surface_height_mm": H})
        if self.truth is not None:
            check_relpath(self.truth, "truth")

    def to_dict(self) -> dict:
        d = {
            "id": self.id, "subject": self.subject, "surface": self.surface,
            "speed_mm_s": self.speed_mm_s, "repetition": self.repetition,
            "video": self.video.to_dict(), "force": self.force.to_dict(),
        }
        if self.calibration is not None:
            d["calibration"] = dict(self.calibration)
        if self.truth is not None:
            d["truth"] = self.truth
        return d

    @classmethod
    def from_dict(cls, d: Any, where: str = "trial", problems: list | None = None,
                  parts: list | None = None) -> TrialRecord | None:
        """Parse one entry of the manifest's ``trials``; with ``problems`` (a list) every
        mistake is appended as a :class:`Problem` and None returned for a bad entry, and
        with ``parts`` (a list) ``(id, VideoInfo or None, ForceInfo or None)`` is appended
        (what parsed of a bad entry, whose recordings can still be checked)."""
        c = ProblemCollector(problems)
        d = c(mapping, d, where)
        if d is None:
            if parts is not None:
                parts.append((None, None, None))
            return None
        tid = c(validate_id, d.get("id"), where=f"{where}.id")
        if tid is None and problems and is_long_id(d.get("id")):
            # an id too long to name a results folder: that trial's error alone
            problems[-1] = dataclasses.replace(problems[-1], trial=shown_id(d["id"]), kind="trial")
        c.trial = tid
        subject = d.get("subject")
        if isinstance(subject, int) and not isinstance(subject, bool):
            subject = str(subject)  # a lab may write subject numbers; labels are strings
        if not isinstance(subject, str) or not subject:
            c(_raise, f"{where}.subject", f"must be a non-empty string, got {subject!r}")
        truth = d.get("truth")
        if truth is not None:
            c(check_relpath, truth, f"{where}.truth")
        cal = d.get("calibration")
        if cal is not None:
            cal = c(mapping, cal, f"{where}.calibration")
            if cal is not None:
                c(number, cal, "surface_height_mm", f"{where}.calibration", positive=True)
        kw = dict(
            surface=c(string, d, "surface", where),
            speed_mm_s=c(number, d, "speed_mm_s", where, positive=True),
            repetition=c(number, d, "repetition", where, positive=True, integer=True, default=1),
        )
        sub = problems if problems is not None else None
        video = c(VideoInfo.from_dict, d.get("video"), f"{where}.video", sub, tid)
        force = c(ForceInfo.from_dict, d.get("force"), f"{where}.force", sub, tid)
        if parts is not None:
            parts.append((tid, video, force))
        if c.failed or video is None or force is None:
            return None
        return cls(id=tid, subject=subject, video=video, force=force, calibration=cal, truth=truth, **kw)


def _raise(where: str, msg: str):
    raise fail(where, msg)


def _surface_of_name(name: str) -> dict | None:
    """The spec of a surface named directly in a trial (a built-in name or a parametric
    spec such as ``'bump:W=3,H=0.5'``), or None. Profile files are not looked up here:
    they belong in ``surfaces``, relative to no folder in particular."""
    if name in SURFACE_NAMES or (":" in name and not name.lower().endswith(".csv")):
        try:
            return surface_from_spec(name, files=False).to_dict()
        except (ValueError, TypeError):
            return None
    return None


@dataclass(frozen=True)
class Study:
    """A study manifest (schema version 1).

    Parameters
    ----------
    trials : tuple of TrialRecord
        Unique ids; each trial's surface is a key of ``surfaces``.
    surfaces : dict
        Surface name -> spec dict as written by ``Surface.to_dict()``. A built-in name
        (``'bump-2mm'``) or a parametric spec (``'bump:W=3,H=0.5'``) used by a trial is
        added to it.
    description : str
        Free text.
    created_by : str
        Software that wrote the manifest.
    root : Path or None
        The study folder (set by :func:`load_manifest`; not written to the file).
    """

    trials: tuple
    surfaces: dict = field(default_factory=dict)
    description: str = ""
    created_by: str = ""
    root: Path | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "trials", tuple(self.trials))
        if not isinstance(self.surfaces, dict):
            raise fail("surfaces", f"must be a mapping of name -> spec, got {type(self.surfaces).__name__}")
        surfaces = dict(self.surfaces)
        seen: set[str] = set()
        for i, t in enumerate(self.trials):
            if not isinstance(t, TrialRecord):
                raise fail(f"trials[{i}]", f"must be a TrialRecord, got {type(t).__name__}")
            if t.id in seen:
                raise fail(f"trials[{i}].id", f"duplicate trial id {t.id!r}")
            seen.add(t.id)
            if t.surface not in surfaces:
                spec = _surface_of_name(t.surface)
                if spec is None:
                    raise fail(f"trials[{i}].surface", _unknown_surface(t.surface, surfaces))
                surfaces[t.surface] = spec
        object.__setattr__(self, "surfaces", surfaces)

    def trial(self, trial_id: str) -> TrialRecord:
        """The trial with this id (``KeyError`` naming the known ids if absent)."""
        for t in self.trials:
            if t.id == trial_id:
                return t
        raise KeyError(f"no trial {trial_id!r} in the study; {len(self.trials)} trials known")

    def surface(self, name: str) -> Surface:
        """The :class:`~fingerfriction.surfaces.Surface` of a surface key."""
        return surface_from_spec(self.surfaces[name])

    def path(self, relpath: str, *, where: str = "path") -> Path:
        """Absolute path of a manifest path (see :func:`resolve_path`)."""
        if self.root is None:
            raise ValueError("this Study has no root folder; load it with load_manifest or pass root=")
        return resolve_path(self.root, relpath, where=where)

    def to_dict(self) -> dict:
        return {
            "format": FORMAT_NAME,
            "schema_version": SCHEMA_VERSION,
            "created_by": self.created_by,
            "description": self.description,
            "surfaces": {k: dict(v) for k, v in self.surfaces.items()},
            "trials": [t.to_dict() for t in self.trials],
        }

    @classmethod
    def from_dict(cls, d: Any, *, root: Path | None = None, problems: list | None = None,
                  parts: list | None = None) -> Study | None:
        """Parse a manifest. With ``problems`` (a list), every mistake is appended as a
        :class:`Problem` and the study returned holds the trials without mistakes (None if
        the manifest as a whole is unusable); ``parts``: see :meth:`TrialRecord.from_dict`,
        one item per entry of ``trials``."""
        c = ProblemCollector(problems)
        d = c(mapping, d, "manifest")
        if d is None:
            return None
        fmt = d.get("format")
        if fmt != FORMAT_NAME:
            c(_raise, "format", f"must be {FORMAT_NAME!r}, got {fmt!r}")
        ver = d.get("schema_version")
        if ver != SCHEMA_VERSION:
            c(_raise, "schema_version", f"this version of fingerfriction reads schema 1, got {ver!r}")
        surfaces = c(mapping, d.get("surfaces", {}), "surfaces") or {}
        good_surfaces = {}
        for name, spec in surfaces.items():
            try:
                surface_from_spec(mapping(spec, f"surfaces.{name}"))
                good_surfaces[name] = spec
            except ManifestError as exc:
                c(_raise, f"surfaces.{name}", str(exc).split(": ", 1)[-1])
            except (ValueError, TypeError, KeyError) as exc:
                c(_raise, f"surfaces.{name}", f"invalid surface spec ({exc})")
        trials = d.get("trials")
        if not isinstance(trials, list):
            c(_raise, "trials", f"must be a list, got {type(trials).__name__}")
            return None
        description = c(string, d, "description", "manifest", default="")
        created_by = c(string, d, "created_by", "manifest", default="")
        if c.failed and problems is None:
            return None
        recs, seen = [], {}
        for i, t in enumerate(trials):
            rec = TrialRecord.from_dict(t, f"trials[{i}]", problems, parts)
            if rec is None:
                continue
            if rec.id in seen:
                c.trial = rec.id
                c(_raise, f"trials[{i}].id", f"duplicate trial id {rec.id!r} (also trials[{seen[rec.id]}])")
                continue
            seen[rec.id] = i
            if rec.surface not in good_surfaces and _surface_of_name(rec.surface) is None:
                c.trial = rec.id
                c(_raise, f"trials[{i}].surface", _unknown_surface(rec.surface, surfaces))
                continue
            recs.append(rec)
        return cls(trials=recs, surfaces=good_surfaces, description=description or "",
                   created_by=created_by or "", root=root)


def _unknown_surface(name: str, surfaces: dict) -> str:
    if ":" in name and not name.lower().endswith(".csv"):  # a spec: why it is refused
        try:
            surface_from_spec(name, files=False)
        except (ValueError, TypeError) as exc:
            return f"surface spec {name!r}: {' '.join(str(exc).split())}"
    known = f"; 'surfaces' defines {', '.join(surfaces)}" if surfaces else ""
    return (f"{name!r} is not in 'surfaces' and is not a built-in surface ({', '.join(SURFACE_NAMES)}) or a "
            f"spec like 'bump:W=3,H=0.5'{known}")


def _manifest_file(path: str | os.PathLike) -> Path:
    p = Path(path)
    return p / MANIFEST_NAME if p.is_dir() else p


def read_manifest_json(path: str | os.PathLike) -> Any:
    """The parsed JSON of a manifest (the file, or the study folder holding it).

    Raises
    ------
    ManifestError
        A missing or unreadable file, text that is not UTF-8 or not JSON, naming the file.
    """
    p = _manifest_file(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ManifestError(f"{p}: no such manifest file") from None
    except OSError as exc:
        raise ManifestError(f"{p}: cannot read manifest ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise ManifestError(f"{p}: manifest is not UTF-8 text") from None
    try:
        return parse_json(text, str(p))  # bounded size and nesting (a deep one: RecursionError)
    except ValueError as exc:
        raise ManifestError(str(exc)) from None


def load_manifest(path: str | os.PathLike, *, complete: bool = True) -> Study:
    """Read and validate a study manifest.

    Parameters
    ----------
    path : path-like
        The ``manifest.json`` file, or the study folder holding it.
    complete : bool
        Read the fields a trial leaves to its files (frame rate, frame count, image size,
        sample count, sampling rate) from the files (:func:`complete_from_files`).

    Returns
    -------
    Study
        With ``root`` set to the folder of the manifest.

    Raises
    ------
    ManifestError
        One line naming the file and the first offending field, e.g.
        ``study/manifest.json: trials[2].video.fps: must be positive, got 0``
        (``fingerfriction check`` lists them all: :func:`fingerfriction.study.check.check_study`).
    """
    p = _manifest_file(path)
    data = read_manifest_json(p)
    try:
        study = Study.from_dict(data, root=p.parent.resolve())
    except ManifestError as exc:
        raise ManifestError(f"{p}: {exc}") from None
    for i, t in enumerate(study.trials):
        for what, rel in (("video.path", t.video.path), ("force.path", t.force.path), ("truth", t.truth)):
            if rel is not None:
                try:
                    resolve_path(study.root, rel, where=f"trials[{i}].{what}")
                except ManifestError as exc:
                    raise ManifestError(f"{p}: {exc}") from None
    if complete:
        try:
            study = complete_from_files(study)
        except ManifestError as exc:
            raise ManifestError(f"{p}: {exc}") from None
    return study


def complete_from_files(study: Study, problems: list | None = None) -> Study:
    """The study with every field a trial left to its files read from them.

    Video: ``fps``, ``width``, ``height``, ``n_frames``
    (:func:`~fingerfriction.video.readers.probe_video`); force: ``n_samples`` and
    ``fs_hz`` (:func:`~fingerfriction.forces.readers.probe_force_file`; the file must
    state its rate: TDMS, an HDF5 attribute, a time column). Trials that state them all
    are not opened.

    Parameters
    ----------
    study : Study
        With its ``root``.
    problems : list, optional
        Append a :class:`Problem` per file that cannot answer and leave that trial out,
        instead of raising.

    Raises
    ------
    ManifestError
        ``trials[i].video.fps: not given, and ... does not state it``, or a file that
        cannot be read.
    """
    out = []
    for i, t in enumerate(study.trials):
        try:
            out.append(_complete_trial(study, i, t))
        except ManifestError as exc:
            if problems is None:
                raise
            rel = t.video.path if ".video." in str(exc).split(":", 1)[0] else t.force.path
            problems.append(problem_from_error(exc, file=rel, trial=t.id, kind="file"))
    return dataclasses.replace(study, trials=tuple(out))


def _complete_trial(study: Study, i: int, t: TrialRecord) -> TrialRecord:
    video, force = t.video, t.force
    if video.missing:
        where = f"trials[{i}].video"
        try:
            info = probe_video(study.path(video.path, where=f"{where}.path"))
        except (ValueError, OSError) as exc:
            msg = f"not given, and the video cannot be read: {exc}"
            raise fail(f"{where}.{video.missing[0]}", msg) from None
        found = {"fps": info.fps, "width": info.width, "height": info.height, "n_frames": info.n_frames}
        if found["fps"] is None and video.fps is None:
            raise fail(f"{where}.fps", f"not given, and {video.path} does not state its frame rate; give it")
        video = build_within(where, VideoInfo, **{**video.to_dict(), **{k: found[k] for k in video.missing}})
    if force.missing:
        where = f"trials[{i}].force"
        opts = force.reader_options()
        try:
            info = probe_force_file(study.path(force.path, where=f"{where}.path"), channels=opts["channels"],
                                    format=opts["format"], time=opts.get("time"),
                                    delimiter=opts.get("delimiter"))
        except (ValueError, OSError) as exc:
            raise fail(f"{where}.{force.missing[0]}", f"not given, and the force file cannot be read: "
                                                      f"{' '.join(str(exc).split())}") from None
        if force.fs_hz is None and info.fs_hz is None:
            raise fail(f"{where}.fs_hz", f"not given, and {force.path} does not state its sampling rate "
                                         "(no time column, no TDMS/HDF5 rate); give it")
        found = {"fs_hz": float(f"{info.fs_hz:.12g}") if info.fs_hz else None, "n_samples": info.n_samples}
        force = build_within(where, ForceInfo, **{**force.to_dict(), **{k: found[k] for k in force.missing}})
    if video is t.video and force is t.force:
        return t
    return dataclasses.replace(t, video=video, force=force)


def manifest_bytes(study: Study) -> bytes:
    """The manifest file content: indented JSON, keys in schema order, final newline."""
    return (json.dumps(study.to_dict(), indent=2, allow_nan=False) + "\n").encode("utf-8")


def write_manifest(study: Study, folder: str | os.PathLike) -> Path:
    """Write ``folder/manifest.json`` atomically (temporary file + ``os.replace``).

    Returns
    -------
    Path
        The manifest path.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    target = folder / MANIFEST_NAME
    atomic_write_bytes(target, manifest_bytes(study))
    return target
