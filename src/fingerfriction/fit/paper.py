"""The paper variant of the fit: Eq. (5) NMSE, p0/p1 per trial, mu per subject by grid search.

Janko, Wiertlewski & Visell 2018, Methods "Estimating model parameters": per trial, the
parameters ``p0, p1`` of Eq. (4) minimise a normalised mean square error between the
measured force ``F_T`` and the median-filtered model estimate ``F_hat_T`` (Nelder-Mead);
per subject, ``mu`` comes from a grid search over all that subject's trials.

How measurement and model are compared (the choices this module makes)
----------------------------------------------------------------------
1. **Same footing (detrend).** The measured ``F_T`` is drift-corrected: the best line over
   the flat segment before the feature is subtracted, so it is near zero there, while
   Eq. (4) has a positive flat level ``p0 mu L``. We apply *the same* operator to the model:
   the best line over the same flat segment is subtracted from ``F_hat`` (and, to make the
   two series exactly comparable, from the measurement too, which changes a correctly
   drift-corrected measurement by at most its residual line). The operator is linear, so
   the model stays linear in ``(p0, p1)``. The flat segment is derived from the contact
   regions themselves (:func:`flat_segment_mask`): the positions where every contact
   region lies entirely left of the feature, i.e. the finger touches only flat ground.
   Because the finger pad is ~16 mm long, contact reaches the feature several mm before
   the finger centre does, so a segment defined from the finger centre would be wrong.
2. **Median filter.** The paper filters the force estimate to remove quantisation artefacts
   of the tracked contours. Those artefacts enter the model only through the per-frame
   integrals of Eq. (4), ``S = sum int sin(alpha)``, ``K = sum int cos(alpha)`` and
   ``Q = sum int s sin(alpha)`` (``F = p0 (S + mu K) + p1 (Q + mu S)``, see
   :mod:`fingerfriction.model`). ``median_on='basis'`` (default) filters these three
   mu-independent series once per trial; the model then stays exactly linear in
   ``(p0, p1)`` for every ``mu``, so least squares is exact and Nelder-Mead and least
   squares minimise the same function. ``median_on='estimate'`` is the literal reading:
   filter ``F_hat`` after combining; it is nonlinear in ``(p0, p1)``, Nelder-Mead handles
   it exactly and least squares uses the filtered-basis fit as its (approximate) solution
   (how close, on synthetic trials: ``docs/fit.md``). A window of 1 switches the filter
   off.
3. **Objective.** :func:`nmse` (conventional, default) and :func:`nmse_eq5` (Eq. 5 as
   printed); see their docstrings for why the conventional one is the default.
4. **mu grid.** For each ``mu`` of the grid every trial is refitted; the subject's curve is
   the sum over its trials of the per-trial minimal objective (each trial normalised by
   its own variance, so trials weigh equally); ``mu`` is the grid point of the minimum.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence

import numpy as np
from scipy import optimize

from .._check import check_option
from ..model import FrictionModel, FrictionParams, T_matrix
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
    nmse_eq5,
    one_subject,
)
from .paper_results import (
    FitOptions,
    SubjectFit,
    TrialFit,
)

__all__ = [
    "FitOptions",
    "TrialFit",
    "SubjectFit",
    "fit_trial",
    "fit_subject",
    "fit_trials",
    "mu_grid",
    "MU_GRID",
    "paper_flags",
]

log = logging.getLogger(__name__)

METHODS = ("lstsq", "nelder-mead")


# ------------------------------------------------------------------------ the mu grid


#: The paper variant's default ``mu`` grid, ``(start, stop, step)``: 0.30 to 0.90 by 0.01,
#: 61 values (:func:`mu_grid`; the fit, its command and :class:`~.variants.FitSettings` take it
#: from here).
MU_GRID = (0.30, 0.90, 0.01)


def mu_grid(start: float | None = None, stop: float | None = None, step: float | None = None) -> np.ndarray:
    """Inclusive grid of ``mu`` values; an end or step left None is that of :data:`MU_GRID`
    (0.30..0.90 by 0.01: 61 values)."""
    start, stop, step = (d if v is None else v for v, d in zip((start, stop, step), MU_GRID, strict=True))
    for name, v in (("start", start), ("stop", stop), ("step", step)):
        if not math.isfinite(v):
            raise ValueError(f"mu grid {name} must be finite, got {v!r}")
    if step <= 0 or start < 0 or stop < start or stop > 5:
        raise ValueError(
            f"mu grid needs 0 <= start <= stop <= 5 and step > 0, got start={start!r}, "
            f"stop={stop!r}, step={step!r}"
        )
    count = (stop - start) / step + 1e-9
    if not count < MAX_MU_GRID:  # each value is a fit of every trial: time and memory grow with it
        raise ValueError(f"mu grid [{start:g}, {stop:g}] by {step:g} has {count:.3g} values, more than the "
                         f"{MAX_MU_GRID} allowed (MAX_MU_GRID); take a larger step")
    n = int(math.floor(count)) + 1
    return np.round(start + step * np.arange(n), 12)


#: The most values of a ``mu`` grid (:func:`mu_grid`): 0 to 5 by 0.0005.
MAX_MU_GRID = 10_001


# ------------------------------------------------------------------------ per-trial design


class _Design:
    """Precomputed, mu-independent pieces of one trial's fit.

    ``P`` holds the three per-frame integrals ``[S, K, Q]`` (mm) of Eq. (4) after the
    processing that is linear or mu-independent (median filter in 'basis' mode, flat
    detrend); for any ``mu`` the two basis columns are ``P @ T(mu)`` with
    ``T = [[1, mu], [mu, 0], [0, 1]]``.
    """

    def __init__(self, trial: Trial, options: FitOptions, model: FrictionModel | None = None):
        model = model if model is not None else FrictionModel(trial.surface)
        raw = model.integrals(trial.regions)  # S, K, Q
        self.mask = flat_segment_mask(trial.regions, trial.surface, margin=options.flat_margin)
        self.detrend = bool(options.detrend)
        if self.detrend and np.count_nonzero(self.mask) < 2:
            raise ValueError(
                f"trial ({trial.subject}, {trial.surface.name}, {trial.labels}): flat segment has "
                f"{int(np.count_nonzero(self.mask))} positions where all contact lies left of the "
                f"feature start {trial.surface.feature_extent[0]:g} mm - margin {options.flat_margin:g} mm; "
                "at least 2 are needed"
            )
        self.x = trial.x
        self.k = options.median_kernel
        self.median_on = options.median_on
        self.raw = raw
        # P: filtered (median on each of S, K, Q), detrended basis. In 'basis' mode it is
        # the model exactly; in 'estimate' mode it is the closed form's linear surrogate.
        self.P = self._detrend(median_filter(raw, self.k))
        self.F = self._detrend(np.asarray(trial.force, dtype=float))
        self.n = trial.n
        self.A = self.P.T @ self.P
        self.b = self.P.T @ self.F
        self.c = float(self.F @ self.F)
        pm = self.P.mean(axis=0)
        self.Ac = self.A - self.n * np.outer(pm, pm)  # Gram of the centred columns
        self.sst = float(np.sum((self.F - self.F.mean()) ** 2))

    T = staticmethod(T_matrix)

    def estimate(self, mu: float, p: np.ndarray) -> np.ndarray:
        """Model as compared: detrended (and filtered) Eq. (4) estimate in N."""
        if self.median_on == "basis":
            return self.P @ (self.T(mu) @ p)
        f = self.raw @ (self.T(mu) @ p)
        return self._detrend(median_filter(f, self.k))

    def _detrend(self, y: np.ndarray) -> np.ndarray:
        return flat_detrend(self.x, y, self.mask) if self.detrend else y

    def lstsq_curve(self, mus: np.ndarray):
        """Closed-form p and conventional NMSE for every mu (vectorised)."""
        T = self.T(mus)  # (m, 3, 2)
        G = np.einsum("mij,jk,mkl->mil", T.transpose(0, 2, 1), self.A, T)
        g = np.einsum("mji,j->mi", T, self.b)
        det = G[:, 0, 0] * G[:, 1, 1] - G[:, 0, 1] * G[:, 1, 0]
        scale = G[:, 0, 0] * G[:, 1, 1]
        ok = np.abs(det) > 1e-12 * np.maximum(scale, 1e-300)
        inv = np.empty_like(G)
        inv[:, 0, 0] = G[:, 1, 1]
        inv[:, 1, 1] = G[:, 0, 0]
        inv[:, 0, 1] = -G[:, 0, 1]
        inv[:, 1, 0] = -G[:, 1, 0]
        inv /= np.where(ok, det, 1.0)[:, None, None]
        p = np.einsum("mij,mj->mi", inv, g)
        sse = self.c - np.einsum("mi,mi->m", p, g)  # at the optimum: c - p'g
        sse = np.maximum(sse, 0.0)
        obj = sse / self.sst if self.sst > 0 else np.full(sse.shape, np.inf)
        return p, np.where(ok, obj, np.inf), ok

    def quad_objective(self, mu: float, name: str):
        """Objective as a function of p using the Gram matrices (exact when linear)."""
        T = self.T(mu)
        G = T.T @ self.A @ T
        g = T.T @ self.b
        H = T.T @ self.Ac @ T
        c, sst = self.c, self.sst

        # Plain float arithmetic: Nelder-Mead calls this ~100 times per fit, and numpy's
        # per-call overhead on 2-vectors would dominate (measured ~3x slower).
        g00, g01, g11 = float(G[0, 0]), float(G[0, 1]), float(G[1, 1])
        g0, g1 = float(g[0]), float(g[1])
        h00, h01, h11 = float(H[0, 0]), float(H[0, 1]), float(H[1, 1])

        def sse(p):
            a, b = float(p[0]), float(p[1])
            return max(g00 * a * a + 2.0 * g01 * a * b + g11 * b * b - 2.0 * (g0 * a + g1 * b) + c, 0.0)

        if name == "nmse":
            def f(p):
                return sse(p) / sst
        else:
            def f(p):
                a, b = float(p[0]), float(p[1])
                den = h00 * a * a + 2.0 * h01 * a * b + h11 * b * b
                if den <= 0:
                    return math.inf
                return math.sqrt(sse(p) / den)
        return f

    def exact_objective(self, mu: float, name: str):
        fn = nmse if name == "nmse" else nmse_eq5
        if self.median_on == "basis":
            return self.quad_objective(mu, name)
        return lambda p: fn(self.F, self.estimate(mu, p))


def _nelder_mead(d: _Design, mu: float, options: FitOptions, x0=None):
    """scipy's Nelder-Mead on the exact objective; returns (OptimizeResult, scale)."""
    f = d.exact_objective(mu, options.objective)
    # Optimise relative parameters q = p / s. Start from a crude common scale, not from the
    # closed form, so the comparison between the two methods is meaningful; along the mu
    # grid, start from the previous grid point's solution with a 1 % simplex (measured
    # ~2x faster than scipy's default 5 % simplex, same optimum).
    col = d.P @ (d.T(mu) @ np.ones(2))
    s = float(np.linalg.norm(d.F) / max(np.linalg.norm(col), 1e-300))
    s = s if math.isfinite(s) and s > 0 else 1.0
    q0 = np.ones(2)
    simplex = None
    if x0 is not None and np.all(np.isfinite(x0)) and np.all(np.asarray(x0) != 0):
        q0 = np.asarray(x0, dtype=float) / s
        simplex = np.array([q0, q0 * [1.01, 1.0], q0 * [1.0, 1.01]])
    res = optimize.minimize(
        lambda q: f(s * q), q0, method="Nelder-Mead",
        options={"xatol": options.xatol, "fatol": options.fatol, "maxiter": options.maxiter,
                 "maxfev": 4 * options.maxiter, "initial_simplex": simplex},
    )
    return res, s


