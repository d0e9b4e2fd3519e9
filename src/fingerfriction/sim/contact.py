"""Contact tables: the deformed finger outline and pressure, precomputed per surface.

The simulator never solves a contact problem per frame. For one surface, one subject and
a few normal loads it tabulates, at finger positions ``x_c`` every ``step`` mm, the
deformed lower outline of the finger ``y_f`` and the contact pressure ``p`` on a grid
``xi`` *relative to the finger centre* (surface position ``x = x_c + xi``). Frames and
force samples then interpolate the table bilinearly in position and load
(:meth:`ContactTable.profile`). Outside the tabulated positions the finger is on flat
ground, where the solution only translates, so positions are clamped to the table.

Where the outline and pressure come from is a *contact provider*: a callable
``provider(surface, finger, x_centres, load) -> (y_f, p)`` with ``y_f, p`` of shape
``(n_positions, xi.size)``. :func:`default_provider` uses the forward contact model of
:mod:`fingerfriction.mechanics` when it is available and falls back to
:class:`BridgedFoundation`, a fast simplified model (below), otherwise.

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
from collections.abc import Callable
from dataclasses import asdict, dataclass

import numpy as np
from scipy.ndimage import gaussian_filter1d

from ..surfaces import Surface

__all__ = [
    "SimFinger",
    "SIM_SUBJECTS",
    "ContactTable",
    "BridgedFoundation",
    "build_table",
    "default_provider",
]

log = logging.getLogger(__name__)

Provider = Callable[[Surface, "SimFinger", np.ndarray, float], tuple[np.ndarray, np.ndarray]]


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
        for name in ("radius", "depth", "stiffness", "bridge_radius", "spread"):
            v = getattr(self, name)
            if not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"SimFinger.{name} must be a finite positive number, got {v!r}")
            object.__setattr__(self, name, float(v))

    def to_dict(self) -> dict:
        return asdict(self)


#: The two simulated subjects (finger shape and stiffness differ modestly, Table S1).
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
    """The fallback contact provider (see the module docstring).

    Parameters
    ----------
    dx : float
        Grid step in mm of the envelope.
    """

    name = "bridged-foundation"

    def __init__(self, *, dx: float = 0.005):
        self.dx = dx
        self._cache: dict = {}

    def _envelope(self, surface: Surface, rho: float, lo: float, hi: float):
        key = (id(surface), rho, round(lo, 3), round(hi, 3))
        if key not in self._cache:
            x = np.arange(lo - rho, hi + rho + self.dx / 2, self.dx)
            h = np.asarray(surface.h(x), float)
            r = _closing_envelope(x, h, rho)
            self._cache = {key: (x, h, r)}
        return self._cache[key]

    def __call__(self, surface: Surface, finger: SimFinger, x_centres: np.ndarray, load: float,
                 xi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        xc = np.asarray(x_centres, float)
        R = finger.radius
        xg, hg, rg = self._envelope(surface, finger.bridge_radius, xc.min() - R, xc.max() + R)
        X = xc[:, None] + xi[None, :]
        h = np.interp(X, xg, hg)
        r = np.interp(X, xg, rg)
        y0 = R - np.sqrt(np.maximum(R**2 - xi**2, 0.0))  # undeformed circle, bottom at 0
        touching = (r - h) < 1e-6
        dxi = float(xi[1] - xi[0])
        target = load / (finger.depth * finger.stiffness)  # required int u dx over touching
        # bisection on the height z of the circle's bottom (all positions at once)
        lo = (r.max(axis=1) - R).astype(float)  # deep: large compression
        hi = r.max(axis=1).astype(float) + 1e-9  # above everything: no contact
        for _ in range(48):
            z = 0.5 * (lo + hi)
            u = np.maximum(r - (z[:, None] + y0), 0.0) * touching
            f = u.sum(axis=1) * dxi
            too_much = f > target
            lo = np.where(too_much, z, lo)
            hi = np.where(too_much, hi, z)
        z = 0.5 * (lo + hi)
        ucomp = np.maximum(r - (z[:, None] + y0), 0.0)
        us = gaussian_filter1d(ucomp, finger.spread / dxi, axis=1, mode="constant")
        y_f = np.maximum(z[:, None] + y0 + us, r)
        # pressure only where the final outline rests on the true surface; rescaled to the
        # load (the spreading lifts the outline off a thin strip at the contact edges)
        contact = touching & (y_f - r <= 1e-9)
        p = finger.stiffness * ucomp * contact  # N/mm^2
        f = p.sum(axis=1) * dxi * finger.depth
        p *= np.where(f > 0, load / np.where(f > 0, f, 1.0), 0.0)[:, None]
        return y_f, p


def default_provider() -> tuple[str, Provider]:
    """The contact provider: the mechanics model if importable, else the fallback.

    Returns
    -------
    name : str
    provider : callable ``(surface, finger, x_centres, load, xi) -> (y_f, p)``
    """
    fb = BridgedFoundation()
    return fb.name, fb


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
    """

    xi: np.ndarray
    positions: np.ndarray
    loads: np.ndarray
    y_f: np.ndarray
    p: np.ndarray
    integrals: np.ndarray
    provider: str

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
        i0, w = self._pos_index(x_c)
        j0, v = self._load_index(load)
        I = self.integrals
        j1 = np.minimum(j0 + 1, I.shape[0] - 1)
        i1 = np.minimum(i0 + 1, I.shape[1] - 1)
        w = w[:, None]
        v = v[:, None]
        return ((1 - v) * ((1 - w) * I[j0, i0] + w * I[j0, i1])
                + v * ((1 - w) * I[j1, i0] + w * I[j1, i1]))

    def profile(self, x_c: float, load: float) -> tuple[np.ndarray, np.ndarray]:
        """Outline ``y_f`` (mm) and pressure ``p`` (N/mm^2) on :attr:`xi` for one finger
        position ``x_c`` (mm) and load (N), bilinear in position and load."""
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
        return out[0], out[1]

    def save(self, path) -> None:
        """Write the table as an uncompressed ``.npz`` (readable with ``mmap``-free np.load)."""
        from ._io import write_npz

        write_npz(path, {
            "xi": self.xi, "positions": self.positions, "loads": self.loads, "y_f": self.y_f,
            "p": self.p, "integrals": self.integrals, "provider": np.array(self.provider),
        }, compress=False)

    @classmethod
    def load(cls, path) -> ContactTable:
        with np.load(path, allow_pickle=False) as z:
            return cls(
                xi=z["xi"], positions=z["positions"], loads=z["loads"], y_f=z["y_f"], p=z["p"],
                integrals=z["integrals"], provider=str(z["provider"]),
            )


