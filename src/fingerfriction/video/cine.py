"""Phantom ``.cine`` files: a reader and a minimal writer for uncompressed gray images.

The paper's camera (Phantom Miro M110, Vision Research) records ``.cine`` files. The
format is publicly documented by Vision Research ("Cine File Format", the SDK headers);
``pycine`` on PyPI implements it but is unmaintained since 2020, so this module reads the
documented layout directly (little-endian, structures packed at 1 byte):

``CINEFILEHEADER`` (44 bytes, at offset 0)
    ``Type`` ("CI"), ``Headersize`` (44), ``Compression`` (0 = gray/uncompressed,
    1 = JPEG, 2 = raw Bayer), ``Version`` (1), ``FirstMovieImage``, ``TotalImageCount``,
    ``FirstImageNo``, ``ImageCount``, ``OffImageHeader``, ``OffSetup``,
    ``OffImageOffsets`` and the trigger time (``TIME64``: fractions, seconds).
``BITMAPINFOHEADER`` (40 bytes, at ``OffImageHeader``)
    ``biWidth``, ``biHeight`` (positive: rows stored bottom-up, as in a Windows DIB),
    ``biBitCount`` (8 or 16), ``biCompression`` (0), ``biSizeImage`` (bytes per image).
``SETUP`` (at ``OffSetup``)
    Camera settings; this module reads ``FrameRate16`` (offset 0), the ``"ST"`` marker
    (offset 140), ``Length`` (142), ``ImWidth``/``ImHeight`` (737/739), ``FrameRate``
    (uint32, 768) and ``RealBPP`` (uint32, 896) when the stored setup is long enough.
Tagged information blocks (between the end of SETUP, ``OffSetup + Length``, and ``OffImageOffsets``)
    Each ``BlockSize`` (uint32, bytes including this 8-byte head), ``Type`` (uint16),
    ``Reserved`` (uint16), then its data. Type 1002, the "time only" block, holds one
    ``TIME64`` per image (uint32 fractions of 2^-32 s, uint32 seconds): the time each image
    was taken. This module reads it: the frame rate the camera really ran at comes from
    these time stamps, the SETUP's ``FrameRate`` being the nominal setting (they can
    disagree: a file states 90000 fps while its images are 111.07 us apart).
Pointer array (at ``OffImageOffsets``)
    ``ImageCount`` little-endian int64 offsets; at each one an annotation block
    (``AnnotationSize`` uint32, annotation bytes, ``ImageSize`` uint32, total
    ``AnnotationSize`` bytes) followed by the ``ImageSize`` bytes of the image.

Only uncompressed gray images stored on 8 or 16 bits are supported (this covers the
Miro M110 in gray mode); packed 10/12-bit and colour (Bayer) cines are refused with a
clear error.
"""

from __future__ import annotations

import logging
import os
import struct
from dataclasses import dataclass

import numpy as np

from .._atomic import atomic_write

__all__ = ["CineHeader", "read_cine_header", "write_cine", "TIME_ONLY_BLOCK"]

log = logging.getLogger(__name__)

_FILEHEADER = struct.Struct("<2sHHHiIiIIIIII")  # 44 bytes
_BITMAPINFO = struct.Struct("<IiiHHIIiiII")  # 40 bytes
_SETUP_MARK_OFFSET = 140
_SETUP_LENGTH_OFFSET = 142
_SETUP_IMWIDTH_OFFSET = 737
_SETUP_FRAMERATE_OFFSET = 768
_SETUP_REALBPP_OFFSET = 896
#: Length of the SETUP block this module writes (up to and including RealBPP).
_SETUP_WRITE_LENGTH = 900
#: Type of the tagged information block holding one TIME64 per image ("time only block").
TIME_ONLY_BLOCK = 1002
_BLOCK_HEAD = struct.Struct("<IHH")  # BlockSize, Type, Reserved


