"""Contact regions C_i from the finger and surface outlines (Methods, "Image analysis").

"A pair of points separated by a distance of 3 pixels (i.e. 70 um) or less was
considered to be in contact." For each column's point of the finger's lower outline
``(c, f[c])`` this module computes its distance to the surface outline ``(c', s[c'])``
(sub-pixel rows from the calibration frame):

* ``metric='euclidean'`` (the paper's): ``min_j sqrt(j^2 + (s[c+j] - f[c])^2)`` over
  neighbouring columns ``|j| <= ceil(tol) + 1``;
* ``metric='vertical'``: the vertical gap ``s[c] - f[c]``, the definition a simulator
  uses when it thresholds ``gap(x) = finger(x) - h(x)``.

The lowest finger pixel of a column is the one nearest the surface: the surface
silhouette is closed under moving down, so the distance to it can only decrease going
down a column. Hence testing the lower outline is equivalent to testing every finger
contour point (checked in the tests against a brute-force pairwise test).

Contact columns form runs; each run becomes one region ``[a_i, b_i]`` whose ends are
interpolated where the distance crosses the tolerance, then mapped to surface mm.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["contact_distance", "contact_regions"]


def contact_distance(f: np.ndarray, s: np.ndarray, *, metric: str = "euclidean",
                     tol_px: float = 3.0) -> np.ndarray:
    """Distance in px from each column's finger outline point to the surface outline.

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
        Distance in px (0 where the finger touches or overlaps), NaN where no finger.
    """
    f = np.atleast_2d(np.asarray(f, dtype=float))
    s = np.asarray(s, dtype=float)
    if metric == "vertical":
        return np.maximum(s[None, :] - f, 0.0)
    if metric != "euclidean":
        raise ValueError(f"metric must be 'euclidean' or 'vertical', got {metric!r}")
    J = int(math.ceil(tol_px)) + 1
    d = np.maximum(s[None, :] - f, 0.0)
    # Only points whose vertical gap is below 2 tol (or the slope bound) can be within tol
    # of a neighbouring column; the others keep their vertical gap (> tol either way).
    ti, ci = np.nonzero(d <= 2.0 * tol_px + J)
    if ti.size:
        fv = f[ti, ci]
        best = d[ti, ci]
        spad = np.concatenate([np.full(J, np.inf), s, np.full(J, np.inf)])
        for j in range(-J, J + 1):
            if j == 0:
                continue
            dy = np.maximum(spad[ci + J + j] - fv, 0.0)
            np.minimum(best, np.sqrt(j * j + dy * dy), out=best)
        d[ti, ci] = best
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
