"""Studies simulated with the layered finite-element finger: drawn FE fingers,
options, and one tiny study end to end (``simulate --finger-model fe``)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from fingerfriction.cli import app
from fingerfriction.mechanics.fe import FE_SUBJECTS, FEFingerParams, FEProvider
from fingerfriction.mechanics.finger_file import write_finger_file
from fingerfriction.sim import KinematicsParams, SimOptions, simulate_study
from fingerfriction.sim.fingers import FE_DRAWN_FIELDS, draw_fingers, study_fingers


def test_fe_draws_are_valid_seeded_and_span_25_percent():
    a = draw_fingers(4, ("1", "2"), "fe")
    assert a == draw_fingers(4, ("1", "2"), "fe") and a["2"] == draw_fingers(4, ("2",), "fe")["2"]
    ratios = []
    for seed in range(200):  # every draw is a valid finger (FEFingerParams validates geometry)
        f = draw_fingers(seed, ("1",), "fe")["1"]
        assert isinstance(f, FEFingerParams)
        ratios.append([getattr(f, n) / getattr(FE_SUBJECTS["1"], n) for n in FE_DRAWN_FIELDS[:5]])
    r = np.array(ratios)
    assert r.min() >= 0.75 and r.max() <= 1.25
    assert np.all(r.min(axis=0) < 0.78) and np.all(r.max(axis=0) > 1.22)


def test_fe_options_provider_and_table_step():
    o = SimOptions(contact_model="fe", finger_seed=2)
    p = o.provider()
    assert isinstance(p, FEProvider) and p.fingers == draw_fingers(2, ("1", "2"), "fe")
    assert o.table_step == 0.1 and SimOptions().table_step == 0.02
    assert p.finger_dict("1")["model"] == "fe"
    f = FE_SUBJECTS["2"]
    got = study_fingers({"1": {"model": "fe", **f.to_dict()}}, None, ("1", "2"), "fe")
    assert got["1"] == f and got["2"] == FE_SUBJECTS["2"]
    with pytest.raises(ValueError, match="not an FE finger"):
        SimOptions(contact_model="fe", fingers={"1": {"radius": 8.0, "modulus": 0.1, "width": 10.0}})


def test_fe_studies_carry_each_subjects_sliding_friction():
    from fingerfriction.sim.physics import SUBJECT_FORCE_LAWS
    from fingerfriction.surfaces import get_surface

    p = SimOptions(contact_model="fe").provider()
    surf, xs = get_surface("bump-2mm"), np.arange(-3.0, 3.0, 0.1)
    for s in ("1", "2"):
        assert p.mu(s) == SUBJECT_FORCE_LAWS[s].mu > 0 and p.finger_dict(s)["friction"] == p.mu(s)
    # the traction is part of the cache key: a frictionless table is another entry
    free = FEProvider(cache_dir=False)
    assert free.mu("1") == 0.0 and free.cache_key(surf, "1", xs, 0.3) != p.cache_key(surf, "1", xs, 0.3)
    assert FEProvider(friction={"1": 0.55}).mu("2") == 0.0
    for bad in (-0.1, float("nan"), True, {"1": 9.0}):
        with pytest.raises(ValueError, match="friction of subject"):
            FEProvider(friction=bad)
    # a truth finger (with its "friction" entry) reads back as the finger with that friction
    got = study_fingers({"1": p.finger_dict("1")}, None, ("1",), "fe")
    assert got["1"] == dataclasses.replace(p.fingers["1"], friction=p.mu("1"))


def test_a_bad_fe_mesh_setting_is_a_one_line_error(monkeypatch):
    monkeypatch.setenv("FINGERFRICTION_FE_MESH", '{"surface_cel": 0.4}')
    with pytest.raises(ValueError, match="FINGERFRICTION_FE_MESH=.* is not a valid FE mesh"):
        FEProvider()


def test_cli_fe_finger_model_errors_are_one_line(tmp_path):
    bad = tmp_path / "half.json"
    bad.write_text('{"radius": 8, "modulus": 0.1, "width": 10}')
    r = CliRunner().invoke(app, ["simulate", "--out", str(tmp_path / "s"), "--finger-model", "fe",
                                 "--finger", f"1={bad}"])
    assert r.exit_code == 2 and "not an FE finger" in r.output
    r = CliRunner().invoke(app, ["simulate", "--out", str(tmp_path / "s"), "--finger-model", "wax"])
    assert r.exit_code == 2 and "--finger-model must be halfspace or fe" in r.output


@pytest.mark.slow
def test_a_tiny_fe_study_from_the_finger_file_and_its_cache(tmp_path, monkeypatch):
    """One short trial on a shallow bump with an FE finger file; simulated again into another
    folder, the contact tables come from the cache (no new cache entry)."""
    monkeypatch.setenv("FINGERFRICTION_CACHE", str(tmp_path / "cache"))
    coarse = '{"surface_cell": 0.4, "skin_layers": 1, "tissue_layers": 3}'
    monkeypatch.setenv("FINGERFRICTION_FE_MESH", coarse)
    finger = write_finger_file(tmp_path / "fe1.json", FE_SUBJECTS["1"])
    args = ["simulate", "--reps", "1", "--subjects", "1", "--surfaces", "bump:W=4,H=0.2", "--speeds", "120",
            "--finger-model", "fe", "--finger", f"1={finger}", "--workers", "1", "--quiet"]
    opts = dict(reps=1, subjects=("1",), surfaces=("bump:W=4,H=0.2",), speeds=(120.0,), seed=0,
                kinematics=KinematicsParams(window=1.0, x_start=-1.0, x_stop=0.7), video_end_mm=0.7,
                table_step=0.5, table_loads=(0.3,), contact_model="fe",
                fingers={"1": {"model": "fe", **FE_SUBJECTS["1"].to_dict()}})
    study = simulate_study(tmp_path / "a", SimOptions(**opts), workers=1)
    entries = sorted((tmp_path / "cache" / "fe").glob("*.npz"))
    assert len(entries) == 1 and len(study.trials) == 1
    truth = json.loads((tmp_path / "a" / "truth" / "study.json").read_text())
    assert truth["contact_model"] == "fe" and truth["subjects"]["1"]["finger"]["model"] == "fe"
    assert truth["subjects"]["1"]["finger"]["mesh"]["surface_cell"] == 0.4
    simulate_study(tmp_path / "b", SimOptions(**opts), workers=1)
    assert sorted((tmp_path / "cache" / "fe").glob("*.npz")) == entries
    # the command line takes the same finger file (help text and option parsing only: the
    # default design would take minutes)
    r = CliRunner().invoke(app, args[:-1] + ["--help"])
    assert r.exit_code == 0 and "--finger-model" in r.output
