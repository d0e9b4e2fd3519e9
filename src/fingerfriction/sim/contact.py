"""Contact tables: the deformed finger outline and pressure, precomputed per surface.

The simulator never solves a contact problem per frame. For one surface, one subject and
a few normal loads it tabulates, at finger positions ``x_c`` every ``step`` mm, the
deformed lower outline of the finger ``y_f`` and the contact pressure ``p`` on a grid
``xi`` *relative to the finger centre* (surface position ``x = x_c + xi``). Frames and
force samples then interpolate the table bilinearly in position and load
(:meth:`ContactTable.profile`). Outside the tabulated positions the finger is on flat
ground, where the solution only translates, so positions are clamped to the table.

Where the outline and pressure come from is a *contact provider*: an object with a
``name``, ``finger_dict(subject)`` (its finger parameters, recorded in the ground truth),
``grid(subject)`` (the relative grid ``xi``, mm) and
``solve(surface, subject, x_centres, load) -> (y_f, p)`` with ``y_f, p`` of shape
``(n_positions, xi.size)``. :class:`MechanicsProvider` (the default) runs the forward
contact model of :mod:`fingerfriction.mechanics` (plane-strain BEM, warm-started sweeps);
:class:`BridgedFoundation` is a fast simplified stand-in (below) for tests and for
studies where contact mechanics is not the point.

BridgedFoundation (the fallback)
--------------------------------
A stand-in with the two features the virtual experiment needs (disconnected contacts
near concave corners, and a gap that opens slowly at contact edges so the 70 um
geometric contact is wider than the mechanical one); it is not a mechanics model:

1. the skin cannot follow concavities sharper than a bridging radius ``rho``: the surface
   is replaced by its morphological closing with a disk of radius ``rho`` (the envelope
   of a disk rolled over the top of the relief), ``r(x) >= h(x)``;
2. a Winkler foundation: the undeformed circle of radius ``R``, lowered by the approach
   ``delta``, is pushed up onto ``r``; compression ``u = max(0, r - y_0)`` and pressure
   ``p = k u`` where the envelope touches the true surface (``r == h``), 0 over bridged
   spans; ``delta`` is found by bisection so that ``D int p dx = F_N``;
3. the compression is spread with a Gaussian of width ``spread`` (skin continuity) to give
   the outline ``y_f = max(y_0 + G * u, r)``.
"""

from __future__ import annotations

import logging
import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from .. import mechanics
from .._check import lookup, positive
from ..mechanics import ContactSolver, sweep
from ..mechanics.fe import FEProvider
from ..surfaces import Surface
from ._geometry import geometric_distance
from ._io import write_npz
from .pad import low_load_outline

__all__ = [
    "SimFinger",
    "SIM_SUBJECTS",
    "ContactTable",
    "BridgedFoundation",
    "MechanicsProvider",
    "build_table",
    "EXTRA_INTEGRALS",
    "default_provider",
    "get_provider",
    "low_load_outline",
]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SimFinger:
    """Finger parameters used by the simulator (geometry and the fallback contact model).

    Parameters
    ----------
    radius : float
        Fingertip radius R in mm (lower outline is a circle of this radius; the silhouette's
        sides continue vertically above the centre).
    depth : float
        Effective contact size D in mm across the finger (converts line load to force).
    stiffness : float
        Winkler modulus k of the fallback model in N/mm^3.
    bridge_radius : float
        Bridging radius rho of the fallback model in mm.
    spread : float
        Gaussian spreading length of the fallback model in mm.
    """

    radius: float = 8.0
    depth: float = 10.0
    stiffness: float = 0.045
    bridge_radius: float = 2.0
    spread: float = 0.35

    def __post_init__(self) -> None:
        for name, unit in (("radius", "mm"), ("depth", "mm"), ("stiffness", "N/mm^3"),
                           ("bridge_radius", "mm"), ("spread", "mm")):
            object.__setattr__(self, name, positive(f"SimFinger.{name}", getattr(self, name), unit))

    def to_dict(self) -> dict:
        return asdict(self)


