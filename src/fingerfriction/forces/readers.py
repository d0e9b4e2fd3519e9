"""Readers of force-sensor recordings: the two piezo channels ``F1``, ``F2`` of a trial.

One entry point, :func:`read_force_file`, dispatches on the file format named in the
study manifest (``force.format``, see ``docs/study-format.md``): ``npz``, ``csv``, ``mat``
(MATLAB v5 through :func:`scipy.io.loadmat`, v7.3 through h5py), ``tdms`` (National
Instruments, through npTDMS) and ``hdf5``. The simulator writes ``npz``.

Channel names come from the manifest's ``force.channels`` mapping, ``{"F1": name1,
"F2": name2}``: a column name or a 0-based column index (CSV), an array name (NPZ), a
variable name (MAT, with ``.`` or ``/`` to reach a struct field), a dataset path (HDF5)
or a channel name (TDMS: ``"group/channel"``, or just ``"channel"`` when it is unique in
the file). A name that is not in the file is an error listing the names that are.

What lab files need beyond a clean two-column file in newtons:

* **CSV layout.** The delimiter (``,``, ``;``, tab, ``|`` or runs of blanks) and the
  decimal mark (``.`` or ``,``) are detected, and so is a header row: a file whose first
  line is all numbers has none, and its channels are named by column index.
* **A time column** (``time=``, manifest ``force.time``): its sampling rate is checked
  against ``fs_hz`` (or gives it), its uniformity is checked (a missing or repeated
  sample is an error), and its first value places sample 0: sample ``n`` is at
  ``t0_s + time[n]`` on the trial's clock.
* **Volts.** ``units='V'`` (or ``'mV'``) with a per-channel sensitivity in N/V
  (``sensitivity_n_per_v``, as charge amplifiers are set) or a gain in V/N
  (``gain_v_per_n``); the record is in newtons either way.
* **Rates from the file.** ``fs_hz`` may be omitted when the file states its rate (TDMS
  ``wf_increment``, an HDF5 ``fs_hz`` attribute, a time column); when both are given
  they must agree. A TDMS waveform's ``wf_start_offset`` places sample 0 as a time
  column's first value does (it is 0 in files written by DAQmx without a pre-trigger).

:func:`probe_force_file` and :func:`list_channels` tell what a file holds (its channels,
sample count and rate) without a manifest: ``fingerfriction init`` uses them.

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

from .._check import check_fs, check_option
from ._base import MAX_SAMPLES, ForceFileError, as_channel, not_index, too_long
from .containers import hdf5_outside_data, read_hdf5, read_mat, read_tdms
from .delimited import CsvLayout, CsvLayoutError, csv_layout
from .units import FORCE_UNITS, channel_scale

__all__ = [
    "MAX_SAMPLES",
    "hdf5_outside_data",
    "FORCE_FORMATS",
    "FORCE_UNITS",
    "ForceFileError",
    "ForceFileInfo",
    "ForceRecord",
    "CsvLayout",
    "channel_scale",
    "csv_layout",
    "infer_force_format",
    "list_channels",
    "probe_force_file",
    "read_force_file",
]

logger = logging.getLogger(__name__)

#: Formats accepted in the manifest's ``force.format`` field.
FORCE_FORMATS = ("npz", "csv", "mat", "tdms", "hdf5")

_SUFFIXES = {
    ".npz": "npz",
    ".csv": "csv",
    ".txt": "csv",
    ".tsv": "csv",
    ".dat": "csv",
    ".mat": "mat",
    ".tdms": "tdms",
    ".h5": "hdf5",
    ".hdf5": "hdf5",
    ".hdf": "hdf5",
}

DEFAULT_CHANNELS = {"F1": "F1", "F2": "F2"}

#: A time column may differ from ``fs_hz`` by this relative amount (a CSV written with a
#: few decimals rounds its times); a rate the file states in its metadata must agree to 1e-6.
TIME_COLUMN_RTOL = 1e-3


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
        ``force.t0_s``, plus the first value of the file's time column if it has one):
        sample ``n`` is at ``t0_s + n / fs_hz``.
    path : str
        The file read (for messages and provenance).
    format : str
        One of :data:`FORCE_FORMATS`.
    channels : dict
        The mapping used, ``{"F1": name, "F2": name}``.
    scale : dict
        ``{"F1": s1, "F2": s2}``: newtons per unit of the file (1.0 for a file in N; the
        sensitivity in N/V for a file in volts).
    units : str
        The file's units (one of :data:`FORCE_UNITS`); the arrays are in N whatever it is.
    """

    f1: np.ndarray
    f2: np.ndarray
    fs_hz: float
    t0_s: float = 0.0
    path: str = ""
    format: str = ""
    channels: dict = field(default_factory=lambda: dict(DEFAULT_CHANNELS))
    scale: dict = field(default_factory=lambda: {"F1": 1.0, "F2": 1.0})
    units: str = "N"

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


