"""Finger calibration from contact regions (fingerfriction.mechanics.calibrate)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from fingerfriction.mechanics import SUBJECTS, FingerParams, sweep
from fingerfriction.mechanics.calibrate import (
    CalibrationError,
    CalibrationOptions,
    CalibrationTrial,
    calibrate_finger,
)
from fingerfriction.sim.writer import geometric_distance
from fingerfriction.surfaces import get_surface

TOL = 0.069
TRUE = dataclasses.replace(SUBJECTS[1], radius=23.0, modulus=0.155, flat_length=5.2, name="true")
FAST = dict(dx=0.08, coarse_step=0.3, fine_step=0.1, n_loads=2, coarse_stride=2, bootstrap=50,
            min_frames=50)


def _crossings(x: np.ndarray, d: np.ndarray, tol: float) -> np.ndarray:
    """Regions where ``d <= tol``, ends interpolated where ``d`` crosses ``tol`` (k, 2)."""
    m = d <= tol
    out = []
    i = 0
    n = m.size
    while i < n:
        if not m[i]:
            i += 1
            continue
        j = i
        while j + 1 < n and m[j + 1]:
            j += 1
        a = x[i] if i == 0 else x[i - 1] + (x[i] - x[i - 1]) * (d[i - 1] - tol) / (d[i - 1] - d[i])
        b = x[j] if j == n - 1 else x[j] + (x[j + 1] - x[j]) * (tol - d[j]) / (d[j + 1] - d[j])
        out.append((a, b))
        i = j + 1
    return np.asarray(out).reshape(-1, 2)


def _measured(finger: FingerParams, surface_name: str, load: float, x: np.ndarray, label: str):
    """A trial 'measured' independently of the calibration's model: a fine BEM sweep
    (n = 1024, the finger's own default grid), the exact Euclidean distance of each surface
    point to the deformed outline (the simulator's), ends interpolated at the tolerance."""
    s = get_surface(surface_name)
    res = sweep(s, finger, x, load=load, n=1024, keep_profiles=True)
    assert res.success.mean() > 0.95
    x = np.where(res.success, x, np.nan)  # a reference solve that failed is no measurement
    regs = []
    for i, xf in enumerate(x):
        X = xf + res.offsets
        h = np.asarray(s.h(X), float)
        d = geometric_distance(res.offsets, res.finger_y[i], h, 2 * TOL)
        regs.append(_crossings(X, d, TOL))
    k = max(r.shape[0] for r in regs)
    arr = np.full((x.size, k, 2), np.nan)
    for i, r in enumerate(regs):
        arr[i, : r.shape[0]] = r
    return CalibrationTrial(s, x, arr, np.full(x.size, load), label=label, tol=TOL)


@pytest.fixture(scope="module")
def trials():
    x = np.arange(-9.0, 9.0, 0.1)
    return [
        _measured(TRUE, name, load, x + off, f"{name}-{load}")
        for name in ("step-up-2mm", "bump-4mm")
        for load, off in ((0.27, 0.0), (0.33, 0.05))
    ]


@pytest.mark.slow
def test_recovers_a_finger_from_independently_computed_regions(trials):
    start = dataclasses.replace(TRUE, radius=26.0, modulus=0.14, flat_length=6.0)
    res = calibrate_finger(trials, start, options=CalibrationOptions(**FAST))
    assert res.success, res.message
    for f in ("radius", "modulus", "flat_length"):
        # measured: 0.01 %, 0.06 %, 0.001 % (the model's table and normal-distance
        # approximations against the exact Euclidean distance on a 1024-cell sweep)
        assert getattr(res.finger, f) == pytest.approx(getattr(TRUE, f), rel=0.005), f
        assert res.std[f] >= 0 and res.ci95[f][0] <= res.ci95[f][1]
        assert math.isfinite(res.systematic[f])
    assert res.finger.width == TRUE.width  # D is not fitted (only F_N / (D E*) is seen)
    assert res.load_per_width == pytest.approx(res.load_median / 10.0) and res.load_median in (0.27, 0.33)
    assert {s.surface for s in res.surfaces} == {"step-up-2mm", "bump-4mm"}
    for s in res.surfaces:
        assert s.rms_end_mm < 0.005  # measured 0.0007, 0.0015 mm
        pairs = s.blind_spot_pairs()
        assert pairs, s.surface
        for meas, pred in pairs:
            assert abs(meas - pred) < 0.01, (s.surface, pairs)  # measured <= 0.004 mm
    assert res.n_solves > 0 and res.timings["bem"] > 0
    assert set(res.nfev) == {"coarse", "fine"}
    d = res.to_dict()
    assert d["parameters"]["radius"] == res.finger.radius and d["success"] is True


@pytest.mark.slow
def test_unconverged_calibration_is_flagged_not_silent(trials):
    start = dataclasses.replace(TRUE, radius=28.0, modulus=0.12, flat_length=6.5)
    res = calibrate_finger(trials, start, options=CalibrationOptions(**{**FAST, "max_nfev": 1}))
    assert not res.success
    assert "did not converge" in res.message


@pytest.mark.slow
def test_too_few_trials_or_no_contact_is_an_error(trials):
    with pytest.raises(CalibrationError, match="only 2 trial"):
        calibrate_finger(trials[:2], TRUE, options=CalibrationOptions(**FAST))
    t = trials[0]
    empty = CalibrationTrial(t.surface, t.x, np.full((t.x.size, 1, 2), np.nan), t.load, label="none")
    with pytest.raises(CalibrationError, match="no trial has a usable frame"):
        calibrate_finger([empty, empty, empty], TRUE, options=CalibrationOptions(**FAST))
    with pytest.raises(CalibrationError, match="no trials given"):
        calibrate_finger([], TRUE)
    few = [dataclasses.replace(tr, x=np.where(np.arange(tr.x.size) < 5, tr.x, np.nan)) for tr in trials]
    with pytest.raises(CalibrationError, match="only 20 usable frames"):
        calibrate_finger(few, TRUE, options=CalibrationOptions(**FAST))


def test_bad_arguments():
    t = CalibrationTrial(get_surface("bump-2mm"), [0.0], [[[-1.0, 1.0]]], [0.3], label="t")
    assert t.usable().tolist() == [True]
    unloaded = CalibrationTrial(get_surface("bump-2mm"), [0.0], [[[-1.0, 1.0]]], [0.0])
    assert unloaded.usable().tolist() == [False]
    with pytest.raises(ValueError, match="x has 2 frames, regions 1, load 2"):
        CalibrationTrial(get_surface("bump-2mm"), [0.0, 1.0], [[[-1.0, 1.0]]], [0.3, 0.3], label="t")
    with pytest.raises(ValueError, match="tol must be a contact tolerance"):
        CalibrationTrial(get_surface("bump-2mm"), [0.0], [[[-1.0, 1.0]]], [0.3], tol=5.0)
    with pytest.raises(TypeError, match="surface must be a Surface"):
        CalibrationTrial("bump-2mm", [0.0], [[[-1.0, 1.0]]], [0.3])
    with pytest.raises(ValueError, match="fit must be a non-empty subset"):
        CalibrationOptions(fit=("radius", "width"))
    with pytest.raises(ValueError, match="warm_start"):
        CalibrationOptions(warm_start="cold")
    with pytest.raises(ValueError, match="bound must be > 1"):
        CalibrationOptions(bound=0.5)
    with pytest.raises(ValueError, match="supports the circle/stadium"):
        calibrate_finger([t], FingerParams(radius=9.0, modulus=0.1, width=10.0, shape="ellipse",
                                           semi_height=2.0))
    with pytest.raises(ValueError, match="initial flat_length must be > 0"):
        calibrate_finger([t], FingerParams(radius=9.0, modulus=0.1, width=10.0))
    with pytest.raises(TypeError, match="CalibrationTrial"):
        calibrate_finger([object()], TRUE)
