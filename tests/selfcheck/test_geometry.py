"""The surface in the manifest against the feature in the calibration frame, and the
sliding speed against the manifest's."""

from __future__ import annotations

import numpy as np
import pytest

from fingerfriction.selfcheck import check_geometry, check_speed, measure_feature, sliding_speed
from fingerfriction.surfaces import RaisedCosine, SampledProfile, get_surface


def _rows(shape, width_px=87.0, height_px=17.4, centre=630.0, n=1260, seed=0):
    """A calibration profile: edge rows (growing downwards) of a raised-cosine feature."""
    cols = np.arange(n, dtype=float)
    g = RaisedCosine(shape, 1.0, 1.0).h((cols - centre) / width_px)
    rng = np.random.default_rng(seed)
    return 300.0 - height_px * g + 0.05 * rng.standard_normal(n)


@pytest.mark.parametrize("name", ["bump-2mm", "step-up-4mm", "step-down-2mm"])
def test_the_right_surface_passes(name):
    s = get_surface(name)
    feat = measure_feature(_rows(s.shape), s.shape)
    assert feat.shape == s.shape and feat.aspect == pytest.approx(5.0, rel=0.02)
    checks = {c.code: c for c in check_geometry(feat, s, s.height)}
    assert checks["surface-type"].level == "ok" and checks["surface-geometry"].level == "ok"


def test_height_twice_in_the_manifest_names_both():
    s = get_surface("bump-2mm")
    feat = measure_feature(_rows("bump"), "bump")
    c = {c.code: c for c in check_geometry(feat, s, 2 * s.height)}["surface-geometry"]
    assert c.level == "error" and c.field == "calibration.surface_height_mm"
    assert c.figure == pytest.approx(100.0, abs=5.0)
    assert "bump-2mm: bump, W 2 mm, H 0.8 mm, W/H 2.5" in c.message and "W/H 5" in c.message


@pytest.mark.parametrize(
    "seen,named", [("step-up", "bump-2mm"), ("bump", "step-down-4mm"), ("step-down", "step-up-2mm")]
)
def test_another_surface_type_is_an_error(seen, named):
    s = get_surface(named)
    feat = measure_feature(_rows(seen), s.shape)
    assert feat.shape == seen
    checks = check_geometry(feat, s, s.height)
    assert checks[0].code == "surface-type" and checks[0].level == "error"
    assert f"{named}: {s.shape}" in checks[0].message and f"a {seen}" in checks[0].message


def test_a_sampled_profile_is_not_checked():
    s = SampledProfile(np.linspace(-5, 5, 101), np.zeros(101))
    checks = check_geometry(measure_feature(_rows("bump")), s, 0.4)
    assert [c.level for c in checks] == ["info"]


def test_speed_against_the_manifest():
    t = np.arange(600) / 1000.0
    x = -13 + 80.0 * t
    assert sliding_speed(t, x) == pytest.approx(80.0)
    assert check_speed(80.0, 90.0).level == "ok"
    w = check_speed(160.0, 80.0)
    assert w.level == "warning" and "2.00x" in w.message and w.field == "speed_mm_s"
    assert check_speed(float("nan"), 80.0).level == "info"
