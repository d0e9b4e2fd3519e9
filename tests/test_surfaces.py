"""Tests of fingerfriction.surfaces: closed forms, the paper's 0.56 rad, sampled profiles."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import cumulative_trapezoid

from fingerfriction.surfaces import (
    SURFACE_NAMES,
    RaisedCosine,
    SampledProfile,
    get_surface,
    load_profile_csv,
    surface_from_spec,
)


def test_bump_max_slope_angle_is_papers_056_rad():
    bump = get_surface("bump-2mm")
    assert bump.max_slope_angle() == pytest.approx(math.atan(math.pi * 0.2), rel=1e-12)
    assert round(bump.max_slope_angle(), 2) == 0.56
    # Scale-free: the 4 mm bump has the same angle; the steps have atan(pi H / 2W).
    assert get_surface("bump-4mm").max_slope_angle() == pytest.approx(bump.max_slope_angle())
    assert get_surface("step-up-4mm").max_slope_angle() == pytest.approx(math.atan(0.1 * math.pi))
    # Numeric maximum over the profile agrees with the closed form.
    xs = np.linspace(-1, 1, 200001)
    assert np.max(np.abs(bump.alpha(xs))) == pytest.approx(bump.max_slope_angle(), abs=1e-9)


@pytest.mark.parametrize("name", SURFACE_NAMES)
def test_slope_and_height_closed_forms(name):
    s = get_surface(name)
    W, H = s.width, s.height
    assert H == pytest.approx(0.2 * W)
    x = np.linspace(-W, W, 4001)
    u = np.clip(x / W + 0.5, 0, 1)
    inside = (u > 0) & (u < 1)
    if s.shape == "bump":
        h = H / 2 * (1 - np.cos(2 * np.pi * u))
        dh = np.where(inside, np.pi * H / W * np.sin(2 * np.pi * u), 0)
    else:
        h = H / 2 * (1 - np.cos(np.pi * u))
        dh = np.where(inside, np.pi * H / (2 * W) * np.sin(np.pi * u), 0)
        if s.shape == "step-down":
            h, dh = H - h, -dh
    np.testing.assert_allclose(s.h(x), h, atol=1e-15)
    np.testing.assert_allclose(s.dhdx(x), dh, atol=1e-15)
    np.testing.assert_allclose(s.alpha(x), np.arctan(dh), atol=1e-15)
    # Finite differences of h agree with dh/dx.
    xi = np.linspace(-W / 2 + 1e-3, W / 2 - 1e-3, 101)
    e = 1e-6
    np.testing.assert_allclose(s.dhdx(xi), (s.h(xi + e) - s.h(xi - e)) / (2 * e), atol=1e-8)


def test_unknown_surface_name_names_value():
    with pytest.raises(ValueError, match=r"unknown surface 'bump-3mm'.*bump-2mm"):
        get_surface("bump-3mm")
    with pytest.raises(ValueError, match=r"unknown surface 'nope'"):
        surface_from_spec("nope")
    with pytest.raises(ValueError, match=r"shape must be one of .* got 'ridge'"):
        RaisedCosine("ridge", 2.0)
    with pytest.raises(ValueError, match=r"width must be a finite positive length in mm, got -1"):
        RaisedCosine("bump", -1)


def test_spec_forms():
    s = surface_from_spec("bump:W=3,H=0.5")
    assert (s.shape, s.width, s.height) == ("bump", 3.0, 0.5)
    assert surface_from_spec(s.to_dict()) == s
    with pytest.raises(ValueError, match=r"needs a width"):
        surface_from_spec("bump:H=0.5")


def test_csv_profile_roundtrip_and_non_monotonic(tmp_path):
    x = np.linspace(-3, 3, 121)
    h = get_surface("bump-2mm").h(x)
    p = tmp_path / "prof.csv"
    p.write_text("x_mm,h_mm\n" + "\n".join(f"{a},{b}" for a, b in zip(x, h, strict=True)))
    prof = load_profile_csv(p)
    assert isinstance(prof, SampledProfile)
    np.testing.assert_allclose(prof.h(x), h, atol=1e-12)
    bad = tmp_path / "bad.csv"
    bad.write_text("0,0\n1,0\n0.5,0.1\n2,0\n3,0\n")
    with pytest.raises(ValueError, match=r"bad\.csv.*strictly increasing.*x\[1\]=1\.0.*x\[2\]=0\.5"):
        load_profile_csv(bad)
    with pytest.raises(ValueError, match=r"bad\.csv"):
        surface_from_spec(str(bad))


def test_sampled_profile_slope_matches_analytic():
    s = get_surface("bump-4mm")
    x = np.linspace(-4, 4, 801)
    prof = SampledProfile(x, s.h(x))
    xi = np.linspace(-1.9, 1.9, 77)
    np.testing.assert_allclose(prof.dhdx(xi), s.dhdx(xi), atol=2e-4)


@settings(max_examples=25, deadline=None)
@given(
    width=st.floats(0.5, 8.0),
    shape=st.sampled_from(["bump", "step-up", "step-down"]),
    frac=st.floats(0.05, 0.4),
)
def test_slope_integrates_back_to_height(width, shape, frac):
    """Property: int dh/dx dx = h(x) - h(x0), for RaisedCosine and SampledProfile."""
    rc = RaisedCosine(shape, width, frac * width)
    x = np.linspace(-width, width, 20001)
    integ = cumulative_trapezoid(rc.dhdx(x), x, initial=0.0)
    np.testing.assert_allclose(integ, rc.h(x) - rc.h(x[0]), atol=1e-6 * rc.height + 1e-12)
    xs = np.linspace(-width, width, 401)
    prof = SampledProfile(xs, rc.h(xs))
    integ = cumulative_trapezoid(prof.dhdx(x), x, initial=0.0)
    np.testing.assert_allclose(integ, prof.h(x) - prof.h(x[0]), atol=1e-6 * rc.height + 1e-12)
