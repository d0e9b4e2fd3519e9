"""The fingertip pad below the contact tables' loads: its force-indentation law
(:class:`PadLaw`, which sets how fast the load leaves zero when the finger lands,
:mod:`~fingerfriction.sim.kinematics`) and the outline it takes as it unloads below the
lowest tabulated load (:func:`low_load_outline`, used by
:meth:`~fingerfriction.sim.contact.ContactTable.profile`)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["PadLaw", "low_load_outline"]


@dataclass(frozen=True)
class PadLaw:
    """The fingertip pad's normal force against its indentation: ``F = (k / b) (exp(b
    delta) - 1)`` (Serina, Mote & Rempel 1997, the exponential law of the pulp compressed by
    a flat; Pawluk & Howe 1999).

    Parameters
    ----------
    stiffness : float
        Initial stiffness ``k`` in N/mm (the slope at zero load).
    stiffening : float
        Stiffening rate ``b`` in 1/mm.
    """

    stiffness: float
    stiffening: float

    def force(self, delta):
        """Force in N at the indentation ``delta`` in mm (0 for ``delta <= 0``)."""
        d = np.maximum(np.asarray(delta, float), 0.0)
        return self.stiffness / self.stiffening * np.expm1(self.stiffening * d)

    def indentation(self, force):
        """Indentation in mm at the force ``force`` in N (0 for ``force <= 0``)."""
        f = np.maximum(np.asarray(force, float), 0.0)
        return np.log1p(self.stiffening * f / self.stiffness) / self.stiffening


#: Width in mm of the soft minimum that joins the two parts of :func:`low_load_outline`.
_JOIN_MM = 0.05


def low_load_outline(xi: np.ndarray, y0: np.ndarray, p0: np.ndarray, load: float, load0: float,
                     pad) -> tuple[np.ndarray, np.ndarray]:
    """The finger's outline and pressure below the lowest tabulated load ``load0``.

    A fingertip's contact grows from a point as it is pressed (2-D Hertz: half-width ~
    sqrt(load)); the tables start at ``load0``. Below it, the pad of the lowest load's
    solution ``(y0, p0)`` is unloaded along its force-indentation law ``pad``
    (:class:`~fingerfriction.sim.kinematics.PadLaw`, indentation ``delta(F)``):

    * away from the contact the outline is ``y0`` raised by ``delta(load0) - delta(load)``
      (the finger's body rises as it unloads);
    * around it the pad is a body of radius ``R_c = a0^2 / (2 delta(load0))`` truncated by
      the ground, ``h_c + max(0, (xi - x_m)^2 / (2 R_c) - delta(load))``, so that the contact
      half-width is ``a = sqrt(2 R_c delta(load))``: ``a0`` (the tabulated half-width) at
      ``load0``, a point at 0, and ``~ sqrt(load)`` at small loads (``delta`` ~ load / k);
    * the two join by a soft minimum 0.05 mm wide, never below ``y0``;
    * the pressure is Hertz's semi-ellipse over ``[x_m - a, x_m + a]``, carrying ``load``
      in the units of ``p0`` (``p0`` carries ``load0``).

    ``x_m``, ``a0`` and ``h_c`` are the middle, half the span and the median height of the
    lowest load's contact (flat ground: where the simulated finger lands and presses).

    Parameters
    ----------
    xi : (m,) ndarray
        Grid relative to the finger centre, mm.
    y0, p0 : (m,) ndarray
        The outline (mm) and pressure (N/mm^2) at ``load0``.
    load, load0 : float
        The load and the lowest tabulated load, N (``load < load0``; <= 0: no contact).
    pad : PadLaw

    Returns
    -------
    y_f, p : (m,) ndarray
    """
    touch = np.flatnonzero(p0 > 0)
    if touch.size == 0:
        return y0, p0
    xl, xr = float(xi[touch[0]]), float(xi[touch[-1]])
    x_m, a0 = 0.5 * (xl + xr), max(0.5 * (xr - xl), float(xi[1] - xi[0]))
    h_c = float(np.median(y0[touch]))
    d0 = float(pad.indentation(load0))
    d = float(pad.indentation(load))
    r_c = a0 * a0 / (2.0 * d0)
    core = h_c + np.maximum((xi - x_m) ** 2 / (2.0 * r_c) - d, 0.0)
    far = y0 + (d0 - d)
    lo = np.minimum(core, far)
    y = np.maximum(lo - _JOIN_MM * np.log1p(np.exp(-np.abs(core - far) / _JOIN_MM)), y0)
    p = np.zeros_like(p0)
    if load > 0 and d > 0:
        a = math.sqrt(2.0 * r_c * d)
        inside = np.abs(xi - x_m) < a
        dxi = float(xi[1] - xi[0])
        width = load0 / max(float(p0.sum()) * dxi, 1e-300)  # the depth that turns p0 into load0
        p[inside] = 2.0 * load / (math.pi * a * a * width) * np.sqrt(a * a - (xi[inside] - x_m) ** 2)
    return y, p
