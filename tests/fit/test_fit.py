"""Tests of fingerfriction.fit: NMSE definitions, recovery of p0, p1, mu, NM vs lstsq."""

import math

import numpy as np
import pytest

from fingerfriction.fit import (
    FitOptions,
    Trial,
    fit_subject,
    fit_trial,
    fit_trials,
    flat_detrend,
    flat_segment_mask,
    median_filter,
    mu_grid,
    nmse,
    nmse_eq5,
)
from fingerfriction.model import FrictionModel
from fingerfriction.surfaces import SURFACE_NAMES, get_surface
from fingerfriction.testing import synthetic_trial

X = np.arange(-13.0, 13.0 + 1e-9, 0.01)  # the paper's 26 mm window at 0.01 mm: 2601 positions


def _walk(rng, n, sd, corr):
    w = rng.normal(size=n + 6 * corr)
    k = np.exp(-0.5 * (np.arange(-3 * corr, 3 * corr + 1) / corr) ** 2)
    return sd * np.convolve(w, k / np.sqrt(np.sum(k**2)), mode="valid")[:n]


def changing_regions(rng, n=X.size):
    """A finger-like contact that changes every frame: a ~8 mm window whose length
    wanders (normal force) with +-0.02 mm end jitter (pixelation), split in two by a
    random gap in 30 % of the frames."""
    hl = np.clip(4.0 + _walk(rng, n, 1.0, 60), 2.5, None)
    a = X - hl + rng.uniform(-0.02, 0.02, n)
    b = X + hl + rng.uniform(-0.02, 0.02, n)
    reg = np.full((n, 2, 2), np.nan)
    reg[:, 0, 0], reg[:, 0, 1] = a, b
    split = rng.random(n) < 0.3
    g0 = rng.uniform(a + 0.5, b - 1.0)
    g1 = g0 + rng.uniform(0.1, 0.5, n)
    reg[split, 0, 1] = g0[split]
    reg[split, 1, 0] = g1[split]
    reg[split, 1, 1] = b[split]
    return reg


def eq4_trial(rng, name, mu, p0, p1, noise=0.1, subject="S1"):
    """Eq. (4) forces + white noise (sd = noise x std of the clean force), drift-corrected."""
    s = get_surface(name)
    reg = changing_regions(rng)
    f = FrictionModel(s).basis(reg, mu) @ [p0, p1]
    f = f + rng.normal(scale=noise * f.std(), size=f.size)
    f = flat_detrend(X, f, flat_segment_mask(reg, s))
    return Trial(X, f, reg, s, subject=subject)


def make_subject(seed, noise=0.1, mu=0.55, n_per_surface=4):
    rng = np.random.default_rng(seed)
    trials, truth = [], []
    for name in SURFACE_NAMES * n_per_surface:
        p0, p1 = 0.1 * math.exp(0.2 * rng.normal()), 1.0 * math.exp(0.2 * rng.normal())
        trials.append(eq4_trial(rng, name, mu, p0, p1, noise))
        truth.append((p0, p1))
    return trials, np.array(truth)


# ---------------------------------------------------------------- NMSE definitions


def test_nmse_hand_values():
    f = np.array([0.0, 1.0, 2.0, 3.0])
    g = np.array([0.0, 1.0, 2.0, 5.0])
    # conventional: ||g - f||^2 / ||f - mean f||^2 = 4 / 5
    assert nmse(f, g) == pytest.approx(4 / 5)
    # Eq. 5: ||g - f|| / ||g - mean g||, mean g = 2 -> sqrt(4) / sqrt(4 + 1 + 0 + 9)
    assert nmse_eq5(f, g) == pytest.approx(2 / math.sqrt(14))
    assert nmse_eq5(f, np.full(4, 1.0)) == math.inf  # flat model: Eq. 5 undefined
    assert nmse(f, f) == 0.0


def test_nmse_bad_input_named():
    with pytest.raises(ValueError, match=r"same length, got 3 and 4"):
        nmse([1, 2, 3], [1, 2, 3, 4])
    with pytest.raises(ValueError, match=r"measured has a non-finite value nan at index 1"):
        nmse_eq5([1, np.nan, 3], [1, 2, 3])


# ---------------------------------------------------------------- recovery (acceptance)


