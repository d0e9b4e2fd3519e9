"""Calibrate a subject's finger from recorded contact regions.

The forward model (:mod:`~fingerfriction.mechanics.bem`) knows the fingers it is given.
This module finds the finger of a recorded subject: the shape and modulus parameters of
the :class:`~fingerfriction.mechanics.finger.FingerParams` family (by default the
stadium pad's end radius ``R``, effective modulus ``E*`` and flat length ``L``) for which
the model's **geometric** contact (surface points within ``tol`` = 3 px, ~70 um, of the
deformed finger: the paper's criterion, Methods "Image analysis") reproduces the contact
regions measured in every frame, at the frame's finger position and measured normal force.
It is a pure function of arrays (no file I/O); :mod:`fingerfriction.pipeline.finger_calibration`
reads a results folder into :class:`CalibrationTrial` objects.

What is identifiable
--------------------
The contact of the plane-strain model depends on the load and the modulus only through
``P' / E* = F_N / (D E*)`` (``D``: the effective finger width, ``P'`` the load per width).
``D`` is therefore held at the initial finger's value (10 mm for the defaults) and ``E*``
is fitted: the fitted ``E*`` is an *effective* modulus for that ``D``, and the load per
width the calibration implies is ``P' = F_N / D``. A study without absolute normal force
can only give ``E*`` relative to an assumed load (``load=`` in
:func:`fingerfriction.pipeline.finger_calibration.trials_from_results`; the result is flagged).

The mismatch (smooth by construction)
-------------------------------------
Per frame, with ``d(s)`` the model's distance from the surface point at ``s`` to the
deformed finger (vertical gap times ``1 / sqrt(1 + y_f'^2)``: the normal distance to first
order, as the video's Euclidean 3-px test) and ``[a_k, b_k]`` the measured regions:

* one residual per measured region end ``e``: ``(d(e) - tol) / sqrt(d'(e)^2 + s_min^2)``,
  a Newton estimate of how far (mm) the model's edge is from the measured one;
* one hinge per measured region interior, ``max(0, max d - tol) / s_0`` (the model
  opens a gap where contact was seen), and per measured gap or exterior span,
  ``max(0, tol - min d) / s_0`` (the model touches where no contact was seen); these
  catch regions the model has and the video has not, and vice versa.

Every residual is a continuous, piecewise-smooth function of the parameters: the model's
grid is fixed for the whole calibration (cells at ``x + u_i``, ``u`` fixed), outlines are
interpolated bilinearly in position and load (as the simulator's contact tables are) with
weights that depend on the data only, and the contact solution of the BEM is continuous in
its parameters. A count of mismatched pixels would be piecewise constant, which no
gradient-based optimiser can use. ``scipy.optimize.least_squares`` (trust-region
reflective, bounds, ``soft_l1`` loss against the video's occasional fragment or outlier)
minimises it over ``log(p / p_initial)``; the Jacobian is by forward differences, each
perturbed sweep warm-started from the base sweep's pressures at the same positions.

Cost
----
Every evaluation runs, per surface and per tabulated load, one warm-started BEM sweep
over the finger positions that can touch the feature. A coarse pass (positions every
``coarse_step`` mm, every ``coarse_stride``-th frame, a wider ``soft`` scale) brings the
parameters near the optimum; a fine pass (``fine_step``, all frames) finishes. The
:class:`FingerCalibration` records the CPU time per stage and the number of solves.

Uncertainty
-----------
A stratified cluster bootstrap over trials (trials resampled with replacement within each
surface; seeded), linearised: each replicate takes one weighted Gauss-Newton step from the
optimum with the residuals and Jacobian at the optimum (frames of one trial share its
finger-position and force errors, so trials, not frames, are the independent units).
"""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from .._check import check_option
from ..regions import as_regions
from ..surfaces import Surface
from ._calibration_problem import (
    CalibrationProblem,
    ResidualOptions,
    bootstrap_spread,
    end_bias_sensitivity,
    identification_flags,
    make_fun_jac,
)
from .bem import GEOMETRIC_TOL
from .finger import FingerParams
from .surface_fit import SurfaceFit, surface_fits

