"""Calibrate a subject's finger from recorded contact regions (issue 15).

The forward model (:mod:`~fingerfriction.mechanics.bem`) knows the fingers it is given.
This module finds the finger of a recorded subject: the shape and modulus parameters of
the :class:`~fingerfriction.mechanics.finger.FingerParams` family (by default the
stadium pad's end radius ``R``, effective modulus ``E*`` and flat length ``L``) for which
the model's **geometric** contact (surface points within ``tol`` = 3 px, ~70 um, of the
deformed finger: the paper's criterion, Methods "Image analysis") reproduces the contact
regions measured in every frame, at the frame's finger position and measured normal force.
It is a pure function of arrays (no file I/O); :mod:`fingerfriction.calibrate_study`
reads a results folder into :class:`CalibrationTrial` objects.

What is identifiable
--------------------
The contact of the plane-strain model depends on the load and the modulus only through
``P' / E* = F_N / (D E*)`` (``D``: the effective finger width, ``P'`` the load per width).
``D`` is therefore held at the initial finger's value (10 mm for the defaults) and ``E*``
is fitted: the fitted ``E*`` is an *effective* modulus for that ``D``, and the load per
width the calibration implies is ``P' = F_N / D``. A study without absolute normal force
can only give ``E*`` relative to an assumed load (``load=`` in
:func:`fingerfriction.calibrate_study.trials_from_results`; the result is flagged).

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

from ..blindspots import blind_spots
from ..regions import as_regions
from ..surfaces import Surface
from .bem import GEOMETRIC_TOL, ContactSolver
from .finger import FingerParams

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
class CalibrationOptions:
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
        same grid cells). Measured on a 36-trial subject (benchmarks/calibrate.py): 19.8
        vs 22.7 CG iterations per solve, so the positions' start is the default.
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
    coarse_stride: int = 4
    n_loads: int = 3
    coarse_soft: float = 0.2
    fine_soft: float = 0.05
    s_min: float = 0.1
    s_0: float = 0.1
    bound: float = 2.0
    diff_step: float = 0.005
    max_nfev: int = 25
    solver_tol: float = 1e-6
    warm_start: str = "positions"
    end_bias_px: float = 0.5
    bootstrap: int = 400
    seed: int = 0
    min_trials: int = 3
    min_frames: int = 200
    max_rel_std: float = 0.1

    def __post_init__(self) -> None:
        fit = tuple(self.fit)
        if not fit or any(f not in FIT_FIELDS for f in fit) or len(set(fit)) != len(fit):
            raise ValueError(f"fit must be a non-empty subset of {FIT_FIELDS}, got {self.fit!r}")
        object.__setattr__(self, "fit", fit)
        for name in ("dx", "clearance", "coarse_step", "fine_step", "coarse_soft", "fine_soft", "s_min",
                     "s_0", "diff_step", "solver_tol", "max_rel_std"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"CalibrationOptions.{name} must be a positive number, got {v!r}")
        if self.warm_start not in ("positions", "parameters", "none"):
            raise ValueError(f"CalibrationOptions.warm_start must be 'positions', 'parameters' or 'none', "
                             f"got {self.warm_start!r}")
        if not (math.isfinite(self.end_bias_px) and self.end_bias_px >= 0):
            raise ValueError(f"CalibrationOptions.end_bias_px must be >= 0 px, got {self.end_bias_px!r}")
        if not self.bound > 1:
            raise ValueError(f"CalibrationOptions.bound must be > 1, got {self.bound!r}")
        for name, lo in (("coarse_stride", 1), ("n_loads", 1), ("max_nfev", 1), ("bootstrap", 0),
                         ("seed", 0), ("min_trials", 1), ("min_frames", 1)):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise ValueError(f"CalibrationOptions.{name} must be an integer >= {lo}, got {v!r}")


# ------------------------------------------------------------------------------ result
@dataclass
class SurfaceFit:
    """Per-surface figures of a calibration.

    Attributes
    ----------
    surface : str
    n_trials, n_frames : int
    rms_end_mm : float
        Root mean square of the end-point residuals at the optimum (mm).
    median_end_mm : float
        Median absolute end-point residual (mm).
    hinge_violations : float
        Fraction of measured interiors / gaps where the model's contact disagrees.
    measured_blind_spots, predicted_blind_spots : (k, 2) ndarray
        Blind spots (mm) of the union of the measured regions, and of the calibrated
        model's regions at the same frames (positions and loads).
    """

    surface: str
    n_trials: int
    n_frames: int
    rms_end_mm: float
    median_end_mm: float
    hinge_violations: float
    measured_blind_spots: np.ndarray
    predicted_blind_spots: np.ndarray

    def blind_spot_pairs(self) -> list[tuple[float, float]]:
        """``(measured width, predicted width)`` in mm, paired by overlap (NaN: no partner)."""
        return _pair_spots(self.measured_blind_spots, self.predicted_blind_spots)

    def to_dict(self) -> dict:
        return {
            "surface": self.surface, "n_trials": self.n_trials, "n_frames": self.n_frames,
            "rms_end_mm": self.rms_end_mm, "median_end_mm": self.median_end_mm,
            "hinge_violations": self.hinge_violations,
            "measured_blind_spots_mm": self.measured_blind_spots.tolist(),
            "predicted_blind_spots_mm": self.predicted_blind_spots.tolist(),
        }


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
        }


def _pair_spots(meas: np.ndarray, pred: np.ndarray) -> list[tuple[float, float]]:
    """Pair blind spots by largest overlap (else nearest centre); unpaired get NaN."""
    out = []
    used = set()
    for a, b in meas:
        best, score = None, -math.inf
        for j, (c, d) in enumerate(pred):
            if j in used:
                continue
            ov = min(b, d) - max(a, c)
            s = ov if ov > 0 else -abs(0.5 * (a + b) - 0.5 * (c + d))
            if s > score:
                best, score = j, s
        if best is not None and score > -1.0:
            used.add(best)
            out.append((float(b - a), float(pred[best][1] - pred[best][0])))
        else:
            out.append((float(b - a), math.nan))
    for j, (c, d) in enumerate(pred):
        if j not in used:
            out.append((math.nan, float(d - c)))
    return out


# ------------------------------------------------------------------------------ problem
class _SurfaceData:
    """The frames of one surface, on the calibration's fixed grid (all fixed arrays)."""

    def __init__(self, surface: Surface, frames: list, u: np.ndarray, table_lo: float, table_hi: float):
        self.surface = surface
        self.name = surface.name
        self.x = np.concatenate([f[0] for f in frames])
        self.load = np.concatenate([f[1] for f in frames])
        self.tol = np.concatenate([f[2] for f in frames])
        self.trial = np.concatenate([f[3] for f in frames])
        self.regions = [r for f in frames for r in f[4]]
        self.min_gap = np.concatenate([f[5] for f in frames])
        self.min_region = np.concatenate([f[6] for f in frames])
        self.u = u
        self.dx = float(u[1] - u[0])
        self.lo, self.hi = table_lo, table_hi
        X = self.x[:, None] + u[None, :]
        self.H = np.asarray(surface.h(X), dtype=float)
        self.X = X


