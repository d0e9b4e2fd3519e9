"""Tests of fingerfriction.predict: prediction on unrecorded surfaces, validity, params."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pandas as pd
import pytest

from fingerfriction.mechanics import SUBJECTS, solve_contact, sweep
from fingerfriction.model import FrictionParams, LoadParams
from fingerfriction.model.blindspots import blind_spots
from fingerfriction.predict import (
    MAX_SLOPE_ANGLE,
    PAPER_MU,
    ProfileTooSteepError,
    check_profile,
    default_params,
    flat_contact_length,
    load_params,
    predict,
)
from fingerfriction.surfaces import RaisedCosine, SampledProfile, get_surface

STEP = 0.05  # mm: coarse finger step keeps these tests fast (the default is 0.01)
PARAMS = FrictionParams(mu=0.55, p0=0.065, p1=0.1)


@pytest.fixture(scope="module")
def bump3():
    """A prediction on a surface outside the paper's six: 3 mm bump, H = 0.5 mm."""
    return predict("bump:W=3,H=0.5", 1, PARAMS, step=STEP)


@pytest.mark.slow
def test_unrecorded_surface_end_to_end(bump3, tmp_path):
    p = bump3
    assert p.surface.width == 3.0 and p.surface.height == 0.5
    x = p.positions
    assert x[0] == pytest.approx(-13.0) and x[-1] == pytest.approx(13.0)
    np.testing.assert_allclose(p.F_T, p.F_int + p.F_def, rtol=0, atol=1e-15)
    # Finger on flat ground at both ends: only the interfacial term, p0 mu L.
    assert p.F_def[0] == 0.0 and p.F_def[-1] == 0.0
    assert p.F_T.max() > p.F_T[0] + 0.01  # the bump raises the force
    paths = p.write(tmp_path)
    forces = pd.read_csv(paths["forces"])
    assert list(forces.columns[:4]) == ["x_mm", "F_T_N", "F_int_N", "F_def_N"]
    np.testing.assert_allclose(forces["F_T_N"], p.F_T, rtol=1e-8)
    summary = json.loads(open(paths["summary"]).read())
    assert summary["contact"] == "geometric" and summary["geom_tol_mm"] == 0.07
    for k in ("forces_png", "occupancy_png"):
        with open(paths[k], "rb") as fh:
            assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
    bs = pd.read_csv(paths["blind_spots"])
    assert len(bs) == len(p.blind_spots)


@pytest.mark.slow
@pytest.mark.parametrize("spec", ["bump:W=3,H=0.5", "step-up:W=3,H=0.6"])
def test_blind_spots_consistent_with_contact_sweep(bump3, spec):
    """The prediction's blind spots are the gaps of the forward model's own sweep: never
    inside any geometric region, bounded by contacted points, and contained in the
    (wider) gaps of the mechanical contact of the same sweep. Both surfaces have blind
    spots with the calibrated fingers (so the checks below are not vacuous)."""
    p = bump3 if spec == "bump:W=3,H=0.5" else predict(spec, 1, PARAMS, step=0.1)
    assert len(p.blind_spots) >= 1
    res = sweep(p.surface, SUBJECTS[1], p.positions, load=0.3)
    assert res.all_converged
    np.testing.assert_array_equal(p.regions, res.geometric_regions)
    ref = res.blind_spots("geometric")
    np.testing.assert_allclose(p.blind_spots.intervals, ref.intervals)
    iv = res.geometric_regions.reshape(-1, 2)
    iv = iv[~np.isnan(iv[:, 0])]
    mech = blind_spots(res.mechanical_regions)
    for a, b in p.blind_spots.intervals:
        # never contacted: no region overlaps (a, b)
        assert not np.any((iv[:, 0] < b - 1e-12) & (iv[:, 1] > a + 1e-12))
        # maximal: both ends are reached by some region
        assert np.any(np.isclose(iv[:, 1], a)) and np.any(np.isclose(iv[:, 0], b))
        # mechanical contact is narrower, so its blind spot around this one is wider
        assert any(ma <= a + 1e-9 and mb >= b - 1e-9 for ma, mb in mech.intervals)
    assert p.max_contacts == res.max_contacts("geometric")


def test_flat_ground_is_amontons_with_flat_consistent_p0():
    L = flat_contact_length(1)
    # An independent single solve of the flat contact gives the same length.
    flat = SampledProfile(np.linspace(-30, 30, 7), np.zeros(7))
    sol = solve_contact(flat, SUBJECTS[1], 0.0, n=1024)
    # (same solver, tolerance 1e-8 on the pressure: lengths agree to ~1e-7)
    assert L == pytest.approx(float(np.sum(np.diff(sol.geometric_regions, axis=1))), rel=1e-6)
    assert 2.0 < L < 20.0  # mm: a fingertip's contact at 0.3 N, widened by the 70 um criterion
    p = predict("step-up-2mm", 1, FrictionParams(0.55, 0.3 / L, 0.2), step=0.5)
    assert p.F_T[0] == pytest.approx(0.55 * 0.3, rel=1e-6)


