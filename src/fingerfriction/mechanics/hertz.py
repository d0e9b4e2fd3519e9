"""Analytic reference: plane-strain Hertz line contact (a test oracle for the BEM solver).

A rigid-on-elastic (or elastic-on-elastic with composite modulus) cylinder of radius
``R`` pressed on a flat by a load per unit width ``P'`` (Johnson, *Contact Mechanics*,
1985, Sec. 4.3, Eq. 4.43-4.45)::

    a    = sqrt(4 P' R / (pi E*))                      contact half-width
    p(x) = (2 P' / (pi a^2)) sqrt(a^2 - x^2)           |x| <= a, 0 outside
    p0   = 2 P' / (pi a)                               peak pressure

Units: mm, N/mm (load per unit width), MPa = N/mm^2.
"""

from __future__ import annotations

import math

import numpy as np

from .._check import positive

__all__ = ["hertz_half_width", "hertz_pressure", "hertz_peak_pressure"]


def hertz_half_width(load_per_width: float, radius: float, modulus: float) -> float:
    """Half-width ``a`` in mm of a plane-strain Hertz line contact.

    Parameters
    ----------
    load_per_width : float
        Normal load per unit width ``P'`` in N/mm.
    radius : float
        Cylinder radius ``R`` in mm.
    modulus : float
        Effective (plane-strain, composite) modulus ``E*`` in MPa (N/mm^2).

    Returns
    -------
    float
        ``a = sqrt(4 P' R / (pi E*))`` in mm.
    """
    P = positive("load_per_width", load_per_width, "N/mm")
    R = positive("radius", radius, "mm")
    E = positive("modulus", modulus, "MPa")
    return math.sqrt(4.0 * P * R / (math.pi * E))


def hertz_peak_pressure(load_per_width: float, radius: float, modulus: float) -> float:
    """Peak pressure ``p0 = 2 P' / (pi a)`` in MPa (N/mm^2)."""
    a = hertz_half_width(load_per_width, radius, modulus)
    return 2.0 * float(load_per_width) / (math.pi * a)


def hertz_pressure(x, load_per_width: float, radius: float, modulus: float, *, center: float = 0.0):
    """Hertz line-contact pressure ``p(x)`` in MPa at positions ``x`` (mm).

    Parameters
    ----------
    x : array_like
        Positions in mm, any shape.
    load_per_width, radius, modulus : float
        As in :func:`hertz_half_width` (N/mm, mm, MPa).
    center : float, optional
        Position of the cylinder axis in mm (default 0).

    Returns
    -------
    ndarray
        ``(2 P'/(pi a^2)) sqrt(a^2 - (x - center)^2)`` inside the contact, 0 outside;
        same shape as ``x``.
    """
    a = hertz_half_width(load_per_width, radius, modulus)
    xr = np.asarray(x, dtype=float) - float(center)
    inside = np.clip(a * a - xr * xr, 0.0, None)
    return 2.0 * float(load_per_width) / (math.pi * a * a) * np.sqrt(inside)
