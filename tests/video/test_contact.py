import numpy as np
import pytest
from scipy.spatial import cKDTree

from fingerfriction.regions import as_regions, n_regions
from fingerfriction.surfaces import RaisedCosine
from fingerfriction.video import AnalysisOptions, FrameAnalyzer, calibrate
from fingerfriction.video.contact import contact_distance, contact_regions
from fingerfriction.video.contours import lower_envelope, trace_contours

from .synth import render


def test_hand_made_frame_regions():
    # flat surface at row 20; finger outline touching over columns 3..5 and 10..11
    s = np.full(16, 20.0)
    f = np.full((1, 16), 10.0)
    f[0, 3:6] = 20.0
    f[0, 10:12] = 18.0
    f[0, 12] = 16.0  # gap 4 > 3: out
    f[0, 0] = np.nan
    d = contact_distance(f, s, metric="vertical")
    np.testing.assert_allclose(d[0, 1:4], [10, 10, 0])
    reg = contact_regions(d, 3.0, lambda c: np.asarray(c, float) * 0.5)
    as_regions(reg)
    # run 3..5: starts between col 2 (d=10) and 3 (d=0): crossing at 2 + 7/10
    assert reg[0, 0, 0] == pytest.approx((2 + 0.7) * 0.5)
    assert reg[0, 0, 1] == pytest.approx((5 + 0.3) * 0.5)
    # run 10..11: ends between col 11 (d=2) and col 12 (d=4) at 11.5
    assert reg[0, 1, 1] == pytest.approx(11.5 * 0.5)
    assert np.isnan(reg[0, 2:]).all()


def test_euclidean_distance_sees_the_slope():
    s = np.arange(20, dtype=float)  # 45 degree slope: the surface falls to the right
    f = np.full((1, 20), np.nan)
    f[0, 8:13] = s[8:13] - 3.5  # finger outline parallel, vertical gap 3.5 px
    dv = contact_distance(f, s, metric="vertical")[0, 10]
    de = contact_distance(f, s, metric="euclidean")[0, 10]
    assert dv == pytest.approx(3.5)
    assert de == pytest.approx(3.5 / np.sqrt(2), abs=0.4)  # perpendicular, sampled at columns
    assert de <= 3.0 < dv
    # no finger within reach: NaN, not a distance
    assert np.isnan(contact_distance(f, s)[0, 0])


@pytest.mark.parametrize("fx", [-3.0, -0.9, 0.6])
def test_outline_test_equals_brute_force_over_all_contour_points(fx):
    """Contact columns from the outlines == columns of the surface contour points that lie
    within 3 px of ANY finger contour point (pixel centres: the paper's pairs)."""
    surf = RaisedCosine("bump", 2.0)
    frame, _ = render(surface=surf, finger=(fx, -0.12, 8.0), blur=0.0)
    crop = frame[180:540, 10:1270]
    dark = (crop <= 125).astype(np.uint8)
    surf_dark = (render(surface=surf, blur=0.0)[0][180:540, 10:1270] <= 125)
    first = np.argmax(surf_dark, axis=0)
    zone = np.arange(360)[:, None] < first[None, :] - 1
    finger = (dark.astype(bool) & zone).astype(np.uint8)
    fpts = max(trace_contours(finger), key=len)
    spts = np.concatenate(trace_contours(surf_dark.astype(np.uint8)))
    tree = cKDTree(fpts.astype(float))
    near = tree.query(spts.astype(float), distance_upper_bound=3.0 + 1e-9)[0] <= 3.0
    brute_cols = np.unique(spts[near, 0])
    env = lower_envelope(fpts, 1260).astype(float)
    env[env < 0] = np.nan
    srow = first.astype(float)  # integer pixel-centre rows of the surface contour
    d = contact_distance(env[None], srow, metric="euclidean", tol_px=3.0)[0]
    np.testing.assert_array_equal(np.flatnonzero(d <= 3.0), brute_cols)
    assert brute_cols.size > 50


def test_contact_regions_of_a_synthetic_frame_match_geometry():
    surf = RaisedCosine("bump", 2.0)
    cal_frame, _ = render(surface=surf, noise=1.0)
    cal = calibrate(cal_frame, 0.4, surface=surf)
    frame, geom = render(surface=surf, finger=(-3.0, -0.1, 8.0), noise=1.0)
    an = FrameAnalyzer(cal, AnalysisOptions(contact_metric="vertical"), frame.shape)
    an.area = 1.0  # skip the reference search: only contact is tested here
    an.reference_frame = 0
    r = an.analyze_chunk(1, frame[None])
    gap = (geom["surface_row"] - geom["finger_row"]) * 0.023  # mm, vertical
    true = np.nan_to_num(gap, nan=1.0) <= 3 * 0.023
    x = geom["x_mm"]
    runs = np.flatnonzero(np.diff(np.r_[0, true.astype(int), 0]))
    truth = np.column_stack([x[runs[::2]], x[runs[1::2] - 1]])
    got = r["regions"][0]
    got = got[~np.isnan(got[:, 0])]
    assert got.shape == truth.shape == (2, 2)
    assert np.abs(got - truth).max() < 3 * 0.023  # end points within 3 px


