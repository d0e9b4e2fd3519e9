"""Influence coefficients of the layer and skin models (mechanics/bem.py) against
independent references: direct quadrature of their Fourier integrals and known limits."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import quad

from fingerfriction.mechanics import FingerParams, hertz_half_width, solve_contact
from fingerfriction.mechanics.kernels import (
    halfspace_kernel,
    layer_compliance,
)
from fingerfriction.mechanics.kernels import layer_kernel as _layer_kernel
from fingerfriction.mechanics.kernels import skin_compliance as _skin_compliance
from fingerfriction.mechanics.kernels import skin_kernel as _skin_kernel


def _flat(x):
    return np.zeros_like(x)


def _quad_kernel(spectrum, x, dx):
    """(1/pi) int_0^inf spectrum(k) S(k) cos(kx) dk, S = 2 sin(k dx/2)/k, by pieces."""

    def f(k):
        return spectrum(k) * (2 * math.sin(k * dx / 2) / k) * math.cos(k * x) / math.pi

    edges = [1e-9, 5, 50, 500, 20000]
    return sum(quad(f, a, b, limit=20000)[0] for a, b in zip(edges[:-1], edges[1:], strict=True))


@pytest.mark.slow
@pytest.mark.parametrize("x", [0.0, 0.3, 1.0, 3.0])
def test_layer_kernel_matches_quadrature(x):
    dx, E, t = 0.05, 0.1, 1.0
    k = _layer_kernel(np.array([x]), dx, E, t, 0.5)[0]
    q = _quad_kernel(lambda kk: 2 * layer_compliance(kk * t, 0.5) / (E * kk), x, dx)
    assert k == pytest.approx(q, abs=2e-4 * abs(_layer_kernel(np.array([0.0]), dx, E, t, 0.5)[0]))


@pytest.mark.slow
@pytest.mark.parametrize("x", [0.0, 0.1, 0.5, 2.0, 6.0])
def test_skin_kernel_matches_quadrature(x):
    dx, E, Es, hs, ref = 0.02, 0.05, 1.0, 0.5, 8.0
    diff = _skin_kernel(np.array([x]), dx, E, Es, hs, ref)[0] - halfspace_kernel(np.array([x]), dx, E, ref)[0]
    q = _quad_kernel(lambda kk: _skin_compliance(np.array([kk]), E, Es, hs)[0] - 2 / (E * kk), x, dx)
    assert diff == pytest.approx(q, abs=1e-5)


def test_layer_compliance_limits():
    # Thick layer -> half-space; thin compressible layer -> confined column; nu = 0.5 -> 2q^3/3.
    assert layer_compliance(np.array([50.0]), 0.3)[0] == pytest.approx(1.0)
    nu, q = 0.3, 1e-4
    kap = 3 - 4 * nu
    expected = 4 * q * (kap - 1) / (1 + kap) ** 2
    assert layer_compliance(np.array([q]), nu)[0] == pytest.approx(expected, rel=1e-3)
    assert layer_compliance(np.array([1e-2]), 0.5)[0] == pytest.approx(2 * 1e-6 / 3, rel=1e-3)


@pytest.mark.slow
def test_thick_layer_is_hertz_and_thin_layer_is_winkler():
    thick = FingerParams(radius=8, modulus=0.1, width=10, layer_thickness=200.0)
    sol = solve_contact(_flat, thick, 0.0, n=2048, half_width=6)
    (lo, hi), = sol.mechanical_regions
    a = hertz_half_width(0.03, 8, 0.1)
    assert abs(0.5 * (hi - lo) - a) / a < 0.015
    # Thin compressible layer: Winkler foundation of stiffness M / t, M the oedometric
    # modulus: p = (M/t)(d - x^2/2R) gives a = (3 R P' t / (2 M))^(1/3).
    nu, t = 0.3, 0.05
    E = 0.1 * (1 - nu**2)
    M = E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))
    thin = FingerParams(radius=8, modulus=0.1, width=10, layer_thickness=t, poisson=nu)
    sol = solve_contact(_flat, thin, 0.0, n=4096, half_width=4)
    (lo, hi), = sol.mechanical_regions
    a = (3 * 8 * 0.03 * t / (2 * M)) ** (1 / 3)
    assert abs(0.5 * (hi - lo) - a) / a < 0.02
    assert sol.approach == pytest.approx(a * a / 16, rel=0.02)


def test_skin_stiffens_short_wavelengths_only():
    soft = FingerParams(radius=8, modulus=0.1, width=10)
    skin = FingerParams(radius=8, modulus=0.1, width=10, skin_modulus=1.0, skin_thickness=0.5)
    a0 = solve_contact(_flat, soft, 0.0, n=2048, half_width=6).mechanical_regions
    s = solve_contact(_flat, skin, 0.0, n=2048, half_width=6)
    assert s.success
    assert (s.mechanical_regions[0, 1] - s.mechanical_regions[0, 0]) < (a0[0, 1] - a0[0, 0])
