"""Write gray frames to the formats the readers support (tests, benchmarks, conversions).

All writers take a ``(n_frames, height, width)`` uint8 array or an iterable of such
chunks, write to a temporary file and move it into place (a crash never leaves a
half-written video under the final name).
"""

from __future__ import annotations

import os
from collections.abc import Iterable

import numpy as np

from .cine import write_cine

__all__ = ["write_video", "write_cine"]

#: format -> (codec, pixel format, container extension)
_AV_FORMATS = {
    "ffv1-mkv": ("ffv1", "gray", ".mkv"),
    "mkv": ("ffv1", "gray", ".mkv"),
    "avi": ("ffv1", "gray", ".avi"),
    "mp4": ("libx264", "yuvj420p", ".mp4"),  # full-range luma = the gray values
}


def _chunks(frames) -> Iterable[np.ndarray]:
    if isinstance(frames, np.ndarray):
        if frames.ndim != 3:
            raise ValueError(f"frames must be (n_frames, height, width), got shape {frames.shape}")
        yield frames
    else:
        for c in frames:
            c = np.asarray(c)
            yield c[None] if c.ndim == 2 else c


def write_video(path: str | os.PathLike, frames, *, fps: float = 1000.0, fmt: str | None = None,
                crf: int = 0) -> str:
    """Write gray frames to a video file.

    Parameters
    ----------
    path : path-like
        Output file (``.mkv``, ``.avi``, ``.mp4``, ``.tif``/``.tiff``, ``.cine``).
    frames : (n, h, w) uint8 ndarray or iterable of chunks
    fps : float
        Frame rate in Hz.
    fmt : str, optional
        ``'ffv1-mkv'``, ``'mkv'``, ``'avi'`` (FFV1, lossless), ``'mp4'`` (H.264),
        ``'tiff'`` (multi-page), ``'cine'``; default from the extension.
    crf : int
        H.264 constant rate factor for ``mp4`` (0 = lossless luma).

    Returns
    -------
    str
        The path written.
    """
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    if fmt is None:
        fmt = {".mkv": "ffv1-mkv", ".avi": "avi", ".mp4": "mp4", ".tif": "tiff", ".tiff": "tiff",
               ".cine": "cine"}.get(ext)
        if fmt is None:
            raise ValueError(f"{path}: cannot tell the video format from extension {ext!r}")
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive frame rate in Hz, got {fps!r}")
    tmp = path + ".tmp" + ext
    if fmt == "cine":
        write_cine(path, np.concatenate(list(_chunks(frames))), fps=fps)
        return path
    if fmt == "tiff":
        import tifffile

        with tifffile.TiffWriter(tmp) as tw:
            for c in _chunks(frames):
                for fr in c:
                    tw.write(fr, contiguous=True, metadata=None)
        os.replace(tmp, path)
        return path
    if fmt not in _AV_FORMATS:
        raise ValueError(f"unknown video format {fmt!r}; allowed: {', '.join(_AV_FORMATS)}, tiff, cine")
    from fractions import Fraction

    import av

    codec, pix, _ = _AV_FORMATS[fmt]
    with av.open(tmp, "w", format={"ffv1-mkv": "matroska", "mkv": "matroska"}.get(fmt)) as out:
        st = None
        for c in _chunks(frames):
            if c.dtype != np.uint8:
                raise ValueError(f"{path}: only uint8 frames can be written as {fmt}, got {c.dtype}")
            for fr in c:
                if st is None:
                    st = out.add_stream(codec, rate=Fraction(fps).limit_denominator(10000))
                    st.width, st.height = fr.shape[1], fr.shape[0]
                    st.pix_fmt = pix
                    if codec == "libx264":
                        st.options = {"crf": str(int(crf)), "preset": "ultrafast"}
                vf = av.VideoFrame.from_ndarray(np.ascontiguousarray(fr), format="gray")
                if pix != "gray":
                    vf = vf.reformat(format=pix)
                for pkt in st.encode(vf):
                    out.mux(pkt)
        if st is not None:
            for pkt in st.encode():
                out.mux(pkt)
    os.replace(tmp, path)
    return path
