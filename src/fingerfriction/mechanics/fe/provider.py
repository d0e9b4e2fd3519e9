"""The FE finger as a contact provider of the simulator, with an on-disk cache of its sweeps.

:class:`FEProvider` implements the contact-provider protocol of
:mod:`fingerfriction.sim.contact` (``name``, ``finger_dict``, ``grid``, ``solve``): for a
surface, a subject and a load it solves the finger at each tabulated position and returns
the deformed lower outline ``y_f`` and the pressure ``p`` on the relative grid ``xi``.

* Flat ground: where the finely meshed contact arc of the finger
  (:attr:`FEMeshParams.contact_half_width` either side of the centre) does not reach the
  relief feature, the solution is that of flat ground at the ground's level, translated:
  it is solved once per level.
* Elsewhere the positions are solved in increasing order, each warm-started from the
  previous one (:meth:`FEContactSolver.solve`).
* Cache: each ``solve`` result is stored under a key, a digest of everything it depends on
  (the code's :data:`CACHE_VERSION`, the finger, the mesh, the surface, the positions, the
  load, the grid and the friction), as ``<cache_dir>/<key>.npz`` with which positions
  converged; a call with the same inputs reads it back, a changed parameter gives a new key
  and is computed. ``cache_dir`` defaults to ``$FINGERFRICTION_CACHE/fe`` or
  ``~/.cache/fingerfriction/fe``.
"""

from __future__ import annotations

import dataclasses
import io
import json
import logging
import math
import os
from pathlib import Path

import numpy as np

from ..._atomic import atomic_write_bytes
from ..._check import lookup
from ...surfaces import Surface
from .params import LITERATURE_FINGER, FEFingerParams, FEMeshParams, params_key
from .solver import FEContactSolver, FEState

__all__ = ["FEProvider", "FE_SUBJECTS", "CACHE_VERSION", "default_cache_dir", "default_mesh", "surface_key"]

log = logging.getLogger(__name__)

#: Bumped whenever a change of the solver changes its results (invalidates every cache entry).
CACHE_VERSION = 3

#: The FE provider's default fingers of the two simulated subjects: the literature finger,
#: and for subject 2 the same layers on a slightly larger outline (the paper's subjects
#: differ modestly).
FE_SUBJECTS: dict[str, FEFingerParams] = {
    "1": dataclasses.replace(LITERATURE_FINGER, name="subject 1 (FE, literature values)"),
    "2": dataclasses.replace(LITERATURE_FINGER, radius=12.0, semi_height=7.0, bone_half_width=7.0,
                             name="subject 2 (FE, literature values)"),
}


def default_mesh() -> FEMeshParams:
    """:class:`FEMeshParams` defaults, or the JSON object of ``$FINGERFRICTION_FE_MESH``
    (e.g. ``{"surface_cell": 0.4}``: a coarse mesh for tests and quick looks; the mesh used
    is recorded with the finger in a study's truth and is part of the cache key)."""
    text = os.environ.get("FINGERFRICTION_FE_MESH")
    if not text:
        return FEMeshParams()
    try:
        d = json.loads(text)
        if not isinstance(d, dict):
            raise ValueError("not a JSON object")
        return FEMeshParams(**d)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"FINGERFRICTION_FE_MESH={text!r} is not a valid FE mesh: {exc}") from None


def default_cache_dir() -> Path:
    """``$FINGERFRICTION_CACHE/fe`` if set, else ``~/.cache/fingerfriction/fe``."""
    root = os.environ.get("FINGERFRICTION_CACHE")
    return (Path(root) if root else Path.home() / ".cache" / "fingerfriction") / "fe"


def surface_key(surface) -> object:
    """A JSON-ready description of a surface for the cache key."""
    if hasattr(surface, "to_dict"):
        return surface.to_dict()
    return repr(surface)


