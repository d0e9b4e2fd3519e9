"""Tests of the BEM contact solver (mechanics/bem.py) against the Hertz oracle and bad input."""

from __future__ import annotations

import logging
import math

import numpy as np
import pytest

from fingerfriction.mechanics import (
    ContactSolver,
    FingerParams,
    hertz_half_width,
    hertz_pressure,
    solve_contact,
)
from fingerfriction.mechanics.hertz import hertz_peak_pressure
from fingerfriction.surfaces import get_surface


def _parabolic_finger(R: float = 8.0, E: float = 0.1, D: float = 10.0, half: float = 7.0) -> FingerParams:
    """Exactly parabolic outline, the geometry Hertz's solution assumes."""
    u = np.linspace(-half, half, 2801)
    return FingerParams(radius=R, modulus=E, width=D, shape="profile", profile=(u, u * u / (2 * R)))


def _flat(x):
    return np.zeros_like(x)


def _edges_from_pressure(sol):
    """Contact edges with sub-cell accuracy: p ~ sqrt(a^2 - x^2), so p^2 is linear in x^2
    near the edge; fit p^2 = c (a^2 - x^2) on the outer half of the contact."""
    x, p = sol.x, sol.pressure
    inside = p > 0
    xs, ps = x[inside], p[inside]
    a_grid = max(-xs.min(), xs.max())
    sel = np.abs(xs) > 0.5 * a_grid
    A = np.column_stack([np.ones(sel.sum()), xs[sel] ** 2])
    c0, c1 = np.linalg.lstsq(A, ps[sel] ** 2, rcond=None)[0]
    return math.sqrt(-c0 / c1)


@pytest.mark.slow
@pytest.mark.parametrize("n", [2048, 4096])
def test_hertz_half_width_and_pressure(n):
    finger = _parabolic_finger()
    P = 0.3 / finger.width
    sol = solve_contact(_flat, finger, 0.0, load=0.3, n=n, half_width=6.0)
    assert sol.success, sol.message
    a = hertz_half_width(P, 8.0, 0.1)
    # Half-width from the grid regions (cell edges) and from the pressure shape.
    (lo, hi), = sol.mechanical_regions
    assert abs(0.5 * (hi - lo) - a) / a < 0.01
    assert abs(_edges_from_pressure(sol) - a) / a < 0.01
    # Elliptical profile: within 1 % of peak away from the edges (the sqrt edge singularity
    # of the slope makes the last cell inexact on any grid).
    ph = hertz_pressure(sol.x, P, 8.0, 0.1)
    p0 = hertz_peak_pressure(P, 8.0, 0.1)
    core = np.abs(sol.x) < 0.95 * a
    assert np.max(np.abs(sol.pressure[core] - ph[core])) < 0.01 * p0
    assert abs(sol.pressure.max() - p0) < 0.005 * p0
    # Load check and complementarity.
    assert abs(sol.total_load - 0.3) < 1e-9
    assert sol.load_error < 1e-12
    assert np.all(sol.gap >= 0)
    assert np.all(sol.gap[sol.pressure > 0] == 0)


@pytest.mark.slow
def test_circle_finger_close_to_hertz():
    finger = FingerParams(radius=30.0, modulus=0.1, width=10.0)
    sol = solve_contact(_flat, finger, 2.5, load=0.3, n=2048, half_width=8.0)
    a = hertz_half_width(0.03, 30.0, 0.1)
    (lo, hi), = sol.mechanical_regions
    assert abs(0.5 * (lo + hi) - 2.5) < sol.dx  # centred on the finger centre
    assert abs(0.5 * (hi - lo) - a) / a < 0.01


def test_deformed_outline_matches_surface_in_contact():
    surf = get_surface("bump-4mm")
    finger = FingerParams(radius=8.0, modulus=0.1, width=10.0)
    sol = solve_contact(surf, finger, -3.0, load=0.3, n=2048)
    assert sol.success
    inside = sol.pressure > 0
    np.testing.assert_allclose(sol.finger_y[inside], surf.h(sol.x[inside]), atol=1e-9)
    assert np.all(sol.finger_y[~inside] >= surf.h(sol.x[~inside]) - 1e-12)
    # Geometric contact (gap <= 70 um) contains the mechanical contact.
    for a, b in sol.mechanical_regions:
        assert any(g0 <= a + 1e-9 and b <= g1 + 1e-9 for g0, g1 in sol.geometric_regions)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"modulus": 0.0}, "modulus"),
        ({"modulus": -1.0}, "modulus"),
        ({"radius": 0.0}, "radius"),
        ({"radius": float("nan")}, "radius"),
        ({"width": -2.0}, "width"),
    ],
)
def test_bad_finger_params(kwargs, match):
    base = {"radius": 8.0, "modulus": 0.1, "width": 10.0}
    base.update(kwargs)
    with pytest.raises(ValueError, match=match):
        FingerParams(**base)


