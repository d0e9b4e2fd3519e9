import numpy as np
import pytest
import tifffile

from fingerfriction.video.readers import AVReader, MultiPageTiffReader, TiffStackReader, open_video
from fingerfriction.video.writers import write_video


@pytest.fixture(scope="module")
def frames():
    rng = np.random.default_rng(7)
    return rng.integers(0, 256, (11, 36, 52), dtype=np.uint8)


def _read_all(r, chunk=4):
    starts, out = [], []
    for i, c in r.iter_chunks(chunk):
        assert c.ndim == 3 and c.shape[1:] == r.shape
        starts.append(i)
        out.append(c.copy())
    return starts, np.concatenate(out)


@pytest.mark.parametrize("ext,cls", [("mkv", AVReader), ("avi", AVReader), ("mp4", AVReader),
                                     ("tif", MultiPageTiffReader)])
def test_round_trip_lossless(tmp_path, frames, ext, cls):
    p = write_video(tmp_path / f"v.{ext}", frames, fps=1000.0)
    with open_video(p) as r:
        assert isinstance(r, cls)
        assert r.n_frames == 11 and r.shape == (36, 52) and r.dtype == np.uint8
        if cls is AVReader:
            assert r.fps == pytest.approx(1000.0)
        starts, got = _read_all(r)
        assert starts == [0, 4, 8]
        np.testing.assert_array_equal(got, frames)
        assert not r.truncated
        np.testing.assert_array_equal(r.read_frame(9), frames[9])
        np.testing.assert_array_equal(r.read_frame(2), frames[2])  # seeks back


def test_tiff_stack_folder_natural_order(tmp_path, frames):
    for i, fr in enumerate(frames):
        tifffile.imwrite(tmp_path / f"img_{i}.tif", fr)  # img_10 sorts after img_9
    with open_video(tmp_path) as r:
        assert isinstance(r, TiffStackReader) and r.n_frames == 11
        _, got = _read_all(r, chunk=5)
        np.testing.assert_array_equal(got, frames)


def test_sixteen_bit_tiff(tmp_path):
    fr = np.random.default_rng(1).integers(0, 4096, (3, 10, 12)).astype(np.uint16)
    tifffile.imwrite(tmp_path / "s.tif", fr, photometric="minisblack")
    with open_video(tmp_path / "s.tif") as r:
        assert r.dtype == np.uint16
        np.testing.assert_array_equal(_read_all(r)[1], fr)


def test_chunk_range(tmp_path, frames):
    p = write_video(tmp_path / "v.mkv", frames)
    with open_video(p) as r:
        got = [(i, c.shape[0]) for i, c in r.iter_chunks(3, start=2, stop=9)]
        assert got == [(2, 3), (5, 3), (8, 1)]
        with pytest.raises(ValueError, match="chunk_size"):
            next(r.iter_chunks(0))


def test_truncated_mkv_flags(tmp_path, frames):
    big = np.repeat(frames, 4, axis=0)  # 44 frames
    p = write_video(tmp_path / "v.mkv", big)
    data = p if isinstance(p, str) else str(p)
    raw = open(data, "rb").read()
    open(data, "wb").write(raw[: len(raw) // 2])
    with open_video(data) as r:
        _, got = _read_all(r, chunk=8)
        assert 0 < got.shape[0] < 44
        assert r.truncated and r.error
        np.testing.assert_array_equal(got, big[: got.shape[0]])


def test_truncated_tiff_stack_file(tmp_path, frames):
    for i, fr in enumerate(frames[:5]):
        tifffile.imwrite(tmp_path / f"f{i}.tif", fr)
    (tmp_path / "f3.tif").write_bytes(b"II*\x00garbage")
    with open_video(tmp_path) as r:
        _, got = _read_all(r, chunk=2)
        assert got.shape[0] == 3 and r.truncated and "f3.tif" in r.error


def test_unusable_inputs_raise_clear_errors(tmp_path):
    with pytest.raises(ValueError, match="no such video"):
        open_video(tmp_path / "missing.mkv")
    (tmp_path / "a.xyz").write_bytes(b"x")
    with pytest.raises(ValueError, match="unknown video extension"):
        open_video(tmp_path / "a.xyz")
    (tmp_path / "bad.mkv").write_bytes(b"\x00" * 100)
    with pytest.raises(ValueError, match=r"bad\.mkv"):
        open_video(tmp_path / "bad.mkv")
    (tmp_path / "bad.tif").write_bytes(b"\x00" * 100)
    with pytest.raises(ValueError, match=r"bad\.tif"):
        open_video(tmp_path / "bad.tif")
    (tmp_path / "empty").mkdir()
    with pytest.raises(ValueError, match="no .tif"):
        open_video(tmp_path / "empty")


@pytest.mark.parametrize("ext,fmt,fps", [("mkv", "mkv", 500.0), ("cine", "cine", 1250.0),
                                         ("tif", "tiff", None)])
def test_probe_video_reads_the_header(tmp_path, frames, ext, fmt, fps):
    from fingerfriction.video.readers import probe_video

    p = write_video(tmp_path / f"v.{ext}", frames, fps=fps or 1000.0)
    info = probe_video(p)
    assert (info.format, info.n_frames, info.width, info.height, info.dtype) == (fmt, 11, 52, 36, "uint8")
    # a TIFF written without ImageJ metadata does not say its rate
    assert info.fps == (pytest.approx(fps) if fps else None)


def test_probe_video_tiff_folder_and_is_video_path(tmp_path, frames):
    from fingerfriction.video.readers import is_video_path, probe_video

    d = tmp_path / "S1_bump_40mms_1"
    d.mkdir()
    for i, fr in enumerate(frames[:4]):
        tifffile.imwrite(d / f"f{i:03d}.tif", fr)
    info = probe_video(d)
    assert (info.format, info.n_frames, info.fps) == ("tiff", 4, None)
    (tmp_path / "notes.txt").write_text("x")
    assert is_video_path(d) and is_video_path(tmp_path / "a.CINE")
    assert not is_video_path(tmp_path / "notes.txt")
    assert not is_video_path(tmp_path / "forces.tdms")
    with pytest.raises(ValueError, match="no such video file"):
        probe_video(tmp_path / "missing.cine")
