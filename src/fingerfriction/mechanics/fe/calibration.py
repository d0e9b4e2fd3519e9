"""Calibrate a subject's layered FE finger from recorded contact regions.

The FE family's counterpart of :func:`fingerfriction.mechanics.calibrate.calibrate_finger`:
the same measured frames, the same residuals (model edge against measured edge, hinges
where the model and the video disagree, ``mechanics/calibrate.py``'s notes), the same
robust least squares, bootstrap and per-surface figures; only the forward model differs: the
surrogate of cached FE tables of :mod:`.surrogate` (a grid of fingers around the initial
one, interpolated in the fitted parameters).

A moving grid: the nodes span a fixed range around the grid's centre, but a subject's finger
need not lie within it (the drawn fingers of a study's subject 2 are drawn around a larger
default finger than the literature one; a real subject may be anywhere in the literature's
range). When the optimum sits at the grid's edge in some field, the grid moves: its centre
becomes the edge node in those fields (the others keep theirs), the new nodes' tables are
solved (or read from the cache: the moved grid shares its centre node and, on a star grid,
the other fields' nodes' outlines are new), and the fit starts again from the new centre; at
most ``max_shifts`` times (an optimum that the surrogate's corrections, below, take to the
edge moves it too). A fit still at the edge after that is not a success. The reported
``initial`` stays the given finger; the message says where the grid moved.

With ``verify`` (default) the FE finger at the optimum is solved exactly (one more set of
tables) and the per-surface figures (end-point RMS, blind spots measured -> predicted) are
those of the exact finger; the surrogate's error at the optimum is reported beside them.

A corrected surrogate: where the exact finger's end points differ from the surrogate's by
more than ``max_surrogate_mm`` at the optimum, the surrogate is corrected there by the
difference (from then on every interpolated table adds the exact finger's tables minus the
surrogate's at that optimum: the zeroth-order, additive correction of surrogate-based
optimisation, Eldred, Giunta & Collis 2004, AIAA 2004-4457), the fit runs again from that
optimum, and the new optimum is verified; at most ``corrections`` times. The corrected
surrogate is exact at the point it was corrected at, so a fit that ends there ends on the
exact finger's optimum to the surrogate's slope error. A step that makes the exact finger's
fit worse is not taken. Each correction costs one finger's tables, the same as the
verification, where a finer grid around the optimum would cost ``2k + 1``.
"""

from __future__ import annotations

import logging
import math
import time
from dataclasses import dataclass

import numpy as np

from ..._check import check_option
from .._calibration_problem import (
    ResidualOptions,
    bootstrap_spread,
    end_bias_sensitivity,
    identification_flags,
)
from ..calibrate import CalibrationError, CalibrationTrial, FingerCalibration, optimise
from ..surface_fit import surface_fits
from .params import FEFingerParams, FEMeshParams
from .surrogate import (
    FE_FIT_FIELDS,
    FECalibrationProblem,
    fe_tables,
    finger_with,
    grid_nodes,
    table_positions,
)

__all__ = ["FE_FIT_FIELDS", "FECalibrationOptions", "FECalibrationProblem", "calibrate_fe_finger",
           "finger_with", "fe_tables", "table_positions", "grid_nodes"]

log = logging.getLogger(__name__)

#: Least-squares evaluations per pass and fitted field when ``FECalibrationOptions.max_nfev``
#: is None (the budget before 2026-12-08 was a fixed 50 for the default two fields).
NFEV_PER_FIELD = 25


