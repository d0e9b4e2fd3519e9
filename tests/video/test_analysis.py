import numpy as np
import pytest

from fingerfriction.regions import as_regions
from fingerfriction.surfaces import RaisedCosine
from fingerfriction.video import AnalysisOptions, FrameFlag, analyze_video
from fingerfriction.video.writers import write_video

from .synth import render, render_video

SURF = RaisedCosine("bump", 2.0)


@pytest.fixture(scope="module")
def video(tmp_path_factory):
    """Calibration frame, 6 finger frames, a finger-free frame, a black frame, 2 frames
    with the finger leaving the field of view on the right."""
    xs = np.linspace(-6.5, -3.5, 6)
    frames = list(render_video(xs, surface=SURF, noise=2.0))
    frames.append(render(surface=SURF, noise=2.0)[0])  # finger missing
    frames.append(np.zeros_like(frames[0]))  # all dark: no contour at this threshold
    for x in (12.0, 14.0):  # C_f cut by the crop's right side
        frames.append(render(surface=SURF, finger=(x, -0.15, 8.0), noise=2.0)[0])
    path = tmp_path_factory.mktemp("v") / "trial.mkv"
    write_video(path, np.stack(frames))
    return path, xs


@pytest.mark.slow
def test_end_to_end_and_flags(video):
    path, xs = video
    res = analyze_video(path, 0.4, surface=SURF, options=AnalysisOptions(chunk_size=4))
    assert res.n_frames == 11 and res.success and not res.truncated
    assert res.calibration.level_method == "otsu" and 100 < res.threshold < 150
    assert res.mm_per_px == pytest.approx(0.023, rel=3e-3)
    f = res.flags
    assert f[0] & FrameFlag.CALIBRATION and f[0] & FrameFlag.FINGER_MISSING
    assert (f[1:7] == 0).all()
    assert f[7] == FrameFlag.FINGER_MISSING
    assert f[8] == FrameFlag.NO_CONTOUR
    assert (f[9:] == FrameFlag.OUT_OF_VIEW).all()
    assert np.isnan(res.x[f != 0]).all() and np.isnan(res.regions[f != 0]).all()
    assert np.abs(res.x[1:7] - xs).max() < 0.02
    as_regions(res.regions)
    assert (res.n_regions[1:7] == 1).all()  # one flat contact left of the bump
    assert res.reasons(8)[0].startswith("threshold leaves no usable contour: the finger zone is "
                                        "(almost) all dark")
    assert res.reasons(3) == []
    assert res.flag_counts() == {"CALIBRATION": 1, "FINGER_MISSING": 2, "NO_CONTOUR": 1,
                                 "OUT_OF_VIEW": 2}
    assert res.timings["frames_per_s"] > 0


@pytest.mark.slow
def test_same_result_in_every_format(video, tmp_path):
    path, _ = video
    ref = analyze_video(path, 0.4, surface=SURF)
    from fingerfriction.video import open_video

    with open_video(path) as r:
        frames = np.concatenate([c.copy() for _, c in r.iter_chunks(16)])
    for ext in ("cine", "tif"):
        p = write_video(tmp_path / f"v.{ext}", frames)
        res = analyze_video(p, 0.4, surface=SURF)
        np.testing.assert_array_equal(res.flags, ref.flags)
        np.testing.assert_allclose(res.x, ref.x, equal_nan=True)


@pytest.mark.slow
def test_truncated_video_flags_missing_frames(video, tmp_path):
    path, _ = video
    from fingerfriction.video import open_video

    with open_video(path) as r:
        frames = np.concatenate([c.copy() for _, c in r.iter_chunks(16)])
    p = tmp_path / "cut.cine"
    write_video(p, frames)
    raw = p.read_bytes()
    p.write_bytes(raw[: len(raw) - 3 * 1280 * 720 - 500])  # last 3+ images lost
    res = analyze_video(p, 0.4, surface=SURF)
    assert res.truncated and "truncated" in res.message
    assert (res.flags[-4:] == FrameFlag.CORRUPT).all() and np.isnan(res.x[-4:]).all()
    assert (res.flags[1:7] == 0).all()
    # the manifest's frame count also reveals a file that simply holds fewer frames
    short = tmp_path / "short.mkv"
    write_video(short, frames[:5])
    res = analyze_video(short, 0.4, surface=SURF, n_frames=11)
    assert res.truncated and (res.flags[5:] == FrameFlag.CORRUPT).all()


@pytest.mark.slow
def test_threshold_leaving_no_contour_is_a_clear_error(video):
    path, _ = video
    with pytest.raises(ValueError, match=r"trial\.mkv.*calibration frame 0.*leaves no contour"):
        analyze_video(path, 0.4, options=AnalysisOptions(level=255))
    with pytest.raises(ValueError, match="contact_metric"):
        AnalysisOptions(contact_metric="manhattan")
    with pytest.raises(ValueError, match="calibration_frame 50"):
        analyze_video(path, 0.4, options=AnalysisOptions(calibration_frame=50))


