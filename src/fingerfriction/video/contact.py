"""Contact regions C_i from the finger and surface outlines (Methods, "Image analysis").

"A pair of points separated by a distance of 3 pixels (i.e. 70 um) or less was
considered to be in contact." The regions are wanted in surface coordinates, so for each
column's point of the surface outline ``(c, s[c])`` (sub-pixel rows from the calibration
frame) this module computes its distance to the finger's lower outline ``f``:

* ``metric='euclidean'`` (the paper's): the distance from the surface point to the finger
  silhouette, ``min_j sqrt(j^2 + max(s[c] - f[c+j], 0)^2)`` over neighbouring columns
  ``|j| <= ceil(tol) + 1``;
* ``metric='vertical'``: the vertical gap ``s[c] - f[c]``.

Why the lower outline suffices: the finger silhouette is closed under moving up (it comes
from above), so the point of a finger column nearest to a surface point is its lowest
point, or the point level with it when the column reaches lower; and the surface
silhouette is closed under moving down, so a column's top surface point is its nearest to
the finger. Testing these points is therefore equivalent to testing every pair of finger
and surface contour points (checked in the tests against a brute-force pairwise test).

Contact columns form runs; each run becomes one region ``[a_i, b_i]`` whose ends are
interpolated where the distance crosses the tolerance, then mapped to surface mm.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["contact_distance", "contact_regions"]


def contact_distance(f: np.ndarray, s: np.ndarray, *, metric: str = "euclidean",
                     tol_px: float = 3.0) -> np.ndarray:
    """Distance in px from each column's surface outline point to the finger.

    Parameters
    ----------
    f : (n_frames, width) float ndarray
        Finger lower-outline rows (NaN: no finger in that column).
    s : (width,) float ndarray
        Surface edge rows.
    metric : {'euclidean', 'vertical'}
    tol_px : float
        Contact tolerance in px; only sets how far sideways the euclidean search looks.

    Returns
    -------
    (n_frames, width) ndarray
        Distance in px (0 where the finger touches), NaN where the finger is absent from
        the column (vertical) or from every column within the search window (euclidean).
    """
    f = np.atleast_2d(np.asarray(f, dtype=float))
    s = np.asarray(s, dtype=float)
    if metric not in ("euclidean", "vertical"):
        raise ValueError(f"metric must be 'euclidean' or 'vertical', got {metric!r}")
    d = np.maximum(s[None, :] - f, 0.0)
    if metric == "vertical":
        return d
    J = int(math.ceil(tol_px)) + 1
    n, w = f.shape
    # Only surface points with a finger column within reach can be in contact; compute
    # the neighbourhood minimum there (sparse), elsewhere keep the vertical gap.
    dd = np.where(np.isnan(d), np.inf, d)
    near = np.zeros((n, w), bool)
    lim = 2.0 * tol_px + J
    for j in range(-J, J + 1):
        lo, hi = max(0, -j), min(w, w - j)
        near[:, lo:hi] |= dd[:, lo + j:hi + j] <= lim
    ti, ci = np.nonzero(near)
    if ti.size:
        best = dd[ti, ci]
        fpad = np.concatenate([np.full((n, J), np.nan), f, np.full((n, J), np.nan)], axis=1)
        sc = s[ci]
        for j in range(-J, J + 1):
            if j == 0:
                continue
            fj = fpad[ti, ci + J + j]
            dy = np.maximum(sc - fj, 0.0)
            dist = np.sqrt(j * j + dy * dy)
            np.minimum(best, np.where(np.isnan(fj), np.inf, dist), out=best)
        d[ti, ci] = np.where(np.isfinite(best), best, np.nan)
    return d


def contact_regions(d: np.ndarray, tol_px: float, col_to_mm, *, n_max: int = 8) -> np.ndarray:
    """Contact regions from per-column distances.

    Parameters
    ----------
    d : (n_frames, width) ndarray
        Distance finger -> surface in px (NaN: no finger).
    tol_px : float
        Contact tolerance in px (paper: 3).
    col_to_mm : callable
        Maps (fractional) crop columns to surface mm.
    n_max : int
        Slots per frame; a frame with more regions raises ``ValueError``.

    Returns
    -------
    (n_frames, n_max, 2) ndarray
        Regions ``[a_i, b_i]`` in mm (:mod:`fingerfriction.regions` format), NaN-padded.
    """
    d = np.atleast_2d(d)
    n, w = d.shape
    m = d <= tol_px  # NaN -> False
    pad = np.zeros((n, 1), dtype=bool)
    dm = np.diff(np.concatenate([pad, m, pad], axis=1).astype(np.int8), axis=1)
    st_t, st_c = np.nonzero(dm == 1)  # first contact column
    en_t, en_c = np.nonzero(dm == -1)  # one past the last contact column
    counts = np.bincount(st_t, minlength=n)
    if counts.size and counts.max() > n_max:
        t = int(np.argmax(counts))
        raise ValueError(f"frame {t} has {counts[t]} contact regions, more than n_max={n_max}")
    dpad = np.concatenate([np.full((n, 1), np.nan), d, np.full((n, 1), np.nan)], axis=1)
    # start: crossing between column c-1 (out) and c (in); dpad index = column + 1
    d_out = dpad[st_t, st_c]
    d_in = dpad[st_t, st_c + 1]
    with np.errstate(invalid="ignore", divide="ignore"):
        fr = np.where(np.isfinite(d_out) & (d_out > d_in), (d_out - tol_px) / (d_out - d_in), 0.5)
    a_col = st_c - 1 + np.clip(fr, 0.0, 1.0)
    e_in = dpad[en_t, en_c]  # column en_c - 1 (last in)
    e_out = dpad[en_t, en_c + 1]  # column en_c (first out)
    with np.errstate(invalid="ignore", divide="ignore"):
        fr = np.where(np.isfinite(e_out) & (e_out > e_in), (tol_px - e_in) / (e_out - e_in), 0.5)
    b_col = en_c - 1 + np.clip(fr, 0.0, 1.0)
    out = np.full((n, n_max, 2), np.nan)
    slot = np.arange(st_t.size) - np.repeat(np.cumsum(counts) - counts, counts)
    out[st_t, slot, 0] = col_to_mm(a_col)
    out[st_t, slot, 1] = col_to_mm(b_col)
    return out
