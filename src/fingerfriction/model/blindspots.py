"""Contact occupancy and tactile blind spots (Fig. 3 of Janko et al. 2018).

The *occupancy* of a surface location is the proportion of frames in which it lies inside
a contact region; Fig. 3 shows it normalised so that the most-contacted location is 1.
A *tactile blind spot* is a maximal interval, inside the span the finger actually swept,
that was never in contact in any frame.

Blind-spot intervals and widths are computed exactly from the union of the contact
intervals (no binning), so hand-built region sequences give exact widths; the occupancy
map is binned (0.01 mm by default) with each bin's exact covered fraction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..regions import as_regions

__all__ = ["Occupancy", "BlindSpots", "occupancy", "blind_spots", "contact_union"]


@dataclass(frozen=True)
class Occupancy:
    """Binned contact occupancy.

    Attributes
    ----------
    edges : (n_bins + 1,) ndarray
        Bin edges in mm.
    fraction : (n_bins,) ndarray
        Mean over frames of the fraction of each bin covered by contact (0..1).
    normalized : (n_bins,) ndarray
        ``fraction / fraction.max()`` (Fig. 3's scale: 1 = most contacted, 0 = never).
    span : tuple of float
        ``(lo, hi)`` in mm: the swept span the map covers.
    n_frames : int
        Number of frames.
    """

    edges: np.ndarray
    fraction: np.ndarray
    normalized: np.ndarray
    span: tuple[float, float]
    n_frames: int

    @property
    def centers(self) -> np.ndarray:
        """Bin centres in mm, ``(n_bins,)``."""
        return 0.5 * (self.edges[1:] + self.edges[:-1])


@dataclass(frozen=True)
class BlindSpots:
    """Never-contacted intervals inside the swept span.

    Attributes
    ----------
    intervals : (n, 2) ndarray
        ``[start, end]`` of each blind spot in mm, sorted by position.
    span : tuple of float
        The swept span ``(lo, hi)`` in mm within which blind spots were sought.
    """

    intervals: np.ndarray
    span: tuple[float, float]

    @property
    def widths(self) -> np.ndarray:
        """Width of each blind spot in mm, ``(n,)``."""
        return self.intervals[:, 1] - self.intervals[:, 0]

    def __len__(self) -> int:
        return int(self.intervals.shape[0])

    def as_table(self) -> list[dict]:
        """Rows ``{'start_mm', 'end_mm', 'width_mm'}`` for reports."""
        return [
            {"start_mm": float(a), "end_mm": float(b), "width_mm": float(b - a)}
            for a, b in self.intervals
        ]


def _valid_intervals(regions) -> np.ndarray:
    arr = as_regions(regions)
    flat = arr.reshape(-1, 2)
    return flat[~np.isnan(flat[:, 0])]


def contact_union(regions) -> np.ndarray:
    """Union of all contact intervals over all frames, ``(n, 2)`` sorted, merged (mm).

    Intervals that touch (``b_k == a_{k+1}``) are merged.
    """
    iv = _valid_intervals(regions)
    if iv.size == 0:
        return np.empty((0, 2))
    iv = iv[np.argsort(iv[:, 0], kind="stable")]
    # A new merged block starts where an interval begins after every earlier one ended.
    run_end = np.maximum.accumulate(iv[:, 1])
    starts = np.concatenate([[True], iv[1:, 0] > run_end[:-1]])
    idx = np.flatnonzero(starts)
    ends = np.append(idx[1:], iv.shape[0]) - 1
    return np.column_stack([iv[idx, 0], run_end[ends]])


def _resolve_span(iv: np.ndarray, span) -> tuple[float, float]:
    if span is None:
        if iv.size == 0:
            raise ValueError("regions contain no contact at all: the swept span is undefined")
        return float(iv[:, 0].min()), float(iv[:, 1].max())
    try:
        lo, hi = (float(v) for v in span)
    except (TypeError, ValueError):
        raise ValueError(f"span must be a pair (lo, hi) in mm, got {span!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
        raise ValueError(f"span must be finite with lo < hi (mm), got {span!r}")
    return lo, hi


def blind_spots(regions, *, span=None, min_width: float = 0.0) -> BlindSpots:
    """Tactile blind spots: maximal never-contacted intervals inside the swept span.

    Parameters
    ----------
    regions : (n_frames, n_max, 2) array_like
        Contact regions per frame in mm (:mod:`fingerfriction.regions`).
    span : (float, float), optional
        Span in mm to search. By default the span the finger actually swept: from the
        leftmost to the rightmost contacted position over all frames. Gaps that touch the
        ends of a given span are not blind spots unless contact was seen beyond them.
    min_width : float, optional
        Ignore gaps narrower than this (mm); default 0 keeps every gap.

    Returns
    -------
    BlindSpots
    """
    if not (math.isfinite(min_width) and min_width >= 0):
        raise ValueError(f"min_width must be >= 0 mm, got {min_width!r}")
    union = contact_union(regions)
    lo, hi = _resolve_span(union, span)
    if union.size:
        # Restrict to the swept part of the span: between first and last contacted point.
        lo = max(lo, float(union[0, 0]))
        hi = min(hi, float(union[-1, 1]))
    gaps = np.column_stack([union[:-1, 1], union[1:, 0]]) if union.shape[0] > 1 else np.empty((0, 2))
    if gaps.size:
        gaps = np.column_stack([np.maximum(gaps[:, 0], lo), np.minimum(gaps[:, 1], hi)])
        w = gaps[:, 1] - gaps[:, 0]
        gaps = gaps[(w > 0) & (w >= min_width)]
    return BlindSpots(intervals=gaps.reshape(-1, 2), span=(lo, hi))


def occupancy(regions, *, bin_width: float = 0.01, span=None) -> Occupancy:
    """Proportion of frames each surface location is in contact (Fig. 3).

    Parameters
    ----------
    regions : (n_frames, n_max, 2) array_like
        Contact regions per frame in mm.
    bin_width : float, optional
        Bin width in mm (default 0.01 mm, the paper's spatial resolution).
    span : (float, float), optional
        Span in mm; default: the swept span (leftmost to rightmost contact).

    Returns
    -------
    Occupancy
    """
    if not (math.isfinite(bin_width) and bin_width > 0):
        raise ValueError(f"bin_width must be a positive length in mm, got {bin_width!r}")
    arr = as_regions(regions)
    iv = arr.reshape(-1, 2)
    iv = iv[~np.isnan(iv[:, 0])]
    lo, hi = _resolve_span(iv, span)
    n_bins = max(int(math.ceil((hi - lo) / bin_width - 1e-9)), 1)
    edges = lo + bin_width * np.arange(n_bins + 1)
    # Covered length left of each edge, summed over intervals:
    # G(e) = sum_k (e - a_k)_+ - (e - b_k)_+, computed with sorted prefix sums.
    G = _ramp_sum(edges, iv[:, 0]) - _ramp_sum(edges, iv[:, 1])
    covered = np.diff(G) / bin_width
    fraction = np.clip(covered / arr.shape[0], 0.0, 1.0)
    peak = fraction.max(initial=0.0)
    normalized = fraction / peak if peak > 0 else fraction.copy()
    return Occupancy(edges=edges, fraction=fraction, normalized=normalized, span=(lo, hi),
                     n_frames=int(arr.shape[0]))


def _ramp_sum(e: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """``sum_k max(e - pts_k, 0)`` for every ``e``, in O((n + m) log m)."""
    p = np.sort(pts)
    csum = np.concatenate([[0.0], np.cumsum(p)])
    k = np.searchsorted(p, e, side="right")
    return k * e - csum[k]
