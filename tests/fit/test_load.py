"""Tests of fingerfriction.fit.load: the load-consistent fit (flat-ground mu with its
confidence interval, the load-bearing inset, p1 per trial with a standard error, flags)."""

import math

import numpy as np
import pytest

from fingerfriction.fit import (
    FitFlag,
    LoadFitOptions,
    Trial,
    fit_load_subject,
    fit_load_trials,
    flat_ground_mu,
)
from fingerfriction.fit.weights import hac_se
from fingerfriction.surfaces import SURFACE_NAMES
from fingerfriction.testing import synthetic_trial

X = np.arange(-13.0, 13.0 + 1e-9, 0.01)


#: The synthetic fixture's rigid pad is not force-controlled: its normal force follows the
#: contact length down to zero, so no position is left out for a low load; and its forces
#: are not median-filtered, so the fit's filter is switched off.
FIXTURE = {"min_load": 0.0, "median_kernel": 1}


def _study(seed=0, *, mu=0.55, p0=0.03, p1=0.2, noise=0.1, inset=0.0, reps=2, subject="S1"):
    """Eq. (4) trials on the absolute footing with a known (mu, p0, p1) on every surface."""
    rng = np.random.default_rng(seed)
    return [synthetic_trial(s, mu=mu, p0=p0, p1=p1, rng=rng, noise=noise, absolute=True, inset=inset,
                            subject=subject, labels={"trial": f"{subject}-{s}-{r}"})
            for s in SURFACE_NAMES for r in range(reps)]


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_recovers_mu_p0_p1_within_2_percent_at_10_percent_noise(seed):
    """Synthetic Eq. (4) data in absolute form, 10 % noise on F_T and on F_N (F_N from the
    same constant pressure): the load-consistent model reduces to Eq. (4), so every
    parameter comes back: mu (with its CI) and every trial's p0 within 2 %, p1 within 2 %
    as the mean and median over the trials (single trials scatter up to ~5 % at this noise,
    as the paper variant's do, see tests/fit/test_fit.py)."""
    trials = _study(seed)
    fit = fit_load_subject(trials, LoadFitOptions(inset=0.0, kappa=0.0, **FIXTURE))
    # the fixture's rigid pad unloads to a few mN on a bump top, where 10 % noise makes F_N
    # negative at some positions: flagged (a negative pressure), the only error allowed here
    assert {f.code for f in fit.flags if f.level == "error"} <= {"negative-pressure"}
    assert fit.mu == pytest.approx(0.55, rel=0.02)
    lo, hi = fit.mu_ci
    assert lo <= 0.55 <= hi
    rel = np.array([t.p1 for t in fit.trials]) / 0.2 - 1
    assert abs(rel.mean()) < 0.02 and np.median(np.abs(rel)) < 0.02
    assert np.all(np.abs(rel) < 0.10)
    for tf in fit.trials:
        assert tf.p0_mean == pytest.approx(0.03, rel=0.02)
        assert tf.footing == "absolute" and tf.used.all()


@pytest.mark.slow
def test_fitted_inset_finds_the_load_bearing_contact():
    """Forces made on the regions inset by 0.3 mm, trials carrying the regions as seen:
    exact without noise; with 5 % noise on F_T and 1 % on F_N within 0.05 mm (noise in F_N
    enters the model through the pressure and pulls the inset up: errors in variables)."""
    exact = fit_load_subject(_study(2, inset=0.3, noise=0.0), LoadFitOptions(kappa=0.0, **FIXTURE))
    assert exact.inset == pytest.approx(0.3, abs=2e-3)
    rng = np.random.default_rng(2)
    trials = [synthetic_trial(s, mu=0.55, p0=0.03, p1=0.2, rng=rng, noise=0.05, noise_normal=0.01,
                              absolute=True, inset=0.3, labels={"trial": f"{s}-{r}"})
              for s in SURFACE_NAMES for r in range(2)]
    fit = fit_load_subject(trials, LoadFitOptions(kappa=0.0, **FIXTURE))
    assert fit.fitted == ("inset",)
    assert fit.inset == pytest.approx(0.3, abs=0.05)
    assert np.median([t.p1 for t in fit.trials]) == pytest.approx(0.2, rel=0.15)
    # without the inset the same data fit worse
    fit0 = fit_load_subject(trials, LoadFitOptions(inset=0.0, kappa=0.0, **FIXTURE))
    def rss(f):
        return sum(float(np.nansum((t.measured - t.estimate) ** 2)) for t in f.trials)

    assert rss(fit) < 0.7 * rss(fit0)