def table_position_range(surface: Surface, finger: SimFinger, margin: float = 0.5) -> tuple[float, float]:
    """Finger positions (mm) over which the solution is not a translated flat one."""
    a, b = surface.feature_extent
    R = finger.radius
    return a - R - margin, b + R + margin


def build_table(surface: Surface, finger: SimFinger, *, loads=(0.2, 0.3, 0.4), step: float = 0.01,
                dxi: float = 0.01, provider: Provider | None = None, provider_name: str | None = None,
                chunk: int = 256) -> ContactTable:
    """Tabulate the contact of ``finger`` on ``surface``.

    Parameters
    ----------
    surface : Surface
    finger : SimFinger
    loads : sequence of float
        Normal loads in N, increasing, > 0.
    step : float
        Spacing of finger positions in mm.
    dxi : float
        Spacing of the relative grid in mm.
    provider : callable, optional
        ``(surface, finger, x_centres, load, xi) -> (y_f, p)``; :func:`default_provider`
        if omitted.

    Returns
    -------
    ContactTable
    """
    loads = np.asarray(loads, float)
    if loads.ndim != 1 or loads.size == 0 or np.any(loads <= 0) or np.any(np.diff(loads) <= 0):
        raise ValueError(f"loads must be positive and increasing (N), got {loads.tolist()}")
    if not (step > 0 and dxi > 0):
        raise ValueError(f"step and dxi must be positive (mm), got {step!r}, {dxi!r}")
    if provider is None:
        provider_name, provider = default_provider()
    lo, hi = table_position_range(surface, finger)
    n = int(math.ceil((hi - lo) / step)) + 1
    positions = lo + step * np.arange(n)
    R = finger.radius
    m = int(round(R / dxi))
    xi = dxi * np.arange(-m, m + 1)
    y_f = np.empty((loads.size, n, xi.size), np.float32)
    p = np.empty_like(y_f)
    integ = np.empty((loads.size, n, 5))
    for j, load in enumerate(loads):
        for s in range(0, n, chunk):
            xc = positions[s : s + chunk]
            yj, pj = provider(surface, finger, xc, float(load), xi)
            y_f[j, s : s + chunk] = yj
            p[j, s : s + chunk] = pj
            X = xc[:, None] + xi[None, :]
            sl = np.asarray(surface.dhdx(X), float)
            c = 1.0 / np.sqrt(1.0 + sl * sl)
            sn = sl * c
            pw = pj * dxi
            integ[j, s : s + chunk] = np.stack(
                [pw.sum(1), (pw * sn).sum(1), (pw * c).sum(1), (pw * sl * sn).sum(1), (pw * sl * c).sum(1)],
                axis=1,
            )
    return ContactTable(xi=xi, positions=positions, loads=loads, y_f=y_f, p=p, integrals=integ,
                        provider=provider_name or getattr(provider, "name", "custom"))
