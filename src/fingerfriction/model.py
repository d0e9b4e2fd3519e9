"""The friction model of Janko, Wiertlewski & Visell (2018), Eq. (1)-(4).

Eq. (4) of the paper, for the contact regions ``C_i = [a_i, b_i]`` of one frame::

    F = F_int + F_def
      = sum_i  int_{C_i} (p0 + p1 dh/dx) (sin alpha + mu cos alpha) dx

with ``alpha = atan(dh/dx)``. The interfacial part (Eq. 2 with the constant pressure
``sigma_p = p0``) is ``F_int = p0 sum_i int (sin alpha + mu cos alpha) dx`` and the
deformation part (Eq. 3 with weight ``p1``) is ``F_def = p1 sum_i int dh/dx (sin alpha +
mu cos alpha) dx``.

Units
-----
The paper absorbs the effective contact size ``D`` (mm, across the finger) into the
parameters, so ``p0`` is a pressure times a width: **N/mm** (N/mm^2 x mm), and ``p1``
likewise **N/mm** (it multiplies the dimensionless slope). Integrals are over mm, so
forces come out in **N**.

Implementation
--------------
Because the integrands depend on ``x`` only through the slope ``s = dh/dx``, with
``sin alpha = s / sqrt(1 + s^2)`` and ``cos alpha = 1 / sqrt(1 + s^2)``, three
antiderivatives ``S(x) = int sin alpha``, ``K(x) = int cos alpha`` and ``Q(x) = int s sin
alpha`` are tabulated once per surface; each region then costs two interpolations:
``F_int = p0 [dS + mu dK]`` and ``F_def = p1 [dQ + mu dS]``. This makes 10^5 frames x 3
regions a few milliseconds, and it exposes the model's linearity in ``(p0, p1)`` that
:mod:`fingerfriction.fit` uses for its closed-form least-squares fit.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy.integrate import cumulative_simpson

from .regions import as_regions
from .surfaces import Surface

__all__ = ["FrictionParams", "ModelForces", "FrictionModel", "friction_force"]


@dataclass(frozen=True)
class FrictionParams:
    """Parameters of Eq. (4).

    Parameters
    ----------
    mu : float
        Coefficient of friction, dimensionless, ``0 <= mu <= 5``.
    p0 : float
        Constant contact pressure times the effective width D, in N/mm (>= 0).
    p1 : float
        Weight of the deformation term times D, in N/mm (any sign is accepted; the paper's
        fits are positive).
    """

    mu: float
    p0: float
    p1: float

    def __post_init__(self) -> None:
        for name in ("mu", "p0", "p1"):
            v = getattr(self, name)
            if not isinstance(v, (int, float, np.integer, np.floating)) or not math.isfinite(v):
                raise ValueError(f"FrictionParams.{name} must be a finite number, got {v!r}")
            object.__setattr__(self, name, float(v))
        if not 0.0 <= self.mu <= 5.0:
            raise ValueError(f"FrictionParams.mu must be in [0, 5], got {self.mu!r}")
        if self.p0 < 0:
            raise ValueError(f"FrictionParams.p0 (N/mm) must be >= 0, got {self.p0!r}")

    def to_json(self) -> str:
        return json.dumps(asdict(self))

    @classmethod
    def from_json(cls, text: str) -> FrictionParams:
        d = json.loads(text)
        return cls(mu=d["mu"], p0=d["p0"], p1=d["p1"])


@dataclass(frozen=True)
class ModelForces:
    """Model forces per frame, in N, each ``(n_frames,)``: Eq. (1) ``total = interfacial +
    deformation``, with ``interfacial`` from Eq. (2) and ``deformation`` from Eq. (3)."""

    total: np.ndarray
    interfacial: np.ndarray
    deformation: np.ndarray


class FrictionModel:
    """Eq. (4) for one surface, tabulated for fast evaluation over many frames.

    Parameters
    ----------
    surface : Surface
        The relief ``h(x)``.
    resolution : float, optional
        Step in mm of the antiderivative tables (default 0.5 um). Integration is by
        Simpson's rule, so the error on the paper's surfaces is below 1e-9 of the integral.
    margin : float, optional
        Extra span in mm tabulated on each side of the relief; outside the table the
        surface is flat and the integrals are continued exactly.
    """

    def __init__(self, surface: Surface, *, resolution: float = 5e-4, margin: float = 1.0):
        if not isinstance(surface, Surface):
            raise TypeError(f"surface must be a fingerfriction Surface, got {type(surface).__name__}")
        if not (math.isfinite(resolution) and resolution > 0):
            raise ValueError(f"resolution must be a positive length in mm, got {resolution!r}")
        self.surface = surface
        a, b = surface.feature_extent
        lo, hi = a - margin, b + margin
        n = max(int(math.ceil((hi - lo) / resolution)) + 1, 5)
        x = np.linspace(lo, hi, n)
        s = np.asarray(surface.dhdx(x), dtype=float)
        c = 1.0 / np.sqrt(1.0 + s * s)
        self._x = x
        self._S = cumulative_simpson(s * c, x=x, initial=0.0)  # int sin(alpha) dx
        self._K = cumulative_simpson(c, x=x, initial=0.0)  # int cos(alpha) dx
        self._Q = cumulative_simpson(s * s * c, x=x, initial=0.0)  # int s sin(alpha) dx
        # Outside the table the surface is flat: sin = 0, cos = 1, s sin = 0.
        self._end_slope = (float(s[0]), float(s[-1]))

    def _antiderivatives(self, x: np.ndarray):
        xt = self._x
        S = np.interp(x, xt, self._S)
        K = np.interp(x, xt, self._K)
        Q = np.interp(x, xt, self._Q)
        K = K + np.where(x < xt[0], x - xt[0], 0.0) + np.where(x > xt[-1], x - xt[-1], 0.0)
        return S, K, Q

    def basis(self, regions, mu: float) -> np.ndarray:
        """Per-frame integrals multiplying p0 and p1 in Eq. (4).

        Parameters
        ----------
        regions : (n_frames, n_max, 2) array_like
            Contact regions in mm (see :mod:`fingerfriction.regions`).
        mu : float
            Coefficient of friction.

        Returns
        -------
        (n_frames, 2) ndarray
            Column 0: ``sum_i int_{C_i} (sin alpha + mu cos alpha) dx`` in mm;
            column 1: ``sum_i int_{C_i} dh/dx (sin alpha + mu cos alpha) dx`` in mm.
            ``F = p0 * col0 + p1 * col1``.
        """
        if not (isinstance(mu, (int, float, np.integer, np.floating)) and math.isfinite(mu)):
            raise ValueError(f"mu must be a finite number, got {mu!r}")
        arr = as_regions(regions)
        valid = ~np.isnan(arr[..., 0])
        a = np.where(valid, arr[..., 0], 0.0)
        b = np.where(valid, arr[..., 1], 0.0)
        Sa, Ka, Qa = self._antiderivatives(a)
        Sb, Kb, Qb = self._antiderivatives(b)
        dS, dK, dQ = Sb - Sa, Kb - Ka, Qb - Qa
        out = np.empty((arr.shape[0], 2))
        out[:, 0] = np.sum(np.where(valid, dS + mu * dK, 0.0), axis=1)
        out[:, 1] = np.sum(np.where(valid, dQ + mu * dS, 0.0), axis=1)
        return out

    def forces(self, regions, params: FrictionParams) -> ModelForces:
        """Eq. (1)-(4): model forces in N for every frame, with their two components."""
        if not isinstance(params, FrictionParams):
            raise TypeError(f"params must be FrictionParams, got {type(params).__name__}")
        B = self.basis(regions, params.mu)
        f_int = params.p0 * B[:, 0]
        f_def = params.p1 * B[:, 1]
        return ModelForces(total=f_int + f_def, interfacial=f_int, deformation=f_def)


def friction_force(surface: Surface, regions, params: FrictionParams) -> ModelForces:
    """Eq. (4) of Janko et al. 2018: friction force for contact regions on a surface.

    Parameters
    ----------
    surface : Surface
        Relief profile.
    regions : (n_frames, n_max, 2) array_like, or a list of (a, b) pairs for one frame
        Contact regions ``C_i`` in mm.
    params : FrictionParams
        ``mu``, ``p0`` (N/mm), ``p1`` (N/mm).

    Returns
    -------
    ModelForces
        ``total``, ``interfacial`` (Eq. 2), ``deformation`` (Eq. 3), each ``(n_frames,)``
        in N.

    Examples
    --------
    >>> from fingerfriction.surfaces import get_surface
    >>> f = friction_force(get_surface("bump-2mm"), [(-3.0, -1.5)], FrictionParams(0.5, 0.1, 0.2))
    >>> round(float(f.total[0]), 4)  # flat ground only: p0 * mu * L
    0.075
    """
    return FrictionModel(surface).forces(regions, params)