def _force_controlled_study(seed, *, mu=0.6, p1=0.05, inset=0.35, kappa=3.0, reps=2):
    """Trials made by the load-consistent model itself: a finger pressing with 0.3 N
    (+-15 mN of slow wander) whose regions come from the synthetic rigid pad, F_T from
    LoadParams(mu, p1, inset, kappa) plus 1 % noise; the trials carry the regions as seen."""
    from fingerfriction.model import FrictionModel, LoadParams
    from fingerfriction.surfaces import get_surface
    from fingerfriction.testing import _smooth_walk, finger_contact_regions

    rng = np.random.default_rng(seed)
    out = []
    for name in SURFACE_NAMES:
        s = get_surface(name)
        for r in range(reps):
            delta = np.clip(0.05 + _smooth_walk(rng, X.size, 0.03, 60), 0.01, None)
            regions = finger_contact_regions(s, X, delta)
            fn = 0.3 + _smooth_walk(rng, X.size, 0.015, 80)
            f = FrictionModel(s).load_forces(regions, fn, LoadParams(mu, p1, inset, kappa)).total
            ok = np.isfinite(f)
            if not ok.all():  # positions with no load-bearing contact: keep the others
                f = np.interp(X, X[ok], f[ok])
            ft = f + 0.01 * np.std(f) * rng.normal(size=X.size)
            fnm = fn + 0.001 * rng.normal(size=X.size)
            out.append(Trial(x=X, force=ft - ft.mean(), regions=regions, surface=s, subject="1",
                             labels={"trial": f"{name}-{r}"}, force_abs=ft, normal_abs=fnm))
    return out


@pytest.mark.slow
def test_force_controlled_finger_recovers_the_load_bearing_contact_and_kappa():
    """Data made by the load-consistent model with known (mu, delta, kappa, p1): the fit
    finds them back (delta and kappa are the finger's, fitted per subject)."""
    fit = fit_load_subject(_force_controlled_study(10), LoadFitOptions(median_kernel=1))
    assert fit.fitted == ("inset", "kappa")
    assert fit.mu == pytest.approx(0.6, rel=0.01)
    assert fit.inset == pytest.approx(0.35, abs=0.03)
    assert fit.kappa == pytest.approx(3.0, abs=0.3)
    assert np.median([t.p1 for t in fit.trials]) == pytest.approx(0.05, rel=0.05)


def _flat_trials(rng, mu_k, *, lam=0.6, amp=0.004, noise=2e-4):
    """Trials on flat ground only: F_N = 0.3 N, F_T = mu_k F_N (1 + amp exp(-u / lam)) + noise."""
    out = []
    for k, m in enumerate(mu_k):
        x = np.arange(-13.0, -3.0, 0.01)
        fn = 0.3 + 0.005 * rng.normal(size=x.size)
        ft = m * fn * (1 + amp * np.exp(-(x - x[0]) / lam)) + noise * rng.normal(size=x.size)
        regions = np.stack([x - 5.0, x + 5.0], axis=1)[:, None, :]  # all before a bump at 0
        out.append(Trial(x=x, force=ft - ft.mean(), regions=regions, surface="bump-4mm", subject="1",
                         labels={"trial": f"t{k}"}, force_abs=ft, normal_abs=fn))
    return out


def test_flat_ground_mu_models_the_start_transient():
    rng = np.random.default_rng(3)
    trials = _flat_trials(rng, np.full(30, 0.55))
    res = flat_ground_mu(trials)
    assert res.transient_mm == pytest.approx(0.6, rel=0.15)
    assert res.ci[0] <= 0.55 <= res.ci[1]
    assert res.mu == pytest.approx(0.55, rel=2e-4)
    plain = flat_ground_mu(trials, transient=False)
    assert math.isnan(plain.transient_mm)
    assert not plain.ci[0] <= 0.55 <= plain.ci[1]  # the transient biases the plain ratio up
    assert plain.mu > 0.55
    # the same seed gives the same interval
    assert flat_ground_mu(trials).ci == res.ci


