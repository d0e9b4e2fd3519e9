"""Tests of the BEM contact solver (mechanics/bem.py) against the Hertz oracle and bad input."""

from __future__ import annotations

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