class _Structure:
    """Residual bookkeeping of a set of frames (fixed for the calibration)."""

    def __init__(self, sd: _SurfaceData, idx: np.ndarray):
        u, dx = sd.u, sd.dx
        n = u.size
        self.idx = idx
        fe, je, te, etrial = [], [], [], []
        codes = np.full((idx.size, n), -1, dtype=np.int64)
        kinds = []  # per run id: +1 region interior (max d), -1 gap/exterior (min d)
        run_trial = []
        rid = 0
        for k, i in enumerate(idx):
            reg = sd.regions[i]
            X = sd.X[i]
            ends = reg.ravel()
            # end residuals (skip ends off the grid)
            pos = (ends - X[0]) / dx
            j = np.floor(pos).astype(int)
            ok = (j >= 0) & (j < n - 1)
            fe.append(np.full(int(ok.sum()), k))
            je.append(j[ok])
            te.append(pos[ok] - j[ok])
            etrial.append(np.full(int(ok.sum()), sd.trial[i]))
            # hinge runs: cells more than 1.5 cells away from every end
            near = np.zeros(n, dtype=bool)
            for e in ends:
                c = (e - X[0]) / dx
                lo_c, hi_c = int(math.floor(c - 1.5)), int(math.ceil(c + 1.5))
                near[max(lo_c, 0): max(min(hi_c + 1, n), 0)] = True
            inside = np.zeros(n, dtype=bool)
            for a, b in reg:
                inside |= (X >= a) & (X <= b)
            # label contiguous runs of (not near) cells with the same inside flag
            lab = np.where(near, -1, inside.astype(int))
            change = np.flatnonzero(np.diff(lab) != 0) + 1
            starts = np.concatenate([[0], change])
            stops = np.concatenate([change, [n]])
            for s0, s1 in zip(starts, stops, strict=True):
                if lab[s0] < 0:
                    continue
                codes[k, s0:s1] = rid
                kinds.append(1 if lab[s0] == 1 else -1)
                run_trial.append(sd.trial[i])
                rid += 1
        self.fe = np.concatenate(fe) if fe else np.empty(0, int)
        self.je = np.concatenate(je) if je else np.empty(0, int)
        self.te = np.concatenate(te) if te else np.empty(0)
        self.end_trial = np.concatenate(etrial) if etrial else np.empty(0, int)
        flat = codes.ravel()
        keep = flat >= 0
        self.cell_index = np.flatnonzero(keep)
        run_ids = flat[keep]
        # runs are contiguous in the flattened array: reduceat over their starts
        self.run_starts = np.concatenate([[0], np.flatnonzero(np.diff(run_ids) != 0) + 1])
        self.kinds = np.asarray(kinds, dtype=int)
        self.run_trial = np.asarray(run_trial, dtype=int)
        assert self.run_starts.size == self.kinds.size
        self.n_res = self.fe.size + self.kinds.size

    @property
    def trials(self) -> np.ndarray:
        """Trial index of every residual, ``(n_res,)``."""
        return np.concatenate([self.end_trial, self.run_trial])


