"""Synchronisation of the forces with the video clock and resampling onto finger
positions (Methods "Force data processing": the 0.01 mm grid over the 26 mm window).

The forces keep their own rate and the finger position is interpolated to the force
sample times (:func:`positions_at_times`; ``docs/forces.md`` says why this direction);
:func:`resample_to_positions` averages the samples per position bin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._check import positive as _positive
from ..regions import as_regions

__all__ = [
    "positions_at_times",
    "extrapolate_positions",
    "flat_segment_from_positions",
    "flat_mask_from_regions",
    "PositionResampling",
    "resample_to_positions",
]


def positions_at_times(t, t_frames, x_frames) -> np.ndarray:
    """Finger position at arbitrary times by linear interpolation between frames.

    Parameters
    ----------
    t : (n,) array_like
        Times in s on the common clock (the force samples).
    t_frames : (m,) array_like
        Frame times in s on the same clock, increasing.
    x_frames : (m,) array_like
        Finger centre in mm at each frame; NaN where there is no finger.

    Returns
    -------
    (n,) ndarray
        Position in mm; NaN outside ``[t_frames[0], t_frames[-1]]`` and wherever one of
        the two bracketing frames is NaN.
    """
    t = np.asarray(t, dtype=np.float64)
    tf = np.asarray(t_frames, dtype=np.float64)
    xf = np.asarray(x_frames, dtype=np.float64)
    if tf.ndim != 1 or tf.shape != xf.shape:
        raise ValueError(
            f"t_frames and x_frames must be 1-D of the same length, got {tf.shape} and {xf.shape}"
        )
    if tf.size < 2 or np.any(np.diff(tf) <= 0):
        raise ValueError("t_frames must hold at least 2 strictly increasing times in s")
    k = np.searchsorted(tf, t, side="right") - 1
    inside = (k >= 0) & (t <= tf[-1])
    k = np.clip(k, 0, tf.size - 2)
    t0, t1 = tf[k], tf[k + 1]
    w = (t - t0) / (t1 - t0)
    x = xf[k] * (1 - w) + xf[k + 1] * w
    # exactly on a frame: do not let a NaN next frame poison a valid sample
    on_frame = w == 0
    x = np.where(on_frame, xf[k], x)
    x[~inside] = np.nan
    return x


def extrapolate_positions(
    t_frames, x_frames, *, max_mm: float, fit_s: float = 0.03
) -> tuple[np.ndarray, tuple[float, float]]:
    """Extend a tracked x(t) at constant speed beyond its first and last tracked frames.

    The video may lose the finger near the edges of its field of view (the finger is
    about 16 mm wide; the field about 29 mm) while the 26 mm window needs positions up to
    13 mm from the feature. Before the first and after the last tracked frame, the
    position is extended along a line fitted over ``fit_s`` s of tracked frames, for as
    long as it stays within ``max_mm`` of the tracked end. Frames in between (flagged
    frames inside the tracked span) are left as they are.

    Parameters
    ----------
    t_frames : (m,) array_like
        Frame times in s.
    x_frames : (m,) array_like
        Finger position in mm, NaN where not tracked.
    max_mm : float
        Longest extension in mm at each end.
    fit_s : float
        Duration in s of tracked frames used for the speed at each end. Default 0.03.

    Returns
    -------
    x : (m,) ndarray
        Positions in mm with the extensions.
    (before_mm, after_mm) : tuple of float
        Length of each extension in mm (0 where nothing was added).
    """
    tf = np.asarray(t_frames, dtype=np.float64)
    x = np.asarray(x_frames, dtype=np.float64).copy()
    fin = np.flatnonzero(np.isfinite(x))
    if fin.size < 2:
        return x, (0.0, 0.0)
    k0, k1 = int(fin[0]), int(fin[-1])
    ext = [0.0, 0.0]
    for side, k, sel in ((0, k0, fin[tf[fin] <= tf[k0] + fit_s]), (1, k1, fin[tf[fin] >= tf[k1] - fit_s])):
        if sel.size < 2:
            continue
        slope, icpt = np.polyfit(tf[sel], x[sel], 1)
        idx = np.arange(0, k0) if side == 0 else np.arange(k1 + 1, x.size)
        xe = slope * tf[idx] + icpt
        keep = np.abs(xe - x[k]) <= max_mm
        x[idx[keep]] = xe[keep]
        if keep.any():
            ext[side] = float(np.max(np.abs(xe[keep] - x[k])))
    return x, (ext[0], ext[1])


def flat_segment_from_positions(
    feature_start_mm: float, *, window: tuple[float, float], contact_half_width_mm: float = 8.0
) -> tuple[float, float]:
    """Default flat segment, in finger-centre positions (mm).

    From the window's left end to ``feature_start_mm - contact_half_width_mm``: while the
    finger centre is left of that point its contact (``2 * contact_half_width_mm`` wide)
    lies entirely on the flat ground before the feature.

    Returns
    -------
    (x_lo, x_hi) : tuple of float
        mm; ``x_hi <= x_lo`` when the window leaves no flat segment (the caller reports it).
    """
    return float(window[0]), float(feature_start_mm) - float(contact_half_width_mm)


def flat_mask_from_regions(t, t_frames, regions, feature_start_mm: float, *, return_known: bool = False):
    """Samples whose nearest frame has contact entirely on the flat ground before the feature.

    Parameters
    ----------
    t : (n,) array_like
        Sample times in s.
    t_frames : (m,) array_like
        Frame times in s, increasing.
    regions : (m, k, 2) array_like
        Contact regions per frame in mm (``fingerfriction.regions`` format).
    feature_start_mm : float
        Left end of the feature in mm.

    return_known : bool
        Also return where the nearest frame has any contact region at all.

    Returns
    -------
    (n,) ndarray of bool
        True where the nearest frame has at least one contact region and every region ends
        (``b_i``) before ``feature_start_mm``.
    known : (n,) ndarray of bool
        With ``return_known``: True where the nearest frame has contact regions.
    """
    r = as_regions(regions, name="regions")
    tf = np.asarray(t_frames, dtype=np.float64)
    if r.shape[0] != tf.size:
        raise ValueError(f"regions has {r.shape[0]} frames but t_frames has {tf.size} times")
    b = r[..., 1]
    has = np.any(np.isfinite(b), axis=1)
    flat_frame = has & np.all(np.where(np.isfinite(b), b < feature_start_mm, True), axis=1)
    t = np.asarray(t, dtype=np.float64)
    k = np.clip(np.searchsorted(tf, t), 1, tf.size - 1)
    nearest = np.where(np.abs(t - tf[k - 1]) <= np.abs(tf[k] - t), k - 1, k)
    inside = (t >= tf[0] - 0.5 * (tf[1] - tf[0])) & (t <= tf[-1] + 0.5 * (tf[-1] - tf[-2]))
    if return_known:
        return flat_frame[nearest] & inside, has[nearest] & inside
    return flat_frame[nearest] & inside


@dataclass(frozen=True)
class PositionResampling:
    """Result of :func:`resample_to_positions`.

    Attributes
    ----------
    x : (L,) ndarray
        Bin centres in mm.
    values : (L,) ndarray
        Per bin, the mean of its samples placed at their mean position, linearly
        interpolated onto the bin centres (empty bins are filled by the same interpolation).
    counts : (L,) ndarray of int
        Samples averaged in each bin (0: filled).
    n_filled : int
        Number of empty bins filled.
    max_fill_mm : float
        Longest run of consecutive filled bins, in mm.
    max_reversal_mm : float
        Largest backward excursion of the finger (running maximum minus position) among
        the samples used, in mm; 0 for a monotonic slide.
    """

    x: np.ndarray
    values: np.ndarray
    counts: np.ndarray
    n_filled: int
    max_fill_mm: float
    max_reversal_mm: float


def resample_to_positions(
    x, y, *, window: tuple[float, float], resolution: float = 0.01
) -> PositionResampling:
    """Associate samples with positions and average them per position bin.

    Parameters
    ----------
    x : (n,) array_like
        Finger position in mm at each sample (NaN: unknown, ignored).
    y : (n,) array_like
        Values (force in N) at each sample.
    window : (float, float)
        First and last bin centre in mm.
    resolution : float
        Bin width in mm. Default 0.01.

    Returns
    -------
    PositionResampling

    Raises
    ------
    ValueError
        If no sample falls in the window, or a bin at either end of the window is empty
        (the finger does not span the window: nothing to interpolate from).
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if x.shape != y.shape or x.ndim != 1:
        raise ValueError(f"x and y must be 1-D arrays of the same length, got {x.shape} and {y.shape}")
    res = _positive("resolution", resolution, "mm")
    lo, hi = float(window[0]), float(window[1])
    n_bins = int(round((hi - lo) / res)) + 1
    grid = lo + res * np.arange(n_bins)
    ok = np.isfinite(x) & np.isfinite(y)
    if not ok.any():
        raise ValueError("no sample has both a finite finger position and a finite value")
    x_min, x_max = float(x[ok].min()), float(x[ok].max())
    if x_min > lo + res / 2 or x_max < hi - res / 2:
        raise ValueError(
            f"the finger positions cover [{max(x_min, lo):.3f}, {min(x_max, hi):.3f}] mm of the window "
            f"[{lo:g}, {hi:g}] mm; the whole window must be traversed"
        )
    # bins on the window extended by a margin, so that an empty bin at either end of the
    # window is interpolated from samples just outside it
    margin = 50
    idx = np.rint((x - lo) / res) + margin
    use = ok & (idx >= 0) & (idx < n_bins + 2 * margin)
    idx = idx[use].astype(np.intp)
    counts_ext = np.bincount(idx, minlength=n_bins + 2 * margin)
    sums = np.bincount(idx, weights=y[use], minlength=n_bins + 2 * margin)
    sums_x = np.bincount(idx, weights=x[use], minlength=n_bins + 2 * margin)
    have = counts_ext > 0
    # each bin's mean force sits at the bin's mean sample position (not exactly its centre);
    # interpolating those points onto the centres makes the result exact for a force linear
    # in x and reduces to linear interpolation when bins hold one sample or none.
    x_mean = sums_x[have] / counts_ext[have]
    y_mean = sums[have] / counts_ext[have]
    values = np.interp(grid, x_mean, y_mean)
    counts = counts_ext[margin : margin + n_bins]
    filled = counts == 0
    # longest run of filled bins
    max_run = 0
    if filled.any():
        d = np.diff(np.concatenate(([0], filled.astype(np.int8), [0])))
        starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
        max_run = int(np.max(ends - starts))
    xs = x[ok & (x >= lo - res / 2) & (x <= hi + res / 2)]
    reversal = float(np.max(np.maximum.accumulate(xs) - xs)) if xs.size else 0.0
    return PositionResampling(
        x=grid,
        values=values,
        counts=counts,
        n_filled=int(filled.sum()),
        max_fill_mm=max_run * res,
        max_reversal_mm=reversal,
    )