#: The fallback model's two fingers (finger shape and stiffness differ modestly, Table S1).
SIM_SUBJECTS: dict[str, SimFinger] = {
    "1": SimFinger(radius=8.0, depth=10.0, stiffness=0.025, bridge_radius=4.0, spread=0.35),
    "2": SimFinger(radius=9.0, depth=11.0, stiffness=0.022, bridge_radius=4.5, spread=0.4),
}


def _closing_envelope(x: np.ndarray, h: np.ndarray, rho: float) -> np.ndarray:
    """Envelope of a disk of radius ``rho`` rolled over the top of ``h(x)`` (grey closing).

    ``x`` uniform (mm). Dilation (disk centre path ``c(x) = max h(x') + sqrt(rho^2 -
    (x - x')^2)``) then erosion (``r(x) = min c(x') - sqrt(...)``), both by a sliding
    window; O(n * window).
    """
    dx = float(x[1] - x[0])
    m = int(rho / dx)
    offs = np.arange(-m, m + 1)
    cap = np.sqrt(np.maximum(rho**2 - (offs * dx) ** 2, 0.0))
    n = h.size
    hp = np.pad(h, m, mode="edge")
    c = np.full(n, -np.inf)
    for k, o in enumerate(offs):
        c = np.maximum(c, hp[m + o : m + o + n] + cap[k])
    cp = np.pad(c, m, mode="edge")
    r = np.full(n, np.inf)
    for k, o in enumerate(offs):
        r = np.minimum(r, cp[m + o : m + o + n] - cap[k])
    return np.maximum(r, h)


class BridgedFoundation:
    """The simplified contact provider (see the module docstring).

    Parameters
    ----------
    dx : float
        Grid step in mm of the relative grid and of the closing envelope.
    fingers : dict, optional
        Subject -> :class:`SimFinger` (default :data:`SIM_SUBJECTS`).
    """

    name = "bridged-foundation"

    def __init__(self, *, dx: float = 0.01, fingers: dict | None = None):
        self.dx = float(dx)
        self.fingers = dict(SIM_SUBJECTS if fingers is None else fingers)
        self._cache: dict = {}

    def _finger(self, subject: str) -> SimFinger:
        return lookup(self.fingers, subject, "subject")

    def finger_dict(self, subject: str) -> dict:
        return {"model": self.name, **self._finger(subject).to_dict()}

    def grid(self, subject: str) -> np.ndarray:
        m = int(round(self._finger(subject).radius / self.dx))
        return self.dx * np.arange(-m, m + 1)

    def _envelope(self, surface: Surface, rho: float, lo: float, hi: float):
        key = (repr(surface), rho, round(lo, 3), round(hi, 3))
        if key not in self._cache:
            d = self.dx / 2
            x = np.arange(lo - rho, hi + rho + d / 2, d)
            h = np.asarray(surface.h(x), float)
            r = _closing_envelope(x, h, rho)
            self._cache = {key: (x, h, r)}
        return self._cache[key]

    def solve(self, surface: Surface, subject: str, x_centres: np.ndarray, load: float,
              *, chunk: int = 256) -> tuple[np.ndarray, np.ndarray]:
        finger = self._finger(subject)
        xi = self.grid(subject)
        xc_all = np.asarray(x_centres, float)
        R = finger.radius
        xg, hg, rg = self._envelope(surface, finger.bridge_radius, xc_all.min() - R, xc_all.max() + R)
        y0 = R - np.sqrt(np.maximum(R**2 - xi**2, 0.0))  # undeformed circle, bottom at 0
        dxi = float(xi[1] - xi[0])
        target = load / (finger.depth * finger.stiffness)  # required int u dx over touching
        ys, ps = [], []
        for s0 in range(0, xc_all.size, chunk):
            xc = xc_all[s0 : s0 + chunk]
            X = xc[:, None] + xi[None, :]
            h = np.interp(X, xg, hg)
            r = np.interp(X, xg, rg)
            touching = (r - h) < 1e-6
            # bisection on the height z of the circle's bottom (all positions at once)
            lo = r.max(axis=1) - R  # deep: large compression
            hi = r.max(axis=1) + 1e-9  # above everything: no contact
            for _ in range(40):
                z = 0.5 * (lo + hi)
                u = np.maximum(r - (z[:, None] + y0), 0.0) * touching
                too_much = u.sum(axis=1) * dxi > target
                lo = np.where(too_much, z, lo)
                hi = np.where(too_much, hi, z)
            z = 0.5 * (lo + hi)
            ucomp = np.maximum(r - (z[:, None] + y0), 0.0)
            us = gaussian_filter1d(ucomp, finger.spread / dxi, axis=1, mode="constant")
            y_f = np.maximum(z[:, None] + y0 + us, r)
            # pressure only where the final outline rests on the true surface; rescaled to
            # the load (the spreading lifts the outline off a thin strip at contact edges)
            contact = touching & (y_f - r <= 1e-9)
            p = finger.stiffness * ucomp * contact  # N/mm^2
            f = p.sum(axis=1) * dxi * finger.depth
            p *= np.where(f > 0, load / np.where(f > 0, f, 1.0), 0.0)[:, None]
            ys.append(y_f)
            ps.append(p)
        return np.concatenate(ys), np.concatenate(ps)


