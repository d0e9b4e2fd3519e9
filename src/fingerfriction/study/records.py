"""The fields of a study manifest's trial entries: the checks every manifest field goes
through, the ``video`` and ``force`` records, and how a mistake is reported.

Part of the manifest parser (:mod:`fingerfriction.study.manifest` re-exports every public
name): :class:`VideoInfo` and :class:`ForceInfo` are validated in ``__post_init__``, and
their ``from_dict`` either raises a :class:`ManifestError` at the first mistake or, given
a list, appends every mistake to it as a :class:`Problem` (what ``fingerfriction check``
prints, one line each naming the file and the field). :func:`resolve_path` is the only
resolver of manifest paths.
"""

from __future__ import annotations

import math
import os
import re
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from .._check import SamplingRate, option_message
from ..forces.readers import DEFAULT_CHANNELS, FORCE_FORMATS, FORCE_UNITS, channel_scale, infer_force_format

__all__ = [
    "MANIFEST_NAME",
    "VIDEO_FORMATS",
    "VIDEO_SUFFIXES",
    "FORCE_FORMATS",
    "FORCE_READER_KEYS",
    "ManifestError",
    "TrialIdTooLong",
    "MAX_ID_LENGTH",
    "shown_id",
    "is_long_id",
    "Problem",
    "VideoInfo",
    "ForceInfo",
    "validate_id",
    "resolve_path",
]

VIDEO_FORMATS = ("ffv1-mkv", "tiff", "avi", "mp4", "mkv", "mov", "cine")
MANIFEST_NAME = "manifest.json"

_ID_RE = re.compile(r"^[A-Za-z0-9_.\-]+$")

#: The longest trial id: it names a folder (``trials/<id>/``) and files (``<id>.parquet``,
#: ``<id>.html`` and their temporary names, about 30 characters more), within the 255
#: bytes a file name may have on common file systems.
MAX_ID_LENGTH = 128


class ManifestError(ValueError):
    """A malformed manifest or an invalid study record; the message names file and field."""


class TrialIdTooLong(ManifestError):
    """A trial id longer than :data:`MAX_ID_LENGTH`: an error of that trial alone (``analyze``
    runs the others and reports it failed)."""


def is_long_id(value: Any) -> bool:
    """Whether ``value`` is a trial id that is wrong only by being longer than
    :data:`MAX_ID_LENGTH`."""
    return (isinstance(value, str) and len(value) > MAX_ID_LENGTH and bool(_ID_RE.match(value))
            and value not in (".", ".."))


def shown_id(trial_id: str) -> str:
    """A trial id as messages show it: a long one cut, with its length."""
    return trial_id if len(trial_id) <= 60 else f"{trial_id[:40]}...({len(trial_id)} characters)"


def fail(where: str, msg: str) -> ManifestError:
    """The :class:`ManifestError` of field ``where`` (``trials[3].video.fps``): ``"<where>: <msg>"``."""
    return ManifestError(f"{where}: {msg}")


def validate_id(trial_id: Any, *, where: str = "id") -> str:
    """Check a trial id: a non-empty string of letters, digits, ``-``, ``_`` and ``.``.

    The id names a folder (``trials/<id>/``), so ``.`` and ``..`` alone are refused, and
    it is at most :data:`MAX_ID_LENGTH` characters long.

    Raises
    ------
    ManifestError
        Naming ``where``, the value and what is allowed; :class:`TrialIdTooLong` for a
        long id.
    """
    if not isinstance(trial_id, str) or not _ID_RE.match(trial_id) or trial_id in (".", ".."):
        shown = repr(shown_id(trial_id)) if isinstance(trial_id, str) else repr(trial_id)[:80]
        raise fail(
            where, f"trial id must be letters, digits, '-', '_' or '.' (not '.' or '..'), got {shown}"
        )
    if len(trial_id) > MAX_ID_LENGTH:
        raise TrialIdTooLong(f"{where}: trial id {shown_id(trial_id)!r} is longer than {MAX_ID_LENGTH} "
                             "characters (MAX_ID_LENGTH): it names the trial's results folder and files; "
                             "give a shorter id")
    return trial_id