def test_failed_sweep_is_an_error_not_a_number():
    from types import SimpleNamespace

    from fingerfriction.predict.forward import _sweep_regions

    reg = np.array([[[0.0, 1.0]], [[0.1, 1.1]], [[0.2, 1.2]]])
    res = SimpleNamespace(success=np.array([True, False, True]), positions=np.array([0.0, 0.1, 0.2]),
                          messages=["x_finger=0.1000 mm: did not converge"], regions=lambda kind: reg)
    with pytest.raises(RuntimeError, match=r"failed at 1 of 3 finger positions, first at x = 0\.100 mm"):
        _sweep_regions(res, "geometric")
    res.success[:] = True
    np.testing.assert_array_equal(_sweep_regions(res, "geometric"), reg)


@pytest.mark.slow
def test_mechanical_contact_option():
    g = predict("bump-2mm", 2, PARAMS, step=0.2)
    m = predict("bump-2mm", 2, PARAMS, step=0.2, contact="mechanical")
    # mechanical contact is narrower than geometric contact at every position
    from fingerfriction.regions import region_lengths

    lg = np.nansum(region_lengths(g.regions), axis=1)
    lm = np.nansum(region_lengths(m.regions), axis=1)
    assert np.all(lm <= lg + 1e-12) and lm.sum() < 0.9 * lg.sum()


@pytest.mark.slow
def test_default_params_provenance():
    for subject in (1, 2):
        p = default_params(subject)
        assert p.mu == PAPER_MU[subject]
        # p0 * L_flat = F_N: flat friction mu * 0.3 N
        assert p.p0 * flat_contact_length(subject) == pytest.approx(0.3, rel=1e-12)
    # p1: mean peak F_def over the four raised surfaces is 50 mN; checked through predict()
    # on a different finger step than the calibration's (0.05 mm).
    peaks = [
        predict(name, 1, None, step=0.04).F_def.max()
        for name in ("bump-2mm", "bump-4mm", "step-up-2mm", "step-up-4mm")
    ]
    assert np.mean(peaks) == pytest.approx(0.050, rel=0.03)


# ------------------------------------------------------------------ validity and bad input
def _bump_with_angle(angle):
    return RaisedCosine("bump", 3.0, math.tan(angle) * 3.0 / math.pi)


def test_slope_limit_boundary():
    assert MAX_SLOPE_ANGLE == pytest.approx(math.acos(0.75))
    ok = check_profile(_bump_with_angle(MAX_SLOPE_ANGLE - 0.005))
    assert ok == pytest.approx(MAX_SLOPE_ANGLE - 0.005, abs=1e-6)
    with pytest.raises(ProfileTooSteepError, match=r"0\.728 rad .* at most 0\.723 rad \(41\.4 deg"):
        check_profile(_bump_with_angle(MAX_SLOPE_ANGLE + 0.005))
    # the paper's steepest surfaces are inside the limit
    for name in ("bump-2mm", "bump-4mm"):
        assert check_profile(get_surface(name)) == pytest.approx(0.5610, abs=1e-3)


def test_too_steep_profile_refused_by_predict():
    with pytest.raises(ProfileTooSteepError, match=r"bump-1mm.*slope angle of 1\.004 rad.*x = -0\.250 mm"):
        predict("bump:W=1,H=0.5", 1, PARAMS)


def test_vertical_wall_csv_refused(tmp_path):
    f = tmp_path / "wall.csv"
    f.write_text("x,h\n-5,0\n-1,0\n-0.999,0\n-0.001,0\n0.0,0.5\n0.001,0.5\n1,0.5\n5,0.5\n")
    with pytest.raises(ProfileTooSteepError, match="wall"):
        predict(str(f), 1, PARAMS)


def test_unknown_surface_name():
    with pytest.raises(ValueError, match=r"unknown surface 'bmp-4mm'.*bump-2mm"):
        predict("bmp-4mm", 1, PARAMS)


def test_malformed_csv(tmp_path):
    f = tmp_path / "bad.csv"
    f.write_text("x,h\n0,0\n1,abc\n")
    with pytest.raises(ValueError, match=r"bad\.csv, line 3: x and h must be numbers"):
        predict(str(f), 1, PARAMS)
    g = tmp_path / "nonmono.csv"
    g.write_text("0,0\n1,0.1\n0.5,0.2\n2,0\n")
    with pytest.raises(ValueError, match="strictly increasing"):
        predict(str(g), 1, PARAMS)


