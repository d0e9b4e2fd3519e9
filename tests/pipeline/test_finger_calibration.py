"""Calibrating a finger from a results folder (fingerfriction.pipeline.finger_calibration)."""

from __future__ import annotations

import dataclasses
import functools
import json

import numpy as np
import pandas as pd
import pytest

from fingerfriction.mechanics import SUBJECTS, sweep
from fingerfriction.mechanics.calibrate import CalibrationError, CalibrationOptions
from fingerfriction.pipeline.finger_calibration import calibrate_results, trials_from_results
from fingerfriction.study import AnalysedTrial, ResultsStore, frames_table
from fingerfriction.surfaces import get_surface

TRUE = dataclasses.replace(SUBJECTS[2], radius=24.0, modulus=0.16, flat_length=6.5)
MMPP = 0.023


@functools.cache
def _measured(name: str, load: float) -> tuple[np.ndarray, np.ndarray]:
    """``(x, regions)`` of the true finger on the surface ``name`` at ``load``: the sweep of
    each (surface, load), solved once per process (the tests below write the same trials into
    several results folders; read-only arrays)."""
    x = np.arange(-9.0, 9.0, 0.1)
    r = sweep(get_surface(name), TRUE, x, load=load, n=1024, gap_tol=3 * MMPP)
    x, regions = np.where(r.success, x, np.nan), np.asarray(r.geometric_regions)
    x.setflags(write=False)
    regions.setflags(write=False)
    return x, regions


def _write(root, trials, *, absolute=True, video=None):
    """A results folder as `analyze` writes it, with the forward model's regions as the
    'measured' ones (vertical-gap geometric contact of a 1024-cell sweep)."""
    store = ResultsStore(root)
    surfaces, recs = {}, []
    for tid, subject, name, load in trials:
        s = get_surface(name)
        surfaces[name] = s.to_dict()
        recs.append({"id": tid, "subject": subject, "surface": name})
        x, regions = _measured(name, load)
        fr = frames_table(np.arange(x.size) * 1e-3, x, regions)
        grid = np.round(np.arange(-13.0, 13.0 + 1e-9, 0.01), 2)
        fn = np.full(grid.size, load if absolute else np.nan)
        fo = pd.DataFrame({"x_mm": grid, "F_T_N": 0.0, "F_N_N": 0.0, "F_T_abs_N": 0.1, "F_N_abs_N": fn,
                           "n_samples": 1})
        store.write_trial(AnalysedTrial.from_tables(tid, fr, fo, {"info": {"video": {"mm_per_px": MMPP}}}))
    store.write_run({"trials": recs, "surfaces": surfaces,
                     "parameters": {"video": video or {"contact_tol_px": 3.0, "min_gap_px": 5.0,
                                                       "min_region_px": 3.0}}})
    return store


DESIGN = [(f"s7-{n}-r{k}", "7", n, ld)
          for n in ("step-up-2mm", "bump-4mm") for k, ld in ((1, 0.28), (2, 0.32))]


@pytest.mark.slow
def test_reader_builds_trials_and_names_what_it_skipped(tmp_path):
    store = _write(tmp_path / "r", DESIGN[:2] + [("s8-bump-2mm-r1", "8", "bump-2mm", 0.3)])
    store.write_failure("s7-bump-4mm-r9", "video unreadable", {})
    trials, skipped = trials_from_results(tmp_path / "r", 7)
    assert [t.label for t in trials] == ["s7-step-up-2mm-r1", "s7-step-up-2mm-r2"]
    t = trials[0]
    assert t.tol == pytest.approx(3 * MMPP) and t.min_gap == pytest.approx(5 * MMPP)
    assert t.min_region == pytest.approx(3 * MMPP)
    assert np.nanmax(t.load) == pytest.approx(0.28) and t.usable().sum() > 150
    with pytest.raises(ValueError, match="no trial of subject '9'; the results have subjects 7, 8"):
        trials_from_results(tmp_path / "r", 9)
    with pytest.raises(ValueError, match="not a results folder"):
        trials_from_results(tmp_path / "nothing", 7)
    with pytest.raises(ValueError, match="load must be a positive normal force"):
        trials_from_results(tmp_path / "r", 7, load=-1.0)
    only = trials_from_results(tmp_path / "r", 7, surfaces=["bump-4mm"])[0]
    assert only == []


@pytest.mark.slow
def test_no_absolute_force_needs_an_assumed_load(tmp_path):
    _write(tmp_path / "r", DESIGN[:3], absolute=False)
    trials, skipped = trials_from_results(tmp_path / "r", "7")
    assert trials == [] and len(skipped) == 3
    assert "no absolute normal force" in skipped[0][1]
    msg = r"subject 7: no trials given.*skipped: s7-.*no absolute normal force.*\(and 2 more\)"
    with pytest.raises(CalibrationError, match=msg):
        calibrate_results(tmp_path / "r", "7")
    trials, skipped = trials_from_results(tmp_path / "r", "7", load=0.3)
    assert len(trials) == 3 and not skipped
    assert np.nanmax(trials[0].load) == 0.3