class _Problem:
    def __init__(self, trials, initial: FingerParams, opts: CalibrationOptions):
        self.opts = opts
        self.initial = initial
        self.fit = opts.fit
        self.p0 = np.array([float(getattr(initial, f)) for f in self.fit])
        hw = initial.default_half_width(clearance=opts.clearance)
        n = int(2 * math.ceil(hw / opts.dx))
        self.n = max(n, 64)
        self.hw = hw
        self.u = -hw + (np.arange(self.n) + 0.5) * (2 * hw / self.n)
        self.n_solves = 0
        self.cg_iterations = 0
        self.t_bem = 0.0
        self.t_res = 0.0
        self.bem_failures = 0
        # group frames by surface
        groups: dict[str, list] = {}
        surfaces: dict[str, Surface] = {}
        self.trial_labels = []
        self.trial_surface = []
        loads = []
        for t in trials:
            ok = t.usable()
            if not ok.any():
                continue
            idx = np.flatnonzero(ok)
            regs = []
            for i in idx:
                r = t.regions[i]
                regs.append(r[~np.isnan(r[:, 0])])
            tnum = len(self.trial_labels)
            self.trial_labels.append(t.label)
            self.trial_surface.append(t.surface.name)
            groups.setdefault(t.surface.name, []).append(
                (t.x[idx], t.load[idx], np.full(idx.size, t.tol), np.full(idx.size, tnum), regs,
                 np.full(idx.size, t.min_gap), np.full(idx.size, t.min_region))
            )
            surfaces[t.surface.name] = t.surface
            loads.append(t.load[idx])
        if not groups:
            raise CalibrationError("no trial has a usable frame (finite position and load, at least one "
                                   "contact region): nothing to calibrate on")
        allload = np.concatenate(loads)
        self.load_median = float(np.median(allload))
        q = np.linspace(0.02, 0.98, opts.n_loads) if opts.n_loads > 1 else np.array([0.5])
        lv = np.unique(np.round(np.quantile(allload, q), 6))
        self.loads = lv
        self.surfaces: list[_SurfaceData] = []
        for name, frames in groups.items():
            s = surfaces[name]
            a, b = s.feature_extent
            self.surfaces.append(_SurfaceData(s, frames, self.u, a - hw - 0.5, b + hw + 0.5))
        self.n_frames = int(sum(sd.x.size for sd in self.surfaces))
        self.n_trials = len(self.trial_labels)
        # warm starts: (level, surface, load index) -> pressures (m, n)
        self._warm: dict = {}
        self._structs: dict = {}
        self.last_end_gain: dict = {}
        self.last_failures = 0

    # ---------------------------------------------------------------- parameters
    def finger(self, z: np.ndarray) -> FingerParams:
        vals = self.p0 * np.exp(np.asarray(z, dtype=float))
        return dataclasses.replace(self.initial, **{f: float(v) for f, v in zip(self.fit, vals, strict=True)})

    # ---------------------------------------------------------------- levels
    def positions(self, sd: _SurfaceData, step: float) -> np.ndarray:
        m = int(math.ceil((sd.hi - sd.lo) / step)) + 1
        return sd.lo + step * np.arange(m)

    def structure(self, level: str, sd: _SurfaceData) -> _Structure:
        key = (level, sd.name)
        if key not in self._structs:
            stride = self.opts.coarse_stride if level == "coarse" else 1
            # every stride-th frame of each trial
            idx = []
            for t in np.unique(sd.trial):
                fi = np.flatnonzero(sd.trial == t)
                idx.append(fi[::stride])
            self._structs[key] = _Structure(sd, np.sort(np.concatenate(idx)))
        return self._structs[key]

    # ---------------------------------------------------------------- forward
    def tables(self, z: np.ndarray, level: str, step: float, perturbed: bool = False) -> dict:
        """Deformed outlines ``(n_loads, m, n)`` per surface for parameters ``z``.

        Each position starts from the last base sweep's pressure at the same position
        (same grid cells) when there is one; a ``perturbed`` sweep (Jacobian) does not
        replace those starts.
        """
        finger = self.finger(z)
        solver = ContactSolver(finger, n=self.n, half_width=self.hw)
        out = {}
        t0 = time.process_time()
        fails = 0
        for sd in self.surfaces:
            pos = self.positions(sd, step)
            Y = np.empty((self.loads.size, pos.size, self.n))
            for j, F in enumerate(self.loads):
                key = (level, sd.name, j)
                start = self._warm.get(key) if self.opts.warm_start == "parameters" else None
                Y[j], P, f = self._sweep(solver, sd.surface, pos, float(F), start)
                fails += f
                if not perturbed:
                    self._warm[key] = P
            out[sd.name] = (pos, Y)
        self.t_bem += time.process_time() - t0
        self.last_failures = fails
        return out

    def _sweep(self, solver: ContactSolver, surface, pos: np.ndarray, load: float, start):
        n = self.n
        Y = np.empty((pos.size, n))
        P = np.empty((pos.size, n))
        prev = prev2 = None
        fails = 0
        tol = self.opts.solver_tol
        for i, xf in enumerate(pos):
            if start is not None:
                guess = start[i]
            elif self.opts.warm_start == "none":
                guess = None
            elif prev is not None:
                guess = prev if prev2 is None else np.maximum(2.0 * prev - prev2, 0.0)
            else:
                guess = None
            sol = solver.solve(surface, xf, load=load, x0=guess, tol=tol, check=False)
            self.n_solves += 1
            self.cg_iterations += sol.iterations
            if not sol.success and guess is not None:
                sol = solver.solve(surface, xf, load=load, tol=tol, check=False)
                self.n_solves += 1
                self.cg_iterations += sol.iterations
            if not sol.success:
                fails += 1
            Y[i] = sol.finger_y  # cell i at xf + u_i (finger frame), heights in surface coordinates
            P[i] = sol.pressure
            prev2, prev = prev, sol.pressure
        return Y, P, fails

    def distances(self, sd: _SurfaceData, idx: np.ndarray, pos: np.ndarray, Y: np.ndarray) -> np.ndarray:
        """Model distance ``d`` (mm) from each surface cell to the finger, ``(len(idx), n)``."""
        x = sd.x[idx]
        ld = sd.load[idx]
        step = pos[1] - pos[0]
        uu = np.clip((x - pos[0]) / step, 0.0, pos.size - 1.0)
        i0 = np.minimum(np.floor(uu).astype(int), pos.size - 2)
        w = (uu - i0)[:, None]
        L = self.loads
        if L.size == 1:
            j0 = np.zeros(x.size, dtype=int)
            v = np.zeros((x.size, 1))
            j1 = j0
        else:
            f = np.clip(ld, L[0], L[-1])
            j0 = np.clip(np.searchsorted(L, f, side="right") - 1, 0, L.size - 2)
            v = ((f - L[j0]) / (L[j0 + 1] - L[j0]))[:, None]
            j1 = j0 + 1
        # outlines are stored in the finger frame (cell i at x_c + u_i), so bilinear
        # interpolation keeps the shape; heights are surface heights.
        i1 = i0 + 1
        yf = (1 - v) * ((1 - w) * Y[j0, i0] + w * Y[j0, i1]) + v * ((1 - w) * Y[j1, i0] + w * Y[j1, i1])
        slope = np.gradient(yf, sd.dx, axis=1)
        return (yf - sd.H[idx]) / np.sqrt(1.0 + slope * slope)

    def residuals(self, level: str, tabs: dict) -> np.ndarray:
        t0 = time.process_time()
        o = self.opts
        out = []
        for sd in self.surfaces:
            st = self.structure(level, sd)
            pos, Y = tabs[sd.name]
            d = self.distances(sd, st.idx, pos, Y)
            tol_f = sd.tol[st.idx]
            # end residuals
            d0 = d[st.fe, st.je]
            d1 = d[st.fe, st.je + 1]
            de = d0 + st.te * (d1 - d0)
            slope = (d1 - d0) / sd.dx
            den = np.sqrt(slope * slope + o.s_min**2)
            r_end = (de - tol_f[st.fe]) / den
            # d r_end / d(outward shift of the measured end), for the systematic sensitivity:
            # moving an end outwards (away from its region) raises d by |d'| per mm.
            self.last_end_gain[sd.name] = np.abs(slope) / den
            # hinge residuals
            flat = d.ravel()[st.cell_index]
            tol_cells = np.repeat(tol_f, sd.u.size)[st.cell_index]
            rel = flat - tol_cells
            if st.kinds.size:
                mx = np.maximum.reduceat(rel, st.run_starts)
                mn = np.minimum.reduceat(rel, st.run_starts)
                r_h = np.where(st.kinds > 0, np.maximum(mx, 0.0), np.maximum(-mn, 0.0)) / o.s_0
            else:
                r_h = np.empty(0)
            out.append(r_end)
            out.append(r_h)
        self.t_res += time.process_time() - t0
        return np.concatenate(out)

    def residual_trials(self, level: str) -> np.ndarray:
        return np.concatenate([self.structure(level, sd).trials for sd in self.surfaces])

    def residual_surfaces(self, level: str) -> list[tuple[str, int, int]]:
        """(surface, n_end, n_hinge) in residual order."""
        return [(sd.name, self.structure(level, sd).fe.size, self.structure(level, sd).kinds.size)
                for sd in self.surfaces]


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
    pb = _Problem(trials, initial, opts)
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
    lb = np.full(len(opts.fit), -math.log(opts.bound))
    ub = -lb
    z = np.zeros(len(opts.fit))
    nfev = {}
    pass_cpu = {}
    results = {}
    for level, step, soft in (("coarse", opts.coarse_step, opts.coarse_soft),
                              ("fine", opts.fine_step, opts.fine_soft)):
        fun, jac, state = _make_fun_jac(pb, level, step)
        t_pass = time.process_time()
        r = least_squares(fun, z, jac=jac, bounds=(lb, ub), loss="soft_l1", f_scale=soft,
                          x_scale=1.0, max_nfev=opts.max_nfev, xtol=1e-4, ftol=1e-6, gtol=1e-8)
        nfev[level] = int(r.nfev)
        pass_cpu[level] = time.process_time() - t_pass
        results[level] = r
        z = r.x
        log.info("calibration %s pass: %s, z=%s, cost %.4g", level, r.message, np.round(z, 4), r.cost)
    fine = results["fine"]
    finger = pb.finger(z)

    # residuals and Jacobian at the optimum (for the bootstrap and the per-surface figures;
    # reused from the fine pass when it evaluated them there)
    r0 = fun(z)
    failures = pb.last_failures
    J = jac(z)
    t_b = time.process_time()
    std, ci = _bootstrap(pb, z, r0, J, opts)
    systematic = _end_bias_sensitivity(pb, z, r0, J, state["gain"], opts)
    t_boot = time.process_time() - t_b

    # per-surface figures and blind spots at the optimum
    t_p = time.process_time()
    surfaces = _surface_fits(pb, state["tabs"], r0)
    t_pred = time.process_time() - t_p

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
    for f in opts.fit:
        v = float(getattr(finger, f))
        if std.get(f, 0.0) > opts.max_rel_std * v:
            flags.append(f"{f} is poorly identified: bootstrap std {std[f]:.3g} is "
                         f"{100 * std[f] / v:.0f} % of {v:.4g}")
    for s in surfaces:
        if s.rms_end_mm > 0.1:
            flags.append(f"{s.surface}: end-point residual RMS {s.rms_end_mm:.3f} mm (> 0.1 mm): the model "
                         "does not reproduce this surface's contact")
    message = "; ".join(msg_parts) if msg_parts else f"converged ({fine.message})"
    timings = {
        "prepare": t_prep, "bem": pb.t_bem, "residuals": pb.t_res, "bootstrap": t_boot,
        "predict": t_pred, "coarse_pass": pass_cpu["coarse"], "fine_pass": pass_cpu["fine"],
        "total": time.process_time() - T0,
    }
    return FingerCalibration(
        finger=finger, initial=initial, fitted=opts.fit, std=std, ci95=ci,
        load_per_width=pb.load_median / finger.width, load_median=pb.load_median, surfaces=surfaces,
        systematic=systematic,
        success=success, message=message, flags=flags, n_trials=pb.n_trials, n_frames=pb.n_frames,
        nfev=nfev, n_solves=pb.n_solves, cg_iterations=pb.cg_iterations, timings=timings,
        cost=float(fine.cost), options=opts,
    )