@dataclass(frozen=True)
class FECalibrationOptions(ResidualOptions):
    """Settings of :func:`calibrate_fe_finger` (the residual and bootstrap settings are those of
    :class:`fingerfriction.mechanics.calibrate.CalibrationOptions`).

    Parameters
    ----------
    fit : tuple of str
        Fields fitted, a subset of :data:`FE_FIT_FIELDS`. Default: the pulp's and the skin's
        moduli, the skin's thickness, the outline's radius and semi-height (the best five by
        the contact ends that include the skin's modulus, chosen without a study; with the
        tracked position's offset, validated on three finger seeds, docs/mechanics-fe.md).
    design : {'star', 'tensor'}
        The grid's nodes (module notes).
    levels : tuple of float
        Grid nodes of every fitted field, as ratios to the initial finger, increasing, with
        1 among them; the fit stays within the first and the last.
    loads : tuple of float
        Tabulated normal loads in N, increasing (frames interpolate linearly, and are clamped
        to the range).
    step : float
        Finger-position step of the tables in mm.
    grid_step : float
        Spacing in mm of the cells on which outlines are compared.
    clearance : float
        The cells span the initial outline out to where it has risen this much, in mm.
    mesh : FEMeshParams, optional
        Default :func:`~.provider.default_mesh` (``$FINGERFRICTION_FE_MESH``).
    workers : int
        Processes solving the grid's tables (1: in this process).
    verify : bool
        Solve the FE finger at the optimum exactly and report its per-surface figures.
    max_surrogate_mm : float
        A surrogate whose end-point residuals differ from the exact finger's by more than this
        (RMS, mm) at the optimum is flagged.
    max_shifts : int
        Times the grid may move when the optimum sits at its edge (module notes; default 2:
        with the default levels, ratios 0.42-2.4 of the initial finger are reachable, which
        spans the literature's ranges of docs/mechanics-fe.md from the literature finger).
        0: the grid stays where it is.
    corrections : int
        With ``verify``: times the surrogate may be corrected at a verified optimum whose
        surrogate error exceeds ``max_surrogate_mm`` and the fit run again (module notes);
        0: the surrogate's optimum is the result.
    position_offset : bool
        Also fit one constant offset (mm) between the tracked finger position and the model
        finger's reference point (the model finger sits at the tracked x plus it). The video's
        x(t) is the midpoint of the finger's chord 4 mm above the relief; a finger that leans
        against its motion under sliding friction is tracked behind the point its FE tables
        are indexed by (docs/mechanics-fe.md, 2026-12-08), and freed skin fields absorb the
        difference. On by default since 2026-12-08 (with the five fields: validated across
        model families on three finger seeds, docs/mechanics-fe.md).
    max_offset : float
        The offset is searched within +-this, in mm.
    max_nfev : int, optional
        Evaluations of the surrogate's residuals per least-squares pass; default
        :data:`NFEV_PER_FIELD` per fitted parameter (150 for the default five fields and the
        position offset). A budget
        that grows with the fitted fields, as scipy's own default (100 per variable) does:
        on 2026-12-07 two of seed 9167's held-out four-field fits stopped at a fixed 50
        (docs/mechanics-fe.md).
    """

    fit: tuple = ("tissue_modulus", "skin_modulus", "skin_thickness", "radius", "semi_height")
    design: str = "star"
    levels: tuple = (0.75, 1.0, 1.25)
    loads: tuple = (0.26, 0.34)
    step: float = 0.1
    grid_step: float = 0.04
    clearance: float = 2.0
    mesh: FEMeshParams | None = None
    workers: int = 1
    verify: bool = True
    max_surrogate_mm: float = 0.03
    max_shifts: int = 2
    corrections: int = 2
    position_offset: bool = True
    max_offset: float = 1.0
    max_nfev: int | None = None

    def evaluations(self) -> int:
        """``max_nfev``, or :data:`NFEV_PER_FIELD` per fitted field when it is None."""
        n = len(self.fit) + int(self.position_offset)
        return NFEV_PER_FIELD * n if self.max_nfev is None else self.max_nfev

    def __post_init__(self) -> None:
        own = "FECalibrationOptions"
        fit = tuple(self.fit)
        for f in fit:
            check_option(f"{own}.fit", f, FE_FIT_FIELDS)
        if not fit or len(set(fit)) != len(fit):
            raise ValueError(f"{own}.fit must be a non-empty subset of {FE_FIT_FIELDS}, got {self.fit!r}")
        object.__setattr__(self, "fit", fit)
        check_option(f"{own}.design", self.design, ("star", "tensor"))
        lv = np.asarray(self.levels, float)
        if lv.ndim != 1 or lv.size < 2 or not np.all(lv > 0) or np.any(np.diff(lv) <= 0) or 1.0 not in lv:
            raise ValueError(f"{own}.levels must be increasing positive ratios including 1, "
                             f"got {self.levels!r}")
        object.__setattr__(self, "levels", tuple(float(v) for v in lv))
        ld = np.asarray(self.loads, float)
        if ld.ndim != 1 or ld.size == 0 or not np.all(ld > 0) or np.any(np.diff(ld) <= 0):
            raise ValueError(f"{own}.loads must be increasing normal forces > 0 in N, got {self.loads!r}")
        object.__setattr__(self, "loads", tuple(float(v) for v in ld))
        if not isinstance(self.position_offset, bool):
            raise TypeError(f"{own}.position_offset must be True or False, got {self.position_offset!r}")
        self.check_shared(floats=("step", "grid_step", "clearance", "max_surrogate_mm", "max_offset"),
                          ints=(("workers", 1), ("max_shifts", 0), ("corrections", 0)),
                          optional=("max_nfev",))
        if self.mesh is not None and not isinstance(self.mesh, FEMeshParams):
            raise TypeError(f"{own}.mesh must be an FEMeshParams or None, got {type(self.mesh).__name__}")
        if not isinstance(self.verify, bool):
            raise TypeError(f"{own}.verify must be True or False, got {self.verify!r}")

    @property
    def coarse_step(self) -> float:
        """Both passes use the grid's tables, at :attr:`step` (the half-space passes differ)."""
        return self.step

    fine_step = coarse_step


