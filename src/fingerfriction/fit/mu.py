"""Coulomb friction measured on flat ground: ``mu`` per subject for the load-consistent
model (:mod:`fingerfriction.fit.load`, step 1), with a start-transient term and a bootstrap
confidence interval over trials."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from .common import Trial, fit_flag, flat_segment_mask

__all__ = ["FlatGroundMu", "flat_ground_mu"]


@dataclass(frozen=True, eq=False)
class FlatGroundMu:
    """Coulomb friction of one subject measured on flat ground (:func:`flat_ground_mu`).

    Attributes
    ----------
    subject : str
    mu : float
        Mean of the trials' steady-sliding ``mu_k`` (dimensionless).
    ci : (float, float)
        Bootstrap percentile confidence interval of ``mu`` over trials (NaN with < 2 trials).
    se : float
        Bootstrap standard error of ``mu``.
    level : float
        Confidence level of ``ci``.
    mu_trials : dict of str to float
        ``mu_k`` per trial id (trials with too little flat ground are absent).
    transient_mm : float
        Decay length ``lambda`` in mm of the start transient (NaN when not modelled, or
        when the trials do not agree on one).
    flags : tuple of FitFlag
    """

    subject: str
    mu: float
    ci: tuple[float, float]
    se: float
    level: float
    mu_trials: dict
    transient_mm: float
    flags: tuple = ()


def _flat_data(trial: Trial, min_load: float, min_flat_mm: float):
    """(u, F_T, F_N) on a trial's flat segment, u the distance in mm from its start."""
    mask = flat_segment_mask(trial.regions, trial.surface)
    if min_load > 0:
        mask &= trial.normal_abs >= min_load
    if np.count_nonzero(mask) < 3:
        return None
    x = trial.x[mask]
    if float(x[-1] - x[0]) < min_flat_mm:
        return None
    return x - x[0], trial.force_abs[mask], trial.normal_abs[mask]


def _transient_rss(data, lam: float | None) -> tuple[float, np.ndarray, np.ndarray]:
    """Summed residual of ``F_T = F_N (mu_k + A_k exp(-u / lam))`` over trials, the mu_k
    and the A_k (0 without a transient).

    ``(mu_k, A_k)`` solve the moment equations with the instruments ``1`` and
    ``exp(-u / lam)``: ``sum w (F_T - F_N (mu + A e)) = 0``. They do not involve the noise
    of ``F_N``, so the estimate stays unbiased when ``F_N`` is noisy (a pointwise ratio
    ``F_T / F_N``, or least squares on ``F_N``, would not). Without a transient
    (``lam=None``) ``mu_k`` is the ratio of sums ``sum F_T / sum F_N``.
    """
    total, mus, amps = 0.0, np.empty(len(data)), np.zeros(len(data))
    for k, (u, ft, fn) in enumerate(data):
        if lam is not None:
            e = np.exp(-u / lam)
            a11, a12 = fn.sum(), fn @ e
            a21, a22 = e @ fn, (fn * e) @ e
            det = a11 * a22 - a12 * a21
            if abs(det) > 1e-9 * abs(a11 * a22):
                r1, r2 = ft.sum(), e @ ft
                mu = (a22 * r1 - a12 * r2) / det
                amp = (a11 * r2 - a21 * r1) / det
                mus[k], amps[k] = mu, amp
                total += float(np.sum((ft - fn * (mu + amp * e)) ** 2))
                continue
        mus[k] = ft.sum() / fn.sum()
        total += float(np.sum((ft - fn * mus[k]) ** 2))
    return total, mus, amps


def _t_statistic(v: np.ndarray) -> float:
    """Mean over its standard error (NaN with fewer than 3 values or no scatter)."""
    if v.size < 3:
        return math.nan
    sd = float(np.std(v, ddof=1))
    return float(np.mean(v)) / (sd / math.sqrt(v.size)) if sd > 0 else math.nan


def _flat_segments(trials, subject: str, min_load: float, min_flat_mm: float, model: str = "load"):
    """``(data, ids, flags)``: each usable trial's flat segment ``(u, F_T, F_N)``; trials
    with too little flat ground or a wrong-signed force are flagged and left out."""
    data, ids, flags = [], [], []
    for t in trials:
        d = _flat_data(t, min_load, min_flat_mm)
        if d is None:
            flags.append(fit_flag("warning", "short-flat", subject, t.id, model,
                                 f"less than {min_flat_mm:g} mm of flat ground before the feature: "
                                 "the trial takes no part in mu"))
            continue
        ratio = float(d[1].sum() / d[2].sum())
        if not ratio > 0:
            flags.append(fit_flag("error", "negative-mu", subject, t.id, model,
                                 f"flat-ground friction ratio F_T / F_N = {ratio:.3g} <= 0: the tangential "
                                 "force has the wrong sign (sensor axis or sliding direction?); the trial "
                                 "takes no part in mu"))
            continue
        data.append(d)
        ids.append(t.id)
    if not data and any(f.code == "negative-mu" for f in flags):
        raise ValueError(f"subject {subject}: every trial's flat-ground F_T / F_N is <= 0 (the tangential "
                         "force has the wrong sign): mu cannot be measured")
    if not data:
        raise ValueError(f"subject {subject}: no trial has {min_flat_mm:g} mm of flat ground with "
                         "absolute forces before the feature: mu cannot be measured")
    return data, ids, flags


