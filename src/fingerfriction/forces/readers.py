"""Readers of force-sensor recordings: the two piezo channels ``F1``, ``F2`` of a trial.

One entry point, :func:`read_force_file`, dispatches on the file format named in the
study manifest (``force.format``, see ``docs/study-format.md``): ``npz``, ``csv``, ``mat``
(MATLAB v5 through :func:`scipy.io.loadmat`, v7.3 through h5py), ``tdms`` (National
Instruments, through npTDMS) and ``hdf5``. The simulator writes ``npz``.

Channel names come from the manifest's ``force.channels`` mapping, ``{"F1": name1,
"F2": name2}``: a column name (CSV), an array name (NPZ), a variable name (MAT, with
``.`` or ``/`` to reach a struct field), a dataset path (HDF5) or a channel name
(TDMS: ``"group/channel"``, or just ``"channel"`` when it is unique in the file).

Files are never unpickled: NPZ is opened with ``allow_pickle=False`` and MATLAB object
/ cell arrays are refused.
"""

from __future__ import annotations

import logging
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._check import check_fs

__all__ = [
    "FORCE_FORMATS",
    "ForceFileError",
    "ForceRecord",
    "read_force_file",
]

logger = logging.getLogger(__name__)

#: Formats accepted in the manifest's ``force.format`` field.
FORCE_FORMATS = ("npz", "csv", "mat", "tdms", "hdf5")

_SUFFIXES = {
    ".npz": "npz",
    ".csv": "csv",
    ".txt": "csv",
    ".mat": "mat",
    ".tdms": "tdms",
    ".h5": "hdf5",
    ".hdf5": "hdf5",
    ".hdf": "hdf5",
}

DEFAULT_CHANNELS = {"F1": "F1", "F2": "F2"}


class ForceFileError(ValueError):
    """A force file that cannot be read as the manifest describes it."""


@dataclass(frozen=True)
class ForceRecord:
    """The two transducer channels of one trial, in newtons, on a uniform clock.

    Parameters
    ----------
    f1, f2 : (n_samples,) ndarray of float64
        Forces in N along the two transducer axes (the paper's +45 and -45 degree piezos,
        Fig. 1C). May contain NaN where the file had missing values.
    fs_hz : float
        Sampling frequency in Hz.
    t0_s : float
        Time in s, on the trial's common clock, of sample 0 (the manifest's
        ``force.t0_s``): sample ``n`` is at ``t0_s + n / fs_hz``.
    path : str
        The file read (for messages and provenance).
    format : str
        One of :data:`FORCE_FORMATS`.
    channels : dict
        The mapping used, ``{"F1": name, "F2": name}``.
    """

    f1: np.ndarray
    f2: np.ndarray
    fs_hz: float
    t0_s: float = 0.0
    path: str = ""
    format: str = ""
    channels: dict = field(default_factory=lambda: dict(DEFAULT_CHANNELS))

    def __post_init__(self) -> None:
        fs = check_fs(self.fs_hz, "fs_hz")
        t0 = float(self.t0_s)
        if not math.isfinite(t0):
            raise ValueError(f"t0_s must be a finite time in s, got {self.t0_s!r}")
        f1 = np.asarray(self.f1, dtype=np.float64)
        f2 = np.asarray(self.f2, dtype=np.float64)
        if f1.ndim != 1 or f2.ndim != 1 or f1.shape != f2.shape:
            raise ValueError(
                f"f1 and f2 must be 1-D arrays of the same length, got shapes {f1.shape} and {f2.shape}"
            )
        object.__setattr__(self, "fs_hz", fs)
        object.__setattr__(self, "t0_s", t0)
        object.__setattr__(self, "f1", f1)
        object.__setattr__(self, "f2", f2)

    @property
    def n_samples(self) -> int:
        """Number of samples per channel."""
        return int(self.f1.shape[0])

    @property
    def duration_s(self) -> float:
        """``n_samples / fs_hz`` in s."""
        return self.n_samples / self.fs_hz

    def times(self) -> np.ndarray:
        """``(n_samples,)`` sample times in s on the common clock, ``t0_s + n / fs_hz``."""
        return self.t0_s + np.arange(self.n_samples) / self.fs_hz