def _fit_one(d: _Design, mu: float, method: str, options: FitOptions, subject: str, labels,
             x0=None) -> TrialFit:
    name = options.objective
    if method == "lstsq":
        if name != "nmse":
            raise ValueError(
                "method='lstsq' minimises the conventional NMSE (least squares); "
                f"objective={name!r} has no closed form: use method='nelder-mead'"
            )
        p_all, _, ok = d.lstsq_curve(np.array([mu]))
        p = p_all[0]
        if not ok[0]:
            msg = ("singular design: p0 and p1 are not separately identifiable (does the "
                   "contact reach the sloped part of the feature?)")
            success = False
        else:
            success, msg = True, "closed-form least squares"
            if d.median_on == "estimate" and d.k > 1:
                msg += " (median filter applied to the basis, an approximation in 'estimate' mode)"
        n_iter = n_fev = 0
    else:
        res, s = _nelder_mead(d, mu, options, x0)
        p = s * res.x
        success, msg = bool(res.success), str(res.message)
        n_iter, n_fev = int(res.nit), int(res.nfev)
        if not np.all(np.isfinite(p)) or not math.isfinite(float(res.fun)):
            success, msg = False, f"Nelder-Mead ended at a non-finite point/objective: {msg}"
    p = np.asarray(p, dtype=float)
    if success and p[0] < 0:
        success = False
        msg = f"p0 = {p[0]:.4g} N/mm < 0 is unphysical (fit of {method}); {msg}"
    est = d.estimate(mu, p) if np.all(np.isfinite(p)) else np.full(d.n, np.nan)
    if np.all(np.isfinite(est)):
        obj = (nmse if name == "nmse" else nmse_eq5)(d.F, est)
    else:
        obj = math.inf
    if not success:  # reported once per subject by paper_flags and the fit stage, never per fit
        log.debug("fit failed (subject %s, %s, mu=%g): %s", subject, labels.get("trial", ""), mu, msg)
    return TrialFit(mu=float(mu), p0=float(p[0]), p1=float(p[1]), objective=float(obj),
                    objective_name=name, method=method, success=success, message=msg,
                    n_iter=n_iter, n_fev=n_fev, measured=d.F, estimate=est,
                    subject=subject, labels=dict(labels))