def _fit_transient(data, hi: float) -> tuple[float, np.ndarray, bool]:
    """``(lambda, mu_k, at_bound)`` of the start-transient model (``lambda`` NaN when the
    trials do not agree on a transient; ``at_bound``: a kept transient at ``hi`` mm)."""
    grid = np.geomspace(0.05, hi, 40)
    rss = np.array([_transient_rss(data, g)[0] for g in grid])
    j = int(np.argmin(rss))
    lo_b, hi_b = grid[max(j - 1, 0)], grid[min(j + 1, grid.size - 1)]
    res = optimize.minimize_scalar(lambda g: _transient_rss(data, g)[0], bounds=(lo_b, hi_b),
                                   method="bounded", options={"xatol": 1e-3})
    lam = float(res.x)
    _, mus, amps = _transient_rss(data, lam)
    # The transient is kept only where the trials agree on it: its amplitude's mean over
    # the trials at least 3 standard errors (trials are independent, positions are not)
    # from 0. On data without one the residual is flat in lambda, its minimum falls
    # anywhere, the bound included, and the term only adds scatter to the mu_k.
    if not _t_statistic(amps) > 3.0:
        return math.nan, _transient_rss(data, None)[1], False
    return lam, mus, j == grid.size - 1


def flat_ground_mu(trials: Sequence[Trial], *, transient: bool = True, transient_max_mm: float = 3.0,
                   min_load: float = 0.05, min_flat_mm: float = 1.0, n_boot: int = 2000, seed: int = 0,
                   level: float = 0.95, model: str = "load") -> FlatGroundMu:
    """Coulomb friction of one subject from the flat ground before the feature.

    Parameters
    ----------
    trials : sequence of Trial
        One subject's trials with absolute forces (others are ignored).
    transient : bool
        Model a static-to-sliding transient at the start of the flat segment (Notes).
    transient_max_mm : float
        Upper bound in mm of the transient's decay length.
    min_load : float
        Positions with a measured ``F_N`` below this (N) are left out; 0 keeps them all.
    min_flat_mm : float
        Least flat-ground travel in mm for a trial to take part.
    n_boot : int
        Bootstrap resamples of the confidence interval.
    seed : int
        Seed of the bootstrap's ``numpy.random.Generator``.
    level : float
        Confidence level.
    model : str
        The model variant the flags are raised for (every variant on the absolute footing
        measures ``mu`` here).

    Returns
    -------
    FlatGroundMu

    Raises
    ------
    ValueError
        Trials of several subjects, or no trial with absolute forces and enough flat
        ground (the message says which).

    Notes
    -----
    Per trial, over the flat segment (every contact region before the feature and
    ``F_N >= min_load``), ``F_T = F_N (mu_k + A_k exp(-u / lambda))`` with one ``lambda``
    for the subject; the transient is kept only when the trials agree on it (mean ``A_k``
    at least 3 standard errors from 0), else ``mu_k = sum F_T / sum F_N``. ``mu`` is the
    mean of the ``mu_k``, its CI the percentile interval of ``n_boot`` bootstrap means over
    trials. Details and measurements: ``docs/fit.md``.
    """
    trials = [t for t in trials if t.has_absolute]
    subjects = sorted({t.subject for t in trials})
    if len(subjects) > 1:
        raise ValueError(f"flat_ground_mu needs trials of one subject, got subjects {subjects}")
    if not trials:
        raise ValueError("no trial with absolute forces: mu cannot be measured on flat ground "
                         "(fit the paper's model instead)")
    subject = subjects[0]
    data, ids, flags = _flat_segments(trials, subject, min_load, min_flat_mm, model)
    if transient:
        lam, mus, at_bound = _fit_transient(data, float(transient_max_mm))
        if at_bound:
            flags.append(fit_flag("warning", "transient-at-bound", subject, "", model,
                                 f"the start transient's decay length reached its bound "
                                 f"{transient_max_mm:g} mm: the flat-ground ratio drifts over the whole "
                                 "flat segment"))
    else:
        lam, mus = math.nan, _transient_rss(data, None)[1]
    mu = float(np.mean(mus))
    if mus.size >= 2:
        rng = np.random.default_rng(seed)
        boots = mus[rng.integers(0, mus.size, size=(n_boot, mus.size))].mean(axis=1)
        a = 100 * (1 - level) / 2
        ci = (float(np.percentile(boots, a)), float(np.percentile(boots, 100 - a)))
        se = float(np.std(boots, ddof=1))
    else:
        ci, se = (math.nan, math.nan), math.nan
        flags.append(fit_flag("warning", "mu-ci-unavailable", subject, "", model,
                             "mu comes from a single trial: no confidence interval"))
    return FlatGroundMu(subject=subject, mu=mu, ci=ci, se=se, level=level,
                        mu_trials=dict(zip(ids, (float(m) for m in mus), strict=True)),
                        transient_mm=lam, flags=tuple(flags))