def calibrate_fe_finger(trials, initial: FEFingerParams, *, options: FECalibrationOptions | None = None,
                        cache_dir=None, progress=None) -> FingerCalibration:
    """Fit a subject's layered FE finger to its measured contact regions.

    Parameters
    ----------
    trials : sequence of CalibrationTrial
        The subject's trials.
    initial : FEFingerParams
        The starting finger: the grid's centre; its unfitted fields and its sliding
        friction (:attr:`FEFingerParams.friction`, the traction the tables carry) are kept.
    options : FECalibrationOptions, optional
    cache_dir : path-like, optional
        The FE tables' cache (default :func:`~.provider.default_cache_dir`).
    progress : callable, optional
        ``progress(done, total)`` as the grid's tables are solved.

    Returns
    -------
    FingerCalibration
        Its ``finger`` an :class:`FEFingerParams`; ``success=False`` with a message when the
        optimiser did not converge or a parameter sits at the grid's edge; flags for a
        surrogate that departs from the exact finger, poorly identified parameters and
        surfaces the finger does not reproduce.

    Raises
    ------
    CalibrationError
        Too few usable trials or frames.
    TypeError, ValueError
        Bad arguments.
    """
    T0 = time.process_time()
    opts = options or FECalibrationOptions()
    if not isinstance(opts, FECalibrationOptions):
        raise TypeError(f"options must be FECalibrationOptions, got {type(opts).__name__}")
    if not isinstance(initial, FEFingerParams):
        raise TypeError(f"initial must be an FEFingerParams, got {type(initial).__name__}")
    trials = list(trials)
    for t in trials:
        if not isinstance(t, CalibrationTrial):
            raise TypeError(f"trials must be CalibrationTrial objects, got {type(t).__name__}")
    if not any(t.usable().any() for t in trials):
        raise CalibrationError("no trial has a usable frame (finite position, positive load, at least "
                               "one contact region): nothing to calibrate on")
    _check_grid(initial, opts)
    pb, opt, moves, t_build, ver, t_v = _fit_on_moving_grid(trials, initial, opts, cache_dir, progress)
    flags, surrogate_rms, exact, n_corr, first_rms, refused = [], math.nan, None, 0, math.nan, False
    if ver is not None:
        opt, exact, surrogate_rms, n_corr, first_rms, refused = ver
        if surrogate_rms > opts.max_surrogate_mm:
            flags.append(f"the surrogate's end points differ from the exact FE finger's by "
                         f"{surrogate_rms:.3f} mm RMS at the optimum (> {opts.max_surrogate_mm:g} mm"
                         + (f", after {n_corr} correction(s))" if n_corr else ")"))
    z, fine, fun, jac, state, nfev, pass_cpu = opt
    finger = pb.finger(z)
    r0 = fun(z)
    J = jac(z)
    t_b = time.process_time()
    std, ci = bootstrap_spread(pb, z, r0, J, opts)
    systematic = end_bias_sensitivity(pb, z, r0, J, state["gain"], opts)
    t_boot = time.process_time() - t_b
    tabs, r_fig = (state["tabs"], r0) if exact is None else exact
    surfaces = surface_fits(pb, tabs, r_fig, pb.offset(z))
    success, message, more = _assess(fine, z, pb, finger, std, surfaces, opts, len(moves))
    if moves:
        message += "; the grid moved " + ", then ".join(
            " and ".join(f"{f} x{r:g}" for f, r in m.items()) for m in moves)
    if n_corr:
        message += (f"; the surrogate was corrected {n_corr} time(s) at a verified optimum (its end "
                    f"points were {first_rms:.3f} mm RMS off the exact finger's at the first)")
    if refused:
        message += ("; a fit on the surrogate corrected at the optimum fitted the exact finger worse "
                    "and was not taken")
    flags += more
    if pb.fe_unconverged:
        flags.append(f"{pb.fe_unconverged} of {pb.fe_positions} tabulated FE positions did not converge "
                     "(interpolated from their converged neighbours)")
    timings = {"fe_tables": pb.t_fe, "build": t_build, "surrogate": pb.t_bem, "residuals": pb.t_res,
               "bootstrap": t_boot, "verify": t_v, "coarse_pass": pass_cpu["coarse"],
               "fine_pass": pass_cpu["fine"], "total": time.process_time() - T0}
    res = FingerCalibration(
        finger=finger, initial=initial, fitted=opts.fit, std=std, ci95=ci, systematic=systematic,
        load_per_width=pb.load_median / finger.width, load_median=pb.load_median, surfaces=surfaces,
        success=success, message=message, flags=flags, n_trials=pb.n_trials, n_frames=pb.n_frames,
        nfev=nfev, n_solves=pb.fe_tables, timings=timings, cost=float(fine.cost), options=opts,
        surrogate_rms_mm=surrogate_rms, position_offset_mm=pb.offset(z) if pb.fit_offset else math.nan)
    return res


