"""Synthetic silhouette frames for the video tests (independent of the simulator).

A plate with a raised-cosine feature at the bottom, optionally a finger from above: a disc
of radius ``radius_mm`` whose lower outline is flattened where it would enter the surface.
Pixels are anti-aliased by their exact vertical coverage, then blurred (Gaussian) and
optionally given noise.
"""

from __future__ import annotations

import cv2
import numpy as np

from fingerfriction.surfaces import RaisedCosine

BRIGHT, DARK = 220.0, 30.0


def _coverage_below(edge: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Fraction of each pixel (rows x cols) lying below the edge row of its column."""
    return np.clip(rows[:, None] + 0.5 - edge[None, :], 0.0, 1.0)


def render(*, shape=(720, 1280), mm_per_px=0.023, surface=None, x0_px=640.3, base_row=520.4,
           finger=None, blur=1.0, noise=0.0, rng=None, dtype=np.uint8):
    """One frame and its geometry.

    Parameters
    ----------
    finger : (x_mm, z_mm, radius_mm) or None
        Disc centre x in surface mm, height in mm of the disc's lowest point above the
        base (negative: pressed into the surface, flattened), radius in mm.

    Returns
    -------
    frame : (rows, cols) ndarray
    geom : dict
        ``surface_row`` (cols,) full-frame edge rows, ``finger_row`` (cols,) outline rows or
        NaN, ``x_mm`` (cols,) surface position of each column.
    """
    surface = surface or RaisedCosine("bump", 2.0)
    rows_n, cols_n = shape
    cols = np.arange(cols_n, dtype=float)
    x_mm = (cols - x0_px) * mm_per_px
    s_row = base_row - surface.h(x_mm) / mm_per_px
    rows = np.arange(rows_n, dtype=float)
    dark = _coverage_below(s_row, rows)
    f_row = np.full(cols_n, np.nan)
    if finger is not None:
        fx, fz, R = finger
        dx = x_mm - fx
        inside = np.abs(dx) < R
        low = np.full(cols_n, -np.inf)
        low[inside] = (fz + R - np.sqrt(R**2 - dx[inside] ** 2))  # height (mm) of the disc's lower edge
        f_mm = np.maximum(low, surface.h(x_mm))
        f_row = np.where(inside, base_row - f_mm / mm_per_px, np.nan)
        cov_f = np.where(inside[None, :], 1.0 - _coverage_below(np.nan_to_num(f_row, nan=-1e9), rows), 0.0)
        dark = np.clip(dark + cov_f, 0.0, 1.0)
    img = BRIGHT - (BRIGHT - DARK) * dark
    if blur > 0:
        img = cv2.GaussianBlur(img, (0, 0), blur)
    if noise > 0:
        rng = rng or np.random.default_rng(0)
        img = img + rng.normal(0.0, noise, img.shape)
    if dtype == np.uint16:
        img = img * 256.0
    img = np.clip(np.rint(img), 0, np.iinfo(dtype).max).astype(dtype)
    return img, {"surface_row": s_row, "finger_row": f_row, "x_mm": x_mm}


def render_video(xs_mm, *, z_mm=-0.15, radius_mm=8.0, **kw):
    """Frames: a finger-free calibration frame then one frame per finger position."""
    frames = [render(**kw)[0]]
    for x in xs_mm:
        frames.append(render(finger=(x, z_mm, radius_mm), **kw)[0])
    return np.stack(frames)