class MechanicsProvider:
    """Contact from :mod:`fingerfriction.mechanics` (plane-strain BEM), via its ``sweep``.

    The BEM grid spans the part of the pad that can touch the paper's reliefs: out to
    where the undeformed outline has risen ``clearance`` mm (``FingerParams.
    default_half_width``; the reliefs are at most 0.8 mm high, the pad's approach adds
    ~0.3 mm: at 1.0 mm the bump-4mm reached the grid's edge at 0.38-0.45 N for subject 1,
    at 1.5 mm no position of the six surfaces did, up to 0.45 N). Beyond it the silhouette
    continues, for the camera only, with a tangent circular arc of radius ``side_radius``
    that turns the outline up to 80 degrees, then the vertical sides of the finger (a
    fingertip of finite width seen side-on, rather than the pad's large contact radius
    continued across the whole field). The arc carries no pressure.

    Parameters
    ----------
    n : int
        Grid cells of the BEM solver (default 512; ~0.04 mm cells for the calibrated
        subjects).
    clearance : float
        Height in mm of the undeformed outline at the BEM grid's edge (default 1.5).
    side_radius : float
        Radius in mm of the arc that rounds the pad into the finger's sides.
    fingers : dict, optional
        Subject label -> ``FingerParams``; default the mechanics module's calibrated
        subjects (``mechanics.get_subject``).
    """

    name = "mechanics-bem"

    def __init__(self, *, n: int = 512, clearance: float = 1.5, side_radius: float = 1.5,
                 fingers: dict | None = None):
        self.n = int(n)
        self.clearance = float(clearance)
        self.side_radius = float(side_radius)
        self.fingers = fingers
        self.failures = 0

    def _finger(self, subject: str):
        if self.fingers is not None:
            return lookup(self.fingers, subject, "subject")
        try:
            return mechanics.get_subject(int(subject))
        except (TypeError, ValueError):
            raise ValueError(
                f"unknown subject {subject!r}; the contact model knows subjects "
                f"{', '.join(str(k) for k in mechanics.SUBJECTS)}"
            ) from None

    def finger_dict(self, subject: str) -> dict:
        return {"model": self.name, "n": self.n, "clearance_mm": self.clearance,
                "side_radius_mm": self.side_radius, **self._finger(subject).to_dict()}

    def _bem_grid(self, subject: str):
        finger = self._finger(subject)
        hw = finger.default_half_width(clearance=self.clearance)
        u = ContactSolver(finger, n=self.n, half_width=hw).u.copy()
        return finger, hw, u

    def _arc_count(self, finger, u: np.ndarray) -> tuple[int, float]:
        dx = float(u[1] - u[0])
        ue = float(u[-1])
        se = float((finger.outline(ue) - finger.outline(ue - dx)) / dx)
        sin_e = se / math.sqrt(1 + se * se)
        run = self.side_radius * (math.sin(math.radians(80.0)) - sin_e)
        return max(int(math.ceil(run / dx)), 1), dx

    def grid(self, subject: str) -> np.ndarray:
        finger, _, u = self._bem_grid(subject)
        k, dx = self._arc_count(finger, u)
        ext = dx * np.arange(1, k + 1)
        return np.concatenate([u[0] - ext[::-1], u, u[-1] + ext])

    def solve(self, surface: Surface, subject: str, x_centres: np.ndarray, load: float):
        finger, hw, u = self._bem_grid(subject)
        res = sweep(surface, finger, np.asarray(x_centres, float), load=float(load),
                    n=self.n, half_width=hw, keep_profiles=True)
        if not res.all_converged:
            bad = int((~res.success).sum())
            self.failures += bad
            log.warning("contact model did not converge at %d of %d positions (%s, subject %s, %g N): %s",
                        bad, res.positions.size, getattr(surface, "name", "surface"), subject, load,
                        res.messages[:1])
        k, dx = self._arc_count(finger, u)
        y = np.asarray(res.finger_y, float)
        right = self._arc(y[:, -2], y[:, -1], dx, k)
        left = self._arc(y[:, 1], y[:, 0], dx, k)[:, ::-1]
        y_ext = np.concatenate([left, y, right], axis=1)
        p = np.asarray(res.pressure, float)
        z = np.zeros((p.shape[0], k))
        return y_ext, np.concatenate([z, p, z], axis=1)

    def _arc(self, y_prev: np.ndarray, y_end: np.ndarray, dx: float, k: int) -> np.ndarray:
        """Heights (n, k) of the tangent arc continuing an outline outwards by k cells."""
        rs = self.side_radius
        s = (y_end - y_prev) / dx  # outward slope (positive: rising)
        sin_e = s / np.sqrt(1 + s * s)
        cos_e = 1 / np.sqrt(1 + s * s)
        t = dx * np.arange(1, k + 1)[None, :]
        sin_t = np.minimum(sin_e[:, None] + t / rs, math.sin(math.radians(80.0)))
        cos_t = np.sqrt(1 - sin_t**2)
        # circle centre at (rs sin_e inward, rs cos_e above the end point); beyond 80 deg
        # continue along the 80 deg tangent
        u80 = rs * (sin_t - sin_e[:, None])
        y_arc = y_end[:, None] + rs * (cos_e[:, None] - cos_t)
        beyond = t - u80
        return y_arc + beyond * math.tan(math.radians(80.0))


