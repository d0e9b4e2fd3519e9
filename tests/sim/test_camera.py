"""Tests of the camera model: calibration frame, scale, and that the contact seen in the
rendered silhouettes is the stored geometric ground truth."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt

from fingerfriction.regions import regions_from_mask
from fingerfriction.sim.camera import Camera, CameraParams
from fingerfriction.sim.contact import BridgedFoundation, MechanicsProvider
from fingerfriction.sim.writer import geometric_mask
from fingerfriction.surfaces import get_surface


def test_calibration_frame_is_surface_only_and_scaled():
    surf = get_surface("bump-4mm")
    cam = Camera(surf)
    img = cam.render(None, np.random.default_rng(0))
    P = cam.params
    assert img.shape == (720, 1280) and img.dtype == np.uint8
    dark = img < 128
    # per column, dark pixels are exactly those below the surface line: no finger
    top = np.argmax(dark, axis=0)
    expected = np.ceil(cam.surface_rows - 0.5 + 1e-9).astype(int)  # first row >50 % covered
    assert np.max(np.abs(top - expected)) <= 1
    assert not dark[: int(cam.surface_rows.min()) - 3].any()
    # feature height in pixels -> mm per pixel, as the video analysis calibrates (Fig. 7A)
    height_px = cam.surface_rows.max() - cam.surface_rows.min()
    assert 0.8 / height_px == pytest.approx(P.mm_per_px, rel=1e-3)
    # surface and contact zone inside the paper's central 1260 x 360 crop
    assert 180 <= cam.surface_rows.min() and cam.surface_rows.max() < 540


def _image_contact(frame, calib, thr=128, tol_px=3.0):
    """Columns where a surface boundary pixel lies within tol_px of a finger pixel."""
    surf = calib < thr
    # finger: dark now and clearly darker than in the calibration frame (the noisy edge
    # band of the surface line is not finger)
    finger = (frame < thr) & (calib.astype(int) - frame.astype(int) > 64)
    if not finger.any():
        return np.zeros(frame.shape[1], bool)
    dist = distance_transform_edt(~finger)
    top = np.argmax(surf, axis=0)
    return dist[top, np.arange(frame.shape[1])] <= tol_px


@pytest.mark.slow
@pytest.mark.parametrize("provider", ["mechanics", "fallback"])
def test_silhouette_contact_matches_geometric_truth(provider):
    surf = get_surface("bump-2mm")
    cam = Camera(surf, CameraParams())
    P = cam.params
    tol = 3 * P.mm_per_px
    prov = MechanicsProvider() if provider == "mechanics" else BridgedFoundation()
    xi = prov.grid("1")
    positions = np.array([-3.0, -1.6, -0.8, 0.0, 0.9, 2.2])
    Y, _ = prov.solve(surf, "1", positions, 0.3)
    rng = np.random.default_rng(0)
    calib = cam.render(None, rng)
    checked = 0
    ious = []
    for x_c, y_f in zip(positions, Y, strict=True):
        frame = cam.render(cam.finger_rows(x_c, xi, y_f), rng)
        seen = _image_contact(frame, calib)
        # truth at the pixel columns: the stored geometric criterion on the outline
        X = x_c + xi
        mask = geometric_mask(xi, y_f, surf.h(X), tol)
        truth_regions = regions_from_mask(X, mask)[0]
        cols = cam.x_cols
        in_truth = np.zeros(cols.size, bool)
        for a, b in truth_regions[~np.isnan(truth_regions[:, 0])]:
            in_truth |= (cols >= a) & (cols <= b)
        # distance (px) of each column's surface point to the finger (vertical gap times
        # the cosine of the outline's slope angle: an independent, local estimate)
        yf_c = np.interp(cols - x_c, xi, y_f, left=np.inf, right=np.inf)
        slope = np.gradient(np.interp(cols - x_c, xi, y_f), cols)
        d_px = (yf_c - surf.h(cols)) / np.sqrt(1 + slope**2) / P.mm_per_px
        # every column clearly inside the truth is seen in contact, and every column seen
        # in contact is at most a pixel and a half beyond the 3 px criterion
        slack = 1.5
        assert np.all(seen[d_px <= 3 - slack]), x_c
        assert np.all(d_px[seen] <= 3 + slack), (x_c, d_px[seen].max())
        # and as regions: large overlap with the stored truth (where the gap grows by a
        # pixel over ~0.5 mm, as at the ends of a flat pad's contact, pixel rounding makes
        # the image's contact ends flicker: the slack test above is the strict one)
        inter = np.sum(seen & in_truth)
        union = np.sum(seen | in_truth)
        assert union > 0
        ious.append(inter / union)
        checked += 1
    assert checked == positions.size
    assert min(ious) > 0.8 and np.median(ious) > 0.9, ious


def test_noise_only_in_edge_band_and_deterministic():
    surf = get_surface("step-up-2mm")
    cam = Camera(surf)
    a = cam.render(None, np.random.default_rng(4))
    b = cam.render(None, np.random.default_rng(4))
    assert np.array_equal(a, b)
    mid = (a > 0) & (a < 255)
    assert 0 < mid.mean() < 0.02  # edge band only: flat background and shadow are clean
    loud = Camera(surf, CameraParams(read_noise=1.0, dark=3.0)).render(None, np.random.default_rng(4))
    assert ((loud > 0) & (loud < 255)).mean() > 0.3


@pytest.mark.parametrize("kw, match", [
    (dict(bright=300.0), "bright"), (dict(mm_per_px=0.0), "mm_per_px"), (dict(blur_px=-1.0), "blur_px"),
    (dict(dark=200.0, bright=100.0), r"CameraParams.dark must be in \[0, 100\) DN \(below bright\), got 200"),
    (dict(width=15), r"CameraParams.width must be an integer >= 16 pixels, got 15"),
    (dict(fps=-1.0), r"CameraParams.fps must be a finite positive frame rate in Hz, got -1.0"),
    (dict(y0_row=float("inf")), r"CameraParams.y0_row must be a finite number in px, got inf"),
])
def test_camera_params_validated(kw, match):
    with pytest.raises(ValueError, match=match) as e:
        CameraParams(**kw)
    assert "\n" not in str(e.value)


def test_camera_params_take_numbers_only():
    with pytest.raises(TypeError, match="CameraParams.gain must be a number, got str"):
        CameraParams(gain="0.1")
    assert CameraParams(width=640.0).width == 640 and isinstance(CameraParams(width=640.0).width, int)