def test_unknown_subject_and_bad_step():
    with pytest.raises(ValueError, match=r"unknown subject 3; known subjects: \[1, 2\]"):
        predict("bump-2mm", 3, PARAMS)
    with pytest.raises(ValueError, match="step must be"):
        predict("bump-2mm", 1, PARAMS, step=0.0)


# ------------------------------------------------------------------ parameter files
def test_load_params_forms(tmp_path):
    a = tmp_path / "a.json"
    a.write_text(PARAMS.to_json())
    assert load_params(a) == PARAMS
    b = tmp_path / "b.json"
    subjects = {"1": {"mu": 0.5, "p0": 0.1, "p1": 0.2}, "2": {"mu": 0.6, "p0": 1, "p1": 2}}
    b.write_text(json.dumps({"subjects": subjects}))
    assert load_params(b, 2) == FrictionParams(0.6, 1.0, 2.0)
    b2 = tmp_path / "b2.json"
    b2.write_text(json.dumps({"subjects": {"S1": {"mu": 0.5, "p0": 0.1, "p1": 0.2}}}))  # labels as 'S1'
    assert load_params(b2, 1) == FrictionParams(0.5, 0.1, 0.2)
    lp = tmp_path / "lp.json"
    lp.write_text(json.dumps({"subjects": {"2": json.loads(LoadParams(0.6, 0.1, 0.5, 0.2).to_json())}}))
    assert load_params(lp, 2) == LoadParams(0.6, 0.1, 0.5, 0.2)
    # one shape: a subject's parameters are the parameters' own JSON (no other layout is read)
    c = tmp_path / "c.json"
    trials = [{"p0": v, "p1": 10 * v} for v in (0.1, 0.3, 0.2)]
    c.write_text(json.dumps({"subjects": {"1": {"mu": 0.55, "trials": trials}}}))
    with pytest.raises(ValueError, match=r"c\.json: subject 1: malformed parameters \(missing 'p0'\); exp"):
        load_params(c, 1)
    with pytest.raises(ValueError, match=r"c\.json: no parameters for subject 2"):
        load_params(c, 2)
    flat = tmp_path / "flat.json"
    flat.write_text(json.dumps({"1": {"mu": 0.5, "p0": 0.1, "p1": 0.2}}))  # no 'subjects' level
    with pytest.raises(ValueError, match=r"flat\.json: malformed parameters"):
        load_params(flat, 1)
    d = tmp_path / "d.json"
    d.write_text("{not json")
    with pytest.raises(ValueError, match=r"d\.json: not valid JSON"):
        load_params(d)
    with pytest.raises(ValueError, match="cannot read parameters"):
        load_params(tmp_path / "missing.json")
    e = tmp_path / "e.json"
    e.write_text(json.dumps({"mu": 9, "p0": 0.1, "p1": 0.1}))
    with pytest.raises(ValueError, match=r"mu must be in \[0, 5\]"):
        load_params(e)


# ------------------------------------------------------------------ leave one surface out
LOSO_SURFACES = ("bump-2mm", "step-up-4mm", "step-down-2mm")
LOSO_MU = {"S1": 0.55, "S2": 0.60}
LOSO_STEP = 0.2  # mm


@pytest.fixture(scope="module")
def forward_study():
    """Per (subject, surface): positions, forward-model regions and Eq. (4) basis."""
    from fingerfriction.model import FrictionModel
    from fingerfriction.predict import forward_regions

    x = np.round(-13.0 + LOSO_STEP * np.arange(int(round(26.0 / LOSO_STEP)) + 1), 9)
    out = {}
    for subj, mu in LOSO_MU.items():
        for name in LOSO_SURFACES:
            s = get_surface(name)
            reg = forward_regions(s, SUBJECTS[int(subj[-1])], x)
            out[subj, name] = (s, x, reg, FrictionModel(s).basis(reg, mu))
    return out


def _study_trials(forward_study, *, reps, noise, param_sd, seed=0, drift_correct=True):
    """Trials whose 'video' regions are the forward model's, forces Eq. (4) + noise,
    drift-corrected over the flat segment as a measurement would be."""
    from fingerfriction.fit import Trial, flat_detrend, flat_segment_mask

    # p0/p1 = 0.2 is kept outside the mu grid (0.3..0.9) on purpose: Eq. (4) is exactly
    # invariant under (mu, p0, p1) -> (p0/p1, p1 mu, p1) (expand p0 (S + mu K) + p1 (Q + mu S)),
    # so a grid containing p0/p1 has two exact minima and mu is not identifiable.
    rng = np.random.default_rng(seed)
    trials = []
    for (subj, _name), (s, x, reg, B) in forward_study.items():
        for r in range(reps):
            p0 = 0.02 * np.exp(param_sd * rng.normal())
            p1 = 0.1 * np.exp(param_sd * rng.normal())
            F = p0 * B[:, 0] + p1 * B[:, 1]
            F = F + rng.normal(scale=noise * F.std(), size=F.size)
            if drift_correct:
                F = flat_detrend(x, F, flat_segment_mask(reg, s))
            trials.append(Trial(x, F, reg, s, subj, {"rep": str(r)}))
    return trials