def test_frames_with_only_a_lifted_finger_are_flagged(tmp_path):
    """After the reference frame, a finger lifted to the top of the crop cannot enclose A."""
    frames = [render(surface=SURF)[0], render(surface=SURF, finger=(-4.0, -0.15, 8.0))[0],
              render(surface=SURF, finger=(-4.0, 7.6, 8.0))[0]]
    p = write_video(tmp_path / "lift.mkv", np.stack(frames))
    res = analyze_video(p, 0.4, surface=SURF)
    assert res.flags[1] == 0 and res.flags[2] == FrameFlag.AREA_UNREACHABLE


@pytest.mark.slow
def test_result_save_is_readable_without_pickle(video, tmp_path):
    path, _ = video
    res = analyze_video(path, 0.4, surface=SURF)
    out = tmp_path / "r.npz"
    res.save(out)
    with np.load(out, allow_pickle=False) as z:
        np.testing.assert_array_equal(z["flags"], res.flags)
        np.testing.assert_allclose(z["x"], res.x, equal_nan=True)
        assert float(z["mm_per_px"]) == res.mm_per_px
    assert not list(tmp_path.glob("*.tmp*"))


def test_a_finger_wider_than_the_view_is_out_of_view_not_no_contour(tmp_path):
    frames = [render(surface=SURF)[0], render(surface=SURF, finger=(-4.0, -0.15, 8.0))[0],
              render(surface=SURF, finger=(-4.0, -0.05, 1000.0))[0]]  # flat, every column
    p = write_video(tmp_path / "wide.mkv", np.stack(frames))
    res = analyze_video(p, 0.4, surface=SURF)
    assert res.flags[1] == 0 and res.flags[2] == FrameFlag.OUT_OF_VIEW


@pytest.mark.slow
def test_position_option_selects_the_chord_midpoint(video):
    path, xs = video
    cf = analyze_video(path, 0.4, surface=SURF)
    ch = analyze_video(path, 0.4, surface=SURF, options=AnalysisOptions(position="chord"))
    np.testing.assert_array_equal(ch.x, ch.x_chord)
    np.testing.assert_array_equal(cf.x, cf.x_cf)
    np.testing.assert_allclose(ch.x_cf, cf.x_cf, equal_nan=True)  # C_f always computed
    assert np.abs(ch.x[1:7] - xs).max() < 0.02
    with pytest.raises(ValueError, match="position"):
        AnalysisOptions(position="nose")


def test_sixteen_bit_cine_gives_the_same_positions(tmp_path):
    xs = np.linspace(-6.0, -4.0, 3)
    v8 = render_video(xs, surface=SURF, noise=1.0)
    v16 = render_video(xs, surface=SURF, noise=1.0, dtype=np.uint16)
    assert v16.dtype == np.uint16
    p8 = write_video(tmp_path / "a.cine", v8)
    p16 = write_video(tmp_path / "b.cine", v16)
    r8 = analyze_video(p8, 0.4, surface=SURF)
    r16 = analyze_video(p16, 0.4, surface=SURF)
    assert r16.calibration.level > 255  # Otsu on the 16-bit scale
    assert (r16.flags == r8.flags).all()
    np.testing.assert_allclose(r16.x[1:], xs, atol=0.02)
    np.testing.assert_allclose(r16.x[1:], r8.x[1:], atol=0.005)


@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    """A rigid disc finger over the whole 26 mm window, then one lifted frame far right."""
    xs = np.array([-13.0, -11.5, -10.0, -9.0, -8.5, -8.0, -4.0, 0.0, 4.0, 8.0, 8.5, 9.0, 10.0, 11.5, 13.0])
    frames = list(render_video(xs, surface=SURF, noise=2.0))
    frames.append(render(surface=SURF, finger=(11.0, 1.0, 8.0), noise=2.0)[0])  # lifted by 1 mm
    path = tmp_path_factory.mktemp("sweep") / "sweep.mkv"
    write_video(path, np.stack(frames))
    return path, xs


@pytest.mark.slow
def test_hybrid_position_covers_the_window(sweep):
    from fingerfriction.video import PositionSource

    path, xs = sweep
    res = analyze_video(path, 0.4, surface=SURF, options=AnalysisOptions(position="hybrid"))
    fin = slice(1, 1 + xs.size)
    assert (res.flags[fin] == 0).all()
    assert np.abs(res.x[fin] - xs).max() < 0.02  # mm, no offset removed: chord and edges agree
    src = res.x_source[fin]
    assert (src[np.abs(xs) <= 8.5] == PositionSource.CHORD).all()
    assert (src[xs >= 9] == PositionSource.LEFT_EDGE).all()
    assert (src[xs <= -9] == PositionSource.RIGHT_EDGE).all()
    # the offsets are measured: the disc's half-width at the edge row, 4 mm above the
    # bump's top (0.4 mm), i.e. 4.55 mm above the disc's lowest point (pressed 0.15 mm in)
    w = np.sqrt(8.0**2 - (8.0 - 4.55) ** 2)
    assert res.hybrid["offsets_mm"]["left"] == pytest.approx(w, abs=0.03)
    assert res.hybrid["offsets_mm"]["right"] == pytest.approx(-w, abs=0.03)
    # contact regions in every positioned frame, also where C_f is out of view
    assert (res.n_regions[fin] >= 1).all()
    assert np.isnan(res.x_cf[fin][np.abs(xs) >= 11.5]).all()
    # the lifted finger beyond the chord's range: its edges are no position
    assert res.flags[-1] & FrameFlag.NO_HYBRID and np.isnan(res.x[-1])
    assert res.x_source[-1] == PositionSource.NONE and np.isnan(res.regions[-1]).all()
    assert "no hybrid position" in res.reasons(len(res.x) - 1)[-1]


