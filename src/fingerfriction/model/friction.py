"""The friction model of Janko, Wiertlewski & Visell (2018), Eq. (1)-(4), in two variants.

The paper's Eq. (4), for the contact regions ``C_i = [a_i, b_i]`` of one frame::

    F = F_int + F_def
      = sum_i  int_{C_i} (p0 + p1 dh/dx) (sin alpha + mu cos alpha) dx

with ``alpha = atan(dh/dx)``. The interfacial part (Eq. 2 with the constant pressure
``sigma_p = p0``) is ``F_int = p0 sum_i int (sin alpha + mu cos alpha) dx`` and the
deformation part (Eq. 3 with weight ``p1``) is ``F_def = p1 sum_i int dh/dx (sin alpha +
mu cos alpha) dx``. This is the **paper variant** (:class:`FrictionParams`,
:meth:`FrictionModel.forces`).

The load-consistent variant (the package's default model)
----------------------------------------------------------
With a constant ``p0`` the model's normal load is proportional to the contact length, but
the finger is force-controlled: when the contact splits or shrinks over a feature, the
measured ``F_N`` stays near 0.3 N and the pressure rises. The **load-consistent Eq. (4)**
(:class:`LoadParams`, :meth:`FrictionModel.load_forces`) keeps the paper's stresses,
Coulomb friction ``sigma_r = mu sigma_p`` (Eq. 2) and the deformation term of Eq. (3), and
adds the one condition the paper leaves out: the stresses of Eq. (2) carry the measured
normal load. Projecting the normal stress ``sigma_p`` (along the surface normal, pressing
on the plate) and the friction stress ``mu sigma_p`` (along the surface, dragging the plate
in the direction of motion) onto the vertical gives, for a region ``C_i`` of uniform
pressure ``p_i`` (per unit width, ``D`` absorbed as in the paper), the load it carries::

    P_i = p_i int_{C_i} (cos alpha - mu sin alpha) dx = p_i (K_i - mu S_i) = p_i s_i

with the integrals of the next section taken over ``C_i``; ``s_i`` (mm) is the region's
vertical support. The loads of all regions add up to the measured ``F_N(x)`` at each finger
position ``x``. How the load is shared between disconnected regions is the one thing the
paper's single constant pressure decides and that the video cannot show. A soft finger
pressed onto a relief is indented most where the surface is highest (the finger rides on a
bump, is lifted onto a step), so the pressure of a region is written to rise with its
mean height ``hbar_i`` (mm)::

    p_i = F_N exp(kappa hbar_i) / sum_j s_j exp(kappa hbar_j)

so that ``kappa = 0`` (1/mm) is the paper's assumption, one pressure ``F_N / sum_j s_j``
over the whole contact, and a region ``1 / kappa`` mm higher than another carries ``e``
times its pressure. Then::

    F_int(x) = sum_i p_i (S_i + mu K_i) = F_N(x) g(x)                 (Eq. 2)
    F_def(x) = p1 sum_i (Q_i + mu S_i)                                (Eq. 3, as in Eq. 4)

On flat ground (``S = Q = 0``, every region at the same height) this is Amontons' law
``F_T = mu F_N`` exactly, whatever the contact, so ``mu`` is the flat-ground ratio of the
measured forces (:func:`fingerfriction.fit.flat_ground_mu`), and the only parameter per
trial is the deformation weight ``p1`` (N/mm, as the paper's). When ``F_N`` happens to be
the load of a constant pressure, ``F_N = p0 sum_i s_i`` with ``kappa = 0``, the variant
*is* the paper's Eq. (4). The load is shared by height, not by region length (a power of
``s_i``): a short region is the top of a bump but also the lower flat left behind a step,
and only height tells them apart. The deformation stress of Eq. (3) is taken as a
tangential (dissipative) term that carries no load, not the literal reading ``sigma_p =
p0 + p1 dh/dx``. How each alternative fared on the simulated study: ``docs/fit.md``.
With ``LoadParams.push_up``, ``push_down`` (interlocking, :func:`slope_terms`) the slope
push is weighed by slope direction, ``F_int = F_N sum_i w_i (mu K_i + push_up S_up_i +
push_down S_down_i)``; both 1 is Eq. (2); the fit's ``interlock`` has ``p1 = 0`` (docs/fit.md).

Load-bearing contact. The paper's regions ``C_i`` are geometric: finger and surface within
3 px (about 70 um) of each other. Under a soft finger the gap opens slowly at a contact
edge, so each geometric region extends a strip of a few tenths of a millimetre beyond the
load-bearing (mechanical, pressure > 0) contact, and a region that has just formed near a
feature carries no load yet. The load-consistent variant therefore integrates over the
regions inset by ``inset`` mm at each end (:func:`fingerfriction.regions.inset_regions`;
``FrictionModel.region_integrals(..., inset=)``; 0 = the geometric regions as they are).
``inset`` and ``kappa`` (``LoadParams.kappa``) are properties of the finger, fitted per
subject by :mod:`fingerfriction.fit`; for a prediction on a surface never recorded, ``F_N``
is the nominal load (0.3 N).

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
alpha`` are tabulated once per surface; each region then costs two interpolations
(:meth:`FrictionModel.integrals`, the one place they are built). Both variants are
combinations of the per-frame sums ``S, K, Q``: the paper's is
``F = p0 (S + mu K) + p1 (Q + mu S)``, linear in ``(p0, p1)`` (:meth:`FrictionModel.basis`,
used by :mod:`fingerfriction.fit` for its closed-form least squares); the load-consistent
one needs them region by region (:meth:`FrictionModel.region_integrals`,
:func:`load_terms`). 10^5 frames x 3 regions cost a few milliseconds.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy.integrate import cumulative_simpson, cumulative_trapezoid

from .._check import in_range
from ..regions import as_regions
from ..surfaces import Surface

__all__ = [
    "FrictionParams",
    "LoadParams",
    "ModelForces",
    "FrictionModel",
    "friction_force",
    "load_terms",
    "slope_terms",
    "T_matrix",
]

#: Smallest vertical support ``K - mu S`` (mm) of the load-bearing contact for which the
#: load-consistent pressure is defined; below it (no load-bearing contact) it is NaN.
MIN_SUPPORT_MM = 1e-3


def _finite_fields(obj, names, optional=()) -> None:
    """Set each field ``names`` of the frozen dataclass ``obj`` to its value as a finite
    float, or raise the ValueError of :func:`~fingerfriction._check.in_range` naming it
    ("FrictionParams.mu must be a finite number, got nan"); a field of ``optional`` may be
    None."""
    own = type(obj).__name__
    for name in names:
        v = getattr(obj, name)
        if not (v is None and name in optional):
            object.__setattr__(obj, name, in_range(f"{own}.{name}", v))


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
        _finite_fields(self, ("mu", "p0", "p1"))
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
class LoadParams:
    """Parameters of the load-consistent Eq. (4) (see the module notes).

    Parameters
    ----------
    mu : float
        Coefficient of friction, dimensionless, ``0 <= mu <= 5`` (from flat ground).
    p1 : float
        Weight of the deformation term times D, in N/mm (any sign is accepted; a negative
        one is flagged by the fit as unphysical).
    inset : float
        Inset in mm of each geometric contact region at both ends, giving the load-bearing
        contact (>= 0; 0 = the regions as given).
    kappa : float
        Rise of the pressure with the mean height of a region, in 1/mm (>= 0; 0 = one
        uniform pressure over the whole contact, the paper's assumption).
    push_up, push_down : float or None
        Weights (dimensionless) of the interfacial slope push ``S`` of Eq. (2) on ascending
        and on descending slopes (:func:`slope_terms`): the normal stress's horizontal push
        against rising ground and its forward push on falling ground, which an elastic finger
        gives in full (both 1) and a viscoelastic one unequally (interlocking); None (default,
        both together) = 1, Eq. (2) as printed.
    """

    mu: float
    p1: float
    inset: float = 0.0
    kappa: float = 0.0
    push_up: float | None = None
    push_down: float | None = None

    def __post_init__(self) -> None:
        if (self.push_up is None) != (self.push_down is None):
            raise ValueError("LoadParams.push_up and push_down must be given together (or neither), got "
                             f"{self.push_up!r} and {self.push_down!r}")
        _finite_fields(self, ("mu", "p1", "inset", "kappa", "push_up", "push_down"),
                       optional=("push_up", "push_down"))
        if not 0.0 <= self.mu <= 5.0:
            raise ValueError(f"LoadParams.mu must be in [0, 5], got {self.mu!r}")
        if self.inset < 0:
            raise ValueError(f"LoadParams.inset (mm) must be >= 0, got {self.inset!r}")
        if self.kappa < 0:
            raise ValueError(f"LoadParams.kappa (1/mm) must be >= 0, got {self.kappa!r}")

    @property
    def split_push(self) -> bool:
        """True when the interfacial slope push is weighed by slope direction."""
        return self.push_up is not None

    def to_json(self) -> str:
        d = {k: v for k, v in asdict(self).items() if v is not None}
        return json.dumps({"model": "interlock" if self.split_push else "load", **d})

    @classmethod
    def from_json(cls, text: str) -> LoadParams:
        d = json.loads(text)
        return cls(mu=d["mu"], p1=d["p1"], inset=d.get("inset", 0.0), kappa=d.get("kappa", 0.0),
                   push_up=d.get("push_up"), push_down=d.get("push_down"))


@dataclass(frozen=True)
class ModelForces:
    """Model forces per frame, in N, each ``(n_frames,)``: Eq. (1) ``total = interfacial +
    deformation``, with ``interfacial`` from Eq. (2) and ``deformation`` from Eq. (3).
    ``pressure`` is the load-consistent ``p0(x)`` in N/mm (None for the paper variant,
    whose ``p0`` is a constant; NaN where the load-bearing contact is empty)."""

    total: np.ndarray
    interfacial: np.ndarray
    deformation: np.ndarray
    pressure: np.ndarray | None = None


def T_matrix(mu) -> np.ndarray:
    """``(..., 3, 2)`` matrix mapping ``[S, K, Q]`` to the two columns of Eq. (4):
    ``[S, K, Q] @ T(mu) = [S + mu K, Q + mu S]`` (the parts multiplying ``p0`` and ``p1``)."""
    mu = np.asarray(mu, dtype=float)
    T = np.zeros(mu.shape + (3, 2))
    T[..., 0, 0] = 1.0
    T[..., 1, 0] = mu
    T[..., 0, 1] = mu
    T[..., 2, 1] = 1.0
    return T


def load_terms(region_integrals, mu: float,
               kappa: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The load-independent parts of the load-consistent Eq. (4) (see the module notes).

    Parameters
    ----------
    region_integrals : (n, k, 5) array_like
        ``[S_i, K_i, Q_i, H_i, L_i]`` of every region at each position
        (:meth:`FrictionModel.region_integrals`, over the load-bearing contact): the three
        integrals of Eq. (4) in mm, ``H_i = int_{C_i} h dx`` in mm^2 and the length ``L_i``
        in mm; 0 for unused slots.
    mu : float
        Coefficient of friction.
    kappa : float
        Rise of the pressure with a region's mean height ``H_i / L_i``, in 1/mm (0: one
        uniform pressure over the whole contact, the paper's assumption).

    Returns
    -------
    g : (n,) ndarray
        ``F_int / F_N = sum_i w_i (S_i + mu K_i)``, dimensionless, with the region
        pressures per unit load ``w_i = exp(kappa hbar_i) / sum_j s_j exp(kappa hbar_j)``
        (1/mm) and ``s_i = K_i - mu S_i`` a region's vertical support; NaN where no region
        has a support above :data:`MIN_SUPPORT_MM`.
    b_def : (n,) ndarray
        ``sum_i (Q_i + mu S_i)`` in mm: ``F_def = p1 b_def`` (Eq. 3).
    support : (n,) ndarray
        ``sum_i s_i`` in mm, the total vertical support: ``F_N / support`` is the mean
        pressure over the load-bearing contact (N/mm).
    """
    I = np.asarray(region_integrals, dtype=float)
    if I.ndim != 3 or I.shape[2] != 5:
        raise ValueError(
            "region_integrals must be an (n, k, 5) array of S_i, K_i, Q_i, H_i, L_i, got shape "
            f"{I.shape}"
        )
    S, K, Q, H, L = (I[..., j] for j in range(5))
    per, sup, any_ok = _shares(S, K, H, L, mu, kappa)
    g = np.where(any_ok, np.sum(per * (S + mu * K), axis=1), np.nan)
    b = np.sum(Q + mu * S, axis=1)
    return g, b, sup


def _shares(S, K, H, L, mu: float, kappa: float):
    """``(w, support, any_ok)``: each region's pressure per unit load ``w_i`` (1/mm, 0 for a
    region without vertical support), the total support ``sum_i s_i`` (mm, NaN where none)
    and where any region has one (module notes)."""
    if not (math.isfinite(kappa) and kappa >= 0):
        raise ValueError(f"kappa must be a finite rate >= 0 in 1/mm, got {kappa!r}")
    sup = K - mu * S
    ok = sup > MIN_SUPPORT_MM
    if kappa:
        hbar = np.where(ok, H / np.where(L > 0, L, 1.0), -np.inf)
        top = np.max(hbar, axis=1, keepdims=True)
        rel = np.exp(kappa * np.where(ok, hbar - np.where(np.isfinite(top), top, 0.0), 0.0))
        rel = np.where(ok, rel, 0.0)  # pressure per unit load, up to the normalisation
    else:
        rel = ok.astype(float)
    total = np.sum(rel * np.where(ok, sup, 0.0), axis=1)
    any_ok = total > 0
    per = rel / np.where(any_ok, total, 1.0)[:, None]
    support = np.where(any_ok, np.sum(np.where(ok, sup, 0.0), axis=1), np.nan)
    return per, support, any_ok


def slope_terms(region_integrals, region_up, mu: float, kappa: float = 0.0) -> np.ndarray:
    """The load-independent parts of the load-consistent Eq. (4) with the interfacial
    slope push split by slope direction (``LoadParams.push_up``, ``push_down``).

    Parameters
    ----------
    region_integrals : (n, k, 5) array_like
        As :func:`load_terms`.
    region_up : (n, k, 2) array_like
        ``[S_up_i, Q_up_i]``: the ascending parts (``dh/dx > 0``) of ``S_i`` and ``Q_i`` of
        every region, in mm (:meth:`FrictionModel.region_up`).
    mu, kappa : float
        As :func:`load_terms`.

    Returns
    -------
    (n, 3) ndarray
        ``[sum_i w_i mu K_i, sum_i w_i S_up_i, sum_i w_i S_down_i]`` (dimensionless; ``w_i``
        the pressures per unit load of :func:`load_terms`, ``S_down_i = S_i - S_up_i <= 0``):
        ``F_int / F_N = c0 + push_up c1 + push_down c2``, and with both weights 1 the
        ``g`` of :func:`load_terms`; NaN where no region has a vertical support.
    """
    I = np.asarray(region_integrals, dtype=float)
    U = np.asarray(region_up, dtype=float)
    if I.ndim != 3 or I.shape[2] != 5 or U.shape != I.shape[:2] + (2,):
        raise ValueError(f"region_integrals (n, k, 5) and region_up (n, k, 2) must match, got shapes "
                         f"{I.shape} and {U.shape}")
    S, K, _, H, L = (I[..., j] for j in range(5))
    per, _, any_ok = _shares(S, K, H, L, mu, kappa)
    up = U[..., 0]
    out = np.stack([np.sum(per * mu * K, axis=1), np.sum(per * up, axis=1), np.sum(per * (S - up), axis=1)],
                   axis=1)
    return np.where(any_ok[:, None], out, np.nan)


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
        h = np.asarray(surface.h(x), dtype=float)
        self._H = cumulative_simpson(h, x=x, initial=0.0)  # int h dx (mean heights of regions)
        # The ascending parts (dh/dx > 0) of int sin(alpha) and int s sin(alpha), for the
        # slope push split by slope direction (:meth:`region_up`, :func:`slope_terms`); the
        # trapezoid rule, as the integrand jumps where the slope changes sign.
        up = s > 0
        self._up = np.stack([cumulative_trapezoid(np.where(up, s * c, 0.0), x=x, initial=0.0),
                             cumulative_trapezoid(np.where(up, s * s * c, 0.0), x=x, initial=0.0)],
                            axis=-1)
        self._h_ends = (float(h[0]), float(h[-1]))
        # Outside the table the surface is flat: sin = 0, cos = 1, s sin = 0.
        self._end_slope = (float(s[0]), float(s[-1]))
        # The table is uniform, so a position's cell is found by arithmetic: measured 4x
        # faster than np.interp's binary search on the 10^4-point tables (the load-consistent
        # fit evaluates them ~10^4 times per subject), with the same values.
        self._table = np.stack([self._S, self._K, self._Q, self._H], axis=-1)
        self._x0, self._dx = float(x[0]), float(x[1] - x[0])

    def _antiderivatives(self, x: np.ndarray):
        x = np.asarray(x, dtype=float)
        n = self._table.shape[0]
        u = np.clip((x - self._x0) / self._dx, 0.0, n - 1.0)
        i = np.minimum(u.astype(np.intp), n - 2)
        t = (u - i)[..., None]
        v = self._table[i] * (1.0 - t) + self._table[i + 1] * t
        # beyond the table the surface is flat: K grows as x, H as h x, S and Q stay
        xt0, xt1 = self._x[0], self._x[-1]
        below, above = np.where(x < xt0, x - xt0, 0.0), np.where(x > xt1, x - xt1, 0.0)
        v[..., 1] += below + above
        v[..., 3] += self._h_ends[0] * below + self._h_ends[1] * above
        return v  # (..., 4): S, K, Q, H

    def integrals(self, regions) -> np.ndarray:
        """Per-frame sums over the regions of the three integrals of Eq. (4).

        Parameters
        ----------
        regions : (n_frames, n_max, 2) array_like
            Contact regions in mm (see :mod:`fingerfriction.regions`).

        Returns
        -------
        (n_frames, 3) ndarray
            ``S = sum_i int_{C_i} sin alpha dx``, ``K = sum_i int_{C_i} cos alpha dx`` and
            ``Q = sum_i int_{C_i} dh/dx sin alpha dx``, in mm (0 for a frame without
            contact).
        """
        return self.region_integrals(regions).sum(axis=1)[:, :3]

    def region_integrals(self, regions, *, inset: float = 0.0) -> np.ndarray:
        """The three integrals of Eq. (4) over each region separately.

        Parameters
        ----------
        regions : (n_frames, n_max, 2) array_like
            Contact regions in mm.
        inset : float
            Integrate over each region shortened by ``inset`` mm at both ends (the
            load-bearing contact, :func:`fingerfriction.regions.inset_regions`); a region
            not longer than ``2 inset`` contributes nothing (default 0).

        Returns
        -------
        (n_frames, n_max, 5) ndarray
            ``[S_i, K_i, Q_i, H_i, L_i]``: the integrals of :meth:`integrals` in mm, the
            integral of the height ``H_i = int h dx`` in mm^2 and the length ``L_i`` in mm
            of each (inset) region; 0 for unused slots.
        """
        d = float(inset)
        if not (math.isfinite(d) and d >= 0):
            raise ValueError(f"inset must be a finite length >= 0 in mm, got {inset!r}")
        return self._region_integrals(as_regions(regions), d)

    def _region_integrals(self, arr: np.ndarray, inset: float) -> np.ndarray:
        """:meth:`region_integrals` of an already validated regions array (the fit calls
        this many times per trial while it searches the inset)."""
        a = arr[..., 0] + inset
        b = arr[..., 1] - inset
        valid = b > a  # False for the NaN slots too
        a = np.where(valid, a, 0.0)
        b = np.where(valid, b, 0.0)
        lo = self._antiderivatives(a)
        hi = self._antiderivatives(b)
        out = np.empty(arr.shape[:2] + (5,))
        out[..., :4] = np.where(valid[..., None], hi - lo, 0.0)
        out[..., 4] = np.where(valid, b - a, 0.0)
        return out

    def _region_up(self, arr: np.ndarray, inset: float, *, per_region: bool = False) -> np.ndarray:
        """``(n_frames, 2)``: the ascending parts ``[S_up, Q_up]`` of ``S`` and ``Q`` summed over
        the (inset) regions of an already validated regions array (``(n_frames, n_max, 2)``,
        region by region, with ``per_region``)."""
        a = arr[..., 0] + inset
        b = arr[..., 1] - inset
        valid = b > a
        n = self._up.shape[0]

        def at(x):
            u = np.clip((np.where(valid, x, self._x0) - self._x0) / self._dx, 0.0, n - 1.0)
            i = np.minimum(u.astype(np.intp), n - 2)
            t = (u - i)[..., None]
            return self._up[i] * (1.0 - t) + self._up[i + 1] * t  # flat beyond the table

        out = np.where(valid[..., None], at(b) - at(a), 0.0)
        return out if per_region else out.sum(axis=1)

    def region_up(self, regions, *, inset: float = 0.0) -> np.ndarray:
        """The ascending parts of ``S_i`` and ``Q_i`` region by region.

        Parameters
        ----------
        regions : (n_frames, n_max, 2) array_like
            Contact regions in mm.
        inset : float
            Integrate over each region shortened by ``inset`` mm at both ends.

        Returns
        -------
        (n_frames, n_max, 2) ndarray
            ``[S_up_i, Q_up_i]`` in mm: ``int sin alpha`` and ``int dh/dx sin alpha`` over
            the parts of each region where ``dh/dx > 0`` (0 for unused slots); the
            descending parts are ``S_i - S_up_i`` and ``Q_i - Q_up_i``
            (:meth:`region_integrals`).
        """
        d = float(inset)
        if not (math.isfinite(d) and d >= 0):
            raise ValueError(f"inset must be a finite length >= 0 in mm, got {inset!r}")
        return self._region_up(as_regions(regions), d, per_region=True)

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
        return self.integrals(regions) @ T_matrix(float(mu))

    def forces(self, regions, params: FrictionParams) -> ModelForces:
        """Eq. (1)-(4): model forces in N for every frame, with their two components."""
        if not isinstance(params, FrictionParams):
            raise TypeError(f"params must be FrictionParams, got {type(params).__name__}")
        B = self.basis(regions, params.mu)
        f_int = params.p0 * B[:, 0]
        f_def = params.p1 * B[:, 1]
        return ModelForces(total=f_int + f_def, interfacial=f_int, deformation=f_def)


    def load_forces(self, regions, f_n, params: LoadParams) -> ModelForces:
        """The load-consistent Eq. (4) (module notes): forces in N for every frame.

        Parameters
        ----------
        regions : (n_frames, n_max, 2) array_like
            Geometric contact regions in mm; inset by ``params.inset`` here.
        f_n : float or (n_frames,) array_like
            Normal force in N (measured at each frame, or the nominal load).
        params : LoadParams

        Returns
        -------
        ModelForces
            With ``pressure`` ``p0(x)`` in N/mm; NaN forces where the load-bearing contact
            is empty.
        """
        if not isinstance(params, LoadParams):
            raise TypeError(f"params must be LoadParams, got {type(params).__name__}")
        R = self.region_integrals(regions, inset=params.inset)
        g, b_def, support = load_terms(R, params.mu, params.kappa)
        if params.split_push:
            c = slope_terms(R, self.region_up(regions, inset=params.inset), params.mu, params.kappa)
            g = c @ np.array([1.0, params.push_up, params.push_down])
        fn = np.broadcast_to(np.asarray(f_n, dtype=float), g.shape)
        f_int = fn * g
        f_def = np.where(np.isfinite(g), params.p1 * b_def, np.nan)
        return ModelForces(total=f_int + f_def, interfacial=f_int, deformation=f_def, pressure=fn / support)


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