def _d_from_mask(rows):
    """Distances from strings: '#' in contact (d=0), '.' out (d=10), ' ' no finger."""
    return np.array([[0.0 if c == "#" else (10.0 if c == "." else np.nan) for c in r] for r in rows])


def _ident(c):
    return np.asarray(c, float)


def test_cleanup_merges_short_gaps_and_drops_specks():
    d = _d_from_mask(["..######.#####.....###.........#######......",
                      "...####..####..........#.......#########...."])
    raw = contact_regions(d, 3.0, _ident, n_max=8)
    assert list(n_regions(raw)) == [4, 4]
    cl = contact_regions(d, 3.0, _ident, n_max=8, min_gap_px=2.5, min_region_px=2.0)
    as_regions(cl)
    assert list(n_regions(cl)) == [3, 2]
    # frame 0: runs 2-7 and 9-13 (one out column: gap 1.4 px between the interpolated
    # 3 px crossings) merge into one region; the 3-column run 19-21 (2.6 px) and the
    # 7-column run stay
    np.testing.assert_allclose(cl[0, 0], [1.7, 13.3])
    np.testing.assert_allclose(cl[0, 1], [18.7, 21.3])
    np.testing.assert_allclose(cl[0, 2], [30.7, 37.3])
    # frame 1: 3-6 and 9-12 (two out columns: gap 2.4 px) merge; the 1-column speck at 23
    # (0.6 px) is dropped; a gap of 30 columns is never bridged
    np.testing.assert_allclose(cl[1, 0], [2.7, 12.3])
    np.testing.assert_allclose(cl[1, 1], [30.7, 39.3])
    # gap larger than min_gap_px: not merged
    cl = contact_regions(d, 3.0, _ident, n_max=8, min_gap_px=1.0)
    assert list(n_regions(cl)) == [4, 4]


def test_cleanup_order_merge_before_drop():
    # specks 1 px apart form one region long enough to keep
    d = _d_from_mask(["...#.#.#.#........"])
    assert n_regions(contact_regions(d, 3.0, _ident, min_region_px=2.0))[0] == 0
    reg = contact_regions(d, 3.0, _ident, min_gap_px=2.0, min_region_px=2.0)
    np.testing.assert_allclose(reg[0, 0], [2.7, 9.3])


def test_too_many_regions_masks_or_raises():
    d = _d_from_mask(["#.#.#.#.#.#......", "..####..........."])
    with pytest.raises(ValueError, match="frame 0 has 6 contact regions, more than n_max=4"):
        contact_regions(d, 3.0, _ident, n_max=4)
    reg, too_many = contact_regions(d, 3.0, _ident, n_max=4, on_overflow="mask")
    assert list(too_many) == [True, False]
    assert np.isnan(reg[0]).all() and n_regions(reg)[1] == 1
    # the cleanup brings it under n_max: nothing flagged, nothing dropped
    reg, too_many = contact_regions(d, 3.0, _ident, n_max=4, min_gap_px=1.5, on_overflow="mask")
    assert not too_many.any() and n_regions(reg)[0] == 1
    with pytest.raises(ValueError, match="min_gap_px"):
        contact_regions(d, 3.0, _ident, min_gap_px=-1)
    with pytest.raises(ValueError, match="on_overflow"):
        contact_regions(d, 3.0, _ident, on_overflow="drop")


def test_options_validate_cleanup():
    with pytest.raises(ValueError, match="min_region_px"):
        AnalysisOptions(min_region_px=float("nan"))
    with pytest.raises(ValueError, match="min_gap_px"):
        AnalysisOptions(min_gap_px=-0.5)