def _check_method(method: str) -> str:
    return check_option("method", method, METHODS)


def fit_trial(trial: Trial, mu: float, *, method: str = "lstsq",
              options: FitOptions | None = None) -> TrialFit:
    """Fit ``p0, p1`` of Eq. (4) to one trial at a fixed ``mu``.

    Parameters
    ----------
    trial : Trial
    mu : float
        Coefficient of friction (dimensionless).
    method : {'lstsq', 'nelder-mead'}
        Closed-form least squares (conventional NMSE only) or Nelder-Mead on the chosen
        objective (as the paper does).
    options : FitOptions, optional

    Returns
    -------
    TrialFit
        ``success`` is False (with a message) for a singular design, a non-converged
        simplex or an unphysical ``p0 < 0``; never a silent number.

    Examples
    --------
    >>> from fingerfriction.testing import synthetic_trial
    >>> import numpy as np
    >>> t = synthetic_trial("bump-2mm", mu=0.55, p0=0.1, p1=0.3, rng=np.random.default_rng(0))
    >>> r = fit_trial(t, 0.55, options=FitOptions(median_kernel=1))
    >>> bool(r.success), round(r.p0, 2), round(r.p1, 1)
    (True, 0.1, 0.3)
    """
    if not isinstance(trial, Trial):
        raise TypeError(f"trial must be a fingerfriction.fit.Trial, got {type(trial).__name__}")
    options = options or FitOptions()
    _check_method(method)
    FrictionParams(mu=mu, p0=0.0, p1=0.0)  # validates mu
    return _fit_one(_Design(trial, options), float(mu), method, options, trial.subject, fit_labels(trial))


