"""Video readers with one interface: stream gray frames in chunks, never a whole video.

Supported inputs (``open_video(path)`` picks the reader from the path):

================================  ==========================================  ===========
input                             library                                     ``format``
================================  ==========================================  ===========
folder of ``.tif``/``.tiff``      tifffile, one frame per file, natural order  ``tiff``
multi-page ``.tif``/``.tiff``     tifffile, one frame per page                 ``tiff``
``.avi``, ``.mp4``, ``.mkv``      PyAV (FFmpeg): FFV1, H.264, MJPEG, raw...    ``avi``...
``.cine`` (Phantom cameras)       :mod:`fingerfriction.video.cine`            ``cine``
================================  ==========================================  ===========

Every reader has ``n_frames``, ``shape`` ``(height, width)``, ``dtype``, ``fps`` (Hz, or
None if the file does not say), and :meth:`VideoReader.iter_chunks` yielding
``(start_index, frames)`` with ``frames`` a ``(k, height, width)`` uint8 or uint16 array.
Colour frames are reduced to their luma (Y plane) or converted to gray.

Frame rate: a file's per-frame time stamps (a ``.cine`` file's time block, a Matroska
file's packet timestamps) say at what rate the camera really ran; the header's or
container's setting is nominal. ``fps`` is the rate of the time stamps when the file has
them, the nominal setting otherwise; when the two disagree (by more than
:data:`FPS_TOLERANCE`, or the time stamps' own resolution) the time stamps win and the
reader says so in ``fps_note`` (:func:`frame_rate`, the one rule ``init``, ``check`` and
the readers share).

A file that is truncated or corrupt part-way yields the frames that could be read, then
stops with ``reader.truncated = True`` and ``reader.error`` set (the analysis flags the
missing frames); a file that cannot be read at all raises ``ValueError`` naming it.
"""

from __future__ import annotations

import logging
import os
import re
from dataclasses import dataclass

import numpy as np

from .cine import read_cine_header
from .reader_base import FPS_TOLERANCE, FrameRate, VideoReader, check_dtype, frame_rate, to_gray

__all__ = ["VideoReader", "open_video", "tiff_frame_files", "TiffStackReader", "MultiPageTiffReader",
           "AVReader", "CineReader", "VIDEO_EXTENSIONS", "VideoProbe", "probe_video", "is_video_path",
           "FrameRate", "frame_rate", "FPS_TOLERANCE"]

log = logging.getLogger(__name__)

#: File extensions recognised by :func:`open_video` (lower case, with dot).
VIDEO_EXTENSIONS = (".tif", ".tiff", ".avi", ".mp4", ".mkv", ".mov", ".cine")

#: The FFmpeg demuxer of each container extension. It is named, never guessed from the
#: content: a guessed format could be a playlist (HLS, ffconcat) that makes FFmpeg read
#: other files or URLs, outside the study folder and outside what resume hashes.
AV_DEMUXERS = {".avi": "avi", ".mp4": "mov", ".mov": "mov", ".mkv": "matroska"}


def _natural_key(name: str):
    return [int(t) if t.isdigit() else t.lower() for t in re.split(r"(\d+)", name)]


# ---------------------------------------------------------------------------------------
# TIFF
# ---------------------------------------------------------------------------------------
def tiff_frame_files(folder: str | os.PathLike) -> list[str]:
    """The frames of a folder of TIFF images: its ``.tif``/``.tiff`` files in natural name
    order (``frame2`` before ``frame10``), as paths.

    Raises
    ------
    ValueError
        A folder without TIFF files, or a frame that is a link to a file outside the
        folder (a folder's frames are its own: that is what is read and what resume hashes).
    """
    folder = os.fspath(folder)
    try:
        names = sorted((n for n in os.listdir(folder) if n.lower().endswith((".tif", ".tiff"))),
                       key=_natural_key)
    except OSError as exc:
        raise ValueError(f"{folder}: cannot list the folder of TIFF frames ({exc.strerror or exc})") from None
    if not names:
        raise ValueError(f"{folder}: folder contains no .tif/.tiff files")
    real = os.path.realpath(folder)
    files = []
    for n in names:
        p = os.path.join(folder, n)
        target = os.path.realpath(p)
        if os.path.dirname(target) != real and not target.startswith(real + os.sep):
            raise ValueError(f"{p}: frame file links to {target}, outside the folder {real}")
        if not os.path.isfile(target):
            raise ValueError(f"{p}: not a file (a frame of the TIFF folder must be a TIFF image)")
        files.append(p)
    return files


