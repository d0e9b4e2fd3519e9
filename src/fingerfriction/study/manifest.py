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

import json
import math
import os
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._atomic import atomic_write_bytes
from ..forces.readers import FORCE_FORMATS
from ..surfaces import Surface, surface_from_spec

__all__ = [
    "FORMAT_NAME",
    "SCHEMA_VERSION",
    "VIDEO_FORMATS",
    "FORCE_FORMATS",
    "ManifestError",
    "VideoInfo",
    "ForceInfo",
    "TrialRecord",
    "Study",
    "validate_id",
    "resolve_path",
    "load_manifest",
    "write_manifest",
    "manifest_bytes",
]

FORMAT_NAME = "fingerfriction-study"
SCHEMA_VERSION = 1
VIDEO_FORMATS = ("ffv1-mkv", "tiff", "avi", "mp4", "mkv", "cine")
MANIFEST_NAME = "manifest.json"

_ID_RE = re.compile(r"^[A-Za-z0-9_.\-]+$")


class ManifestError(ValueError):
    """A malformed manifest or an invalid study record; the message names file and field."""


def _fail(where: str, msg: str) -> ManifestError:
    return ManifestError(f"{where}: {msg}")


def validate_id(trial_id: Any, *, where: str = "id") -> str:
    """Check a trial id: a non-empty string of letters, digits, ``-``, ``_`` and ``.``.

    The id names a folder (``trials/<id>/``), so ``.`` and ``..`` alone are refused.

    Raises
    ------
    ManifestError
        Naming ``where``, the value and what is allowed.
    """
    if not isinstance(trial_id, str) or not _ID_RE.match(trial_id) or trial_id in (".", ".."):
        raise _fail(
            where, f"trial id must be letters, digits, '-', '_' or '.' (not '.' or '..'), got {trial_id!r}"
        )
    return trial_id


def _check_relpath(path: Any, where: str) -> str:
    """A manifest path: relative, POSIX separators, no component ``..``."""
    if not isinstance(path, str) or not path:
        raise _fail(where, f"must be a non-empty relative path string, got {path!r}")
    if "\\" in path:
        raise _fail(where, f"must use '/' separators, got {path!r}")
    p = Path(path)
    if p.is_absolute() or path.startswith("/"):
        raise _fail(where, f"must be relative to the study folder, got absolute path {path!r}")
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
    _check_relpath(relpath, where)
    base = Path(root).resolve()
    full = (base / relpath).resolve()
    if full != base and base not in full.parents:
        raise _fail(where, f"path {relpath!r} resolves to {full}, outside the study folder {base}")
    return full