def check_relpath(path: Any, where: str) -> str:
    """A manifest path: relative, POSIX separators, no component ``..``."""
    if not isinstance(path, str) or not path:
        raise fail(where, f"must be a non-empty relative path string, got {path!r}")
    if "\\" in path:
        raise fail(where, f"must use '/' separators, got {path!r}")
    p = Path(path)
    if p.is_absolute() or path.startswith("/"):
        raise fail(where, f"must be relative to the study folder, got absolute path {path!r}")
    if any(part == ".." for part in p.parts):
        raise ManifestError(f"{where} {path!r} escapes the study folder ('..' is not allowed)")
    return path


def resolve_path(root: str | os.PathLike, relpath: str, *, where: str = "path") -> Path:
    """Absolute path of ``relpath`` inside the study folder ``root``.

    Parameters
    ----------
    root : path-like
        The study folder.
    relpath : str
        A path from the manifest, relative to ``root``.
    where : str
        Field name used in error messages.

    Raises
    ------
    ManifestError
        If ``relpath`` is absolute, contains ``..``, or resolves (through symbolic links)
        outside ``root``.
    """
    check_relpath(relpath, where)
    base = Path(root).resolve()
    full = (base / relpath).resolve()
    if full != base and base not in full.parents:
        raise fail(where, f"path {relpath!r} resolves to {full}, outside the study folder {base}")
    return full


#: Upper bounds of the manifest's numbers (field name -> (bound, unit)): each keeps memory
#: and time reasonable, or is far beyond any recording (a finger slides at most a few
#: hundred mm/s; the fastest cameras record about a million frames per second).
LIMITS = {
    "speed_mm_s": (10_000.0, "mm/s"),
    "repetition": (1_000_000, ""),
    "fps": (10_000_000.0, "Hz"),
    "width": (65_536, "px"),
    "height": (65_536, "px"),
    "n_frames": (10_000_000, "frames"),
    "calibration_frame": (10_000_000, ""),
    "fs_hz": (10_000_000.0, "Hz"),
    "n_samples": (50_000_000, "samples"),  # forces.readers.MAX_SAMPLES
    "t0_s": (1_000_000.0, "s"),  # a bound on |t0_s|
    "surface_height_mm": (10.0, "mm"),  # surfaces.MAX_HEIGHT_MM
}