def _robust_cost(r: np.ndarray, f_scale: float) -> float:
    """The fine pass's soft-L1 cost of residuals ``r`` (what :func:`optimise` minimises)."""
    return float(f_scale**2 * np.sum(np.sqrt(1.0 + (r / f_scale) ** 2) - 1.0))


def _verified(pb: FECalibrationProblem, opt: tuple, opts: FECalibrationOptions):
    """The exact FE finger at the optimum of ``opt`` (:func:`optimise`'s result on ``pb``),
    the surrogate corrected there and the fit run again while its end points differ from the
    exact finger's by more than ``opts.max_surrogate_mm`` (module notes). Returns the
    optimisation kept, ``(exact tables, exact residuals)`` at its optimum, the surrogate's
    end-point RMS error there (mm), the corrections taken, the uncorrected surrogate's error
    at the first optimum (mm), and whether a corrected fit was refused (it fitted the exact
    finger worse). ``pb`` is left with the surrogate the kept optimisation ran on, so that
    the kept optimum is its stationary point (the bootstrap linearises there)."""
    ends = np.concatenate([np.r_[np.ones(n_e, bool), np.zeros(n_h, bool)]
                           for _, n_e, n_h in pb.residual_surfaces("fine")])

    def verify(o):
        z, fun = o[0], o[2]
        tabs = pb.exact_tables(pb.finger(z))
        r = pb.residuals("fine", tabs, pb.offset(z))
        rms = float(np.sqrt(np.mean((r[ends] - fun(z)[ends]) ** 2))) if ends.any() else math.nan
        return tabs, r, rms

    tabs, r, rms = verify(opt)
    first_rms, n_corr, refused = rms, 0, False
    bounds = _bounds(pb, opts)
    while rms > opts.max_surrogate_mm and n_corr < opts.corrections:
        before = pb.correction
        pb.correct(tabs, opt[0])
        new = optimise(pb, opts, bounds=bounds, z0=opt[0])
        tabs_n, r_n, rms_n = verify(new)
        cost, cost_n = _robust_cost(r, opts.fine_soft), _robust_cost(r_n, opts.fine_soft)
        log.info("FE calibration: surrogate corrected, exact cost %.5g -> %.5g, surrogate error "
                 "%.4f -> %.4f mm", cost, cost_n, rms, rms_n)
        if cost_n >= cost:  # the corrected fit fits the exact finger worse: keep the last one
            pb.correction, refused = before, True
            break
        opt, tabs, r, rms = new, tabs_n, r_n, rms_n
        n_corr += 1
    return opt, (tabs, r), rms, n_corr, first_rms, refused