def _num(d: dict, key: str, where: str, *, positive: bool = False, integer: bool = False,
         nonneg: bool = False, default: Any = ...) -> Any:
    if key not in d:
        if default is not ...:
            return default
        raise _fail(f"{where}.{key}", "missing required field")
    v = d[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise _fail(f"{where}.{key}", f"must be a number, got {v!r}")
    if integer and (not float(v).is_integer()):
        raise _fail(f"{where}.{key}", f"must be an integer, got {v!r}")
    if not math.isfinite(v):
        raise _fail(f"{where}.{key}", f"must be finite, got {v!r}")
    if positive and v <= 0:
        raise _fail(f"{where}.{key}", f"must be positive, got {v!r}")
    if nonneg and v < 0:
        raise _fail(f"{where}.{key}", f"must be >= 0, got {v!r}")
    return int(v) if integer else float(v)


def _str(d: dict, key: str, where: str, *, allowed: tuple[str, ...] | None = None,
         default: Any = ...) -> Any:
    if key not in d:
        if default is not ...:
            return default
        raise _fail(f"{where}.{key}", "missing required field")
    v = d[key]
    if not isinstance(v, str):
        raise _fail(f"{where}.{key}", f"must be a string, got {v!r}")
    if allowed is not None and v not in allowed:
        raise _fail(f"{where}.{key}", f"must be one of {', '.join(allowed)}, got {v!r}")
    return v


def _obj(d: Any, where: str) -> dict:
    if not isinstance(d, dict):
        raise _fail(where, f"must be a JSON object, got {type(d).__name__}")
    return d


@dataclass(frozen=True)
class VideoInfo:
    """The video of one trial.

    Parameters
    ----------
    path : str
        Relative to the study folder.
    format : str
        One of :data:`VIDEO_FORMATS`.
    fps : float
        Frame rate in Hz (> 0).
    width, height : int
        Frame size in pixels (> 0).
    n_frames : int
        Number of frames (> 0).
    t0_s : float
        Time in s of frame 0 on the trial's common clock; frame k is at ``t0_s + k / fps``.
    calibration_frame : int
        Index of the finger-free frame used for calibration (Fig. 7A), ``0 <= . < n_frames``.
    """

    path: str
    format: str
    fps: float
    width: int
    height: int
    n_frames: int
    t0_s: float = 0.0
    calibration_frame: int = 0

    def __post_init__(self) -> None:
        _check_relpath(self.path, "video.path")
        d = {k: getattr(self, k) for k in ("fps", "width", "height", "n_frames", "t0_s", "calibration_frame")}
        object.__setattr__(self, "fps", _num(d, "fps", "video", positive=True))
        for k in ("width", "height", "n_frames"):
            object.__setattr__(self, k, _num(d, k, "video", positive=True, integer=True))
        object.__setattr__(self, "t0_s", _num(d, "t0_s", "video"))
        cf = _num(d, "calibration_frame", "video", integer=True, nonneg=True)
        if cf >= self.n_frames:
            raise _fail("video.calibration_frame", f"must be < n_frames ({self.n_frames}), got {cf}")
        object.__setattr__(self, "calibration_frame", cf)
        if self.format not in VIDEO_FORMATS:
            raise _fail("video.format", f"must be one of {', '.join(VIDEO_FORMATS)}, got {self.format!r}")

    def frame_times(self):
        """Times in s of every frame on the common clock, ``(n_frames,)`` ndarray."""
        return self.t0_s + np.arange(self.n_frames) / self.fps

    def to_dict(self) -> dict:
        return {
            "path": self.path, "format": self.format, "fps": self.fps, "width": self.width,
            "height": self.height, "n_frames": self.n_frames, "t0_s": self.t0_s,
            "calibration_frame": self.calibration_frame,
        }

    @classmethod
    def from_dict(cls, d: Any, where: str = "video") -> VideoInfo:
        d = _obj(d, where)
        return cls(
            path=_check_relpath(d.get("path"), f"{where}.path"),
            format=_str(d, "format", where, allowed=VIDEO_FORMATS),
            fps=_num(d, "fps", where, positive=True),
            width=_num(d, "width", where, positive=True, integer=True),
            height=_num(d, "height", where, positive=True, integer=True),
            n_frames=_num(d, "n_frames", where, positive=True, integer=True),
            t0_s=_num(d, "t0_s", where, default=0.0),
            calibration_frame=_num(d, "calibration_frame", where, integer=True, nonneg=True, default=0),
        )


def _units(d: dict, where: str) -> str:
    units = d.get("units", "N")
    if units != "N":
        raise ManifestError(f"{where}.units is {units!r}; only 'N' (newtons) is supported: scale the "
                            "channels to newtons")
    return units


@dataclass(frozen=True)
class ForceInfo:
    """The force recording of one trial: the two transducer channels F1, F2.

    Parameters
    ----------
    path : str
        Relative to the study folder.
    format : str
        One of :data:`FORCE_FORMATS`.
    fs_hz : float
        Sampling frequency in Hz (> 0).
    n_samples : int
        Number of samples per channel (> 0).
    channels : dict
        Maps ``'F1'`` and ``'F2'`` (the paper's +-45 degree piezos, Fig. 1C) to the names of
        the arrays/columns in the file.
    units : str
        ``'N'``.
    t0_s : float
        Time in s of sample 0 on the trial's common clock.
    """

    path: str
    format: str
    fs_hz: float
    n_samples: int
    channels: dict = field(default_factory=lambda: {"F1": "F1", "F2": "F2"})
    units: str = "N"
    t0_s: float = 0.0

    def __post_init__(self) -> None:
        _check_relpath(self.path, "force.path")
        if self.format not in FORCE_FORMATS:
            raise _fail("force.format", f"must be one of {', '.join(FORCE_FORMATS)}, got {self.format!r}")
        d = {"fs_hz": self.fs_hz, "n_samples": self.n_samples, "t0_s": self.t0_s}
        object.__setattr__(self, "fs_hz", _num(d, "fs_hz", "force", positive=True))
        object.__setattr__(self, "n_samples", _num(d, "n_samples", "force", positive=True, integer=True))
        object.__setattr__(self, "t0_s", _num(d, "t0_s", "force"))
        ch = self.channels
        if not isinstance(ch, dict) or set(ch) != {"F1", "F2"} or not all(
            isinstance(v, str) and v for v in ch.values()
        ):
            raise _fail("force.channels", f"must map exactly 'F1' and 'F2' to column names, got {ch!r}")
        object.__setattr__(self, "channels", {"F1": ch["F1"], "F2": ch["F2"]})
        if self.units != "N":
            raise _fail("force.units", f"must be 'N' (channels scaled to newtons), got {self.units!r}")

    def sample_times(self):
        """Times in s of every sample on the common clock, ``(n_samples,)`` ndarray."""
        return self.t0_s + np.arange(self.n_samples) / self.fs_hz

    def to_dict(self) -> dict:
        return {
            "path": self.path, "format": self.format, "fs_hz": self.fs_hz,
            "n_samples": self.n_samples, "channels": dict(self.channels), "units": self.units,
            "t0_s": self.t0_s,
        }

    @classmethod
    def from_dict(cls, d: Any, where: str = "force") -> ForceInfo:
        d = _obj(d, where)
        ch = d.get("channels", {"F1": "F1", "F2": "F2"})
        if not isinstance(ch, dict) or set(ch) != {"F1", "F2"} or not all(
            isinstance(v, str) and v for v in ch.values()
        ):
            raise _fail(f"{where}.channels", f"must map exactly 'F1' and 'F2' to column names, got {ch!r}")
        return cls(
            path=_check_relpath(d.get("path"), f"{where}.path"),
            format=_str(d, "format", where, allowed=FORCE_FORMATS),
            fs_hz=_num(d, "fs_hz", where, positive=True),
            n_samples=_num(d, "n_samples", where, positive=True, integer=True),
            channels=ch,
            units=_units(d, where),
            t0_s=_num(d, "t0_s", where, default=0.0),
        )


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
        Key into :attr:`Study.surfaces`.
    speed_mm_s : float
        Nominal sliding speed in mm/s (the condition, > 0).
    repetition : int
        Repetition number (>= 1).
    video : VideoInfo
    force : ForceInfo
    calibration : dict or None
        ``{'surface_height_mm': H}``: the known feature height H in mm (> 0) used to
        calibrate the image scale; None (the field absent from the manifest): the
        surface's own feature height (:meth:`Study.surface_height_mm`).
    truth : str or None
        Relative path of the ground-truth file (simulated studies only).
    """

    id: str
    subject: str
    surface: str
    speed_mm_s: float
    repetition: int
    video: VideoInfo
    force: ForceInfo
    calibration: dict | None = None
    truth: str | None = None

    def __post_init__(self) -> None:
        validate_id(self.id)
        if not isinstance(self.subject, str) or not self.subject:
            raise _fail("subject", f"must be a non-empty string, got {self.subject!r}")
        if not isinstance(self.surface, str) or not self.surface:
            raise _fail("surface", f"must be a non-empty string, got {self.surface!r}")
        d = {"speed_mm_s": self.speed_mm_s, "repetition": self.repetition}
        object.__setattr__(self, "speed_mm_s", _num(d, "speed_mm_s", "trial", positive=True))
        object.__setattr__(self, "repetition", _num(d, "repetition", "trial", positive=True, integer=True))
        if not isinstance(self.video, VideoInfo):
            raise _fail("video", f"must be a VideoInfo, got {type(self.video).__name__}")
        if not isinstance(self.force, ForceInfo):
            raise _fail("force", f"must be a ForceInfo, got {type(self.force).__name__}")
        if self.calibration is not None:
            cal = _obj(self.calibration, "calibration")
            H = _num(cal, "surface_height_mm", "calibration", positive=True)
            object.__setattr__(self, "calibration", {**cal, "surface_height_mm": H})
        if self.truth is not None:
            _check_relpath(self.truth, "truth")

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
    def from_dict(cls, d: Any, where: str = "trial") -> TrialRecord:
        d = _obj(d, where)
        tid = d.get("id")
        validate_id(tid, where=f"{where}.id")
        subject = d.get("subject")
        if isinstance(subject, int) and not isinstance(subject, bool):
            subject = str(subject)  # a lab may write subject numbers; labels are strings
        if not isinstance(subject, str) or not subject:
            raise _fail(f"{where}.subject", f"must be a non-empty string, got {subject!r}")
        truth = d.get("truth")
        if truth is not None:
            _check_relpath(truth, f"{where}.truth")
        cal = d.get("calibration")
        if cal is not None:
            cal = _obj(cal, f"{where}.calibration")
            _num(cal, "surface_height_mm", f"{where}.calibration", positive=True)
        try:
            return cls(
                id=tid,
                subject=subject,
                surface=_str(d, "surface", where),
                speed_mm_s=_num(d, "speed_mm_s", where, positive=True),
                repetition=_num(d, "repetition", where, positive=True, integer=True),
                video=VideoInfo.from_dict(d.get("video"), f"{where}.video"),
                force=ForceInfo.from_dict(d.get("force"), f"{where}.force"),
                calibration=cal,
                truth=truth,
            )
        except ManifestError as exc:
            msg = str(exc)
            if msg.startswith(f"{where}"):
                raise
            raise ManifestError(f"{where}.{msg}") from None


@dataclass(frozen=True)
class Study:
    """A study manifest (schema version 1).

    Parameters
    ----------
    trials : tuple of TrialRecord
        Unique ids; each trial's surface is a key of ``surfaces``.
    surfaces : dict
        Surface name -> spec dict as written by ``Surface.to_dict()``.
    description : str
        Free text.
    created_by : str
        Software that wrote the manifest.
    root : Path or None
        The study folder (set by :func:`load_manifest`; not written to the file).
    """

    trials: tuple
    surfaces: dict
    description: str = ""
    created_by: str = ""
    root: Path | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "trials", tuple(self.trials))
        if not isinstance(self.surfaces, dict):
            raise _fail("surfaces", f"must be a mapping of name -> spec, got {type(self.surfaces).__name__}")
        seen: set[str] = set()
        for i, t in enumerate(self.trials):
            if not isinstance(t, TrialRecord):
                raise _fail(f"trials[{i}]", f"must be a TrialRecord, got {type(t).__name__}")
            if t.id in seen:
                raise _fail(f"trials[{i}].id", f"duplicate trial id {t.id!r}")
            seen.add(t.id)
            if t.surface not in self.surfaces:
                raise _fail(
                    f"trials[{i}].surface",
                    f"{t.surface!r} is not in 'surfaces' (known: {', '.join(self.surfaces) or 'none'})",
                )

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
    def from_dict(cls, d: Any, *, root: Path | None = None) -> Study:
        d = _obj(d, "manifest")
        fmt = d.get("format")
        if fmt != FORMAT_NAME:
            raise _fail("format", f"must be {FORMAT_NAME!r}, got {fmt!r}")
        ver = d.get("schema_version")
        if ver != SCHEMA_VERSION:
            raise _fail("schema_version", f"this version of fingerfriction reads schema 1, got {ver!r}")
        surfaces = _obj(d.get("surfaces"), "surfaces")
        for name, spec in surfaces.items():
            try:
                surface_from_spec(_obj(spec, f"surfaces.{name}"))
            except (ValueError, TypeError, KeyError) as exc:
                raise _fail(f"surfaces.{name}", f"invalid surface spec ({exc})") from None
        trials = d.get("trials")
        if not isinstance(trials, list):
            raise _fail("trials", f"must be a list, got {type(trials).__name__}")
        recs = tuple(TrialRecord.from_dict(t, f"trials[{i}]") for i, t in enumerate(trials))
        return cls(
            trials=recs,
            surfaces=surfaces,
            description=_str(d, "description", "manifest", default=""),
            created_by=_str(d, "created_by", "manifest", default=""),
            root=root,
        )


def load_manifest(path: str | os.PathLike) -> Study:
    """Read and validate a study manifest.

    Parameters
    ----------
    path : path-like
        The ``manifest.json`` file, or the study folder holding it.

    Returns
    -------
    Study
        With ``root`` set to the folder of the manifest.

    Raises
    ------
    ManifestError
        One line naming the file and the offending field, e.g.
        ``study/manifest.json: trials[2].video.fps: must be positive, got 0``.
    """
    p = Path(path)
    if p.is_dir():
        p = p / MANIFEST_NAME
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ManifestError(f"{p}: no such manifest file") from None
    except OSError as exc:
        raise ManifestError(f"{p}: cannot read manifest ({exc.strerror})") from None
    except UnicodeDecodeError:
        raise ManifestError(f"{p}: manifest is not UTF-8 text") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ManifestError(
            f"{p}: not valid JSON (line {exc.lineno}, column {exc.colno}: {exc.msg})"
        ) from None
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
    return study


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
