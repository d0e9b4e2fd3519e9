"""The tables of an analysed trial: the per-frame table (``frames.parquet``,
:func:`frames_table`) and the per-position table (``forces.parquet``), their contact-region
columns read back as an array (:func:`regions_from_table`), and Parquet written atomically.
The results folder that holds them is :mod:`fingerfriction.study.store`.

Per-frame table (``frames.parquet``): ``frame`` (int, index in the video), ``t_s``
(s, common clock), ``x_mm`` (finger position x(t), NaN where unknown), ``n_regions``
(int), ``a1, b1, a2, b2, ...`` (contact regions C_i in mm, NaN-padded; as many pairs
as the trial's largest count, at least one), ``clipped`` (bool, a region ends at the
edge of the camera's field of view, so its length is a lower bound), ``flag`` (str,
empty when the frame is good, else the reason it was flagged), ``x_source`` (str, the
estimator that gave x: ``chord``, ``left-edge``, ``right-edge``, ``cf-centroid``; empty
without a position; absent in results written before it was recorded).

Per-position table (``forces.parquet``): ``x_mm`` (finger position on the 0.01 mm grid),
``F_T_N`` and ``F_N_N`` (tangential and normal force in N, drift-corrected over the flat
segment: the paper's footing), ``F_T_abs_N`` and ``F_N_abs_N`` (the same forces on the
absolute footing: drift removed on the unloaded rests only, flat-ground level ``mu F_N``
kept; NaN when the trial has no absolute level, see ``status.json`` ``info.forces.absolute``),
``n_samples`` (force samples averaged into the bin; 0 = interpolated).
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import pandas as pd

from .._atomic import atomic_write
from ..regions import as_regions, region_columns, regions_from_columns

__all__ = ["frames_table", "with_regions", "regions_from_table", "atomic_write_parquet", "clipped_on_grid"]


def atomic_write_parquet(path: str | os.PathLike, df: pd.DataFrame) -> None:
    """Write a DataFrame as Parquet (pyarrow) to ``path`` atomically."""
    atomic_write(path, lambda tmp: df.to_parquet(tmp, engine="pyarrow", index=False))


def frames_table(
    t_s: np.ndarray,
    x_mm: np.ndarray,
    regions,
    flags=None,
    *,
    frame: np.ndarray | None = None,
    clipped: np.ndarray | None = None,
    x_source=None,
) -> pd.DataFrame:
    """Build the per-frame table from arrays.

    Parameters
    ----------
    t_s : (n_frames,) ndarray
        Frame times in s on the trial's common clock.
    x_mm : (n_frames,) ndarray
        Finger position x(t) in mm (NaN where unknown).
    regions : (n_frames, n_max, 2) array_like
        Contact regions in mm (:mod:`fingerfriction.regions`).
    flags : (n_frames,) sequence of str, optional
        Empty string for a good frame, else the reason it was flagged.
    frame : (n_frames,) int ndarray, optional
        Frame indices; default ``0..n_frames-1``.
    clipped : (n_frames,) bool ndarray, optional
        A contact region ends at the edge of the field of view (default: none).
    x_source : (n_frames,) sequence of str, optional
        Which estimator gave each frame's x(t) (``chord``, ``left-edge``, ``right-edge``,
        ``cf-centroid``; empty without a position); the column is left out when None.

    Returns
    -------
    pandas.DataFrame
        Columns ``frame, t_s, x_mm, n_regions, a1, b1, ..., clipped, flag`` (and
        ``x_source`` when given).
    """
    t_s = np.asarray(t_s, dtype=float).ravel()
    x_mm = np.asarray(x_mm, dtype=float).ravel()
    n = t_s.size
    if x_mm.size != n:
        raise ValueError(f"x_mm has {x_mm.size} frames but t_s has {n}")
    reg = as_regions(regions) if n else np.full((0, 1, 2), np.nan)
    if reg.shape[0] != n:
        raise ValueError(f"regions has {reg.shape[0]} frames but t_s has {n}")
    if frame is None:
        frame = np.arange(n)
    frame = np.asarray(frame, dtype=np.int64).ravel()
    if frame.size != n:
        raise ValueError(f"frame has {frame.size} entries but t_s has {n}")
    if flags is None:
        flags = [""] * n
    flags = ["" if f is None else str(f) for f in flags]
    if len(flags) != n:
        raise ValueError(f"flags has {len(flags)} entries but t_s has {n}")
    cols: dict[str, Any] = {"frame": frame, "t_s": t_s, "x_mm": x_mm, **_region_part(reg)}
    clipped = np.zeros(n, bool) if clipped is None else np.asarray(clipped, dtype=bool).ravel()
    if clipped.size != n:
        raise ValueError(f"clipped has {clipped.size} entries but t_s has {n}")
    cols["clipped"] = clipped
    cols["flag"] = pd.array(flags, dtype="string")
    if x_source is not None:
        src = ["" if s is None else str(s) for s in x_source]
        if len(src) != n:
            raise ValueError(f"x_source has {len(src)} entries but t_s has {n}")
        cols["x_source"] = pd.array(src, dtype="string")
    return pd.DataFrame(cols)


def _region_part(reg: np.ndarray) -> dict[str, np.ndarray]:
    """``n_regions`` and ``a1, b1, ...`` of regions ``(n_frames, n_max, 2)`` (one NaN pair
    for no frame)."""
    cols = {"n_regions": np.sum(~np.isnan(reg[..., 0]), axis=1).astype(np.int64)}
    cols.update(region_columns(reg) if reg.shape[0] else {"a1": reg[:, 0, 0], "b1": reg[:, 0, 1]})
    return cols


def with_regions(frames: pd.DataFrame, regions) -> pd.DataFrame:
    """The per-frame table as the store writes it: the columns of ``frames`` with its
    ``n_regions, a1, b1, ...`` made from ``regions`` (the one place an analysed trial's
    regions are flattened into the table), after ``x_mm`` as in :func:`frames_table`.

    Parameters
    ----------
    frames : pandas.DataFrame
        A per-frame table (its region columns, if any, are replaced).
    regions : (n_frames, n_max, 2) array_like
        Contact regions in mm.

    Raises
    ------
    ValueError
        Regions of another number of frames, or invalid regions
        (:func:`~fingerfriction.regions.as_regions`).
    """
    n = len(frames)
    reg = as_regions(regions) if n else np.full((0, 1, 2), np.nan)
    if reg.shape[0] != n:
        raise ValueError(f"regions has {reg.shape[0]} frames but the per-frame table has {n}")
    old = {"n_regions", *(c for c in frames.columns if _is_region_column(c))}
    keep = [c for c in frames.columns if c not in old]
    at = keep.index("x_mm") + 1 if "x_mm" in keep else len(keep)
    col = {c: frames[c].reset_index(drop=True) for c in keep}
    return pd.DataFrame({**{c: col[c] for c in keep[:at]}, **_region_part(reg),
                         **{c: col[c] for c in keep[at:]}})


def _is_region_column(name) -> bool:
    return isinstance(name, str) and len(name) > 1 and name[0] in "ab" and name[1:].isdigit()


def regions_from_table(df: pd.DataFrame) -> np.ndarray:
    """Contact regions ``(n_frames, n_max, 2)`` in mm from a per-frame table
    (:func:`~fingerfriction.regions.regions_from_columns`)."""
    return regions_from_columns(df)


def clipped_on_grid(frames: pd.DataFrame, x: np.ndarray) -> np.ndarray | None:
    """The frames' ``clipped`` flag at each grid position: that of the tracked frame whose
    x(t) is nearest, as :func:`~fingerfriction.regions.regions_on_grid` takes its regions
    (None when the frames have no such column or fewer than two tracked frames)."""
    if "clipped" not in frames.columns:
        return None
    xf = frames["x_mm"].to_numpy(float)
    ok = np.isfinite(xf)
    if ok.sum() < 2:
        return None
    order = np.argsort(xf[ok], kind="stable")
    xs, cl = xf[ok][order], frames["clipped"].to_numpy(bool)[ok][order]
    j = np.clip(np.searchsorted(xs, x), 1, xs.size - 1)
    nearest = np.where(np.abs(x - xs[j - 1]) <= np.abs(xs[j] - x), j - 1, j)
    return cl[nearest]
