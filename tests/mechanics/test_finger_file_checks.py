"""Finger files are checked for known values and physical ranges."""

from __future__ import annotations

import json
import re

import pytest

from fingerfriction.mechanics.fe import FEProvider
from fingerfriction.mechanics.finger_file import (
    FINGER_MODELS,
    FINGER_RANGES,
    read_finger_file,
    register_finger_model,
)
from fingerfriction.sim.contact import BridgedFoundation, MechanicsProvider

GOOD = {"radius": 8.0, "modulus": 0.1, "width": 10.0}


def _file(tmp_path, d) -> str:
    p = tmp_path / "finger.json"
    p.write_text(json.dumps(d))
    return str(p)


def test_every_contact_model_is_a_known_finger_model():
    for provider in (MechanicsProvider, BridgedFoundation, FEProvider):
        assert provider.name in FINGER_MODELS


def test_an_unknown_model_is_refused_and_the_registry_extends(tmp_path):
    with pytest.raises(ValueError, match=r"finger file .*: model 'wooden-leg' is not a known finger model; "
                                         r"known: bridged-foundation, fe, mechanics-bem"):
        read_finger_file(_file(tmp_path, {**GOOD, "model": "wooden-leg"}))
    register_finger_model("wooden-leg", "a test's finger")
    try:
        assert read_finger_file(_file(tmp_path, {**GOOD, "model": "wooden-leg"})).radius == 8.0
    finally:
        del FINGER_MODELS["wooden-leg"]


@pytest.mark.parametrize("field,value", [("radius", 1e6), ("radius", 0.01), ("modulus", 2e5),
                                         ("width", 500.0), ("flat_length", 80.0)])
def test_values_outside_a_fingertip_are_refused(tmp_path, field, value):
    lo, hi, unit = FINGER_RANGES[field]
    msg = f"{field} = {value:g} {unit} is outside the physical range [{lo:g}, {hi:g}] {unit} of a fingertip"
    with pytest.raises(ValueError, match=re.escape(msg)):
        read_finger_file(_file(tmp_path, {**GOOD, field: value}))


def test_a_deeply_nested_finger_file_is_one_line(tmp_path):
    p = tmp_path / "finger.json"
    p.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(ValueError, match="nested too deeply"):
        read_finger_file(p)
