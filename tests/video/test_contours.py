import cv2
import numpy as np
import pytest
from scipy.spatial import cKDTree
from skimage.measure import find_contours

from fingerfriction.video.contours import finger_zone, lower_envelope, trace_contours, trace_finger


def _random_shapes(seed, h=80, w=100):
    """Random blobs: smoothed, thresholded noise (several components, holes, thin parts)."""
    rng = np.random.default_rng(seed)
    noise = cv2.GaussianBlur(rng.normal(size=(h, w)).astype(np.float32), (0, 0), 4.0)
    img = (noise > 0.05).astype(np.uint8)
    img[:2] = img[-2:] = 0
    img[:, :2] = img[:, -2:] = 0
    return img


@pytest.mark.parametrize("seed", range(6))
def test_opencv_contours_match_skimage(seed):
    """Every OpenCV boundary pixel lies on a pixel next to skimage's iso-line, and back."""
    img = _random_shapes(seed)
    cv = trace_contours(img, external=False)
    # skimage's marching squares at level 0.5, foreground (1) 8-connected like OpenCV.
    sk = find_contours(img.astype(float), 0.5, fully_connected="high")
    assert len(cv) == len(sk)
    P = np.concatenate(cv).astype(float)[:, ::-1]  # (row, col)
    Q = np.concatenate(sk)
    d_pq, _ = cKDTree(Q).query(P)
    d_qp, _ = cKDTree(P).query(Q)
    # OpenCV gives boundary pixel centres, skimage the iso-line between pixel centres:
    # both within one pixel of each other everywhere.
    assert d_pq.max() <= 1.0 + 1e-9
    assert d_qp.max() <= 1.0 + 1e-9
    # The enclosed areas agree within half the perimeter (pixel-centre vs mid-edge outline).
    for c in cv:
        assert img[c[:, 1], c[:, 0]].all()  # OpenCV's points are foreground pixels


def test_lower_envelope_equals_columnwise_lowest_pixel():
    rng = np.random.default_rng(5)
    h, w = 60, 90
    depth = np.clip(30 + np.cumsum(rng.integers(-3, 4, w)), 1, h - 5)
    img = (np.arange(h)[:, None] <= depth[None, :]).astype(np.uint8)
    img[:, :3] = 0
    img[:, -4:] = 0
    fc = trace_finger(img, min_points=5)
    env = lower_envelope(fc.points, w)
    expect = np.where(img.any(axis=0), h - 1 - np.argmax(img[::-1], axis=0), -1)
    np.testing.assert_array_equal(env, expect)


def test_trace_finger_needs_a_region_from_the_top():
    img = np.zeros((40, 50), np.uint8)
    img[10:20, 10:30] = 1  # floating blob, not a finger
    assert trace_finger(img, min_points=5) is None
    assert trace_finger(np.zeros((40, 50), np.uint8)) is None
    img[:25, 5:40] = 1
    img[30, 45] = 1  # a noise speck is not chosen
    fc = trace_finger(img, min_points=5)
    assert fc is not None and fc.n_contours == 2 and fc.points[:, 1].max() == 24


def test_finger_zone_leaves_out_the_row_above_the_surface():
    z = finger_zone(np.array([10, 12]), 15)
    assert z[:, 0].nonzero()[0].max() == 8 and z[:, 1].nonzero()[0].max() == 10