def test_flat_ground_mu_ci_covers_trial_to_trial_scatter():
    rng = np.random.default_rng(4)
    mu_k = 0.6 * (1 + 0.1 * rng.normal(size=40))
    res = flat_ground_mu(_flat_trials(rng, mu_k, amp=0.0))
    assert res.ci[0] <= mu_k.mean() <= res.ci[1]
    assert res.se == pytest.approx(np.std(mu_k, ddof=1) / math.sqrt(40), rel=0.15)
    assert set(res.mu_trials) == {f"t{k}" for k in range(40)}


@pytest.mark.slow
def test_flat_ground_mu_without_a_transient_neither_models_nor_flags_one():
    """No start transient in the data: the residual is flat in lambda, whose minimum can
    fall on the bound; the term is dropped (the trials do not agree on an amplitude) and
    nothing is flagged, while a real transient is kept."""
    for seed in range(4):
        rng = np.random.default_rng(10 + seed)
        res = flat_ground_mu(_flat_trials(rng, np.full(30, 0.55), amp=0.0))
        assert math.isnan(res.transient_mm)
        assert not [f for f in res.flags if f.code == "transient-at-bound"]
        assert res.ci[0] <= 0.55 <= res.ci[1]
    with_transient = flat_ground_mu(_flat_trials(np.random.default_rng(3), np.full(30, 0.55)))
    assert math.isfinite(with_transient.transient_mm)


def test_hac_standard_error_matches_the_scatter_of_p1():
    """White noise: the Newey-West SE agrees with the spread of p1 over noise draws."""
    rng = np.random.default_rng(5)
    b = np.sin(np.linspace(0, 6, 2000)) + 0.5
    p1s, ses = [], []
    for _ in range(300):
        y = 0.2 * b + 0.05 * rng.normal(size=b.size)
        p1 = float(b @ y / (b @ b))
        p1s.append(p1)
        ses.append(hac_se(b, y - p1 * b, 20))
    assert np.mean(ses) == pytest.approx(np.std(p1s), rel=0.15)


@pytest.mark.slow
def test_unphysical_and_fallback_fits_are_flagged_not_silent():
    trials = _study(6, p1=-0.1, reps=1)
    fit = fit_load_subject(trials, LoadFitOptions(inset=0.0, kappa=0.0, **FIXTURE))
    assert not fit.success
    assert "6 of 6 trial fits failed or unphysical" in fit.message
    codes = {f.code for f in fit.flags}
    assert "negative-p1" in codes
    assert all(isinstance(f, FitFlag) and f.model == "load" for f in fit.flags)
    # a trial without absolute forces: fitted on the paper's footing with the nominal load, flagged
    good = _study(7, reps=1)
    t0 = good[0]
    bare = Trial(x=t0.x, force=t0.force, regions=t0.regions, surface=t0.surface, subject=t0.subject,
                 labels={"trial": "bare"})
    fit = fit_load_subject([*good, bare], LoadFitOptions(inset=0.0, kappa=0.0, **FIXTURE))
    tf = fit.trials[-1]
    assert tf.footing == "flat"  # (its p1 is not asserted: the fixture's load is far from the nominal)
    assert tf.flags[0].code == "no-absolute"
    assert np.isfinite(tf.estimate[tf.used]).all()
    assert "bare" not in fit.flat.mu_trials
    # no trial with absolute forces at all: mu cannot be measured, said so
    fit = fit_load_subject([bare])
    assert not fit.success and math.isnan(fit.mu)
    assert fit.flags[0].code == "mu-unavailable"
    assert "no trial with absolute forces" in fit.message


