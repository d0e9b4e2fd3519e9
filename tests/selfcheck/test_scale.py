"""The force's scale against the contact the video shows (fingerfriction.selfcheck.scale)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fingerfriction.selfcheck import flat_contact_length, scale_checks


def _finger(n=9, seed=0, group="1"):
    """Trials of one finger: presses of 0.25-0.35 N, contact ~ sqrt(load) with scatter."""
    rng = np.random.default_rng(seed)
    f = rng.uniform(0.25, 0.35, n)
    length = 10.0 * np.sqrt(f / 0.3) * (1 + 0.02 * rng.standard_normal(n))
    pairs = zip(f, length, strict=True)
    return {f"{group}-{i}": (group, float(a), float(b)) for i, (a, b) in enumerate(pairs)}


def test_clean_trials_are_not_flagged_and_a_harder_press_with_its_contact_is_not_either():
    items = _finger()
    items["hard"] = ("1", 1.2, 10.0 * math.sqrt(1.2 / 0.3))  # four times the press, twice the contact
    got = scale_checks(items)
    assert all(c.level == "ok" for c in got.values()), [c.message for c in got.values() if c.level != "ok"]


@pytest.mark.parametrize("factor", [10.0, 0.1, 1000.0])
def test_a_scale_mistake_is_an_error_naming_the_fields(factor):
    items = _finger()
    g, f, length = items["1-3"]
    items["1-3"] = (g, f * factor, length)
    got = scale_checks(items)
    c = got["1-3"]
    assert c.level == "error" and c.figure == pytest.approx(factor, rel=0.3)
    assert "sensitivity" in c.message and "units" in c.message
    assert sum(x.level == "error" for x in got.values()) == 1


def test_not_measured_says_why():
    items = _finger(n=2) | {"x": ("1", math.nan, 10.0)}
    got = scale_checks(items)
    assert got["x"].level == "info" and "no F_N level" in got["x"].message
    assert got["1-0"].level == "info" and "needs 3" in got["1-0"].message
    # the reference: copies are measured against the unmodified trials only
    many = _finger() | {"copy": ("1", 3.0, 10.0)}
    assert scale_checks(many, reference=set(_finger()))["copy"].level == "error"


def test_flat_contact_length_uses_the_frames_on_flat_ground():
    n = 200
    x = np.linspace(-14.0, 14.0, n)
    reg = np.full((n, 2, 2), np.nan)
    reg[:, 0, 0], reg[:, 0, 1] = x - 5.0, x + 5.0  # a 10 mm contact
    on_feature = (reg[:, 0, 1] > -2.5) & (reg[:, 0, 0] < 2.5)
    reg[on_feature, 0, 1] = reg[on_feature, 0, 0] + 4.0  # something else over the feature
    assert flat_contact_length(x, reg, (-2.0, 2.0)) == pytest.approx(10.0)
    assert math.isnan(flat_contact_length(x[:5], reg[:5], (-2.0, 2.0)))
