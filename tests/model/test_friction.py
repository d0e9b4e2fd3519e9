"""Tests of fingerfriction.model (Eq. 1-4) against a brute-force integral."""

import numpy as np
import pytest

from fingerfriction.model import (
    FrictionModel,
    FrictionParams,
    LoadParams,
    T_matrix,
    friction_force,
    load_terms,
)
from fingerfriction.surfaces import SURFACE_NAMES, SampledProfile, get_surface


def brute_force(surface, regions, p):
    """Eq. (4) by np.trapezoid on a fine grid in every region (independent reference)."""
    out = []
    for frame in regions:
        tot = fi = fd = 0.0
        for a, b in frame:
            if np.isnan(a):
                continue
            x = np.linspace(a, b, 200001)
            s = surface.dhdx(x)
            al = np.arctan(s)
            w = np.sin(al) + p.mu * np.cos(al)
            fi += np.trapezoid(p.p0 * w, x)
            fd += np.trapezoid(p.p1 * s * w, x)
        tot = fi + fd
        out.append((tot, fi, fd))
    return np.array(out)


def random_regions(rng, n, W):
    """Frames with 1-3 sorted, disjoint regions spanning flat ground and the feature."""
    out = np.full((n, 3, 2), np.nan)
    for t in range(n):
        k = rng.integers(1, 4)
        pts = np.sort(rng.uniform(-1.5 * W - 3, 1.5 * W + 3, 2 * k))
        out[t, :k] = pts.reshape(k, 2)
    return out


@pytest.mark.parametrize("name", SURFACE_NAMES)
def test_eq4_matches_brute_force_integral(name):
    s = get_surface(name)
    rng = np.random.default_rng(1)
    regions = random_regions(rng, 6, s.width)
    p = FrictionParams(mu=0.55, p0=0.1, p1=0.3)
    f = friction_force(s, regions, p)
    # atol 0.05 uN: the model interpolates its antiderivative tables linearly at region ends.
    ref = brute_force(s, regions, p)
    np.testing.assert_allclose(f.total, ref[:, 0], rtol=1e-6, atol=5e-8)
    np.testing.assert_allclose(f.interfacial, ref[:, 1], rtol=1e-6, atol=5e-8)
    np.testing.assert_allclose(f.deformation, ref[:, 2], rtol=1e-6, atol=5e-8)
    # Eq. (1): components sum to the total.
    np.testing.assert_allclose(f.interfacial + f.deformation, f.total, rtol=0, atol=1e-15)


def test_sampled_profile_matches_parametric():
    s = get_surface("bump-4mm")
    x = np.linspace(-5, 5, 2001)
    prof = SampledProfile(x, s.h(x))
    regions = random_regions(np.random.default_rng(2), 5, 4.0)
    p = FrictionParams(0.6, 0.1, 0.3)
    np.testing.assert_allclose(friction_force(prof, regions, p).total,
                               friction_force(s, regions, p).total, rtol=1e-5, atol=1e-8)


def test_vectorised_equals_per_frame():
    s = get_surface("step-up-2mm")
    m = FrictionModel(s)
    regions = random_regions(np.random.default_rng(3), 50, 2.0)
    p = FrictionParams(0.5, 0.08, 0.4)
    allf = m.forces(regions, p).total
    one = np.array([m.forces(regions[t][~np.isnan(regions[t, :, 0])].tolist(), p).total[0]
                    if np.any(~np.isnan(regions[t, :, 0])) else 0.0 for t in range(50)])
    np.testing.assert_allclose(allf, one, rtol=0, atol=1e-14)


def test_flat_ground_is_p0_mu_L_and_basis_affine_in_mu():
    s = get_surface("bump-2mm")
    f = friction_force(s, [(-9.0, -3.0), (4.0, 5.5)], FrictionParams(0.5, 0.1, 0.7))
    assert f.total[0] == pytest.approx(0.1 * 0.5 * 7.5, rel=1e-12)
    m = FrictionModel(s)
    r = random_regions(np.random.default_rng(4), 10, 2.0)
    b0, b1, bm = m.basis(r, 0.0), m.basis(r, 1.0), m.basis(r, 0.37)
    np.testing.assert_allclose(bm, b0 + 0.37 * (b1 - b0), atol=1e-13)