def _make_fun_jac(pb: _Problem, level: str, step: float):
    """Residual function and forward-difference Jacobian sharing the base evaluation.

    Warm starts: the base sweep at new parameters starts each position from the previous
    base sweep's pressure there (same grid cells); each perturbed sweep starts from the
    base sweep at the same parameters. The last evaluation and Jacobian are kept in
    ``state`` (``'tabs'``, ``'r'``, ``'J'``) for reuse at the optimum.
    """
    h = pb.opts.diff_step
    state: dict = {}

    def key_of(z):
        return tuple(np.asarray(z, dtype=float).round(12))

    def fun(z):
        key = key_of(z)
        if state.get("key") != key:
            tabs = pb.tables(z, level, step)
            r = pb.residuals(level, tabs)
            state.update(key=key, tabs=tabs, r=r, fail=pb.last_failures, gain=dict(pb.last_end_gain))
        pb.last_failures = state["fail"]
        return state["r"]

    def jac(z):
        key = key_of(z)
        if state.get("jkey") == key:
            return state["J"]
        r0 = fun(z)
        z = np.asarray(z, dtype=float)
        J = np.empty((r0.size, z.size))
        for k in range(z.size):
            zk = z.copy()
            zk[k] += h
            tabs = pb.tables(zk, level, step, perturbed=True)
            J[:, k] = (pb.residuals(level, tabs) - r0) / h
        state.update(jkey=key, J=J)
        return J

    return fun, jac, state


