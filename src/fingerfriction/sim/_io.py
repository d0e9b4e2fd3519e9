"""Deterministic ``.npz`` writer used by the simulator.

``numpy.savez`` stamps every zip member with the current time, so two runs of the same
simulation would differ by a few bytes; :func:`write_npz` writes the same ``.npz`` layout
(readable by ``numpy.load``) with a fixed member date, atomically
(:mod:`fingerfriction._atomic`). The simulator's video writer is
:class:`fingerfriction.video.writers.VideoWriter`.
"""

from __future__ import annotations

import io
import os
import zipfile
from pathlib import Path

import numpy as np

from .._atomic import atomic_write_bytes

__all__ = ["npz_bytes", "write_npz"]

_FIXED_DATE = (1980, 1, 1, 0, 0, 0)


def npz_bytes(arrays: dict, *, compress: bool = True) -> bytes:
    """The bytes of an ``.npz`` archive of ``arrays`` (name -> array), deterministic."""
    buf = io.BytesIO()
    method = zipfile.ZIP_DEFLATED if compress else zipfile.ZIP_STORED
    with zipfile.ZipFile(buf, "w", compression=method, allowZip64=True) as zf:
        for name, value in arrays.items():
            arr = np.asanyarray(value)
            if arr.dtype.hasobject:
                raise TypeError(f"array {name!r} has dtype object; only plain numeric/str arrays are written")
            info = zipfile.ZipInfo(f"{name}.npy", date_time=_FIXED_DATE)
            info.compress_type = method
            info.external_attr = 0o644 << 16
            with zf.open(info, "w", force_zip64=True) as fh:
                np.lib.format.write_array(fh, arr, allow_pickle=False)
    return buf.getvalue()


def write_npz(path: str | os.PathLike, arrays: dict, *, compress: bool = True) -> Path:
    """Atomically write ``arrays`` to ``path`` as a deterministic ``.npz``."""
    atomic_write_bytes(path, npz_bytes(arrays, compress=compress))
    return Path(path)
