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