def test_exact_recovery_without_noise():
    trials, truth = make_subject(7, noise=0.0)
    r = fit_subject(trials, options=FitOptions(median_kernel=1))
    assert r.success, r.message
    assert r.mu == pytest.approx(0.55, abs=1e-12)
    est = np.array([(t.p0, t.p1) for t in r.trials])
    np.testing.assert_allclose(est, truth, rtol=1e-6)


def test_recovers_p0_p1_mu_within_2_percent_with_10_percent_noise():
    """Eq. 4 forces, 10 % white noise, contact regions changing frame to frame, 24 trials.

    mu within 2 % both as the grid value (0.30..0.90 by 0.01) and refined; p0 and p1
    within 2 % as the mean and the median relative error over the trials. Single trials
    scatter more at this noise level (measured up to ~9 % for p0 over 12 seeds): that is
    the noise limit of one 2601-sample trial, not a bias, so they are bounded at 10 %.
    Over seeds 0..11 of this fixture every assertion holds (see the report)."""
    trials, truth = make_subject(2)
    grid_only = fit_subject(trials, options=FitOptions(median_kernel=1))
    assert grid_only.success, grid_only.message
    assert abs(grid_only.mu - 0.55) / 0.55 <= 0.02
    r = fit_subject(trials, options=FitOptions(median_kernel=1), refine=True)
    assert r.success, r.message
    assert abs(r.mu - 0.55) / 0.55 <= 0.02
    assert abs(r.mu - grid_only.mu) <= 0.01
    est = np.array([(t.p0, t.p1) for t in r.trials])
    rel = est / truth - 1
    assert np.all(np.abs(rel.mean(axis=0)) < 0.02), rel
    assert np.all(np.median(np.abs(rel), axis=0) < 0.02), rel
    assert np.all(np.abs(rel) < 0.10), rel
    assert all(t.success for t in r.trials)


@pytest.mark.slow
def test_two_subjects_each_get_their_mu():
    t1, _ = make_subject(3, mu=0.55)
    t2, _ = make_subject(4, mu=0.60)
    t2 = [Trial(t.x, t.force, t.regions, t.surface, subject="S2") for t in t2]
    res = fit_trials(t1 + t2, options=FitOptions(median_kernel=1))
    assert set(res) == {"S1", "S2"}
    assert abs(res["S1"].mu - 0.55) <= 0.011
    assert abs(res["S2"].mu - 0.60) <= 0.012
    assert res["S1"].curve.shape == (61,)


# ---------------------------------------------------------------- NM vs lstsq


@pytest.mark.slow
def test_nelder_mead_agrees_with_lstsq_when_model_is_linear():
    """median_on='basis' (default): both minimise the same quadratic; they agree to ~1e-7."""
    trials, _ = make_subject(5)
    for kernel in (1, 11):
        opt = FitOptions(median_kernel=kernel)
        for t in trials[:6]:
            a = fit_trial(t, 0.55, method="lstsq", options=opt)
            b = fit_trial(t, 0.55, method="nelder-mead", options=opt)
            assert b.success and b.n_iter > 10
            assert b.p0 == pytest.approx(a.p0, rel=1e-5)
            assert b.p1 == pytest.approx(a.p1, rel=1e-5)
            assert b.objective == pytest.approx(a.objective, rel=1e-9)
            assert b.objective >= a.objective * (1 - 1e-12)  # lstsq is the true minimum


def test_median_on_estimate_nm_vs_lstsq_difference_is_small():
    """Literal reading (filter the combined estimate): lstsq's filtered-basis solution is an
    approximation; NM minimises the exact objective, so NM's objective is never worse and
    the parameters differ by under 1 % on these trials (measured: p0 <= 0.01 %, p1 <= 0.5 %;
    up to 1.5 % for p1 on a 2 mm Step Down, where p1 is weakly determined)."""
    rng = np.random.default_rng(11)
    opt = FitOptions(median_kernel=11, median_on="estimate")
    for name in ("bump-2mm", "step-up-4mm"):
        t = synthetic_trial(name, mu=0.55, p0=0.1, p1=0.3, rng=rng)
        a = fit_trial(t, 0.55, method="lstsq", options=opt)
        b = fit_trial(t, 0.55, method="nelder-mead", options=opt)
        assert b.success
        assert b.objective <= a.objective * (1 + 1e-9)
        assert abs(b.p0 / a.p0 - 1) < 0.01 and abs(b.p1 / a.p1 - 1) < 0.01