def test_bad_load_nan_profile_and_coarse_grid():
    finger = FingerParams(radius=8.0, modulus=0.1, width=10.0)
    with pytest.raises(ValueError, match="load"):
        solve_contact(_flat, finger, 0.0, load=0.0)
    with pytest.raises(ValueError, match="load"):
        solve_contact(_flat, finger, 0.0, load=-0.3)

    def nan_surface(x):
        h = np.zeros_like(x)
        h[len(h) // 2] = np.nan
        return h

    with pytest.raises(ValueError, match="not finite"):
        solve_contact(nan_surface, finger, 0.0)
    with pytest.raises(ValueError, match="profile"):
        FingerParams(radius=8, modulus=0.1, width=10, shape="profile", profile=([-1, 0, np.nan], [1, 0, 1]))
    stiff = FingerParams(radius=8.0, modulus=50.0, width=10.0)
    with pytest.raises(ValueError, match="grid too coarse"):
        solve_contact(_flat, stiff, 0.0, n=128)


def test_non_convergence_is_reported():
    finger = FingerParams(radius=8.0, modulus=0.1, width=10.0)
    sol = ContactSolver(finger, n=1024).solve(get_surface("bump-4mm"), -2.0, max_iter=3)
    assert not sol.success
    assert "did not converge" in sol.message


def test_warm_start_on_a_window_matches_cold_solve():
    # A warm start runs the CG on a window around its contact (smaller FFTs); the result
    # must be the full problem's solution.
    finger = FingerParams(radius=8.0, modulus=0.1, width=10.0)
    surf = get_surface("bump-4mm")
    solver = ContactSolver(finger, n=1024)
    prev = solver.solve(surf, -3.0, tol=1e-10)
    warm = solver.solve(surf, -2.9, x0=prev, tol=1e-10)
    cold = solver.solve(surf, -2.9, tol=1e-10)
    assert warm.success and cold.success
    assert solver._windows, "the warm start should have used a window"
    assert np.max(np.abs(warm.pressure - cold.pressure)) < 1e-6 * cold.pressure.max()
    np.testing.assert_allclose(warm.finger_y, cold.finger_y, atol=1e-7)
    np.testing.assert_array_equal(warm.mechanical_regions, cold.mechanical_regions)


def test_warm_start_misses_a_new_contact_outside_its_window(caplog):
    # The warm start's contact is the flat-ground patch in the middle of the grid; the
    # relief has a tall narrow bump near the grid's edge that the finger must touch. The
    # window cannot see it: the full-grid penetration check must catch it and continue
    # on the full grid, giving the cold solution.
    finger = FingerParams(radius=8.0, modulus=0.1, width=10.0)
    solver = ContactSolver(finger, n=1024)
    flat = solver.solve(_flat, 0.0, tol=1e-10)
    xb = 0.6 * solver.half_width
    Hb = float(finger.outline(np.array([xb]))[0]) + 0.05

    def bumpy(x):
        return Hb * np.exp(-(((x - xb) / 0.4) ** 2))

    with caplog.at_level(logging.DEBUG, logger="fingerfriction.mechanics.bem"):
        warm = solver.solve(bumpy, 0.0, x0=flat, tol=1e-10)
    assert "penetrated outside" in caplog.text
    cold = solver.solve(bumpy, 0.0, tol=1e-10)
    assert warm.success and cold.success
    assert cold.mechanical_regions.shape[0] == 2
    assert np.max(np.abs(warm.pressure - cold.pressure)) < 1e-6 * cold.pressure.max()
    np.testing.assert_array_equal(warm.mechanical_regions, cold.mechanical_regions)
    assert warm.max_penetration < 1e-6


def test_region_extraction_matches_the_regions_module():
    # bem extracts the regions of every sweep position with its own vectorised code; it
    # must give exactly what fingerfriction.regions.regions_from_mask gives.
    from fingerfriction.mechanics._cgkernels import contact_regions
    from fingerfriction.mechanics.solution import _mechanical_regions
    from fingerfriction.mechanics.solution import regions_within_gap as _geometric_regions
    from fingerfriction.regions import regions_from_mask

    rng = np.random.default_rng(3)
    x = -1.5 + 0.01 * np.arange(300) + 0.005
    for k in range(200):
        p = np.where(rng.random(300) < 0.5, rng.random(300), 0.0)
        p[[0, -1]] = [k % 2, k % 3 == 0]
        if k == 0:
            p[:] = 0.0
        ref = regions_from_mask(x, p > 0)[0]
        np.testing.assert_array_equal(_mechanical_regions(x, p), ref[~np.isnan(ref[:, 0])])
        gap = np.where(p > 0, 0.0, rng.random(300) * 0.14)
        g = _geometric_regions(x, gap, 0.07)
        inside = gap <= 0.07
        ref = regions_from_mask(x, inside)[0]
        ref = ref[~np.isnan(ref[:, 0])]
        assert g.shape == ref.shape
        # Interpolated ends lie within half a cell outside the cell-edge intervals' centres.
        assert np.all(np.abs(g - ref) <= 0.01 + 1e-12)
        for a, b in g:
            assert np.all(gap[(x > a) & (x < b)] <= 0.07)
        # The compiled pass used per solve gives exactly the same rows.
        rm, rg = np.empty((151, 2)), np.empty((151, 2))
        km, kg = contact_regions(x, p, gap, 0.07, rm, rg)
        np.testing.assert_array_equal(rm[:km], _mechanical_regions(x, p))
        np.testing.assert_array_equal(rg[:kg], g)
