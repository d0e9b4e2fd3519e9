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


def test_below_the_lowest_load_the_contact_grows_from_a_point_as_the_pad_indents(fb_table):
    from fingerfriction.sim.kinematics import KinematicsParams

    t = fb_table
    pad = KinematicsParams().pad
    x_flat = float(t.positions[0]) - 5.0  # flat ground (clamped to the table's end)
    y0, p0 = t.profile(x_flat, float(t.loads[0]))
    dxi = float(t.xi[1] - t.xi[0])
    lengths = []
    for f in (0.0, 0.005, 0.02, 0.08, 0.2, 0.249):
        y, p = t.profile(x_flat, f, pad=pad)
        assert np.all(y >= y0 - 1e-12)  # less load: never deeper than at the lowest load
        assert np.sum(p) * dxi * 10.0 == pytest.approx(f, rel=1e-3, abs=1e-9)  # D = 10 mm
        lengths.append(np.sum(p > 0) * dxi)
        if f == 0.0:
            assert not np.any(p > 0) and np.min(y) == pytest.approx(np.min(y0), abs=1e-6)
    assert np.all(np.diff(lengths) > 0) and lengths[1] < 0.3 * lengths[-1]
    # small loads: half-width ~ sqrt(load) (the pad's indentation ~ load / k)
    assert lengths[2] / lengths[1] == pytest.approx(2.0, rel=0.15)
    # continuous with the table at its lowest load, and the body rises as it unloads
    y1, _ = t.profile(x_flat, float(t.loads[0]) * (1 - 1e-6), pad=pad)
    np.testing.assert_allclose(y1, y0, atol=1e-3)
    y_zero, _ = t.profile(x_flat, 0.0, pad=pad)
    far = np.abs(t.xi) > 0.9 * np.max(np.abs(t.xi))
    np.testing.assert_allclose(y_zero[far] - y0[far], pad.indentation(float(t.loads[0])), atol=1e-6)
    # without the pad law the lowest load's outline is held (the old behaviour)
    y_held, _ = t.profile(x_flat, 0.0)
    np.testing.assert_array_equal(y_held, y0)