@pytest.mark.slow
def test_eq5_objective_inflates_the_model_under_noise():
    """Eq. 5 normalises by the model's own variance: its minimiser is a larger model than
    least squares'. Without noise both are exact; with 10 % noise Eq. 5 fits come out
    larger on average, roughly by 1/r^2 = 1 / (1 - NMSE)."""
    clean, truth = make_subject(8, noise=0.0)
    noisy, _ = make_subject(8, noise=0.1)
    eq5 = FitOptions(median_kernel=1, objective="nmse_eq5")
    conv = FitOptions(median_kernel=1)
    b = fit_trial(clean[0], 0.55, method="nelder-mead", options=eq5)
    assert b.p0 == pytest.approx(truth[0, 0], rel=1e-5)
    ratios, predicted = [], []
    for t in noisy:
        a = fit_trial(t, 0.55, options=conv)
        b = fit_trial(t, 0.55, method="nelder-mead", options=eq5)
        assert b.success
        ratios.append((b.p0 / a.p0 + b.p1 / a.p1) / 2)
        predicted.append(1 / (1 - a.objective))
    ratios = np.array(ratios)
    assert np.all(ratios > 1.0)
    np.testing.assert_allclose(ratios, predicted, atol=0.01)


# ---------------------------------------------------------------- failures and validation


def test_failed_fits_say_so():
    rng = np.random.default_rng(0)
    s = get_surface("bump-2mm")
    # Contact never leaves the flat ground: p1 is not identifiable.
    reg = np.stack([X - 30 - 4, X - 30 + 4], axis=-1)[:, None, :]
    reg[:, 0, 1] += rng.uniform(0, 0.5, X.size)
    t = Trial(X, rng.normal(size=X.size) * 1e-3, reg, s)
    r = fit_trial(t, 0.5)
    assert not r.success and "not separately identifiable" in r.message
    # Minimum at the end of the grid is reported, not hidden.
    trials, _ = make_subject(1, noise=0.0)
    sf = fit_subject(trials[:3], grid=mu_grid(0.30, 0.40, 0.01), options=FitOptions(median_kernel=1))
    assert not sf.success and "end of the grid" in sf.message


def test_trial_validation_names_argument_and_value():
    s = "bump-2mm"
    reg = np.stack([X - 4, X + 4], axis=-1)[:, None, :]
    f = np.zeros(X.size)
    fnan = f.copy()
    fnan[5] = np.nan
    with pytest.raises(ValueError, match=r"Trial.force has a non-finite value nan at index 5"):
        Trial(X, fnan, reg, s)
    with pytest.raises(ValueError, match=r"Trial.force must have one value per position: got shape \(10,\)"):
        Trial(X, f[:10], reg, s)
    with pytest.raises(ValueError, match=r"Trial.regions must have one frame per position: got 3 frames"):
        Trial(X, f, reg[:3], s)
    with pytest.raises(ValueError, match=r"Trial.regions is empty"):
        Trial(X, f, np.full((X.size, 1, 2), np.nan), s)
    bad = reg.copy()
    bad[7, 0] = (1.0, 0.5)
    msg = r"Trial.regions: frame 7, region 0 is inverted: \[a, b\] = \[1.0, 0.5\]"
    with pytest.raises(ValueError, match=msg):
        Trial(X, f, bad, s)
    with pytest.raises(ValueError, match=r"unknown surface 'bump-5mm'"):
        Trial(X, f, reg, "bump-5mm")
    with pytest.raises(ValueError, match=r"median kernel must be an odd positive integer \(samples\), got 4"):
        FitOptions(median_kernel=4)
    with pytest.raises(ValueError, match=r"objective must be one of .* got 'mse'"):
        FitOptions(objective="mse")
    t = Trial(X, f, reg, s)
    with pytest.raises(ValueError, match=r"objective='nmse_eq5' has no closed form"):
        fit_trial(t, 0.5, options=FitOptions(objective="nmse_eq5"))
    with pytest.raises(ValueError, match=r"method must be one of .* got 'bfgs'"):
        fit_trial(t, 0.5, method="bfgs")