def _soft_weights(r: np.ndarray, f_scale: float) -> np.ndarray:
    """IRLS weights of the soft-L1 loss, ``rho'(z) = 1 / sqrt(1 + (r / f)^2)``."""
    return 1.0 / np.sqrt(1.0 + (r / f_scale) ** 2)


def _bootstrap(pb: _Problem, z: np.ndarray, r: np.ndarray, J: np.ndarray, opts: CalibrationOptions):
    """Linearised stratified cluster bootstrap (see the module notes). Returns (std, ci95)."""
    if opts.bootstrap == 0:
        return ({f: math.nan for f in opts.fit}, {f: (math.nan, math.nan) for f in opts.fit})
    rng = np.random.default_rng(opts.seed)
    w = _soft_weights(r, opts.fine_soft)
    tr = pb.residual_trials("fine")
    T = pb.n_trials
    by_surface: dict[str, list[int]] = {}
    for t, s in enumerate(pb.trial_surface):
        by_surface.setdefault(s, []).append(t)
    # per-trial normal-equation pieces: A_t = J_t^T W_t J_t, b_t = J_t^T W_t r_t
    p = z.size
    A = np.zeros((T, p, p))
    b = np.zeros((T, p))
    for t in range(T):
        m = tr == t
        Jw = J[m] * w[m, None]
        A[t] = Jw.T @ J[m]
        b[t] = Jw.T @ r[m]
    zs = np.empty((opts.bootstrap, p))
    for k in range(opts.bootstrap):
        c = np.zeros(T)
        for ts in by_surface.values():
            draw = rng.integers(0, len(ts), size=len(ts))
            np.add.at(c, np.asarray(ts)[draw], 1.0)
        Ab = np.tensordot(c, A, axes=1)
        bb = c @ b
        try:
            zs[k] = z - np.linalg.solve(Ab, bb)
        except np.linalg.LinAlgError:
            zs[k] = np.nan
    vals = pb.p0[None, :] * np.exp(zs)
    std, ci = {}, {}
    for i, f in enumerate(opts.fit):
        v = vals[:, i][np.isfinite(vals[:, i])]
        std[f] = float(np.std(v, ddof=1)) if v.size > 1 else math.nan
        ci[f] = ((float(np.percentile(v, 2.5)), float(np.percentile(v, 97.5))) if v.size
                 else (math.nan, math.nan))
    return std, ci