@dataclass(frozen=True)
class ForceFileInfo:
    """What a force file says about itself (:func:`probe_force_file`).

    Attributes
    ----------
    path : str
    format : str
        One of :data:`FORCE_FORMATS`.
    names : tuple of str
        The channels (columns, arrays, variables, datasets) the file holds, as they can
        be given in ``force.channels``.
    n_samples : int or None
        Samples per channel of the channels asked for (None if none were).
    fs_hz : float or None
        Sampling rate in Hz that the file states (TDMS ``wf_increment``, an HDF5
        attribute, a time column), or None.
    time0_s : float
        Time in s of sample 0 in the file's own clock (the first value of a time column,
        a TDMS waveform's ``wf_start_offset``; 0 without one).
    header : bool or None
        CSV: whether the first line names the columns (None for other formats).
    delimiter : str or None
        CSV: the column delimiter detected (``r'\\s+'`` for runs of blanks).
    """

    path: str
    format: str
    names: tuple
    n_samples: int | None = None
    fs_hz: float | None = None
    time0_s: float = 0.0
    header: bool | None = None
    delimiter: str | None = None


def infer_force_format(path: str | os.PathLike) -> str:
    """The force format (one of :data:`FORCE_FORMATS`) of a file from its suffix.

    Raises
    ------
    ForceFileError
        For a suffix no reader knows, listing the known ones.
    """
    path = Path(path)
    fmt = _SUFFIXES.get(path.suffix.lower())
    if fmt is None:
        raise ForceFileError(
            f"cannot tell the format of force file {str(path)!r} from its suffix {path.suffix!r} "
            f"(known: {', '.join(sorted(_SUFFIXES))}); pass format= one of {FORCE_FORMATS}"
        )
    return fmt


def _check_name(key: str, v) -> str | int:
    if isinstance(v, bool) or not isinstance(v, (str, int)) or v == "" or (isinstance(v, int) and v < 0):
        raise ValueError(f"channels[{key!r}] must be a non-empty name or a column index >= 0, got {v!r}")
    return v


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
    return {k: _check_name(k, channels[k]) for k in ("F1", "F2")}


def _csv_column(layout: CsvLayout, key: str, name, path: Path) -> int:
    """0-based column index of a channel given by name or index."""
    n = layout.n_columns
    if layout.header is not None and isinstance(name, str) and name in layout.header:
        return layout.header.index(name)
    if isinstance(name, int) or (isinstance(name, str) and name.isdigit()):
        i = int(name)
        if i >= n:
            raise ForceFileError(
                f"column index {i} (channel {key}) is out of range: {str(path)!r} has {n} columns "
                f"(indices 0..{n - 1})"
            )
        return i
    if layout.header is None:
        raise ForceFileError(
            f"no column {name!r} (channel {key}) in {str(path)!r}: the file has no header row, so its "
            f"{n} columns are named by 0-based index (0..{n - 1}); first row: {list(layout.first_row)}"
        )
    raise ForceFileError(
        f"no column {name!r} (channel {key}) in {str(path)!r}; columns: {list(layout.header)}"
    )