def default_provider():
    """The default contact provider: :class:`MechanicsProvider`."""
    return MechanicsProvider()


def get_provider(name: str, *, fingers: dict | None = None, friction: dict | None = None):
    """A contact provider by name: ``'mechanics-bem'``, ``'bridged-foundation'`` or ``'fe'``
    (the layered finite-element finger, :class:`fingerfriction.mechanics.fe.FEProvider`).

    ``fingers`` (subject label -> the model's finger parameters) overrides the provider's
    default fingers (``mechanics-bem``: ``FingerParams``; ``fe``: ``FEFingerParams``).
    ``friction`` (subject label -> sliding friction coefficient) is the FE finger's contact
    traction; the half-space providers are frictionless and ignore it.
    """
    if name == MechanicsProvider.name:
        return MechanicsProvider(fingers=fingers)
    if name == BridgedFoundation.name:
        if fingers:
            raise ValueError("the bridged-foundation contact model takes no finger files")
        return BridgedFoundation()
    if name == FEProvider.name:
        return FEProvider(fingers=fingers, friction=friction or 0.0)
    raise ValueError(
        f"unknown contact model {name!r}; known: {MechanicsProvider.name}, {BridgedFoundation.name}, fe"
    )


@dataclass(frozen=True)
class ContactTable:
    """Tabulated contact solutions of one surface and finger.

    Attributes
    ----------
    xi : (m,) ndarray
        Grid relative to the finger centre in mm (uniform), ``[-R, R]``.
    positions : (n,) ndarray
        Tabulated finger centre positions in mm (uniform step).
    loads : (L,) ndarray
        Tabulated normal loads in N (increasing).
    y_f : (L, n, m) float32 ndarray
        Deformed finger lower outline, height in mm in surface coordinates.
    p : (L, n, m) float32 ndarray
        Contact pressure in N/mm^2 (0 outside mechanical contact).
    integrals : (L, n, 5) ndarray
        Per solution ``int p w dx`` (N/mm) for the weights ``w = 1, sin a, cos a, s sin a,
        s cos a`` (``s = dh/dx``, ``a = atan s``): what the true force law needs.
    provider : str
        Name of the contact model that produced the table.
    extra : (L, n, len(EXTRA_INTEGRALS)) ndarray or None
        Further integrals the simulator's worlds need (:data:`EXTRA_INTEGRALS`), computed
        by :func:`build_table` from ``y_f``, ``p`` and the surface whatever the provider.
    geom_tol_mm : float
        The distance in mm within which a surface point counts as in geometric contact
        in the ``g_*`` integrals of :attr:`extra` (the paper's 3 px, 0.069 mm).
    """

    xi: np.ndarray
    positions: np.ndarray
    loads: np.ndarray
    y_f: np.ndarray
    p: np.ndarray
    integrals: np.ndarray
    provider: str
    extra: np.ndarray | None = None
    geom_tol_mm: float = 0.069

    def _pos_index(self, x_c: np.ndarray):
        pos = self.positions
        step = float(pos[1] - pos[0]) if pos.size > 1 else 1.0
        u = np.clip((np.asarray(x_c, float) - pos[0]) / step, 0.0, pos.size - 1.0)
        i0 = np.minimum(np.floor(u).astype(int), max(pos.size - 2, 0))
        w = u - i0
        return i0, w

    def _load_index(self, load: np.ndarray):
        L = self.loads
        f = np.clip(np.asarray(load, float), L[0], L[-1])
        j0 = np.clip(np.searchsorted(L, f, side="right") - 1, 0, max(L.size - 2, 0))
        if L.size == 1:
            return j0, np.zeros_like(f)
        v = (f - L[j0]) / (L[j0 + 1] - L[j0])
        return j0, v

    def interp_integrals(self, x_c: np.ndarray, load: np.ndarray) -> np.ndarray:
        """Bilinear interpolation of :attr:`integrals`, ``(k, 5)`` for ``k`` samples."""
        return self._interp(self.integrals, x_c, load)

    def interp_extra(self, x_c: np.ndarray, load: np.ndarray) -> dict:
        """Bilinear interpolation of :attr:`extra`: name (:data:`EXTRA_INTEGRALS`) ->
        ``(k,)`` array for ``k`` samples."""
        if self.extra is None:
            raise ValueError("this contact table has no extra integrals (built before they existed); "
                             "build it again with build_table")
        I = self._interp(self.extra, x_c, load)
        return {name: I[:, k] for k, name in enumerate(EXTRA_INTEGRALS)}

    def _interp(self, I: np.ndarray, x_c: np.ndarray, load: np.ndarray) -> np.ndarray:
        i0, w = self._pos_index(x_c)
        j0, v = self._load_index(load)
        j1 = np.minimum(j0 + 1, I.shape[0] - 1)
        i1 = np.minimum(i0 + 1, I.shape[1] - 1)
        w = w[:, None]
        v = v[:, None]
        return ((1 - v) * ((1 - w) * I[j0, i0] + w * I[j0, i1])
                + v * ((1 - w) * I[j1, i0] + w * I[j1, i1]))

    def profile(self, x_c: float, load: float, pad=None) -> tuple[np.ndarray, np.ndarray]:
        """Outline ``y_f`` (mm) and pressure ``p`` (N/mm^2) on :attr:`xi` for one finger
        position ``x_c`` (mm) and load (N), bilinear in position and load.

        Below the lowest tabulated load, with the pad's force-indentation law ``pad``
        (:class:`~fingerfriction.sim.kinematics.PadLaw`), the outline is the lowest load's
        unloaded by the pad (:func:`low_load_outline`: the contact shrinks to a point as
        the load goes to 0); without it, the lowest load's outline is held.
        """
        i0, w = self._pos_index(np.array([x_c]))
        j0, v = self._load_index(np.array([load]))
        i0, w, j0, v = int(i0[0]), float(w[0]), int(j0[0]), float(v[0])
        j1 = min(j0 + 1, self.loads.size - 1)
        i1 = min(i0 + 1, self.positions.size - 1)
        out = []
        for arr in (self.y_f, self.p):
            a = (1 - w) * arr[j0, i0].astype(float) + w * arr[j0, i1]
            b = (1 - w) * arr[j1, i0].astype(float) + w * arr[j1, i1]
            out.append((1 - v) * a + v * b)
        if pad is not None and load < float(self.loads[0]):
            return low_load_outline(self.xi, out[0], out[1], float(load), float(self.loads[0]), pad)
        return out[0], out[1]

    def save(self, path) -> None:
        """Write the table as an uncompressed ``.npz`` (readable with ``mmap``-free np.load)."""
        extra = {} if self.extra is None else {"extra": self.extra}
        write_npz(path, {
            "xi": self.xi, "positions": self.positions, "loads": self.loads, "y_f": self.y_f,
            "p": self.p, "integrals": self.integrals, "provider": np.array(self.provider),
            "geom_tol_mm": np.float64(self.geom_tol_mm), **extra,
        }, compress=False)

    @classmethod
    def stack(cls, tables) -> ContactTable:
        """One table from tables of the same surface, finger and positions at different
        loads (sorted by load)."""
        tables = sorted(tables, key=lambda t: float(t.loads[0]))
        t0 = tables[0]
        for t in tables[1:]:
            if not (np.array_equal(t.xi, t0.xi) and np.array_equal(t.positions, t0.positions)
                    and t.provider == t0.provider and t.geom_tol_mm == t0.geom_tol_mm
                    and (t.extra is None) == (t0.extra is None)):
                raise ValueError("ContactTable.stack: tables differ in grid, positions, provider or "
                                 "geometric tolerance")
        if len(tables) == 1:
            return t0
        return cls(
            xi=t0.xi, positions=t0.positions, loads=np.concatenate([t.loads for t in tables]),
            y_f=np.concatenate([t.y_f for t in tables]), p=np.concatenate([t.p for t in tables]),
            integrals=np.concatenate([t.integrals for t in tables]), provider=t0.provider,
            extra=None if t0.extra is None else np.concatenate([t.extra for t in tables]),
            geom_tol_mm=t0.geom_tol_mm,
        )

    @classmethod
    def load(cls, path) -> ContactTable:
        with np.load(path, allow_pickle=False) as z:
            return cls(
                xi=z["xi"], positions=z["positions"], loads=z["loads"], y_f=z["y_f"], p=z["p"],
                integrals=z["integrals"], provider=str(z["provider"]),
                extra=z["extra"] if "extra" in z.files else None,
                geom_tol_mm=float(z["geom_tol_mm"]) if "geom_tol_mm" in z.files else 0.069,
            )


