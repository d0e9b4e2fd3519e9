"""Contact regions C_i: the common currency of the video analysis, simulator and model.

A frame's contact is a set of disconnected intervals ``[a_i, b_i]`` of surface position
in mm (the paper's C_i, "Modeling frictional forces"). Over many frames they are stored
as one padded array:

``regions : (n_frames, n_max, 2) float ndarray``
    ``regions[t, i] = (a_i, b_i)`` in mm with ``a_i <= b_i``; intervals of a frame are
    sorted by ``a`` and do not overlap; unused slots are ``(nan, nan)`` and come last.
    A frame with no contact has only NaN slots.

:func:`as_regions` converts the other accepted forms (one frame as a list of pairs, a
list of frames) to this array and validates it; every public function that takes
regions calls it, so bad input fails at the door with the frame and slot named.
:func:`regions_on_grid` maps per-frame regions onto finger positions (the force grid).
In a table (the results store's ``frames.parquet``) they are the columns ``a1, b1, a2, b2,
...``: :func:`region_columns` and :func:`regions_from_columns`, the one place that names them.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

__all__ = [
    "as_regions", "regions_from_mask", "region_lengths", "n_regions", "inset_regions", "regions_on_grid",
    "region_columns", "regions_from_columns",
]


def as_regions(regions, *, name: str = "regions", allow_touching: bool = True) -> np.ndarray:
    """Validate contact regions and return them as a ``(n_frames, n_max, 2)`` array.

    Parameters
    ----------
    regions : array_like or sequence
        ``(n_frames, n_max, 2)`` array with NaN padding; or ``(n_max, 2)`` / a list of
        ``(a, b)`` pairs for a single frame (returned with ``n_frames = 1``); or a list of
        frames, each a list of pairs (ragged allowed).
    name : str
        Argument name used in error messages.
    allow_touching : bool
        Whether intervals of one frame may share an end point (``b_i == a_{i+1}``).

    Returns
    -------
    (n_frames, n_max, 2) ndarray of float
        ``n_max >= 1``.

    Raises
    ------
    ValueError
        For an inverted interval (``a > b``), an infinite end point, a half-NaN pair,
        overlapping or unsorted intervals, naming the frame, the slot and the values.
    """
    arr = _to_array(regions, name)
    nan_a = np.isnan(arr[..., 0])
    nan_b = np.isnan(arr[..., 1])
    if np.any(nan_a != nan_b):
        t, i = np.argwhere(nan_a != nan_b)[0]
        raise ValueError(
            f"{name}: frame {t}, region {i} has one NaN end point {_pair_repr(arr[t, i])}; "
            "both ends must be numbers (mm) or both NaN (unused slot)"
        )
    valid = ~nan_a
    if np.any(np.isinf(arr[valid])):
        t, i = np.argwhere(valid & np.isinf(arr).any(-1))[0]
        raise ValueError(f"{name}: frame {t}, region {i} has an infinite end point {_pair_repr(arr[t, i])}")
    inverted = valid & (arr[..., 0] > arr[..., 1])
    if inverted.any():
        t, i = np.argwhere(inverted)[0]
        a, b = (float(v) for v in arr[t, i])
        raise ValueError(
            f"{name}: frame {t}, region {i} is inverted: [a, b] = [{a!r}, {b!r}] mm; "
            "each region must have a <= b"
        )
    # NaN slots must come last: a valid slot after a NaN slot is a layout error.
    if arr.shape[1] > 1:
        gap = (~valid[:, :-1]) & valid[:, 1:]
        if gap.any():
            t = int(np.argwhere(gap)[0][0])
            raise ValueError(f"{name}: frame {t} has a valid region after an unused (NaN) slot")
        both = valid[:, :-1] & valid[:, 1:]
        nxt_a = arr[:, 1:, 0]
        cur_b = arr[:, :-1, 1]
        bad = both & ((nxt_a < cur_b) if allow_touching else (nxt_a <= cur_b))
        if bad.any():
            t, i = np.argwhere(bad)[0]
            raise ValueError(
                f"{name}: frame {t}, regions {i} {_pair_repr(arr[t, i])} and {i + 1} "
                f"{_pair_repr(arr[t, i + 1])} overlap or are not sorted by position"
            )
    return arr


def _pair_repr(pair) -> str:
    """``(a, b)`` with plain floats (numpy 2 would print ``np.float64(...)``)."""
    return repr(tuple(float(v) for v in pair))


def _to_array(regions, name: str) -> np.ndarray:
    if isinstance(regions, np.ndarray):
        arr = regions.astype(float, copy=False)
    elif isinstance(regions, Sequence) and not isinstance(regions, (str, bytes)):
        if len(regions) == 0:
            return np.full((1, 1, 2), np.nan)
        first = regions[0]
        single_frame = _is_pair(first)
        frames = [regions] if single_frame else list(regions)
        n_max = max(1, max((len(f) for f in frames), default=0))
        arr = np.full((len(frames), n_max, 2), np.nan)
        for t, f in enumerate(frames):
            if not isinstance(f, (Sequence, np.ndarray)) or isinstance(f, (str, bytes)):
                raise TypeError(f"{name}: frame {t} must be a list of (a, b) pairs, got {f!r}")
            for i, pair in enumerate(f):
                if not _is_pair(pair):
                    raise ValueError(
                        f"{name}: frame {t}, region {i} must be an (a, b) pair in mm, got {pair!r}"
                    )
                arr[t, i] = (float(pair[0]), float(pair[1]))
    else:
        raise TypeError(f"{name} must be an array or a list of (a, b) pairs, got {type(regions).__name__}")
    if arr.ndim == 2 and arr.shape[-1] == 2:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[-1] != 2:
        raise ValueError(f"{name} must have shape (n_frames, n_max, 2), got {arr.shape}")
    if arr.shape[1] == 0:
        arr = np.full((arr.shape[0], 1, 2), np.nan)
    return arr


def _is_pair(obj) -> bool:
    if isinstance(obj, np.ndarray):
        return obj.shape == (2,)
    if isinstance(obj, Sequence) and not isinstance(obj, (str, bytes)) and len(obj) == 2:
        return all(isinstance(v, (int, float, np.integer, np.floating)) for v in obj)
    return False


def region_lengths(regions) -> np.ndarray:
    """Lengths ``L_i = b_i - a_i`` in mm, ``(n_frames, n_max)``, NaN for unused slots."""
    arr = as_regions(regions)
    return arr[..., 1] - arr[..., 0]


def n_regions(regions) -> np.ndarray:
    """Number of contact regions per frame, ``(n_frames,)`` int."""
    arr = as_regions(regions)
    return np.sum(~np.isnan(arr[..., 0]), axis=1)


def inset_regions(regions, inset: float) -> np.ndarray:
    """Every region shortened by ``inset`` mm at both ends; shorter ones are dropped.

    ``[a_i, b_i] -> [a_i + inset, b_i - inset]`` where ``b_i - a_i > 2 inset``; a region
    that is not longer than ``2 inset`` disappears. The remaining regions of each frame
    keep their order and come first (NaN padding after them), so the result is a valid
    regions array of the same shape. ``inset = 0`` returns a copy.

    This turns the paper's geometric contact (finger within 3 px, about 70 um, of the
    surface) into an estimate of the load-bearing contact: under a soft finger the gap
    opens slowly at a contact edge, so each geometric region extends a strip of a few
    tenths of a millimetre beyond where the pressure ends (the mechanical contact, pressure
    > 0, is narrower than the geometric one; see the load-consistent model in
    :mod:`fingerfriction.model`).

    Parameters
    ----------
    regions : (n_frames, n_max, 2) array_like
        Contact regions in mm.
    inset : float
        Inset in mm at each end (>= 0).

    Returns
    -------
    (n_frames, n_max, 2) ndarray
        The inset regions in mm.
    """
    arr = as_regions(regions)
    d = float(inset)
    if not (np.isfinite(d) and d >= 0):
        raise ValueError(f"inset must be a finite length >= 0 in mm, got {inset!r}")
    out = arr.copy()
    if d == 0:
        return out
    out[..., 0] += d
    out[..., 1] -= d
    gone = ~(out[..., 1] > out[..., 0])  # also True for the NaN slots
    out[gone] = np.nan
    # Compact each frame: surviving regions first, in their order (a stable sort on "gone").
    order = np.argsort(gone, axis=1, kind="stable")
    return np.take_along_axis(out, order[..., None], axis=1)


def regions_from_mask(x: np.ndarray, mask: np.ndarray, *, n_max: int | None = None) -> np.ndarray:
    """Contact regions from a boolean contact mask sampled at grid positions.

    Parameters
    ----------
    x : (n,) ndarray
        Increasing, uniformly spaced positions in mm (cell centres).
    mask : (n,) or (n_frames, n) bool ndarray
        True where in contact.
    n_max : int, optional
        Number of slots; by default the largest count found. Extra regions beyond
        ``n_max`` raise ``ValueError`` rather than being dropped silently.

    Returns
    -------
    (n_frames, n_max, 2) ndarray
        Each run of True cells ``[i0, i1]`` becomes ``[x[i0] - dx/2, x[i1] + dx/2]``.
    """
    x = np.asarray(x, dtype=float)
    m = np.atleast_2d(np.asarray(mask, dtype=bool))
    if m.shape[-1] != x.size:
        raise ValueError(f"mask has {m.shape[-1]} columns but x has {x.size} positions")
    dx = float(x[1] - x[0]) if x.size > 1 else 0.0
    pad = np.zeros((m.shape[0], 1), dtype=bool)
    d = np.diff(np.concatenate([pad, m, pad], axis=1).astype(np.int8), axis=1)
    starts_t, starts_i = np.nonzero(d == 1)
    _, ends_i = np.nonzero(d == -1)
    counts = np.bincount(starts_t, minlength=m.shape[0])
    need = int(counts.max(initial=0))
    k = max(need, 1) if n_max is None else n_max
    if need > k:
        raise ValueError(f"a frame has {need} contact regions, more than n_max={n_max}")
    out = np.full((m.shape[0], k, 2), np.nan)
    slot = np.arange(starts_t.size) - np.repeat(np.cumsum(counts) - counts, counts)
    out[starts_t, slot, 0] = x[starts_i] - dx / 2
    out[starts_t, slot, 1] = x[ends_i - 1] + dx / 2
    return out


def regions_on_grid(x_frames: np.ndarray, regions: np.ndarray, x_grid: np.ndarray, *,
                    return_translated: bool = False):
    """Contact regions at each grid position: those of the frame where the finger was there.

    Parameters
    ----------
    x_frames : (n_frames,) ndarray
        Finger position x(t) of each frame in mm (NaN frames are ignored).
    regions : (n_frames, n_max, 2) ndarray
        Contact regions of each frame in mm.
    x_grid : (n,) ndarray
        Positions in mm (the force grid).
    return_translated : bool
        Also return which positions got translated regions (see Notes).

    Returns
    -------
    (n, n_max, 2) ndarray
        For each grid position inside the tracked span, the regions of the frame whose
        x(t) is nearest to it (frames sorted by x, as the finger slides left to right).
    translated : (n,) bool ndarray
        Only with ``return_translated``.

    Raises
    ------
    ValueError
        If fewer than two frames have a finger position.

    Notes
    -----
    A grid position outside the span of tracked frames (the force stage may extend x(t)
    beyond it, see ``extrapolate_mm`` of :class:`fingerfriction.forces.ForceProcessingParams`)
    gets the regions of the nearest tracked end frame *translated with the finger*
    (``+ x_grid - x_end``). On flat ground, far from the feature, the contact moves
    rigidly with the finger and this is exact; nearer the feature it is an approximation,
    which is why those positions are reported (``translated``).
    """
    x = np.asarray(x_frames, dtype=float)
    reg = np.asarray(regions, dtype=float)
    g = np.asarray(x_grid, dtype=float)
    ok = np.isfinite(x)
    if ok.sum() < 2:
        raise ValueError("need at least two frames with a finger position to map regions onto positions")
    idx = np.flatnonzero(ok)
    order = idx[np.argsort(x[idx], kind="stable")]
    xs = x[order]
    j = np.clip(np.searchsorted(xs, g), 1, xs.size - 1)
    nearer_left = (g - xs[j - 1]) <= (xs[j] - g)
    pick = np.where(nearer_left, j - 1, j)
    out = reg[order[pick]].copy()
    translated = (g < xs[0]) | (g > xs[-1])
    shift = np.where(g < xs[0], g - xs[0], np.where(g > xs[-1], g - xs[-1], 0.0))
    out += shift[:, None, None]  # NaN slots stay NaN
    return (out, translated) if return_translated else out


def region_columns(regions) -> dict[str, np.ndarray]:
    """Regions ``(n_frames, n_max, 2)`` as table columns ``{"a1": ..., "b1": ..., ...}`` in mm
    (NaN-padded; as many pairs as ``n_max``)."""
    reg = as_regions(regions)
    cols: dict[str, np.ndarray] = {}
    for i in range(reg.shape[1]):
        cols[f"a{i + 1}"] = reg[:, i, 0]
        cols[f"b{i + 1}"] = reg[:, i, 1]
    return cols


def regions_from_columns(table, *, empty_ok: bool = False) -> np.ndarray:
    """Regions ``(n_frames, n_max, 2)`` in mm from the columns ``a1, b1, ...`` of a table
    (a pandas DataFrame, or a mapping of column name to array) written by
    :func:`region_columns`.

    Raises
    ------
    ValueError
        A table without the columns ``a1, b1`` (unless ``empty_ok``: one NaN slot per row).
    """
    names = list(table.columns) if hasattr(table, "columns") else list(table)
    k = 0
    while f"a{k + 1}" in names and f"b{k + 1}" in names:
        k += 1
    n = len(table[names[0]]) if names else 0
    if k == 0:
        if empty_ok:
            return np.full((n, 1, 2), np.nan)
        raise ValueError("per-frame table has no region columns a1, b1")
    out = np.empty((n, k, 2))
    for i in range(k):
        out[:, i, 0] = np.asarray(table[f"a{i + 1}"], dtype=float)
        out[:, i, 1] = np.asarray(table[f"b{i + 1}"], dtype=float)
    return out