__all__ = ["CalibrationTrial", "CalibrationOptions", "FingerCalibration", "SurfaceFit",
           "CalibrationError", "calibrate_finger", "FIT_FIELDS"]

log = logging.getLogger(__name__)

#: Parameters the calibration can fit (all positive, fitted as ``log(p / p_initial)``).
FIT_FIELDS = ("radius", "modulus", "flat_length")


class CalibrationError(ValueError):
    """The data cannot calibrate a finger (too few trials, no contact regions, ...)."""


# ------------------------------------------------------------------------------ inputs
@dataclass(frozen=True)
class CalibrationTrial:
    """The measured contact of one trial.

    Parameters
    ----------
    surface : Surface
        The relief.
    x : (n_frames,) ndarray
        Finger-centre position per frame in mm (NaN: frame unused).
    regions : (n_frames, n_max, 2) ndarray
        Measured contact regions in mm (:mod:`fingerfriction.regions` format).
    load : (n_frames,) ndarray
        Normal force ``F_N`` in N at each frame (NaN or <= 0: frame unused).
    label : str
        Trial id (named in messages).
    tol : float
        The trial's contact tolerance in mm (3 px of its calibrated pixel size; default
        :data:`~fingerfriction.mechanics.bem.GEOMETRIC_TOL`).
    min_gap, min_region : float
        The measurement's cleanup in mm (the video analysis bridges gaps shorter than
        ``min_gap`` and drops regions shorter than ``min_region``); applied to the model's
        regions too when they are compared with the measured ones (blind spots). Default 0.
    """

    surface: Surface
    x: np.ndarray
    regions: np.ndarray
    load: np.ndarray
    label: str = ""
    tol: float = GEOMETRIC_TOL
    min_gap: float = 0.0
    min_region: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.surface, Surface):
            raise TypeError(
                f"trial {self.label!r}: surface must be a Surface, got {type(self.surface).__name__}"
            )
        x = np.asarray(self.x, dtype=float).ravel()
        reg = as_regions(self.regions, name=f"trial {self.label!r} regions")
        ld = np.asarray(self.load, dtype=float).ravel()
        if reg.shape[0] != x.size or ld.size != x.size:
            raise ValueError(
                f"trial {self.label!r}: x has {x.size} frames, regions {reg.shape[0]}, load {ld.size}; "
                "they must be equal"
            )
        if not (math.isfinite(self.tol) and 0 < self.tol < 1):
            raise ValueError(f"trial {self.label!r}: tol must be a contact tolerance in mm in (0, 1), "
                             f"got {self.tol!r}")
        object.__setattr__(self, "x", x)
        object.__setattr__(self, "regions", reg)
        object.__setattr__(self, "load", ld)
        object.__setattr__(self, "tol", float(self.tol))
        for name in ("min_gap", "min_region"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"trial {self.label!r}: {name} must be a length >= 0 in mm, got {v!r}")
            object.__setattr__(self, name, float(v))

    def usable(self) -> np.ndarray:
        """Frames with a finite position, a positive load and a region, ``(n_frames,)`` bool."""
        with np.errstate(invalid="ignore"):
            pos = self.load > 0
        return np.isfinite(self.x) & pos & ~np.isnan(self.regions[:, 0, 0])