@dataclass(frozen=True)
class CineHeader:
    """What a ``.cine`` file says about its images.

    Attributes
    ----------
    path : str
        The file.
    width, height : int
        Image size in pixels.
    bit_count : int
        Storage bits per pixel, 8 or 16.
    real_bpp : int
        Significant bits per pixel (e.g. 12 on a 16-bit storage), from SETUP.
    image_count : int
        Number of images the header announces.
    first_image_no : int
        Number of the first image relative to the trigger.
    fps : float or None
        Nominal frame rate in Hz from SETUP (None if the setup block is too short): the
        camera's setting, which the time stamps may contradict.
    image_offsets : (image_count,) int64 ndarray
        File offset of each image's annotation block.
    bottom_up : bool
        Whether rows are stored bottom-up (``biHeight > 0``); the reader flips them.
    image_size : int
        Bytes per image (``biSizeImage``).
    file_size : int
        Size of the file in bytes.
    timestamps_s : (image_count,) float64 ndarray or None
        Time in s of each image relative to the first one, from the time-only block
        (exact: computed from the integer TIME64 values); None when the file has none.
    """

    path: str
    width: int
    height: int
    bit_count: int
    real_bpp: int
    image_count: int
    first_image_no: int
    fps: float | None
    image_offsets: np.ndarray
    bottom_up: bool
    image_size: int
    file_size: int
    timestamps_s: np.ndarray | None = None

    @property
    def dtype(self) -> np.dtype:
        return np.dtype(np.uint8 if self.bit_count == 8 else "<u2")

    @property
    def row_bytes(self) -> int:
        return self.image_size // self.height


def _bad(path: str, what: str) -> ValueError:
    return ValueError(f"{path}: not a readable Phantom cine file: {what}")


def read_cine_header(path: str | os.PathLike) -> CineHeader:
    """Parse the headers and the image pointer array of a ``.cine`` file.

    Raises
    ------
    ValueError
        Naming the file, for a wrong signature, an unsupported compression or bit depth,
        or headers/pointers that point outside the file.
    OSError
        If the file cannot be opened.
    """
    path = os.fspath(path)
    size = os.path.getsize(path)
    with open(path, "rb") as fh:
        raw = fh.read(_FILEHEADER.size)
        if len(raw) < _FILEHEADER.size:
            raise _bad(path, f"file is {size} bytes, shorter than the 44-byte CINEFILEHEADER")
        (typ, hsize, compression, _version, _first_movie, _total, first_no, count,
         off_bih, off_setup, off_offsets, _tfrac, _tsec) = _FILEHEADER.unpack(raw)
        if typ != b"CI":
            raise _bad(path, f"signature {typ!r}, expected b'CI'")
        if compression != 0:
            raise _bad(path, f"Compression={compression} (1 = JPEG, 2 = raw Bayer); "
                       "only uncompressed gray cines (0) are supported")
        if off_bih + _BITMAPINFO.size > size:
            raise _bad(path, f"OffImageHeader={off_bih} points past the end of the file ({size} bytes)")
        fh.seek(off_bih)
        (_bisize, width, height, _planes, bitcount, bicomp, sizeimage, _xppm, _yppm,
         _clrused, _clrimp) = _BITMAPINFO.unpack(fh.read(_BITMAPINFO.size))
        if bicomp != 0:
            packed = " (packed 10/12-bit pixels)" if bicomp in (256, 1024) else ""
            raise _bad(path, f"biCompression={bicomp}{packed}; only uncompressed 8- or 16-bit images (0) are "
                       "supported: save the cine unpacked (16 bit) from the camera software")
        if bitcount not in (8, 16):
            raise _bad(path, f"biBitCount={bitcount}; only 8- and 16-bit gray images are supported "
                       "(packed 10/12-bit and colour cines are not)")
        if width <= 0 or height == 0:
            raise _bad(path, f"image size {width} x {height} px")
        bottom_up = height > 0
        height = abs(height)
        bpp = bitcount // 8
        if sizeimage == 0:
            sizeimage = width * height * bpp
        if sizeimage % height or sizeimage // height < width * bpp:
            raise _bad(path, f"biSizeImage={sizeimage} does not fit {width} x {height} x {bpp} bytes")
        fps: float | None = None
        real_bpp = bitcount
        setup_length = 0
        if off_setup + 2 <= size:
            fh.seek(off_setup)
            setup = fh.read(_SETUP_WRITE_LENGTH)
            if len(setup) >= 2:
                fr16 = struct.unpack_from("<H", setup, 0)[0]
                fps = float(fr16) if fr16 else None
            marked = setup[_SETUP_MARK_OFFSET:_SETUP_MARK_OFFSET + 2] == b"ST"
            if len(setup) >= _SETUP_LENGTH_OFFSET + 2 and marked:
                length = struct.unpack_from("<H", setup, _SETUP_LENGTH_OFFSET)[0]
                setup_length = int(length)
                if length >= _SETUP_FRAMERATE_OFFSET + 4 and len(setup) >= _SETUP_FRAMERATE_OFFSET + 4:
                    fr = struct.unpack_from("<I", setup, _SETUP_FRAMERATE_OFFSET)[0]
                    fps = float(fr) if fr else fps
                if length >= _SETUP_REALBPP_OFFSET + 4 and len(setup) >= _SETUP_REALBPP_OFFSET + 4:
                    rb = struct.unpack_from("<I", setup, _SETUP_REALBPP_OFFSET)[0]
                    if 0 < rb <= bitcount:
                        real_bpp = int(rb)
        stamps = _time_stamps(fh, off_setup, off_offsets, count, setup_length)
        if off_offsets + 8 * count > size:
            raise _bad(path, f"the pointer array of {count} images at offset {off_offsets} runs past "
                       f"the end of the file ({size} bytes): the file is truncated")
        fh.seek(off_offsets)
        offsets = np.frombuffer(fh.read(8 * count), dtype="<i8").astype(np.int64)
    if hsize != _FILEHEADER.size:
        log.warning("%s: CINEFILEHEADER Headersize=%d (expected 44)", path, hsize)
    return CineHeader(path=path, width=int(width), height=int(height), bit_count=int(bitcount),
                      real_bpp=real_bpp, image_count=int(count), first_image_no=int(first_no),
                      fps=fps, image_offsets=offsets, bottom_up=bottom_up,
                      image_size=int(sizeimage), file_size=int(size), timestamps_s=stamps)