def table_position_range(surface: Surface, half_extent: float, margin: float = 0.5) -> tuple[float, float]:
    """Finger positions (mm) over which the solution is not a translated flat one."""
    a, b = surface.feature_extent
    return a - half_extent - margin, b + half_extent + margin


def build_table(surface: Surface, subject: str, *, loads=(0.22, 0.3, 0.38), step: float = 0.02,
                provider=None, geom_tol_mm: float = 0.069) -> ContactTable:
    """Tabulate the contact of a subject's finger on ``surface``.

    Parameters
    ----------
    surface : Surface
    subject : str
        Subject label known to the provider.
    loads : sequence of float
        Normal loads in N, increasing, > 0 (default brackets 0.3 +- 0.05 N with margin).
    step : float
        Spacing of finger positions in mm (default 0.02 mm, under one pixel).
    provider : optional
        A contact provider (see the module docstring); :func:`default_provider` if omitted.
    geom_tol_mm : float
        Distance in mm within which a surface point is in geometric contact, for the
        ``g_*`` integrals of :data:`EXTRA_INTEGRALS` (default 0.069 mm: the paper's 3 px of
        23 um; the simulator passes 3 of its camera's pixels).

    Returns
    -------
    ContactTable
    """
    loads = np.asarray(loads, float)
    if loads.ndim != 1 or loads.size == 0 or np.any(loads <= 0) or np.any(np.diff(loads) <= 0):
        raise ValueError(f"loads must be positive and increasing (N), got {loads.tolist()}")
    if not (math.isfinite(step) and step > 0):
        raise ValueError(f"step must be a positive length in mm, got {step!r}")
    if not (math.isfinite(geom_tol_mm) and geom_tol_mm > 0):
        raise ValueError(f"geom_tol_mm must be a positive length in mm, got {geom_tol_mm!r}")
    if provider is None:
        provider = default_provider()
    xi = np.asarray(provider.grid(subject), float)
    lo, hi = table_position_range(surface, float(max(-xi[0], xi[-1])))
    n = int(math.ceil((hi - lo) / step)) + 1
    positions = lo + step * np.arange(n)
    dxi = float(xi[1] - xi[0])
    y_f = np.empty((loads.size, n, xi.size), np.float32)
    p = np.empty_like(y_f)
    integ = np.empty((loads.size, n, 5))
    X = positions[:, None] + xi[None, :]
    sl = np.asarray(surface.dhdx(X), float)
    c = 1.0 / np.sqrt(1.0 + sl * sl)
    weights = np.stack([np.ones_like(sl), sl * c, c, sl * sl * c, sl * c])  # (5, n, m)
    h = np.asarray(surface.h(X), float)
    extra = np.empty((loads.size, n, len(EXTRA_INTEGRALS)))
    for j, load in enumerate(loads):
        yj, pj = provider.solve(surface, subject, positions, float(load))
        y_f[j] = yj
        p[j] = pj
        integ[j] = np.einsum("knm,nm->nk", weights, pj) * dxi
        extra[j] = _extra_integrals(xi, np.asarray(yj, float), np.asarray(pj, float), h, weights, geom_tol_mm)
    return ContactTable(xi=xi, positions=positions, loads=loads, y_f=y_f, p=p, integrals=integ,
                        provider=provider.name, extra=extra, geom_tol_mm=float(geom_tol_mm))


