"""The layered finite-element finger: assembly, verification (Hertz, BEM), cache, inputs.

Coarse meshes throughout; the converged figures are printed by benchmarks/fe_finger.py.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from fingerfriction.mechanics import ContactSolver, FingerParams
from fingerfriction.mechanics.fe import (
    LITERATURE_FINGER,
    FEContactSolver,
    FEFingerParams,
    FEMeshParams,
    FEProvider,
    build_mesh,
)
from fingerfriction.mechanics.fe.solver import _surface_funcs
from fingerfriction.mechanics.hertz import hertz_half_width, hertz_peak_pressure
from fingerfriction.surfaces import RaisedCosine, get_surface

#: A homogeneous cylinder with a small rigid core: the Hertz and BEM reference body.
CYLINDER = FEFingerParams(radius=8.0, semi_height=8.0, tissue_modulus=0.1, skin_modulus=0.1,
                          skin_thickness=0.5, poisson=0.45, bone_half_width=1.0, bone_half_height=1.0,
                          pulp_thickness=7.0, nail_modulus=0.1, name="cylinder")
COARSE = FEMeshParams(surface_cell=0.4, contact_half_width=5.0, skin_layers=1, tissue_layers=3, top_cells=8)


def _flat(x):
    return np.zeros_like(np.asarray(x, float))


def half_width(sol) -> float:
    """Half-width of a centred contact from the pressure's second moment (Hertz: exactly a)."""
    x, p = sol.outline_x, sol.outline_pressure
    return 2.0 * np.sqrt(np.trapezoid(p * x * x, x) / np.trapezoid(p, x))


def test_mesh_elements_are_counter_clockwise_and_layered():
    m = build_mesh(LITERATURE_FINGER, COARSE)
    x, y = m.p[0][m.t], m.p[1][m.t]
    area = 0.5 * np.sum(x * np.roll(y, -1, 0) - np.roll(x, -1, 0) * y, 0)
    assert np.all(area > 0)
    assert set(np.unique(m.material)) == {0, 1, 2}
    # the lowest node is the finger's lowest point, at the origin
    assert np.isclose(m.p[1].min(), 0.0, atol=1e-12)
    # the bone's lowest point is pulp_thickness above it
    assert np.isclose(m.p[1][m.bone].min(), LITERATURE_FINGER.pulp_thickness)


