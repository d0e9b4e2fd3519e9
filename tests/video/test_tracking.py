import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import brentq

from fingerfriction.surfaces import RaisedCosine
from fingerfriction.video import AnalysisOptions, FrameAnalyzer, calibrate
from fingerfriction.video.tracking import area_below_line, centroid_below_line, line_for_area

from .synth import render_video


def test_hand_made_outline():
    # a 4-column V: rows 2, 4, 6, 4 ; line at row 3 encloses 1 + 3 + 1 = 5 px^2
    f = np.array([[np.nan, 2.0, 4.0, 6.0, 4.0, np.nan]])
    assert area_below_line(f, 3.0)[0] == pytest.approx(5.0)
    r = line_for_area(f, 5.0)
    assert r[0] == pytest.approx(3.0)
    assert centroid_below_line(f, r)[0] == pytest.approx((2 * 1 + 3 * 3 + 4 * 1) / 5)
    assert np.isnan(line_for_area(f, 1e6)[0])  # not reachable: finger too small
    with pytest.raises(ValueError, match="area"):
        line_for_area(f, 0.0)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 10_000), st.floats(1.0, 2000.0))
def test_line_for_area_matches_root_finding(seed, A):
    rng = np.random.default_rng(seed)
    f = rng.uniform(0, 50, (1, 60))
    f[0, rng.random(60) < 0.2] = np.nan
    r = line_for_area(f, A)[0]
    total = area_below_line(f, -0.5)[0]
    if A > total:
        assert np.isnan(r)
    else:
        ref = brentq(lambda x: area_below_line(f, x)[0] - A, -0.5, 60)
        assert r == pytest.approx(ref, abs=1e-9)
        assert area_below_line(f, r)[0] == pytest.approx(A, rel=1e-12)


@pytest.mark.slow
def test_moving_finger_is_tracked_on_the_flat():
    """A disc finger pressed on a flat region: the C_f centroid is the disc centre."""
    surf = RaisedCosine("bump", 2.0)
    xs = np.linspace(-7.0, -3.0, 21)
    vid = render_video(xs, surface=surf, noise=2.0, radius_mm=8.0, z_mm=-0.1)
    cal = calibrate(vid[0], 0.4, surface=surf)
    an = FrameAnalyzer(cal, AnalysisOptions(), vid.shape[1:])
    r = an.analyze_chunk(0, vid)
    assert r["flags"][0] != 0 and (r["flags"][1:] == 0).all()
    assert an.reference_frame == 1
    err = r["x"][1:] - xs
    assert np.abs(err).max() < 0.02  # mm; symmetric finger on the flat: no offset at all
    # the line keeps the reference area in every frame
    A = area_below_line(r["f"][1:], r["line_row"][1:])
    np.testing.assert_allclose(A, an.area, rtol=1e-9)


@pytest.mark.slow
def test_finger_over_the_bump_after_offset_removal():
    surf = RaisedCosine("bump", 2.0)
    xs = np.linspace(-6.0, 6.0, 41)
    vid = render_video(xs, surface=surf, noise=2.0)
    cal = calibrate(vid[0], 0.4, surface=surf)
    r = FrameAnalyzer(cal, AnalysisOptions(), vid.shape[1:]).analyze_chunk(0, vid)
    err = r["x"][1:] - xs
    err -= err.mean()
    # This synthetic finger is a rigid disc cut by the bump (not volume-preserving), so
    # the centroid moves by up to ~0.12 mm while over the bump; RMS stays below 0.06 mm.
    assert np.sqrt(np.mean(err**2)) < 0.06


def test_chord_midpoint():
    from fingerfriction.video.tracking import chord_midpoint

    c = np.arange(40, dtype=float)
    f = 30 - 0.1 * (c - 17.3) ** 2  # parabola, apex at column 17.3
    f[f < 0] = np.nan
    m = chord_midpoint(np.stack([f, f + 100, np.full(40, np.nan)]), 20.0)
    assert m[0] == pytest.approx(17.3, abs=0.05)  # linear interpolation of the crossings
    assert np.isnan(m[1])  # the chord at row 20 is cut by the sides of the crop
    assert np.isnan(m[2])