def test_bad_params_and_regions():
    with pytest.raises(ValueError, match=r"FrictionParams.p0 \(N/mm\) must be >= 0, got -0.1"):
        FrictionParams(0.5, -0.1, 0.2)
    with pytest.raises(ValueError, match=r"FrictionParams.mu must be in \[0, 5\], got 7"):
        FrictionParams(7, 0.1, 0.2)
    with pytest.raises(ValueError, match=r"mu must be a finite number, got nan"):
        FrictionModel(get_surface("bump-2mm")).basis([(0.0, 1.0)], float("nan"))
    with pytest.raises(ValueError, match=r"inverted: \[a, b\] = \[2.0, 1.0\]"):
        friction_force(get_surface("bump-2mm"), [(2.0, 1.0)], FrictionParams(0.5, 0.1, 0.2))


def test_params_json_roundtrip():
    p = FrictionParams(0.55, 0.1, 0.3)
    assert FrictionParams.from_json(p.to_json()) == p


# --- the load-consistent variant ------------------------------------------------------------


def brute_force_load(surface, regions, f_n, mu, p1):
    """Load-consistent Eq. (4) by quadrature: p0 from the vertical balance of Eq. (2)'s
    stresses, F_N = p0 sum int (cos a - mu sin a) dx (independent reference)."""
    out = []
    for frame, fn in zip(regions, f_n, strict=True):
        up = down = dfm = 0.0
        for a, b in frame:
            if np.isnan(a):
                continue
            x = np.linspace(a, b, 200001)
            s = surface.dhdx(x)
            al = np.arctan(s)
            up += np.trapezoid(np.sin(al) + mu * np.cos(al), x)
            down += np.trapezoid(np.cos(al) - mu * np.sin(al), x)
            dfm += np.trapezoid(s * (np.sin(al) + mu * np.cos(al)), x)
        p0 = fn / down
        out.append((p0 * up + p1 * dfm, p0 * up, p1 * dfm, p0))
    return np.array(out)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["bump-2mm", "step-up-4mm", "step-down-2mm"])
def test_load_consistent_matches_brute_force(name):
    s = get_surface(name)
    regions = random_regions(np.random.default_rng(5), 6, s.width)
    f_n = np.linspace(0.25, 0.35, 6)
    f = FrictionModel(s).load_forces(regions, f_n, LoadParams(mu=0.6, p1=0.04))
    ref = brute_force_load(s, regions, f_n, 0.6, 0.04)
    np.testing.assert_allclose(f.total, ref[:, 0], rtol=1e-6, atol=5e-8)
    np.testing.assert_allclose(f.interfacial, ref[:, 1], rtol=1e-6, atol=5e-8)
    np.testing.assert_allclose(f.deformation, ref[:, 2], rtol=1e-6, atol=5e-8)
    np.testing.assert_allclose(f.pressure, ref[:, 3], rtol=1e-6)