def _check_grid(centre: FEFingerParams, opts: FECalibrationOptions) -> None:
    """ValueError unless every node of the grid around ``centre`` is a valid finger."""
    for node in grid_nodes(len(opts.fit), opts.levels, opts.design):
        ratios = tuple(opts.levels[i] for i in node)
        try:
            finger_with(centre, dict(zip(opts.fit, ratios, strict=True)))
        except ValueError as exc:
            raise ValueError(f"the calibration grid leaves the valid fingers at ratios {ratios}: "
                             f"{exc}") from None


def _edge(z: np.ndarray, pb: FECalibrationProblem) -> dict:
    """The fitted fields whose optimum sits at the grid's edge -> the level of that edge."""
    lv, ax = pb.opts.levels, pb.axes
    return {f: (lv[0] if zi - ax[0] < 1e-3 else lv[-1])
            for f, zi in zip(pb.fit, pb.fields(z), strict=True) if min(zi - ax[0], ax[-1] - zi) < 1e-3}


def _bounds(pb: FECalibrationProblem, opts: FECalibrationOptions) -> tuple[np.ndarray, np.ndarray]:
    """The least squares' bounds: the grid's range of every field, then +-``max_offset`` mm."""
    lo = np.full(len(opts.fit), pb.axes[0])
    hi = np.full(len(opts.fit), pb.axes[-1])
    if pb.fit_offset:
        lo, hi = np.r_[lo, -opts.max_offset], np.r_[hi, opts.max_offset]
    return lo, hi


def _movable(centre: FEFingerParams, shift: dict, opts: FECalibrationOptions) -> bool:
    """Whether the grid around ``centre`` moved by ``shift`` keeps every node a valid finger."""
    try:
        _check_grid(finger_with(centre, shift), opts)
    except ValueError as exc:  # the moved grid would leave the valid fingers: stay
        log.warning("the calibration grid cannot move to %s: %s", shift, exc)
        return False
    return True


