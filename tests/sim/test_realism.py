"""The realism option of the virtual experiment: off by default (the default study is
unchanged), and on it draws friction per trial, lets it fall with load and widens the
normal-force wander."""

import numpy as np
import pytest

from fingerfriction.sim import RealismParams, SimOptions, plan_trial
from fingerfriction.sim.options import realism_rng as _realism_rng
from fingerfriction.sim.options import trial_rngs as _rngs
from fingerfriction.sim.physics import true_forces


def test_default_study_has_no_realism_and_an_unchanged_record():
    opts = SimOptions()
    assert opts.realism is None
    assert "realism" not in opts.to_dict()
    assert SimOptions.from_dict(opts.to_dict()) == opts


def test_realism_round_trips_and_widens_the_force_wander():
    opts = SimOptions(realism=RealismParams())
    d = opts.to_dict()
    assert d["realism"]["mu_sd"] == 0.10
    assert d["kinematics"]["force_sd"] == 0.025 and d["kinematics"]["force_sd_trial"] == 0.025
    assert SimOptions.from_dict(d) == opts
    with pytest.raises(ValueError, match=r"RealismParams.mu_sd must be <= 0.3"):
        RealismParams(mu_sd=0.5)
    with pytest.raises(TypeError, match="realism must be a RealismParams or None, got dict"):
        SimOptions(realism={"mu_sd": 0.1})


@pytest.mark.parametrize(("kw", "message"), [
    ({"mu_sd": -0.1}, "RealismParams.mu_sd must be a standard deviation >= 0 (relative), got -0.1"),
    ({"mu_load_exponent": -1.0}, "RealismParams.mu_load_exponent must be a load exponent >= 0, got -1.0"),
    ({"f_ref_n": 0.0}, "RealismParams.f_ref_n must be a finite positive force in N, got 0.0"),
    ({"force_sd": -0.01}, "RealismParams.force_sd must be a finite standard deviation >= 0 in N, got -0.01"),
])
def test_bad_realism_values_are_one_line(kw, message):
    with pytest.raises(ValueError) as e:
        RealismParams(**kw)
    assert str(e.value) == message


def test_realism_draws_leave_the_other_streams_alone():
    spec = SimOptions(reps=1, subjects=("1",), surfaces=("bump-2mm",), speeds=(80.0,)).trial_specs()[0]
    a = [g.standard_normal(3) for g in _rngs(spec, 4)]
    r = _realism_rng(spec, 4).standard_normal(3)
    b = [g.standard_normal(3) for g in _rngs(spec, 4)]
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(x, y)
    assert not any(np.allclose(r, x) for x in a)
    # the kinematics of a default trial do not depend on the realism stream
    k0 = plan_trial(spec, SimOptions(reps=1, subjects=("1",), surfaces=("bump-2mm",), speeds=(80.0,))).kin
    np.testing.assert_array_equal(k0.x, plan_trial(spec, SimOptions(
        reps=1, subjects=("1",), surfaces=("bump-2mm",), speeds=(80.0,))).kin.x)


def test_trial_mu_scatter_and_load_dependence():
    rp = RealismParams()
    rng = np.random.default_rng(0)
    scales = np.array([rp.trial_mu_scale(rng) for _ in range(4000)])
    assert scales.std() == pytest.approx(0.10, rel=0.05)
    assert scales.min() >= 0.7

    class FlatTable:  # flat ground: int p = int p cos = F_N-normalised, no slope terms
        def interp_integrals(self, x, f):
            n = np.asarray(x).size
            return np.column_stack([np.ones(n), np.zeros(n), np.ones(n), np.zeros(n), np.zeros(n)])

    from fingerfriction.sim import SUBJECT_FORCE_LAWS
    law = SUBJECT_FORCE_LAWS["1"]
    fn = np.array([0.15, 0.3, 0.6])
    far = np.full(3, 50.0)  # far past the start transient
    ft, *_ = true_forces(FlatTable(), law, np.zeros(3), fn, far, 80.0, np.ones(3, bool), mu_scale=1.1,
                         load_exponent=0.2, f_ref_n=0.3)
    mu = ft / fn
    assert mu[1] == pytest.approx(0.55 * 1.1, rel=1e-9)
    # within the paper's "less than 20 % change if the force is doubled or halved"
    assert 1.0 < mu[0] / mu[1] < 1.2 and 0.8 < mu[2] / mu[1] < 1.0