@pytest.mark.slow
def test_default_position_unchanged_and_hybrid_always_reported(sweep):
    path, xs = sweep
    cf = analyze_video(path, 0.4, surface=SURF)
    hy = analyze_video(path, 0.4, surface=SURF, options=AnalysisOptions(position="hybrid"))
    np.testing.assert_array_equal(cf.x, cf.x_cf)
    out = np.abs(xs) >= 11.5
    assert (cf.flags[1:1 + xs.size][out] == FrameFlag.OUT_OF_VIEW).all()  # C_f cut: flagged
    assert np.isnan(cf.regions[1:1 + xs.size][out]).all()
    np.testing.assert_array_equal(cf.x_hybrid, hy.x)  # computed in every mode
    np.testing.assert_array_equal(cf.x_source, hy.x_source)
    ok = cf.flags == 0
    np.testing.assert_allclose(hy.x_cf[ok], cf.x_cf[ok])
    np.testing.assert_allclose(hy.regions[ok], cf.regions[ok][:, : hy.regions.shape[1]], equal_nan=True)


@pytest.mark.slow
@pytest.mark.parametrize("position", ["cf-centroid", "hybrid"])
def test_more_regions_than_n_max_is_flagged_not_raised(tmp_path, position):
    """A frame whose contact has more regions than n_max_regions is flagged (with its
    reason, no position, no regions); the others are unaffected."""
    xs = [-6.0, -3.0, -2.8, -6.0]  # near -3 mm: contact left of the bump and on its flank
    frames = list(render_video(xs, surface=SURF, z_mm=-0.1, noise=1.0))
    p = write_video(tmp_path / "two.mkv", np.stack(frames))
    ref = analyze_video(p, 0.4, surface=SURF, options=AnalysisOptions(position=position))
    two = np.flatnonzero(ref.n_regions == 2)
    assert two.size >= 1 and (ref.flags[two] == 0).all()
    res = analyze_video(p, 0.4, surface=SURF, options=AnalysisOptions(position=position, n_max_regions=1))
    assert (res.flags[two] & FrameFlag.TOO_MANY_REGIONS).all()
    assert FrameFlag.TOO_MANY_REGIONS == FrameFlag.NO_CONTOUR  # alias: uint8 flags are full
    assert "more than n_max_regions" in res.reasons(int(two[0]))[0]
    assert np.isnan(res.x[two]).all() and np.isnan(res.regions[two]).all()
    assert np.isnan(res.x_cf[two]).all() and np.isnan(res.x_hybrid[two]).all()
    assert (res.x_source[two] == 0).all()  # PositionSource.NONE
    other = np.flatnonzero(ref.n_regions == 1)
    assert other.size >= 1
    np.testing.assert_array_equal(res.flags[other], ref.flags[other])
    np.testing.assert_allclose(res.x[other], ref.x[other])
    np.testing.assert_allclose(res.regions[other, :1], ref.regions[other, :1])


@pytest.mark.slow
def test_regions_cut_by_the_crop_edge_are_marked_clipped(sweep, tmp_path):
    path, xs = sweep
    res = analyze_video(path, 0.4, surface=SURF, options=AnalysisOptions(position="hybrid"))
    fin = slice(1, 1 + xs.size)
    # the disc (R = 8 mm, 0.15 mm in) touches over +-1.55 mm: at x = +-13 mm that passes the
    # crop's edges (columns 10 and 1269: -14.50 and +14.46 mm); at +-11.5 mm it does not
    np.testing.assert_array_equal(res.clipped[fin], np.abs(xs) >= 13.0)
    assert not res.clipped[0] and not res.clipped[-1]
    lo, hi = np.nanmin(res.regions[fin]), np.nanmax(res.regions[fin])
    # half a column outside the crop (to within the calibrated scale and origin)
    assert lo == pytest.approx((9.5 - 640.3) * 0.023, abs=0.03)
    assert hi == pytest.approx((1269.5 - 640.3) * 0.023, abs=0.03)
    res.save(tmp_path / "r.npz")
    with np.load(tmp_path / "r.npz", allow_pickle=False) as z:
        np.testing.assert_array_equal(z["clipped"], res.clipped)
