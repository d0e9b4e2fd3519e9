"""The surrogate of an FE calibration: FE tables of a grid of fingers around an initial one,
interpolated in the fitted parameters (:class:`FECalibrationProblem`, the forward model of
:func:`fingerfriction.mechanics.fe.calibration.calibrate_fe_finger`).

One FE table (a finger, a surface, a load, positions every 0.1 mm) costs tens of seconds of
CPU at the coarse mesh, so the optimiser cannot call the FE solver at every evaluation.
Instead the fitted parameters ``theta`` (a few :class:`FEFingerParams` fields, as ratios to
the initial finger) are tabulated at ``levels`` (default 0.75, 1, 1.25: the range the FE
family's drawn fingers span, ``docs/mechanics-fe.md``), every node's tables are solved once
(through :class:`~.provider.FEProvider` and its disk cache, with the finger's sliding
friction), and the deformed outline at any ``theta`` inside the grid interpolates the
nodes' outlines with Lagrange polynomials in ``log(ratio)`` (quadratic for three levels):
smooth in ``theta``, so the least squares sees smooth residuals, and exact at the nodes.

* ``design='star'`` (default): the initial finger and, for each fitted field, the finger
  with that field at each other level (``1 + 2k`` nodes for ``k`` fields and three levels);
  the outline is the sum of each field's interpolation along its axis minus ``k - 1`` times
  the initial finger's (no cross terms: a change of two fields is the sum of their changes).
* ``design='tensor'``: every combination of levels (``3^k`` nodes), the tensor-product
  interpolation (cross terms included).

The grid depends on the initial finger and the options only, never on the data, so the
calibrations of one subject on different subsets of its surfaces (leave-one-surface-out)
share it, and so do studies with the same subject finger. The optimiser stays inside the
grid (its bounds).

Coupled geometry: fitting ``radius`` scales the bone's half-width with it, fitting
``semi_height`` scales the bone's half-height and the pulp thickness with it (as the drawn
fingers do, :func:`fingerfriction.sim.fingers.draw_fe_finger`), so every grid node is a
valid finger.
"""

from __future__ import annotations

import dataclasses
import itertools
import math
import time
from concurrent.futures import ProcessPoolExecutor

import numpy as np

from .._calibration_problem import CalibrationProblem
from .params import FEFingerParams, FEMeshParams
from .provider import FEProvider, default_mesh

__all__ = ["FE_FIT_FIELDS", "FECalibrationProblem", "finger_with", "fe_tables", "table_positions",
           "grid_nodes"]

#: The FE finger's fields a calibration can fit (all positive, fitted as ratios to the initial).
FE_FIT_FIELDS = ("tissue_modulus", "skin_modulus", "skin_thickness", "radius", "semi_height",
                 "pulp_thickness")


def finger_with(initial: FEFingerParams, ratios: dict) -> FEFingerParams:
    """``initial`` with each field of ``ratios`` multiplied by its ratio, geometry coupled as
    in the module notes (the bone and the pulp follow the outline)."""
    kw = {f: float(getattr(initial, f)) * float(r) for f, r in ratios.items()}
    if "radius" in ratios:
        kw["bone_half_width"] = initial.bone_half_width * float(ratios["radius"])
    if "semi_height" in ratios:
        k = float(ratios["semi_height"])
        kw["bone_half_height"] = initial.bone_half_height * k
        kw["pulp_thickness"] = kw.get("pulp_thickness", initial.pulp_thickness) * k
    return dataclasses.replace(initial, **kw)


def _lagrange(nodes: np.ndarray, t: float) -> np.ndarray:
    """Lagrange basis polynomials of ``nodes`` evaluated at ``t``, ``(nodes.size,)``."""
    n = nodes.size
    w = np.ones(n)
    for i in range(n):
        for j in range(n):
            if j != i:
                w[i] *= (t - nodes[j]) / (nodes[i] - nodes[j])
    return w


def grid_nodes(k: int, levels, design: str) -> list[tuple]:
    """The grid's nodes as tuples of level indices, one per fitted field (module notes)."""
    n = len(levels)
    if design == "tensor":
        return list(itertools.product(range(n), repeat=k))
    c = list(levels).index(1.0)
    nodes = [(c,) * k]
    for a in range(k):
        nodes += [tuple(i if b == a else c for b in range(k)) for i in range(n) if i != c]
    return nodes


def table_positions(surface, half_width: float, step: float) -> np.ndarray:
    """Finger positions (mm) of a calibration's tables on ``surface``: every ``step`` mm from
    ``half_width + 0.5`` mm before the feature to as far after it (the positions of
    :meth:`CalibrationProblem.positions`)."""
    a, b = surface.feature_extent
    lo, hi = a - half_width - 0.5, b + half_width + 0.5
    return lo + step * np.arange(int(math.ceil((hi - lo) / step)) + 1)


