"""Internals of :mod:`.calibrate`: the fixed-grid forward model of the measured frames, the
residuals, the Jacobian with warm-started sweeps, the bootstrap (see that module's notes)."""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np

from ..model.blindspots import blind_spots
from ..surfaces import Surface
from .bem import ContactSolver
from .finger import FingerParams
from .solution import regions_within_gap

__all__: list[str] = []


@dataclass(frozen=True)
class ResidualOptions:
    """The residual, optimiser and bootstrap settings both calibrations share (documented
    with :class:`fingerfriction.mechanics.calibrate.CalibrationOptions`): the base of its
    options and of :class:`fingerfriction.mechanics.fe.calibration.FECalibrationOptions`,
    which check these fields with :meth:`check_shared`."""

    coarse_stride: int = 4
    coarse_soft: float = 0.2
    fine_soft: float = 0.05
    s_min: float = 0.1
    s_0: float = 0.1
    diff_step: float = 0.005
    max_nfev: int = 25
    end_bias_px: float = 0.5
    bootstrap: int = 400
    seed: int = 0
    min_trials: int = 3
    min_frames: int = 200
    max_rel_std: float = 0.1

    def evaluations(self) -> int:
        """Evaluations of the residuals allowed per least-squares pass (``max_nfev``)."""
        return self.max_nfev

    def check_shared(self, floats=(), ints=(), optional=()) -> None:
        """ValueError unless the shared fields, and a subclass's ``floats`` (positive
        numbers) and ``ints`` (``(name, lowest)`` integers), are valid; a field named in
        ``optional`` may also be None."""
        own = type(self).__name__
        for name in ("coarse_soft", "fine_soft", "s_min", "s_0", "diff_step", "max_rel_std", *floats):
            v = getattr(self, name)
            if isinstance(v, bool) or not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{own}.{name} must be a positive number, got {v!r}")
        if not (isinstance(self.end_bias_px, (int, float)) and math.isfinite(self.end_bias_px)
                and self.end_bias_px >= 0):
            raise ValueError(f"{own}.end_bias_px must be >= 0 px, got {self.end_bias_px!r}")
        for name, lo in (("coarse_stride", 1), ("max_nfev", 1), ("bootstrap", 0), ("seed", 0),
                         ("min_trials", 1), ("min_frames", 1), *ints):
            v = getattr(self, name)
            if v is None and name in optional:
                continue
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise ValueError(f"{own}.{name} must be an integer >= {lo}, got {v!r}")


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


