"""The finger's structured mesh: an O-grid of quadrilaterals between the outline and the bone.

Nodes lie on ``n_theta`` rays around the section and ``n_r + 1`` rings: ring 0 is the
outer outline, rings ``1..skin_layers`` cut the skin layer at constant depth along the
outline's inward normal, the remaining rings grade (geometrically, finest next to the skin)
from the skin's inner face to the bone's outline, the last ring. Along the outline the
rays are equally spaced in arc length (``surface_cell``) over the contact arc around the
bottom and grow geometrically towards the top. Coordinates: mm, the finger's lowest point
at the origin, ``y`` up.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .params import FEFingerParams, FEMeshParams

__all__ = ["FingerMesh", "build_mesh"]


@dataclass(frozen=True)
class FingerMesh:
    """The mesh of one finger (arrays in mm).

    Attributes
    ----------
    p : (2, n_nodes) ndarray
        Node coordinates (corner nodes of the quadrilaterals).
    t : (4, n_elements) int ndarray
        Counter-clockwise corner nodes of each element.
    material : (n_elements,) int ndarray
        0 pulp, 1 skin, 2 nail.
    outer : (n_theta,) int ndarray
        Nodes of the outline in counter-clockwise order, starting at the bottom.
    bone : (n_theta,) int ndarray
        Nodes on the bone's outline.
    """

    p: np.ndarray
    t: np.ndarray
    material: np.ndarray
    outer: np.ndarray
    bone: np.ndarray


def _graded(length: float, h0: float, n: int) -> np.ndarray:
    """``n`` cell sizes growing geometrically from ``h0`` that add up to ``length``."""
    if n * h0 >= length:
        return np.full(n, length / n)
    lo, hi = 1.0, 2.0
    while h0 * (hi**n - 1) / (hi - 1) < length:
        hi *= 2
    for _ in range(100):
        r = 0.5 * (lo + hi)
        if h0 * (r**n - 1) / (r - 1) < length:
            lo = r
        else:
            hi = r
    r = 0.5 * (lo + hi)
    h = h0 * r ** np.arange(n)
    return h * (length / h.sum())


def _ellipse_arclength(a: float, b: float, t: np.ndarray) -> np.ndarray:
    """Arc length of ``(a cos t, b sin t)`` from ``t[0]`` at the sample angles ``t``."""
    ds = np.hypot(a * np.sin(t), b * np.cos(t))
    return np.concatenate([[0.0], np.cumsum(0.5 * (ds[1:] + ds[:-1]) * np.diff(t))])


def _angles(finger: FEFingerParams, mesh: FEMeshParams) -> np.ndarray:
    """Ray angles ``t`` (rad) on the outline ``(R cos t, b + b sin t)``, CCW from the bottom."""
    R, b = finger.radius, finger.semi_height
    chw = min(mesh.contact_half_width, 0.97 * R)
    t_c = math.asin(chw / R)  # contact arc: t in [-pi/2 - t_c, -pi/2 + t_c]
    tt = np.linspace(-0.5 * math.pi, 1.5 * math.pi, 200001)
    s = _ellipse_arclength(R, b, tt)
    total = s[-1]
    s_c = float(np.interp(-0.5 * math.pi + t_c, tt, s))  # half the contact arc
    n_c = max(2, int(math.ceil(s_c / mesh.surface_cell)))
    h_c = s_c / n_c
    n_top = max(2, mesh.top_cells // 2)
    top = _graded(0.5 * total - s_c, h_c, n_top)
    half = np.concatenate([np.full(n_c, h_c), top])  # bottom -> top on the right side
    s_right = np.concatenate([[0.0], np.cumsum(half)])  # 0 .. total/2
    s_nodes = np.concatenate([s_right[:-1], total - s_right[::-1][:-1]])
    return np.interp(s_nodes, s, tt)


def build_mesh(finger: FEFingerParams, mesh: FEMeshParams | None = None) -> FingerMesh:
    """The O-grid mesh of ``finger`` at the resolution ``mesh`` (see the module notes)."""
    mesh = mesh or FEMeshParams()
    R, b = finger.radius, finger.semi_height
    t = _angles(finger, mesh)
    n_th = t.size
    ct, st = np.cos(t), np.sin(t)
    outer = np.stack([R * ct, b + b * st])  # (2, n_th)
    # inward unit normal of the ellipse (x/R)^2 + ((y-b)/b)^2 = 1
    nrm = -np.stack([ct / R, st / b])
    nrm /= np.linalg.norm(nrm, axis=0)
    hs = finger.skin_thickness
    skin_in = outer + hs * nrm
    bone = np.stack([finger.bone_half_width * ct, finger.bone_centre_height + finger.bone_half_height * st])
    ns, nt = mesh.skin_layers, mesh.tissue_layers
    rings = [outer + (hs * k / ns) * nrm for k in range(ns + 1)]
    h0 = hs / ns
    seg = bone - skin_in
    L = np.linalg.norm(seg, axis=0)
    frac = np.stack([np.concatenate([[0.0], np.cumsum(_graded(float(Li), h0, nt))]) / Li for Li in L])
    for k in range(1, nt + 1):
        rings.append(skin_in + seg * frac[:, k])
    P = np.stack(rings, axis=1)  # (2, n_r + 1, n_th)
    n_r = P.shape[1] - 1
    p = P.reshape(2, -1)  # node (j, i) -> j * n_th + i
    j = np.arange(n_r)[:, None]
    i = np.arange(n_th)[None, :]
    i1 = (i + 1) % n_th
    t_el = np.stack([j * n_th + i, j * n_th + i1, (j + 1) * n_th + i1, (j + 1) * n_th + i]).reshape(4, -1)
    mat = np.where(j < ns, 1, 0) * np.ones_like(i)
    t0 = np.degrees(t)
    t1 = np.degrees(np.concatenate([t[1:], [t[0] + 2 * np.pi]]))
    # an element of the outer layer is nail where its arc overlaps the nail's arc
    nail = (t1 > 90.0 - finger.nail_half_angle) & (t0 < 90.0 + finger.nail_half_angle)
    mat = np.where((j < ns) & nail[None, :], 2, mat)
    return FingerMesh(p=np.ascontiguousarray(p), t=np.ascontiguousarray(t_el), material=mat.reshape(-1),
                      outer=np.arange(n_th), bone=n_r * n_th + np.arange(n_th))