def _one_table(job):
    """One FE table: outlines on the cells ``u`` (float32), converged mask, solved or not, CPU s."""
    finger, surface, load, pos, mesh, grid_step, cache_dir, k = job
    prov = FEProvider(fingers={"n": finger}, mesh=mesh, grid_step=grid_step, cache_dir=cache_dir)
    t0 = time.process_time()
    y, _ = prov.solve(surface, "n", pos, float(load))
    ok = prov.last_ok if prov.last_ok is not None else np.ones(pos.size, dtype=bool)
    m = (y.shape[1] - 1) // 2
    if m < k:
        raise ValueError(f"the finger {finger.name or finger} is narrower ({m * grid_step:g} mm) than the "
                         f"calibration's cells ({k * grid_step:g} mm)")
    y = y[:, m - k: m + k + 1]
    if not ok.all() and ok.any():  # unconverged positions: interpolated from converged neighbours
        good = np.flatnonzero(ok)
        for j in range(y.shape[1]):
            y[~ok, j] = np.interp(pos[~ok], pos[good], y[good, j])
    return y.astype(np.float32), ok, prov.computed, time.process_time() - t0


def fe_tables(fingers: list, surfaces: list, *, loads, half_width: float, step: float, grid_step: float,
              mesh: FEMeshParams, cache_dir=None, workers: int = 1, progress=None) -> tuple[list, dict]:
    """FE tables of several fingers on several surfaces and loads, through the provider's cache.

    Parameters
    ----------
    fingers : list of FEFingerParams
        Each with its own sliding friction.
    surfaces : list of Surface
    loads : sequence of float
        Normal loads in N.
    half_width, step : float
        The positions (:func:`table_positions`) and the cells ``u = grid_step * k``,
        ``|u| <= half_width``, on which outlines are returned (mm).
    grid_step : float
        The provider's grid spacing (mm).
    mesh : FEMeshParams
    cache_dir : path-like, optional
    workers : int
        Processes (1: in this process).
    progress : callable, optional
        ``progress(done, total)`` after each table.

    Returns
    -------
    tables : list of dict
        Per finger, surface name -> ``(positions (m,), Y (n_loads, m, n) float32)``: the outline
        heights (mm) at ``position + u``; unconverged positions interpolated from their
        converged neighbours.
    stats : dict
        ``cpu_s`` (the solves' CPU, in whichever process), ``solved`` (tables not read from
        the cache), ``unconverged`` and ``positions``.
    """
    k = int(round(half_width / grid_step))
    jobs, where = [], []
    for fi, f in enumerate(fingers):
        for s in surfaces:
            pos = table_positions(s, half_width, step)
            for j, F in enumerate(loads):
                jobs.append((f, s, float(F), pos, mesh, grid_step, cache_dir, k))
                where.append((fi, s.name, j, pos))
    out = []
    if workers > 1 and len(jobs) > 1:
        with ProcessPoolExecutor(workers) as ex:
            for r in ex.map(_one_table, jobs):
                out.append(r)
                if progress is not None:
                    progress(len(out), len(jobs))
    else:
        for job in jobs:
            out.append(_one_table(job))
            if progress is not None:
                progress(len(out), len(jobs))
    stats = {"cpu_s": 0.0, "solved": 0, "unconverged": 0, "positions": 0}
    res: list = [dict() for _ in fingers]
    for (fi, name, j, pos), (y, ok, computed, cpu) in zip(where, out, strict=True):
        stats["cpu_s"] += cpu
        stats["solved"] += computed
        stats["unconverged"] += int((~ok).sum())
        stats["positions"] += ok.size
        if name not in res[fi]:
            res[fi][name] = (pos, np.empty((len(loads), pos.size, 2 * k + 1), np.float32))
        res[fi][name][1][j] = y
    return res, stats