def _read_csv(path: Path, wanted: dict, delimiter: str | None = None) -> tuple[dict, dict]:
    import pandas as pd  # only for CSV files

    try:
        layout = csv_layout(path, delimiter=delimiter)
    except CsvLayoutError as exc:
        raise ForceFileError(str(exc)) from None
    cols = {key: _csv_column(layout, key, name, path) for key, name in wanted.items()}
    info = {"header": layout.header is not None, "delimiter": layout.delimiter,
            "names": list(layout.header) if layout.header is not None else
            [str(i) for i in range(layout.n_columns)]}
    if not cols:
        return {}, info
    use = sorted(set(cols.values()))
    try:
        df = pd.read_csv(path, sep=layout.delimiter, decimal=layout.decimal, header=None,
                         skiprows=layout.skiprows, usecols=use, skip_blank_lines=True,
                         skipinitialspace=True, encoding="utf-8-sig",
                         engine="python" if layout.delimiter == r"\s+" else "c")
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise ForceFileError(f"cannot read {str(path)!r} as CSV: {' '.join(str(exc).split())}") from None
    out = {}
    for key, col in cols.items():
        label = layout.header[col] if layout.header is not None else col
        raw = df[col]
        values = pd.to_numeric(raw, errors="coerce")
        bad = values.isna() & raw.notna() & (raw.astype(str).str.strip().str.lower() != "nan")
        if bad.any():
            row = int(np.flatnonzero(bad.to_numpy())[0])
            raise ForceFileError(
                f"column {label!r} of {str(path)!r} has a non-numeric value {raw.iloc[row]!r} "
                f"at data row {row}; expected numbers (empty cells are read as NaN)"
            )
        out[key] = as_channel(values.to_numpy(dtype=np.float64), name=label, path=path)
    return out, info


# --------------------------------------------------------------------------------------
# format readers: each returns ({key: array}, info) for the wanted {key: name}; info may
# carry "fs_hz" when the file itself states a sampling rate (checked against the
# manifest) and "names", the channels available.
# --------------------------------------------------------------------------------------


