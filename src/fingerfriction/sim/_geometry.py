"""Distance from surface points to the finger's outline: the paper's 3-px (70 um) contact
criterion ("Image analysis", Janko et al. 2018), shared by the frames' ground truth
(:mod:`~fingerfriction.sim.writer`) and the contact tables (:mod:`~fingerfriction.sim.contact`)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["geometric_distance", "geometric_mask"]


def geometric_mask(xi: np.ndarray, y_f: np.ndarray, h: np.ndarray, tol_mm: float) -> np.ndarray:
    """Surface points within ``tol_mm`` of the finger outline (the paper's 3-px criterion).

    Parameters
    ----------
    xi : (m,) ndarray
        Uniform grid in mm (positions relative to the finger; the surface points are at
        the same positions).
    y_f, h : (m,) ndarray
        Finger outline and surface heights in mm on that grid.
    tol_mm : float

    Returns
    -------
    (m,) bool ndarray
        True where the Euclidean distance from the surface point ``(x_j, h_j)`` to the
        finger outline (the polyline through ``(x_i, y_f_i)``) is at most ``tol_mm``
        (:func:`geometric_distance`).
    """
    return geometric_distance(xi, y_f, h, tol_mm) <= tol_mm


def geometric_distance(xi: np.ndarray, y_f: np.ndarray, h: np.ndarray, reach_mm: float) -> np.ndarray:
    """Euclidean distance in mm from each surface point to the finger outline.

    Parameters
    ----------
    xi : (m,) ndarray
        Uniform grid in mm (as in :func:`geometric_mask`).
    y_f, h : (..., m) ndarray
        Finger outline and surface heights in mm on that grid (leading axes, e.g. one
        row per finger position, are broadcast).
    reach_mm : float
        Distances up to this are exact; beyond it the result is an upper bound (the
        search looks at outline segments within ``reach_mm`` sideways only).

    Returns
    -------
    (..., m) ndarray
        Distance in mm from ``(x_j, h_j)`` to the polyline through ``(x_i, y_f_i)``.
    """
    dx = float(xi[1] - xi[0])
    m = xi.size
    y_f, h = np.broadcast_arrays(np.asarray(y_f, float), np.asarray(h, float))
    best = np.abs(y_f - h)  # vertical distance to the vertex above: an upper bound
    K = int(math.ceil(reach_mm / dx)) + 1
    for k in range(-K, K):
        # segment from vertex i = j + k to i + 1, for every surface point j
        j = np.arange(max(0, -k), min(m, m - 1 - k))
        i = j + k
        ax, ay = xi[i], y_f[..., i]
        bx, by = xi[i + 1], y_f[..., i + 1]
        px, py = xi[j], h[..., j]
        vx, vy = bx - ax, by - ay
        tpar = np.clip(((px - ax) * vx + (py - ay) * vy) / (vx * vx + vy * vy), 0.0, 1.0)
        d = np.hypot(ax + tpar * vx - px, ay + tpar * vy - py)
        best[..., j] = np.minimum(best[..., j], d)
    return best