class FEProvider:
    """Contact provider backed by the layered FE finger (see the module notes).

    Parameters
    ----------
    fingers : dict, optional
        Subject label -> :class:`FEFingerParams` (default :data:`FE_SUBJECTS`).
    mesh : FEMeshParams, optional
        Mesh resolution (default :func:`default_mesh`).
    grid_step : float
        Spacing in mm of the relative grid ``xi`` (default 0.02).
    cache_dir : path-like or None, optional
        Where solved sweeps are kept (default :func:`default_cache_dir`); ``False`` for no
        cache.
    friction : float or dict, optional
        Sliding friction coefficient of a tangential traction ``mu p`` on the contact,
        opposing the finger's motion towards ``+x``: one for every subject, or a dict
        subject label -> coefficient. It shifts the contact patch against the motion
        (``docs/mechanics-fe.md``); simulated studies pass each subject's coefficient
        (:attr:`fingerfriction.sim.options.SimOptions.provider`). A subject without one
        takes its finger's own :attr:`FEFingerParams.friction` (default 0: frictionless).
    """

    name = "fe"

    def __init__(self, *, fingers: dict | None = None, mesh: FEMeshParams | None = None,
                 grid_step: float = 0.02, cache_dir=None, friction=None):
        self.fingers = dict(FE_SUBJECTS if fingers is None else fingers)
        for k, f in self.fingers.items():
            if not isinstance(f, FEFingerParams):
                raise TypeError(f"finger of subject {k!r} must be an FEFingerParams, got {type(f).__name__}")
        self.mesh = mesh or default_mesh()
        if not (isinstance(grid_step, (int, float)) and math.isfinite(grid_step) and grid_step > 0):
            raise ValueError(f"grid_step must be a positive length in mm, got {grid_step!r}")
        self.grid_step = float(grid_step)
        mus = ({} if friction is None else
               friction if isinstance(friction, dict) else dict.fromkeys(self.fingers, friction))
        for k, mu in mus.items():
            ok = isinstance(mu, (int, float)) and not isinstance(mu, bool) and math.isfinite(mu)
            if not (ok and 0 <= mu <= 5):
                raise ValueError(f"friction of subject {k!r} must be a coefficient in [0, 5], got {mu!r}")
        self.friction = {str(k): float(v) for k, v in mus.items()}
        self.cache_dir = None if cache_dir is False else Path(cache_dir or default_cache_dir())
        self.failures = 0
        self.last_ok: np.ndarray | None = None  # which positions of the last solve converged
        self.computed = 0  # sweeps solved (not read from the cache), for tests and benchmarks
        self._solvers: dict = {}

    def _finger(self, subject: str) -> FEFingerParams:
        return lookup(self.fingers, subject, "subject")

    def mu(self, subject: str) -> float:
        """The friction coefficient of the subject's contact traction (0: frictionless): the
        provider's for that subject, else its finger's own."""
        f = self._finger(subject)
        return self.friction.get(str(subject), f.friction)

    def finger_dict(self, subject: str) -> dict:
        return {"model": self.name, "mesh": self.mesh.to_dict(), **self._finger(subject).to_dict(),
                "friction": self.mu(subject)}

    def grid(self, subject: str) -> np.ndarray:
        f = self._finger(subject)
        m = int(math.floor(0.995 * f.radius / self.grid_step))
        return self.grid_step * np.arange(-m, m + 1)

    def solver(self, subject: str) -> FEContactSolver:
        f = self._finger(subject)
        key = (f, self.mesh)
        if key not in self._solvers:
            self._solvers = {key: FEContactSolver(f, self.mesh)}
        return self._solvers[key]

    def cache_key(self, surface, subject: str, x_centres: np.ndarray, load: float) -> str:
        xc = np.asarray(x_centres, float)
        return params_key("fe-table", CACHE_VERSION, self._finger(subject).to_dict(), self.mesh.to_dict(),
                          surface_key(surface), np.round(xc, 9).tolist(), round(float(load), 12),
                          self.grid_step, self.mu(subject))

    def reach(self, subject: str, surface) -> float:
        """Offset (mm) from the finger centre beyond which the relief cannot touch: where the
        undeformed outline has risen 1 mm above the feature's height (the pad's approach is
        under 0.7 mm at the tabulated loads, the contact criterion 0.07 mm), within the
        finely meshed contact arc."""
        f = self._finger(subject)
        top = float(getattr(surface, "max_height", 1.0)) + 1.0
        u = np.linspace(0.0, 0.97 * f.radius, 2001)
        above = np.flatnonzero(f.outline(u) >= top)
        r = float(u[above[0]]) if above.size else 0.97 * f.radius
        return min(r, self.mesh.contact_half_width) + 0.2

    def solve(self, surface: Surface, subject: str, x_centres, load: float):
        """Outline ``y_f`` (mm) and pressure ``p`` (MPa), each ``(n_positions, xi.size)``.

        Which positions converged is kept in :attr:`last_ok` (``(n_positions,)`` bool, also
        for a table read from the cache); an unconverged position holds its last iterate.
        """
        xc = np.asarray(x_centres, float)
        if xc.ndim != 1 or xc.size == 0 or not np.all(np.isfinite(xc)):
            raise ValueError("x_centres must be a non-empty 1-D array of finite positions in mm")
        path = None
        if self.cache_dir is not None:
            path = self.cache_dir / f"{self.cache_key(surface, subject, xc, load)}.npz"
            if path.is_file():
                try:
                    with np.load(path, allow_pickle=False) as z:
                        y, p, ok = z["y_f"], z["p"], z["ok"]
                    if y.shape == (xc.size, self.grid(subject).size) and p.shape == y.shape \
                            and ok.shape == (xc.size,):
                        self.last_ok = ok.astype(bool)
                        return y.astype(float), p.astype(float)
                except (OSError, ValueError, KeyError):
                    pass
                log.warning("ignoring an unreadable FE cache entry %s", path)
        y, p, ok = self._compute(surface, subject, xc, float(load))
        self.computed += 1
        self.last_ok = ok
        if path is not None:
            buf = io.BytesIO()
            np.savez_compressed(buf, y_f=y, p=p, ok=ok)
            path.parent.mkdir(parents=True, exist_ok=True)
            atomic_write_bytes(path, buf.getvalue())
        return y, p

    def _compute(self, surface, subject, xc, load):
        finger = self._finger(subject)
        s = self.solver(subject)
        xi = self.grid(subject)
        reach = self.reach(subject, surface)
        a, b = surface.feature_extent if isinstance(surface, Surface) else (-math.inf, math.inf)
        flat = (xc + reach < a) | (xc - reach > b)
        y = np.empty((xc.size, xi.size))
        p = np.empty_like(y)
        ok = np.ones(xc.size, dtype=bool)
        states: dict = {}

        def flat_state(level):
            if level not in states:
                sol, st = s.solve(lambda x: np.full_like(np.asarray(x, float), level), 0.0, load=load,
                                  friction=self.mu(subject))
                if not sol.success:
                    self.failures += 1
                    log.warning("FE flat-ground solve did not converge (%s)", sol.message)
                states[level] = (sol, st)
            return states[level]

        for i in np.flatnonzero(flat):
            level = float(np.asarray(surface.h(np.array([xc[i]])), float)[0])
            sol, _ = flat_state(level)
            ok[i] = sol.success
            sol0 = dataclasses.replace(sol, outline_x=sol.outline_x + xc[i])
            y[i], p[i] = sol0.on_grid(xc[i] + xi, load, finger.width)
        idx = np.flatnonzero(~flat)
        if idx.size:
            order = idx[np.argsort(xc[idx])]
            x0 = xc[order[0]]
            level = float(np.asarray(surface.h(np.array([x0 - reach - 1.0])), float)[0])
            _, st = flat_state(level)
            step = float(np.min(np.diff(np.sort(xc[idx])))) if idx.size > 1 else 0.1
            state = FEState(u=st.u, z=st.z, x_c=x0 - step, P=st.P)
            bad = 0
            for i in order:
                sol, new = s.solve(surface, xc[i], load=load, warm=state, friction=self.mu(subject))
                if sol.success:
                    state = new
                else:
                    bad += 1
                    ok[i] = False
                y[i], p[i] = sol.on_grid(xc[i] + xi, load, finger.width)
            if bad:
                self.failures += bad
                log.warning("FE contact did not converge at %d of %d positions (%s, subject %s, %g N)",
                            bad, idx.size, getattr(surface, "name", "surface"), subject, load)
        return y, p, ok