class CalibrationProblem:
    """The least-squares problem of the finger calibration: the measured frames grouped by
    surface, the model's sweeps on a grid of ``opts.dx`` (mm), and the counters of the work
    done (solves, CG iterations, times); :func:`make_fun_jac` gives its residuals and Jacobian."""
    def __init__(self, trials, initial: FingerParams, opts):
        self.opts = opts
        self.initial = initial
        self.fit = opts.fit
        self.p0 = np.array([float(getattr(initial, f)) for f in self.fit])
        #: Whether ``z`` ends with the position offset (mm, :meth:`offset`) after the fields.
        self.fit_offset = bool(getattr(opts, "position_offset", False))
        #: The names of ``z``'s entries: the fitted fields, then ``'position_offset'`` if fitted.
        self.param_names = tuple(self.fit) + (("position_offset",) if self.fit_offset else ())
        self.hw, self.u = self._grid(initial, opts)
        self.n = self.u.size
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
        if not groups:  # calibrate_finger checks this first, with a message for the user
            raise ValueError("no usable frame")
        allload = np.concatenate(loads)
        self.load_median = float(np.median(allload))
        self.loads = self._table_loads(allload, opts)
        self.surfaces: list[_SurfaceData] = []
        for name, frames in groups.items():
            s = surfaces[name]
            a, b = s.feature_extent
            self.surfaces.append(_SurfaceData(s, frames, self.u, a - self.hw - 0.5, b + self.hw + 0.5))
        self.n_frames = int(sum(sd.x.size for sd in self.surfaces))
        self.n_trials = len(self.trial_labels)
        # warm starts: (level, surface, load index) -> pressures (m, n)
        self._warm: dict = {}
        self._structs: dict = {}
        self.last_end_gain: dict = {}
        self.last_failures = 0

    @staticmethod
    def _grid(initial, opts) -> tuple[float, np.ndarray]:
        """``(half-width, u)``: the fixed cells ``u`` (mm, finger frame) of every table."""
        hw = initial.default_half_width(clearance=opts.clearance)
        n = max(int(2 * math.ceil(hw / opts.dx)), 64)
        return hw, -hw + (np.arange(n) + 0.5) * (2 * hw / n)

    @staticmethod
    def _table_loads(allload: np.ndarray, opts) -> np.ndarray:
        """The tabulated normal loads (N): quantiles 2 %, ..., 98 % of the frames' loads."""
        q = np.linspace(0.02, 0.98, opts.n_loads) if opts.n_loads > 1 else np.array([0.5])
        return np.unique(np.round(np.quantile(allload, q), 6))

    # ---------------------------------------------------------------- parameters
    def fields(self, z: np.ndarray) -> np.ndarray:
        """The fitted fields' part of ``z`` (``log`` ratios to the initial finger)."""
        return np.asarray(z, dtype=float)[: len(self.fit)]

    def offset(self, z: np.ndarray) -> float:
        """The position offset in ``z`` (mm; 0 when it is not fitted): the model finger sits
        at the tracked position plus this (the tracked point, e.g. the chord midpoint of a
        finger leaning under friction, is not the model finger's reference point)."""
        return float(np.asarray(z, dtype=float)[len(self.fit)]) if self.fit_offset else 0.0

    def finger(self, z: np.ndarray) -> FingerParams:
        vals = self.p0 * np.exp(self.fields(z))
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

    def distances(self, sd: _SurfaceData, idx: np.ndarray, pos: np.ndarray, Y: np.ndarray,
                  offset: float = 0.0) -> np.ndarray:
        """Model distance ``d`` (mm) from each surface cell to the finger, ``(len(idx), n)``,
        with the model finger at the frames' positions plus ``offset`` (mm)."""
        x = sd.x[idx] + offset
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
        if offset:
            # the cells stay at the frames' surface coordinates x + u_i: the finger moved by
            # the offset is read at its own cell u_i - offset (linear, the end cells held)
            c = np.clip(np.arange(sd.u.size) - offset / sd.dx, 0.0, sd.u.size - 1.0)
            k0 = np.minimum(np.floor(c).astype(int), sd.u.size - 2)
            f = c - k0
            yf = (1 - f) * yf[:, k0] + f * yf[:, k0 + 1]
        slope = np.gradient(yf, sd.dx, axis=1)
        return (yf - sd.H[idx]) / np.sqrt(1.0 + slope * slope)

    def residuals(self, level: str, tabs: dict, offset: float = 0.0) -> np.ndarray:
        """End-point then hinge residuals (mm), surface after surface, of the tables ``tabs``
        with the model finger at the frames' positions plus ``offset`` (mm)."""
        t0 = time.process_time()
        o = self.opts
        out = []
        for sd in self.surfaces:
            st = self.structure(level, sd)
            pos, Y = tabs[sd.name]
            d = self.distances(sd, st.idx, pos, Y, offset)
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


def make_fun_jac(pb: CalibrationProblem, level: str, step: float):
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
            r = pb.residuals(level, tabs, pb.offset(z))
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
            # the offset (the last entry, when fitted) moves the finger, not its tables
            tabs = state["tabs"] if k >= len(pb.fit) else pb.tables(zk, level, step, perturbed=True)
            J[:, k] = (pb.residuals(level, tabs, pb.offset(zk)) - r0) / h
        state.update(jkey=key, J=J)
        return J

    return fun, jac, state


def _soft_weights(r: np.ndarray, f_scale: float) -> np.ndarray:
    """IRLS weights of the soft-L1 loss, ``rho'(z) = 1 / sqrt(1 + (r / f)^2)``."""
    return 1.0 / np.sqrt(1.0 + (r / f_scale) ** 2)


