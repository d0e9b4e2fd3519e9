import struct

import numpy as np
import pytest

from fingerfriction.video.cine import read_cine_header, write_cine
from fingerfriction.video.readers import CineReader, open_video


@pytest.mark.parametrize("dtype,real_bpp", [(np.uint8, 8), (np.uint16, 12)])
def test_cine_round_trip(tmp_path, dtype, real_bpp):
    rng = np.random.default_rng(3)
    hi = 255 if dtype == np.uint8 else 4095
    frames = rng.integers(0, hi + 1, (9, 30, 44)).astype(dtype)
    p = tmp_path / "a.cine"
    write_cine(p, frames, fps=1000.0, real_bpp=real_bpp, annotation=b"note")
    hdr = read_cine_header(p)
    assert (hdr.width, hdr.height, hdr.image_count) == (44, 30, 9)
    assert hdr.bit_count == 8 * np.dtype(dtype).itemsize and hdr.real_bpp == real_bpp
    assert hdr.fps == 1000.0 and hdr.bottom_up
    with open_video(p) as r:
        assert isinstance(r, CineReader) and r.dtype == dtype
        got = np.concatenate([c.copy() for _, c in r.iter_chunks(4)])
        np.testing.assert_array_equal(got, frames)
        np.testing.assert_array_equal(r.read_frame(5), frames[5])
        assert not r.truncated


def test_cine_layout_is_the_documented_one(tmp_path):
    """Bytes at the documented offsets, independently of the reader."""
    frames = np.arange(2 * 4 * 8, dtype=np.uint8).reshape(2, 4, 8)
    p = tmp_path / "b.cine"
    write_cine(p, frames, fps=250)
    raw = p.read_bytes()
    assert raw[:2] == b"CI"
    typ, hsize, comp, ver, _, total, _, count, off_bih, off_setup, off_img = struct.unpack_from(
        "<2sHHHiIiIIII", raw, 0)
    assert (hsize, comp, ver, count) == (44, 0, 1, 2)
    assert struct.unpack_from("<Iii", raw, off_bih) == (40, 8, 4)
    assert raw[off_setup + 140:off_setup + 142] == b"ST"
    assert struct.unpack_from("<I", raw, off_setup + 768)[0] == 250
    p0 = struct.unpack_from("<q", raw, off_img)[0]
    ann = struct.unpack_from("<I", raw, p0)[0]
    img = np.frombuffer(raw[p0 + ann:p0 + ann + 32], np.uint8).reshape(4, 8)
    np.testing.assert_array_equal(img[::-1], frames[0])  # stored bottom-up


def test_truncated_cine_gives_read_frames_and_flag(tmp_path):
    frames = np.random.default_rng(0).integers(0, 256, (6, 20, 24), dtype=np.uint8)
    p = tmp_path / "t.cine"
    write_cine(p, frames)
    data = p.read_bytes()
    p.write_bytes(data[: len(data) - 20 * 24 - 100])  # cut into image 4, drop image 5
    with open_video(p) as r:
        assert r.n_frames == 6
        got = [(i, c.copy()) for i, c in r.iter_chunks(2)]
        n = sum(c.shape[0] for _, c in got)
        assert n == 4 and r.truncated and "truncated" in r.error
        np.testing.assert_array_equal(np.concatenate([c for _, c in got]), frames[:4])
        with pytest.raises(ValueError, match="frame 5 cannot be read"):
            r.read_frame(5)


def test_bad_cine_files_name_the_file(tmp_path):
    p = tmp_path / "x.cine"
    p.write_bytes(b"NOTACINE" * 10)
    with pytest.raises(ValueError, match=r"x\.cine.*signature"):
        open_video(p)
    p.write_bytes(b"CI")
    with pytest.raises(ValueError, match="shorter than the 44-byte"):
        open_video(p)
    frames = np.zeros((2, 8, 8), np.uint8)
    write_cine(p, frames)
    raw = bytearray(p.read_bytes())
    struct.pack_into("<H", raw, 4, 1)  # Compression = JPEG
    p.write_bytes(bytes(raw))
    with pytest.raises(ValueError, match="only uncompressed gray"):
        open_video(p)


# --- real files written by Phantom cameras (tests/data/README.md) --------------------------

REAL = __import__("pathlib").Path(__file__).resolve().parents[1] / "data" / "cine"


def _all_frames(path):
    with open_video(path) as r:
        return r, np.concatenate([c.copy() for _, c in r.iter_chunks(64)])


def _as_function(src: np.ndarray, dst: np.ndarray) -> dict:
    """{value in src: value in dst}, asserting each src value maps to one dst value."""
    out: dict = {}
    for a, b in zip(src.ravel().tolist(), dst.ravel().tolist(), strict=True):
        assert out.setdefault(a, b) == b, f"pixel value {a} exported as both {out[a]} and {b}"
    return out


@pytest.mark.parametrize("name,bits", [("8bpp", 8), ("12bpp", 12)])
def test_phantom_files_pixel_for_pixel_with_phantoms_tiff_export(name, bits):
    """Frame 0 against Phantom Camera Control's own TIFF export of it: the export is a
    16-bit image after PCC's black offset, so every pixel of a given value in our frame
    must be exported as one and the same value (rows in the same order: the file is stored
    bottom-up), increasing with it; at 8 bit the export is exactly ``max(v - 5, 0) * 256``."""
    import tifffile

    r, frames = _all_frames(REAL / f"{name}.cine")
    assert frames.shape == (202, 16, 128) and r.fps == 10_000.0 and not r.truncated
    assert r.dtype == (np.uint8 if bits == 8 else np.uint16) and r.header.real_bpp == bits
    export = tifffile.imread(REAL / f"{name}.tif").astype(np.int64)
    ours = frames[0].astype(np.int64)
    lut = _as_function(ours, export)
    values = sorted(lut)
    assert np.all(np.diff([lut[v] for v in values]) >= 0) and len(values) > 20
    if bits == 8:
        np.testing.assert_array_equal(export, np.maximum(ours - 5, 0) * 256)
    with pytest.raises(AssertionError):  # a reader that flipped the rows would not agree
        _as_function(ours[::-1], export)


def test_phantom_8_and_12_bit_recordings_of_one_scene_agree():
    """The 8- and 12-bit files hold the same 202 frames: the 8-bit pixels are the 12-bit
    ones without their 4 low bits, in every pixel of every frame."""
    _, f8 = _all_frames(REAL / "8bpp.cine")
    _, f12 = _all_frames(REAL / "12bpp.cine")
    np.testing.assert_array_equal(f8.astype(np.int64), f12.astype(np.int64) >> 4)


def test_packed_10_bit_phantom_file_is_refused_with_a_clear_message():
    with pytest.raises(ValueError, match=r"packed_10.cine: not a readable Phantom cine file: "
                                         r"biCompression=256 \(packed 10/12-bit pixels\); .*"
                                         r"save the cine unpacked"):
        open_video(REAL / "packed_10.cine")