@dataclass(frozen=True)
class CalibrationOptions(ResidualOptions):
    """Settings of :func:`calibrate_finger` (defaults measured in ``benchmarks/calibrate.py``).

    Parameters
    ----------
    fit : tuple of str
        Parameters fitted, a subset of :data:`FIT_FIELDS`; the others keep the initial
        finger's values.
    dx : float
        Target cell size of the BEM grid in mm (default 0.045, the simulator's ~0.046).
    clearance : float
        The grid spans the initial outline out to where it has risen this much, in mm
        (default 2.0: margin for blunter fingers than the initial one).
    coarse_step, fine_step : float
        Finger-position step in mm of the contact tables of the two passes.
    coarse_stride : int
        The coarse pass uses every ``coarse_stride``-th usable frame.
    n_loads : int
        Tabulated normal loads (quantiles 2 %, ..., 98 % of the frames' loads); frames
        interpolate linearly between them.
    coarse_soft, fine_soft : float
        ``f_scale`` (mm) of the soft-L1 loss in each pass: residuals beyond it count
        linearly, not quadratically.
    s_min : float
        Floor of ``|d'(e)|`` in the end residuals (dimensionless slope).
    s_0 : float
        Slope converting hinge residuals (mm of distance) into mm of position.
    bound : float
        Each fitted parameter stays within ``[p0 / bound, p0 * bound]``.
    diff_step : float
        Forward-difference step in ``log p`` for the Jacobian.
    max_nfev : int
        Evaluations per pass.
    solver_tol : float
        Tolerance of each BEM solve.
    warm_start : {'positions', 'parameters', 'none'}
        How each BEM solve starts: ``'positions'`` (default) from the previous position's
        pressure, linearly extrapolated, as :func:`~.sweep.sweep` does; ``'parameters'``
        from the last base sweep's pressure at the same position (previous parameters,
        same grid cells). The positions' start needs fewer CG iterations per solve
        (``benchmarks/calibrate.py``, figures in ``docs/mechanics.md``), so it is the
        default.
        ``'none'``: every solve starts cold (a reference for the benchmark).
    end_bias_px : float
        Size in px of the per-end widening of the measured regions whose effect on the
        parameters is reported as a systematic sensitivity (default 0.5 px).
    bootstrap : int
        Bootstrap replicates for the uncertainties.
    seed : int
        Seed of the bootstrap.
    min_trials : int
        Fewer usable trials than this is an error.
    min_frames : int
        Fewer usable frames than this is an error.
    max_rel_std : float
        A parameter whose bootstrap standard deviation exceeds this fraction of its value
        is flagged as poorly identified.
    """

    fit: tuple = FIT_FIELDS
    dx: float = 0.045
    clearance: float = 2.0
    coarse_step: float = 0.2
    fine_step: float = 0.05
    n_loads: int = 3
    bound: float = 2.0
    solver_tol: float = 1e-6
    warm_start: str = "positions"

    def __post_init__(self) -> None:
        fit = tuple(self.fit)
        if not fit or any(f not in FIT_FIELDS for f in fit) or len(set(fit)) != len(fit):
            raise ValueError(f"fit must be a non-empty subset of {FIT_FIELDS}, got {self.fit!r}")
        object.__setattr__(self, "fit", fit)
        self.check_shared(floats=("dx", "clearance", "coarse_step", "fine_step", "solver_tol"),
                          ints=(("n_loads", 1),))
        check_option("CalibrationOptions.warm_start", self.warm_start, ("positions", "parameters", "none"))
        if not self.bound > 1:
            raise ValueError(f"CalibrationOptions.bound must be > 1, got {self.bound!r}")