def test_load_consistent_is_amontons_on_flat_ground_and_reduces_to_the_paper_variant():
    s = get_surface("bump-4mm")
    m = FrictionModel(s)
    # flat ground: F_T = mu F_N whatever the contact length
    f = m.load_forces([[(-12.0, -4.0)], [(-11.0, -6.5)]], [0.3, 0.21], LoadParams(0.55, 0.2))
    np.testing.assert_allclose(f.total, [0.55 * 0.3, 0.55 * 0.21], rtol=1e-12)
    np.testing.assert_allclose(f.pressure, [0.3 / 8.0, 0.21 / 4.5], rtol=1e-12)
    # a normal force proportional to the vertical support (a constant pressure p0) gives
    # exactly the paper's Eq. (4) with that p0
    r = random_regions(np.random.default_rng(6), 20, 4.0)
    S, K, Q = m.integrals(r).T
    p0, mu = 0.04, 0.6
    keep = K - mu * S > 0.5
    fn = p0 * (K - mu * S)
    load = m.load_forces(r[keep], fn[keep], LoadParams(mu, 0.3))
    paper = m.forces(r[keep], FrictionParams(mu, p0, 0.3))
    np.testing.assert_allclose(load.total, paper.total, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(load.pressure, p0, rtol=1e-12)


def test_integrals_and_basis_agree():
    m = FrictionModel(get_surface("step-up-2mm"))
    r = random_regions(np.random.default_rng(7), 30, 2.0)
    S, K, Q = m.integrals(r).T
    B = m.basis(r, 0.45)
    np.testing.assert_allclose(B[:, 0], S + 0.45 * K, atol=1e-14)
    np.testing.assert_allclose(B[:, 1], Q + 0.45 * S, atol=1e-14)
    np.testing.assert_allclose(T_matrix([0.45])[0], [[1, 0.45], [0.45, 0], [0, 1]])


def test_load_bearing_contact_is_the_inset_regions():
    s = get_surface("bump-2mm")
    m = FrictionModel(s)
    r = [[(-9.0, -2.0), (-0.5, 0.1)]]  # the second region is 0.6 mm long: gone at a 0.4 mm inset
    f = m.load_forces(r, 0.3, LoadParams(0.5, 0.1, inset=0.4))
    g = m.load_forces([[(-8.6, -2.4)]], 0.3, LoadParams(0.5, 0.1))
    np.testing.assert_allclose(f.total, g.total, rtol=1e-14)
    # no load-bearing contact left: undefined pressure, not a number
    e = m.load_forces([[(-1.0, -0.5)]], 0.3, LoadParams(0.5, 0.1, inset=0.3))
    assert np.isnan(e.pressure[0]) and np.isnan(e.total[0])


def test_load_params_validation_and_json():
    p = LoadParams(0.55, 0.03, 0.4, 2.5)
    assert LoadParams.from_json(p.to_json()) == p
    with pytest.raises(ValueError, match=r"LoadParams.inset \(mm\) must be >= 0, got -0.1"):
        LoadParams(0.5, 0.1, -0.1)
    with pytest.raises(ValueError, match=r"LoadParams.mu must be in \[0, 5\], got 6"):
        LoadParams(6, 0.1)
    with pytest.raises(TypeError, match="params must be LoadParams, got FrictionParams"):
        FrictionModel(get_surface("bump-2mm")).load_forces([(0.0, 1.0)], 0.3, FrictionParams(0.5, 0.1, 0.1))
    with pytest.raises(ValueError, match=r"region_integrals must be an \(n, k, 5\) array"):
        load_terms(np.zeros((4, 2)), 0.5)
    with pytest.raises(ValueError, match=r"kappa must be a finite rate >= 0 in 1/mm, got -1"):
        load_terms(np.zeros((4, 2, 5)), 0.5, -1)
    with pytest.raises(ValueError, match=r"LoadParams.kappa \(1/mm\) must be >= 0, got -0.5"):
        LoadParams(0.5, 0.1, 0.0, -0.5)


def test_load_sharing_between_regions_rises_with_height():
    """Region pressures p_i = F_N exp(kappa hbar_i) / sum_j s_j exp(kappa hbar_j): kappa = 0
    is one uniform pressure, kappa > 0 puts more on the higher region; the loads add up
    to F_N."""
    s = get_surface("bump-4mm")
    m = FrictionModel(s)
    r = [[(-9.0, -3.0), (-0.5, 0.5)]]  # a flat 6 mm region and the 1 mm top of the bump
    R = m.region_integrals(r)
    mu = 0.5
    S, K, H, L = R[0, :, 0], R[0, :, 1], R[0, :, 3], R[0, :, 4]
    np.testing.assert_allclose(L, [6.0, 1.0])
    xs = np.linspace(-0.5, 0.5, 200001)
    assert H[1] == pytest.approx(np.trapezoid(s.h(xs), xs), rel=1e-7)  # int h dx over the bump top
    sup = K - mu * S
    for kappa in (0.0, 2.0, 5.0):
        g, b, support = load_terms(R, mu, kappa)
        p = 0.3 * np.exp(kappa * H / L) / np.sum(sup * np.exp(kappa * H / L))
        assert np.sum(p * sup) == pytest.approx(0.3, rel=1e-12)  # the loads add up to F_N
        assert 0.3 * g[0] == pytest.approx(np.sum(p * (S + mu * K)), rel=1e-12)
        assert support[0] == pytest.approx(sup.sum(), rel=1e-12)
    f0 = m.load_forces(r, 0.3, LoadParams(mu, 0.0))
    assert f0.pressure[0] == pytest.approx(0.3 / sup.sum(), rel=1e-12)
    # on the rising flank of the bump: more pressure there with kappa > 0, so more F_int
    r2 = [[(-9.0, -3.0), (-1.5, -0.5)]]
    assert m.load_forces(r2, 0.3, LoadParams(mu, 0.0, kappa=4.0)).interfacial[0] > \
        m.load_forces(r2, 0.3, LoadParams(mu, 0.0)).interfacial[0]
    # two regions at the same height: kappa changes nothing (flat ground is Amontons' law)
    flat = m.load_forces([[(-12.0, -8.0), (-7.0, -4.0)]], 0.3, LoadParams(mu, 0.1, kappa=6.0))
    assert flat.total[0] == pytest.approx(mu * 0.3, rel=1e-12)
