"""Every size, step and count a user gives has a bound: command-line options,
the manifest's numbers and ids, JSON nesting, surfaces. A value outside is a one-line
error naming it, never a traceback, an overflow or a run out of memory."""

from __future__ import annotations

import json
import re

import pytest
import typer
from typer.testing import CliRunner

from fingerfriction._check import parse_json
from fingerfriction.cli import app
from fingerfriction.fit import mu_grid
from fingerfriction.study.check import check_study
from fingerfriction.surfaces import surface_from_spec

runner = CliRunner()


def test_every_numeric_option_of_every_command_has_a_bound():
    group = typer.main.get_command(app)
    unbounded = []
    for name, cmd in group.commands.items():
        for p in cmd.params:
            ann = getattr(getattr(p, "type_descriptor", None), "annotation", None)
            if any(k in str(ann) for k in ("int", "float")) and getattr(p.callback, "bounds", None) is None:
                unbounded.append(f"{name} {p.opts[0]}")
    assert not unbounded, unbounded


@pytest.mark.parametrize("args,message", [
    (["fit", "r", "--mu-step", "1e-9"], "error: --mu-step must be in [0.0001, 1], got 1e-09"),
    (["predict", "--surface", "bump-2mm", "--subject", "1", "--step", "1e-7"],
     "error: --step must be in [0.001, 1] mm, got 1e-07"),
    (["analyze", "s", "--out", "r", "--workers", "0"], "error: --workers must be in [1, 256] workers, got 0"),
    (["render", "--surface", "bump-2mm", "--subject", "1", "--out", "c.wav", "--speed", "inf"],
     "error: --speed must be in [0.1, 10000] mm/s, got inf"),
])
def test_an_option_out_of_bounds_is_one_line_exit_2(args, message):
    r = runner.invoke(app, args)
    assert r.exit_code == 2 and r.output.strip() == message, r.output


def test_mu_grid_has_a_bound():
    with pytest.raises(ValueError, match=r"has 6e\+08 values, more than the 10001 allowed"):
        mu_grid(0.3, 0.9, 1e-9)
    assert mu_grid(0.0, 5.0, 0.0005).size == 10_001


@pytest.mark.parametrize("spec,message", [
    ("bump:W=1e9,H=1e9", "width W = 1e+09 mm is outside the physical range [0.05, 50] mm"),
    ("bump:W=3,H=11", "height H = 11 mm is above the 10 mm"),
    ("step-up:W=3,H=3,C=60", "center C = 60 mm is more than 50 mm from the origin"),
    ("bump:W=1,H=3", "rises at 83.9 degrees, steeper than the 80 degrees"),
])
def test_surface_specs_have_physical_ranges(spec, message):
    with pytest.raises(ValueError, match=re.escape(message)):
        surface_from_spec(spec)


def test_json_nesting_size_and_huge_integers_are_one_line_errors():
    for text, message in [("[" * 100_000 + "]" * 100_000, "nested too deeply"),
                          ("[" * 70 + "]" * 70, "nested more than 64 levels deep"),
                          ("7" * 5000, "Exceeds the limit"), ("{", "not valid JSON (line 1")]:
        with pytest.raises(ValueError, match=re.escape(message)):
            parse_json(text, "f.json")


def _manifest(tmp_path, **entry):
    t = {"id": "t1", "subject": "1", "surface": "bump-2mm", "speed_mm_s": 80,
         "video": {"path": "v.cine", "fps": 250.0, "n_frames": 10, "width": 40, "height": 20},
         "force": {"path": "f.npz", "fs_hz": 1e4, "n_samples": 100}}
    t.update(entry)
    text = json.dumps({"format": "fingerfriction-study", "schema_version": 1, "trials": [t]})
    (tmp_path / "manifest.json").write_text(text.replace('"N_FRAMES"', "1" + "0" * 400))
    return check_study(tmp_path, files=False)


def test_manifest_numbers_have_bounds(tmp_path):
    res = _manifest(tmp_path, video={"path": "v.cine", "fps": 250.0, "n_frames": "N_FRAMES"})
    assert [str(p) for p in res.problems] == [
        f"{tmp_path / 'manifest.json'}: trials[0].video.n_frames: must be at most 1e+07 frames, got a number "
        "of 401 digits"]
    res = _manifest(tmp_path, speed_mm_s=1e9)
    assert "trials[0].speed_mm_s: must be at most 10000 mm/s, got 1000000000.0" in str(res.problems[0])


def test_a_long_id_is_that_trials_problem(tmp_path):
    res = _manifest(tmp_path, id="x" * 300)
    (p,) = res.problems
    assert p.kind == "trial" and p.trial == "x" * 40 + "...(300 characters)"
    assert "is longer than 128 characters (MAX_ID_LENGTH)" in p.message