def test_flat_segment_comes_from_contact_regions():
    s = get_surface("step-up-4mm")  # feature starts at -2 mm
    reg = np.array([[[-9.0, -3.0]], [[-8.0, -2.0]], [[-7.0, -1.9]], [[-6.5, -4.0]]])
    np.testing.assert_array_equal(flat_segment_mask(reg, s), [True, True, False, True])
    np.testing.assert_array_equal(flat_segment_mask(reg, s, margin=0.5), [True, False, False, True])
    # With the finger centre 4 mm behind the contact front, the segment ends at x = -6.
    reg = np.stack([X - 4, X + 4], axis=-1)[:, None, :]
    m = flat_segment_mask(reg, s)
    assert X[m].max() == pytest.approx(-6.0)


def test_flat_detrend_removes_line_exactly_and_median_filter_keeps_ramps():
    x = np.linspace(0, 10, 101)
    y = 0.3 + 0.02 * x + np.where(x > 5, 1.0, 0.0)
    out = flat_detrend(x, y, x < 4)
    np.testing.assert_allclose(out, np.where(x > 5, 1.0, 0.0), atol=1e-12)
    np.testing.assert_allclose(median_filter(x, 11), x)  # monotone input is unchanged
    spike = np.zeros(20)
    spike[10] = 5
    assert median_filter(spike, 3).max() == 0.0
    with pytest.raises(ValueError, match="at least 2 are needed"):
        flat_detrend(x, y, x < 0)


def test_absolute_forces_recover_every_trial_within_2_percent():
    """With absolute forces (no drift correction, ``detrend=False``) the flat level
    p0 mu L is data too, so every single trial's p0 and p1 are recovered within 2 % at
    10 % noise, and mu within 2 %. (With the drift-corrected comparison the flat level is
    removed, p0 and p1 become nearly collinear, and only their ensemble meets 2 %: see
    test_recovers_p0_p1_mu_within_2_percent_with_10_percent_noise.)"""
    rng = np.random.default_rng(21)
    trials, truth = [], []
    for name in SURFACE_NAMES * 4:
        p0, p1 = 0.1 * math.exp(0.2 * rng.normal()), 1.0 * math.exp(0.2 * rng.normal())
        s = get_surface(name)
        reg = changing_regions(rng)
        f = FrictionModel(s).basis(reg, 0.55) @ [p0, p1]
        f = f + rng.normal(scale=0.1 * f.std(), size=f.size)
        trials.append(Trial(X, f, reg, s, subject="S1"))
        truth.append((p0, p1))
    opt = FitOptions(median_kernel=1, detrend=False)
    r = fit_subject(trials, options=opt, refine=True)
    assert r.success, r.message
    assert abs(r.mu - 0.55) / 0.55 <= 0.02
    est = np.array([(t.p0, t.p1) for t in r.trials])
    rel = np.abs(est / np.array(truth) - 1)
    assert np.all(rel < 0.02), rel.max(axis=0)


# Reference values of the paper variant as the code computed them before the fit became a
# package with the load-consistent default (commit d1c8df8, src/fingerfriction/fit.py):
# the same 12 synthetic trials fitted there and here. Their mu (0.88 and 0.45 for true
# 0.55 and 0.60) shows Eq. (4)'s twin (mu, p0, p1) ~ (p0/p1, p1 mu, p1) on the flat footing.
_OLD_PAPER = {
    "S1": (0.88, [(0.08395836, 0.18191245), (0.0634742, 0.26175868), (0.06821485, 0.26233582),
                  (0.06430683, 0.25247723), (0.08504522, 0.37233285), (0.05777151, 0.19223266)]),
    "S2": (0.45, [(0.18482664, 0.12202464), (0.10818408, 0.34940708), (0.13260594, 0.37266905),
                  (0.14501085, 0.26664093), (0.13896576, 0.28321761), (0.13929775, 0.33032959)]),
}


@pytest.mark.parametrize("method,tol", [("lstsq", 1e-7),
                                        pytest.param("nelder-mead", 5e-6, marks=pytest.mark.slow)])
def test_paper_variant_reproduces_the_earlier_code(method, tol):
    from fingerfriction.testing import synthetic_trials

    trials, _ = synthetic_trials(speeds=(80,), reps=1, seed=3, noise=0.1, step=0.05)
    fits = fit_trials(trials, method=method)
    assert sorted(fits) == sorted(_OLD_PAPER)
    for s, (mu, pairs) in _OLD_PAPER.items():
        f = fits[s]
        assert f.mu == pytest.approx(mu, abs=1e-12)
        got = np.array([(t.p0, t.p1) for t in f.trials])
        np.testing.assert_allclose(got, np.array(pairs), rtol=0, atol=tol)
