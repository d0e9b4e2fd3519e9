"""Calibration of the layered FE finger through its surrogate of FE tables
(fingerfriction.mechanics.fe.calibration). The fast tests replace the FE tables by an
analytic stand-in finger (a parabola of the finger's tip radius, pressed in by a depth that
falls with the pulp modulus and conforming where it touches), so that the surrogate, the
optimiser and the figures are tested in seconds; the slow one runs the FE itself."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from fingerfriction.mechanics.calibrate import CalibrationError, CalibrationTrial
from fingerfriction.mechanics.fe import FE_SUBJECTS, FEFingerParams, FEMeshParams, surrogate
from fingerfriction.mechanics.fe import calibration as cal
from fingerfriction.mechanics.fe.calibration import (
    FECalibrationOptions,
    FECalibrationProblem,
    calibrate_fe_finger,
    finger_with,
)
from fingerfriction.surfaces import RaisedCosine, SampledProfile

TOL = 0.069
BASE = dataclasses.replace(FE_SUBJECTS["1"], friction=0.55)
BUMP = RaisedCosine("bump", 3.0, height=0.3, name="bump 3 mm")
FLAT = SampledProfile(np.linspace(-40, 40, 9), np.zeros(9), name="flat")


def _outline(finger: FEFingerParams, surface, load: float, x: float, u: np.ndarray) -> np.ndarray:
    """The stand-in finger's outline (mm) at cells ``x + u``: a parabola of the tip radius,
    lowered onto the relief and pressed ``delta`` deeper, conforming where it touches."""
    delta = 0.3 * (load / 0.3) ** 0.7 * (0.02 / finger.tissue_modulus) ** (1 / 3)
    par = u * u / (2 * finger.tip_radius)
    h = np.asarray(surface.h(x + u), float)
    z = np.max(h - par) - delta
    return np.maximum(h, z + par)


def _fake_table(job):
    finger, surface, load, pos, mesh, grid_step, cache_dir, k = job
    u = grid_step * np.arange(-k, k + 1)
    y = np.stack([_outline(finger, surface, load, x, u) for x in pos])
    return y.astype(np.float32), np.ones(pos.size, bool), 1, 0.0


def _trial(finger, surface, load, label):
    x = np.arange(-6.0, 6.0, 0.05)
    u = np.arange(-8.0, 8.0, 0.005)
    regs = []
    for xf in x:
        d = _outline(finger, surface, load, xf, u) - np.asarray(surface.h(xf + u), float)
        m = d <= TOL
        edges = np.flatnonzero(np.diff(m.astype(int)))
        r = (xf + u[edges] + 0.0025).reshape(-1, 2)
        regs.append(r)
    k = max(r.shape[0] for r in regs)
    arr = np.full((x.size, k, 2), np.nan)
    for i, r in enumerate(regs):
        arr[i, : r.shape[0]] = r
    return CalibrationTrial(surface, x, arr, np.full(x.size, load), label=label, tol=TOL)


# the stand-in's tracked positions are exact: the surrogate's tests leave the offset out
FAST = dict(fit=("tissue_modulus", "radius"), loads=(0.25, 0.35), step=0.2, bootstrap=30, min_trials=1,
            min_frames=10, verify=True, position_offset=False)


@pytest.fixture
def fake(monkeypatch):
    monkeypatch.setattr(surrogate, "_one_table", _fake_table)


def test_lagrange_weights_are_exact_at_the_nodes_and_reproduce_quadratics(fake):
    tr = [_trial(BASE, FLAT, 0.3, "t")]
    z = np.array([0.07, -0.13])
    for design, n, cross in (("tensor", 9, 1.0), ("star", 5, 0.0)):
        pb = FECalibrationProblem(tr, BASE, FECalibrationOptions(**FAST, design=design))
        assert len(pb.nodes) == n == len(set(pb.nodes))
        for i, node in enumerate(pb.nodes):
            w = pb.weights(pb.axes[list(node)])
            assert np.allclose(w, np.eye(n)[i])
        w = pb.weights(z)
        assert math.isclose(w.sum(), 1.0)
        # quadratics in each log-ratio are exact; the cross term only on the tensor grid
        vals = np.array([1 + 2 * pb.axes[a] - pb.axes[b] ** 2 + cross * pb.axes[a] * pb.axes[b]
                         for a, b in pb.nodes])
        assert math.isclose(w @ vals, 1 + 2 * z[0] - z[1] ** 2 + cross * z[0] * z[1], rel_tol=1e-12)
    assert len(cal.grid_nodes(3, (0.75, 1.0, 1.25), "star")) == 7
    # the fitted fields map to a finger with its bone following the outline
    f = pb.finger(np.log([1.1, 0.9]))
    assert math.isclose(f.tissue_modulus, 1.1 * BASE.tissue_modulus)
    assert math.isclose(f.radius, 0.9 * BASE.radius)
    assert math.isclose(f.bone_half_width, 0.9 * BASE.bone_half_width)
    assert f.friction == 0.55 and f.skin_modulus == BASE.skin_modulus


def test_recovers_a_stand_in_finger_inside_the_grid(fake):
    true = finger_with(BASE, {"tissue_modulus": 1.15, "radius": 0.92})
    trials = [_trial(true, s, load, f"{s.name}-{load}") for s in (FLAT, BUMP) for load in (0.27, 0.33)]
    res = calibrate_fe_finger(trials, BASE, options=FECalibrationOptions(**FAST))
    assert res.success, res.message
    assert isinstance(res.finger, FEFingerParams) and res.finger.friction == 0.55
    assert res.finger.tissue_modulus == pytest.approx(true.tissue_modulus, rel=0.03)
    assert res.finger.radius == pytest.approx(true.radius, rel=0.02)
    assert res.surrogate_rms_mm < 0.05  # interpolated across the conforming kink of the stand-in
    for s in res.surfaces:
        assert s.rms_end_mm < 0.05  # the exact stand-in at the calibrated parameters
    text = res.summary()
    assert "tissue_modulus (MPa)" in text and "surrogate" in text
    d = json.loads(json.dumps(res.to_dict()))
    assert d["parameters"]["radius"] == pytest.approx(res.finger.radius) and "surrogate_rms_mm" in d


def test_a_constant_offset_of_the_tracked_position_is_fitted_with_position_offset(fake):
    """The tracked x trails the finger by 0.15 mm (as a chord midpoint trails a finger that
    leans under friction): with ``position_offset`` the offset comes back and the finger with
    it; without, the ends are fitted worse."""
    true = finger_with(BASE, {"tissue_modulus": 1.15, "radius": 0.92})
    made = [_trial(true, s, load, f"{s.name}-{load}") for s in (FLAT, BUMP) for load in (0.27, 0.33)]
    trials = [dataclasses.replace(t, x=t.x - 0.15) for t in made]
    res = calibrate_fe_finger(trials, BASE, options=FECalibrationOptions(**{**FAST, "position_offset": True}))
    assert res.success, res.message
    assert res.position_offset_mm == pytest.approx(0.15, abs=0.01)
    assert res.finger.tissue_modulus == pytest.approx(true.tissue_modulus, rel=0.03)
    assert res.finger.radius == pytest.approx(true.radius, rel=0.02)
    assert max(s.rms_end_mm for s in res.surfaces) < 0.05
    lo, hi = res.ci95["position_offset"]
    assert lo <= res.position_offset_mm <= hi and math.isfinite(res.std["position_offset"])
    assert "position offset (mm)" in res.summary()
    saved = json.loads(json.dumps(res.to_dict()))
    assert saved["position_offset_mm"] == pytest.approx(res.position_offset_mm)
    plain = calibrate_fe_finger(trials, BASE, options=FECalibrationOptions(**FAST))
    assert math.isnan(plain.position_offset_mm) and "position_offset_mm" not in plain.to_dict()
    assert max(s.rms_end_mm for s in plain.surfaces) > 2 * max(s.rms_end_mm for s in res.surfaces)


def test_a_coarse_surrogate_corrected_at_its_verified_optimum_finds_the_exact_one(fake):
    """A coarse grid (levels x0.5-x2) interpolates the stand-in's outlines poorly: its optimum
    is 16-18 % off and 0.5 mm off in the end points. Corrected at each verified optimum by the
    exact finger's tables, the fit lands on the finger that made the data."""
    true = finger_with(BASE, {"tissue_modulus": 1.3, "radius": 0.7})
    trials = [_trial(true, s, load, f"{s.name}-{load}") for s in (FLAT, BUMP) for load in (0.27, 0.33)]
    opts = FECalibrationOptions(**{**FAST, "bootstrap": 0, "levels": (0.5, 1.0, 2.0), "max_shifts": 0})
    raw = calibrate_fe_finger(trials, BASE, options=dataclasses.replace(opts, corrections=0))
    assert abs(raw.finger.radius / true.radius - 1) > 0.1 and raw.surrogate_rms_mm > 0.1
    assert any("surrogate's end points differ" in f for f in raw.flags)
    res = calibrate_fe_finger(trials, BASE, options=opts)
    assert res.success and "the surrogate was corrected 2 time(s)" in res.message, res.message
    assert f"were {raw.surrogate_rms_mm:.3f} mm RMS off" in res.message  # the uncorrected error
    assert res.finger.tissue_modulus == pytest.approx(true.tissue_modulus, rel=0.03)
    assert res.finger.radius == pytest.approx(true.radius, rel=0.02)
    assert res.surrogate_rms_mm < opts.max_surrogate_mm
    assert not any("surrogate's end points differ" in f for f in res.flags)
    assert all(s.rms_end_mm < 0.03 for s in res.surfaces)  # the exact finger's figures
    # each correction costs one finger's tables (2 surfaces x 2 loads): 5 nodes, 1 + 2 verified
    assert (raw.n_solves, res.n_solves) == ((5 + 1) * 4, (5 + 3) * 4)
    # the bootstrap linearises at the kept optimum, a stationary point of its surrogate
    boot = calibrate_fe_finger(trials, BASE, options=dataclasses.replace(opts, bootstrap=30))
    for f in ("tissue_modulus", "radius"):
        lo, hi = boot.ci95[f]
        assert lo <= getattr(boot.finger, f) <= hi, (f, lo, hi)