@pytest.mark.slow
def test_too_few_trials_is_one_clear_error(tmp_path):
    _write(tmp_path / "r", DESIGN[:2])
    with pytest.raises(CalibrationError, match="subject 7: only 2 trial"):
        calibrate_results(tmp_path / "r", "7")


@pytest.mark.slow
def test_calibrates_from_a_results_folder(tmp_path):
    _write(tmp_path / "r", DESIGN)
    opts = CalibrationOptions(dx=0.08, coarse_step=0.3, fine_step=0.1, n_loads=2, coarse_stride=2,
                              bootstrap=20, min_frames=50)
    res = calibrate_results(tmp_path / "r", "7", initial=SUBJECTS[2], options=opts)
    assert res.success, res.message
    assert res.n_trials == 4
    # the 'measured' regions use the vertical gap, the calibration the normal distance: a
    # small, real model difference, so 3 % rather than the exact recovery of
    # tests/mechanics/test_calibrate.py
    for f in ("radius", "modulus", "flat_length"):
        assert getattr(res.finger, f) == pytest.approx(getattr(TRUE, f), rel=0.03), f
    # an assumed load is said in the flags, converged or not: one solver step, no bootstrap
    one_step = dataclasses.replace(opts, max_nfev=1, bootstrap=0)
    res2 = calibrate_results(tmp_path / "r", "7", initial=SUBJECTS[2], options=one_step, load=0.3)
    assert any("assumed constant at 0.3 N" in f for f in res2.flags)


# ------------------------------------------------------------------------------ command line
def _cli(args):
    from typer.testing import CliRunner

    from fingerfriction.cli import app

    return CliRunner().invoke(app, args)