def _time_stamps(fh, off_setup: int, off_offsets: int, count: int, setup_length: int) -> np.ndarray | None:
    """Per-image times in s relative to the first image, from the time-only tagged block
    between the end of SETUP and the pointer array; None when there is none (or the SETUP's
    length is unknown, so the blocks cannot be located)."""
    if setup_length <= 0 or count < 2:
        return None
    pos, end = off_setup + setup_length, off_offsets
    while pos + _BLOCK_HEAD.size <= end:
        fh.seek(pos)
        block_size, kind, _ = _BLOCK_HEAD.unpack(fh.read(_BLOCK_HEAD.size))
        if block_size < _BLOCK_HEAD.size or pos + block_size > end:
            return None  # not a tagged block: nothing reliable here
        if kind == TIME_ONLY_BLOCK and (block_size - _BLOCK_HEAD.size) // 8 >= count:
            raw = np.frombuffer(fh.read(8 * count), dtype="<u4").reshape(count, 2).astype(np.int64)
            ticks = raw[:, 1] * 2**32 + raw[:, 0]  # TIME64: seconds and 2^-32 s fractions
            return (ticks - ticks[0]).astype(np.float64) / 2.0**32
        pos += block_size
    return None


def write_cine(path: str | os.PathLike, frames, *, fps: float = 1000.0, real_bpp: int | None = None,
               annotation: bytes = b"", timestamps_s=None) -> None:
    """Write gray frames as an uncompressed ``.cine`` file (the documented layout).

    Written for tests and for converting recordings; the file is written to a temporary
    name and moved into place.

    Parameters
    ----------
    path : path-like
        Output file.
    frames : (n_frames, height, width) uint8 or uint16 ndarray, or an iterable of 2-D frames
        The images, top row first; they are stored bottom-up like the camera's files.
    fps : float
        Frame rate in Hz written to SETUP (``FrameRate``, rounded to an integer).
    real_bpp : int, optional
        Significant bits per pixel (default 8 or 16 from the dtype).
    annotation : bytes
        Annotation bytes stored before every image.
    timestamps_s : (n_frames,) array_like, optional
        Time of each image in s (relative to any origin, non-decreasing), written as a
        time-only tagged block (TIME64 per image) after SETUP, as the cameras do. Without
        it the file has no time stamps, only the nominal ``fps``.
    """
    path = os.fspath(path)
    arr = np.asarray(frames)
    if arr.ndim != 3 or arr.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"frames must be a (n, h, w) uint8 or uint16 array, got {arr.shape} {arr.dtype}")
    if not (np.isfinite(fps) and fps > 0):
        raise ValueError(f"fps must be a positive frame rate in Hz, got {fps!r}")
    n, h, w = arr.shape
    bitcount = 8 * arr.dtype.itemsize
    rb = bitcount if real_bpp is None else int(real_bpp)
    img_size = h * w * arr.dtype.itemsize
    block = b""
    if timestamps_s is not None:
        ts = np.asarray(timestamps_s, dtype=np.float64)
        if ts.shape != (n,) or not np.all(np.isfinite(ts)) or np.any(np.diff(ts) < 0):
            raise ValueError(f"timestamps_s must be {n} finite non-decreasing times in s, "
                             f"got shape {ts.shape}")
        ticks = np.rint((ts - ts[0]) * 2.0**32).astype(np.int64) + 1_000_000 * 2**32  # an arbitrary epoch
        pairs = np.stack([ticks % 2**32, ticks // 2**32], axis=1).astype("<u4")
        block = _BLOCK_HEAD.pack(_BLOCK_HEAD.size + 8 * n, TIME_ONLY_BLOCK, 1) + pairs.tobytes()
    off_bih = _FILEHEADER.size
    off_setup = off_bih + _BITMAPINFO.size
    off_offsets = off_setup + _SETUP_WRITE_LENGTH + len(block)
    first_image = off_offsets + 8 * n
    ann_size = 8 + len(annotation)
    offsets = first_image + np.arange(n, dtype=np.int64) * (ann_size + img_size)
    setup = bytearray(_SETUP_WRITE_LENGTH)
    struct.pack_into("<H", setup, 0, min(int(round(fps)), 65535))
    setup[_SETUP_MARK_OFFSET:_SETUP_MARK_OFFSET + 2] = b"ST"
    struct.pack_into("<H", setup, _SETUP_LENGTH_OFFSET, _SETUP_WRITE_LENGTH)
    struct.pack_into("<HH", setup, _SETUP_IMWIDTH_OFFSET, w, h)
    struct.pack_into("<I", setup, _SETUP_FRAMERATE_OFFSET, int(round(fps)))
    struct.pack_into("<I", setup, _SETUP_REALBPP_OFFSET, rb)

    def write(tmp) -> None:
        with open(tmp, "wb") as fh:
            fh.write(_FILEHEADER.pack(b"CI", _FILEHEADER.size, 0, 1, 0, n, 0, n, off_bih, off_setup,
                                      off_offsets, 0, 0))
            fh.write(_BITMAPINFO.pack(_BITMAPINFO.size, w, h, 1, bitcount, 0, img_size, 0, 0, 0, 0))
            fh.write(bytes(setup))
            fh.write(block)
            fh.write(offsets.astype("<i8").tobytes())
            dt = np.dtype("<u2") if bitcount == 16 else np.dtype(np.uint8)
            for k in range(n):
                fh.write(struct.pack("<I", ann_size))
                fh.write(annotation)
                fh.write(struct.pack("<I", img_size))
                fh.write(np.ascontiguousarray(arr[k, ::-1], dtype=dt).tobytes())

    atomic_write(path, write)
