import numpy as np
import pytest

from fingerfriction.surfaces import RaisedCosine
from fingerfriction.video.binarize import Crop, central_crop, otsu_level
from fingerfriction.video.calibrate import calibrate

from .synth import render


@pytest.mark.parametrize("shape", ["bump", "step-up", "step-down"])
@pytest.mark.parametrize("width", [2.0, 4.0])
def test_calibration_recovers_scale_origin_and_profile(shape, width):
    surf = RaisedCosine(shape, width)
    frame, geom = render(surface=surf, mm_per_px=0.023, x0_px=641.37, base_row=520.4, noise=1.0)
    cal = calibrate(frame, surf.height, surface=surf)
    assert cal.method == "raised-cosine fit" and cal.level_method == "otsu"
    assert cal.mm_per_px == pytest.approx(0.023, rel=2.5e-3)
    assert cal.x0_px == pytest.approx(641.37, abs=0.1)
    assert cal.mm_per_px_width == pytest.approx(0.023, rel=5e-3)
    assert cal.crop == Crop(10, 180, 1260, 360)
    # the measured profile h-hat is the surface, to a small fraction of a pixel
    s_true = geom["surface_row"][10:1270] - 180
    assert np.abs(cal.surface_row - s_true).max() < 0.25
    h_true = surf.h(cal.x_mm)
    assert np.abs(cal.h_hat_mm - h_true).max() < 0.25 * 0.023


def test_calibration_without_shape_uses_profile_maximum():
    surf = RaisedCosine("bump", 4.0)
    frame, _ = render(surface=surf, x0_px=640.0, noise=0.0)
    cal = calibrate(frame, surf.height)
    assert cal.method == "profile"
    assert cal.mm_per_px == pytest.approx(0.023, rel=0.01)
    assert cal.x0_px == pytest.approx(640.0, abs=0.6)


def test_given_level_is_used_and_reported():
    surf = RaisedCosine("bump", 2.0)
    frame, _ = render(surface=surf)
    cal = calibrate(frame, 0.4, level=100, surface=surf)
    assert cal.level == 100 and cal.level_method == "given"
    assert otsu_level(central_crop(frame.shape).apply(frame)) == pytest.approx(125, abs=3)


def test_calibration_errors():
    surf = RaisedCosine("bump", 2.0)
    frame, _ = render(surface=surf)
    with pytest.raises(ValueError, match="leaves no contour"):
        calibrate(frame, 0.4, level=255)
    with pytest.raises(ValueError, match="surface_height_mm"):
        calibrate(frame, -1.0)
    with pytest.raises(ValueError, match="does not fit"):
        calibrate(frame[:300], 0.4, crop=Crop(10, 180, 1260, 360))
    with pytest.raises(ValueError, match="constant"):
        calibrate(np.full((720, 1280), 200, np.uint8), 0.4)
    flat = render(surface=RaisedCosine("bump", 2.0, 0.001))[0]
    with pytest.raises(ValueError, match="no surface feature"):
        calibrate(flat, 0.4)
    blank = frame.copy()
    blank[530:] = 220  # no surface at the bottom of the crop
    with pytest.raises(ValueError, match="no surface at the bottom"):
        calibrate(blank, 0.4)


def test_sim_geometry_lies_in_the_central_crop():
    """docs/study-format.md and the simulator's camera: 1280 x 720 frames, flat ground on
    row 500, relief at most 35 px high: inside rows 180-539 of the central crop."""
    crop = central_crop((720, 1280))
    assert (crop.x0, crop.y0, crop.width, crop.height) == (10, 180, 1260, 360)
    assert crop.y0 < 500 - 35 - 0.4 / 0.023 and 500 < crop.y0 + crop.height