def _read_tiff_image(path: str) -> np.ndarray:
    """The first image of one TIFF file, gray. Read by page, never through tifffile's
    series, which for an OME-TIFF would also read the other files its metadata names."""
    import tifffile  # only for TIFF files

    with tifffile.TiffFile(path) as tf:
        return to_gray(tf.pages[0].asarray(), path)


class TiffStackReader(VideoReader):
    """A folder of single-image TIFF files, one frame each, in natural name order
    (:func:`tiff_frame_files`)."""

    format = "tiff"

    def __init__(self, path: str) -> None:
        super().__init__(path)
        self.files = tiff_frame_files(path)
        try:
            first = _read_tiff_image(self.files[0])
        except Exception as exc:  # noqa: BLE001 - tifffile raises many types on bad files
            raise ValueError(
                f"{self.files[0]}: cannot read TIFF image ({type(exc).__name__}: {exc})") from None
        self.dtype = check_dtype(first.dtype, self.files[0])
        self.shape = first.shape
        self.n_frames = len(self.files)

    def _read_range(self, start, stop, out):
        f = self.files
        return self._read_images(
            start, stop, out, lambda i: _read_tiff_image(f[i]),
            unreadable=lambda i, exc: f"{f[i]}: cannot read TIFF image ({type(exc).__name__}: {exc})",
            misshapen=lambda i, shape: f"{f[i]}: image is {shape}, the stack's frames are {self.shape}")


class MultiPageTiffReader(VideoReader):
    """A multi-page TIFF file, one frame per page (tifffile)."""

    format = "tiff"

    def __init__(self, path: str) -> None:
        import tifffile  # only for TIFF files

        super().__init__(path)
        try:
            self._tf = tifffile.TiffFile(path)
            pages = self._tf.pages
            pages.useframes = True
            n = len(pages)
            first = to_gray(pages[0].asarray(), path)
        except Exception as exc:  # noqa: BLE001 - tifffile raises many types on bad files
            raise ValueError(f"{path}: cannot read as TIFF ({type(exc).__name__}: {exc})") from None
        self.dtype = check_dtype(first.dtype, path)
        self.shape = first.shape
        self.n_frames = n
        fps = None
        ij = self._tf.imagej_metadata or {}
        if ij.get("finterval"):
            fps = 1.0 / float(ij["finterval"])
        elif ij.get("fps"):
            fps = float(ij["fps"])
        self._set_rate(frame_rate(fps))

    def _read_range(self, start, stop, out):
        return self._read_images(
            start, stop, out, lambda i: to_gray(self._tf.pages[i].asarray(), self.path),
            unreadable=lambda i, exc: f"page {i} cannot be read ({type(exc).__name__}: {exc})",
            misshapen=lambda i, shape: f"page {i} is {shape}, the first page is {self.shape}")

    def close(self) -> None:
        self._tf.close()