# ------------------------------------------------------------------------------ result
@dataclass
class FingerCalibration:
    """Result of :func:`calibrate_finger` (in the style of ``scipy.optimize.OptimizeResult``).

    Attributes
    ----------
    finger : FingerParams
        The calibrated finger.
    initial : FingerParams
        Where the fit started (and the fixed parameters' source).
    fitted : tuple of str
        Names of the fitted parameters.
    std : dict
        Bootstrap standard deviation of each fitted parameter (its unit).
    ci95 : dict
        Bootstrap 2.5 and 97.5 percentiles of each fitted parameter.
    systematic : dict
        Change of each fitted parameter (its unit) if every measured region were
        ``options.end_bias_px`` px wider at each end (linearised at the optimum): the
        bootstrap sees only trial-to-trial scatter, not a bias shared by all frames of
        the video analysis, which dominates on simulated studies.
    load_per_width : float
        ``P' = median F_N / D`` in N/mm.
    load_median : float
        Median normal force of the frames used, in N.
    surfaces : list of SurfaceFit
    success : bool
        The optimiser converged, no parameter sits at its bound, every BEM solve at the
        optimum converged.
    message : str
    flags : list of str
        Reasons to doubt the result (each one line); empty when there are none.
    n_trials, n_frames : int
    nfev : dict
        Evaluations per pass.
    n_solves : int
        BEM solves in total; ``cg_iterations`` their conjugate-gradient iterations.
    timings : dict
        CPU seconds per stage (``'prepare', 'bem', 'residuals', 'bootstrap', 'predict'``),
        per pass (``'coarse_pass', 'fine_pass'``: optimiser, BEM and residuals) and
        ``'total'``.
    cost : float
        Final robust cost of the fine pass.
    surrogate_rms_mm : float
        FE calibrations (:func:`fingerfriction.mechanics.fe.calibration.calibrate_fe_finger`):
        RMS difference (mm) of the end-point residuals of the surrogate and of the exact FE
        finger at the optimum (NaN: not verified, or a half-space calibration).
    position_offset_mm : float
        FE calibrations with ``position_offset``: the fitted offset (mm) of the model finger's
        reference point from the tracked position (the model finger sits at the tracked x
        plus this); its spread is ``std['position_offset']``. NaN: not fitted.
    """

    finger: FingerParams
    initial: FingerParams
    fitted: tuple
    std: dict
    ci95: dict
    systematic: dict
    load_per_width: float
    load_median: float
    surfaces: list
    success: bool
    message: str
    flags: list = field(default_factory=list)
    n_trials: int = 0
    n_frames: int = 0
    nfev: dict = field(default_factory=dict)
    n_solves: int = 0
    cg_iterations: int = 0
    timings: dict = field(default_factory=dict)
    cost: float = math.nan
    options: CalibrationOptions | None = field(default=None, repr=False)
    surrogate_rms_mm: float = math.nan
    position_offset_mm: float = math.nan

    def summary(self) -> str:
        """The result as plain-text tables: parameters, then per-surface figures and flags."""
        lines = [f"finger calibration: {self.message}; {self.n_trials} trials, {self.n_frames} frames",
                 f"{'parameter':22s} {'start':>9s} {'calibrated':>11s} {'bootstrap std':>13s} "
                 f"{'95 % interval':>19s} {'+0.5 px ends':>12s}"]
        for f in self.fitted:
            lo, hi = self.ci95[f]
            unit = "MPa" if "modulus" in f else "mm"
            lines.append(f"{f + ' (' + unit + ')':22s} {getattr(self.initial, f):9.4g} "
                         f"{getattr(self.finger, f):11.4g} {self.std[f]:13.2g} {lo:9.4g}..{hi:<9.4g} "
                         f"{self.systematic[f]:+12.2g}")
        if math.isfinite(self.position_offset_mm):
            lo, hi = self.ci95.get("position_offset", (math.nan, math.nan))
            lines.append(f"{'position offset (mm)':22s} {0.0:9.4g} {self.position_offset_mm:11.4g} "
                         f"{self.std.get('position_offset', math.nan):13.2g} {lo:9.4g}..{hi:<9.4g} "
                         f"{self.systematic.get('position_offset', math.nan):+12.2g}")
        if math.isfinite(self.surrogate_rms_mm):
            lines.append(f"FE surrogate against the exact FE finger at the optimum: end points differ by "
                         f"{self.surrogate_rms_mm:.4f} mm RMS")
        lines.append(f"load per width P' = {self.load_per_width:.4f} N/mm (median F_N "
                     f"{self.load_median:.3f} N, D = {self.finger.width:g} mm fixed)")
        lines.append(f"{'surface':14s} {'frames':>6s} {'end rms mm':>10s}  "
                     "blind spots measured -> predicted (mm)")
        for s in self.surfaces:
            txt = ", ".join(f"{m:.3f} -> {p:.3f}" for m, p in s.blind_spot_pairs()) or "none"
            lines.append(f"{s.surface:14s} {s.n_frames:6d} {s.rms_end_mm:10.4f}  {txt}")
        lines += [f"flag: {f}" for f in self.flags]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """JSON-ready provenance (what ``calibrate-finger`` stores in the finger file)."""
        return {
            "success": self.success, "message": self.message, "flags": list(self.flags),
            "fitted": list(self.fitted),
            "parameters": {k: float(getattr(self.finger, k)) for k in self.fitted},
            "std": {k: float(v) for k, v in self.std.items()},
            "ci95": {k: [float(a), float(b)] for k, (a, b) in self.ci95.items()},
            "systematic_per_end_bias": {k: float(v) for k, v in self.systematic.items()},
            "initial": self.initial.to_dict(),
            "width_mm_fixed": float(self.finger.width),
            "load_median_N": self.load_median, "load_per_width_N_per_mm": self.load_per_width,
            "n_trials": self.n_trials, "n_frames": self.n_frames, "nfev": dict(self.nfev),
            "n_solves": self.n_solves, "cg_iterations": self.cg_iterations,
            "cpu_s": {k: round(float(v), 3) for k, v in self.timings.items()},
            "surfaces": [s.to_dict() for s in self.surfaces],
            "options": dataclasses.asdict(self.options) if self.options is not None else None,
            **({"surrogate_rms_mm": self.surrogate_rms_mm} if math.isfinite(self.surrogate_rms_mm) else {}),
            **({"position_offset_mm": self.position_offset_mm}
               if math.isfinite(self.position_offset_mm) else {}),
        }


