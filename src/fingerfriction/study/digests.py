"""The digests that decide what ``analyze`` recomputes (:mod:`fingerfriction.pipeline.plan`):
the SHA-256 of a trial's input files (a TIFF folder's frames in order), a file-system
fingerprint that ``--quick-resume`` trusts instead of hashing, and the digest of the
analysis parameters. The run record and the trials' ``status.json`` in the results store
(:mod:`fingerfriction.study.store`) keep them.
"""

from __future__ import annotations

import hashlib
import json
import os

from .._atomic import jsonable
from ..video.readers import tiff_frame_files

__all__ = ["sha256_file", "sha256_input", "input_fingerprint", "params_digest"]


def sha256_file(path: str | os.PathLike, *, chunk: int = 1 << 20) -> str:
    """SHA-256 hex digest of a file, read in 1 MiB chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        while block := fh.read(chunk):
            h.update(block)
    return h.hexdigest()


def sha256_input(path: str | os.PathLike) -> str:
    """SHA-256 hex digest of a trial's input: a file's bytes, or for a folder of TIFF frames
    (:func:`~fingerfriction.video.readers.tiff_frame_files`) the digest of its frames' names
    and digests, in frame order (a renamed, added, removed or edited frame changes it).

    Raises
    ------
    OSError
        A missing or unreadable file or folder.
    ValueError
        A folder without TIFF frames, or whose frames link out of it; something that is
        neither a regular file nor a folder.
    """
    if not os.path.isdir(path):
        if os.path.exists(path) and not os.path.isfile(path):  # a FIFO or a device would block or never end
            raise ValueError(f"{os.fspath(path)}: not a regular file")
        return sha256_file(path)
    h = hashlib.sha256(b"fingerfriction tiff folder v1\n")
    for f in tiff_frame_files(path):
        h.update(f"{os.path.basename(f)}\0{sha256_file(f)}\n".encode())
    return h.hexdigest()


def input_fingerprint(path: str | os.PathLike) -> str:
    """What the file system says of a trial's input, without reading it: size, modification
    and status-change times (ns) and inode, of the file or of every frame of a TIFF folder.
    Any write changes the status-change time (``ctime``), which no user call can set back;
    ``analyze --quick-resume`` trusts an unchanged fingerprint instead of hashing.

    Raises
    ------
    OSError, ValueError
        As :func:`sha256_input`.
    """
    files = tiff_frame_files(path) if os.path.isdir(path) else [path]
    parts = []
    for f in files:
        st = os.stat(f)
        parts.append(f"{os.path.basename(f)}:{st.st_size}:{st.st_mtime_ns}:{st.st_ctime_ns}:{st.st_ino}")
    return hashlib.sha256("\n".join(parts).encode()).hexdigest()


def params_digest(params: dict) -> str:
    """SHA-256 of a parameter dict's canonical JSON (sorted keys)."""
    text = json.dumps(jsonable(params), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()