def _end_bias_sensitivity(pb: _Problem, z: np.ndarray, r: np.ndarray, J: np.ndarray, gain: dict,
                          opts: CalibrationOptions) -> dict:
    """Parameter change (linearised, IRLS weights at the optimum) if every measured region
    were ``end_bias_px`` px wider at each end; the pixel size is taken as ``tol / 3``."""
    w = _soft_weights(r, opts.fine_soft)
    dr = []
    for sd in pb.surfaces:
        st = pb.structure("fine", sd)
        px = sd.tol[st.idx][st.fe] / 3.0
        dr.append(gain[sd.name] * opts.end_bias_px * px)
        dr.append(np.zeros(st.kinds.size))
    dr = np.concatenate(dr)
    Jw = J * w[:, None]
    try:
        dz = -np.linalg.solve(Jw.T @ J, Jw.T @ dr)
    except np.linalg.LinAlgError:
        return {f: math.nan for f in opts.fit}
    vals = pb.p0 * np.exp(z)
    return {f: float(v * (math.exp(d) - 1.0)) for f, v, d in zip(opts.fit, vals, dz, strict=True)}


def _model_regions(d: np.ndarray, X: np.ndarray, tol: np.ndarray, min_gap: np.ndarray,
                   min_region: np.ndarray) -> list[np.ndarray]:
    """Regions ``d <= tol`` per frame, ends interpolated linearly (as the BEM's geometric
    ones), then the measurement's cleanup (as :func:`fingerfriction.video.contact.
    contact_regions`): gaps shorter than ``min_gap`` bridged, regions shorter than
    ``min_region`` dropped."""
    out = []
    for i in range(d.shape[0]):
        di, xi = d[i], X[i]
        m = di <= tol[i]
        if not m.any():
            out.append(np.empty((0, 2)))
            continue
        dm = np.diff(m.view(np.int8))
        starts = np.flatnonzero(dm == 1) + 1
        ends = np.flatnonzero(dm == -1)
        if m[0]:
            starts = np.concatenate(([0], starts))
        if m[-1]:
            ends = np.concatenate((ends, [m.size - 1]))
        rows = []
        for s, e in zip(starts, ends, strict=True):
            if s > 0:
                g0, g1 = di[s - 1], di[s]
                a = xi[s - 1] + (xi[s] - xi[s - 1]) * (g0 - tol[i]) / (g0 - g1)
            else:
                a = xi[0]
            if e < m.size - 1:
                g0, g1 = di[e], di[e + 1]
                bb = xi[e] + (xi[e + 1] - xi[e]) * (tol[i] - g0) / (g1 - g0)
            else:
                bb = xi[-1]
            if rows and a - rows[-1][1] < min_gap[i]:
                rows[-1] = (rows[-1][0], bb)
            else:
                rows.append((a, bb))
        rows = [r for r in rows if r[1] - r[0] >= min_region[i]]
        out.append(np.asarray(rows).reshape(-1, 2))
    return out