# ------------------------------------------------------------------------------ public
def calibrate_finger(trials, initial: FingerParams, *, options: CalibrationOptions | None = None
                     ) -> FingerCalibration:
    """Fit a subject's finger to its measured contact regions.

    Parameters
    ----------
    trials : sequence of CalibrationTrial
        The subject's trials (any surfaces; all should be the same subject).
    initial : FingerParams
        Starting finger; its family (shape), width ``D`` and unfitted parameters are kept.
        For the default fit it must be a circle with ``flat_length > 0`` (a stadium).
    options : CalibrationOptions, optional

    Returns
    -------
    FingerCalibration
        ``success=False`` with a message (and ``flags``) when the fit did not converge,
        hit a bound or a contact solve failed; check it before using the finger.

    Raises
    ------
    CalibrationError
        Too few usable trials or frames, no contact regions.
    TypeError, ValueError
        Bad arguments.

    Notes
    -----
    See the module notes for the mismatch, the optimiser and the uncertainties.
    """
    T0 = time.process_time()
    opts = options or CalibrationOptions()
    trials = _check_inputs(trials, initial, opts)
    pb = CalibrationProblem(trials, initial, opts)
    if pb.n_trials < opts.min_trials:
        raise CalibrationError(
            f"only {pb.n_trials} trial(s) with usable contact regions (need at least {opts.min_trials}); "
            "a finger calibrated on so little data would be a guess"
        )
    if pb.n_frames < opts.min_frames:
        raise CalibrationError(
            f"only {pb.n_frames} usable frames (need at least {opts.min_frames}): frames need a finite "
            "position, a normal force and a contact region"
        )
    t_prep = time.process_time() - T0
    z, fine, fun, jac, state, nfev, pass_cpu = optimise(pb, opts)
    finger = pb.finger(z)

    # residuals and Jacobian at the optimum (for the bootstrap and the per-surface figures;
    # reused from the fine pass when it evaluated them there)
    r0 = fun(z)
    failures = pb.last_failures
    J = jac(z)
    t_b = time.process_time()
    std, ci = bootstrap_spread(pb, z, r0, J, opts)
    systematic = end_bias_sensitivity(pb, z, r0, J, state["gain"], opts)
    t_boot = time.process_time() - t_b
    t_p = time.process_time()
    surfaces = surface_fits(pb, state["tabs"], r0)
    t_pred = time.process_time() - t_p

    success, message, flags = _assess(fine, z, failures, finger, std, surfaces, opts)
    timings = {
        "prepare": t_prep, "bem": pb.t_bem, "residuals": pb.t_res, "bootstrap": t_boot,
        "predict": t_pred, "coarse_pass": pass_cpu["coarse"], "fine_pass": pass_cpu["fine"],
        "total": time.process_time() - T0,
    }
    return FingerCalibration(
        finger=finger, initial=initial, fitted=opts.fit, std=std, ci95=ci, systematic=systematic,
        load_per_width=pb.load_median / finger.width, load_median=pb.load_median, surfaces=surfaces,
        success=success, message=message, flags=flags, n_trials=pb.n_trials, n_frames=pb.n_frames,
        nfev=nfev, n_solves=pb.n_solves, cg_iterations=pb.cg_iterations, timings=timings,
        cost=float(fine.cost), options=opts,
    )