def _fit_on_moving_grid(trials, initial: FEFingerParams, opts: FECalibrationOptions, cache_dir, progress):
    """The least squares on the surrogate, the grid moved to its edge node while the optimum
    sits there (module notes). With ``opts.verify`` the optimum the grid keeps is verified
    (:func:`_verified`); a corrected optimum at the grid's edge moves the grid too. Returns
    the last grid's problem (its ``initial`` the grid's centre), :func:`optimise`'s result on
    it, the moves, the CPU of the tables' builds, :func:`_verified`'s result (None without
    ``verify``) and the CPU of the verifications; the abandoned grids' table counts and CPU
    are added to the last problem's."""
    centre, moves, spent = initial, [], {"t_fe": 0.0, "fe_tables": 0, "fe_unconverged": 0, "fe_positions": 0}
    t_build = t_verify = 0.0
    while True:
        pb = FECalibrationProblem(trials, centre, opts, cache_dir=cache_dir)
        if pb.n_trials < opts.min_trials:
            raise CalibrationError(f"only {pb.n_trials} trial(s) with usable contact regions (need at "
                                   f"least {opts.min_trials}); a finger calibrated on so little data would "
                                   "be a guess")
        if pb.n_frames < opts.min_frames:
            raise CalibrationError(f"only {pb.n_frames} usable frames (need at least {opts.min_frames}): "
                                   "frames need a finite position, a normal force and a contact region")
        t = time.process_time()
        pb.build(progress)
        t_build += time.process_time() - t
        bounds = _bounds(pb, opts)
        opt, ver = optimise(pb, opts, bounds=bounds), None

        def may_move(shift, centre=centre):
            return bool(shift) and len(moves) < opts.max_shifts and _movable(centre, shift, opts)

        shift = _edge(opt[0], pb)
        move = may_move(shift)
        if opts.verify and not move:
            t = time.process_time()
            ver = _verified(pb, opt, opts)
            t_verify += time.process_time() - t
            opt = ver[0]
            corrected = _edge(opt[0], pb)
            if corrected != shift:  # the corrections moved the optimum to (another) edge
                shift, move = corrected, may_move(corrected)
            if move:
                log.info("FE calibration: the corrected optimum sits at the grid's edge in %s",
                         ", ".join(shift))
        if not move:
            break
        for key in spent:
            spent[key] += getattr(pb, key)
        moves.append(shift)
        log.info("FE calibration at the grid's edge in %s: the grid moves there", ", ".join(shift))
        centre = finger_with(centre, shift)
    for key, v in spent.items():  # the abandoned grids' tables count in the cost
        setattr(pb, key, getattr(pb, key) + v)
    return pb, opt, moves, t_build, ver, t_verify


def _assess(fine, z, pb: FECalibrationProblem, finger, std: dict, surfaces, opts: FECalibrationOptions,
            n_moves: int):
    """``(success, message, flags)`` of a finished FE calibration on ``pb``, the last grid's."""
    flags, parts = [], []
    success = bool(fine.status > 0)
    if not success:
        parts.append(f"the optimiser did not converge ({fine.message})")
    edge = _edge(z, pb)
    if edge:
        success = False
        centre = pb.initial
        span = ", ".join(f"{f} {getattr(centre, f) * opts.levels[0]:.4g}.."
                         f"{getattr(centre, f) * opts.levels[-1]:.4g}" for f in edge)
        moved = f", after {n_moves} move(s) of the grid" if n_moves else ""
        parts.append(f"parameter(s) {', '.join(edge)} at the edge of the tabulated range ({span}{moved}): "
                     "the data want a finger outside it")
    if pb.fit_offset and abs(pb.offset(z)) > opts.max_offset - 1e-3:
        success = False
        parts.append(f"the position offset at the bound of the search ({pb.offset(z):+.3f} mm, "
                     f"max_offset {opts.max_offset:g} mm): the tracked positions are off by more")
    flags.extend(identification_flags(opts.fit, finger, std, opts.max_rel_std, surfaces))
    return success, ("; ".join(parts) if parts else f"converged ({fine.message})"), flags
