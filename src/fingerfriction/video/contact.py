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
Runs closer than ``min_gap_px`` are merged and runs shorter than ``min_region_px`` dropped
(pixel-scale flicker of slowly opening contact edges; see docs/video.md).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from scipy.ndimage import correlate1d
from scipy.signal import savgol_coeffs

from .._check import check_option

__all__ = ["contact_distance", "contact_regions", "smooth_outline", "CONTACT_METRICS"]

#: How the distance from the finger to the surface is measured (``metric``).
CONTACT_METRICS = ("euclidean", "vertical")


def smooth_outline(rows: np.ndarray, window: int, order: int = 2) -> np.ndarray:
    """Savitzky-Golay smoothing of outline rows along the columns, NaN-aware.

    Not in the paper. Each sub-pixel outline row carries its own noise (a few hundredths
    of a pixel, ``docs/video.md``); near a contact edge where the gap opens by
    only 1 px over 50-200 columns, that noise moves the 3 px crossing by several pixels.
    A local polynomial fit over ``window`` columns averages it while keeping curvature.

    Parameters
    ----------
    rows : (..., width) float ndarray
        Outline rows in px, NaN where there is no outline.
    window : int
        Odd number of columns of the fit; 0 or 1 returns ``rows`` unchanged.
    order : int
        Polynomial order (< window).

    Returns
    -------
    (..., width) float ndarray
        Smoothed rows; a column whose window reaches a NaN or the end of the array keeps
        its raw value (no extrapolation), NaN stays NaN.

    Notes
    -----
    Orders 0-1 and 2-3 (which share their coefficients for a centred window) run in a
    compiled pass with running window sums (:func:`_sg_running`); others through
    :func:`scipy.signal.savgol_coeffs` and :func:`scipy.ndimage.correlate1d`. Why
    compiled: ``correlate1d`` with 41 taps was a large share of the whole per-frame
    analysis (``docs/video.md``); the two agree to ~1e-9 px, checked in the tests.
    """
    rows = np.asarray(rows, dtype=float)
    if window <= 1:
        return rows
    if window % 2 == 0 or not 0 <= order < window:
        raise ValueError(f"window must be odd and > order, got window={window!r}, order={order!r}")
    if order <= 3:
        flat = np.ascontiguousarray(rows.reshape(-1, rows.shape[-1]))
        out = np.empty_like(flat)
        _sg_running(flat, window // 2, order >= 2, out)
        return out.reshape(rows.shape)
    fin = np.isfinite(rows)
    sm = correlate1d(np.where(fin, rows, 0.0), savgol_coeffs(window, order), axis=-1, mode="nearest")
    # windows holding a NaN or running past either end keep the raw value
    bad = correlate1d((~fin).astype(np.float32), np.ones(window, np.float32), axis=-1,
                      mode="constant", cval=1.0) > 0
    return np.where(bad, rows, sm)


@njit(cache=True, nogil=True)
def _sg_running(rows, m, quadratic, out):  # pragma: no cover - compiled
    """Centred Savitzky-Golay fit of order 1 (``quadratic`` False) or 2 over ``2m+1``
    columns of each row, by running sums of ``y``, ``j y`` and ``j^2 y``; raw values where
    the window holds a NaN or leaves the row. The sums are re-anchored every 256 columns
    to bound round-off."""
    k, n = rows.shape
    w = 2 * m + 1
    D = (2.0 * m - 1.0) * (2.0 * m + 1.0) * (2.0 * m + 3.0)
    A = 3.0 * (3.0 * m * m + 3.0 * m - 1.0) / D
    B = 15.0 / D
    for r in range(k):
        y = rows[r]
        o = out[r]
        for c in range(n):
            o[c] = y[c]
        if n < w:
            continue
        c = m
        while c < n - m:
            # (re-)anchor: sums over the window centred on c, offsets j = i - c
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            nbad = 0
            for j in range(-m, m + 1):
                v = y[c + j]
                if v != v:
                    nbad += 1
                else:
                    s0 += v
                    s1 += j * v
                    s2 += j * j * v
            stop = min(c + 256, n - m)
            while True:
                if nbad == 0:
                    o[c] = A * s0 - B * s2 if quadratic else s0 / w
                if c + 1 >= stop:
                    break
                # slide to c + 1: offsets shift by -1, drop y[c-m] (j=-m), add y[c+m+1] (j=m)
                vo = y[c - m]
                vi = y[c + m + 1]
                if vo != vo:
                    nbad -= 1
                    vo = 0.0
                if vi != vi:
                    nbad += 1
                    vi = 0.0
                # sums with offsets j' = j - 1: s2' = s2 - 2 s1 + s0, s1' = s1 - s0
                s0o = s0 - vo
                s1o = s1 + m * vo  # remove the term j=-m: s1 - (-m) vo
                s2o = s2 - m * m * vo
                s2 = s2o - 2.0 * s1o + s0o + m * m * vi
                s1 = s1o - s0o + m * vi
                s0 = s0o + vi
                c += 1
            c += 1
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
    check_option("metric", metric, CONTACT_METRICS)
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


def contact_regions(d: np.ndarray, tol_px: float, col_to_mm, *, n_max: int = 8,
                    min_gap_px: float = 0.0, min_region_px: float = 0.0,
                    on_overflow: str = "raise"):
    """Contact regions from per-column distances, with the pixel-scale cleanup.

    Parameters
    ----------
    d : (n_frames, width) ndarray
        Distance finger -> surface in px (NaN: no finger).
    tol_px : float
        Contact tolerance in px (paper: 3).
    col_to_mm : callable
        Maps (fractional) crop columns to surface mm.
    n_max : int
        Slots per frame.
    min_gap_px : float
        Neighbouring runs of contact columns whose gap (from the interpolated end of one
        to the interpolated start of the next, px) is shorter than this are one region.
        0 disables the merge.
    min_region_px : float
        Regions (after merging) shorter than this (px, interpolated ends) are dropped.
        0 disables the drop.
    on_overflow : {'raise', 'mask'}
        A frame with more than ``n_max`` regions (after the cleanup) raises ``ValueError``
        ('raise'); with 'mask' it gets no regions (all NaN) and is reported in the second
        return value, so that the caller can flag it.

    Returns
    -------
    regions : (n_frames, n_max, 2) ndarray
        Regions ``[a_i, b_i]`` in mm (:mod:`fingerfriction.regions` format), NaN-padded.
    too_many : (n_frames,) bool ndarray
        Only with ``on_overflow='mask'``: frames that had more than ``n_max`` regions.

    Notes
    -----
    Why a cleanup, and the measured defaults: see docs/video.md, 'Contact-region cleanup'.
    """
    check_option("on_overflow", on_overflow, ("raise", "mask"))
    for name, v in (("min_gap_px", min_gap_px), ("min_region_px", min_region_px)):
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"{name} must be a finite number of px >= 0, got {v!r}")
    d = np.atleast_2d(d)
    n = d.shape[0]
    t, a_col, b_col = _runs(d, tol_px)
    if min_gap_px > 0 and t.size > 1:
        # runs come sorted by (frame, column): bridge short gaps to the previous run
        join = np.r_[False, (t[1:] == t[:-1]) & (a_col[1:] - b_col[:-1] < min_gap_px)]
        first = np.flatnonzero(~join)
        last = np.r_[first[1:] - 1, t.size - 1]
        t, a_col, b_col = t[first], a_col[first], b_col[last]
    if min_region_px > 0:
        keep = (b_col - a_col) >= min_region_px
        t, a_col, b_col = t[keep], a_col[keep], b_col[keep]
    counts = np.bincount(t, minlength=n)
    too_many = counts > n_max
    if too_many.any():
        if on_overflow == "raise":
            k = int(np.argmax(counts))
            raise ValueError(f"frame {k} has {counts[k]} contact regions, more than n_max={n_max}")
        keep = ~too_many[t]
        t, a_col, b_col = t[keep], a_col[keep], b_col[keep]
        counts[too_many] = 0
    out = np.full((n, n_max, 2), np.nan)
    slot = np.arange(t.size) - np.repeat(np.cumsum(counts) - counts, counts)
    out[t, slot, 0] = col_to_mm(a_col)
    out[t, slot, 1] = col_to_mm(b_col)
    if on_overflow == "mask":
        return out, too_many
    return out


def _runs(d: np.ndarray, tol_px: float):
    """The runs of contact columns of every frame of ``d`` (n_frames, width), sorted by
    (frame, column): ``(frame, a_col, b_col)``, the ends in fractional columns, interpolated
    where the distance crosses ``tol_px`` (0.5 where it cannot be)."""
    n = d.shape[0]
    m = d <= tol_px  # NaN -> False
    pad = np.zeros((n, 1), dtype=bool)
    dm = np.diff(np.concatenate([pad, m, pad], axis=1).astype(np.int8), axis=1)
    st_t, st_c = np.nonzero(dm == 1)  # first contact column
    en_t, en_c = np.nonzero(dm == -1)  # one past the last contact column
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
    return st_t, a_col, b_col