def _infer_format(path: Path) -> str:
    fmt = _SUFFIXES.get(path.suffix.lower())
    if fmt is None:
        raise ForceFileError(
            f"cannot tell the format of force file {str(path)!r} from its suffix {path.suffix!r}; "
            f"pass format= one of {FORCE_FORMATS}"
        )
    return fmt


def _as_channel(values, *, name: str, path: Path) -> np.ndarray:
    arr = np.asarray(values)
    if arr.dtype == object or not (np.issubdtype(arr.dtype, np.number) or arr.dtype == bool):
        raise ForceFileError(f"channel {name!r} in {str(path)!r} has dtype {arr.dtype}, expected numbers (N)")
    if np.iscomplexobj(arr):
        raise ForceFileError(f"channel {name!r} in {str(path)!r} is complex, expected real forces (N)")
    squeezed = np.squeeze(arr)
    if squeezed.ndim != 1:
        raise ForceFileError(
            f"channel {name!r} in {str(path)!r} has shape {arr.shape}, expected one vector of samples"
        )
    return squeezed.astype(np.float64)


def _check_channels_arg(channels) -> dict:
    if channels is None:
        return dict(DEFAULT_CHANNELS)
    if not isinstance(channels, Mapping):
        raise TypeError(f"channels must be a mapping {{'F1': name, 'F2': name}}, got {channels!r}")
    missing = {"F1", "F2"} - set(channels)
    if missing:
        raise ValueError(
            f"channels must map both 'F1' and 'F2' to names in the file, got {dict(channels)!r}"
            f" (missing {sorted(missing)})"
        )
    out = {k: channels[k] for k in ("F1", "F2")}
    for k, v in out.items():
        if not isinstance(v, str) or not v:
            raise ValueError(f"channels[{k!r}] must be a non-empty name, got {v!r}")
    return out


# --------------------------------------------------------------------------------------
# format readers: each returns ({"F1": array, "F2": array}, info) where info may carry
# "fs_hz" when the file itself states a sampling rate (checked against the manifest).
# --------------------------------------------------------------------------------------


def _read_npz(path: Path, channels: dict) -> tuple[dict, dict]:
    # Never allow_pickle=True: an .npz can carry pickled objects that run code on load.
    try:
        with np.load(path, allow_pickle=False) as z:
            names = list(z.files)
            out = {}
            for key, name in channels.items():
                if name not in names:
                    raise ForceFileError(
                        f"no array {name!r} (channel {key}) in {str(path)!r}; arrays present: {names}"
                    )
                try:
                    out[key] = _as_channel(z[name], name=name, path=path)
                except ValueError as exc:
                    if isinstance(exc, ForceFileError):
                        raise
                    raise ForceFileError(
                        f"array {name!r} in {str(path)!r} cannot be read without unpickling "
                        f"({exc}); store plain numeric arrays"
                    ) from None
    except (OSError, EOFError) as exc:
        raise ForceFileError(f"cannot read {str(path)!r} as an .npz archive: {exc}") from None
    except ValueError as exc:
        if isinstance(exc, ForceFileError):
            raise
        raise ForceFileError(f"cannot read {str(path)!r} as an .npz archive: {exc}") from None
    return out, {}


def _read_csv(path: Path, channels: dict) -> tuple[dict, dict]:
    import pandas as pd  # only for CSV files

    try:
        header = pd.read_csv(path, nrows=0)
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise ForceFileError(f"cannot read {str(path)!r} as CSV: {exc}") from None
    columns = [str(c) for c in header.columns]
    for key, name in channels.items():
        if name not in columns:
            raise ForceFileError(f"no column {name!r} (channel {key}) in {str(path)!r}; columns: {columns}")
    try:
        df = pd.read_csv(path, usecols=list(set(channels.values())))
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise ForceFileError(f"cannot read {str(path)!r} as CSV: {exc}") from None
    out = {}
    for key, name in channels.items():
        col = pd.to_numeric(df[name], errors="coerce")
        bad = col.isna() & df[name].notna()
        if bad.any():
            row = int(np.flatnonzero(bad.to_numpy())[0])
            raise ForceFileError(
                f"column {name!r} of {str(path)!r} has a non-numeric value {df[name].iloc[row]!r} "
                f"at data row {row}; expected forces in N (empty cells are read as NaN)"
            )
        out[key] = _as_channel(col.to_numpy(dtype=np.float64), name=name, path=path)
    return out, {}