@pytest.mark.slow
def test_loso_exact_on_forward_generated_study(forward_study, tmp_path):
    from fingerfriction.fit import FitOptions
    from fingerfriction.pipeline.validation import leave_one_surface_out

    trials = _study_trials(forward_study, reps=2, noise=0.0, param_sd=0.0)
    res = leave_one_surface_out(trials, model="paper", options=FitOptions(median_kernel=1),
                                forward_step=LOSO_STEP)
    t = res.table
    assert len(t) == 3 * 3  # (S1, S2, both) x held-out surfaces
    assert list(t["subject"]) == ["S1"] * 3 + ["S2"] * 3 + ["Both subjects"] * 3
    assert list(t["surface"][:3]) == ["bump-2mm", "step-down-2mm", "step-up-4mm"]  # Table 1 order
    # noise-free, same params in every trial: the prediction from geometry alone is exact
    np.testing.assert_allclose(t["rho_in_sample"], 1.0, atol=1e-9)
    np.testing.assert_allclose(t["rho_out_of_sample"], 1.0, atol=1e-9)
    per = t[t["subject"] != "Both subjects"]
    for row in per.itertuples():
        assert row.mu == pytest.approx(LOSO_MU[row.subject], abs=1e-12)
        assert row.p0 == pytest.approx(0.02, rel=1e-6) and row.p1 == pytest.approx(0.1, rel=1e-6)
    df = pd.read_csv(res.write_csv(tmp_path / "loso.csv"))
    assert {"rho_in_sample", "rho_out_of_sample", "rho_heldout_params_video"} <= set(df.columns)
    x, measured, predicted = res.estimates["S1", "bump-2mm"][0]
    # equal up to the solver tolerance (the LOSO sweep's positions differ by rounding)
    np.testing.assert_allclose(predicted, measured, rtol=0, atol=1e-6)


@pytest.mark.slow
def test_loso_absolute_forces(forward_study):
    """FitOptions(detrend=False): absolute forces, predicted with their flat level."""
    from fingerfriction.fit import FitOptions
    from fingerfriction.pipeline.validation import leave_one_surface_out

    trials = _study_trials(forward_study, reps=1, noise=0.0, param_sd=0.0, drift_correct=False)
    res = leave_one_surface_out(trials, model="paper", options=FitOptions(median_kernel=1, detrend=False),
                                forward_step=LOSO_STEP)
    np.testing.assert_allclose(res.table["rho_out_of_sample"], 1.0, atol=1e-9)
    _, measured, predicted = res.estimates["S2", "step-up-4mm"][0]
    assert measured[0] == pytest.approx(0.60 * 0.02 * flat_contact_length(2), rel=1e-6)  # mu p0 L_flat
    np.testing.assert_allclose(predicted, measured, rtol=0, atol=1e-6)


@pytest.mark.slow
def test_loso_noisy_study_and_wrong_finger(forward_study):
    """With 10 % noise and per-trial parameter scatter, predictions from the right finger
    lose only what the transfer of parameters loses (the 'video' regions are the forward
    model's here, so both columns agree); a forward model with the wrong finger (each
    subject's, 10x stiffer) loses much more: the validation measures the geometry."""
    from fingerfriction.fit import FitOptions
    from fingerfriction.pipeline.validation import leave_one_surface_out

    trials = _study_trials(forward_study, reps=2, noise=0.1, param_sd=0.15, seed=3)
    opts = FitOptions(median_kernel=1)
    good = leave_one_surface_out(trials, model="paper", options=opts, forward_step=LOSO_STEP).table
    # measured with the calibrated fingers: 0.88..0.995 (mu poorly identified from 2 surfaces)
    assert np.all(good["rho_out_of_sample"] > 0.85)
    np.testing.assert_allclose(good["rho_out_of_sample"], good["rho_heldout_params_video"], atol=1e-6)
    wrong = {s: dataclasses.replace(SUBJECTS[int(s[-1])], modulus=10 * SUBJECTS[int(s[-1])].modulus)
             for s in LOSO_MU}
    bad = leave_one_surface_out(trials, model="paper", options=opts, forward_step=LOSO_STEP,
                                fingers=wrong).table
    # measured: 0.62..0.73 against 0.88..0.995
    assert np.all(bad["rho_out_of_sample"] < good["rho_out_of_sample"] - 0.15)