def _checked_grid(grid) -> np.ndarray:
    """The ``mu`` grid as a 1-D array (default :func:`mu_grid`), checked."""
    mus = mu_grid() if grid is None else np.asarray(grid, dtype=float).reshape(-1)
    if mus.size == 0 or not np.all(np.isfinite(mus)) or np.any(mus < 0) or np.any(mus > 5):
        raise ValueError(f"grid must be non-empty finite mu values in [0, 5], got {mus!r}")
    return mus


def _objective_curve(d: _Design, mus: np.ndarray, method: str, options: FitOptions) -> np.ndarray:
    """One trial's objective at every ``mu`` of the grid (``p0, p1`` refitted at each; inf
    where the fit fails)."""
    if method == "lstsq":
        return d.lstsq_curve(mus)[1]
    # One simplex per grid point, each warm-started from the previous point's solution.
    obj = np.empty(mus.size)
    prev = None
    for i, m in enumerate(mus):
        res, sc = _nelder_mead(d, float(m), options, prev)
        ok = bool(res.success) and math.isfinite(float(res.fun))
        obj[i] = float(res.fun) if ok else math.inf
        prev = sc * res.x if ok else None
    return obj


def fit_subject(trials: Sequence[Trial], *, grid=None, method: str = "lstsq",
                options: FitOptions | None = None, refine: bool = False) -> SubjectFit:
    """Per-subject ``mu`` by grid search, refitting ``p0, p1`` per trial at each ``mu``.

    Parameters
    ----------
    trials : sequence of Trial
        All trials of one subject (any surfaces).
    grid : (m,) array_like, optional
        ``mu`` values to try; default :func:`mu_grid` (0.30..0.90 by 0.01, 61 values).
    method : {'lstsq', 'nelder-mead'}
        How ``p0, p1`` are fitted at every grid point. The closed form is vectorised over
        the grid (two :meth:`FrictionModel.basis` calls per trial, exact because the basis
        is affine in ``mu``); Nelder-Mead runs once per trial per grid point.
    options : FitOptions, optional
    refine : bool
        If True, refine ``mu`` below the grid step by the vertex of the parabola through
        the minimum and its two neighbours (then refit every trial at that ``mu``). The
        paper reports the grid value (False, the default).

    Returns
    -------
    SubjectFit

    Notes
    -----
    ``F = p0 mu K + (p0 + p1 mu) S + p1 Q`` (see :class:`_Design`): with ``p0, p1`` free per
    trial, ``mu`` is identified only by the consistency of the three per-frame integrals
    across the trial, mostly through variations of the contact length (``K``). When the
    contact length hardly varies, the summed objective is nearly flat in ``mu`` and, under
    noise, the selected ``mu`` can be far from the truth, while noise-free trials give the
    true value exactly; a contact length that varies over the trial pins it
    (``tests/fit/test_fit.py``; the figures of both cases are in ``docs/fit.md``). Inspect
    ``curve`` before trusting ``mu``.
    """
    options = options or FitOptions()
    _check_method(method)
    trials, subject = one_subject(trials, caller="fit_subject", purpose="fit a subject's mu",
                                   group="fit_trials")
    mus = _checked_grid(grid)
    if method == "lstsq" and options.objective != "nmse":
        raise ValueError(
            f"method='lstsq' minimises the conventional NMSE; objective={options.objective!r} "
            "needs method='nelder-mead'"
        )
    models: dict[Surface, FrictionModel] = {}
    designs = []
    for t in trials:
        if t.surface not in models:  # RaisedCosine hashes by value, SampledProfile by identity
            models[t.surface] = FrictionModel(t.surface)
        designs.append(_Design(t, options, models[t.surface]))
    curve = sum(_objective_curve(d, mus, method, options) for d in designs)
    if not np.any(np.isfinite(curve)):
        j = 0
    else:
        j = int(np.nanargmin(np.where(np.isfinite(curve), curve, np.nan)))
    mu = float(mus[j])
    if refine and 0 < j < mus.size - 1 and np.all(np.isfinite(curve[j - 1 : j + 2])):
        mu = _parabola_vertex(mus[j - 1 : j + 2], curve[j - 1 : j + 2])
    fits = tuple(
        _fit_one(d, mu, method, options, t.subject, fit_labels(t))
        for d, t in zip(designs, trials, strict=True)
    )
    n_bad = sum(not f.success for f in fits)
    success, parts = True, [f"mu = {mu:g} minimises the summed {options.objective} over {len(trials)} trials"]
    if not np.isfinite(curve[j]):
        success = False
        parts.append("the objective is not finite at any grid point")
    if mus.size > 1 and j in (0, mus.size - 1):
        success = False
        parts.append(f"the minimum is at the end of the grid [{mus[0]:g}, {mus[-1]:g}]: widen the grid")
    if n_bad:
        success = False
        parts.append(f"{n_bad} of {len(fits)} trial fits failed")
    if mu != float(mus[j]):
        parts.append(f"refined from the grid value {mus[j]:g} by a parabola through 3 grid points")
    return SubjectFit(subject=subject, mu=mu, grid=mus, curve=curve, trials=fits,
                      success=success, message="; ".join(parts), method=method)