def _check_inputs(trials, initial, opts: CalibrationOptions) -> list[CalibrationTrial]:
    if not isinstance(initial, FingerParams):
        raise TypeError(f"initial must be a FingerParams, got {type(initial).__name__}")
    if initial.shape != "circle" or initial.layer_thickness is not None or initial.has_skin:
        raise ValueError("calibration supports the circle/stadium half-space finger family, got "
                         f"shape={initial.shape!r}, layer_thickness={initial.layer_thickness!r}, "
                         f"skin={initial.has_skin}")
    for f in opts.fit:
        if float(getattr(initial, f)) <= 0:
            raise ValueError(f"initial {f} must be > 0 to be fitted (fitted as log({f})), got "
                             f"{getattr(initial, f)!r}")
    trials = list(trials)
    for t in trials:
        if not isinstance(t, CalibrationTrial):
            raise TypeError(f"trials must be CalibrationTrial objects, got {type(t).__name__}")
    if not trials:
        raise CalibrationError("no trials given: nothing to calibrate on")
    if not any(t.usable().any() for t in trials):
        raise CalibrationError("no trial has a usable frame (finite position, positive load, at least "
                               "one contact region): nothing to calibrate on")
    return trials


def optimise(pb: CalibrationProblem, opts, bounds: tuple | None = None, z0=None):
    """The coarse then the fine least-squares pass, from ``z0`` (default the initial finger,
    z = 0), within ``bounds`` (``(lower, upper)`` arrays of ``z = log(p / p_initial)``;
    default ``+-log(opts.bound)``). Returns ``(z, fine result, fun, jac, state, nfev,
    pass_cpu)``."""
    lb, ub = bounds if bounds is not None else (np.full(len(opts.fit), -math.log(opts.bound)),
                                                np.full(len(opts.fit), math.log(opts.bound)))
    z = np.zeros(len(lb)) if z0 is None else np.clip(np.asarray(z0, float), lb, ub)
    nfev, pass_cpu = {}, {}
    for level, step, soft in (("coarse", opts.coarse_step, opts.coarse_soft),
                              ("fine", opts.fine_step, opts.fine_soft)):
        fun, jac, state = make_fun_jac(pb, level, step)
        t_pass = time.process_time()
        r = least_squares(fun, z, jac=jac, bounds=(lb, ub), loss="soft_l1", f_scale=soft,
                          x_scale=1.0, max_nfev=opts.evaluations(), xtol=1e-4, ftol=1e-6, gtol=1e-8)
        nfev[level] = int(r.nfev)
        pass_cpu[level] = time.process_time() - t_pass
        z = r.x
        log.info("calibration %s pass: %s, z=%s, cost %.4g", level, r.message, np.round(z, 4), r.cost)
    return z, r, fun, jac, state, nfev, pass_cpu


def _assess(fine, z, failures: int, finger: FingerParams, std: dict, surfaces, opts: CalibrationOptions):
    """``(success, message, flags)`` of a finished calibration."""
    flags = []
    msg_parts = []
    success = bool(fine.status > 0)
    if not success:
        msg_parts.append(f"the optimiser did not converge ({fine.message})")
    at_bound = [f for f, zi in zip(opts.fit, z, strict=True) if abs(abs(zi) - math.log(opts.bound)) < 1e-3]
    if at_bound:
        success = False
        msg_parts.append(f"parameter(s) {', '.join(at_bound)} at the bound (x{opts.bound:g} / {opts.bound:g} "
                         "of the initial finger): the data want a finger outside the searched range")
    if failures:
        success = False
        msg_parts.append(f"{failures} contact solve(s) did not converge at the optimum")
    flags.extend(identification_flags(opts.fit, finger, std, opts.max_rel_std, surfaces))
    message = "; ".join(msg_parts) if msg_parts else f"converged ({fine.message})"
    return success, message, flags
