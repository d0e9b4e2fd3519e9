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

Alternatives (not in the paper): :func:`chord_midpoint`, the midpoint of the finger's chord
at a fixed row, and :func:`hybrid_positions`, the chord midpoint where the chord is in
view and, beyond, one edge of the outline (:func:`chord_ends`) shifted by an offset
measured where both are seen. How the three compare on the simulated studies: ``docs/video.md``.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

__all__ = ["area_below_line", "line_for_area", "centroid_below_line", "chord_midpoint", "chord_ends",
           "PositionSource", "HybridPositions", "hybrid_positions"]


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
    left, right = chord_ends(f, row)
    return 0.5 * (left + right)


def chord_ends(f: np.ndarray, row: float) -> tuple[np.ndarray, np.ndarray]:
    """Columns where the finger's outline crosses a horizontal row, on each side.

    Each end is found on its own: the left end exists when the outline crosses ``row``
    inside the crop on the finger's left side, whatever happens on its right side (and
    vice versa), so one end can serve as a position when the other has left the field of
    view (see :func:`hybrid_positions`).

    Parameters
    ----------
    f : (n_frames, width) float ndarray
        Lower-outline rows, NaN where there is no finger.
    row : float
        The row (px, crop coordinates).

    Returns
    -------
    left, right : (n_frames,) ndarray
        Sub-pixel columns of the crossings (linear interpolation between columns; a
        column without finger counts as row -1, above the crop); NaN where the outline
        does not reach ``row`` or that end is cut by the crop's side.
    """
    f = np.atleast_2d(np.asarray(f, dtype=float))
    n, w = f.shape
    below = np.nan_to_num(f, nan=-np.inf) > row
    anyb = below.any(axis=1)
    a = np.argmax(below, axis=1)
    b = w - 1 - np.argmax(below[:, ::-1], axis=1)
    okl = anyb & (a > 0)
    okr = anyb & (b < w - 1)
    a = np.where(okl, a, 1)
    b = np.where(okr, b, w - 2)
    t = np.arange(n)
    fa0 = np.nan_to_num(f[t, a - 1], nan=-1.0)
    fa = f[t, a]
    fb = f[t, b]
    fb1 = np.nan_to_num(f[t, b + 1], nan=-1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        left = a - 1 + (row - fa0) / (fa - fa0)
        right = b + (fb - row) / (fb - fb1)
    return np.where(okl, left, np.nan), np.where(okr, right, np.nan)


class PositionSource(enum.IntEnum):
    """Which estimator gave a frame's hybrid position (:func:`hybrid_positions`)."""

    NONE = 0
    CHORD = 1
    LEFT_EDGE = 2
    RIGHT_EDGE = 3


@dataclass(frozen=True)
class HybridPositions:
    """Result of :func:`hybrid_positions`.

    Attributes
    ----------
    x : (n_frames,) ndarray
        Position in mm; NaN where no estimator applies.
    source : (n_frames,) uint8 ndarray
        :class:`PositionSource` of each frame.
    offsets_mm : dict
        ``{'left': o_L, 'right': o_R}``: chord midpoint minus edge position (mm), NaN
        where it could not be estimated.
    calibration_frames : dict
        ``{'left': n, 'right': n}``: frames the offsets were estimated from.
    calibration_range_mm : dict
        ``{'left': (lo, hi), 'right': (lo, hi)}``: chord positions (mm) of those frames.
    """

    x: np.ndarray = field(repr=False)
    source: np.ndarray = field(repr=False)
    offsets_mm: dict
    calibration_frames: dict
    calibration_range_mm: dict

    def counts(self) -> dict[str, int]:
        """Number of frames per estimator, by :class:`PositionSource` name."""
        return {s.name: int(np.count_nonzero(self.source == s)) for s in PositionSource}


def _edge_stand_in(xc: np.ndarray, xe: np.ndarray, sign: float, calibration_mm: float, min_frames: int):
    """One outline edge as a stand-in for the chord midpoint (:func:`hybrid_positions`):
    ``(offset_mm, n_calibration_frames, calibration_range_mm, x)``, ``x`` the edge plus its
    offset beyond the calibration range where the chord is missing (NaN elsewhere), or
    None when fewer than ``min_frames`` frames have both. ``sign``: +1 for the left
    (trailing) edge, calibrated at the right end of the chord's range; -1 for the right."""
    has_c = np.isfinite(xc)
    both = np.flatnonzero(has_c & np.isfinite(xe))
    if both.size < min_frames:
        return float("nan"), 0, (float("nan"), float("nan")), None
    # signed distance from the chord range's end on this side (left edge: right end)
    depth = sign * (xc[both].max() if sign > 0 else xc[both].min()) - sign * xc[both]
    sel = both[depth <= calibration_mm]
    if sel.size < min_frames:
        sel = both[np.argsort(depth, kind="stable")[:min_frames]]
    o = float(np.median(xc[sel] - xe[sel]))
    rng = (float(xc[sel].min()), float(xc[sel].max()))
    xs = xe + o
    # beyond the calibration range only, on this side (where the finger is on the flat)
    beyond = (xs >= rng[0]) if sign > 0 else (xs <= rng[1])
    return o, int(sel.size), rng, np.where(~has_c & np.isfinite(xs) & beyond, xs, np.nan)


def hybrid_positions(x_chord, x_left, x_right, *, calibration_mm: float = 1.0,
                     min_frames: int = 3) -> HybridPositions:
    """Chord midpoint where it exists, one offset-corrected outline edge beyond its range.

    Not in the paper. The chord midpoint (:func:`chord_midpoint`) follows the finger's
    centre without the deformation-dependent shift of the C_f centroid, but its chord is
    cut by the crop's sides once the finger is more than ~8 mm from the feature. Beyond
    that, the finger's trailing (left) or leading (right) edge, taken higher up the
    outline where the tissue barely deforms, is still in view; it sits a constant
    distance from the centre while the finger rests on flat ground. That distance (the
    edge's *offset*) is estimated per video as the median of ``x_chord - x_edge`` over the
    frames at the end of the chord's range on the side where the edge stands in (within
    ``calibration_mm`` of that end: the finger is on the flat there, as beyond), and the
    edge is used only beyond that calibration range.

    Parameters
    ----------
    x_chord : (n_frames,) array_like
        Chord midpoint in mm; NaN where unavailable.
    x_left, x_right : (n_frames,) array_like
        Left / right edge of the outline at the edge row, in mm; NaN where unavailable
        (the caller also blanks frames where the finger does not touch the surface: an
        edge is only a position while the finger rests on the surface).
    calibration_mm : float
        Length of chord travel (mm) at each end of the chord's range whose frames give the
        offset. Default 1.0.
    min_frames : int
        Fewest calibration frames; if fewer lie within ``calibration_mm``, the
        ``min_frames`` nearest the end are used; if the video has fewer than that, the
        edge is not used.

    Returns
    -------
    HybridPositions
    """
    xc = np.asarray(x_chord, dtype=float)
    xl = np.asarray(x_left, dtype=float)
    xr = np.asarray(x_right, dtype=float)
    if not (xc.ndim == 1 and xc.shape == xl.shape == xr.shape):
        raise ValueError(f"x_chord, x_left and x_right must be 1-D of one length, got shapes "
                         f"{xc.shape}, {xl.shape}, {xr.shape}")
    if not (np.isfinite(calibration_mm) and calibration_mm > 0):
        raise ValueError(f"calibration_mm must be > 0 mm, got {calibration_mm!r}")
    if int(min_frames) < 1:
        raise ValueError(f"min_frames must be >= 1, got {min_frames!r}")
    has_c = np.isfinite(xc)
    x = np.where(has_c, xc, np.nan)
    source = np.where(has_c, PositionSource.CHORD, PositionSource.NONE).astype(np.uint8)
    offsets, n_cal, ranges = {}, {}, {}
    est = {}
    for side, xe, sign in (("left", xl, 1.0), ("right", xr, -1.0)):
        offsets[side], n_cal[side], ranges[side], e = _edge_stand_in(xc, xe, sign, calibration_mm,
                                                                     int(min_frames))
        if e is not None:
            est[side] = e
    nan = np.full(xc.shape, np.nan)
    el, er = est.get("left", nan), est.get("right", nan)
    use_l, use_r = np.isfinite(el), np.isfinite(er)
    both = use_l & use_r
    if both.any():
        # both edges qualify (only when the two calibration ranges overlap, i.e. the chord
        # covered very little): keep the edge whose calibration range is nearer
        dl = np.abs(el - np.mean(ranges["left"]))
        dr = np.abs(er - np.mean(ranges["right"]))
        use_l &= ~both | (dl <= dr)
        use_r &= ~use_l
    x[use_l], source[use_l] = el[use_l], PositionSource.LEFT_EDGE
    x[use_r], source[use_r] = er[use_r], PositionSource.RIGHT_EDGE
    return HybridPositions(x=x, source=source, offsets_mm=offsets, calibration_frames=n_cal,
                           calibration_range_mm=ranges)