def _split_name(name: str) -> list[str]:
    return [p for p in name.replace(".", "/").split("/") if p]


def _read_mat(path: Path, channels: dict) -> tuple[dict, dict]:
    import h5py  # only for HDF5 and MATLAB v7.3 files

    if h5py.is_hdf5(path):  # MATLAB v7.3 files are HDF5 with a 512-byte user block
        return _read_mat73(path, channels)
    import scipy.io  # only for MATLAB v5 files

    try:
        # simplify_cells turns structs into dicts; MATLAB objects (classdef) are not
        # unpickled by scipy, they come back as opaque MatlabOpaque arrays we refuse.
        data = scipy.io.loadmat(path, simplify_cells=True)
    except NotImplementedError as exc:  # e.g. an HDF5 file that h5py did not recognise
        raise ForceFileError(f"cannot read {str(path)!r} as a MATLAB file: {exc}") from None
    except (OSError, ValueError, TypeError) as exc:
        raise ForceFileError(f"cannot read {str(path)!r} as a MATLAB v5 file: {exc}") from None
    variables = sorted(k for k in data if not k.startswith("__"))
    out = {}
    for key, name in channels.items():
        node = data
        for part in _split_name(name):
            if not isinstance(node, dict) or part not in node:
                raise ForceFileError(
                    f"no variable {name!r} (channel {key}) in {str(path)!r}; variables: {variables}"
                )
            node = node[part]
        out[key] = _as_channel(node, name=name, path=path)
    return out, {}


def _read_mat73(path: Path, channels: dict) -> tuple[dict, dict]:
    import h5py  # only for HDF5 and MATLAB v7.3 files

    out = {}
    with h5py.File(path, "r") as f:
        for key, name in channels.items():
            obj = f.get("/".join(_split_name(name)))
            if not isinstance(obj, h5py.Dataset):
                raise ForceFileError(
                    f"no variable {name!r} (channel {key}) in MATLAB v7.3 file {str(path)!r}; "
                    f"top-level variables: {sorted(f.keys())}"
                )
            cls = obj.attrs.get("MATLAB_class", b"double")
            cls = cls.decode() if isinstance(cls, bytes) else str(cls)
            if cls in ("cell", "struct", "char", "function_handle") or obj.dtype.kind not in "fiub":
                raise ForceFileError(
                    f"variable {name!r} in {str(path)!r} is a MATLAB {cls} (dtype {obj.dtype}); "
                    "expected a numeric vector in N"
                )
            # MATLAB stores column-major, so an n x 1 column vector appears as (1, n) here;
            # squeezing makes row and column vectors alike.
            out[key] = _as_channel(obj[()], name=name, path=path)
    return out, {}


def _dataset_names(f) -> list[str]:
    import h5py  # only for HDF5 and MATLAB v7.3 files

    found: list[str] = []
    f.visititems(lambda n, o: found.append(n) if isinstance(o, h5py.Dataset) else None)
    return found


def _read_hdf5(path: Path, channels: dict) -> tuple[dict, dict]:
    import h5py  # only for HDF5 and MATLAB v7.3 files

    info: dict = {}
    try:
        f = h5py.File(path, "r")
    except OSError as exc:
        raise ForceFileError(f"cannot read {str(path)!r} as HDF5: {exc}") from None
    with f:
        out = {}
        for key, name in channels.items():
            obj = f.get(name)
            if not isinstance(obj, h5py.Dataset):
                found = _dataset_names(f)
                raise ForceFileError(
                    f"no dataset {name!r} (channel {key}) in {str(path)!r}; datasets: {found[:20]}"
                )
            out[key] = _as_channel(obj[()], name=name, path=path)
            for attr in ("fs_hz", "sampling_rate_hz"):
                if attr in obj.attrs:
                    info.setdefault("fs_hz", float(np.asarray(obj.attrs[attr])))
    return out, info


