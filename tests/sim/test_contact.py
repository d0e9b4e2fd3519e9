"""Tests of the contact tables and providers (fingerfriction.sim.contact)."""

from __future__ import annotations

import numpy as np
import pytest

from fingerfriction.regions import regions_from_mask
from fingerfriction.sim.contact import (
    BridgedFoundation,
    ContactTable,
    MechanicsProvider,
    build_table,
    get_provider,
)
from fingerfriction.sim.writer import geometric_mask
from fingerfriction.surfaces import get_surface


@pytest.fixture(scope="module")
def fb_table():
    return build_table(get_surface("bump-2mm"), "1", loads=(0.25, 0.35), step=0.1,
                       provider=BridgedFoundation())


@pytest.mark.slow
def test_table_interpolation_exact_at_nodes_and_clamped(fb_table):
    t = fb_table
    i = 37
    y, p = t.profile(float(t.positions[i]), 0.25)
    np.testing.assert_allclose(y, t.y_f[0, i], atol=1e-6)
    np.testing.assert_allclose(p, t.p[0, i], atol=1e-9)
    # midway in position and load: the bilinear mean of the four neighbours
    y, _ = t.profile(float(t.positions[i] + 0.05), 0.30)
    mean4 = 0.25 * (t.y_f[0, i] + t.y_f[0, i + 1] + t.y_f[1, i] + t.y_f[1, i + 1])
    np.testing.assert_allclose(y, mean4, atol=1e-5)
    # beyond the table the finger is on flat ground: the end solution (translated)
    y_far, _ = t.profile(-40.0, 0.5)
    np.testing.assert_allclose(y_far, t.y_f[1, 0], atol=1e-6)


@pytest.mark.slow
def test_fallback_physics_sanity(fb_table):
    t = fb_table
    surf = get_surface("bump-2mm")
    dxi = t.xi[1] - t.xi[0]
    for j, load in enumerate(t.loads):
        # load balance: D int p dx = F_N
        np.testing.assert_allclose(t.integrals[j, :, 0] * 10.0, load, rtol=1e-6)
    for i in range(0, t.positions.size, 9):
        y, p = t.y_f[1, i].astype(float), t.p[1, i]
        X = t.positions[i] + t.xi
        h = surf.h(X)
        assert np.all(y - h >= -1e-5)  # no penetration
        mech = regions_from_mask(X, p > 0)[0]
        geom_mask = geometric_mask(t.xi, y, h, 0.069)
        # every mechanically loaded point is in geometric contact
        assert np.all(geom_mask[p > 0])
        assert np.nansum(mech[:, 1] - mech[:, 0]) <= np.sum(geom_mask) * dxi + 1e-9
    assert np.isclose(dxi, 0.01)


def test_fallback_has_disconnected_contacts_on_bump():
    surf = get_surface("bump-4mm")
    prov = BridgedFoundation()
    y, p = prov.solve(surf, "1", np.array([-3.0]), 0.3)
    X = -3.0 + prov.grid("1")
    assert regions_from_mask(X, p[0] > 0).shape[1] == 2


def test_mechanics_provider_load_and_grid():
    prov = MechanicsProvider()
    surf = get_surface("step-up-2mm")
    xi = prov.grid("1")
    y, p = prov.solve(surf, "1", np.array([-2.0, -1.9]), 0.3)
    assert y.shape == p.shape == (2, xi.size)
    d = prov.finger_dict("1")
    assert d["model"] == "mechanics-bem"
    np.testing.assert_allclose(p.sum(axis=1) * (xi[1] - xi[0]) * d["width"], 0.3, rtol=1e-4)
    with pytest.raises(ValueError, match="unknown subject"):
        prov.finger_dict("9")


@pytest.mark.slow
def test_stack_and_save_round_trip(tmp_path, fb_table):
    a = build_table(get_surface("bump-2mm"), "1", loads=(0.35,), step=0.1, provider=BridgedFoundation())
    b = build_table(get_surface("bump-2mm"), "1", loads=(0.25,), step=0.1, provider=BridgedFoundation())
    s = ContactTable.stack([a, b])
    np.testing.assert_array_equal(s.loads, [0.25, 0.35])
    np.testing.assert_array_equal(s.y_f, fb_table.y_f)
    s.save(tmp_path / "t.npz")
    back = ContactTable.load(tmp_path / "t.npz")
    np.testing.assert_array_equal(back.p, s.p)
    assert back.provider == "bridged-foundation"


@pytest.mark.parametrize("kw, match", [(dict(loads=(0.3, 0.2)), "increasing"), (dict(step=0.0), "step")])
def test_build_table_validation(kw, match):
    with pytest.raises(ValueError, match=match):
        build_table(get_surface("bump-2mm"), "1", provider=BridgedFoundation(), **kw)


def test_get_provider():
    assert get_provider("bridged-foundation").name == "bridged-foundation"
    with pytest.raises(ValueError, match="unknown contact model"):
        get_provider("jelly")


def test_geometric_mask_is_euclidean_distance_to_outline():
    """Against brute force: distance from each surface point to a densely resampled
    finger polyline, including steep (near-vertical) outline parts."""
    xi = np.arange(-2.0, 2.0 + 1e-9, 0.04)
    y_f = 0.05 + 0.3 * xi**2
    y_f[xi > 1.2] += 3.0 * (xi[xi > 1.2] - 1.2)  # a steep side
    h = 0.02 + 0.25 * np.clip(xi + 0.3, 0, None) ** 2
    dense = np.linspace(xi[0], xi[-1], 20001)
    yd = np.interp(dense, xi, y_f)
    d = np.min(np.hypot(dense[None, :] - xi[:, None], yd[None, :] - h[:, None]), axis=1)
    for tol in (0.03, 0.069, 0.1):
        got = geometric_mask(xi, y_f, h, tol)
        clear = np.abs(d - tol) > 2e-4  # away from ties
        np.testing.assert_array_equal(got[clear], (d <= tol)[clear])
        assert got.any() and not got.all()


def test_mechanics_grid_holds_the_contact_near_the_feature():
    """The pad's edge must not reach the relief beyond the BEM grid (solver success)."""
    prov = MechanicsProvider()
    surf = get_surface("bump-4mm")
    prov.solve(surf, "1", np.arange(-11.2, -9.8, 0.05), 0.42)
    assert prov.failures == 0