def test_chord_ends_each_side_on_its_own():
    from fingerfriction.video.tracking import chord_ends, chord_midpoint

    c = np.arange(40, dtype=float)
    f = 30 - 0.1 * (c - 17.3) ** 2  # crosses row 20 at 17.3 -+ 10 (linear interpolation error ~0.05)
    shifted = 30 - 0.1 * (c - 33.0) ** 2  # apex near the right side: the right end is cut
    lo, hi = chord_ends(np.stack([f, shifted, np.full(40, np.nan)]), 20.0)
    assert lo[0] == pytest.approx(7.3, abs=0.06) and hi[0] == pytest.approx(27.3, abs=0.06)
    assert lo[1] == pytest.approx(23.0, abs=0.06) and np.isnan(hi[1])
    assert np.isnan(lo[2]) and np.isnan(hi[2])
    np.testing.assert_array_equal(chord_midpoint(np.stack([f, shifted]), 20.0), 0.5 * (lo[:2] + hi[:2]))


def _hybrid_inputs():
    x = np.linspace(-13.0, 13.0, 27)  # 1 mm steps
    chord = np.where(np.abs(x) <= 8.0, x + 0.1, np.nan)  # the chord's own constant bias
    left = np.where(x > -5.0, x - 7.0, np.nan)  # trailing edge: in view right of -5
    right = np.where(x < 5.0, x + 7.0, np.nan)
    return x, chord, left, right


def test_hybrid_positions_chord_then_offset_corrected_edges():
    from fingerfriction.video.tracking import PositionSource, hybrid_positions

    x, chord, left, right = _hybrid_inputs()
    h = hybrid_positions(chord, left, right, calibration_mm=1.0, min_frames=3)
    np.testing.assert_allclose(h.x, x + 0.1, atol=1e-12)  # continuous with the chord
    assert (h.source[np.abs(x) <= 8] == PositionSource.CHORD).all()
    assert (h.source[x > 8] == PositionSource.LEFT_EDGE).all()
    assert (h.source[x < -8] == PositionSource.RIGHT_EDGE).all()
    assert h.offsets_mm == pytest.approx({"left": 7.1, "right": -6.9})
    # 1 mm of chord travel holds 2 frames (7, 8 mm): the 3 nearest the end are used
    assert h.calibration_frames == {"left": 3, "right": 3}
    assert h.calibration_range_mm["left"] == pytest.approx((6.1, 8.1))
    assert h.counts() == {"NONE": 0, "CHORD": 17, "LEFT_EDGE": 5, "RIGHT_EDGE": 5}


def test_hybrid_edges_measure_their_offset_at_the_chord_range_end():
    """An edge whose offset drifts over the feature (deformation) is calibrated where the
    finger is on the flat (the end of the chord's range), not on average."""
    from fingerfriction.video.tracking import hybrid_positions

    x, chord, left, right = _hybrid_inputs()
    left = left + np.where(np.abs(x) < 4, 0.3, 0.0)  # the edge moves while over the feature
    h = hybrid_positions(chord, left, right)
    assert h.offsets_mm["left"] == pytest.approx(7.1)
    np.testing.assert_allclose(h.x[x > 8], x[x > 8] + 0.1, atol=1e-12)


def test_hybrid_never_uses_an_edge_inside_the_chord_range_or_without_calibration():
    from fingerfriction.video.tracking import PositionSource, hybrid_positions

    x, chord, left, right = _hybrid_inputs()
    chord[13] = np.nan  # x = 0: a chord glitch over the feature, where edges move
    h = hybrid_positions(chord, left, right)
    assert np.isnan(h.x[13]) and h.source[13] == PositionSource.NONE
    # no chord at all: nothing to calibrate the edges against
    none = hybrid_positions(np.full(27, np.nan), left, right)
    assert np.isnan(none.x).all() and np.isnan(none.offsets_mm["left"])
    assert none.calibration_frames == {"left": 0, "right": 0}
    with pytest.raises(ValueError, match="one length"):
        hybrid_positions(chord, left[:-1], right)
    with pytest.raises(ValueError, match="calibration_mm"):
        hybrid_positions(chord, left, right, calibration_mm=0.0)
    with pytest.raises(ValueError, match="edge_height_mm"):
        AnalysisOptions(edge_height_mm=-1.0)
    with pytest.raises(ValueError, match="edge_calibration_mm"):
        AnalysisOptions(edge_calibration_mm=float("nan"))
