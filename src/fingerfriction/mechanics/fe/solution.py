"""Results of the FE contact solver: :class:`FESolution` (one solve) and :class:`FEState` (a solve's
state, to warm-start another); :mod:`.solver` returns them and re-exports them."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["FESolution", "FEState"]


@dataclass
class FESolution:
    """One FE contact solve.

    Attributes
    ----------
    x_finger : float
        Finger centre (mm, surface coordinates).
    load : float
        Normal force ``F_N`` in N.
    z : float
        Height in mm of the bone's rigid translation (the undeformed finger's lowest point
        sits at ``(x_finger, z)``).
    outline_x, outline_y : (m,) ndarray
        Deformed outline points of the lower half (mm, surface coordinates), left to right.
    outline_pressure : (m,) ndarray
        Contact pressure (MPa) at each outline point, per unit horizontal length.
    iterations : int
        Newton iterations.
    residual : float
        Final largest out-of-balance nodal force relative to ``P'``.
    success : bool
    message : str
    """

    x_finger: float
    load: float
    z: float
    outline_x: np.ndarray
    outline_y: np.ndarray
    outline_pressure: np.ndarray
    iterations: int
    residual: float
    success: bool
    message: str

    def on_grid(self, x: np.ndarray, load: float | None = None, width: float | None = None):
        """Outline height ``y_f`` (mm) and pressure ``p`` (MPa) on the surface positions ``x`` (mm).

        ``y_f`` is interpolated linearly between outline points; ``p`` likewise, then scaled
        so that ``width * int p dx`` equals ``load`` (N) when both are given.
        """
        x = np.asarray(x, float)
        y = np.interp(x, self.outline_x, self.outline_y)
        p = np.interp(x, self.outline_x, self.outline_pressure, left=0.0, right=0.0)
        if load is not None and width is not None and x.size > 1:
            tot = p.sum() * float(x[1] - x[0]) * width
            if tot > 0:
                p *= load / tot
        return y, p


@dataclass
class FEState:
    """Nodal displacements (mm) and rigid height ``z`` (mm) of a solve, to warm-start
    another; with its finger position ``x_c`` (mm) and load per width ``P`` (N/mm)."""

    u: np.ndarray
    z: float
    x_c: float | None = None
    P: float | None = None