def test_a_corrected_optimum_at_the_grids_edge_moves_the_grid(fake):
    """On a coarse grid the uncorrected optimum of a finger just inside its edge (radius x0.52,
    edge x0.5) lies inside; corrected, it sits at the edge: the grid moves there and the fit
    ends on the finger, where it used to stop at the edge as a failure."""
    true = finger_with(BASE, {"radius": 0.52})
    trials = [_trial(true, s, load, f"{s.name}-{load}") for s in (FLAT, BUMP) for load in (0.27, 0.33)]
    opts = FECalibrationOptions(**{**FAST, "fit": ("radius",), "bootstrap": 0, "levels": (0.5, 1.0, 2.0),
                                   "max_shifts": 1})
    res = calibrate_fe_finger(trials, BASE, options=opts)
    assert res.success and "the grid moved radius x0.5" in res.message, res.message
    assert res.finger.radius == pytest.approx(true.radius, rel=0.02)
    assert res.surrogate_rms_mm < opts.max_surrogate_mm


def test_a_corrected_fit_that_fits_the_exact_finger_worse_is_not_taken(fake):
    """At the grid's edge (no move allowed) the corrected surrogate's fit does not fit the
    exact finger better: the first optimum is kept, and the message says so."""
    true = finger_with(BASE, {"tissue_modulus": 1.3, "radius": 0.7})
    trials = [_trial(true, s, load, f"{s.name}-{load}") for s in (FLAT, BUMP) for load in (0.27, 0.33)]
    opts = FECalibrationOptions(**{**FAST, "bootstrap": 0, "max_shifts": 0})
    raw = calibrate_fe_finger(trials, BASE, options=dataclasses.replace(opts, corrections=0))
    res = calibrate_fe_finger(trials, BASE, options=opts)
    assert "fitted the exact finger worse and was not taken" in res.message
    assert "the surrogate was corrected" not in res.message
    assert res.finger == raw.finger and res.surrogate_rms_mm == raw.surrogate_rms_mm
    assert res.n_solves == raw.n_solves + 4  # the refused fit's exact tables


