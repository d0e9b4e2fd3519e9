"""Simulated subjects with any finger: per-subject overrides and seeded draws."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from fingerfriction.cli import app
from fingerfriction.mechanics import SUBJECTS, FingerParams
from fingerfriction.mechanics.finger_file import finger_from_mapping, read_finger_file, write_finger_file
from fingerfriction.sim import KinematicsParams, SimOptions, simulate_study
from fingerfriction.sim.fingers import DRAWN_FIELDS, draw_fingers, study_fingers

from .test_writer import _digest


def _bem_tiny(**kw) -> SimOptions:
    """One very short trial with the BEM contact model (coarse table)."""
    d = dict(
        reps=1, subjects=("1",), surfaces=("step-up-2mm",), speeds=(120.0,), seed=3,
        kinematics=KinematicsParams(window=1.0, x_start=-1.0, x_stop=0.7),
        video_end_mm=0.7, table_step=0.25, table_loads=(0.3,),
    )
    d.update(kw)
    return SimOptions(**d)


def test_draws_are_seeded_within_25_percent_and_per_subject():
    a = draw_fingers(7, ("1", "2"))
    b = draw_fingers(7, ("2",))
    assert a["2"] == b["2"]  # a subject's draw depends on the seed and its label only
    assert a == draw_fingers(7, ("1", "2"))
    assert a["1"] != draw_fingers(8, ("1",))["1"]
    for label, f in a.items():
        base = SUBJECTS[int(label)]
        for name in DRAWN_FIELDS:
            r = getattr(f, name) / getattr(base, name)
            assert 0.75 <= r <= 1.25 and r != 1.0
        assert f.width == base.width and f.shape == base.shape
    # the spread of many draws fills +-25 %
    ratios = np.array([draw_fingers(s, ("1",))["1"].radius / SUBJECTS[1].radius for s in range(200)])
    assert ratios.min() < 0.78 and ratios.max() > 1.22


def test_explicit_finger_wins_over_the_draw():
    f = FingerParams(radius=20.0, modulus=0.2, width=10.0, flat_length=5.0)
    got = study_fingers({"1": f.to_dict()}, 3, ("1", "2"))
    assert got["1"] == f and got["2"] == draw_fingers(3, ("2",))["2"]
    assert study_fingers({}, None, ("1", "2")) is None


def test_options_record_fingers_only_when_set():
    d = SimOptions().to_dict()
    assert "fingers" not in d and "finger_seed" not in d  # default studies unchanged
    f = FingerParams(radius=20.0, modulus=0.2, width=10.0, flat_length=5.0)
    o = SimOptions(fingers={"2": f}, finger_seed=5)
    d = o.to_dict()
    assert d["finger_seed"] == 5 and d["fingers"] == {"2": f.to_dict()}
    assert SimOptions.from_dict(json.loads(json.dumps(d))) == o


@pytest.mark.parametrize("kw, match", [
    (dict(finger_seed=-1), "finger_seed must be an integer >= 0"),
    (dict(finger_seed=1.5), "finger_seed must be an integer"),
    (dict(fingers={"3": {"radius": 20, "modulus": 0.2, "width": 10}}), "subject '3' is not simulated"),
    (dict(fingers={"1": {"radius": -2, "modulus": 0.2, "width": 10}}), "finger of subject 1: .*radius"),
    (dict(fingers={"1": {"radius": 20, "modulus": 0.2}}), "finger of subject 1: .*width"),
    (dict(fingers={"1": {"radius": 20, "modulus": 0.2, "width": 10, "colour": 1}}), "unknown field"),
    (dict(finger_seed=1, contact_model="bridged-foundation"), "need contact_model 'mechanics-bem'"),
])
def test_finger_option_mistakes(kw, match):
    with pytest.raises(ValueError, match=match):
        SimOptions(**kw)


def test_finger_file_round_trip_and_errors(tmp_path):
    f = dataclasses.replace(SUBJECTS[2], radius=19.5, name="mine")
    p = write_finger_file(tmp_path / "f.json", f, calibration={"note": "x"})
    assert read_finger_file(p) == f
    (tmp_path / "bare.json").write_text(f.to_json())
    assert read_finger_file(tmp_path / "bare.json") == f
    (tmp_path / "bad.json").write_text("{radius: 3")
    with pytest.raises(ValueError, match=r"finger file '.*bad.json': not valid JSON"):
        read_finger_file(tmp_path / "bad.json")
    (tmp_path / "neg.json").write_text(json.dumps({"radius": 20, "modulus": -1, "width": 10}))
    with pytest.raises(ValueError, match=r"neg.json'.*modulus must be a finite positive"):
        read_finger_file(tmp_path / "neg.json")
    with pytest.raises(ValueError, match="cannot read finger file"):
        read_finger_file(tmp_path / "missing.json")


@pytest.mark.slow
def test_drawn_study_is_reproducible_and_records_its_fingers(tmp_path):
    opts = _bem_tiny(finger_seed=11)
    simulate_study(tmp_path / "a", opts, workers=1)
    simulate_study(tmp_path / "b", _bem_tiny(finger_seed=11), workers=1)
    assert _digest(tmp_path / "a") == _digest(tmp_path / "b")
    truth = json.loads((tmp_path / "a" / "truth" / "study.json").read_text())
    got = finger_from_mapping(truth["subjects"]["1"]["finger"])
    assert got == draw_fingers(11, ("1",))["1"]
    assert truth["options"]["finger_seed"] == 11
    # another finger seed changes the video (a different finger) but not the kinematics
    simulate_study(tmp_path / "c", _bem_tiny(finger_seed=12), workers=1)
    da, dc = _digest(tmp_path / "a"), _digest(tmp_path / "c")
    assert da["trials/s1-step-up-2mm-v120-r1/video.mkv"] != dc["trials/s1-step-up-2mm-v120-r1/video.mkv"]


def test_cli_finger_options(tmp_path):
    f = FingerParams(radius=20.0, modulus=0.2, width=10.0, flat_length=5.0)
    write_finger_file(tmp_path / "f1.json", f)
    out = tmp_path / "o"
    for args, msg in [
        (["--finger", "1"], "expected SUBJECT=FILE"),
        (["--finger", f"1={tmp_path / 'nope.json'}"], "cannot read finger file"),
        (["--finger", f"5={tmp_path / 'f1.json'}"], "subject '5' is not simulated"),
        (["--finger-seed", "-2"], "--finger-seed must be in [0, "),
    ]:
        r = CliRunner().invoke(app, ["simulate", "--out", str(out), *args])
        assert r.exit_code == 2, (args, r.output)
        assert msg in " ".join(r.output.split()), (args, r.output)
        assert "Traceback" not in r.output
    assert not out.exists()
