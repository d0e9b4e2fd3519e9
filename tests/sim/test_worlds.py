"""The simulator's worlds (fingerfriction.sim.worlds): each law on a known geometry, and
the options that choose them."""

from __future__ import annotations

import json

import numpy as np
import pytest

from fingerfriction.sim import SimOptions, simulate_study
from fingerfriction.sim.contact import build_table
from fingerfriction.sim.worlds import (
    WORLD_NAMES,
    ConstantPressure,
    Interlocking,
    LoadSharing,
    TrialMotion,
    get_world,
)
from fingerfriction.surfaces import get_surface

from .conftest import tiny_options

HALF = 3.0  # half-width in mm of the patch provider's contact


class _PatchProvider:
    """A finger lying on the surface over |xi| <= 3 mm (its outline is the surface, so the
    geometric contact is the whole grid) with a parabolic pressure over |xi| < 1."""

    name = "patch"

    def finger_dict(self, subject):
        return {}

    def grid(self, subject):
        return np.linspace(-HALF, HALF, 1201)

    def solve(self, surface, subject, x_centres, load):
        xi = self.grid(subject)
        X = np.asarray(x_centres)[:, None] + xi[None, :]
        p = np.clip(1.0 - xi**2, 0.0, None)[None, :].repeat(X.shape[0], 0)
        return surface.h(X), p * load


def _table(name):
    return build_table(get_surface(name), "1", loads=(0.2, 0.4), step=0.05, provider=_PatchProvider())


@pytest.fixture(scope="module")
def tables():
    return {n: _table(n) for n in ("step-up-4mm", "step-down-4mm")}


def _motion(x, f_n=0.3, speed=80.0, f_target=0.3):
    x = np.atleast_1d(np.asarray(x, float))
    n = x.size
    return TrialMotion(t=np.full(n, 1.0), x=x, f_n=np.full(n, f_n), sliding_distance=np.full(n, 20.0),
                       in_contact=np.ones(n, bool), mean_speed=speed, f_target=f_target, t_slide_start=0.0)


QUIET = Interlocking(psi_sd=0.0, mu_sd=0.0, fluct_sd=0.0)  # no draws that change the forces


@pytest.mark.slow
@pytest.mark.parametrize("world", [LoadSharing(), ConstantPressure(p1_sd=0.0), QUIET])
def test_flat_ground_is_amontons_in_every_world(tables, world):
    f = world.trial_forces(tables["step-up-4mm"], _motion([-9.0, -8.0]), "1", np.random.default_rng(0))
    np.testing.assert_allclose(f.f_t / 0.3, 0.55, rtol=1e-9)
    np.testing.assert_allclose(f.f_def, 0.0, atol=1e-15)
    assert f.truth["mu_trial"] == pytest.approx(0.55)


@pytest.mark.slow
def test_constant_pressure_is_eq4_on_the_geometric_contact(tables):
    """Hand computation: with the outline on the surface the contact is [x - 3, x + 3]; p0
    carries the target load over the flat contact (6 mm), p1 is the world's."""
    w = ConstantPressure(p1=0.2, p1_sd=0.0)
    surf = get_surface("step-up-4mm")
    mu = 0.55
    for x_c, f_target in ((-1.5, 0.3), (0.4, 0.27), (1.9, 0.33)):
        f = w.trial_forces(tables["step-up-4mm"], _motion([x_c], f_n=0.3, f_target=f_target), "1",
                           np.random.default_rng(0))
        x = np.linspace(x_c - HALF, x_c + HALF, 60001)
        s = surf.dhdx(x)
        a = np.arctan(s)
        proj = np.sin(a) + mu * np.cos(a)
        length = 2 * HALF + 0.005  # 1201 grid points of 0.005 mm, each counted whole
        p0 = f_target / length
        assert f.truth["p0_trial"] == pytest.approx(p0, rel=1e-9)
        assert f.f_int[0] == pytest.approx(p0 * np.trapezoid(proj, x), rel=2e-3)
        assert f.f_def[0] == pytest.approx(0.2 * np.trapezoid(s * proj, x), rel=2e-3)
        # the normal force does not enter: friction follows the contact, not the load
        g = w.trial_forces(tables["step-up-4mm"], _motion([x_c], f_n=0.36, f_target=f_target), "1",
                           np.random.default_rng(0))
        assert g.f_t[0] == pytest.approx(f.f_t[0], rel=1e-12)