def _union_blind_spots(region_list: list[np.ndarray]) -> np.ndarray:
    k = max((r.shape[0] for r in region_list), default=0)
    if k == 0:
        return np.empty((0, 2))
    arr = np.full((len(region_list), k, 2), np.nan)
    for i, r in enumerate(region_list):
        arr[i, : r.shape[0]] = r
    return blind_spots(arr).intervals


def _surface_fits(pb: _Problem, tabs: dict, r0: np.ndarray) -> list[SurfaceFit]:
    out = []
    off = 0
    for sd in pb.surfaces:
        st = pb.structure("fine", sd)
        ne, nh = st.fe.size, st.kinds.size
        re = r0[off: off + ne]
        rh = r0[off + ne: off + ne + nh]
        off += ne + nh
        pos, Y = tabs[sd.name]
        d = pb.distances(sd, st.idx, pos, Y)
        model = _model_regions(d, sd.X[st.idx], sd.tol[st.idx], sd.min_gap[st.idx], sd.min_region[st.idx])
        meas = [sd.regions[i] for i in st.idx]
        out.append(SurfaceFit(
            surface=sd.name, n_trials=int(np.unique(sd.trial).size), n_frames=int(st.idx.size),
            rms_end_mm=float(np.sqrt(np.mean(re**2))) if re.size else math.nan,
            median_end_mm=float(np.median(np.abs(re))) if re.size else math.nan,
            hinge_violations=float(np.mean(rh > 0.05)) if rh.size else 0.0,
            measured_blind_spots=_union_blind_spots(meas),
            predicted_blind_spots=_union_blind_spots(model),
        ))
    return out