def _load_study_trials(forward_study, *, reps, noise, seed=0):
    """Trials made by the load-consistent model on the forward regions: a finger pressing
    with 0.3 N (+-2 mN of slow wander), known (mu, p1), absolute forces."""
    from fingerfriction.fit import Trial
    from fingerfriction.model import FrictionModel

    rng = np.random.default_rng(seed)
    trials = []
    for (subj, _name), (s, x, reg, _B) in forward_study.items():
        for r in range(reps):
            fn = 0.3 + 0.002 * np.sin(x / 3.0 + r)
            F = FrictionModel(s).load_forces(reg, fn, LoadParams(LOSO_MU[subj], 0.04)).total
            F = F + rng.normal(scale=noise * F.std(), size=F.size)
            labels = {"rep": str(r), "trial": f"{subj}-{_name}-{r}"}
            trials.append(Trial(x, F - F.mean(), reg, s, subj, labels, force_abs=F, normal_abs=fn))
    return trials


@pytest.mark.slow
def test_loso_load_model_exact_on_forward_generated_study(forward_study):
    """The load-consistent model on data it made: mu from flat ground, p1 and the
    (default-fitted) load-bearing contact come back, the prediction at the nominal load of
    a held-out surface matches up to the +-2 mN load wander."""
    from fingerfriction.fit import LoadFitOptions
    from fingerfriction.pipeline.validation import leave_one_surface_out

    trials = _load_study_trials(forward_study, reps=2, noise=0.0)
    opts = LoadFitOptions(median_kernel=1, inset=0.0, kappa=0.0)
    res = leave_one_surface_out(trials, model="load", load_options=opts, forward_step=LOSO_STEP)
    t = res.table
    assert set(t["model"]) == {"load"}
    np.testing.assert_allclose(t["rho_in_sample"], 1.0, atol=1e-9)
    np.testing.assert_allclose(t["rho_out_of_sample_measured_load"], 1.0, atol=1e-6)
    np.testing.assert_allclose(t["rho_heldout_params_video"], 1.0, atol=1e-6)
    assert np.all(t["rho_out_of_sample"] > 0.95)  # the nominal load misses only the wander
    per = t[t["subject"] != "Both subjects"]
    for row in per.itertuples():
        assert row.mu == pytest.approx(LOSO_MU[row.subject], rel=1e-9)
        assert row.p1 == pytest.approx(0.04, rel=1e-6)
        assert row.inset_mm == 0.0 and row.kappa_per_mm == 0.0 and np.isnan(row.p0)


@pytest.mark.slow
def test_loso_bad_input(forward_study):
    from fingerfriction.pipeline.validation import leave_one_surface_out

    trials = _study_trials(forward_study, reps=1, noise=0.0, param_sd=0.0)
    one = [t for t in trials if t.surface.name == "bump-2mm"]
    with pytest.raises(ValueError, match="at least 2 surfaces"):
        leave_one_surface_out(one, model="paper")
    with pytest.raises(ValueError, match="model must be one of"):
        leave_one_surface_out(trials, model="hertz")
    with pytest.raises(ValueError, match="cannot map subject 'Alice'"):
        from fingerfriction.fit import Trial

        t0 = trials[0]
        leave_one_surface_out([Trial(t0.x, t0.force, t0.regions, t0.surface, "Alice")] + trials[1:],
                              model="paper")
    with pytest.raises(TypeError, match=r"trials\[0\] must be a fingerfriction.fit.Trial"):
        leave_one_surface_out([object()])


# ------------------------------------------------------------------ command line
def test_cli_predict(tmp_path):
    from typer.testing import CliRunner

    from fingerfriction.cli import app

    pfile = tmp_path / "p.json"
    pfile.write_text(PARAMS.to_json())
    out = tmp_path / "pred"
    r = CliRunner().invoke(app, ["predict", "--surface", "bump:W=3,H=0.6", "--subject", "1", "--params",
                                 str(pfile), "--out", str(out), "--step", "0.1", "--no-figures"])
    assert r.exit_code == 0, r.output
    assert "blind spots" in r.output and (out / "forces.csv").exists() and not (out / "forces.png").exists()
    bad = CliRunner().invoke(app, ["predict", "--surface", "bump:W=1,H=0.5", "--subject", "1"])
    assert bad.exit_code == 2 and "at most 0.723 rad" in bad.output and "Traceback" not in bad.output
    bad = CliRunner().invoke(app, ["predict", "--surface", "nope-4mm", "--subject", "1"])
    assert bad.exit_code == 2 and "unknown surface 'nope-4mm'" in bad.output


