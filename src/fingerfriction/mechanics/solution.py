"""The result of the plane-strain BEM (:class:`ContactSolution`, returned by
:class:`~fingerfriction.mechanics.bem.ContactSolver`) and the contact regions read from a
gap or a pressure (:func:`regions_within_gap`; the solver itself uses their compiled
equivalents in :mod:`._cgkernels`, tested equal).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .finger import FingerParams

__all__ = ["ContactSolution", "regions_within_gap"]


@dataclass
class ContactSolution:
    """Result of one contact solve (in the style of ``scipy.optimize.OptimizeResult``).

    Attributes
    ----------
    x : (n,) ndarray
        Cell centres in mm, surface coordinates.
    pressure : (n,) ndarray
        Contact pressure ``p(x)`` in MPa (N/mm^2), ``>= 0``.
    gap : (n,) ndarray
        Vertical gap ``y_f - h`` in mm (0 in mechanical contact).
    finger_y : (n,) ndarray
        Height in mm of the deformed finger's lower surface ``y_f(x)`` (surface
        coordinates: same reference as ``h``).
    surface_h : (n,) ndarray
        Relief height ``h(x)`` in mm on the grid.
    x_finger : float
        Finger centre position in mm (see :mod:`~fingerfriction.mechanics.finger`).
    load : float
        Normal load ``F_N`` in N.
    load_per_width : float
        ``P' = F_N / D`` in N/mm.
    z : float
        Height in mm of the lowest point of the *undeformed* outline (rigid body position).
    approach : float
        Rigid approach in mm: first-touch height of the undeformed outline minus ``z``
        (half-space: relative to the displacement reference, see module notes).
    mechanical_regions : (k, 2) ndarray
        Intervals ``[a, b]`` (mm) where ``p > 0``, cell edges.
    geometric_regions : (k, 2) ndarray
        Intervals (mm) where ``gap <= gap_tol``, edges interpolated linearly between cells.
    gap_tol : float
        Tolerance of the geometric criterion in mm (default 0.070: 3 px of the paper).
    iterations : int
        Conjugate-gradient iterations.
    residual : float
        Final relative change of the pressure, ``dx sum |p - p_old| / P'``.
    max_penetration : float
        Largest negative gap in mm (0 for an exact solution).
    load_error : float
        ``|dx sum p - P'| / P'``.
    success : bool
        True when converged within ``max_iter`` and the checks passed.
    message : str
        What happened, in words.
    """

    x: np.ndarray
    pressure: np.ndarray
    gap: np.ndarray
    finger_y: np.ndarray
    surface_h: np.ndarray
    x_finger: float
    load: float
    load_per_width: float
    z: float
    approach: float
    mechanical_regions: np.ndarray
    geometric_regions: np.ndarray
    gap_tol: float
    iterations: int
    residual: float
    max_penetration: float
    load_error: float
    success: bool
    message: str
    finger: FingerParams = field(repr=False)

    @property
    def dx(self) -> float:
        """Grid spacing in mm."""
        return float(self.x[1] - self.x[0])

    @property
    def offsets(self) -> np.ndarray:
        """Cell centres relative to the finger centre, ``x - x_finger`` (mm), ``(n,)``."""
        return self.x - self.x_finger

    @property
    def total_load(self) -> float:
        """Integrated pressure times the width ``D``: the load check, in N."""
        return float(self.pressure.sum() * self.dx * self.finger.width)


def _runs(m: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First and last indices of the runs of True in the boolean ``m`` (n,)."""
    d = np.diff(m.view(np.int8))
    starts = np.flatnonzero(d == 1) + 1
    ends = np.flatnonzero(d == -1)
    if m[0]:
        starts = np.concatenate(([0], starts))
    if m[-1]:
        ends = np.concatenate((ends, [m.size - 1]))
    return starts, ends


def regions_within_gap(x: np.ndarray, gap: np.ndarray, tol: float) -> np.ndarray:
    """Intervals where ``gap <= tol``, ends linearly interpolated at ``gap = tol``."""
    i0, i1 = _runs(gap <= tol)
    k = i0.size
    out = np.empty((k, 2))
    if k == 0:
        return out
    # Vectorised over the runs (this runs once per sweep position, where a Python loop
    # over runs was ~15 % of a warm-started sweep); the same arithmetic as interpolating
    # run by run. Only the first run can start at cell 0, only the last end at n - 1:
    # those ends are the grid's ends.
    f = 1 if i0[0] == 0 else 0
    i = i0[f:]
    g0, g1 = gap[i - 1], gap[i]
    out[f:, 0] = x[i - 1] + (x[i] - x[i - 1]) * (g0 - tol) / (g0 - g1)
    if f:
        out[0, 0] = x[0]
    e = k - 1 if i1[-1] == x.size - 1 else k
    j = i1[:e]
    g0, g1 = gap[j], gap[j + 1]
    out[:e, 1] = x[j] + (x[j + 1] - x[j]) * (tol - g0) / (g1 - g0)
    if e < k:
        out[-1, 1] = x[-1]
    return out


def _mechanical_regions(x: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Runs of ``p > 0`` as cell-edge intervals (as :func:`~fingerfriction.regions.regions_from_mask`)."""
    i0, i1 = _runs(p > 0)
    dx = float(x[1] - x[0])
    return np.column_stack([x[i0] - dx / 2, x[i1] + dx / 2])
