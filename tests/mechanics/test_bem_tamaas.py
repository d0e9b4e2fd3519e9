"""BEM solver (mechanics/bem.py) against the tamaas peer solver on a cylinder-on-bump problem.

tamaas (AGPL) is imported only here, never by the package.

Making the comparison well-posed: tamaas solves a *periodic* plane-strain contact with
the mean pressure as input, while our problem is isolated (non-periodic, zero padding).
We give tamaas the same composite profile ``h(x) - s(x)`` on the same cells, embedded in
a period 8 times longer whose padding lies 10 mm below (never in contact), and the mean
pressure ``P' / L_period``. The periodic images of the contact are then >= 7 windows
away; their effect on the pressure was measured at 0.3 % of peak (3.6 % with a period of
only 2 windows). Both solvers use ``E*`` directly (tamaas: ``E = E*``, ``nu = 0``).
"""

from __future__ import annotations

import numpy as np
import pytest

from fingerfriction.mechanics import ContactSolver, FingerParams
from fingerfriction.surfaces import get_surface

tm = pytest.importorskip("tamaas")


def tamaas_pressure(hs: np.ndarray, dx: float, load_per_width: float, modulus: float, pad: int = 8):
    """Pressure (MPa) on the ``hs.size`` cells from tamaas' periodic Polonsky-Keer solver."""
    n = hs.size
    N = n * pad
    L = N * dx
    model = tm.ModelFactory.createModel(tm.model_type.basic_1d, [L], [N])
    model.E = modulus
    model.nu = 0.0
    surf = np.full(N, hs.min() - 10.0)
    i0 = (N - n) // 2
    surf[i0 : i0 + n] = hs
    solver = tm.PolonskyKeerRey(model, np.ascontiguousarray(surf), 1e-12)
    solver.solve(load_per_width / L)
    return np.array(model.traction).ravel()[i0 : i0 + n].copy()


@pytest.mark.parametrize("x_finger", [-3.0, 0.0, 2.2])
def test_matches_tamaas_on_cylinder_over_bump(x_finger):
    tm.set_log_level(tm.LogLevel.error)
    finger = FingerParams(radius=8.0, modulus=0.1, width=10.0)
    bump = get_surface("bump-4mm")
    solver = ContactSolver(finger, n=2048)
    sol = solver.solve(bump, x_finger, load=0.3, tol=1e-10)
    assert sol.success, sol.message
    hs = bump.h(sol.x) - solver.outline
    pt = tamaas_pressure(hs, solver.dx, sol.load_per_width, finger.modulus)
    peak = sol.pressure.max()
    assert np.max(np.abs(pt - sol.pressure)) < 0.01 * peak
    # Same contact regions within one grid cell: same number of regions, each edge within dx.
    ours = sol.mechanical_regions
    from fingerfriction.regions import regions_from_mask

    theirs = regions_from_mask(sol.x, pt > 0)[0]
    theirs = theirs[~np.isnan(theirs[:, 0])]
    assert ours.shape == theirs.shape
    assert np.max(np.abs(ours - theirs)) <= solver.dx * (1 + 1e-9)
    if x_finger == -3.0:
        assert ours.shape[0] == 2  # the finger spans the flat and the bump's flank