@pytest.mark.slow
def test_calibrate_finger_command_writes_a_finger_the_other_commands_accept(tmp_path, monkeypatch):
    import fingerfriction.mechanics.calibrate as cal
    from fingerfriction.mechanics.finger_file import read_finger_file

    _write(tmp_path / "r", DESIGN)
    fast = functools.partial(cal.CalibrationOptions, dx=0.08, coarse_step=0.3, fine_step=0.1, n_loads=2,
                             coarse_stride=2, bootstrap=20, min_frames=50)
    monkeypatch.setattr(cal, "CalibrationOptions", fast)
    out = tmp_path / "f7.json"
    r = _cli(["calibrate-finger", str(tmp_path / "r"), "--subject", "7",
              "--initial", str(tmp_path / "i.json"), "--out", str(out)])
    assert r.exit_code == 2 and "cannot read finger file" in r.output  # no such start file
    r = _cli(["calibrate-finger", str(tmp_path / "r"), "--subject", "7", "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert "wrote" in r.output and "bump-4mm" in r.output
    f = read_finger_file(out)
    assert f.radius == pytest.approx(TRUE.radius, rel=0.03)
    r = _cli(["predict-contact", "--surface", "step-up-2mm", "--finger", str(out), "--step", "0.1",
              "--out", str(tmp_path / "figs")])
    assert r.exit_code == 0, r.output
    assert "finger subject 7 (calibrated)" in " ".join(r.output.split())


@pytest.mark.slow
def test_calibrate_finger_command_errors_are_one_line(tmp_path):
    _write(tmp_path / "r", DESIGN[:2])
    for args, msg in [
        (["calibrate-finger", str(tmp_path / "nothing"), "--subject", "7"], "not a results folder"),
        (["calibrate-finger", str(tmp_path / "r"), "--subject", "9"], "no trial of subject '9'"),
        (["calibrate-finger", str(tmp_path / "r"), "--subject", "7"], "only 2 trial(s)"),
        (["calibrate-finger", str(tmp_path / "r"), "--subject", "7", "--load", "-1"], "load must be"),
    ]:
        r = _cli(args)
        assert r.exit_code == 2, (args, r.output)
        assert msg in " ".join(r.output.split()), (args, r.output)
        assert "Traceback" not in r.output
    assert not list(tmp_path.glob("finger-*.json"))


def test_finger_option_errors_are_one_line(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text('{"radius": 20, "modulus": 0.1}')
    for args in (["predict", "--surface", "bump-2mm", "--subject", "1"],
                 ["predict-contact", "--surface", "bump-2mm"],
                 ["render", "--surface", "bump-2mm", "--subject", "1", "--out", str(tmp_path / "c.wav")]):
        r = _cli(args + ["--finger", str(bad)])
        assert r.exit_code == 2, (args, r.output)
        assert "bad.json" in r.output and "width" in r.output and "Traceback" not in r.output
    r = _cli(["validate", str(tmp_path), "--finger", "1"])
    assert r.exit_code == 2 and "expected SUBJECT=FILE" in r.output


@pytest.mark.slow
def test_held_out_calibrations_record_what_failed(tmp_path):
    from fingerfriction.pipeline.finger_calibration import calibrate_held_out

    _write(tmp_path / "r", DESIGN)  # 2 surfaces x 2 trials: 2 trials left without either
    seen = []
    held = calibrate_held_out(tmp_path / "r", progress=lambda k, n, what: seen.append((k, n, what)))
    assert set(held.errors) == {("bump-4mm", "7"), ("step-up-2mm", "7")}
    assert "only 2 trial(s)" in held.errors["bump-4mm", "7"]
    assert held.fingers() == {} and held.calibrations == {}
    assert seen[-1][:2] == (2, 2)
    with pytest.raises(ValueError, match="no trial of subject '3'"):
        calibrate_held_out(tmp_path / "r", subjects=["3"])


@pytest.mark.slow
def test_held_out_calibrations_use_the_other_surfaces_only(tmp_path):
    from fingerfriction.pipeline.finger_calibration import calibrate_held_out

    _write(tmp_path / "r", DESIGN)
    opts = CalibrationOptions(dx=0.08, coarse_step=0.3, fine_step=0.1, n_loads=2, coarse_stride=2,
                              bootstrap=10, min_frames=50, min_trials=2)
    held = calibrate_held_out(tmp_path / "r", options=opts)
    assert not held.errors
    for (surf, subj), res in held.calibrations.items():
        assert subj == "7" and [s.surface for s in res.surfaces] == [n for n in ("step-up-2mm", "bump-4mm")
                                                                     if n != surf]
    f = held.fingers()
    assert set(f) == {"step-up-2mm", "bump-4mm"} and set(f["bump-4mm"]) == {"7"}


# ------------------------------------------------------------------------------ the FE family
@pytest.mark.slow  # the results folder's reference sweeps; the FE tables are an analytic stand-in
def test_fe_family_from_a_results_folder_takes_the_fits_friction(tmp_path, monkeypatch):
    import fingerfriction.pipeline.finger_calibration as fc
    from fingerfriction.mechanics.fe import FEFingerParams, surrogate
    from fingerfriction.mechanics.fe.calibration import FECalibrationOptions
    from fingerfriction.model import LoadParams
    from fingerfriction.pipeline.finger_calibration import calibrate_held_out, fitted_friction

    def stand_in(job):  # a parabola of the finger's tip radius, pressed in, conforming
        finger, surface, load, pos, mesh, grid_step, cache_dir, k = job
        u = grid_step * np.arange(-k, k + 1)
        delta = 0.3 * (load / 0.3) ** 0.7 * (0.02 / finger.tissue_modulus) ** (1 / 3)
        par = u * u / (2 * finger.tip_radius)
        y = []
        for x in pos:
            h = np.asarray(surface.h(x + u), float)
            y.append(np.maximum(h, np.max(h - par) - delta + par))
        return np.asarray(y, np.float32), np.ones(pos.size, bool), 1, 0.0

    monkeypatch.setattr(surrogate, "_one_table", stand_in)
    _write(tmp_path / "r", DESIGN)
    opts = FECalibrationOptions(fit=("tissue_modulus",), loads=(0.25, 0.35), step=0.3, bootstrap=10,
                                    min_frames=50, verify=False)
    res = calibrate_results(tmp_path / "r", "7", model="fe", options=opts)  # no fit: frictionless
    assert isinstance(res.finger, FEFingerParams) and res.finger.friction == 0.0
    assert any("frictionless FE finger: no fitted mu for subject 7" in f for f in res.flags)
    assert res.finger.name == "subject 7 (calibrated)" and res.n_trials == 4
    res = calibrate_results(tmp_path / "r", "7", model="fe", options=opts, friction=0.6)
    assert res.finger.friction == 0.6 and not any("frictionless" in f for f in res.flags)
    # the fit's flat-ground mu, rounded to FRICTION_STEP
    monkeypatch.setattr(fc, "load_params", lambda *a, **k: LoadParams(mu=0.5735, p1=0.1))
    assert fitted_friction(tmp_path / "r", "7") == (0.6, "")
    assert calibrate_results(tmp_path / "r", "7", model="fe", options=opts).finger.friction == 0.6
    with pytest.raises(ValueError, match="model must be one of halfspace, fe"):
        calibrate_results(tmp_path / "r", "7", model="bem")
    opts1 = dataclasses.replace(opts, min_trials=1)
    held = calibrate_held_out(tmp_path / "r", options=opts1, model="fe")
    assert sorted(held.calibrations) == [("bump-4mm", "7"), ("step-up-2mm", "7")]
    fingers = held.fingers()
    assert set(fingers) == {s for s, _ in held.calibrations if held.calibrations[(s, "7")].success}
    for (surf, _), r in held.calibrations.items():  # each calibrated without its held-out surface
        assert [s.surface for s in r.surfaces] == [n for n in ("step-up-2mm", "bump-4mm") if n != surf]
    # what validate writes beside its table: each held-out surface's finger, as a finger file's
    from fingerfriction.mechanics.finger_file import fe_finger_from_mapping

    d = json.loads(json.dumps(held.to_dict()))
    assert sorted(d) == ["bump-4mm", "step-up-2mm"]
    one = d["bump-4mm"]["7"]
    assert fe_finger_from_mapping(one["finger"]) == held.calibrations[("bump-4mm", "7")].finger
    assert one["success"] == held.calibrations[("bump-4mm", "7")].success