@pytest.mark.slow
def test_constant_pressure_draws_p1_per_trial(tables):
    w = ConstantPressure()
    tab = tables["step-up-4mm"]
    p1 = [w.trial_forces(tab, _motion([0.0]), "1", np.random.default_rng(k)).truth["p1_trial"]
          for k in range(400)]
    assert np.mean(p1) == pytest.approx(0.14, rel=0.03)
    assert np.std(p1) / np.mean(p1) == pytest.approx(0.15, rel=0.15)


@pytest.mark.slow
def test_interlocking_pushes_back_on_rising_ground_and_gives_little_on_falling(tables):
    """Mirror geometries: the step up at x and the step down at -x put the same pressure on
    slopes of opposite sign; the deformation force is (1 + psi_up) times the elastic push
    there, and down_return of the forward push here."""
    up = QUIET.trial_forces(tables["step-up-4mm"], _motion([-1.0]), "1", np.random.default_rng(0))
    down = QUIET.trial_forces(tables["step-down-4mm"], _motion([1.0]), "1", np.random.default_rng(0))
    assert up.f_def[0] > 0 > down.f_def[0]
    ratio = (1 + QUIET.psi_up) / QUIET.down_return
    assert up.f_def[0] / -down.f_def[0] == pytest.approx(ratio, rel=1e-6)
    # the interfacial part is the Coulomb shear alone: nearly mu F_N on both
    assert up.f_int[0] == pytest.approx(down.f_int[0], rel=1e-9)
    assert up.f_int[0] == pytest.approx(0.55 * 0.3, rel=0.05)


@pytest.mark.slow
def test_interlocking_grows_with_speed(tables):
    tab = tables["step-up-4mm"]
    fd = [QUIET.trial_forces(tab, _motion([-1.0], speed=v), "1", np.random.default_rng(0)).f_def[0]
          for v in (40.0, 80.0, 120.0)]
    assert fd[0] < fd[1] < fd[2]
    up40, _ = QUIET.psi(40.0)
    assert fd[0] / fd[1] == pytest.approx((1 + up40) / (1 + QUIET.psi_up), rel=1e-6)


@pytest.mark.slow
def test_interlocking_varies_within_and_between_trials(tables):
    w = Interlocking()
    m = TrialMotion(t=np.arange(4000) / 1e4, x=np.full(4000, -1.0), f_n=np.full(4000, 0.3),
                    sliding_distance=np.full(4000, 20.0), in_contact=np.ones(4000, bool), mean_speed=80.0,
                    f_target=0.3, t_slide_start=-1.0)
    a = w.trial_forces(tables["step-up-4mm"], m, "1", np.random.default_rng(1))
    b = w.trial_forces(tables["step-up-4mm"], m, "1", np.random.default_rng(2))
    assert np.std(a.f_def) / np.mean(a.f_def) > 0.05  # within the trial
    assert a.truth["psi_up_trial"] != b.truth["psi_up_trial"]  # between trials


def test_interlocking_static_peak_is_the_aging_law_erased_by_slip():
    """Hand computation of the rate-and-state aging law at constant speed: the contact
    touches at t = 0 and slides from t = 0.02 s, so theta0 = 0.02 s; at slip d the
    friction's gain is 1 + b ln(1 + (v theta0 / D_c - 1) exp(-d / D_c)). Two speeds at the
    same slip differ only through C = v theta0 / D_c: the memory is erased by slip, not by
    time."""
    w = Interlocking(aging=0.05, memory_mm=0.1)
    t = np.arange(4001) / 1e4
    for v in (40.0, 120.0):
        d = np.maximum(t - 0.02, 0.0) * v
        m = TrialMotion(t=t, x=-15.0 + d, f_n=np.full(t.size, 0.3), sliding_distance=d,
                        in_contact=np.ones(t.size, bool), mean_speed=v, f_target=0.3, t_slide_start=0.02)
        c = v * 0.02 / 0.1
        g = w.static_peak(m)
        assert g[0] == pytest.approx(1 + 0.05 * np.log(c), rel=1e-12)
        for dd in (0.1, 0.3, 1.0):
            k = np.searchsorted(d, dd)
            assert g[k] == pytest.approx(1 + 0.05 * np.log1p((c - 1) * np.exp(-d[k] / 0.1)), rel=1e-12)
        assert g[-1] - 1 < 1e-10  # gone after 10 mm of slip ...
        k1 = np.searchsorted(d, 1.0)
        assert 0 < g[k1] - 1 < 1e-4 * c  # ... and nearly so after 1 mm, whatever the speed
    # a contact with no age (it slides as it touches) has no static peak
    m0 = TrialMotion(t=t, x=np.zeros(t.size), f_n=np.full(t.size, 0.3), sliding_distance=t * 80.0,
                     in_contact=np.ones(t.size, bool), mean_speed=80.0, f_target=0.3, t_slide_start=0.0)
    assert np.all(w.static_peak(m0) == 1.0)