#: Names of :attr:`ContactTable.extra`, all per finger position and load (``s = dh/dx``,
#: ``a = atan s``, ``p`` the pressure in N/mm^2, ``G`` the geometric contact: surface
#: points within ``geom_tol_mm`` of the deformed outline, the contact the camera sees):
#:
#: * ``sin_up``, ``sin_down``: ``int p sin a dx`` over rising (``s > 0``) and falling
#:   (``s < 0``) ground, N/mm (the horizontal push of the pressure on slopes, by side);
#: * ``h``: ``int p h dx``, N (divided by ``int p dx``: the load-weighted height of the
#:   ground the finger stands on, mm);
#: * ``g_len``, ``g_sin``, ``g_cos``, ``g_ssin``, ``g_scos``: ``int_G w dx`` for the
#:   weights ``1, sin a, cos a, s sin a, s cos a``, mm (the paper's Eq. 4 integrals on the
#:   geometric contact regions, Janko et al. 2018).
EXTRA_INTEGRALS = ("sin_up", "sin_down", "h", "g_len", "g_sin", "g_cos", "g_ssin", "g_scos")


def _extra_integrals(xi, y_f, p, h, weights, tol) -> np.ndarray:
    """:data:`EXTRA_INTEGRALS` of one load, ``(n, len(EXTRA_INTEGRALS))``; ``weights`` as in
    :func:`build_table` (``1, sin a, cos a, s sin a, s cos a``, each ``(n, m)``)."""
    dxi = float(xi[1] - xi[0])
    sin_a = weights[1]
    rising = sin_a > 0
    out = [np.sum(p * sin_a * rising, axis=1) * dxi, np.sum(p * sin_a * (sin_a < 0), axis=1) * dxi,
           np.sum(p * h, axis=1) * dxi]
    g = np.empty(p.shape, bool)
    for s0 in range(0, p.shape[0], 256):  # chunks: the distance search holds a few (256, m) arrays
        g[s0 : s0 + 256] = geometric_distance(xi, y_f[s0 : s0 + 256], h[s0 : s0 + 256], tol) <= tol
    out += [np.sum(w * g, axis=1) * dxi for w in weights]
    return np.stack(out, axis=1)