def _parabola_vertex(x: np.ndarray, y: np.ndarray) -> float:
    """Abscissa of the vertex of the parabola through three points, clipped to their span."""
    (x0, x1, x2), (y0, y1, y2) = x, y
    num = (x1 - x0) ** 2 * (y1 - y2) - (x1 - x2) ** 2 * (y1 - y0)
    den = (x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0)
    if den == 0 or not math.isfinite(num / den):
        return float(x1)
    return float(np.clip(x1 - 0.5 * num / den, x0, x2))


def fit_trials(trials: Sequence[Trial], *, grid=None, method: str = "lstsq",
               options: FitOptions | None = None, refine: bool = False) -> dict[str, SubjectFit]:
    """:func:`fit_subject` for every subject present in ``trials`` (keyed by subject)."""
    return {s: fit_subject(ts, grid=grid, method=method, options=options, refine=refine)
            for s, ts in sorted(by_subject(trials).items())}


def paper_flags(fit: SubjectFit) -> list[FitFlag]:
    """The flags of a paper-variant subject fit: what makes its parameters unusable.

    * ``mu-at-grid-edge`` (error): the grid minimum is at an end of the grid, so the
      optimum may lie outside it;
    * ``mu-not-identifiable`` (warning): Eq. (4) is exactly invariant under
      ``(mu, p0, p1) -> (p0/p1, p1 mu, p1)`` (see
      :func:`fingerfriction.pipeline.validation.leave_one_surface_out`),
      and the flat-segment detrend removes most of the ``cos alpha`` term that would pin
      ``mu``; flagged when the summed objective varies by less than 5 % over the grid;
    * ``negative-p0`` and ``fit-failed`` (error), one per trial: an unphysical pressure
      or a fit that did not converge.

    Parameters
    ----------
    fit : SubjectFit

    Returns
    -------
    list of FitFlag
    """
    out: list[FitFlag] = []
    s = fit.subject
    g, c = np.asarray(fit.grid), np.asarray(fit.curve)
    fin = np.isfinite(c)
    if g.size > 1 and fin.any():
        j = int(np.nanargmin(np.where(fin, c, np.nan)))
        if j in (0, g.size - 1):
            out.append(fit_flag("error", "mu-at-grid-edge", s, "", "paper",
                               f"mu = {fit.mu:.3f} is at the end of the grid [{g[0]:.2f}, {g[-1]:.2f}]: "
                               "the objective may still fall outside it"))
        lo, hi = float(np.min(c[fin])), float(np.max(c[fin]))
        if hi <= 1.05 * lo:
            out.append(fit_flag("warning", "mu-not-identifiable", s, "", "paper",
                               f"the summed objective changes by {100 * (hi / lo - 1):.1f} % over mu in "
                               f"[{g[0]:.2f}, {g[-1]:.2f}]: mu is not identified by these forces"))
    for tf in fit.trials:
        tid = str(tf.labels.get("trial", ""))
        if not tf.success:
            if tf.p0 < 0:
                out.append(fit_flag("error", "negative-p0", s, tid, "paper",
                                   f"p0 = {tf.p0:.3g} N/mm < 0: an unphysical (negative) pressure"))
            else:
                out.append(fit_flag("error", "fit-failed", s, tid, "paper", tf.message))
    return out
