"""Area-preserving finger region C_f and finger position x(t) (Fig. 7C,D).

Methods, "Image analysis": the tissue is modelled as incompressible; the area ``A``
enclosed by the fingertip contour below a horizontal line 0.4 mm above the maximum
height of the surface feature is computed in the first finger frame; in every later
frame the line is moved so that the region ``C_f`` between it and the finger's lower
outline again encloses ``A``, and ``x(t)`` is the x coordinate of the centroid of ``C_f``.

With the lower outline given per column as a row ``f[c]`` (rows grow downwards, sub-pixel),
the region below line row ``r`` has per-column height ``max(f[c] - r, 0)``:

    area(r) = sum_c max(f[c] - r, 0)            (px^2)
    centroid column = sum_c c max(f[c] - r, 0) / area(r)

``area`` is convex, piecewise linear and decreasing in ``r``, so the line enclosing a
given area is found exactly from the sorted outline (no iteration).
"""

from __future__ import annotations

import numpy as np

__all__ = ["area_below_line", "line_for_area", "centroid_below_line"]


def area_below_line(f: np.ndarray, r) -> np.ndarray:
    """Area in px^2 between the outline rows ``f`` and the line row ``r``.

    Parameters
    ----------
    f : (..., width) float ndarray
        Lower-outline row per column; NaN where there is no finger.
    r : float or (...,) ndarray
        Line row(s).

    Returns
    -------
    (...,) ndarray
    """
    f = np.asarray(f, dtype=float)
    r = np.asarray(r, dtype=float)[..., None]
    return np.nansum(np.clip(f - r, 0.0, None), axis=-1)


def line_for_area(f: np.ndarray, area, *, top: float = -0.5) -> np.ndarray:
    """Row of the horizontal line below which the finger encloses ``area`` (px^2).

    Parameters
    ----------
    f : (n_frames, width) float ndarray
        Lower-outline rows; NaN where there is no finger.
    area : float
        Target area ``A`` in px^2 (> 0).
    top : float
        Highest allowed line (the crop's top edge, row -0.5).

    Returns
    -------
    (n_frames,) ndarray
        The line row; NaN where even the line at ``top`` encloses less than ``area``
        (finger lifted or missing).
    """
    f = np.atleast_2d(np.asarray(f, dtype=float))
    A = float(area)
    if not A > 0:
        raise ValueError(f"area must be > 0 px^2, got {area!r}")
    g = np.where(np.isnan(f), top, np.maximum(f, top))
    fs = -np.sort(-g, axis=1)  # descending
    n, w = fs.shape
    S = np.cumsum(fs, axis=1)  # S[:, k-1] = sum of the k largest
    k = np.arange(1, w + 1)
    nxt = np.concatenate([fs[:, 1:], np.full((n, 1), top)], axis=1)
    G = S - k * nxt  # area when the line sits at the (k+1)-th largest value (or at top)
    ok = G >= A
    found = ok.any(axis=1)
    kk = np.argmax(ok, axis=1)  # first k (0-based) with G >= A
    r = (S[np.arange(n), kk] - A) / (kk + 1)
    return np.where(found, r, np.nan)


def centroid_below_line(f: np.ndarray, r) -> np.ndarray:
    """Centroid column of the region between outline ``f`` and line ``r`` (NaN if empty)."""
    f = np.atleast_2d(np.asarray(f, dtype=float))
    r = np.asarray(r, dtype=float).reshape(-1, 1)
    wgt = np.nan_to_num(np.clip(f - r, 0.0, None))
    tot = wgt.sum(axis=1)
    cols = np.arange(f.shape[1], dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(tot > 0, wgt @ cols / tot, np.nan)


def chord_midpoint(f: np.ndarray, row: float) -> np.ndarray:
    """Midpoint column of the finger's chord at a horizontal row (an alternative x(t)).

    The outline crosses ``row`` once on each side of the finger; the crossings are
    interpolated linearly between columns and their midpoint returned. Far enough above
    the contact, the finger's sides are not deformed by the relief, so the midpoint
    follows the finger's centre without the deformation-dependent shift of the C_f
    centroid (this is not in the paper; see the benchmark for both).

    Parameters
    ----------
    f : (n_frames, width) float ndarray
        Lower-outline rows, NaN where there is no finger.
    row : float
        The chord's row (px, crop coordinates).

    Returns
    -------
    (n_frames,) ndarray
        Midpoint column; NaN where the outline does not reach ``row`` or the chord is cut
        by the crop's side.
    """
    f = np.atleast_2d(np.asarray(f, dtype=float))
    n, w = f.shape
    below = np.nan_to_num(f, nan=-np.inf) > row
    anyb = below.any(axis=1)
    a = np.argmax(below, axis=1)
    b = w - 1 - np.argmax(below[:, ::-1], axis=1)
    ok = anyb & (a > 0) & (b < w - 1)
    a = np.where(ok, a, 1)
    b = np.where(ok, b, w - 2)
    t = np.arange(n)
    fa0 = np.nan_to_num(f[t, a - 1], nan=-1.0)
    fa = f[t, a]
    fb = f[t, b]
    fb1 = np.nan_to_num(f[t, b + 1], nan=-1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        left = a - 1 + (row - fa0) / (fa - fa0)
        right = b + (fb - row) / (fb - fb1)
    return np.where(ok, 0.5 * (left + right), np.nan)