def _read_npz(path: Path, wanted: dict, delimiter=None) -> tuple[dict, dict]:
    not_index(path, "npz", wanted)
    # Never allow_pickle=True: an .npz can carry pickled objects that run code on load.
    try:
        with np.load(path, allow_pickle=False) as z:
            names = list(z.files)
            out = {}
            for key, name in wanted.items():
                if name not in names:
                    raise ForceFileError(
                        f"no array {name!r} (channel {key}) in {str(path)!r}; arrays present: {names}"
                    )
                # the size once decompressed, before decompressing (a small archive may
                # inflate to any size)
                member = f"{name}.npy" if f"{name}.npy" in z.zip.namelist() else name
                size = z.zip.getinfo(member).file_size
                if size > 8 * MAX_SAMPLES + (1 << 20):
                    raise too_long(path, name, key, size // 8)
                try:
                    out[key] = as_channel(z[name], name=name, path=path)
                except ValueError as exc:
                    if isinstance(exc, ForceFileError):
                        raise
                    raise ForceFileError(
                        f"array {name!r} in {str(path)!r} cannot be read without unpickling "
                        f"({exc}); store plain numeric arrays"
                    ) from None
    except ForceFileError:
        raise
    except Exception as exc:  # noqa: BLE001 - a damaged archive raises many types (BadZipFile...)
        raise ForceFileError(f"cannot read {str(path)!r} as an .npz archive ({type(exc).__name__}: {exc})") \
            from None
    return out, {"names": names}


_READERS = {
    "npz": _read_npz,
    "csv": _read_csv,
    "mat": read_mat,
    "tdms": read_tdms,
    "hdf5": read_hdf5,
}


def _time_axis(t: np.ndarray, *, name, path: Path) -> tuple[float, float]:
    """(sampling rate in Hz, time of sample 0 in s) of a time column, or ForceFileError.

    The line ``t0 + n / fs`` is fitted by least squares over all samples; a sample further
    than a quarter period from it (a gap, a repeated or missing sample) is an error.
    """
    n = t.size
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise ForceFileError(f"time column {name!r} of {str(path)!r} has a missing value at row {bad[0]}")
    d = np.diff(t)
    back = np.flatnonzero(d <= 0)
    if back.size:
        i = int(back[0])
        raise ForceFileError(
            f"time column {name!r} of {str(path)!r} does not increase at row {i + 1} "
            f"({t[i]!r} then {t[i + 1]!r} s)"
        )
    k = np.arange(n, dtype=np.float64)
    km = k.mean()
    slope = float(np.dot(k - km, t - t.mean()) / np.dot(k - km, k - km))
    t_first = float(t.mean() - slope * km)
    resid = t - (t_first + slope * k)
    worst = int(np.argmax(np.abs(resid)))
    if abs(resid[worst]) > 0.25 * slope:
        raise ForceFileError(
            f"time column {name!r} of {str(path)!r} is not uniformly sampled: row {worst} "
            f"(t = {t[worst]:.6g} s) is {resid[worst] / slope:+.2f} sample periods off the line "
            f"t0 + n/fs at {1 / slope:.6g} Hz; missing or repeated samples? "
            "(the analysis needs a uniform clock)"
        )
    # the file's own first time when the line passes through it (to a millionth of a period:
    # floating-point noise of the fit, ~1e-17 s, would otherwise move sample 0 off the grid)
    if abs(t_first - t[0]) <= 1e-6 * slope:
        t_first = float(t[0])
    return 1.0 / slope, t_first


def _read(path: Path, fmt: str, wanted: dict, delimiter: str | None) -> tuple[dict, dict]:
    check_option("format", fmt, FORCE_FORMATS)
    if not path.exists():
        raise FileNotFoundError(f"force file {str(path)!r} does not exist")
    if not path.is_file():
        raise ForceFileError(f"force file {str(path)!r} is not a file")
    if delimiter is not None and fmt != "csv":
        raise ValueError(f"delimiter is for CSV files, but {str(path)!r} is read as {fmt}")
    return _READERS[fmt](path, wanted, delimiter)


def list_channels(path: str | os.PathLike, *, format: str | None = None,
                  delimiter: str | None = None) -> list[str]:
    """The channel names a force file holds, as they can be given in ``force.channels``.

    CSV: the header's column names, or ``'0'``, ``'1'``... for a headerless file; NPZ:
    array names; MAT: numeric variables (struct fields as ``a.b``); HDF5: dataset paths;
    TDMS: ``group/channel``.
    """
    p = Path(path)
    fmt = infer_force_format(p) if format is None else str(format).lower()
    _, info = _read(p, fmt, {}, delimiter)
    return list(info.get("names", []))


def probe_force_file(
    path: str | os.PathLike,
    *,
    channels: Mapping | None = None,
    format: str | None = None,
    time=None,
    delimiter: str | None = None,
) -> ForceFileInfo:
    """What a force file holds: its channels, and the sample count and rate of two of them.

    Parameters
    ----------
    path : path-like
    channels : mapping, optional
        ``{'F1': name, 'F2': name}`` to count samples of; default ``F1``/``F2`` when the
        file has them, else no count.
    format : str, optional
        One of :data:`FORCE_FORMATS`; from the suffix by default.
    time : str or int, optional
        A time column (name or CSV index) giving the rate and the start time.
    delimiter : str, optional
        CSV delimiter (detected by default).

    Returns
    -------
    ForceFileInfo

    Raises
    ------
    ForceFileError
        An unreadable file, a missing channel (listing those present), channels of
        different lengths, a bad time column.
    """
    p = Path(path)
    fmt = infer_force_format(p) if format is None else str(format).lower()
    if channels is None:
        _, listed = _read(p, fmt, {}, delimiter)
        names = list(listed.get("names", []))
        # the bare names a lookup answers to (TDMS: each channel's own name, whatever its group)
        short = set(listed.get("leaves") or {n.rsplit("/", 1)[-1] for n in names})
        chans = dict(DEFAULT_CHANNELS) if {"F1", "F2"} <= (set(names) | short) else {}
    else:
        chans = _check_channels_arg(channels)
    wanted = dict(chans)
    if time is not None:
        wanted["time"] = _check_name("time", time)
    data, info = _read(p, fmt, wanted, delimiter)
    n = None
    if chans:
        n = _check_lengths(data, chans, p)
    fs = info.get("fs_hz")
    t_first = float(info.get("time0_s", 0.0))
    if "time" in data:
        if data["time"].size != (n if n is not None else data["time"].size):
            raise ForceFileError(f"time column {wanted['time']!r} of {str(p)!r} has {data['time'].size} "
                                 f"samples, the channels {n}")
        fs, t_first = _time_axis(data["time"], name=wanted["time"], path=p)
    return ForceFileInfo(path=str(p), format=fmt, names=tuple(info.get("names", ())), n_samples=n,
                         fs_hz=fs, time0_s=t_first, header=info.get("header"),
                         delimiter=info.get("delimiter"))


def _check_lengths(data: dict, chans: dict, p: Path) -> int:
    f1, f2 = data["F1"], data["F2"]
    if f1.shape != f2.shape:
        raise ForceFileError(
            f"channels F1 ({chans['F1']!r}, {f1.size} samples) and F2 ({chans['F2']!r}, "
            f"{f2.size} samples) of {str(p)!r} differ in length"
        )
    if f1.size < 2:
        raise ForceFileError(f"force file {str(p)!r} holds {f1.size} sample(s); a trial needs many more")
    return int(f1.size)


def _clock(data: dict, info: dict, n: int, fs: float | None, time, n_samples, p: Path) -> tuple[float, float]:
    """The sampling rate in Hz of a file read by :func:`read_force_file` and the time in s of
    its first sample after the file's time zero (a time column's first value, TDMS
    ``wf_start_offset``): the file's own rate, if any, checked against ``fs`` when given, and
    the file's length ``n`` against ``n_samples``; ForceFileError when they disagree."""
    file_fs, rtol, what = info.get("fs_hz"), 1e-6, "states a sampling rate of"
    if "time" in data:
        if data["time"].size != n:
            raise ForceFileError(f"time column {time!r} of {str(p)!r} has {data['time'].size} samples, "
                                 f"the channels {n}")
        file_fs, t_first = _time_axis(data["time"], name=time, path=p)
        rtol, what = TIME_COLUMN_RTOL, f"time column {time!r} gives a sampling rate of"
    else:
        t_first = float(info.get("time0_s", 0.0))  # TDMS wf_start_offset
    if fs is None:
        if file_fs is None:
            raise ForceFileError(
                f"force file {str(p)!r} states no sampling rate; give fs_hz (manifest force.fs_hz) "
                "or a time column (force.time)"
            )
        fs = float(file_fs)
    elif file_fs is not None and abs(file_fs - fs) > rtol * fs:
        hint = ""
        if "time" in data and abs(file_fs * 1e3 / fs - 1) < 0.01:
            hint = " (is the time column in ms? it must be in s)"
        raise ForceFileError(
            f"force file {str(p)!r} {what} {file_fs:.6g} Hz but fs_hz={fs:g} Hz was given "
            f"(manifest force.fs_hz); they must agree{hint}"
        )
    if n_samples is not None and int(n_samples) != n:
        raise ForceFileError(
            f"force file {str(p)!r} holds {n} samples per channel but the manifest says "
            f"n_samples={int(n_samples)} ({int(n_samples) / fs:.4g} s at fs_hz={fs:g} Hz, the file "
            f"lasts {n / fs:.4g} s); check force.fs_hz, force.n_samples and the file"
        )
    return fs, t_first


def read_force_file(path: str | os.PathLike, *, fs_hz: float | None = None, channels: Mapping | None = None,
                    format: str | None = None, t0_s: float = 0.0, n_samples: int | None = None,
                    units: str = "N", sensitivity_n_per_v=None, gain_v_per_n=None, time=None,
                    delimiter: str | None = None) -> ForceRecord:
    """Read the two transducer channels of one trial, in newtons.

    Parameters
    ----------
    path : path-like
        The force file.
    fs_hz : float, optional
        Sampling frequency in Hz (the manifest's ``force.fs_hz``). When the file states
        its own rate (TDMS ``wf_increment``, an HDF5 ``fs_hz`` attribute: within 1e-6
        relative; a time column: within :data:`TIME_COLUMN_RTOL`) the two must agree;
        when omitted, the file's rate is used.
    channels : mapping, optional
        ``{"F1": name, "F2": name}``: the names of the two channels in the file (manifest
        ``force.channels``); for CSV also 0-based column indices. Default
        ``{"F1": "F1", "F2": "F2"}``.
    format : str, optional
        One of :data:`FORCE_FORMATS`; inferred from the suffix when omitted.
    t0_s : float, optional
        Time in s on the trial's common clock of the file's time zero (manifest
        ``force.t0_s``): sample ``n`` is at ``t0_s + n / fs_hz``, or at ``t0_s + time[n]``
        with a time column (``t0_s + wf_start_offset + n / fs_hz`` for a TDMS waveform).
    n_samples : int, optional
        Expected number of samples (manifest ``force.n_samples``); a different file
        length is an error, since it means ``fs_hz`` or the file does not match the trial.
    units : {'N', 'V', 'mV'}
        Units of the channels in the file (manifest ``force.units``).
    sensitivity_n_per_v, gain_v_per_n : float or {'F1': float, 'F2': float}, optional
        For channels in volts, exactly one: the sensitivity in N/V, or the gain in V/N
        (see :func:`channel_scale`).
    time : str or int, optional
        A time column in s (manifest ``force.time``): a column name or index (CSV), an
        array, variable, dataset or channel name (other formats).
    delimiter : str, optional
        CSV column delimiter (manifest ``force.delimiter``); detected by default.

    Returns
    -------
    ForceRecord
        Channels in N.

    Raises
    ------
    ForceFileError
        (a ``ValueError``) for a missing channel (the message lists those present), a
        non-numeric or non-vector channel, a length different from ``n_samples``, channels
        of different lengths, a sampling rate in the file that contradicts ``fs_hz`` (or
        none at all when ``fs_hz`` is omitted), a time column that is not uniform.
        ``ValueError`` for bad arguments (units, scales); ``FileNotFoundError`` if the
        file is missing.
    """
    p = Path(path)
    fs = None if fs_hz is None else check_fs(fs_hz, "fs_hz")
    chans = _check_channels_arg(channels)
    scale = channel_scale(units, sensitivity_n_per_v, gain_v_per_n)
    try:
        t0 = float(t0_s)
    except (TypeError, ValueError):
        raise ValueError(f"t0_s must be a time in s, got {t0_s!r}") from None
    fmt = infer_force_format(p) if format is None else str(format).lower()
    wanted = dict(chans)
    if time is not None:
        wanted["time"] = _check_name("time", time)
    data, info = _read(p, fmt, wanted, delimiter)
    n = _check_lengths(data, chans, p)
    fs, t_first = _clock(data, info, n, fs, time, n_samples, p)
    t0 += t_first
    f1, f2 = data["F1"] * scale["F1"], data["F2"] * scale["F2"]
    logger.debug("read %d samples x 2 channels from %s (%s, %s)", n, p, fmt, units)
    return ForceRecord(f1=f1, f2=f2, fs_hz=fs, t0_s=t0, path=str(p), format=fmt, channels=chans,
                       scale=scale, units=units)