def test_world_names_and_errors():
    assert WORLD_NAMES == ("load-sharing", "constant-pressure", "interlocking")
    for name in WORLD_NAMES:
        assert get_world(name).name == name
    with pytest.raises(ValueError, match=r"^unknown world 'paper'; worlds: load-sharing, constant-pressure, "
                                         r"interlocking$"):
        SimOptions(world="paper")
    with pytest.raises(ValueError, match=r"^unknown chain 'perfect'; chains: ideal, realistic$"):
        SimOptions(chain="perfect")
    with pytest.raises(ValueError, match=r"^ConstantPressure.p1_sd must be in \[0, 0.3\], got 0.5$"):
        ConstantPressure(p1_sd=0.5)
    with pytest.raises(ValueError, match="down_return must be in"):
        Interlocking(down_return=1.5)
    with pytest.raises(ValueError, match=r"^Interlocking.v_ref must be > 0, got 0$"):
        Interlocking(v_ref=0)
    with pytest.raises(ValueError, match=r"^Interlocking.fluct_sd must be in \[0, 0.5\], got 0.6$"):
        Interlocking(fluct_sd=0.6)
    with pytest.raises(ValueError, match=r"^ConstantPressure.p1 must be >= 0, got True$"):
        ConstantPressure(p1=True)
    with pytest.raises(ValueError, match=r"^ConstantPressure.p1 must be a number, got '0.2'$"):
        ConstantPressure(p1="0.2")


def test_options_round_trip_with_world_and_chain():
    opts = SimOptions(world=Interlocking(psi_up=0.7), chain="realistic")
    d = json.loads(json.dumps(opts.to_dict()))
    assert d["world"] == {"name": "interlocking", "params": opts.world.to_dict()["params"]}
    assert d["chain"]["name"] == "realistic"
    assert SimOptions.from_dict(d) == opts
    assert SimOptions.from_dict(SimOptions().to_dict()) == SimOptions()


@pytest.mark.slow
def test_study_records_its_world_and_the_trials_realised_values(tmp_path):
    opts = tiny_options(world="constant-pressure", chain="realistic")
    simulate_study(tmp_path / "s", opts, workers=1)
    head = json.loads((tmp_path / "s" / "truth" / "study.json").read_text())
    assert head["world"]["name"] == head["options"]["world"]["name"] == "constant-pressure"
    assert head["chain"]["name"] == "realistic"
    dev = head["chain"]["device"]
    assert 3.0 <= dev["cutoff_hz"] <= 8.0 and all(0.02 <= abs(c) <= 0.05 for c in
                                                 (dev["crosstalk"][0][1], dev["crosstalk"][1][0]))
    z = np.load(next((tmp_path / "s" / "truth").glob("*.npz")), allow_pickle=False)
    assert str(z["world"]) == "constant-pressure" and str(z["chain"]) == "realistic"
    for key in ("mu_trial", "p0_trial", "p1_trial", "F_N_target", "sensor_poles_hz", "sensor_crosstalk"):
        assert key in z.files
    # the normal force on the plate is the command plus the participant's coupling to the relief
    assert not np.array_equal(z["F_N"], z["F_N_command"])


@pytest.mark.slow
def test_ideal_chain_videos_do_not_depend_on_the_world(tmp_path):
    """The world changes the forces only: kinematics, video and sensor noise are the same."""
    out = {}
    for w in ("load-sharing", "interlocking"):
        simulate_study(tmp_path / w, tiny_options(world=w), workers=1)
        out[w] = next((tmp_path / w / "trials").glob("*/video.mkv")).read_bytes()
    assert out["load-sharing"] == out["interlocking"]