class FECalibrationProblem(CalibrationProblem):
    """:class:`~fingerfriction.mechanics._calibration_problem.CalibrationProblem` with the FE
    surrogate as its forward model (see the module notes): ``tables(z)`` interpolates the grid
    nodes' outlines; :meth:`build` solves (or reads from the cache) the nodes' tables;
    :meth:`exact_tables` solves one finger's. ``opts`` is a
    :class:`~fingerfriction.mechanics.fe.calibration.FECalibrationOptions` (not imported here:
    that module imports this one)."""

    def __init__(self, trials, initial: FEFingerParams, opts, cache_dir=None):
        self.mesh = opts.mesh or default_mesh()
        self.cache_dir = cache_dir
        super().__init__(trials, initial, opts)
        self.t_fe = 0.0
        self.fe_tables = 0  # tables solved (not read from the cache)
        self.fe_unconverged = 0
        self.fe_positions = 0
        self.axes = np.log(np.asarray(opts.levels))
        self.nodes = grid_nodes(len(self.fit), opts.levels, opts.design)
        self._node_tabs: dict | None = None
        #: The additive correction (:meth:`correct`): surface name -> tables added, or None.
        self.correction: dict | None = None

    # the fixed cells and loads are the options', not the data's: the grid is shared
    @staticmethod
    def _grid(initial, opts) -> tuple[float, np.ndarray]:
        u = np.linspace(0.0, 0.97 * min(initial.radius * min(opts.levels), initial.radius), 4001)
        above = np.flatnonzero(initial.outline(u) >= opts.clearance)
        hw = float(u[above[0]]) if above.size else float(u[-1])
        k = int(math.floor(hw / opts.grid_step))
        return k * opts.grid_step, opts.grid_step * np.arange(-k, k + 1)

    @staticmethod
    def _table_loads(allload: np.ndarray, opts) -> np.ndarray:
        return np.asarray(opts.loads, float)

    def finger(self, z: np.ndarray) -> FEFingerParams:
        ratios = np.exp(self.fields(z)).tolist()
        return finger_with(self.initial, dict(zip(self.fit, ratios, strict=True)))

    def node_finger(self, node: tuple) -> FEFingerParams:
        lv = self.opts.levels
        return finger_with(self.initial, {f: lv[i] for f, i in zip(self.fit, node, strict=True)})

    def _solve_tables(self, fingers: list, progress=None) -> list:
        """FE tables of ``fingers`` on the problem's surfaces and loads (:func:`fe_tables`)."""
        res, st = fe_tables(fingers, [sd.surface for sd in self.surfaces], loads=self.loads,
                            half_width=self.hw, step=self.opts.step, grid_step=self.opts.grid_step,
                            mesh=self.mesh, cache_dir=self.cache_dir, workers=self.opts.workers,
                            progress=progress)
        self.t_fe += st["cpu_s"]
        self.fe_tables += st["solved"]
        self.fe_unconverged += st["unconverged"]
        self.fe_positions += st["positions"]
        return res

    def build(self, progress=None) -> None:
        """Solve (or read from the cache) the FE tables of every grid node."""
        per = self._solve_tables([self.node_finger(n) for n in self.nodes], progress)
        self._node_tabs = {sd.name: (per[0][sd.name][0], np.stack([p[sd.name][1] for p in per]))
                           for sd in self.surfaces}

    def weights(self, z: np.ndarray) -> np.ndarray:
        """Interpolation weights of the grid's nodes at ``z`` (``log`` ratios), ``(n_nodes,)``."""
        per = [_lagrange(self.axes, float(t)) for t in self.fields(z)]
        if self.opts.design == "tensor":
            return np.array([math.prod(per[a][i] for a, i in enumerate(node)) for node in self.nodes])
        # star: the sum over the axes of each axis' interpolation, minus (k - 1) centres
        c = self.opts.levels.index(1.0)
        w = np.zeros(len(self.nodes))
        for i, node in enumerate(self.nodes):
            off = [a for a, j in enumerate(node) if j != c]
            w[i] = per[off[0]][node[off[0]]] if off else sum(p[c] for p in per) - (len(per) - 1)
        return w

    def tables(self, z: np.ndarray, level: str, step: float, perturbed: bool = False) -> dict:
        if self._node_tabs is None:
            self.build()
        t0 = time.process_time()
        w = self.weights(z)
        out = {name: (pos, np.tensordot(w, Y, axes=1).astype(float))
               for name, (pos, Y) in self._node_tabs.items()}
        if self.correction is not None:
            out = {name: (pos, Y + self.correction[name]) for name, (pos, Y) in out.items()}
        self.t_bem += time.process_time() - t0
        self.last_failures = 0
        return out

    def exact_tables(self, finger: FEFingerParams) -> dict:
        """The FE tables of ``finger`` itself (no surrogate), as :meth:`tables` returns them."""
        tabs = self._solve_tables([finger])[0]
        return {name: (pos, Y.astype(float)) for name, (pos, Y) in tabs.items()}

    def correct(self, exact: dict, z: np.ndarray) -> None:
        """Make the surrogate exact at ``z``: from now on :meth:`tables` adds ``exact`` (the
        tables of ``self.finger(z)``, :meth:`exact_tables`) minus the uncorrected surrogate's
        tables at ``z`` (module notes; replaces an earlier correction)."""
        self.correction = None
        raw = self.tables(z, "fine", self.opts.step)
        self.correction = {name: exact[name][1] - Y for name, (_, Y) in raw.items()}
