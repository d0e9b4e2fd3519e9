"""Tests of the true force law against direct numerical integration."""

from __future__ import annotations

import numpy as np
import pytest

from fingerfriction.sim.contact import build_table
from fingerfriction.sim.physics import ForceLaw, true_forces
from fingerfriction.surfaces import get_surface


class _PatchProvider:
    """A finger resting on the surface with a known pressure: a parabola over |xi| < 1."""

    name = "patch"

    def finger_dict(self, subject):
        return {}

    def grid(self, subject):
        return np.linspace(-3.0, 3.0, 1201)

    def solve(self, surface, subject, x_centres, load):
        xi = self.grid(subject)
        X = np.asarray(x_centres)[:, None] + xi[None, :]
        p = np.clip(1.0 - xi**2, 0.0, None)[None, :].repeat(X.shape[0], 0)
        return surface.h(X), p * load


@pytest.fixture(scope="module")
def table():
    return build_table(get_surface("step-up-4mm"), "1", loads=(0.2, 0.4), step=0.05,
                       provider=_PatchProvider())


def _direct(surface, x_c, f_n, mu, beta):
    xi = np.linspace(-1.0, 1.0, 20001)
    x = x_c + xi
    q = 1.0 - xi**2
    q = f_n * q / np.trapezoid(q, xi)
    s = surface.dhdx(x)
    a = np.arctan(s)
    proj = np.sin(a) + mu * np.cos(a)
    return np.trapezoid(q * proj, xi), np.trapezoid(beta * q * s * proj, xi)


@pytest.mark.slow
@pytest.mark.parametrize("x_c", [-8.0, -1.5, -0.3, 0.0, 0.7, 1.9, 6.0])
def test_force_law_matches_direct_integration(table, x_c):
    surf = get_surface("step-up-4mm")
    law = ForceLaw(mu=0.6, beta0=0.8, beta_speed=0.1, v_ref=80.0, transient=0.0)
    f_n = np.array([0.3])
    ft, fi, fd = true_forces(table, law, np.array([x_c]), f_n, np.array([5.0]), 120.0, np.array([True]))
    beta = 0.8 * (1 + 0.1 * (120.0 / 80.0 - 1))
    ei, ed = _direct(surf, x_c, 0.3, 0.6, beta)
    assert fi[0] == pytest.approx(ei, abs=2e-4)
    assert fd[0] == pytest.approx(ed, abs=2e-4)
    assert ft[0] == pytest.approx(fi[0] + fd[0])
    if abs(x_c) > 4:  # flat ground: Amontons, F_T = mu F_N
        assert ft[0] == pytest.approx(0.6 * 0.3, rel=1e-9)
        assert fd[0] == 0.0


@pytest.mark.slow
def test_transient_and_start_of_motion(table):
    law = ForceLaw(mu=0.5, transient=0.4, transient_mm=0.5)
    d = np.array([0.0, 0.05, 0.1, 0.5, 5.0])
    n = d.size
    ft, _, _ = true_forces(table, law, np.full(n, -8.0), np.full(n, 0.3), d, 80.0, np.ones(n, bool))
    assert ft[0] == 0.0  # at rest: no sliding friction
    assert ft[2] == pytest.approx(0.3 * 0.5 * (1 + 0.4 * np.exp(-0.2)), rel=1e-9)  # peak after 0.1 mm
    assert ft[3] == pytest.approx(0.3 * 0.5 * (1 + 0.4 * np.exp(-1.0)), rel=1e-9)
    assert ft[4] == pytest.approx(0.15, rel=1e-4)
    # not in contact: no force
    ft, _, _ = true_forces(table, law, np.array([-8.0]), np.array([0.3]), np.array([5.0]), 80.0,
                           np.array([False]))
    assert ft[0] == 0.0


def test_force_law_validated():
    with pytest.raises(ValueError, match="mu"):
        ForceLaw(mu=-0.1)
    with pytest.raises(ValueError, match="transient_mm"):
        ForceLaw(transient_mm=0.0)