def test_smooth_outline_keeps_quadratics_and_nan_neighbourhoods():
    from fingerfriction.video.contact import smooth_outline

    c = np.arange(200, dtype=float)
    q = 50.0 + 0.01 * (c - 80.0) ** 2 - 0.3 * c
    got = smooth_outline(q, 21)
    np.testing.assert_allclose(got, q, atol=1e-9)  # order 2 reproduces a parabola
    rows = np.tile(q, (2, 1))
    rows[1, 100] = np.nan
    rng = np.random.default_rng(3)
    noisy = rows + rng.normal(0.0, 0.04, rows.shape)
    sm = smooth_outline(noisy, 21)
    assert np.isnan(sm[1, 100]) and np.isfinite(sm[1, 99]) and np.isfinite(sm[1, 101])
    # columns whose window reaches the NaN or the array's ends keep their raw value
    near = np.r_[np.arange(10), np.arange(90, 111), np.arange(190, 200)]
    np.testing.assert_array_equal(sm[1, near[near != 100]], noisy[1, near[near != 100]])
    # elsewhere the noise is reduced (about sqrt(0.2) for 21 columns of a quadratic fit)
    inner = np.r_[np.arange(10, 90), np.arange(111, 190)]
    assert np.std(sm[1, inner] - q[inner]) < 0.6 * np.std(noisy[1, inner] - q[inner])
    np.testing.assert_array_equal(smooth_outline(noisy, 0), noisy)
    np.testing.assert_array_equal(smooth_outline(noisy, 1), noisy)
    with pytest.raises(ValueError, match="window must be odd"):
        smooth_outline(q, 20)


@pytest.mark.slow
def test_outline_smoothing_makes_a_slowly_opening_contact_edge_accurate():
    """A large, nearly flat finger: the gap reaches 3 px with a slope of 0.05 px/px, where
    0.1 px of outline noise moves the end point by 2 px. Raw outlines vs the default fit."""
    surf = RaisedCosine("bump", 2.0)
    R, fx, fz, mmpp = 60.0, -9.0, -0.01, 0.023
    tol = 3 * mmpp
    half = np.sqrt(R**2 - (R + fz - tol) ** 2)  # where the disc's lower edge is 3 px up
    truth = np.array([fx - half, fx + half])
    errs = {0: [], 41: []}
    for seed in range(6):
        rng = np.random.default_rng(seed)
        cal_frame, _ = render(surface=surf, noise=3.0, rng=rng)
        frame, _ = render(surface=surf, finger=(fx, fz, R), noise=3.0, rng=rng)
        cal = calibrate(cal_frame, 0.4, surface=surf)
        for w in errs:
            opt = AnalysisOptions(contact_metric="vertical", outline_smooth_px=w)
            an = FrameAnalyzer(cal, opt, frame.shape)
            an.area, an.reference_frame = 1.0, 0  # only contact is tested here
            reg = an.analyze_chunk(1, frame[None])["regions"][0]
            reg = reg[np.isfinite(reg[:, 0])]
            assert reg.shape == (1, 2)
            errs[w].append(np.abs(reg[0] - truth) / mmpp)
    raw, sm = np.concatenate(errs[0]), np.concatenate(errs[41])
    assert sm.max() < 3.0  # px
    assert sm.mean() < 0.5 * raw.mean()  # measured: raw mean 1.17 px (max 2.39), smoothed 0.40 (0.96)


@pytest.mark.parametrize("kw, msg", [
    ({"outline_smooth_px": 20}, "outline_smooth_px must be 0, 1 or an odd"),
    ({"outline_smooth_px": -3}, "outline_smooth_px must be 0, 1 or an odd"),
    ({"outline_smooth_px": 5, "outline_smooth_order": 5}, "order must be an integer >= 0 and < outline"),
    ({"outline_smooth_order": 1.5}, "outline_smooth_order must be an integer"),
])
def test_options_validate_outline_smoothing(kw, msg):
    with pytest.raises(ValueError, match=msg):
        AnalysisOptions(**kw)


@pytest.mark.parametrize("window, order", [(41, 2), (41, 3), (21, 1), (5, 0), (15, 4)])
def test_smooth_outline_compiled_path_equals_scipy_savgol(window, order):
    from scipy.ndimage import correlate1d
    from scipy.signal import savgol_coeffs

    from fingerfriction.video.contact import smooth_outline

    rng = np.random.default_rng(window + order)
    f = 200 + rng.normal(0, 1, (6, 700))
    f[:, :50] = np.nan
    f[3, 300] = np.nan
    f[5, 400:405] = np.nan
    fin = np.isfinite(f)
    ref = correlate1d(np.where(fin, f, 0.0), savgol_coeffs(window, order), axis=-1, mode="nearest")
    bad = correlate1d((~fin).astype(float), np.ones(window), axis=-1, mode="constant", cval=1.0) > 0
    ref = np.where(bad, f, ref)
    got = smooth_outline(f, window, order)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(f))
    np.testing.assert_allclose(got, ref, atol=1e-8, rtol=0)
    np.testing.assert_array_equal(got[bad], f[bad])
