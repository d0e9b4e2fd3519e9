"""Tests of FingerParams and SUBJECTS (mechanics/finger.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fingerfriction.mechanics import SUBJECTS, FingerParams, get_subject


def test_json_round_trip_all_shapes():
    u = np.linspace(-5, 5, 11)
    fingers = [
        FingerParams(radius=8.0, modulus=0.1, width=10.0),
        FingerParams(radius=20.0, modulus=0.2, width=10.0, flat_length=6.0, name="pad"),
        FingerParams(radius=9.0, modulus=0.1, width=10.0, shape="ellipse", semi_height=3.0),
        FingerParams(radius=5.0, modulus=0.1, width=10.0, shape="profile", profile=(u, u**2 / 10)),
        FingerParams(radius=8.0, modulus=0.1, width=10.0, layer_thickness=3.0, poisson=0.45),
        FingerParams(radius=8.0, modulus=0.05, width=10.0, skin_modulus=1.0, skin_thickness=0.5),
        *SUBJECTS.values(),
    ]
    for f in fingers:
        text = f.to_json()
        json.loads(text)
        assert FingerParams.from_json(text) == f


def test_outlines():
    c = FingerParams(radius=8.0, modulus=0.1, width=10.0)
    assert c.outline(0.0) == 0.0
    np.testing.assert_allclose(c.outline(np.array([8.0, -8.0])), 8.0)
    st = FingerParams(radius=10.0, modulus=0.1, width=10.0, flat_length=4.0)
    np.testing.assert_array_equal(st.outline(np.array([-2.0, 0.0, 2.0])), 0.0)
    np.testing.assert_allclose(st.outline(np.array([2.0 + 6.0])), 10.0 - 8.0)
    assert st.half_extent == 12.0
    el = FingerParams(radius=9.0, modulus=0.1, width=10.0, shape="ellipse", semi_height=3.0)
    np.testing.assert_allclose(el.outline(np.array([9.0])), 3.0)
    assert el.tip_radius == pytest.approx(27.0)
    with pytest.raises(ValueError, match="half extent"):
        c.outline(np.array([9.0]))
    assert 0 < st.default_half_width() <= 0.98 * st.half_extent
    assert st.outline(st.default_half_width()) == pytest.approx(2.5, abs=0.01)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"shape": "square"}, "shape"),
        ({"shape": "ellipse"}, "semi_height"),
        ({"semi_height": 2.0}, "only used with shape='ellipse'"),
        ({"shape": "profile"}, "profile"),
        ({"layer_thickness": 0.0}, "layer_thickness"),
        ({"poisson": 0.6}, "poisson"),
        ({"flat_length": -1.0}, "flat_length"),
        ({"skin_modulus": 1.0}, "skin_thickness"),
        ({"skin_modulus": 1.0, "skin_thickness": 0.5, "layer_thickness": 2.0}, "cannot be combined"),
        ({"modulus": "soft"}, "modulus"),
    ],
)
def test_validation(kwargs, match):
    base = {"radius": 8.0, "modulus": 0.1, "width": 10.0}
    base.update(kwargs)
    with pytest.raises((ValueError, TypeError), match=match):
        FingerParams(**base)


def test_profile_validation():
    with pytest.raises(ValueError, match="strictly increasing"):
        FingerParams(radius=5, modulus=0.1, width=10, shape="profile", profile=([-1, 1, 0.5], [1, 0, 1]))
    with pytest.raises(ValueError, match="span 0"):
        FingerParams(radius=5, modulus=0.1, width=10, shape="profile", profile=([1, 2, 3], [1, 0, 1]))


def test_subjects():
    assert set(SUBJECTS) == {1, 2}
    for i, f in SUBJECTS.items():
        assert get_subject(i) is f
        assert f.load_per_width(0.3) == pytest.approx(0.3 / f.width)
    with pytest.raises(ValueError, match="unknown subject 3"):
        get_subject(3)
    with pytest.raises(ValueError, match="load"):
        SUBJECTS[1].load_per_width(0.0)