# ---------------------------------------------------------------------------------------
# FFmpeg containers (PyAV)
# ---------------------------------------------------------------------------------------
class AVReader(VideoReader):
    """AVI / MP4 / MKV (any FFmpeg codec: FFV1, H.264, MJPEG, raw) through PyAV.

    Parameters
    ----------
    path : str
        The file.
    threads : int
        Decoder threads (default 1: one core, as the benchmarks measure).

    Notes
    -----
    YUV frames are reduced to their luma plane without a colour conversion; 9-16 bit
    gray formats (``gray16le``, ``gray12le``...) are returned as uint16. Frames are
    decoded sequentially; a chunk starting before the current position reopens the file.
    """

    def __init__(self, path: str, *, threads: int = 1) -> None:
        import av  # heavy (FFmpeg bindings), only for video containers

        super().__init__(path)
        self.format = os.path.splitext(path)[1].lower().lstrip(".")
        self.demuxer = AV_DEMUXERS.get("." + self.format)
        if self.demuxer is None:
            raise ValueError(f"{path}: unknown video container {self.format!r}; allowed: "
                             + ", ".join(AV_DEMUXERS))
        self._threads = int(threads)
        try:
            with av.open(path, format=self.demuxer) as c:
                if not c.streams.video:
                    raise ValueError(f"{path}: file has no video stream")
                s = c.streams.video[0]
                cc = s.codec_context
                self.shape = (int(cc.height), int(cc.width))
                rate = s.average_rate or s.guessed_rate or s.base_rate
                nominal = float(rate) if rate else None
                self._set_rate(frame_rate(nominal))
                pix = cc.pix_fmt or ""
                n = int(s.frames or 0)
                if n == 0:  # MKV does not store a frame count: count packets (no decoding)
                    dur = None
                    if s.duration is not None and s.time_base is not None:
                        dur = float(s.duration * s.time_base)
                    elif c.duration is not None:
                        dur = c.duration / 1e6
                    pts = [p.pts for p in c.demux(s) if p.size]
                    n = len(pts)
                    if s.time_base is not None and n >= 3 and None not in pts:
                        # the packets' timestamps: the rate the frames were really taken at
                        tb = float(s.time_base)
                        self._set_rate(frame_rate(nominal, np.sort(np.asarray(pts, dtype=np.float64)) * tb,
                                                  resolution_s=tb))
                    # The container's duration announces the frame count: fewer packets
                    # than that means the file was cut short.
                    if dur and self.fps and round(dur * self.fps) > n:
                        n_ann = int(round(dur * self.fps))
                        log.warning("%s: duration says %d frames but only %d are stored", path, n_ann, n)
                        n = n_ann
        except av.error.FFmpegError as exc:
            raise ValueError(f"{path}: cannot open as video ({exc})") from None
        self.n_frames = n
        self.dtype = np.dtype(np.uint16 if _is_high_bit_gray(pix) else np.uint8)
        self._container = None
        self._gen = None
        self._pos = 0

    def _open(self) -> None:
        import av  # heavy (FFmpeg bindings), only for video containers

        self.close()
        self._container = av.open(self.path, format=self.demuxer)
        s = self._container.streams.video[0]
        s.thread_count = self._threads
        s.thread_type = "AUTO" if self._threads > 1 else "SLICE"
        self._gen = self._container.decode(s)
        self._pos = 0

    def _next_frame(self) -> np.ndarray:
        frame = next(self._gen)
        name = frame.format.name
        if self.dtype == np.uint16:
            return frame.to_ndarray(format="gray16le")
        if name in ("gray", "gray8") or name.startswith(("yuv", "yuvj", "nv12", "nv21")):
            plane = frame.planes[0]
            h, w = self.shape
            buf = np.frombuffer(plane, np.uint8).reshape(-1, plane.line_size)
            return buf[:h, :w]
        return frame.to_ndarray(format="gray")

    def _read_range(self, start, stop, out):
        import av  # heavy (FFmpeg bindings), only for video containers

        if self._gen is None or start < self._pos:
            self._open()
        try:
            while self._pos < start:
                self._next_frame()
                self._pos += 1
            for k in range(stop - start):
                out[k] = self._next_frame()
                self._pos += 1
        except StopIteration:
            self.error = f"the stream ended after {self._pos} frames ({self.n_frames} announced)"
            return self._pos - start if self._pos > start else 0
        except (av.error.FFmpegError, ValueError) as exc:
            self.error = f"decoding failed at frame {self._pos} ({exc})"
            return max(self._pos - start, 0)
        return stop - start

    def close(self) -> None:
        if self._container is not None:
            self._container.close()
        self._container = None
        self._gen = None


def _is_high_bit_gray(pix: str) -> bool:
    return bool(re.fullmatch(r"gray(9|10|12|14|16)(le|be)", pix))


