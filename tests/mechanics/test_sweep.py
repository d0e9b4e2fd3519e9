"""Tests of sliding sweeps and outline tables (mechanics/sweep.py)."""

from __future__ import annotations

import numpy as np
import pytest

from fingerfriction.mechanics import (
    SUBJECTS,
    ContactSolver,
    FingerParams,
    default_positions,
    outline_table,
    sweep,
)
from fingerfriction.model.blindspots import blind_spots
from fingerfriction.regions import as_regions
from fingerfriction.surfaces import get_surface

FINGER = FingerParams(radius=8.0, modulus=0.1, width=10.0)


def test_default_positions_match_paper_window():
    pos = default_positions(get_surface("bump-4mm"))
    assert pos.size == 2601
    assert pos[0] == pytest.approx(-13.0) and pos[-1] == pytest.approx(13.0)
    assert np.allclose(np.diff(pos), 0.01)


def test_warm_sweep_equals_cold_solves():
    surf = get_surface("bump-4mm")
    pos = np.linspace(-4.0, 4.0, 41)
    res = sweep(surf, FINGER, pos, n=1024, tol=1e-9, keep_profiles=True)
    assert res.all_converged
    solver = ContactSolver(FINGER, n=1024)
    for i in (0, 13, 27, 40):
        cold = solver.solve(surf, pos[i], tol=1e-9)
        assert np.max(np.abs(cold.pressure - res.pressure[i])) < 1e-5 * cold.pressure.max()
        np.testing.assert_allclose(res.finger_y[i], cold.finger_y, atol=1e-6)
        r = res.mechanical_regions[i]
        np.testing.assert_allclose(r[~np.isnan(r[:, 0])], cold.mechanical_regions)
    # Regions are in the project format and feed the blindspots module.
    as_regions(res.geometric_regions)
    bs = blind_spots(res.mechanical_regions)
    assert len(res.blind_spots("mechanical")) == len(bs)


def test_blind_spots_of_a_symmetric_bump_are_symmetric():
    surf = get_surface("bump-4mm")
    res = sweep(surf, FINGER, default_positions(surf, step=0.05), n=512)
    assert res.all_converged
    for kind in ("geometric", "mechanical"):
        iv = res.blind_spots(kind).intervals
        assert iv.shape == (2, 2)
        np.testing.assert_allclose(iv[0], -iv[1][::-1], atol=0.03)
    # The 70 um blind spots lie at the bump's concave feet, inside the feature, and within
    # the mechanical ones (the finger is near the surface over a wider strip than it touches).
    geo, mech = res.blind_spots("geometric").intervals, res.blind_spots("mechanical").intervals
    assert np.all(np.abs(geo) <= 2.0 + 1e-9) and np.all(np.abs(geo) >= 1.0)
    assert np.all(mech[:, 0] <= geo[:, 0]) and np.all(geo[:, 1] <= mech[:, 1])
    # The geometric (70 um) criterion is wider contact, hence narrower blind spots.
    assert np.all(res.blind_spots("geometric").widths < res.blind_spots("mechanical").widths)
    assert res.max_contacts("mechanical") >= 2


def test_profile_at_and_outline_table():
    surf = get_surface("step-up-2mm")
    pos = np.linspace(-3.0, 3.0, 61)
    res = sweep(surf, FINGER, pos, n=512, keep_profiles=True)
    x, y = res.profile_at(pos[10])
    np.testing.assert_allclose(y, res.finger_y[10])
    np.testing.assert_allclose(x, pos[10] + res.offsets)
    with pytest.raises(ValueError, match="outside"):
        res.profile_at(10.0)
    table = outline_table(surf, FINGER, pos, loads=(0.25, 0.3, 0.35), n=512)
    assert table.finger_y.shape == (3, 61, 512) and table.success.all()
    _, y_mid = table.at(pos[10], 0.3)
    np.testing.assert_allclose(y_mid, res.finger_y[10], atol=1e-5)  # float32 storage
    # Halfway between loads and positions: between the neighbours.
    _, y_lo = table.at(0.05, 0.25)
    _, y_hi = table.at(0.05, 0.35)
    _, y_in = table.at(0.05, 0.3)
    assert np.all(np.minimum(y_lo, y_hi) - 1e-6 <= y_in) and np.all(y_in <= np.maximum(y_lo, y_hi) + 1e-6)
    with pytest.raises(ValueError, match="load"):
        table.at(0.0, 0.5)
    with pytest.raises(ValueError, match="loads"):
        outline_table(surf, FINGER, pos, loads=(0.3, 0.2))


def test_sweep_reports_failures_instead_of_hiding_them():
    surf = get_surface("bump-4mm")
    res = sweep(surf, FINGER, np.linspace(-2, 2, 5), n=512, max_iter=2)
    assert not res.all_converged
    assert res.messages and "did not converge" in res.messages[0]


def test_bad_sweep_input():
    surf = get_surface("bump-4mm")
    with pytest.raises(ValueError, match="positions"):
        sweep(surf, FINGER, [0.0, np.nan])
    with pytest.raises(ValueError, match="load"):
        sweep(surf, FINGER, [0.0], load=-1)
    with pytest.raises(TypeError, match="FingerParams"):
        sweep(surf, {"radius": 8}, [0.0])


@pytest.mark.slow
def test_subjects_reproduce_paper_step_up_blind_spot():
    """Calibration check (benchmarks/calibrate_fingers.py): Step Up 2 mm blind spot
    0.47 mm with the 70 um criterion, three contacts at most on Bump 2 mm."""
    for finger in SUBJECTS.values():
        s = get_surface("step-up-2mm")
        res = sweep(s, finger, default_positions(s, step=0.02), n=512)
        w = res.blind_spots().widths
        assert w.size == 1 and abs(w[0] - 0.47) < 0.03
        b = get_surface("bump-2mm")
        assert sweep(b, finger, default_positions(b, step=0.02), n=512).max_contacts() == 3