@pytest.mark.slow
def test_two_subjects_and_option_validation():
    fits = fit_load_trials(_study(8, reps=1, subject="S1") + _study(9, reps=1, mu=0.6, subject="S2"),
                           LoadFitOptions(inset=0.0, kappa=0.0, **FIXTURE))
    assert fits["S1"].mu == pytest.approx(0.55, rel=0.02)
    assert fits["S2"].mu == pytest.approx(0.60, rel=0.02)
    with pytest.raises(ValueError, match="inset must be 'fit' or a length >= 0 in mm, got -1"):
        LoadFitOptions(inset=-1)
    with pytest.raises(ValueError, match="mu_per must be one of"):
        LoadFitOptions(mu_per="trialwise")
    with pytest.raises(ValueError, match="n_boot must be an integer >= 100, got 10"):
        LoadFitOptions(n_boot=10)
    with pytest.raises(ValueError, match="fit_load_subject needs trials of one subject"):
        fit_load_subject(_study(8, reps=1, subject="S1") + _study(9, reps=1, subject="S2"))
    with pytest.raises(ValueError, match="Trial.force_abs and Trial.normal_abs go together"):
        Trial(x=X, force=np.zeros(X.size), regions=np.tile([[-5.0, 5.0]], (X.size, 1, 1)), surface="bump-2mm",
              force_abs=np.zeros(X.size))


@pytest.mark.slow
def test_each_trial_uses_its_own_flat_ground_mu_by_default():
    """Friction that varies from trial to trial (10 % SD): with the trial's own flat-ground
    mu (the default) every p1 comes back; with the subject's mean the friction error on
    the slopes is pushed into p1."""
    rng = np.random.default_rng(7)
    trials = []
    for s in SURFACE_NAMES:
        for r in range(3):
            mu = 0.55 * (1 + 0.1 * rng.normal())
            trials.append(synthetic_trial(s, mu=mu, p0=0.03, p1=0.2, rng=rng, noise=0.02, absolute=True,
                                          labels={"trial": f"S1-{s}-{r}"}))
    fixed = {"inset": 0.0, "kappa": 0.0, **FIXTURE}
    assert LoadFitOptions().mu_per == "trial"
    own = fit_load_subject(trials, LoadFitOptions(**fixed))
    mean = fit_load_subject(trials, LoadFitOptions(mu_per="subject", **fixed))
    err_own = np.array([t.p1 / 0.2 - 1 for t in own.trials])
    err_mean = np.array([t.p1 / 0.2 - 1 for t in mean.trials])
    assert np.median(np.abs(err_own)) < 0.02
    assert np.median(np.abs(err_mean)) > 3 * np.median(np.abs(err_own))
    assert [t.mu for t in own.trials] == pytest.approx([own.flat.mu_trials[t.id] for t in trials])


@pytest.mark.slow
def test_a_trial_with_the_wrong_force_sign_is_flagged_and_left_out_of_mu():
    trials = _study(0, noise=0.02)
    bad = trials[3]
    flipped = Trial(x=bad.x, force=-bad.force, regions=bad.regions, surface=bad.surface, subject=bad.subject,
                    labels=dict(bad.labels), force_abs=-bad.force_abs, normal_abs=bad.normal_abs)
    trials[3] = flipped
    fit = fit_load_subject(trials, LoadFitOptions(inset=0.0, kappa=0.0, **FIXTURE))
    flags = [f for f in fit.flags if f.code == "negative-mu"]
    assert len(flags) == 1 and flags[0].trial == flipped.id and flags[0].level == "error"
    assert "wrong sign" in flags[0].message
    assert flipped.id not in fit.flat.mu_trials
    assert fit.mu == pytest.approx(0.55, rel=0.01)
    assert not fit.trials[3].success and not fit.success
    # the others as without the flipped trial (the fixture's bump tops unload to ~0 N, where
    # noise makes F_N negative: flagged negative-pressure, see the 10 % noise test)
    clean = fit_load_subject(_study(0, noise=0.02), LoadFitOptions(inset=0.0, kappa=0.0, **FIXTURE))
    assert [t.success for i, t in enumerate(fit.trials) if i != 3] == \
        [t.success for i, t in enumerate(clean.trials) if i != 3]
    with pytest.raises(ValueError, match="wrong sign"):
        flat_ground_mu([flipped])