# ---------------------------------------------------------------------------------------
# Phantom cine
# ---------------------------------------------------------------------------------------
class CineReader(VideoReader):
    """Phantom ``.cine`` files, uncompressed 8- or 16-bit gray (see :mod:`.cine`)."""

    format = "cine"

    def __init__(self, path: str) -> None:
        super().__init__(path)
        hdr = read_cine_header(path)
        self.header = hdr
        self.shape = (hdr.height, hdr.width)
        self.dtype = hdr.dtype
        self._set_rate(frame_rate(hdr.fps, hdr.timestamps_s))
        self.n_frames = hdr.image_count
        self._fh = open(path, "rb")

    def _read_range(self, start, stop, out):
        hdr = self.header
        h, w = self.shape
        rb = hdr.row_bytes
        for k, i in enumerate(range(start, stop)):
            off = int(hdr.image_offsets[i])
            self._fh.seek(off)
            raw = self._fh.read(4)
            if len(raw) < 4 or off < 0:
                self.error = f"image {i}: its annotation at offset {off} is past the end of the file"
                return k
            ann = int.from_bytes(raw, "little")
            if ann < 8:
                self.error = f"image {i}: AnnotationSize={ann} is invalid (>= 8 expected)"
                return k
            self._fh.seek(off + ann)
            data = self._fh.read(hdr.image_size)
            if len(data) < hdr.image_size:
                self.error = (f"image {i} is cut short: {len(data)} of {hdr.image_size} bytes "
                              "(the file is truncated)")
                return k
            img = np.frombuffer(data, dtype=hdr.dtype).reshape(h, rb // hdr.dtype.itemsize)[:, :w]
            out[k] = img[::-1] if hdr.bottom_up else img
        return stop - start

    def close(self) -> None:
        self._fh.close()


def open_video(path: str | os.PathLike, **kwargs) -> VideoReader:
    """Open a video for streaming; the reader is chosen from the path.

    Parameters
    ----------
    path : path-like
        A folder of TIFF files, or a ``.tif/.tiff``, ``.avi``, ``.mp4``, ``.mkv``,
        ``.mov`` or ``.cine`` file.
    **kwargs
        Passed to the reader (``threads=`` for :class:`AVReader`).

    Returns
    -------
    VideoReader

    Raises
    ------
    ValueError
        For a missing file, an unknown extension, or a file that cannot be read at all.
    """
    p = os.fspath(path)
    if os.path.isdir(p):
        return TiffStackReader(p)
    if not os.path.exists(p):
        raise ValueError(f"{p}: no such video file or folder")
    if not os.path.isfile(p):  # a FIFO or a device: reading it would block, or never end
        raise ValueError(f"{p}: not a regular file or a folder of TIFF frames")
    ext = os.path.splitext(p)[1].lower()
    if ext in (".tif", ".tiff"):
        return MultiPageTiffReader(p)
    if ext in (".avi", ".mp4", ".mkv", ".mov"):
        return AVReader(p, **kwargs)
    if ext == ".cine":
        return CineReader(p)
    raise ValueError(f"{p}: unknown video extension {ext!r}; allowed: a TIFF folder or "
                     + ", ".join(VIDEO_EXTENSIONS))


@dataclass(frozen=True)
class VideoProbe:
    """What a video says about itself (:func:`probe_video`), without decoding its frames.

    Attributes
    ----------
    path : str
    format : str
        The reader's format name: ``'tiff'``, ``'cine'``, or the container's extension
        (``'mkv'``, ``'avi'``, ``'mp4'``, ``'mov'``).
    n_frames : int
        Frames the file announces.
    fps : float or None
        Frame rate in Hz, or None when the file does not record it (a TIFF without
        ImageJ metadata, a folder of TIFF files): the rate of the frames' time stamps when
        the file has them, else its nominal setting (:func:`frame_rate`).
    width, height : int
        Frame size in pixels.
    dtype : str
        ``'uint8'`` or ``'uint16'``.
    rate : FrameRate
        The nominal and time-stamp rates, and a note when they disagree.
    """

    path: str
    format: str
    n_frames: int
    fps: float | None
    width: int
    height: int
    dtype: str
    rate: FrameRate = FrameRate(None)


def probe_video(path: str | os.PathLike) -> VideoProbe:
    """Frame count, frame rate and image size of a video, read from its header.

    Parameters
    ----------
    path : path-like
        Anything :func:`open_video` takes.

    Returns
    -------
    VideoProbe

    Raises
    ------
    ValueError
        A missing or unreadable file (as :func:`open_video`).
    """
    with open_video(path) as r:
        h, w = r.shape
        fps = float(r.fps) if r.fps else None
        return VideoProbe(path=os.fspath(path), format=r.format, n_frames=int(r.n_frames), fps=fps,
                          width=int(w), height=int(h), dtype=str(np.dtype(r.dtype)), rate=r.rate)


def is_video_path(path: str | os.PathLike) -> bool:
    """Whether :func:`open_video` would pick a reader for this path: a file with one of
    :data:`VIDEO_EXTENSIONS` or a folder holding ``.tif``/``.tiff`` files."""
    p = os.fspath(path)
    if os.path.isdir(p):
        try:
            return any(n.lower().endswith((".tif", ".tiff")) for n in os.listdir(p))
        except OSError:
            return False
    return os.path.splitext(p)[1].lower() in VIDEO_EXTENSIONS