def number(d: dict, key: str, where: str, *, positive: bool = False, integer: bool = False,
           nonneg: bool = False, default: Any = ...) -> Any:
    """Field ``key`` of manifest object ``d`` as a number, checked.

    ``where`` names the object in messages (``<where>.<key>``). The value must be a finite
    int or float (not a bool), within :data:`LIMITS` for its key (1e12 otherwise); with
    ``positive`` above 0, with ``nonneg`` at least 0, with ``integer`` a whole number (returned
    as int, else float). A missing key returns ``default`` when given, else raises.

    Raises
    ------
    ManifestError
        Naming ``<where>.<key>``, the value and what is allowed.
    """
    if key not in d:
        if default is not ...:
            return default
        raise fail(f"{where}.{key}", "missing required field")
    v = d[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise fail(f"{where}.{key}", f"must be a number, got {str(v)[:40]!r}")
    hi, unit = LIMITS.get(key, (1e12, ""))
    # before any conversion: an integer of 400 digits has no float
    if isinstance(v, int) and abs(v) > hi:
        raise fail(f"{where}.{key}", f"must be at most {hi:g}{' ' + unit if unit else ''}, got a number of "
                                     f"{len(str(abs(v)))} digits")
    if integer and (not float(v).is_integer()):
        raise fail(f"{where}.{key}", f"must be an integer, got {v!r}")
    if not math.isfinite(v):
        raise fail(f"{where}.{key}", f"must be finite, got {v!r}")
    if positive and v <= 0:
        raise fail(f"{where}.{key}", f"must be positive, got {v!r}")
    if nonneg and v < 0:
        raise fail(f"{where}.{key}", f"must be >= 0, got {v!r}")
    if abs(v) > hi:
        raise fail(f"{where}.{key}", f"must be at most {hi:g}{' ' + unit if unit else ''}, got {v!r}")
    return int(v) if integer else float(v)


def rate(d: dict, key: str, where: str, *, default: Any = ...) -> Any:
    """Field ``key`` of manifest object ``d`` as a sampling rate in Hz (:func:`number`, > 0,
    within :data:`LIMITS`), a :class:`~fingerfriction._check.SamplingRate`: checked here once,
    the force readers take it as checked."""
    v = number(d, key, where, positive=True, default=default)
    return v if v is None or v is default else SamplingRate(v)


def string(d: dict, key: str, where: str, *, allowed: tuple[str, ...] | None = None,
           default: Any = ...) -> Any:
    """Field ``key`` of manifest object ``d`` as a string, one of ``allowed`` when given; a
    missing key returns ``default`` when given, else raises :class:`ManifestError` (naming
    ``<where>.<key>``)."""
    if key not in d:
        if default is not ...:
            return default
        raise fail(f"{where}.{key}", "missing required field")
    v = d[key]
    if not isinstance(v, str):
        raise fail(f"{where}.{key}", f"must be a string, got {v!r}")
    if allowed is not None:
        option(f"{where}.{key}", v, allowed)
    return v


def option(where: str, value: Any, allowed) -> Any:
    """``value`` when it is one of ``allowed``, else the :class:`ManifestError` of field
    ``where``: "trials[3].force.format: must be one of npz, csv, ..., got 'xls'"."""
    if value not in allowed:
        raise fail(where, option_message(value, allowed))
    return value


def mapping(d: Any, where: str) -> dict:
    """``d`` itself when it is a JSON object (a dict), else a :class:`ManifestError` naming ``where``."""
    if not isinstance(d, dict):
        raise fail(where, f"must be a JSON object, got {type(d).__name__}")
    return d


@dataclass(frozen=True)
class Problem:
    """One thing wrong with a study, on one line: the file, the field, what is wrong.

    Attributes
    ----------
    file : str
        The file the problem is in: the manifest, or a recording (its manifest path).
    field : str
        The manifest field (``trials[3].video.fps``), or ``''`` for the file as a whole.
    message : str
        What is wrong and what is allowed.
    trial : str or None
        The trial's id, when the problem belongs to one trial.
    kind : {'manifest', 'file', 'trial'}
        A mistake in the manifest's text, or a recording that does not match it (missing,
        unreadable, other frame count...), or an entry that cannot be run on its own
        (``'trial'``: an id too long to name its results; ``analyze`` fails that trial and
        runs the others).
    """

    file: str
    field: str
    message: str
    trial: str | None = None
    kind: str = "manifest"

    def __str__(self) -> str:
        return f"{self.file}: {self.field}: {self.message}" if self.field else f"{self.file}: {self.message}"


_FIELD_RE = re.compile(r"^[A-Za-z_][\w.\[\]\-]*$")


def problem_from_error(exc: Exception, *, file: str = MANIFEST_NAME, trial: str | None = None,
                       kind: str = "manifest", field: str = "") -> Problem:
    """A Problem from a ``'<field>: <message>'`` error."""
    text = " ".join(str(exc).split())
    head, sep, rest = text.partition(": ")
    if sep and not field and _FIELD_RE.match(head):
        field, text = head, rest
    return Problem(file=file, field=field, message=text, trial=trial, kind=kind)


class ProblemCollector:
    """Runs parsing steps and keeps their :class:`ManifestError` instead of raising at the
    first one, so that ``fingerfriction check`` lists every problem of a manifest."""

    def __init__(self, problems: list | None, trial: str | None = None):
        self.problems = problems
        self.trial = trial
        self.failed = False

    def __call__(self, fn, *args, **kw):
        try:
            return fn(*args, **kw)
        except ManifestError as exc:
            if self.problems is None:
                raise
            self.failed = True
            self.problems.append(problem_from_error(exc, trial=self.trial))
            return None


#: Video suffix -> manifest ``video.format`` (a path without suffix is a folder of TIFF frames).
VIDEO_SUFFIXES = {".cine": "cine", ".tif": "tiff", ".tiff": "tiff", ".mkv": "mkv", ".avi": "avi",
                  ".mp4": "mp4", ".mov": "mov"}


def _video_format(path: str, where: str) -> str:
    suffix = Path(path).suffix.lower()
    if not suffix:
        return "tiff"
    if suffix not in VIDEO_SUFFIXES:
        raise fail(f"{where}.format", f"not given, and the suffix {suffix!r} of {path!r} does not tell it; "
                                      f"give one of {', '.join(VIDEO_FORMATS)}")
    return VIDEO_SUFFIXES[suffix]


@dataclass(frozen=True)
class VideoInfo:
    """The video of one trial.

    Fields the file itself answers (``format``, ``fps``, ``width``, ``height``,
    ``n_frames``) may be None in the manifest; :func:`load_manifest` reads them from the
    file.

    Parameters
    ----------
    path : str
        Relative to the study folder.
    format : str
        One of :data:`VIDEO_FORMATS`; default from the suffix (none: a folder of TIFF frames).
    fps : float or None
        Frame rate in Hz (> 0).
    width, height : int or None
        Frame size in pixels (> 0).
    n_frames : int or None
        Number of frames (> 0).
    t0_s : float
        Time in s of frame 0 on the trial's common clock; frame k is at ``t0_s + k / fps``.
    calibration_frame : int
        Index of the finger-free frame used for calibration (Fig. 7A), ``0 <= . < n_frames``.
    """

    path: str
    format: str | None = None
    fps: float | None = None
    width: int | None = None
    height: int | None = None
    n_frames: int | None = None
    t0_s: float = 0.0
    calibration_frame: int = 0

    def __post_init__(self) -> None:
        check_relpath(self.path, "video.path")
        d = {k: getattr(self, k) for k in ("fps", "width", "height", "n_frames", "t0_s", "calibration_frame")}
        if self.fps is not None:
            object.__setattr__(self, "fps", number(d, "fps", "video", positive=True))
        for k in ("width", "height", "n_frames"):
            if d[k] is not None:
                object.__setattr__(self, k, number(d, k, "video", positive=True, integer=True))
        object.__setattr__(self, "t0_s", number(d, "t0_s", "video"))
        cf = number(d, "calibration_frame", "video", integer=True, nonneg=True)
        if self.n_frames is not None and cf >= self.n_frames:
            raise fail("video.calibration_frame", f"must be < n_frames ({self.n_frames}), got {cf}")
        object.__setattr__(self, "calibration_frame", cf)
        fmt = _video_format(self.path, "video") if self.format is None else self.format
        option("video.format", fmt, VIDEO_FORMATS)
        object.__setattr__(self, "format", fmt)

    @property
    def missing(self) -> tuple[str, ...]:
        """The fields left for the file to answer."""
        return tuple(k for k in ("fps", "width", "height", "n_frames") if getattr(self, k) is None)

    def frame_times(self):
        """Times in s of every frame on the common clock, ``(n_frames,)`` ndarray."""
        if self.fps is None or self.n_frames is None:
            raise ValueError(f"video {self.path}: fps and n_frames are not known; read the manifest with "
                             "load_manifest, which takes them from the file")
        return self.t0_s + np.arange(self.n_frames) / self.fps

    def to_dict(self) -> dict:
        d = {"path": self.path, "format": self.format, "fps": self.fps, "width": self.width,
             "height": self.height, "n_frames": self.n_frames, "t0_s": self.t0_s,
             "calibration_frame": self.calibration_frame}
        return {k: v for k, v in d.items() if v is not None}

    @classmethod
    def from_dict(cls, d: Any, where: str = "video", problems: list | None = None,
                  trial: str | None = None) -> VideoInfo | None:
        """Parse a manifest ``video`` object; with ``problems`` (a list), every mistake is
        appended as a :class:`Problem` and None returned instead of raising at the first."""
        opt = {"default": None}
        return _parse(cls, d, where, problems, trial, lambda c, d: dict(
            path=c(check_relpath, d.get("path"), f"{where}.path"),
            format=c(string, d, "format", where, allowed=VIDEO_FORMATS, **opt),
            fps=c(number, d, "fps", where, positive=True, **opt),
            width=c(number, d, "width", where, positive=True, integer=True, **opt),
            height=c(number, d, "height", where, positive=True, integer=True, **opt),
            n_frames=c(number, d, "n_frames", where, positive=True, integer=True, **opt),
            t0_s=c(number, d, "t0_s", where, default=0.0),
            calibration_frame=c(number, d, "calibration_frame", where, integer=True, nonneg=True, default=0),
        ))


def _parse(cls, d: Any, where: str, problems: list | None, trial: str | None, fields):
    """A manifest object ``d`` parsed into ``cls``: ``fields(c, d)`` gives the keyword
    arguments, each read through the collector ``c``; None once a mistake is collected
    (with ``problems``), else the first mistake raised."""
    c = ProblemCollector(problems, trial)
    d = c(mapping, d, where)
    if d is None:
        return None
    kw = fields(c, d)
    if c.failed:
        return None
    return c(build_within, where, cls, **kw)


def build_within(where: str, cls, **kw):
    """``cls(**kw)`` with the ``__post_init__`` field names put under ``where``."""
    try:
        return cls(**kw)
    except ManifestError as exc:
        raise ManifestError(re.sub(r"^(video|force)(?=[.:])", where, str(exc))) from None


def _channel_name(v) -> bool:
    return (isinstance(v, str) and v != "") or (isinstance(v, int) and not isinstance(v, bool) and v >= 0)


@dataclass(frozen=True)
class ForceInfo:
    """The force recording of one trial: the two transducer channels F1, F2.

    Fields the file itself answers (``format``, ``fs_hz`` when the file states its rate,
    ``n_samples``) may be None in the manifest; :func:`load_manifest` reads them from the
    file.

    Parameters
    ----------
    path : str
        Relative to the study folder.
    format : str
        One of :data:`FORCE_FORMATS`; default from the suffix.
    fs_hz : float or None
        Sampling frequency in Hz (> 0).
    n_samples : int or None
        Number of samples per channel (> 0).
    channels : dict
        Maps ``'F1'`` and ``'F2'`` (the paper's +-45 degree piezos, Fig. 1C) to the names of
        the channels in the file (a CSV column may be given by its 0-based index).
    units : {'N', 'V', 'mV'}
        Units of the channels in the file.
    t0_s : float
        Time in s on the trial's common clock of sample 0 (of the file's time zero when it
        has a time column: sample n at ``t0_s + time[n]``).
    sensitivity_n_per_v, gain_v_per_n : float or dict, optional
        For channels in volts, exactly one: N/V, or V/N; one number or ``{'F1', 'F2'}``.
    time : str or int, optional
        A time column in s.
    delimiter : str, optional
        CSV delimiter (detected when omitted).
    """

    path: str
    format: str | None = None
    fs_hz: float | None = None
    n_samples: int | None = None
    channels: dict = field(default_factory=lambda: dict(DEFAULT_CHANNELS))
    units: str = "N"
    t0_s: float = 0.0
    sensitivity_n_per_v: Any = None
    gain_v_per_n: Any = None
    time: str | int | None = None
    delimiter: str | None = None

    def __post_init__(self) -> None:
        check_relpath(self.path, "force.path")
        fmt = self.format
        if fmt is None:
            try:
                fmt = infer_force_format(self.path)
            except ValueError:
                raise fail("force.format", f"not given, and the suffix of {self.path!r} does not tell it; "
                                           f"give one of {', '.join(FORCE_FORMATS)}") from None
        option("force.format", fmt, FORCE_FORMATS)
        object.__setattr__(self, "format", fmt)
        d = {"fs_hz": self.fs_hz, "n_samples": self.n_samples, "t0_s": self.t0_s}
        if self.fs_hz is not None and not isinstance(self.fs_hz, SamplingRate):  # else checked by rate()
            object.__setattr__(self, "fs_hz", rate(d, "fs_hz", "force"))
        if self.n_samples is not None:
            n = number(d, "n_samples", "force", positive=True, integer=True)
            object.__setattr__(self, "n_samples", n)
        object.__setattr__(self, "t0_s", number(d, "t0_s", "force"))
        ch = self.channels
        if not isinstance(ch, dict) or set(ch) != {"F1", "F2"} or not all(map(_channel_name, ch.values())):
            raise fail("force.channels", "must map exactly 'F1' and 'F2' to channel names (or CSV column "
                                         f"indices), got {ch!r}")
        object.__setattr__(self, "channels", {"F1": ch["F1"], "F2": ch["F2"]})
        try:
            channel_scale(self.units, self.sensitivity_n_per_v, self.gain_v_per_n)
        except ValueError as exc:
            raise fail("force.units" if str(exc).startswith("units") else "force", str(exc)) from None
        if self.time is not None and not _channel_name(self.time):
            raise fail("force.time", f"must be a channel name or a CSV column index, got {self.time!r}")
        if self.delimiter is not None and (not isinstance(self.delimiter, str) or not self.delimiter):
            raise fail("force.delimiter", f"must be a non-empty string, got {self.delimiter!r}")

    @property
    def missing(self) -> tuple[str, ...]:
        """The fields left for the file to answer."""
        return tuple(k for k in ("fs_hz", "n_samples") if getattr(self, k) is None)

    def reader_options(self) -> dict:
        """Keywords of :func:`fingerfriction.forces.read_force_file` for this file: every field
        but ``path`` that is set (:data:`FORCE_READER_KEYS`)."""
        d = self.to_dict()
        return {k: d[k] for k in FORCE_READER_KEYS if k in d}

    def sample_times(self):
        """Times in s of every sample on the common clock, ``(n_samples,)`` ndarray."""
        if self.fs_hz is None or self.n_samples is None:
            raise ValueError(f"force file {self.path}: fs_hz and n_samples are not known; read the manifest "
                             "with load_manifest, which takes them from the file")
        return self.t0_s + np.arange(self.n_samples) / self.fs_hz

    def to_dict(self) -> dict:
        """The manifest ``force`` object: every field that is set, in the fields' order."""
        d = {f.name: getattr(self, f.name) for f in fields(self)}
        d["channels"] = dict(self.channels)
        return {k: v for k, v in d.items() if v is not None}

    @classmethod
    def from_dict(cls, d: Any, where: str = "force", problems: list | None = None,
                  trial: str | None = None) -> ForceInfo | None:
        """Parse a manifest ``force`` object (``problems``: as :meth:`VideoInfo.from_dict`)."""
        opt = {"default": None}
        return _parse(cls, d, where, problems, trial, lambda c, d: dict(
            path=c(check_relpath, d.get("path"), f"{where}.path"),
            format=c(string, d, "format", where, allowed=FORCE_FORMATS, **opt),
            fs_hz=c(rate, d, "fs_hz", where, **opt),
            n_samples=c(number, d, "n_samples", where, positive=True, integer=True, **opt),
            channels=d.get("channels", dict(DEFAULT_CHANNELS)),
            units=c(string, d, "units", where, allowed=FORCE_UNITS, default=cls.units),
            t0_s=c(number, d, "t0_s", where, default=cls.t0_s),
            sensitivity_n_per_v=d.get("sensitivity_n_per_v"),
            gain_v_per_n=d.get("gain_v_per_n"),
            time=d.get("time"),
            delimiter=d.get("delimiter"),
        ))


#: The manifest ``force`` fields that are keywords of
#: :func:`fingerfriction.forces.read_force_file` (every field of :class:`ForceInfo` but ``path``).
FORCE_READER_KEYS = tuple(f.name for f in fields(ForceInfo) if f.name != "path")