def test_the_grid_moves_to_a_finger_outside_it_and_says_so(fake):
    true = finger_with(BASE, {"tissue_modulus": 1.45})  # outside the first grid (0.75-1.25)
    trials = [_trial(true, s, 0.3, s.name) for s in (FLAT, BUMP)]
    opts = FECalibrationOptions(**{**FAST, "fit": ("tissue_modulus",), "bootstrap": 0})
    res = calibrate_fe_finger(trials, BASE, options=opts)
    assert res.success, res.message
    assert "the grid moved tissue_modulus x1.25" in res.message
    assert res.finger.tissue_modulus == pytest.approx(true.tissue_modulus, rel=0.03)
    assert res.initial == BASE  # the given start, not the moved grid's centre
    # tables (2 surfaces x 2 loads) of both grids' three nodes (the stand-in has no cache, so the
    # shared node counts twice) and of the optimum: the abandoned grid's cost is counted
    assert res.n_solves == (2 * 3 + 1) * 2 * 2
    # a grid that may not move stops at its edge, and so does one that runs out of moves
    res = calibrate_fe_finger(trials, BASE, options=dataclasses.replace(opts, max_shifts=0))
    assert not res.success and "edge of the tabulated range (tissue_modulus 0.015..0.025)" in res.message
    far = [_trial(finger_with(BASE, {"tissue_modulus": 3.0}), s, 0.3, s.name) for s in (FLAT, BUMP)]
    res = calibrate_fe_finger(far, BASE, options=opts)
    assert not res.success and "after 2 move(s) of the grid" in res.message, res.message


