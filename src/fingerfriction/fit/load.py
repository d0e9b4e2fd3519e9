"""The load-consistent variant of the fit (the package's default model).

The model is Eq. (4) of Janko, Wiertlewski & Visell 2018 with the pressure taken from the
measured normal force at each position (:mod:`fingerfriction.model`, "The load-consistent
variant"): ``F_T = F_N (S + mu K) / (K - mu S) + p1 (Q + mu S)`` over the load-bearing
contact. Its parameters are fitted in three steps, each where the data pin it:

1. **mu per trial and per subject from flat-ground Coulomb friction** (:func:`flat_ground_mu`). Where the
   finger touches only flat ground (every contact region before the feature, the same flat
   segment as the paper's detrend) the model is Amontons' law ``F_T = mu F_N`` exactly, so
   ``mu`` is the ratio of the absolute forces there. Per trial, ``F_T = F_N (mu_k + A_k
   exp(-u / lambda))`` is fitted (``u`` the distance from the start of the flat segment,
   ``lambda`` shared by the subject's trials): a static-to-sliding
   transient at the start of the slide (the paper's Discussion) would otherwise bias the
   ratio upwards (kept where the trials agree on it). The subject's ``mu`` is the mean of
   the trials' ``mu_k``, with a seeded bootstrap confidence interval over trials; each
   trial's model uses its own ``mu_k`` (``LoadFitOptions.mu_per``: friction varies from
   trial to trial).
2. **The load-bearing contact per subject**: the inset ``delta`` (mm) of the geometric
   regions (``LoadParams.inset``) and the rise ``kappa`` (1/mm) of a region's pressure with
   its height (``LoadParams.kappa``; 0 = one uniform pressure, the paper's) minimise the
   subject's summed squared residual with ``p1`` profiled out per trial: a grid over
   ``[0, inset_max] x [0, kappa_max]``, then a bounded Nelder-Mead
   (``scipy.optimize.minimize``) from the best grid point. ``kappa`` is then held where
   every trial's ``p1`` stays >= 0 (the deformation term dissipates; the residual alone
   can take ``kappa`` past that point), flagged ``kappa-limited``, and the inset refitted
   at that ``kappa``. Noise in ``F_N`` enters the model through the pressure and pulls
   ``delta`` up (errors in variables); ``docs/fit.md`` gives the size of both effects.
3. **p1 per trial** by closed-form least squares on the absolute forces (the model is
   linear in ``p1``), with a standard error that allows for the autocorrelated residuals
   (Newey-West, Bartlett kernel over ``hac_mm`` of positions).

Why ``mu`` is not refined jointly with the rest: minimising the residual over ``mu``,
``delta`` and ``kappa`` together bends ``mu`` to absorb model mismatch at the features,
where Eq. (4) is an approximation, whereas flat ground is where the model is exact
(``benchmarks/science.py`` prints both; the figures are in ``docs/fit.md``).

A trial without absolute forces (no unloaded rest, or ``sensor_highpass_hz=None`` in the
force stage) is fitted on the paper's footing instead: the nominal load stands in for
``F_N`` and model and measurement are detrended over the flat segment alike, as the paper
variant does; it is flagged ``no-absolute`` and takes no part in ``mu`` or ``delta``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy import optimize

from .._check import check_option
from ..model import FrictionModel, LoadParams, load_terms, slope_terms
from ..surfaces import Surface
from .common import (
    FitFlag,
    Trial,
    by_subject,
    fit_flag,
    fit_labels,
    flat_detrend,
    flat_segment_mask,
    median_filter,
    nmse,
    one_subject,
)
from .load_results import (
    LoadFitOptions,
    LoadSubjectFit,
    LoadTrialFit,
)
from .mu import FlatGroundMu, flat_ground_mu
from .weights import column_weights, column_weights_se

__all__ = [
    "LoadFitOptions",
    "LoadTrialFit",
    "LoadSubjectFit",
    "fit_load_subject",
    "subject_flat_mu",
    "fit_load_trials",
    "load_estimate",
]

#: Position stride of the search for the inset and kappa (see _LoadDesign).
SEARCH_STRIDE = 3


# ------------------------------------------------------------------------ per-trial design


#: The laws of the load family (:class:`_LoadDesign`): ``'deformation'`` (Eq. 3's weight
#: ``p1``: the load variant) and ``'push'`` (the interfacial slope push of Eq. 2 weighed per
#: slope direction, ``push_up`` and ``push_down``, without Eq. 3's term: the interlock variant).
LAWS = ("deformation", "push")
#: Per law, the names of its per-trial weights in the order of its design's columns.
WEIGHTS = {"deformation": ("p1",), "push": ("push_up", "push_down")}
#: Per law, the weights that must be >= 0 (physical): Eq. 3's term dissipates, and rising
#: ground pushes the finger back, never pulls it on. On falling ground the net push is what
#: the receding slope's normal stress gives forward less what the tissue's lag and adhesion
#: hold back: either sign (``docs/fit.md``).
NONNEGATIVE = {"deformation": ("p1",), "push": ("push_up",)}


class _LoadDesign:
    """One trial's data and cached integrals for a fit of the load family (``law``, one of
    :data:`LAWS`): the model is ``F_T = F_N g0 + X w`` with the per-trial weights ``w``
    (:data:`WEIGHTS`) and the columns ``X`` (those of the push scaled by ``F_N``)."""

    def __init__(self, trial: Trial, options: LoadFitOptions, model: FrictionModel, *,
                 law: str = "deformation"):
        self.trial = trial
        self.model = model
        self.law = law
        self.push = law == "push"
        self.k = options.median_kernel
        self.absolute = trial.has_absolute
        if self.absolute:
            self.F = trial.force_abs
            self.FN = trial.normal_abs
            # min_load = 0 keeps every position (a negative load is then flagged, not dropped)
            self.load_ok = self.FN >= options.min_load if options.min_load > 0 else np.ones(trial.n, bool)
        else:
            self.F = trial.force
            self.FN = np.full(trial.n, float(options.nominal_load))
            self.load_ok = np.ones(trial.n, bool)
            self.flat = flat_segment_mask(trial.regions, trial.surface)
        step = float(np.median(np.diff(trial.x)))
        self.lags = int(round(options.hac_mm / step)) if step > 0 else 0
        # Where every region lies on flat ground, F_int = mu F_N and F_def = 0 whatever the
        # inset, kappa and p1: those positions (and the median window around the
        # others) are left out of the contact search, whose residual they do not change.
        a, b = trial.surface.feature_extent
        reg = trial.regions
        touches = np.any((reg[..., 1] > a) & (reg[..., 0] < b), axis=1)
        idx = np.flatnonzero(touches)
        # The search also takes every SEARCH_STRIDE-th position (with a median window
        # shortened alike): the residual is smooth in the parameters, and this makes the
        # search 3x cheaper; the final fit of each trial uses every position.
        if idx.size:
            self.search = slice(max(int(idx[0]) - self.k, 0), min(int(idx[-1]) + self.k + 1, trial.n),
                                SEARCH_STRIDE)
        else:
            self.search = slice(0, 0)
        # No median filter in the search: measured on the simulated study, it moves the
        # residual by under 0.1 % there and would cost half of the search's time.
        self.k_search = 1
        self._cache: dict = {}
        self._cache_inset = math.nan

    def _integrals(self, inset: float, window: slice) -> np.ndarray:
        """Region integrals over ``window`` at ``inset``, kept for the last inset: they do
        not depend on ``mu`` or ``kappa``, which the physical limit on ``kappa`` varies at
        a fixed inset (half of the fit's time before they were kept)."""
        key = (float(inset), window.start, window.stop, window.step)
        if self._cache_inset != key[0]:
            self._cache, self._cache_inset = {}, key[0]
        R = self._cache.get(key)
        if R is None:
            R = self._cache[key] = self.model._region_integrals(self.trial.regions[window], inset)
        return R

    def _up(self, inset: float, window: slice) -> np.ndarray:
        """The ascending parts ``[S_up_i, Q_up_i]`` of every region over ``window`` at
        ``inset`` (kept as :meth:`_integrals` keeps its own)."""
        self._integrals(inset, window)  # resets the cache at a new inset
        key = ("up", float(inset), window.start, window.stop, window.step)
        U = self._cache.get(key)
        if U is None:
            U = self._cache[key] = self.model._region_up(self.trial.regions[window], inset, per_region=True)
        return U

    def parts(self, mu: float, inset: float, kappa: float, window: slice = slice(None)):
        """``(g0, B, support)`` over the positions ``window``, median-filtered along them
        like the paper's model estimate (NaN where undefined): ``F_N g0`` the part of the
        interfacial force with no free weight (:func:`fingerfriction.model.load_terms`'s
        ``g``; with the push law only ``mu K``), ``B`` ``(n, m)`` the columns of the
        weights (:data:`WEIGHTS`), the push's per unit load, and the vertical support
        ``sum_i s_i`` (mm)."""
        R = self._integrals(inset, window)
        g, b, support = load_terms(R, mu, kappa)
        if self.push:
            c = slope_terms(R, self._up(inset, window), mu, kappa)
            g, B = c[:, 0], c[:, 1:]
        else:
            B = b[:, None]
        ok = np.isfinite(g)
        B = np.where(np.isfinite(B), B, 0.0)
        k = self.k if window.step in (None, 1) else self.k_search
        if k > 1 and ok.any():
            idx = np.arange(g.size)
            g = np.where(ok, median_filter(np.interp(idx, idx[ok], g[ok]), k), np.nan)
            B = median_filter(B, k)
        return g, B, support

    def terms(self, mu: float, inset: float, kappa: float, window: slice = slice(None)):
        """(used, y, X, f_int, B, support) of the linear problem ``y = X w`` over the
        positions ``window`` (the paper's footing needs them all: ``window`` is ignored);
        ``F_N g0`` is ``f_int``, and ``X`` the columns ``B`` over the used positions, those
        of the push times ``F_N``."""
        if not self.absolute:
            window = slice(None)
        g, B, support = self.parts(mu, inset, kappa, window)
        FN, F = self.FN[window], self.F[window]
        used = self.load_ok[window] & np.isfinite(g)
        f_int = FN * np.where(used, g, 0.0)
        if self.push:
            B = B * FN[:, None]
        if not self.absolute:  # the paper's footing: detrend model parts and measurement alike
            m = self.flat & used
            if np.count_nonzero(m) < 2:
                return used & False, None, None, f_int, B, support
            f_int = flat_detrend(self.trial.x, f_int, m)
            B = flat_detrend(self.trial.x, B, m)
            F = flat_detrend(self.trial.x, F, m)
        y = (F - f_int)[used]
        return used, y, B[used], f_int, B, support

    def rss(self, mu: float, inset: float, kappa: float) -> float:
        """Residual with the weights profiled out, over the positions near the feature."""
        return self.solve(mu, inset, kappa)[1]

    def solve(self, mu: float, inset: float, kappa: float, *, full: bool = False) -> tuple[float, float]:
        """``(w_min, residual)`` by least squares, over the positions near the feature (the
        search's) or, with ``full``, every position as the trial's own fit uses them;
        ``w_min`` is the smallest of the weights that must be >= 0 (:data:`NONNEGATIVE`,
        among those the trial identifies; 0 when none)."""
        used, y, X, *_ = self.terms(mu, inset, kappa, slice(None) if full else self.search)
        if y is None or y.size == 0:
            return 0.0, 0.0
        p, ok = column_weights(X, y)
        r = y - X @ p
        names = WEIGHTS[self.law]
        w = [p[i] for i, n in enumerate(names) if ok[i] and n in NONNEGATIVE[self.law]]
        return (float(min(w)) if w else 0.0), float(r @ r)


def _unphysical(d: _LoadDesign, w: dict, used: np.ndarray, model_name: str, *,
                wrong_sign: bool) -> tuple[bool, list, list]:
    """Why a trial's fit is unphysical or undersupported: ``(failed, reasons, flags)``.

    Negative weights that must be >= 0 (``NONNEGATIVE``), more than 10 % of the positions
    left out, a flat-ground ``F_T / F_N <= 0`` (``wrong_sign``), a negative measured ``F_N``.
    """
    t, n = d.trial, d.trial.n
    tid = t.id
    failed, parts, flags = False, [], []
    for name in NONNEGATIVE[d.law]:
        v = w[name]
        if math.isfinite(v) and v < 0:
            failed = True
            what = ("a negative deformation weight is unphysical" if name == "p1" else
                    "a normal stress that pulls the finger along the slope is unphysical")
            msg = f"{name} = {v:.4g}{' N/mm' if name == 'p1' else ''} < 0: {what}"
            parts.insert(0, msg)
            code = "negative-p1" if name == "p1" else "negative-" + name.replace("_", "-")
            flags.append(fit_flag("error", code, t.subject, tid, model_name, msg))
    n_out = int(n - np.count_nonzero(used))
    if n_out:
        level = "error" if n_out > 0.1 * n else "warning"
        flags.append(fit_flag(level, "positions-left-out", t.subject, tid, model_name,
                             f"{n_out} of {n} positions have no load-bearing contact or a normal force "
                             "below the minimum and are left out of the fit"))
        if level == "error":
            failed = True
            parts.insert(0, f"{n_out} of {n} positions left out")
    if wrong_sign:  # flagged negative-mu by the flat-ground fit
        failed = True
        parts.insert(0, "flat-ground F_T / F_N <= 0 (wrong sign)")
    if np.any(d.FN[used] < 0):
        failed = True
        flags.append(fit_flag("error", "negative-pressure", t.subject, tid, model_name,
                             "the measured normal force is negative at some compared positions"))
    return failed, parts, flags


def _fit_design(d: _LoadDesign, mu: float, inset: float, kappa: float, mu_flat: float,
                model_name: str = "load", *, wrong_sign: bool = False) -> LoadTrialFit:
    t = d.trial
    labels = fit_labels(t)
    tid = t.id
    flags: list[FitFlag] = []
    used, y, X, f_int, B, support = d.terms(mu, inset, kappa)
    n = t.n
    nan = np.full(n, np.nan)
    pressure = d.FN / support
    footing = "absolute" if d.absolute else "flat"
    if not d.absolute:
        flags.append(fit_flag("warning", "no-absolute", t.subject, tid, model_name,
                             "no absolute forces: fitted on the paper's flat-segment footing with the "
                             "nominal load standing in for F_N"))
    if y is None or y.size < 3:
        msg = "no position with load-bearing contact and a normal load to compare"
        flags.append(fit_flag("error", "fit-failed", t.subject, tid, model_name, msg))
        return LoadTrialFit(mu=mu, p1=math.nan, p1_se=math.nan, inset=inset, kappa=kappa,
                            p0_mean=math.nan, mu_flat=mu_flat, objective=math.inf, success=False, message=msg,
                            footing=footing, used=used,
                            measured=nan, estimate=nan, interfacial=nan, deformation=nan, pressure=pressure,
                            subject=t.subject, labels=labels, flags=tuple(flags))
    success, parts = True, ["closed-form least squares"]
    names = WEIGHTS[d.law]
    p, se, ok = column_weights_se(X, y, d.lags)
    w = {n_: (float(p[i]) if ok[i] else math.nan) for i, n_ in enumerate(names)}
    w_se = {n_: float(se[i]) for i, n_ in enumerate(names)}
    if "p1" not in w:
        w["p1"], w_se["p1"] = 0.0, math.nan  # no deformation term of Eq. 3 in this law
    elif math.isnan(w["p1"]):
        w["p1"] = 0.0  # no slope reached: F_def = 0
    if not ok.any():
        flags.append(fit_flag("warning", "p1-not-identified", t.subject, tid, model_name,
                             "the load-bearing contact never reaches a slope: its slope weights are not "
                             "identified (no slope term)"))
    bad, why, more = _unphysical(d, w, used, model_name, wrong_sign=wrong_sign)
    success = success and not bad
    parts[:0] = why
    flags.extend(more)
    # the trial's pressure: total load over total vertical support (a ratio of sums stays
    # unbiased under noise in F_N, a mean of the pointwise pressure would not)
    p0_mean = float(np.sum(d.FN[used]) / np.sum(support[used]))
    f_w = B @ np.where(ok, p, 0.0)  # the weighted columns: F_def, or with the push law part of F_int
    est = np.where(used, f_int + f_w, np.nan)
    meas = np.full(n, np.nan)
    if d.absolute:
        meas[used] = d.F[used]
    else:
        meas[used] = y + f_int[used]  # the detrended measurement
    f_int, f_def = (f_int + f_w, np.zeros(n)) if d.push else (f_int, f_w)
    obj = nmse(meas[used], est[used])
    return LoadTrialFit(
        mu=float(mu), p1=float(w["p1"]), p1_se=float(w_se["p1"]), inset=float(inset), kappa=float(kappa),
        p0_mean=p0_mean, mu_flat=float(mu_flat), objective=float(obj),
        success=success, message="; ".join(parts), footing=footing, used=used, measured=meas, estimate=est,
        interfacial=np.where(used, f_int, np.nan), deformation=np.where(used, f_def, np.nan),
        pressure=pressure, subject=t.subject, labels=labels, flags=tuple(flags),
        push_up=w.get("push_up", math.nan), push_up_se=w_se.get("push_up", math.nan),
        push_down=w.get("push_down", math.nan), push_down_se=w_se.get("push_down", math.nan),
    )


def _physical_kappa(designs: list, mu_of, inset: float, kappa: float, *, steps: int = 8) -> float:
    """The largest ``kappa <= kappa`` at which every trial's least-squares ``p1`` is >= 0.

    The deformation term of Eq. (3) resists the motion (it dissipates energy), so a
    negative weight is unphysical; a larger ``kappa`` moves the force on the slopes from
    ``F_def`` to ``F_int`` and can push ``p1`` below 0 on the trials with the least
    deformation (the 4 mm steps). Bisection on ``[0, kappa]`` over the trials whose ``p1``
    is negative at ``kappa`` (``p1`` falls as ``kappa`` rises), with the search's
    positions, then a check of every trial with every position (what the trials' own
    fits use), stepping down by 2 % until it holds.
    """
    def p1(d, k: float, full: bool) -> float:
        return d.solve(mu_of(d), inset, k, full=full)[0]

    def negative(k: float, full: bool, among: list) -> bool:  # stops at the first p1 < 0
        return any(p1(d, k, full) < 0 for d in among)

    bad = [d for d in designs if p1(d, kappa, True) < 0]
    if not bad:
        return kappa
    lo, hi = 0.0, kappa
    if negative(lo, False, bad):
        return 0.0  # p1 < 0 even with one uniform pressure: flagged per trial by the fit
    for _ in range(steps):
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if negative(mid, False, bad) else (mid, hi)
    k = lo
    for _ in range(20):
        if k <= 0 or not negative(k, True, designs):
            break
        k *= 0.98
    return max(k, 0.0)


def _search_designs(designs: list, n_max: int) -> list:
    """At most ``n_max`` trials for the contact search, spread evenly over the surfaces
    (and, within a surface, over the trials in their order: speeds and repetitions)."""
    if len(designs) <= n_max:
        return designs
    by: dict[str, list] = {}
    for d in designs:
        by.setdefault(d.trial.surface.name, []).append(d)
    out, k = [], 0
    while len(out) < n_max:  # round robin over the surfaces, each list thinned evenly
        for ds in by.values():
            picks = [ds[int(i)] for i in np.linspace(0, len(ds) - 1, min(len(ds), -(-n_max // len(by))))]
            if k < len(picks) and len(out) < n_max:
                out.append(picks[k])
        k += 1
    return out


def _fit_contact(designs, mu_of, options: LoadFitOptions) -> tuple[float, float, tuple]:
    """The subject's load-bearing inset and pressure rise with height (module notes, step 2)."""
    free = [name for name in ("inset", "kappa") if getattr(options, name) == "fit"]
    fixed = {name: float(getattr(options, name)) for name in ("inset", "kappa") if name not in free}
    if not free or not designs:
        return fixed.get("inset", 0.0), fixed.get("kappa", 0.0), ()
    hi = {"inset": float(options.inset_max), "kappa": float(options.kappa_max)}

    def total(v) -> float:
        p = {**fixed, **dict(zip(free, (float(a) for a in v), strict=True))}
        return sum(d.rss(mu_of(d), p["inset"], p["kappa"]) for d in designs)

    # a coarse grid first (the summed residual can have shallow local minima), then a
    # bounded Nelder-Mead from its best point, on parameters scaled to [0, 1]
    axes = {"inset": np.linspace(0.0, hi["inset"], 6),
            "kappa": hi["kappa"] * np.array([0.0, 0.125, 0.25, 0.5, 0.75])}
    mesh = np.meshgrid(*(axes[n] for n in free), indexing="ij")
    points = np.stack([m.ravel() for m in mesh], axis=1)
    values = [total(p) for p in points]
    best = points[int(np.argmin(values))]
    scale = np.array([hi[n] for n in free])
    step = np.array([0.2 * hi[n] if n == "inset" else 0.125 * hi[n] for n in free]) / scale
    x0 = best / scale
    simplex = np.vstack([x0] + [x0 + np.where(np.arange(len(free)) == i, step[i] / 2, 0.0)
                                for i in range(len(free))])
    res = optimize.minimize(lambda q: total(q * scale), x0, method="Nelder-Mead",
                            bounds=[(0.0, 1.0)] * len(free),
                            # 0.01 of each range (0.01 mm of inset, 0.08/mm of kappa), or a
                            # residual settled to 1e-5 of its size: finer is below the noise
                            options={"initial_simplex": np.clip(simplex, 0.0, 1.0), "xatol": 1e-2,
                                     "fatol": 1e-5 * float(np.min(values)), "maxfev": 80})
    out = {**fixed, **dict(zip(free, (float(v) for v in res.x * scale), strict=True))}
    return out["inset"], out["kappa"], tuple(free)


# ------------------------------------------------------------------------ subject fit


def _at_bound_flags(subject: str, fitted, inset: float, kappa: float, options: LoadFitOptions,
                    model: str = "load") -> list:
    """A warning for each fitted contact parameter that ended within 2 % of its bound."""
    flags = []
    bounds = (("inset", inset, options.inset_max), ("kappa", kappa, options.kappa_max))
    for name, value, bound in bounds:
        if name in fitted and value > 0.98 * bound:
            what = "load-bearing inset" if name == "inset" else "rise of the pressure with height"
            flags.append(fit_flag("warning", f"{name}-at-bound", subject, "", model,
                                 f"the {what} reached its bound {bound:g}"))
    return flags



def subject_flat_mu(trials: Sequence[Trial], options: LoadFitOptions, subject: str,
                    model: str) -> tuple[FlatGroundMu | None, LoadSubjectFit | None]:
    """One subject's flat-ground mu for a fit of the load family (:func:`flat_ground_mu`
    with the fit's options), or, when it cannot be measured, the failed subject fit that
    says why (flag ``mu-unavailable``); returns ``(flat, None)`` or ``(None, failed)``."""
    try:
        flat = flat_ground_mu(trials, transient=options.transient, transient_max_mm=options.transient_max_mm,
                              min_load=options.min_load, min_flat_mm=options.min_flat_mm,
                              n_boot=options.n_boot, seed=options.seed, level=options.level, model=model)
    except ValueError as exc:
        msg = str(exc)
        flag = fit_flag("error", "mu-unavailable", subject, "", model, msg)
        return None, LoadSubjectFit(subject=subject, mu=math.nan, flat=None, inset=math.nan, kappa=math.nan,
                                    fitted=(), trials=(), flags=(flag,), success=False, message=msg,
                                    model=model)
    return flat, None

def fit_load_subject(trials: Sequence[Trial], options: LoadFitOptions | None = None, *,
                     models: dict | None = None, law: str = "deformation",
                     name: str = "load") -> LoadSubjectFit:
    """Fit the load-consistent Eq. (4) to one subject's trials (see the module notes).

    Parameters
    ----------
    trials : sequence of Trial
        All trials of one subject; those with ``force_abs``/``normal_abs`` are fitted on
        the absolute footing, the others on the paper's (flagged).
    options : LoadFitOptions, optional
    models : dict, optional
        Surface -> FrictionModel cache shared between calls.
    law : {'deformation', 'push'}
        The law (:data:`LAWS`): Eq. (3)'s deformation weight ``p1`` per trial (default), or
        the interfacial slope push weighed by slope direction, one weight per trial for the
        ascending slopes (``push_up``, >= 0) and one for the descending ones (``push_down``,
        either sign), without Eq. (3)'s term (the interlock variant, ``docs/fit.md``).
    name : str
        The variant's name in the flags and results (its registry entry passes it).

    Returns
    -------
    LoadSubjectFit
        ``success`` is False (with the reason in ``message`` and ``flags``) when ``mu``
        cannot be measured (no trial with absolute forces and flat ground) or any trial
        fit is unphysical; never a silent number.
    """
    options = options or LoadFitOptions()
    trials, subject = one_subject(trials, caller="fit_load_subject", purpose="fit a subject",
                                   group="fit_load_trials")
    models = {} if models is None else models
    law = check_option("law", law, LAWS)
    designs = []
    for t in trials:
        key: Surface = t.surface
        if key not in models:
            models[key] = FrictionModel(key)
        designs.append(_LoadDesign(t, options, models[key], law=law))
    flat, failed = subject_flat_mu(trials, options, subject, name)
    if failed is not None:
        return failed
    mu = flat.mu
    flags = list(flat.flags)

    def mu_of(d: _LoadDesign) -> float:
        if options.mu_per == "trial":
            return flat.mu_trials.get(d.trial.id, mu)
        return mu

    absolute = [d for d in designs if d.absolute]
    search = _search_designs(absolute, options.search_trials)
    inset, kappa, fitted = _fit_contact(search, mu_of, options)
    if "kappa" in fitted:  # the physical limit: every trial's deformation weight p1 >= 0
        best = kappa
        kappa = _physical_kappa(absolute, mu_of, inset, kappa)
        if kappa < best:
            if "inset" in fitted:  # the best inset at the limited kappa
                res = optimize.minimize_scalar(lambda v: sum(d.rss(mu_of(d), v, kappa) for d in search),
                                               bounds=(0.0, float(options.inset_max)), method="bounded",
                                               options={"xatol": 1e-3})
                inset = float(res.x)
                kappa = _physical_kappa(absolute, mu_of, inset, kappa)
            # info, not a warning: the limit is the physics the fit imposes, and it holds
            # on clean studies too (both subjects of the simulated default study)
            flags.append(fit_flag("info", "kappa-limited", subject, "", name,
                                 f"the pressure's rise with height is limited to {kappa:.2f}/mm, where every "
                                 f"trial's deformation weight p1 stays >= 0 (the residual alone would take "
                                 f"{best:.2f}/mm)"))
    flags += _at_bound_flags(subject, fitted, inset, kappa, options, name)
    wrong_sign = {f.trial for f in flat.flags if f.code == "negative-mu"}
    fits = tuple(_fit_design(d, mu_of(d), inset, kappa, flat.mu_trials.get(d.trial.id, math.nan), name,
                             wrong_sign=d.trial.id in wrong_sign) for d in designs)
    for f in fits:
        flags.extend(f.flags)
    n_bad = sum(not f.success for f in fits)
    parts = [f"mu = {mu:.4f} (flat ground, {100 * flat.level:g} % CI [{flat.ci[0]:.4f}, {flat.ci[1]:.4f}]); "
             f"load-bearing inset {inset:.3f} mm, pressure rise with height {kappa:.2f}/mm"
             + (f" (fitted: {', '.join(fitted)})" if fitted else "")]
    if n_bad:
        parts.append(f"{n_bad} of {len(fits)} trial fits failed or unphysical")
    return LoadSubjectFit(subject=subject, mu=mu, flat=flat, inset=inset, kappa=kappa, fitted=fitted,
                          trials=fits, flags=tuple(flags), success=n_bad == 0, message="; ".join(parts),
                          model=name)


def fit_load_trials(trials: Sequence[Trial], options: LoadFitOptions | None = None, *,
                    law: str = "deformation", name: str = "load") -> dict[str, LoadSubjectFit]:
    """:func:`fit_load_subject` for every subject present in ``trials`` (keyed by subject)."""
    models: dict = {}
    return {s: fit_load_subject(ts, options, models=models, law=law, name=name)
            for s, ts in sorted(by_subject(trials).items())}


def load_estimate(model: FrictionModel, regions: np.ndarray, f_n, params: LoadParams, *,
                  median_kernel: int = 11) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The load-consistent Eq. (4) for fixed parameters, processed as the fit processes its
    model (the median filter on the load-independent parts).

    Parameters
    ----------
    model : FrictionModel
        The surface's model.
    regions : (n, n_max, 2) ndarray
        Geometric contact regions in mm (video or forward model); inset by ``params.inset``.
    f_n : float or (n,) array_like
        Normal force in N (the nominal load for a prediction, or a measured one).
    params : LoadParams
        With ``push_up``, ``push_down`` the slope push weighed by slope direction
        (``'interlock'``).
    median_kernel : int
        Median filter window in positions, as the fit's.

    Returns
    -------
    total, interfacial, deformation : (n,) ndarray
        ``F_T``, ``F_int`` (Eq. 2) and ``F_def`` (Eq. 3) in N; NaN where the load-bearing
        contact is empty.
    """
    R = model.region_integrals(regions, inset=params.inset)
    g, b, _ = load_terms(R, params.mu, params.kappa)
    if params.split_push:  # the push's columns filtered one by one, as the fit's (_LoadDesign.parts)
        c = slope_terms(R, model.region_up(regions, inset=params.inset), params.mu, params.kappa)
        g, push = c[:, 0], np.where(np.isfinite(c[:, 1:]), c[:, 1:], 0.0)
    ok = np.isfinite(g)
    if median_kernel > 1 and ok.any():
        idx = np.arange(g.size)
        g = np.where(ok, median_filter(np.interp(idx, idx[ok], g[ok]), median_kernel), np.nan)
        b = median_filter(b, median_kernel)
        if params.split_push:
            push = median_filter(push, median_kernel)
    if params.split_push:
        g = g + push @ np.array([params.push_up, params.push_down])
    f_int = np.broadcast_to(np.asarray(f_n, dtype=float), g.shape) * g
    f_def = np.where(ok, params.p1 * b, np.nan)
    return f_int + f_def, f_int, f_def