def bootstrap_spread(pb: CalibrationProblem, z: np.ndarray, r: np.ndarray, J: np.ndarray, opts):
    """Linearised stratified cluster bootstrap (see the module notes). Returns (std, ci95)."""
    names = pb.param_names
    if opts.bootstrap == 0:
        return ({f: math.nan for f in names}, {f: (math.nan, math.nan) for f in names})
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
    nf = len(opts.fit)
    vals = pb.p0[None, :] * np.exp(zs[:, :nf])
    if pb.fit_offset:
        vals = np.column_stack([vals, zs[:, nf]])
    std, ci = {}, {}
    for i, f in enumerate(names):
        v = vals[:, i][np.isfinite(vals[:, i])]
        std[f] = float(np.std(v, ddof=1)) if v.size > 1 else math.nan
        ci[f] = ((float(np.percentile(v, 2.5)), float(np.percentile(v, 97.5))) if v.size
                 else (math.nan, math.nan))
    return std, ci


def end_bias_sensitivity(pb: CalibrationProblem, z: np.ndarray, r: np.ndarray, J: np.ndarray, gain: dict,
                         opts) -> dict:
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
        return {f: math.nan for f in pb.param_names}
    nf = len(opts.fit)
    vals = pb.p0 * np.exp(pb.fields(z))
    out = {f: float(v * (math.exp(d) - 1.0)) for f, v, d in zip(opts.fit, vals, dz[:nf], strict=True)}
    if pb.fit_offset:
        out["position_offset"] = float(dz[nf])
    return out


def model_regions(d: np.ndarray, X: np.ndarray, tol: np.ndarray, min_gap: np.ndarray,
                  min_region: np.ndarray) -> list[np.ndarray]:
    """Regions ``d <= tol`` per frame, ends interpolated linearly (as the BEM's geometric
    ones), then the measurement's cleanup (as :func:`fingerfriction.video.contact.
    contact_regions`): gaps shorter than ``min_gap`` bridged, regions shorter than
    ``min_region`` dropped."""
    out = []
    for i in range(d.shape[0]):
        rows = []
        for a, bb in regions_within_gap(X[i], d[i], tol[i]):
            if rows and a - rows[-1][1] < min_gap[i]:
                rows[-1] = (rows[-1][0], bb)
            else:
                rows.append((a, bb))
        rows = [r for r in rows if r[1] - r[0] >= min_region[i]]
        out.append(np.asarray(rows).reshape(-1, 2))
    return out


def union_blind_spots(region_list: list[np.ndarray]) -> np.ndarray:
    """The blind spots (:func:`fingerfriction.model.blindspots.blind_spots`) of a list of
    per-frame ``(k_i, 2)`` region arrays, padded with NaN to one ``(n, k, 2)`` array; ``(0, 2)``
    when no frame has a region."""
    k = max((r.shape[0] for r in region_list), default=0)
    if k == 0:
        return np.empty((0, 2))
    arr = np.full((len(region_list), k, 2), np.nan)
    for i, r in enumerate(region_list):
        arr[i, : r.shape[0]] = r
    return blind_spots(arr).intervals


def identification_flags(fields, finger, std: dict, max_rel_std: float, surfaces) -> list[str]:
    """The calibration's warnings: each fitted field of ``fields`` whose bootstrap std
    (``std``, field -> std) exceeds ``max_rel_std`` of its value on ``finger``, and each
    surface fit of ``surfaces`` whose end-point residual RMS exceeds 0.1 mm."""
    flags = []
    for f in fields:
        v = float(getattr(finger, f))
        if std.get(f, 0.0) > max_rel_std * v:
            flags.append(f"{f} is poorly identified: bootstrap std {std[f]:.3g} is "
                         f"{100 * std[f] / v:.0f} % of {v:.4g}")
    for s in surfaces:
        if s.rms_end_mm > 0.1:
            flags.append(f"{s.surface}: end-point residual RMS {s.rms_end_mm:.3f} mm (> 0.1 mm): the model "
                         "does not reproduce this surface's contact")
    return flags
