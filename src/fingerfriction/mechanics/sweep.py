"""Sliding sweeps: the contact at many finger positions, with warm starts.

A sweep solves the contact at each finger position in turn, starting each solve from the
previous position's pressure (same finger-frame cells), which cuts the number of
conjugate-gradient iterations several-fold compared with cold starts. Its contact regions
are in the project's region format (:mod:`fingerfriction.regions`), ready for
:func:`fingerfriction.model.blindspots.blind_spots` and :func:`~fingerfriction.model.blindspots.occupancy`.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field

import numpy as np

from .._check import check_option
from ..model.blindspots import BlindSpots, Occupancy, blind_spots, occupancy
from ..regions import n_regions
from ..surfaces import Surface
from .bem import GEOMETRIC_TOL, ContactSolver, check_load
from .finger import FingerParams

__all__ = ["SweepResult", "sweep", "default_positions", "OutlineTable", "outline_table", "CONTACT_KINDS"]

#: The two contacts a sweep gives: ``'geometric'`` (the finger within the video's 70 um of
#: the surface, the paper's) and ``'mechanical'`` (positive pressure).
CONTACT_KINDS = ("geometric", "mechanical")

log = logging.getLogger(__name__)


def default_positions(
    surface: Surface | None = None, *, window: float = 26.0, step: float = 0.01
) -> np.ndarray:
    """Finger positions (mm) at ``step`` across a ``window`` centred on the feature.

    The paper analyses a 26 mm window centred on the relief feature at 0.01 mm
    resolution (Methods, "Force data processing"): 2601 positions by default.
    """
    if not (math.isfinite(window) and window > 0):
        raise ValueError(f"window must be a positive length in mm, got {window!r}")
    if not (math.isfinite(step) and step > 0):
        raise ValueError(f"step must be a positive length in mm, got {step!r}")
    c = 0.0
    if surface is not None:
        a, b = surface.feature_extent
        c = 0.5 * (a + b)
    m = int(round(window / step))
    if m > 1_000_000:  # one contact solve per position: a bound on time and memory
        raise ValueError(f"a {window:g} mm window at steps of {step:g} mm is {m + 1} positions, more than "
                         "1000001; take a larger step")
    return c - window / 2 + step * np.arange(m + 1)


def _pad_regions(rows: list[np.ndarray]) -> np.ndarray:
    k = max(1, max((r.shape[0] for r in rows), default=0))
    out = np.full((len(rows), k, 2), np.nan)
    for i, r in enumerate(rows):
        out[i, : r.shape[0]] = r
    return out


@dataclass
class SweepResult:
    """Contact at each finger position of a sweep.

    Attributes
    ----------
    positions : (m,) ndarray
        Finger centre positions in mm.
    load : float
        Normal load in N.
    mechanical_regions : (m, k, 2) ndarray
        ``p > 0`` intervals in mm per position, NaN padded (region format).
    geometric_regions : (m, k, 2) ndarray
        ``gap <= gap_tol`` intervals in mm per position, NaN padded.
    gap_tol : float
        Geometric contact tolerance in mm.
    success : (m,) bool ndarray
        Per-position convergence flags.
    iterations : (m,) int ndarray
        Conjugate-gradient iterations per position.
    offsets : (n,) ndarray
        Grid cell centres relative to the finger centre (mm); the grid of position ``i``
        is ``positions[i] + offsets``.
    finger_y : (m, n) ndarray or None
        Deformed finger lower surface heights (mm) when ``keep_profiles=True``.
    pressure : (m, n) ndarray or None
        Pressures (MPa) when ``keep_profiles=True``.
    messages : list of str
        Messages of the positions that failed (empty when all succeeded).
    """

    positions: np.ndarray
    load: float
    mechanical_regions: np.ndarray
    geometric_regions: np.ndarray
    gap_tol: float
    success: np.ndarray
    iterations: np.ndarray
    offsets: np.ndarray
    finger: FingerParams = field(repr=False)
    finger_y: np.ndarray | None = field(default=None, repr=False)
    pressure: np.ndarray | None = field(default=None, repr=False)
    messages: list[str] = field(default_factory=list)

    @property
    def all_converged(self) -> bool:
        return bool(self.success.all())

    def regions(self, kind: str = "geometric") -> np.ndarray:
        """Regions of ``kind`` (one of :data:`CONTACT_KINDS`), ``(m, k, 2)``."""
        check_option("kind", kind, CONTACT_KINDS)
        return self.geometric_regions if kind == "geometric" else self.mechanical_regions

    def blind_spots(self, kind: str = "geometric", **kwargs) -> BlindSpots:
        """Tactile blind spots of the sweep (:func:`fingerfriction.model.blindspots.blind_spots`)."""
        return blind_spots(self.regions(kind), **kwargs)

    def occupancy(self, kind: str = "geometric", **kwargs) -> Occupancy:
        """Contact occupancy map (:func:`fingerfriction.model.blindspots.occupancy`)."""
        return occupancy(self.regions(kind), **kwargs)

    def n_contacts(self, kind: str = "geometric") -> np.ndarray:
        """Number of simultaneous contact regions per position, ``(m,)`` int."""
        return n_regions(self.regions(kind))

    def max_contacts(self, kind: str = "geometric") -> int:
        """Largest number of simultaneous contact regions over the sweep."""
        return int(self.n_contacts(kind).max(initial=0))

    def profile_at(self, x_finger: float) -> tuple[np.ndarray, np.ndarray]:
        """Deformed finger outline at any position, linearly interpolated between positions.

        Returns
        -------
        x : (n,) ndarray
            Surface coordinates (mm): ``x_finger + offsets``.
        y : (n,) ndarray
            Height of the deformed finger lower surface (mm).
        """
        if self.finger_y is None:
            raise ValueError("this sweep has no profiles; run sweep(..., keep_profiles=True)")
        pos = self.positions
        if not (pos[0] <= x_finger <= pos[-1]):
            raise ValueError(f"x_finger={x_finger!r} mm is outside the sweep [{pos[0]:g}, {pos[-1]:g}] mm")
        j = int(np.clip(np.searchsorted(pos, x_finger) - 1, 0, pos.size - 2))
        w = (x_finger - pos[j]) / (pos[j + 1] - pos[j])
        # Profiles are stored in the finger frame, so interpolation keeps the shape.
        y = (1 - w) * self.finger_y[j] + w * self.finger_y[j + 1]
        return x_finger + self.offsets, y


def sweep(
    surface,
    finger: FingerParams,
    positions=None,
    *,
    load: float = 0.3,
    n: int = 1024,
    half_width: float | None = None,
    tol: float = 1e-6,
    max_iter: int = 1000,
    gap_tol: float = GEOMETRIC_TOL,
    keep_profiles: bool = False,
    solver: ContactSolver | None = None,
) -> SweepResult:
    """Contact at each finger position of a slide, with warm starts.

    Parameters
    ----------
    surface : Surface or callable
        The relief ``h(x)`` (mm).
    finger : FingerParams
        The finger.
    positions : (m,) array_like, optional
        Finger centre positions in mm, increasing or decreasing; default
        :func:`default_positions` (0.01 mm steps over the 26 mm window centred on the
        feature, 2601 positions).
    load : float, optional
        Normal force in N (default 0.3).
    n, half_width : optional
        Grid of the :class:`ContactSolver` (default 1024 cells over
        ``finger.default_half_width()``).
    tol : float, optional
        Convergence tolerance per position (default 1e-6, looser than a single solve's
        1e-8; why: docs/mechanics.md, 'Sweep tolerance').
    max_iter, gap_tol : optional
        As in :meth:`ContactSolver.solve`.
    keep_profiles : bool, optional
        Also return the deformed outlines and pressures, ``(m, n)`` each (memory:
        ``16 m n`` bytes, 43 MB for 2601 x 1024).
    solver : ContactSolver, optional
        Reuse a solver (its finger must be ``finger``).

    Returns
    -------
    SweepResult
    """
    if not isinstance(finger, FingerParams):
        raise TypeError(f"finger must be a FingerParams, got {type(finger).__name__}")
    F = check_load(load)
    if positions is None:
        positions = default_positions(surface if isinstance(surface, Surface) else None)
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 1 or pos.size < 1:
        raise ValueError(f"positions must be a non-empty 1-D array in mm, got shape {pos.shape}")
    if not np.all(np.isfinite(pos)):
        raise ValueError("positions contain a non-finite value")
    if solver is None:
        solver = ContactSolver(finger, n=n, half_width=half_width)
    elif solver.finger != finger:
        raise ValueError("solver was built for a different finger")
    solver.check_resolution(F)
    opts = {"load": F, "tol": tol, "max_iter": max_iter, "gap_tol": gap_tol, "check": False}
    mech_rows, geom_rows, ok, its, ys, ps, msgs = _warm_sweep(solver, surface, pos, opts, keep_profiles)
    if msgs:
        log.warning("%d of %d sweep positions did not converge; first: %s", len(msgs), pos.size, msgs[0])
    return SweepResult(
        positions=pos, load=F, mechanical_regions=_pad_regions(mech_rows),
        geometric_regions=_pad_regions(geom_rows), gap_tol=float(gap_tol), success=ok,
        iterations=its, offsets=solver.u.copy(), finger=finger, finger_y=ys, pressure=ps,
        messages=msgs,
    )


def _warm_sweep(solver: ContactSolver, surface, pos: np.ndarray, opts: dict, keep_profiles: bool):
    """The solves of :func:`sweep`, each warm-started from the previous position's pressure
    (linearly extrapolated over equal steps; retried cold when it fails):
    ``(mech_rows, geom_rows, success, iterations, finger_y, pressure, messages)``."""
    m = pos.size
    mech_rows: list[np.ndarray] = []
    geom_rows: list[np.ndarray] = []
    ok = np.zeros(m, dtype=bool)
    its = np.zeros(m, dtype=int)
    ys = np.empty((m, solver.n)) if keep_profiles else None
    ps = np.empty((m, solver.n)) if keep_profiles else None
    msgs: list[str] = []
    prev = None
    prev2 = None
    for i, xf in enumerate(pos):
        guess = None
        if prev is not None:
            guess = prev.pressure
            if prev2 is not None and abs((xf - prev.x_finger) - (prev.x_finger - prev2.x_finger)) < 1e-9:
                # Equal steps: extrapolate linearly (the error of the guess drops from O(step)
                # to O(step^2); measured 22 -> see benchmarks/contact.py).
                guess = np.maximum(2.0 * prev.pressure - prev2.pressure, 0.0)
        sol = solver.solve(surface, xf, x0=guess, **opts)
        if not sol.success and prev is not None:
            sol = solver.solve(surface, xf, **opts)  # retry cold
        mech_rows.append(sol.mechanical_regions)
        geom_rows.append(sol.geometric_regions)
        ok[i] = sol.success
        its[i] = sol.iterations
        if not sol.success:
            msgs.append(f"x_finger={xf:.4f} mm: {sol.message}")
        if keep_profiles:
            ys[i] = sol.finger_y  # type: ignore[index]
            ps[i] = sol.pressure  # type: ignore[index]
        prev2 = prev if sol.success else None
        prev = sol if sol.success else None
    return mech_rows, geom_rows, ok, its, ys, ps, msgs


@dataclass
class OutlineTable:
    """Deformed finger outlines tabulated over finger positions and normal loads.

    Built by :func:`outline_table` for renderers that need the finger's silhouette at
    arbitrary positions and loads (the paper's normal force fluctuates by +-50 mN around
    0.3 N): bilinear interpolation in (load, position) of outlines stored in the finger
    frame, so a contact patch moving with the surface is not smeared by more than one
    table step.

    Attributes
    ----------
    positions : (m,) ndarray
        Finger centre positions in mm (increasing, uniform).
    loads : (l,) ndarray
        Normal loads in N (increasing).
    offsets : (n,) ndarray
        Grid offsets from the finger centre in mm.
    finger_y : (l, m, n) ndarray of float32
        Deformed lower-surface heights in mm.
    success : (l, m) bool ndarray
        Convergence flags.
    """

    positions: np.ndarray
    loads: np.ndarray
    offsets: np.ndarray
    finger_y: np.ndarray
    success: np.ndarray
    finger: FingerParams = field(repr=False)

    def at(self, x_finger: float, load: float) -> tuple[np.ndarray, np.ndarray]:
        """Outline ``(x, y)`` (mm, surface coordinates) at one position and load.

        Raises ``ValueError`` outside the tabulated ranges (no extrapolation).
        """
        pos, ld = self.positions, self.loads
        if not (pos[0] <= x_finger <= pos[-1]):
            raise ValueError(f"x_finger={x_finger!r} mm is outside the table [{pos[0]:g}, {pos[-1]:g}] mm")
        if not (ld[0] - 1e-12 <= load <= ld[-1] + 1e-12):
            raise ValueError(f"load={load!r} N is outside the table [{ld[0]:g}, {ld[-1]:g}] N")
        j, wj = _bracket(pos, x_finger)
        if ld.size == 1:
            i, wi = 0, 0.0
        else:
            i, wi = _bracket(ld, load)
        Y = self.finger_y
        i1 = min(i + 1, ld.size - 1)
        y = (
            (1 - wi) * ((1 - wj) * Y[i, j] + wj * Y[i, j + 1])
            + wi * ((1 - wj) * Y[i1, j] + wj * Y[i1, j + 1])
        )
        return x_finger + self.offsets, y.astype(float)


def _bracket(grid: np.ndarray, v: float) -> tuple[int, float]:
    j = int(np.clip(np.searchsorted(grid, v) - 1, 0, grid.size - 2))
    return j, float((v - grid[j]) / (grid[j + 1] - grid[j]))


def outline_table(
    surface,
    finger: FingerParams,
    positions=None,
    loads=(0.25, 0.3, 0.35),
    *,
    n: int = 1024,
    half_width: float | None = None,
    tol: float = 1e-6,
) -> OutlineTable:
    """Tabulate deformed finger outlines for a renderer (one warm-started sweep per load).

    Parameters
    ----------
    surface : Surface or callable
        The relief.
    finger : FingerParams
        The finger.
    positions : (m,) array_like, optional
        Increasing finger positions in mm (default :func:`default_positions`).
    loads : sequence of float, optional
        Increasing normal loads in N (default 0.25, 0.3, 0.35 N: the paper's 0.3 N
        +- 50 mN).
    n, half_width, tol : optional
        As in :func:`sweep`.

    Returns
    -------
    OutlineTable
        Memory: ``4 l m n`` bytes (32 MB for 3 loads x 2601 positions x 1024 cells).
    """
    ld = np.asarray(loads, dtype=float).ravel()
    if ld.size < 1 or not np.all(np.isfinite(ld)) or np.any(ld <= 0) or np.any(np.diff(ld) <= 0):
        raise ValueError(f"loads must be increasing positive forces in N, got {loads!r}")
    if positions is None:
        positions = default_positions(surface if isinstance(surface, Surface) else None)
    pos = np.asarray(positions, dtype=float)
    if pos.ndim != 1 or pos.size < 2 or np.any(np.diff(pos) <= 0):
        raise ValueError("positions must be an increasing 1-D array of at least 2 positions (mm)")
    solver = ContactSolver(finger, n=n, half_width=half_width)
    Y = np.empty((ld.size, pos.size, solver.n), dtype=np.float32)
    ok = np.empty((ld.size, pos.size), dtype=bool)
    for i, F in enumerate(ld):
        r = sweep(surface, finger, pos, load=float(F), tol=tol, keep_profiles=True, solver=solver)
        Y[i] = r.finger_y  # type: ignore[assignment]
        ok[i] = r.success
    return OutlineTable(
        positions=pos, loads=ld, offsets=solver.u.copy(), finger_y=Y, success=ok, finger=finger
    )
