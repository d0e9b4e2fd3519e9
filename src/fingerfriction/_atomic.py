"""The one atomic file writer of the package: a temporary file in the target's folder,
moved into place with :func:`os.replace`, so a crash never leaves a half-written file
under the final name (as ``pooch`` does for downloads).

* :func:`atomic_write` runs a writer callable on the temporary path (anything that
  writes to a path: ``DataFrame.to_parquet``, ``Figure.savefig``, ``av.open``...);
* :func:`atomic_write_bytes`, :func:`atomic_write_text`, :func:`atomic_write_json` for
  content in memory;
* :class:`AtomicFile` for a file written over a while (a video encoder): ``tmp`` now,
  :meth:`~AtomicFile.commit` or :meth:`~AtomicFile.discard` later.

The temporary file is named ``.<name>.<random>.tmp<suffix>`` (the target's suffix kept, so
libraries that choose a format from the extension see the right one) and gets the mode
of a normal new file (``0666`` minus the umask; :func:`tempfile.mkstemp` creates ``0600``).
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["AtomicFile", "atomic_write", "atomic_write_bytes", "atomic_write_text", "atomic_write_json",
           "jsonable"]


def _default_mode() -> int:
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


class AtomicFile:
    """A temporary file beside ``path`` that becomes ``path`` on :meth:`commit`.

    Parameters
    ----------
    path : path-like
        The final file name; its folder is created if missing.

    Attributes
    ----------
    path : Path
        The final name.
    tmp : Path
        The temporary file to write (it exists, empty, when the object is made).
    """

    def __init__(self, path: str | os.PathLike):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=f".tmp{self.path.suffix}",
                                   dir=self.path.parent)
        os.close(fd)
        self.tmp = Path(tmp)
        os.chmod(self.tmp, _default_mode())

    def commit(self) -> Path:
        """Move the temporary file onto :attr:`path`; returns :attr:`path`."""
        os.replace(self.tmp, self.path)
        return self.path

    def discard(self) -> None:
        """Remove the temporary file (if it is still there)."""
        self.tmp.unlink(missing_ok=True)


def atomic_write(path: str | os.PathLike, writer: Callable[[Path], Any]) -> Path:
    """Write ``path`` through ``writer(tmp_path)``, then move the result into place.

    Parameters
    ----------
    path : path-like
        The final file name.
    writer : callable
        Called once with the temporary path (same folder and suffix as ``path``); it
        writes the whole file there.

    Returns
    -------
    Path
        ``path``. If ``writer`` raises, ``path`` is left as it was and the temporary
        file is removed.
    """
    f = AtomicFile(path)
    try:
        writer(f.tmp)
        return f.commit()
    finally:
        f.discard()


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically, flushed to disk before the rename."""

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())

    return atomic_write(path, write)


def atomic_write_text(path: str | os.PathLike, text: str) -> Path:
    """Write UTF-8 ``text`` to ``path`` atomically."""
    return atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: str | os.PathLike, obj: Any) -> Path:
    """Write ``obj`` as indented JSON to ``path`` atomically (:func:`jsonable`: NaN as null)."""
    return atomic_write_text(path, json.dumps(jsonable(obj), indent=2, sort_keys=False) + "\n")


def jsonable(obj: Any) -> Any:
    """``obj`` with numpy scalars and arrays, tuples and paths made JSON types; non-finite
    floats become None (JSON has no NaN)."""
    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if np.isfinite(v) else None
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, Path):
        return str(obj)
    return obj
