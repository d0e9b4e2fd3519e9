"""Write gray frames to the formats the readers support (the simulator, tests, benchmarks,
conversions).

:func:`write_video` takes a ``(n_frames, height, width)`` uint8 array or an iterable of
such chunks; :class:`VideoWriter` takes frames one at a time (the simulator's lossless,
deterministic writer). Both write to a temporary file and move it into place
(:mod:`fingerfriction._atomic`: a crash never leaves a half-written video under the final
name).
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from fractions import Fraction
from pathlib import Path

import numpy as np

from .._atomic import AtomicFile, atomic_write
from .._check import check_option
from .cine import write_cine

__all__ = ["write_video", "write_cine", "VideoWriter"]

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
    if fmt == "cine":
        write_cine(path, np.concatenate(list(_chunks(frames))), fps=fps)
        return path
    if fmt == "tiff":
        import tifffile  # optional reader/writer library, only for this format

        def write_tiff(tmp) -> None:
            with tifffile.TiffWriter(tmp) as tw:
                for c in _chunks(frames):
                    for fr in c:
                        tw.write(fr, contiguous=True, metadata=None)

        atomic_write(path, write_tiff)
        return path
    if fmt not in _AV_FORMATS:
        raise ValueError(f"unknown video format {fmt!r}; allowed: {', '.join(_AV_FORMATS)}, tiff, cine")
    import av  # heavy (FFmpeg bindings), only for these formats

    codec, pix, _ = _AV_FORMATS[fmt]

    def write_av(tmp) -> None:
        with av.open(str(tmp), "w", format={"ffv1-mkv": "matroska", "mkv": "matroska"}.get(fmt)) as out:
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

    atomic_write(path, write_av)
    return path


class VideoWriter:
    """Write grayscale uint8 frames losslessly to a temporary file, moved into place on
    :meth:`close` (a crash never leaves a half-written video under the final name).

    Parameters
    ----------
    path : path-like
        Final file name.
    fmt : {'ffv1-mkv', 'tiff'}
        FFV1 (level 3, 4 slices with CRCs, Golomb-Rice coder) in a Matroska container written with the
        ``bitexact`` flags (no date, deterministic ids: the same frames give the same
        bytes), or a zlib-compressed multi-page TIFF (tifffile).
    width, height : int
    fps : float
        Frame rate in Hz (stored as the stream rate; must be an integer for FFV1).
    """

    def __init__(self, path, fmt: str, width: int, height: int, fps: float):
        check_option("video format", fmt, ("ffv1-mkv", "tiff"))
        self._file = AtomicFile(path)
        self.path = self._file.path
        self._tmp = str(self._file.tmp)
        self.fmt = fmt
        self.width, self.height = int(width), int(height)
        self.n = 0
        if fmt == "ffv1-mkv":
            import av  # heavy (FFmpeg bindings), only for this format

            self._c = av.open(self._tmp, "w", format="matroska",
                              options={"fflags": "+bitexact"}, container_options={"fflags": "+bitexact"})
            s = self._c.add_stream("ffv1", rate=int(round(fps)))
            s.width, s.height, s.pix_fmt = self.width, self.height, "gray"
            # Golomb-Rice coder: its run mode suits silhouettes (mostly constant runs):
            # measured 10 kB/frame against 15 kB with the range coder, and faster
            s.options = {"level": "3", "slices": "4", "slicecrc": "1", "context": "0", "coder": "0",
                         "threads": "1", "flags": "+bitexact"}
            self._s = s
        else:
            import tifffile  # optional reader/writer library, only for this format

            self._tw = tifffile.TiffWriter(self._tmp, bigtiff=True)

    def write(self, frame: np.ndarray) -> None:
        """Append one ``(height, width)`` uint8 frame."""
        if frame.shape != (self.height, self.width) or frame.dtype != np.uint8:
            raise ValueError(
                f"frame must be ({self.height}, {self.width}) uint8, got {frame.shape} {frame.dtype}"
            )
        if self.fmt == "ffv1-mkv":
            import av  # heavy (FFmpeg bindings), only for this format

            vf = av.VideoFrame.from_ndarray(frame, format="gray")
            vf.pts = self.n
            for pkt in self._s.encode(vf):
                self._c.mux(pkt)
        else:
            self._tw.write(frame, compression="zlib", compressionargs={"level": 1},
                           contiguous=False, metadata=None)
        self.n += 1

    def close(self) -> Path:
        """Finish the file and move it into place; returns its path."""
        if self.fmt == "ffv1-mkv":
            for pkt in self._s.encode():
                self._c.mux(pkt)
            self._c.close()
        else:
            self._tw.close()
        return self._file.commit()

    def abort(self) -> None:
        """Drop the partial file (after an error)."""
        try:
            if self.fmt == "ffv1-mkv":
                self._c.close()
            else:
                self._tw.close()
        except Exception:  # noqa: BLE001 - best effort cleanup of a failed write
            pass
        self._file.discard()
