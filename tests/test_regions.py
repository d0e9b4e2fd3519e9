"""Tests of fingerfriction.regions: the contact-region format and its validation."""

import numpy as np
import pytest

from fingerfriction.regions import as_regions, inset_regions, n_regions, region_lengths, regions_from_mask


def test_single_frame_and_ragged_lists():
    r = as_regions([(0.0, 1.0), (2.0, 3.5)])
    assert r.shape == (1, 2, 2)
    r = as_regions([[(0.0, 1.0)], [(0.0, 1.0), (2.0, 3.0)], []])
    assert r.shape == (3, 2, 2)
    np.testing.assert_array_equal(n_regions(r), [1, 2, 0])
    np.testing.assert_allclose(region_lengths(r)[1], [1.0, 1.0])


def test_empty_list_is_one_empty_frame():
    assert np.isnan(as_regions([])).all()


@pytest.mark.parametrize(
    "bad, match",
    [
        ([(1.0, 0.5)], r"frame 0, region 0 is inverted: \[a, b\] = \[1\.0, 0\.5\]"),
        (np.array([[[0.0, np.nan]]]), r"frame 0, region 0 has one NaN end point"),
        ([(0.0, 2.0), (1.0, 3.0)], r"regions 0 \(0\.0, 2\.0\) and 1 \(1\.0, 3\.0\) overlap"),
        (np.array([[[np.nan, np.nan], [0.0, 1.0]]]), r"valid region after an unused"),
        (np.array([[[0.0, np.inf]]]), r"infinite end point"),
        (np.zeros((2, 3)), r"shape \(n_frames, n_max, 2\), got \(2, 3\)"),
    ],
)
def test_bad_regions_are_named(bad, match):
    with pytest.raises(ValueError, match=match):
        as_regions(bad)


def test_regions_from_mask_runs():
    x = np.arange(10) * 0.1
    m = np.array([[0, 1, 1, 0, 0, 1, 0, 0, 1, 1], [0] * 10], dtype=bool)
    r = regions_from_mask(x, m)
    np.testing.assert_allclose(r[0], [[0.05, 0.25], [0.45, 0.55], [0.75, 0.95]])
    assert np.isnan(r[1]).all()
    with pytest.raises(ValueError, match=r"3 contact regions, more than n_max=2"):
        regions_from_mask(x, m, n_max=2)


def test_inset_regions_shortens_drops_and_compacts():
    r = np.array([[[0.0, 1.0], [2.0, 2.5], [3.0, 5.0]],
                  [[0.0, 0.6], [np.nan, np.nan], [np.nan, np.nan]]])
    out = inset_regions(r, 0.3)
    np.testing.assert_allclose(out[0, :2], [[0.3, 0.7], [3.3, 4.7]])
    assert np.isnan(out[0, 2]).all()
    assert np.isnan(out[1]).all()  # 0.6 mm is not longer than 2 x 0.3 mm
    as_regions(out)  # still a valid regions array: survivors first, in order
    np.testing.assert_array_equal(inset_regions(r, 0.0), r)
    with pytest.raises(ValueError, match=r"inset must be a finite length >= 0 in mm, got -1"):
        inset_regions(r, -1)