def _read_tdms(path: Path, channels: dict) -> tuple[dict, dict]:
    from nptdms import TdmsFile  # only for TDMS files

    try:
        tdms = TdmsFile.read(path)
    except (OSError, ValueError, KeyError) as exc:
        raise ForceFileError(f"cannot read {str(path)!r} as a TDMS file: {exc}") from None
    all_channels = {f"{g.name}/{c.name}": c for g in tdms.groups() for c in g.channels()}
    info: dict = {}
    out = {}
    for key, name in channels.items():
        if name in all_channels:
            ch = all_channels[name]
        else:
            hits = [c for full, c in all_channels.items() if full.split("/", 1)[1] == name]
            if len(hits) != 1:
                how = "no" if not hits else f"{len(hits)}"
                raise ForceFileError(
                    f"{how} channel named {name!r} (channel {key}) in {str(path)!r}; "
                    f"use 'group/channel', one of {sorted(all_channels)}"
                )
            ch = hits[0]
        out[key] = _as_channel(ch[:], name=name, path=path)
        inc = ch.properties.get("wf_increment")
        if inc is not None and float(inc) > 0:
            info.setdefault("fs_hz", 1.0 / float(inc))
    return out, info


_READERS = {
    "npz": _read_npz,
    "csv": _read_csv,
    "mat": _read_mat,
    "tdms": _read_tdms,
    "hdf5": _read_hdf5,
}


def read_force_file(
    path: str | os.PathLike,
    *,
    fs_hz: float,
    channels: Mapping[str, str] | None = None,
    format: str | None = None,
    t0_s: float = 0.0,
    n_samples: int | None = None,
) -> ForceRecord:
    """Read the two transducer channels of one trial.

    Parameters
    ----------
    path : path-like
        The force file.
    fs_hz : float
        Sampling frequency in Hz (the manifest's ``force.fs_hz``). When the file states its
        own rate (TDMS ``wf_increment``, an HDF5 ``fs_hz`` attribute) the two must agree
        within 1e-6 relative.
    channels : mapping, optional
        ``{"F1": name, "F2": name}``: the names of the two channels in the file (manifest
        ``force.channels``). Default ``{"F1": "F1", "F2": "F2"}``.
    format : str, optional
        One of :data:`FORCE_FORMATS`; inferred from the suffix when omitted.
    t0_s : float, optional
        Time in s of sample 0 on the trial's common clock (manifest ``force.t0_s``).
    n_samples : int, optional
        Expected number of samples (manifest ``force.n_samples``); a different file
        length is an error, since it means ``fs_hz`` or the file does not match the trial.

    Returns
    -------
    ForceRecord

    Raises
    ------
    ForceFileError
        (a ``ValueError``) for a missing channel, a non-numeric or non-vector channel, a
        length different from ``n_samples``, channels of different lengths, or a sampling
        rate in the file that contradicts ``fs_hz``. ``OSError`` if the file is missing.
    """
    p = Path(path)
    fs = check_fs(fs_hz, "fs_hz")
    chans = _check_channels_arg(channels)
    fmt = _infer_format(p) if format is None else str(format).lower()
    if fmt not in _READERS:
        raise ValueError(f"format must be one of {FORCE_FORMATS}, got {format!r}")
    if not p.is_file():
        raise FileNotFoundError(f"force file {str(p)!r} does not exist")
    data, info = _READERS[fmt](p, chans)
    f1, f2 = data["F1"], data["F2"]
    if f1.shape != f2.shape:
        raise ForceFileError(
            f"channels F1 ({chans['F1']!r}, {f1.size} samples) and F2 ({chans['F2']!r}, "
            f"{f2.size} samples) of {str(p)!r} differ in length"
        )
    if f1.size < 2:
        raise ForceFileError(f"force file {str(p)!r} holds {f1.size} sample(s); a trial needs many more")
    if n_samples is not None and int(n_samples) != f1.size:
        raise ForceFileError(
            f"force file {str(p)!r} holds {f1.size} samples per channel but the manifest says "
            f"n_samples={int(n_samples)} ({int(n_samples) / fs:.4g} s at fs_hz={fs:g} Hz, the file "
            f"lasts {f1.size / fs:.4g} s); check force.fs_hz, force.n_samples and the file"
        )
    file_fs = info.get("fs_hz")
    if file_fs is not None and abs(file_fs - fs) > 1e-6 * fs:
        raise ForceFileError(
            f"force file {str(p)!r} states a sampling rate of {file_fs:g} Hz but fs_hz={fs:g} Hz "
            "was given (manifest force.fs_hz); they must agree"
        )
    logger.debug("read %d samples x 2 channels from %s (%s)", f1.size, p, fmt)
    return ForceRecord(f1=f1, f2=f2, fs_hz=fs, t0_s=t0_s, path=str(p), format=fmt, channels=chans)
