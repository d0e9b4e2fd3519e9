"""Tests of fingerfriction.model.blindspots on hand-built region sequences (exact answers)."""

import numpy as np
import pytest

from fingerfriction.model.blindspots import blind_spots, contact_union, occupancy


def test_blind_spot_widths_exact():
    # Three frames: flat contact advancing, a second region on the feature, a gap never touched.
    regions = [
        [(-6.0, -2.0)],
        [(-5.0, -1.5), (0.25, 1.0)],
        [(-4.0, -1.25), (0.5, 2.0)],
    ]
    bs = blind_spots(regions)
    np.testing.assert_array_equal(bs.intervals, [[-1.25, 0.25]])
    np.testing.assert_array_equal(bs.widths, [1.5])
    assert bs.span == (-6.0, 2.0)


def test_two_blind_spots_and_touching_regions_merge():
    regions = [[(0.0, 1.0), (1.5, 2.0)], [(1.0, 1.25), (3.0, 4.0)], [(5.0, 5.5)]]
    bs = blind_spots(regions)
    np.testing.assert_allclose(bs.intervals, [[1.25, 1.5], [2.0, 3.0], [4.0, 5.0]])
    np.testing.assert_allclose(bs.widths, [0.25, 1.0, 1.0])
    np.testing.assert_allclose(contact_union(regions), [[0, 1.25], [1.5, 2], [3, 4], [5, 5.5]])
    assert len(blind_spots(regions, min_width=0.5)) == 2


def test_no_blind_spot_when_covered_and_span_clipping():
    regions = [[(0.0, 2.0)], [(1.0, 3.0)]]
    assert len(blind_spots(regions)) == 0
    # A given span larger than the swept span does not create blind spots at the ends.
    assert len(blind_spots(regions, span=(-5, 10))) == 0


def test_occupancy_normalised():
    regions = [[(0.0, 1.0)], [(0.5, 1.0)]]
    occ = occupancy(regions, bin_width=0.25)
    np.testing.assert_allclose(occ.fraction, [0.5, 0.5, 1.0, 1.0])
    np.testing.assert_allclose(occ.normalized, [0.5, 0.5, 1.0, 1.0])


def test_bad_input():
    with pytest.raises(ValueError, match="no contact at all"):
        blind_spots(np.full((3, 1, 2), np.nan))
    with pytest.raises(ValueError, match=r"frame 1, region 0 is inverted: \[a, b\] = \[3.0, 2.0\]"):
        blind_spots([[(0.0, 1.0)], [(3.0, 2.0)]])