def test_the_evaluation_budget_grows_with_the_fitted_fields():
    assert FECalibrationOptions().evaluations() == 150  # the default five fields and the offset
    assert FECalibrationOptions(fit=("tissue_modulus", "radius"), position_offset=False).evaluations() == 50
    four = ("tissue_modulus", "skin_thickness", "radius", "semi_height")
    assert FECalibrationOptions(fit=four, position_offset=False).evaluations() == 100
    assert FECalibrationOptions(fit=four, max_nfev=7).evaluations() == 7


def test_bad_options_and_inputs_are_one_line_errors(fake):
    for kw, match in [({"fit": ("modulus",)}, "fit"), ({"fit": ()}, "non-empty"),
                      ({"levels": (0.8, 1.2)}, "including 1"), ({"loads": (0.3, 0.2)}, "increasing"),
                      ({"step": 0.0}, "step"), ({"workers": 0}, "workers"), ({"mesh": {}}, "mesh"),
                      ({"max_shifts": -1}, "max_shifts"), ({"corrections": -1}, "corrections"),
                      ({"design": "sparse"}, "design"), ({"max_nfev": 0}, "max_nfev")]:
        with pytest.raises((ValueError, TypeError), match=match):
            FECalibrationOptions(**kw)
    tr = [_trial(BASE, FLAT, 0.3, "t")]
    with pytest.raises(TypeError, match="FEFingerParams"):
        calibrate_fe_finger(tr, FE_SUBJECTS["1"].to_dict(), options=FECalibrationOptions(**FAST))
    with pytest.raises(CalibrationError, match="only 1 trial"):
        calibrate_fe_finger(tr, BASE, options=FECalibrationOptions(**{**FAST, "min_trials": 3}))
    empty = CalibrationTrial(FLAT, np.zeros(3), np.full((3, 1, 2), np.nan), np.full(3, 0.3))
    with pytest.raises(CalibrationError, match="no trial has a usable frame"):
        calibrate_fe_finger([empty], BASE, options=FECalibrationOptions(**FAST))
    thick = dataclasses.replace(BASE, skin_thickness=3.8)  # x 1.25 would not fit under the bone
    with pytest.raises(ValueError, match="leaves the valid fingers"):
        calibrate_fe_finger(tr, thick, options=FECalibrationOptions(**{**FAST, "fit": ("skin_thickness",)}))


@pytest.mark.slow  # five coarse FE sweeps of ~25 positions (truth, three nodes, the optimum)
def test_the_fe_calibration_recovers_an_fe_finger(tmp_path):
    mesh = FEMeshParams(surface_cell=0.4, skin_layers=1, tissue_layers=3, top_cells=8)
    base = FE_SUBJECTS["1"]  # frictionless: half the cost
    true = finger_with(base, {"tissue_modulus": 1.12})
    opts = FECalibrationOptions(fit=("tissue_modulus",), levels=(0.8, 1.0, 1.25), loads=(0.3,), step=0.5,
                                clearance=1.0, mesh=mesh, bootstrap=20, min_trials=1, min_frames=10)
    # the "measurement": the true finger's own FE table (same mesh and positions), its regions
    # from the outline exactly as the calibration computes distances
    pb = FECalibrationProblem([_trial(true, BUMP, 0.3, "x")], true, opts, cache_dir=tmp_path)
    tabs = pb.exact_tables(true)
    pos, Y = tabs[BUMP.name]
    x = pos[(pos > -5) & (pos < 5)]
    idx = np.searchsorted(pos, x)
    regs = []
    for i in idx:
        X = pos[i] + pb.u
        d = Y[0, i] - BUMP.h(X)
        m = d <= TOL
        e = np.flatnonzero(np.diff(m.astype(int)))
        regs.append(X[e].reshape(-1, 2) + 0.5 * (pb.u[1] - pb.u[0]))
    k = max(r.shape[0] for r in regs)
    arr = np.full((x.size, k, 2), np.nan)
    for j, r in enumerate(regs):
        arr[j, : r.shape[0]] = r
    trial = CalibrationTrial(BUMP, x, arr, np.full(x.size, 0.3), label="bump", tol=TOL)
    res = calibrate_fe_finger([trial], base, options=opts, cache_dir=tmp_path)
    assert res.finger.tissue_modulus == pytest.approx(true.tissue_modulus, rel=0.04), res.summary()
    assert res.surrogate_rms_mm < 0.03
    assert len(list(tmp_path.glob("*.npz"))) == 5  # the truth, three grid nodes, the calibrated finger
