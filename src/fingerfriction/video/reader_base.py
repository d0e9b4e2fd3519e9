"""The readers' common part: the base class :class:`VideoReader` (a video as a stream of gray
frames) and the frame-rate rule :func:`frame_rate` that ``init``, ``check`` and every reader
share. The readers themselves, and :func:`~fingerfriction.video.readers.open_video` which
picks one from a path, are in :mod:`fingerfriction.video.readers`.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

__all__ = ["VideoReader", "FrameRate", "frame_rate", "FPS_TOLERANCE", "to_gray", "check_dtype"]

#: The readers' one logger (the readers module's name, as before the base class moved here).
log = logging.getLogger("fingerfriction.video.readers")

#: Relative difference between the time stamps' rate and the nominal one above which they
#: disagree (1e-4: 0.1 ms in a 1 s recording; a camera's clock is better than this).
FPS_TOLERANCE = 1e-4


@dataclass(frozen=True)
class FrameRate:
    """A video's frame rate as the file states it, by :func:`frame_rate`'s rule.

    Attributes
    ----------
    fps : float or None
        The rate to use, in Hz: the time stamps' when the file has them, else the nominal.
    nominal : float or None
        The header's (or container's) setting, in Hz.
    timestamps : float or None
        The rate of the per-frame time stamps in Hz (least-squares slope over all frames).
    source : str
        ``'time stamps'``, ``'header'`` or ``'none'``: where ``fps`` comes from.
    note : str
        Why the time stamps were preferred to a nominal setting that disagrees ('' when
        they agree or there is only one of them).
    """

    fps: float | None
    nominal: float | None = None
    timestamps: float | None = None
    source: str = "none"
    note: str = ""


def frame_rate(nominal: float | None, times_s=None, *, resolution_s: float = 0.0) -> FrameRate:
    """The frame rate of a video from its nominal setting and its per-frame time stamps.

    Parameters
    ----------
    nominal : float or None
        The rate the header states, in Hz (None or 0: none).
    times_s : (n,) array_like, optional
        Time of each frame in s (any origin); at least 3 to count.
    resolution_s : float
        Resolution of the time stamps in s (a container's time base): a disagreement
        within it is not one.

    Returns
    -------
    FrameRate
        The time stamps win when they disagree with the nominal setting by more than
        ``max(FPS_TOLERANCE, 2 resolution_s / duration)`` (relative), and ``note`` says so.
    """
    nominal = float(nominal) if nominal else None
    t = None if times_s is None else np.asarray(times_s, dtype=np.float64)
    if t is None or t.size < 3 or not np.all(np.isfinite(t)) or t[-1] <= t[0]:
        return FrameRate(nominal, nominal, None, "header" if nominal else "none")
    k = np.arange(t.size, dtype=np.float64)
    period = float(np.polyfit(k, t - t[0], 1)[0])
    ts = 1.0 / period
    if nominal is None:
        return FrameRate(ts, None, ts, "time stamps")
    tol = max(FPS_TOLERANCE, 2.0 * resolution_s / (t[-1] - t[0]))
    if abs(ts / nominal - 1.0) <= tol:
        return FrameRate(nominal, nominal, ts, "header")
    note = (f"the header states {nominal:g} fps but the frames' time stamps are {1e6 * period:.2f} us "
            f"apart ({ts:.6g} fps): the time stamps are used")
    return FrameRate(ts, nominal, ts, "time stamps", note)


class VideoReader:
    """Base class of the readers: a video as a stream of gray frames.

    Attributes
    ----------
    path : str
        The file or folder read.
    format : str
        Short format name (``'tiff'``, ``'mkv'``, ``'cine'``...).
    n_frames : int
        Number of frames the file announces.
    shape : (int, int)
        ``(height, width)`` of a frame in pixels.
    dtype : numpy.dtype
        uint8 or uint16.
    fps : float or None
        Frame rate in Hz, if the file records it: its time stamps' rate when it has
        per-frame time stamps, else its nominal setting (:func:`frame_rate`).
    rate : FrameRate
        Both, and ``rate.note`` when they disagree.
    truncated : bool
        Set once reading stopped before ``n_frames`` because the file is truncated or
        corrupt; ``error`` then says why and ``n_read`` how many frames were read.
    """

    format = "video"

    def __init__(self, path: str) -> None:
        self.path = path
        self.truncated = False
        self.error: str | None = None
        self.n_read = 0
        self.n_frames = 0
        self.shape: tuple[int, int] = (0, 0)
        self.dtype = np.dtype(np.uint8)
        self.fps: float | None = None
        self.rate = FrameRate(None)

    def _set_rate(self, rate: FrameRate) -> None:
        self.rate = rate
        self.fps = rate.fps
        if rate.note:
            log.info("%s: %s", self.path, rate.note)

    # -- to implement ---------------------------------------------------------------
    def _read_range(self, start: int, stop: int, out: np.ndarray) -> int:
        """Fill ``out[:stop - start]`` with frames ``start..stop-1``; return how many were read.

        A return value below ``stop - start`` means the file ended or is corrupt there
        (and ``self.error`` says why).
        """
        raise NotImplementedError

    def _read_images(self, start: int, stop: int, out: np.ndarray, read, unreadable, misshapen) -> int:
        """:meth:`_read_range` of a format read one image at a time: ``read(i)`` gives image
        ``i`` (gray); the first image that cannot be read, or whose shape is not
        ``self.shape``, stops the reading, and ``self.error`` says why:
        ``unreadable(i, exc)`` or ``misshapen(i, shape)``."""
        for k, i in enumerate(range(start, stop)):
            try:
                img = read(i)
            except Exception as exc:  # noqa: BLE001 - any decoder failure = corrupt frame
                self.error = unreadable(i, exc)
                return k
            if img.shape != self.shape:
                self.error = misshapen(i, img.shape)
                return k
            out[k] = img
        return stop - start

    # -- common interface -----------------------------------------------------------
    def iter_chunks(self, chunk_size: int = 256, *, start: int = 0,
                    stop: int | None = None) -> Iterator[tuple[int, np.ndarray]]:
        """Yield ``(start_index, frames)`` chunks of at most ``chunk_size`` frames.

        Parameters
        ----------
        chunk_size : int
            Frames per chunk (memory: ``chunk_size * height * width * itemsize`` bytes).
        start, stop : int
            Frame range ``[start, stop)``; ``stop`` defaults to ``n_frames``.

        Yields
        ------
        start_index : int
            Index of the first frame of the chunk.
        frames : (k, height, width) ndarray
            uint8 or uint16; the array is reused between chunks: copy what you keep.
        """
        chunk_size = int(chunk_size)
        if chunk_size < 1:
            raise ValueError(f"chunk_size must be >= 1 frame, got {chunk_size}")
        stop = self.n_frames if stop is None else min(int(stop), self.n_frames)
        if not 0 <= start <= stop:
            raise ValueError(f"start ({start}) must be in [0, {stop}] for {self.path}")
        buf = np.empty((min(chunk_size, max(stop - start, 1)), *self.shape), dtype=self.dtype)
        i = start
        while i < stop:
            j = min(i + chunk_size, stop)
            got = self._read_range(i, j, buf)
            self.n_read = max(self.n_read, i + got)
            if got:
                yield i, buf[:got]
            if got < j - i:
                self.truncated = True
                log.warning("%s: read stopped at frame %d of %d: %s", self.path, i + got,
                            self.n_frames, self.error)
                return
            i = j

    def read_frame(self, index: int) -> np.ndarray:
        """One frame ``(height, width)`` (a copy).

        Raises
        ------
        IndexError
            If ``index`` is outside ``[0, n_frames)``.
        ValueError
            If the frame cannot be read (truncated or corrupt file).
        """
        if not 0 <= index < self.n_frames:
            raise IndexError(f"frame {index} is outside [0, {self.n_frames}) in {self.path}")
        out = np.empty((1, *self.shape), dtype=self.dtype)
        if self._read_range(index, index + 1, out) != 1:
            raise ValueError(f"{self.path}: frame {index} cannot be read: {self.error}")
        return out[0].copy()

    def close(self) -> None:
        """Release the file."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __repr__(self) -> str:
        h, w = self.shape
        return (f"<{type(self).__name__} {self.path!r}: {self.n_frames} frames {w}x{h} "
                f"{self.dtype} fps={self.fps}>")


def to_gray(img: np.ndarray, where: str) -> np.ndarray:
    """A frame as a 2-D gray image: returned as is when 2-D, RGB or RGBA converted to gray
    (OpenCV); ``ValueError`` naming ``where`` for any other shape."""
    if img.ndim == 2:
        return img
    if img.ndim == 3 and img.shape[-1] in (3, 4):
        import cv2  # heavy (OpenCV), only for this reader

        code = cv2.COLOR_RGB2GRAY if img.shape[-1] == 3 else cv2.COLOR_RGBA2GRAY
        return cv2.cvtColor(img, code)
    raise ValueError(f"{where}: expected a 2-D gray (or RGB) image, got shape {img.shape}")


def check_dtype(dtype: np.dtype, where: str) -> np.dtype:
    """``dtype`` when it is uint8 or uint16 (the readers' pixel types), else ``ValueError`` naming
    ``where``."""
    dtype = np.dtype(dtype)
    if dtype not in (np.uint8, np.uint16):
        raise ValueError(f"{where}: pixel type {dtype} is not supported; allowed: uint8, uint16")
    return dtype
