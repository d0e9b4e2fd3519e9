"""Influence coefficients of the finger models of the plane-strain BEM (:mod:`.bem`, whose
notes derive them): surface displacement per unit cell pressure of the homogeneous half-space,
of an elastic layer on a rigid base, and of a stiff skin on a soft pulp.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.fft as sfft

__all__ = ["halfspace_kernel", "layer_compliance", "layer_kernel", "skin_compliance", "skin_kernel"]


def _xlogx_minus_x(t: np.ndarray) -> np.ndarray:
    at = np.abs(t)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(at > 0, t * np.log(np.where(at > 0, at, 1.0)) - t, 0.0)


def halfspace_kernel(x: np.ndarray, dx: float, modulus: float, ref_length: float) -> np.ndarray:
    """Half-space influence coefficients (mm per N/mm^2 of cell pressure).

    Surface displacement (into the body, mm) at ``x`` due to a unit pressure on the cell
    ``[-dx/2, dx/2]``, zero at distance ``ref_length`` (for a point load).

    Parameters
    ----------
    x : (m,) ndarray
        Distances in mm.
    dx : float
        Cell width in mm.
    modulus : float
        ``E*`` in MPa.
    ref_length : float
        Reference distance ``l`` in mm.
    """
    F = _xlogx_minus_x(x + dx / 2) - _xlogx_minus_x(x - dx / 2)
    return -(2.0 / (math.pi * modulus)) * (F - dx * math.log(ref_length))


def layer_compliance(q: np.ndarray, poisson: float) -> np.ndarray:
    """Dimensionless layer factor ``C(q)``, ``q = |k| t`` (see the notes of :mod:`.bem`).

    Written with ``exp(-2q)`` scaling so it is finite for any ``q >= 0``.
    """
    q = np.abs(np.asarray(q, dtype=float))
    kap = 3.0 - 4.0 * poisson
    e2 = np.exp(-2.0 * q)
    e4 = e2 * e2
    num = kap * (1.0 - e4) - 4.0 * q * e2
    den = kap * (1.0 + e4) + (1.0 + kap * kap + 4.0 * q * q) * e2
    return num / den


def _reg_log_cell(x: np.ndarray, dx: float, c: float) -> np.ndarray:
    """Cell integral of ``ln(1 + c^2/xi^2)`` over ``[x - dx/2, x + dx/2]``."""

    def A(t):
        return t * np.log(t * t + c * c) - 2.0 * t + 2.0 * c * np.arctan(t / c) - 2.0 * _xlogx_minus_x(t)

    return A(x + dx / 2) - A(x - dx / 2)


def layer_kernel(x: np.ndarray, dx: float, modulus: float, thickness: float, poisson: float) -> np.ndarray:
    """Influence coefficients of an elastic layer of ``thickness`` (mm) on a rigid base (mm per
    N/mm^2 of cell pressure), at distances ``x`` (mm) from a cell of width ``dx`` (mm):
    the analytic part of the log singularity plus the remainder summed on a long periodic
    grid (the layer model of :mod:`.bem`; ``modulus`` is ``E*`` in MPa)."""
    t = thickness
    c = t
    analytic = _reg_log_cell(x, dx, c) / (math.pi * modulus)
    # Remainder R(k) = 2 (C(kt) - 1 + exp(-kc)) / (E* k): finite at k = 0, decays like
    # exp(-min(2t, c) k). Summed on a long periodic grid (period >= 400 t + span) so that
    # the images are negligible; no aliasing because R S is tiny at the Nyquist number.
    span = float(np.max(np.abs(x))) + dx
    period = max(400.0 * t, 8.0 * span)
    m = int(2 ** math.ceil(math.log2(max(period / dx, 1024))))
    m = min(m, 2**22)
    k = 2.0 * math.pi * sfft.rfftfreq(m, d=dx)
    q = k * t
    with np.errstate(divide="ignore", invalid="ignore"):
        Rk = 2.0 * (layer_compliance(q, poisson) - 1.0 + np.exp(-k * c)) / (modulus * k)
        S = np.where(k > 0, 2.0 * np.sin(0.5 * k * dx) / k, dx)
    kap = 3.0 - 4.0 * poisson
    c1 = 4.0 * (kap - 1.0) / (1.0 + kap) ** 2
    Rk[0] = 2.0 * (c1 * t - c) / modulus
    r = sfft.irfft(Rk * S, m) / dx  # periodic kernel sampled at j dx
    j = np.rint(np.abs(x) / dx).astype(int)
    return analytic + r[j]


def skin_compliance(k: np.ndarray, modulus: float, skin_modulus: float, skin_thickness: float) -> np.ndarray:
    """``W/P`` (mm per MPa per 1/mm) of the skin-on-pulp model at wavenumbers ``k > 0``."""
    B = skin_modulus * skin_thickness**3 / 12.0
    bend = B * k**4
    local = 0.5 * skin_modulus * k
    return 1.0 / (0.5 * modulus * k + bend * local / (bend + local))


def skin_kernel(
    x: np.ndarray, dx: float, modulus: float, skin_modulus: float, skin_thickness: float, ref_length: float
) -> np.ndarray:
    """Influence coefficients of the skin-on-pulp model (a stiff skin of ``skin_modulus`` MPa
    and ``skin_thickness`` mm on a half-space pulp of ``E* = modulus`` MPa), in mm per N/mm^2
    of cell pressure at distances ``x`` (mm) from a cell of width ``dx`` (mm), zero at
    ``ref_length`` (mm) as :func:`halfspace_kernel` (the skin model of :mod:`.bem`)."""
    c = 4.0 * dx
    e_hi = modulus + skin_modulus
    analytic = halfspace_kernel(x, dx, modulus, ref_length) - _reg_log_cell(x, dx, c) / (math.pi * modulus)
    analytic += _reg_log_cell(x, dx, c) / (math.pi * e_hi)
    span = float(np.max(np.abs(x))) + dx
    period = max(8.0 * span, 400.0 * skin_thickness, 400.0 * c)
    m = int(2 ** math.ceil(math.log2(max(period / dx, 1024))))
    m = min(m, 2**22)
    k = 2.0 * math.pi * sfft.rfftfreq(m, d=dx)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        e = np.exp(-k * c)
        # R = W/P - (2/(E_hi k)) (1 - e^{-kc}) - (2/(E* k)) e^{-kc}: finite at 0, ~k^-4 at inf.
        Rk = skin_compliance(k, modulus, skin_modulus, skin_thickness)
        Rk -= 2.0 / (e_hi * k) * (1.0 - e) + 2.0 / (modulus * k) * e
        S = np.where(k > 0, 2.0 * np.sin(0.5 * k * dx) / k, dx)
    # k -> 0: W/P - 2/(E* k) -> 0 and the rest tends to 2 c (1/E* - 1/E_hi).
    Rk[0] = 2.0 * c * (1.0 / modulus - 1.0 / e_hi)
    r = sfft.irfft(Rk * S, m) / dx
    j = np.rint(np.abs(x) / dx).astype(int)
    return analytic + r[j]