def test_element_kernels_match_scikit_fem_assembly():
    """The vectorised neo-Hookean residual and tangent equal scikit-fem's form assembly."""
    import skfem
    from skfem.helpers import ddot, grad, transpose

    s = FEContactSolver(CYLINDER, FEMeshParams(surface_cell=1.0, contact_half_width=3.0, skin_layers=1,
                                               tissue_layers=2, top_cells=4))
    X = s.sbasis.doflocs
    u = np.empty(s.n_dof)  # a smooth large deformation (up to ~10 % strain)
    u[0::2] = 0.3 * np.sin(0.3 * X[1]) + 0.05 * X[0]
    u[1::2] = -0.4 * np.cos(0.2 * X[0]) * X[1] / 16.0
    fint, vals = s._internal(u)
    vb = skfem.Basis(s.skmesh, skfem.ElementVector(skfem.ElementQuad2()), intorder=4)
    mu, lam = s._mu, s._lam

    def kin(w):
        F = grad(w["u"]) + np.eye(2)[:, :, None, None]
        J = F[0, 0] * F[1, 1] - F[0, 1] * F[1, 0]
        FiT = np.stack([np.stack([F[1, 1], -F[1, 0]]), np.stack([-F[0, 1], F[0, 0]])]) / J
        return F, J, FiT

    @skfem.LinearForm
    def res(v, w):
        F, J, FiT = kin(w)
        P = w["mu"] * (F - FiT) + w["lam"] * np.log(J) * FiT
        return ddot(P, grad(v))

    @skfem.BilinearForm
    def tan(du, v, w):
        F, J, FiT = kin(w)
        A = grad(du)
        tr = ddot(FiT, A)
        dP = (w["mu"] * A + (w["mu"] - w["lam"] * np.log(J)) * np.einsum("ij...,jk...,kl...->il...", FiT,
                                                                           transpose(A), FiT)
              + w["lam"] * tr * FiT)
        return ddot(dP, grad(v))

    ui = vb.interpolate(u)
    r_ref = skfem.asm(res, vb, u=ui, mu=mu, lam=lam)
    K_ref = skfem.asm(tan, vb, u=ui, mu=mu, lam=lam).toarray()
    N = s.n_dof
    K = np.zeros((N + 1, N + 1))
    np.add.at(K, (s._keys // (N + 1), s._keys % (N + 1)), vals)
    assert np.allclose(fint[:N], r_ref, atol=1e-12 * np.abs(r_ref).max() + 1e-14)
    assert np.allclose(K[:N, :N], K_ref, atol=1e-10 * np.abs(K_ref).max())


def test_contact_tangent_is_the_derivative_of_the_residual():
    s = FEContactSolver(LITERATURE_FINGER, COARSE)
    surf = get_surface("bump-4mm")
    hf = _surface_funcs(surf)
    rng = np.random.default_rng(1)
    X = s.sbasis.doflocs
    u = np.zeros(s.n_dof)
    u[1::2] = 0.1 * np.exp(-X[1]) * np.cos(X[0])
    z = s.initial_height(surf, -3.0) - 0.3
    N = s.n_dof

    def resid(u, z):
        fint, vals = s._internal(u)
        _, fc, trip, _ = s._contact(u, z, -3.0, hf)
        np.add.at(vals, trip[0], trip[1])  # the exact tangent
        return fint + fc, vals

    _, vals = resid(u, z)
    K = np.zeros((N + 1, N + 1))
    np.add.at(K, (s._keys // (N + 1), s._keys % (N + 1)), vals)
    v = rng.normal(size=N + 1)
    e = 1e-7
    fd = (resid(u + e * v[:N], z + e * v[N])[0] - resid(u - e * v[:N], z - e * v[N])[0]) / (2 * e)
    assert np.max(np.abs(fd - K @ v)) < 1e-6 * np.max(np.abs(fd))
    # the trailing entries are the curvature terms Newton may leave out far from the solution:
    # on the horizontal diagonal of contact nodes, some of them softening (negative) here
    idx, cv, n = s._contact(u, z, -3.0, hf)[2]
    rows, cols = s._keys[idx[-n:]] // (N + 1), s._keys[idx[-n:]] % (N + 1)
    assert np.all(rows == cols) and np.all(rows % 2 == 0) and np.any(cv[-n:] < 0)


@pytest.mark.slow
def test_cylinder_against_plane_strain_hertz_coarse():
    """Half-width within 3 % and peak pressure within 8 % of Hertz on a coarse mesh (the
    benchmark refines to 3 % for both)."""
    P = 0.0079  # N/mm: a / R = 0.1
    mesh = FEMeshParams(surface_cell=0.08, contact_half_width=2.0, skin_layers=2, tissue_layers=8,
                        top_cells=16)
    sol, _ = FEContactSolver(CYLINDER, mesh).solve(_flat, 0.0, load=P * CYLINDER.width)
    assert sol.success, sol.message
    Es = CYLINDER.plane_strain_modulus()
    a, p0 = hertz_half_width(P, 8.0, Es), hertz_peak_pressure(P, 8.0, Es)
    assert abs(half_width(sol) / a - 1) < 0.03
    xg = np.linspace(-2 * a, 2 * a, 801)
    _, p = sol.on_grid(xg, P * CYLINDER.width, CYLINDER.width)
    assert abs(p.max() / p0 - 1) < 0.08
    assert np.isclose(np.trapezoid(p, xg), P, rtol=1e-3)


@pytest.mark.slow
def test_homogeneous_finger_against_bem_on_a_shallow_bump():
    """Small strains (a shallow bump, 0.1 N): contact lengths within 5 % of the BEM's."""
    surf = RaisedCosine("bump", 4.0, height=0.2)
    bem = ContactSolver(FingerParams(radius=8.0, modulus=CYLINDER.plane_strain_modulus(), width=10.0),
                        n=1024, half_width=4.0)
    s = FEContactSolver(CYLINDER, FEMeshParams(surface_cell=0.08, contact_half_width=3.5, skin_layers=1,
                                               tissue_layers=8, top_cells=16))
    state = None
    for xc in (-2.5, -2.0, -1.5):
        sol, state = s.solve(surf, xc, load=0.1, warm=state)
        assert sol.success, sol.message
        b = bem.solve(surf, xc, load=0.1)
        _, p = sol.on_grid(bem.grid(xc), 0.1, 10.0)
        assert abs((p > 0).sum() / (b.pressure > 0).sum() - 1) < 0.05


@pytest.mark.slow
def test_load_balance_and_no_penetration_on_a_bump_sweep():
    s = FEContactSolver(LITERATURE_FINGER, COARSE)
    surf = get_surface("step-up-2mm")
    state = None
    for xc in np.arange(-3.0, -1.9, 0.2):
        sol, state = s.solve(surf, xc, load=0.3, warm=state)
        assert sol.success, sol.message
        x = np.linspace(xc - 8, xc + 8, 3201)
        y, p = sol.on_grid(x, 0.3, LITERATURE_FINGER.width)
        assert np.isclose(np.trapezoid(p, x) * LITERATURE_FINGER.width, 0.3, rtol=1e-3)
        # penalty penetration: pressure / penalty, well under a micrometre
        assert np.min(sol.outline_y - surf.h(sol.outline_x)) > -1e-3


@pytest.mark.slow
def test_provider_cache_reuses_unchanged_and_recomputes_changed(tmp_path, monkeypatch):
    surf = RaisedCosine("bump", 2.0)
    xs = np.arange(-9.0, -6.9, 0.3)
    pr = FEProvider(mesh=COARSE, grid_step=0.05, cache_dir=tmp_path / "c")
    y1, p1 = pr.solve(surf, "1", xs, 0.3)
    assert pr.computed == 1 and len(list((tmp_path / "c").glob("*.npz"))) == 1
    # same inputs, a new provider: read back, nothing solved
    pr2 = FEProvider(mesh=COARSE, grid_step=0.05, cache_dir=tmp_path / "c")
    monkeypatch.setattr(pr2, "_compute", lambda *a: pytest.fail("recomputed an unchanged table"))
    y2, p2 = pr2.solve(surf, "1", xs, 0.3)
    assert np.array_equal(y1.astype(np.float32), y2.astype(np.float32)) and np.allclose(p1, p2)
    # a changed finger parameter: a new key, computed
    f = dataclasses.replace(pr.fingers["1"], skin_modulus=0.25)
    pr3 = FEProvider(fingers={"1": f}, mesh=COARSE, grid_step=0.05, cache_dir=tmp_path / "c")
    pr3.solve(surf, "1", xs, 0.3)
    assert pr3.computed == 1 and len(list((tmp_path / "c").glob("*.npz"))) == 2
    # so do a changed load and a changed mesh
    assert pr.cache_key(surf, "1", xs, 0.3) != pr.cache_key(surf, "1", xs, 0.31)
    pr4 = FEProvider(mesh=dataclasses.replace(COARSE, penalty=2000.0), cache_dir=tmp_path / "c")
    assert pr4.cache_key(surf, "1", xs, 0.3) != FEProvider(mesh=COARSE, cache_dir=tmp_path / "c").cache_key(
        surf, "1", xs, 0.3)


@pytest.mark.slow
def test_provider_flat_positions_are_translated_solutions(tmp_path):
    surf = get_surface("step-up-2mm")
    pr = FEProvider(mesh=COARSE, grid_step=0.05, cache_dir=False)
    xs = np.array([-20.0, -19.0, 20.0])
    y, p = pr.solve(surf, "1", xs, 0.3)
    assert np.allclose(y[0], y[1]) and np.allclose(p[0], p[1])
    assert np.allclose(y[2], y[0] + surf.height, atol=1e-9)


@pytest.mark.slow  # six coarse solves, ~4 s: the traction the FE studies carry
def test_friction_shifts_the_patch_against_the_motion_on_any_path():
    s = FEContactSolver(LITERATURE_FINGER, COARSE)
    free, _ = s.solve(_flat, 0.0, load=0.3)
    fr, _ = s.solve(_flat, 0.0, load=0.3, friction=0.55)
    c0, c1 = (float(np.trapezoid(o.outline_pressure * o.outline_x, o.outline_x)
                    / np.trapezoid(o.outline_pressure, o.outline_x)) for o in (free, fr))
    assert abs(c0) < 0.01 and c1 < -0.1  # the finger moves to +x: the patch trails
    assert free.success and fr.success
    # a warm-started sliding sweep reaches the cold solve's state (one fixed point)
    surf = RaisedCosine("bump", 4.0, height=0.2)
    st = None
    for xc in (-3.6, -3.3, -3.0):
        warm, st = s.solve(surf, xc, load=0.3, warm=st, friction=0.55)
    cold, _ = s.solve(surf, -3.0, load=0.3, friction=0.55)
    assert warm.success and cold.success
    assert np.allclose(warm.outline_y, cold.outline_y, atol=1e-5) and abs(warm.z - cold.z) < 1e-5
    with pytest.raises(ValueError, match="friction must be a coefficient >= 0, got -0.1"):
        s.solve(surf, 0.0, friction=-0.1)


@pytest.mark.parametrize(("kw", "match"), [
    ({"radius": -1.0}, r"FEFingerParams.radius must be a finite positive number in mm, got -1.0"),
    ({"tissue_modulus": float("nan")}, r"tissue_modulus must be a finite positive number in MPa"),
    ({"poisson": 0.5}, r"poisson must be in \(0, 0.499\]"),
    ({"skin_thickness": 5.0}, r"skin_thickness \(5 mm\) must be below pulp_thickness"),
    ({"pulp_thickness": 9.0}, r"does not fit under the top"),
    ({"bone_half_width": 10.5}, r"bone_half_width \(10.5 mm\) must be below"),
    ({"friction": -0.1}, r"friction must be a friction coefficient in \[0, 5\], got -0.1"),
    ({"friction": float("nan")}, r"friction must be a friction coefficient"),
    ({"friction": True}, r"friction must be a friction coefficient"),
    ({"nail_half_angle": 95.0}, r"FEFingerParams.nail_half_angle must be in \(0, 90\) degrees, got 95.0"),
])
def test_bad_fe_finger_parameters_raise_one_line_errors(kw, match):
    with pytest.raises(ValueError, match=match) as e:
        FEFingerParams(**kw)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize(("cls", "kw", "error", "match"), [
    (FEFingerParams, {"radius": "11"}, TypeError, r"FEFingerParams.radius must be a number in mm, got str"),
    (FEFingerParams, {"name": 3}, TypeError, r"FEFingerParams.name must be text, got int"),
    (FEMeshParams, {"tissue_layers": 2.5}, ValueError, r"FEMeshParams.tissue_layers must be an integer >= 1, "
                                                       r"got 2.5"),
    (FEMeshParams, {"penalty": 0.0}, ValueError, r"FEMeshParams.penalty must be a finite positive number in "
                                                 r"N/mm\^3, got 0.0"),
])
def test_bad_fe_options_name_the_value_and_what_is_allowed(cls, kw, error, match):
    with pytest.raises(error, match=match) as e:
        cls(**kw)
    assert "\n" not in str(e.value)


def test_bad_mesh_and_load():
    with pytest.raises(ValueError, match="skin_layers must be an integer >= 1"):
        FEMeshParams(skin_layers=0)
    s = FEContactSolver(LITERATURE_FINGER, COARSE)
    with pytest.raises(ValueError, match="load must be a finite positive normal force in N"):
        s.solve(_flat, 0.0, load=-0.3)
    with pytest.raises(TypeError, match="finger must be an FEFingerParams"):
        FEContactSolver(FingerParams(radius=8, modulus=0.1, width=10))


def test_fe_finger_files_round_trip_and_one_line_errors(tmp_path):
    from fingerfriction.mechanics.finger_file import read_finger_file, write_finger_file

    f = dataclasses.replace(LITERATURE_FINGER, skin_modulus=0.3, name="mine")
    p = write_finger_file(tmp_path / "fe.json", f, calibration={"by": "hand"})
    assert read_finger_file(p, model="fe") == f
    (tmp_path / "bare.json").write_text('{"model": "fe", "tissue_modulus": 0.03}')
    assert read_finger_file(tmp_path / "bare.json", model="fe").tissue_modulus == 0.03
    bad = {
        "notjson.json": ("{model: fe", "not valid JSON"),
        "unknown.json": ('{"model": "fe", "skin_colour": 1}', r"unknown field\(s\) \['skin_colour'\]"),
        "value.json": ('{"model": "fe", "skin_thickness": -1}', "skin_thickness must be a finite positive"),
        "geometry.json": ('{"model": "fe", "pulp_thickness": 0.5}', "must be below pulp_thickness"),
        "halfspace.json": ('{"radius": 8, "modulus": 0.1, "width": 10}', "not an FE finger"),
        "version.json": ('{"format": "fingerfriction-finger", "version": 9, "model": "fe", "finger": {}}',
                         "version 9 is not supported"),
    }
    for name, (text, match) in bad.items():
        (tmp_path / name).write_text(text)
        with pytest.raises(ValueError, match=match) as e:
            read_finger_file(tmp_path / name, model="fe")
        assert "\n" not in str(e.value) and name in str(e.value)
    # an FE file where a half-space finger is needed
    with pytest.raises(ValueError, match="holds an FE finger"):
        read_finger_file(p)


@pytest.mark.slow  # a coarse FE sweep of 11 positions, ~6 s
def test_the_fe_finger_as_the_forward_model(tmp_path, monkeypatch):
    from fingerfriction.mechanics.finger_file import read_finger_file, write_finger_file
    from fingerfriction.predict.forward import FE_FORWARD_STEP, finger_for_label, forward_regions

    monkeypatch.setenv("FINGERFRICTION_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("FINGERFRICTION_FE_MESH", json.dumps(COARSE.to_dict()))
    surf = get_surface("bump-4mm")
    x = np.arange(-6.0, -4.99, 0.05)  # finer than the FE step: nearest solved position
    geo = forward_regions(surf, LITERATURE_FINGER, x, load=0.3)
    mech = forward_regions(surf, LITERATURE_FINGER, x, load=0.3, contact="mechanical")
    assert geo.shape[0] == x.size and FE_FORWARD_STEP == 0.1
    assert np.array_equal(geo[0], geo[1], equal_nan=True)  # -6.0 and -5.95 share the -6.0 solve
    w_geo = np.nansum(geo[..., 1] - geo[..., 0], axis=1)
    w_mech = np.nansum(mech[..., 1] - mech[..., 0], axis=1)
    assert np.all(w_geo > 6.0) and np.all(w_mech > 4.0) and np.all(w_geo > w_mech)  # 70 um is wider
    assert len(list((tmp_path / "cache" / "fe").glob("*.npz"))) == 1  # one cached sweep, reused
    forward_regions(surf, LITERATURE_FINGER, x, load=0.3)
    assert len(list((tmp_path / "cache" / "fe").glob("*.npz"))) == 1
    # an FE finger file is a subject's forward-model finger (validate --finger 1=fe.json)
    path = write_finger_file(tmp_path / "fe.json", LITERATURE_FINGER)
    f = read_finger_file(path, model="any")
    assert f == LITERATURE_FINGER and finger_for_label("1", {"1": f}) == f


def test_a_fingers_own_friction_is_its_contacts_unless_the_provider_sets_one(tmp_path):
    from fingerfriction.mechanics.finger_file import read_finger_file, write_finger_file

    f = dataclasses.replace(LITERATURE_FINGER, friction=0.55)
    assert FEProvider(fingers={"1": f}).mu("1") == 0.55
    assert FEProvider(fingers={"1": f}, friction=0.6).mu("1") == 0.6
    assert FEProvider(fingers={"1": f}, friction={"1": 0.0}).mu("1") == 0.0
    assert FEProvider(fingers={"1": LITERATURE_FINGER}).mu("1") == 0.0
    # the truth's provider entry carries the contact's friction: read back as the finger's
    entry = FEProvider(fingers={"1": LITERATURE_FINGER}, friction=0.6).finger_dict("1")
    assert entry["friction"] == 0.6 and entry["model"] == "fe"
    (tmp_path / "truth.json").write_text(json.dumps(entry))
    assert read_finger_file(tmp_path / "truth.json", model="fe").friction == 0.6
    assert read_finger_file(write_finger_file(tmp_path / "f.json", f), model="any") == f
    # a different friction is a different table
    xs = np.arange(-1.0, 1.0, 0.5)
    surf = get_surface("bump-2mm")
    assert FEProvider(fingers={"1": f}).cache_key(surf, "1", xs, 0.3) != \
        FEProvider(fingers={"1": LITERATURE_FINGER}).cache_key(surf, "1", xs, 0.3)


def test_which_positions_converged_is_cached_with_the_table(tmp_path, monkeypatch):
    surf = get_surface("bump-2mm")
    xs = np.arange(-1.0, 1.0, 0.5)
    pr = FEProvider(mesh=COARSE, grid_step=0.05, cache_dir=tmp_path)
    n = pr.grid("1").size
    ok = np.array([True, False, True, True])
    monkeypatch.setattr(pr, "_compute", lambda *a: (np.zeros((4, n)), np.zeros((4, n)), ok))
    pr.solve(surf, "1", xs, 0.3)
    assert np.array_equal(pr.last_ok, ok)
    pr2 = FEProvider(mesh=COARSE, grid_step=0.05, cache_dir=tmp_path)
    monkeypatch.setattr(pr2, "_compute", lambda *a: pytest.fail("recomputed an unchanged table"))
    pr2.solve(surf, "1", xs, 0.3)
    assert np.array_equal(pr2.last_ok, ok)


def test_an_fe_forward_sweep_keeps_a_few_unconverged_positions_and_refuses_many(monkeypatch, caplog):
    from fingerfriction.predict import forward

    surf = get_surface("bump-2mm")
    x = np.round(np.arange(-2.0, 2.0 + 1e-9, 0.1), 6)
    calls = {}

    def fake_solve(self, surface, subject, xc, load):
        n = self.grid(subject).size
        xi = self.grid(subject)
        y = np.empty((xc.size, n))
        for i, c in enumerate(xc):  # a contact 2 mm either side of the finger centre ...
            y[i] = np.where(np.abs(xi) < 2.0, surface.h(c + xi), 1.0)
        bad = calls["bad"]
        y[bad] = 5.0  # ... but an unconverged position's last iterate touches nothing
        ok = np.ones(xc.size, bool)
        ok[bad] = False
        self.last_ok = ok
        return y, np.zeros_like(y)

    monkeypatch.setattr(FEProvider, "solve", fake_solve)
    calls["bad"] = [3]  # 1 of 41: kept, with the nearest converged position's regions
    with caplog.at_level("WARNING"):
        reg = forward.forward_regions(surf, LITERATURE_FINGER, x, load=0.3)
    assert "did not converge at 1 of 41 finger positions" in caplog.text
    assert np.all(np.isfinite(reg[:, 0, 0]))  # no position without its contact
    assert np.allclose(reg[3], reg[2], equal_nan=True) and not np.allclose(reg[4], reg[2], equal_nan=True)
    calls["bad"] = [3, 10, 20]  # 3 of 41 (7 %): no prediction
    msg = r"failed at 3 of 41 finger positions on bump-2mm \(more than 5%\)"
    with pytest.raises(RuntimeError, match=msg):
        forward.forward_regions(surf, LITERATURE_FINGER, x, load=0.3)


@pytest.mark.slow  # ~60 coarse positions, two sweeps
def test_a_stiff_skinned_drawn_finger_converges_over_the_sharp_bump():
    """Bump 2 mm with a drawn layered finger (finger seed 6414's subject 1: a soft pulp, a
    small radius) was where the solver failed most (17 of 120 positions frictionless, 73
    with friction, before its tangent and cold restarts; docs/mechanics-fe.md)."""
    from fingerfriction.sim.fingers import draw_fingers

    finger = draw_fingers(6414, ["1"], model="fe")["1"]
    s = FEContactSolver(finger, COARSE)
    surf = get_surface("bump-2mm")
    for mu, xs in ((0.0, np.arange(-2.0, 2.0, 0.1)), (0.55, np.arange(-1.0, 1.0, 0.1))):
        state, failed = None, []
        for xc in xs:
            sol, new = s.solve(surf, xc, load=0.3, warm=state, friction=mu)
            if sol.success:
                state = new
            else:
                failed.append((round(float(xc), 2), sol.message))
        assert not failed, (mu, failed)
