"""The constant-pressure variant on the absolute footing: Eq. (4) as printed, with ``mu``
measured where it is identified.

Eq. (4) of Janko, Wiertlewski & Visell 2018 with one constant pressure ``p0`` over the
contact regions of a trial (the paper's "fluid-filled membrane" analogy)::

    F_T = p0 (S + mu K) + p1 (Q + mu S)

(``S, K, Q`` the per-position integrals of :mod:`fingerfriction.model`), fitted on the
absolute forces, where the flat ground before the feature pins what the paper's detrended
footing leaves free:

1. **mu per trial and per subject from flat-ground Coulomb friction**, exactly as the
   load-consistent variant measures it (:func:`fingerfriction.fit.flat_ground_mu`): on flat
   ground Eq. (4) is ``F_T = p0 mu L`` and its normal load ``F_N = p0 L``, so ``mu`` is the
   ratio of the two, with its bootstrap confidence interval over trials;
2. **p0 and p1 per trial** by closed-form least squares on the absolute ``F_T`` (with
   ``mu`` fixed, Eq. 4 is linear in them), with Newey-West standard errors; on the absolute
   footing the flat ground's level ``p0 mu L`` pins ``p0``, so the twin of the paper's
   footing does not arise. Positions where the camera's field cut the contact
   (``Trial.clipped``: near the window's ends a flat-ground contact of 12-13 mm leaves the
   29 mm field) are left out: the regions seen there are shorter than the contact that
   makes the force, and this law, in the contact's length, would read the cut as a change
   of friction (the load-consistent variant is immune on flat ground, where its friction is
   ``mu F_N`` whatever the length). (A ``p0`` measured from the flat ground's load alone
   was the first design; with the field's cut, the 4 mm features leave no flat position
   with the whole contact in view.)

What separates it from the load-consistent variant: the pressure stays at one value over
the whole slide, whatever the measured ``F_N`` does there, so the interfacial force
follows the contact length (the paper's Eq. 4 taken literally); the load-consistent
variant makes the contact carry the measured ``F_N`` at every position instead. The two
coincide when ``F_N`` happens to be the load of a constant pressure. A ``p0 <= 0`` or
``p1 < 0`` is unphysical (flagged, the trial's fit fails).

The results are :class:`fingerfriction.fit.LoadTrialFit` and
:class:`fingerfriction.fit.LoadSubjectFit` with ``model='pressure'``, ``inset`` and
``kappa`` 0 (the geometric regions, one uniform pressure), ``p0_mean`` the trial's ``p0``.
A trial without absolute forces cannot be fitted by this variant (flagged ``no-absolute``,
an error).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ..model import FrictionModel, T_matrix
from .common import (
    FitFlag,
    Trial,
    by_subject,
    fit_flag,
    fit_labels,
    median_filter,
    nmse,
    one_subject,
)
from .load import LoadFitOptions, LoadSubjectFit, LoadTrialFit, subject_flat_mu
from .weights import column_weights, hac_cov

__all__ = ["fit_pressure_subject", "fit_pressure_trials"]

NAME = "pressure"


def _failed(t: Trial, mu: float, mu_flat: float, flags: list, msg: str,
            code: str = "fit-failed") -> LoadTrialFit:
    nan = np.full(t.n, np.nan)
    flags.append(fit_flag("error", code, t.subject, t.id, NAME, msg))
    return LoadTrialFit(mu=mu, p1=math.nan, p1_se=math.nan, inset=0.0, kappa=0.0, p0_mean=math.nan,
                        mu_flat=mu_flat, objective=math.inf, success=False, message=msg,
                        footing="absolute" if t.has_absolute else "flat", used=np.zeros(t.n, bool),
                        measured=nan, estimate=nan, interfacial=nan, deformation=nan, pressure=nan,
                        subject=t.subject, labels=fit_labels(t), flags=tuple(flags))


def _fit_trial(t: Trial, model: FrictionModel, mu: float, mu_flat: float, options: LoadFitOptions, *,
               wrong_sign: bool = False) -> LoadTrialFit:
    """p0 and p1 by least squares where the whole contact is seen (module notes, step 2)."""
    flags: list[FitFlag] = []
    if not t.has_absolute:
        return _failed(t, mu, mu_flat, flags, "no absolute forces: the constant-pressure variant measures "
                       "p0 and mu on the absolute flat-ground level", code="no-absolute")
    raw = model.integrals(t.regions)  # S, K, Q (mm)
    contact = raw[:, 1] > 0
    load_ok = t.normal_abs >= options.min_load if options.min_load > 0 else np.ones(t.n, bool)
    # where the camera cut the contact, the regions are shorter than the contact that makes
    # the force: a law in the contact's length cannot be evaluated there (module notes)
    seen = ~t.clipped if t.clipped is not None else np.ones(t.n, bool)
    used = contact & load_ok & seen
    if np.count_nonzero(used) < 3:
        return _failed(t, mu, mu_flat, flags, "fewer than 3 positions with a normal load and the whole "
                       "contact in the camera's field: nothing to fit")
    B = median_filter(raw, options.median_kernel) @ T_matrix(mu)  # (S + mu K, Q + mu S)
    X, y = B[used], t.force_abs[used]
    p, ok = column_weights(X, y)
    step = float(np.median(np.diff(t.x)))
    lags = int(round(options.hac_mm / step)) if step > 0 else 0
    cov = np.full((2, 2), np.nan)
    if ok.any():
        cov[np.ix_(ok, ok)] = hac_cov(X[:, ok], y - X @ p, lags)
    p0, p1 = float(p[0]), float(p[1])
    p1_se = math.sqrt(max(float(cov[1, 1]), 0.0)) if ok[1] else math.nan
    success, parts = True, ["p0 and p1 by closed-form least squares"]
    if not ok[1]:
        flags.append(fit_flag("warning", "p1-not-identified", t.subject, t.id, NAME,
                             "the contact never reaches a slope: p1 is not identified (F_def = 0)"))
    if not p0 > 0:
        success = False
        msg = f"p0 = {p0:.4g} N/mm <= 0: an unphysical (negative) pressure"
        parts.insert(0, msg)
        flags.append(fit_flag("error", "negative-p0", t.subject, t.id, NAME, msg))
    f_int = p0 * B[:, 0]
    if p1 < 0:
        success = False
        msg = f"p1 = {p1:.4g} N/mm < 0: a negative deformation weight is unphysical"
        parts.insert(0, msg)
        flags.append(fit_flag("error", "negative-p1", t.subject, t.id, NAME, msg))
    n_cut = int(np.count_nonzero(~seen))
    if n_cut:
        flags.append(fit_flag("info", "clipped-left-out", t.subject, t.id, NAME,
                             f"{n_cut} of {t.n} positions, where the camera's field cut the contact, are "
                             "left out (the constant-pressure law needs the whole contact)"))
    n_out = int(np.count_nonzero(seen & ~used))
    if n_out:
        level = "error" if n_out > 0.1 * t.n else "warning"
        flags.append(fit_flag(level, "positions-left-out", t.subject, t.id, NAME,
                             f"{n_out} of {t.n} positions have no contact or a normal force below the "
                             "minimum and are left out of the fit"))
        if level == "error":
            success = False
            parts.insert(0, f"{n_out} of {t.n} positions left out")
    if wrong_sign:
        success = False
        parts.insert(0, "flat-ground F_T / F_N <= 0 (wrong sign)")
    f_def = p1 * B[:, 1]
    est = np.where(used, f_int + f_def, np.nan)
    meas = np.where(used, t.force_abs, np.nan)
    return LoadTrialFit(
        mu=float(mu), p1=p1, p1_se=float(p1_se), inset=0.0, kappa=0.0, p0_mean=p0, mu_flat=float(mu_flat),
        objective=float(nmse(meas[used], est[used])) if used.sum() >= 3 else math.inf, success=success,
        message="; ".join(parts), footing="absolute", used=used, measured=meas, estimate=est,
        interfacial=np.where(used, f_int, np.nan), deformation=np.where(used, f_def, np.nan),
        pressure=np.where(contact, p0, np.nan), subject=t.subject, labels=fit_labels(t), flags=tuple(flags))


def fit_pressure_subject(trials: Sequence[Trial], options: LoadFitOptions | None = None, *,
                         models: dict | None = None) -> LoadSubjectFit:
    """Fit the constant-pressure Eq. (4) to one subject's trials on the absolute footing.

    Parameters
    ----------
    trials : sequence of Trial
        All trials of one subject.
    options : LoadFitOptions, optional
        The load-consistent variant's options; this variant uses the median filter, the
        flat-ground ``mu`` settings (transient, ``min_load``, ``min_flat_mm``, bootstrap),
        ``mu_per`` and ``hac_mm`` (it has no inset or pressure rise).
    models : dict, optional
        Surface -> FrictionModel cache shared between calls.

    Returns
    -------
    LoadSubjectFit
        With ``model='pressure'``; ``success`` False (the reason in ``message`` and
        ``flags``) when ``mu`` cannot be measured or a trial fit is unphysical.
    """
    options = options or LoadFitOptions()
    trials, subject = one_subject(trials, caller="fit_pressure_subject", purpose="fit a subject",
                                   group="fit_pressure_trials")
    models = {} if models is None else models
    flat, failed = subject_flat_mu(trials, options, subject, NAME)
    if failed is not None:
        return failed
    wrong_sign = {f.trial for f in flat.flags if f.code == "negative-mu"}
    fits = []
    for t in trials:
        if t.surface not in models:
            models[t.surface] = FrictionModel(t.surface)
        own = flat.mu_trials.get(t.id, math.nan)
        mu = own if options.mu_per == "trial" and math.isfinite(own) else flat.mu
        fits.append(_fit_trial(t, models[t.surface], mu, own, options, wrong_sign=t.id in wrong_sign))
    flags = list(flat.flags) + [f for tf in fits for f in tf.flags]
    n_bad = sum(not f.success for f in fits)
    parts = [f"mu = {flat.mu:.4f} (flat ground, {100 * flat.level:g} % CI [{flat.ci[0]:.4f}, "
             f"{flat.ci[1]:.4f}]); one constant pressure p0 per trial"]
    if n_bad:
        parts.append(f"{n_bad} of {len(fits)} trial fits failed or unphysical")
    return LoadSubjectFit(subject=subject, mu=flat.mu, flat=flat, inset=0.0, kappa=0.0, fitted=(),
                          trials=tuple(fits), flags=tuple(flags), success=n_bad == 0,
                          message="; ".join(parts), model=NAME)


def fit_pressure_trials(trials: Sequence[Trial],
                        options: LoadFitOptions | None = None) -> dict[str, LoadSubjectFit]:
    """:func:`fit_pressure_subject` for every subject present in ``trials`` (keyed by subject)."""
    models: dict = {}
    return {s: fit_pressure_subject(ts, options, models=models)
            for s, ts in sorted(by_subject(trials).items())}