# ------------------------------------------------------------------ results store (pipeline)
def _synthetic_results(tmp_path):
    import importlib.util
    from pathlib import Path

    path = Path(__file__).parents[1] / "report" / "report_synthetic.py"
    spec = importlib.util.spec_from_file_location("ff_report_synthetic", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    root = tmp_path / "results"
    mod.write_synthetic_results(root)
    return root


@pytest.mark.slow
def test_params_from_pipeline_fit_and_validate_results(tmp_path):
    from fingerfriction.pipeline.fitting import fit

    root = _synthetic_results(tmp_path)
    # the fit's own leave-one-surface-out is not what is tested here (the `validate` command
    # below writes loso.csv and loso.png): left out, the variant is chosen on Table 1
    fit(root, progress=False, median_kernel=1, validate=False)
    trials = pd.read_csv(root / "fit" / "trials.csv", dtype={"subject": str})
    fj = json.loads((root / "fit" / "fit.json").read_text())
    assert fj["model"] == "load"
    for src in (root, root / "fit", root / "fit" / "fit.json"):
        sel = trials[(trials["subject"] == "2") & (trials["model"] == "load")]
        load = fj["models"]["load"]
        assert load_params(src, "2") == LoadParams(fj["mu"]["2"], sel["p1"].median(), load["inset_mm"]["2"],
                                                   load["kappa_per_mm"]["2"])
        sel = trials[(trials["subject"] == "2") & (trials["model"] == "paper")]
        assert load_params(src, "2", model="paper") == FrictionParams(
            fj["models"]["paper"]["mu"]["2"], sel["p0"].median(), sel["p1"].median())
    with pytest.raises(ValueError, match=r"no fitted mu for subject '3'"):
        load_params(root, "3")
    from typer.testing import CliRunner

    from fingerfriction.cli import app

    r = CliRunner().invoke(app, ["validate", str(root), "--step", "0.05"])
    assert r.exit_code == 0, r.output
    assert "out-of-sample validation" in r.output
    df = pd.read_csv(root / "fit" / "loso.csv", dtype={"subject": str})
    with open(root / "fit" / "loso.png", "rb") as fh:
        assert fh.read(8) == b"\x89PNG\r\n\x1a\n"
    from fingerfriction.fit.variants import MODELS

    # every variant of the registry, validated on the same trials
    assert len(df) == len(MODELS) * 2 * 3 and set(df["surface"]) == {"bump-2mm", "step-down-4mm"}
    assert list(dict.fromkeys(df["model"])) == list(MODELS)
    df = df[df["model"] == "paper"]
    assert np.all(np.isfinite(df["rho_in_sample"])) and np.all(np.isfinite(df["rho_out_of_sample"]))
    # in-sample rho is the study's Table 1 (same grid and options as the recorded fit)
    from fingerfriction.fit import FitOptions, fit_trials, mu_grid
    from fingerfriction.model.stats import correlation_table
    from fingerfriction.pipeline.validation import trials_from_results

    g = fj["mu_grid"]
    grid = mu_grid(g["start"], g["stop"], g["step"])
    opts = FitOptions(**fj["options"])
    t1 = correlation_table(fit_trials(trials_from_results(root), grid=grid, options=opts))
    got = df.set_index(["subject", "surface"])["rho_in_sample"]
    ref = t1.set_index(["subject", "shape"])["rho"]
    assert got["1", "bump-2mm"] == pytest.approx(ref["1", "Bump"], abs=1e-6)
    bad = CliRunner().invoke(app, ["validate", str(tmp_path / "nowhere")])
    assert bad.exit_code == 2 and "Traceback" not in bad.output
    _a_failed_sweep_is_a_row_not_an_abort(root, tmp_path)


def _a_failed_sweep_is_a_row_not_an_abort(root, tmp_path):
    """The forward model's contact solver failing on one held-out surface (an FE finger's
    unconverged positions, say) costs that surface's cells, with the reason, not the run:
    the other surfaces are predicted, the table written, the exit status 1."""
    from collections import OrderedDict

    from typer.testing import CliRunner

    from fingerfriction.cli import app
    from fingerfriction.pipeline import validation

    real = validation.forward_regions

    def failing(surface, finger, positions, **kw):
        if surface.name == "step-down-4mm":
            raise RuntimeError("the FE contact solver failed at 19 of 261 finger positions on step-down-4mm")
        return real(surface, finger, positions, **kw)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(validation, "forward_regions", failing)
        mp.setattr(validation, "_sweep_memo", OrderedDict())  # solve again, not from this process's memo
        r = CliRunner().invoke(app, ["validate", str(root), "--step", "0.05",
                                     "--out", str(tmp_path / "l.csv")])
    assert r.exit_code == 1, r.output
    assert "Traceback" not in r.output
    import re

    from fingerfriction.fit.variants import MODELS

    said = re.search(r"not predicted \(([a-z, ]+)\) step-down-4mm: no prediction for subject 1 on "
                     r"step-down-4mm: the FE contact solver failed at 19 of 261", " ".join(r.output.split()))
    assert said and set(said.group(1).split(", ")) == set(MODELS), r.output  # one line for every variant
    df = pd.read_csv(tmp_path / "l.csv", dtype={"subject": str})
    down, bump = df[df["surface"] == "step-down-4mm"], df[df["surface"] == "bump-2mm"]
    assert down["rho_out_of_sample"].isna().all() and bump["rho_out_of_sample"].notna().all()
    assert down["note"].str.len().gt(0).all() and bump["note"].isna().all()
    pooled = down[~down["subject"].isin(["1", "2"])]["note"]
    assert len(pooled) == 4 and pooled.str.startswith("no pooled prediction: subject 1, 2").all()


def test_a_failed_forward_sweep_is_kept_and_raised_again(monkeypatch):
    """The variants of one validation share the forward sweeps: a sweep the solver failed is
    not solved again for the next variant, its error is raised again."""
    from types import SimpleNamespace

    from fingerfriction.pipeline import validation

    calls = []

    def failing(surface, finger, positions, **kw):
        calls.append(surface)
        raise RuntimeError("the contact solver failed at 3 of 41 finger positions")

    monkeypatch.setattr(validation, "forward_regions", failing)
    trials = [SimpleNamespace(x=np.linspace(-1.0, 1.0, 21))]
    cache = {}
    for _ in range(2):
        with pytest.raises(RuntimeError, match="failed at 3 of 41"):
            validation._forward_sweep(cache, "bump", "finger", trials, load=0.3, contact="geometric",
                                      step=0.1)
    assert calls == ["bump"]


@pytest.mark.slow
def test_loso_short_window_without_forward_flat_segment():
    """In a window where the forward finger touches the feature (within 70 um) from the
    first positions, the prediction needs no flat segment of its own: its footing is the
    forward model's exact flat-ground level."""
    from fingerfriction.fit import FitOptions, Trial, flat_detrend, flat_segment_mask
    from fingerfriction.mechanics import FingerParams
    from fingerfriction.model import FrictionModel
    from fingerfriction.pipeline.validation import leave_one_surface_out
    from fingerfriction.predict import forward_regions

    x = np.round(-8.0 + 0.2 * np.arange(81), 9)
    rng = np.random.default_rng(1)
    trials = []
    video_finger = FingerParams(radius=8.0, modulus=0.1, width=10.0)  # a smaller finger "filmed"
    for subj in ("1", "2"):
        f = SUBJECTS[int(subj)]
        for name in ("bump-2mm", "step-up-2mm", "bump-4mm"):
            s = get_surface(name)
            reg = forward_regions(s, video_finger, x)
            B = FrictionModel(s).basis(reg, 0.55)
            F = 0.02 * B[:, 0] + 0.1 * B[:, 1] + rng.normal(scale=1e-3, size=x.size)
            F = flat_detrend(x, F, flat_segment_mask(reg, s))
            trials.append(Trial(x, F, reg, s, subj))
            assert np.count_nonzero(flat_segment_mask(forward_regions(s, f, x), s)) < 2  # the premise
    res = leave_one_surface_out(trials, model="paper", options=FitOptions(median_kernel=1), forward_step=0.2)
    t = res.table
    assert np.all(np.isfinite(t["rho_out_of_sample"]))
    # the footing is the exact flat level, not a line: predicted - (Eq. 4 - mu p0 L_flat) = 0
    x_, measured, predicted = res.estimates["1", "bump-2mm"][0]
    row = t[(t["subject"] == "1") & (t["surface"] == "bump-2mm")].iloc[0]
    reg = forward_regions(get_surface("bump-2mm"), SUBJECTS[1], x_)
    eq4 = FrictionModel(get_surface("bump-2mm")).forces(reg, FrictionParams(row.mu, row.p0, row.p1)).total
    level = row.mu * row.p0 * flat_contact_length(1)
    np.testing.assert_allclose(predicted, eq4 - level, rtol=0, atol=1e-6)


@pytest.mark.slow
def test_predict_uses_the_load_consistent_model_by_default():
    """Without parameters: the load-consistent model (its pressure carries the 0.3 N), the
    paper's on request; both are Amontons' law on flat ground, they differ on the relief."""
    load_pred = predict("bump:W=3,H=0.5", 1, step=0.05)
    paper_pred = predict("bump:W=3,H=0.5", 1, step=0.05, model="paper")
    assert load_pred.model == "load" and isinstance(load_pred.params, LoadParams)
    assert paper_pred.model == "paper" and isinstance(paper_pred.params, FrictionParams)
    assert load_pred.flat_level == pytest.approx(0.55 * 0.3, rel=1e-6)
    assert paper_pred.flat_level == pytest.approx(0.55 * 0.3, rel=1e-3)  # p0 = F_N / L_flat
    assert np.max(np.abs(load_pred.F_T - paper_pred.F_T)) > 1e-3  # N: the load is conserved in one
    s = load_pred.summary()
    assert s["model"] == "load" and set(s["params"]) == {"mu", "p1", "inset", "kappa"}
    assert "load-consistent" in load_pred.params_text and "paper" in paper_pred.params_text
    with pytest.raises(ValueError, match="model must be one of"):
        predict("bump:W=3,H=0.5", 1, step=0.05, model="hertz")


@pytest.mark.slow
def test_loso_heldout_fingers_replace_the_finger_of_one_surface_only(forward_study):
    """heldout_fingers (fingers calibrated on the other surfaces) change the
    forward finger of the held-out surface named, for the subject named, and nothing else."""
    from fingerfriction.fit import FitOptions
    from fingerfriction.pipeline.validation import _with_calibrated, leave_one_surface_out

    trials = _study_trials(forward_study, reps=1, noise=0.0, param_sd=0.0)
    stiff = dataclasses.replace(SUBJECTS[1], modulus=10 * SUBJECTS[1].modulus)
    held = {"bump-2mm": {"S1": stiff}}
    opts = FitOptions(median_kernel=1)
    t = leave_one_surface_out(trials, model="paper", options=opts, forward_step=LOSO_STEP,
                              heldout_fingers=held).table
    changed = (t["subject"].isin(["S1", "Both subjects"])) & (t["surface"] == "bump-2mm")
    assert np.all(t.loc[changed, "rho_out_of_sample"] < 0.99)
    np.testing.assert_allclose(t.loc[~changed, "rho_out_of_sample"], 1.0, atol=1e-9)
    # the columns validate_results adds: NaN where a subject kept its default finger
    base = leave_one_surface_out(trials, model="paper", options=opts, forward_step=LOSO_STEP).table
    merged = _with_calibrated(base, t, held)
    assert len(merged) == len(base)
    got = merged.set_index(["subject", "surface"])["rho_out_of_sample_calibrated_finger"]
    assert got["S1", "bump-2mm"] == pytest.approx(float(t[(t.subject == "S1") & (t.surface == "bump-2mm")]
                                                         ["rho_out_of_sample"].iloc[0]))
    assert np.isnan(got["S2", "bump-2mm"]) and np.isnan(got["Both subjects", "bump-2mm"])
    assert np.isnan(got["S1", "step-up-4mm"])


def test_predict_takes_an_fe_finger_file(tmp_path, monkeypatch):
    """``predict --finger FE.json``: the layered FE finger (with its friction) is the forward
    model; the solve itself is replaced here by a stand-in (tests/mechanics/test_fe.py runs it)."""
    import dataclasses

    from typer.testing import CliRunner

    from fingerfriction.cli import app
    from fingerfriction.mechanics.fe import LITERATURE_FINGER, FEFingerParams
    from fingerfriction.mechanics.finger_file import write_finger_file
    from fingerfriction.model import LoadParams
    from fingerfriction.predict import forward, predict

    seen = []

    def stand_in(surface, finger, x, load, contact):
        seen.append(finger)
        reg = np.stack([x - 3.0, x + 3.0], axis=1)[:, None, :]
        return reg

    monkeypatch.setattr(forward, "_fe_regions", stand_in)
    f = dataclasses.replace(LITERATURE_FINGER, friction=0.55, name="calibrated FE")
    path = write_finger_file(tmp_path / "fe.json", f)
    params = LoadParams(mu=0.55, p1=0.1)
    pred = predict("bump-2mm", 1, params, finger=f, step=0.1)
    assert seen[-1] == f and pred.finger == f and np.allclose(pred.F_T[0], 0.55 * 0.3)
    (tmp_path / "p.json").write_text(params.to_json())
    r = CliRunner().invoke(app, ["predict", "--surface", "bump-2mm", "--subject", "1", "--params",
                                 str(tmp_path / "p.json"), "--finger", str(path), "--step", "0.1",
                                 "--no-figures", "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    assert isinstance(seen[-1], FEFingerParams) and seen[-1].friction == 0.55
    with pytest.raises(TypeError, match="FingerParams or an FEFingerParams"):
        predict("bump-2mm", 1, params, finger=f.to_dict())
