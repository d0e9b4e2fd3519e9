"""Checks of a trial's force input, each returning its findings as
:class:`~fingerfriction.flags.Flag` objects (the package's one flag type):
NaN runs and clipping of the channels, the finger's coverage of the window, the record's
coverage of the slide, the flat segment, and the resampling onto positions.

A flag is a ``warning`` (the trial is used, the finding is reported) or an ``error`` (the
trial's forces must not be used; :func:`~fingerfriction.forces.process_forces` raises
:class:`ForceDataError` or returns an unsuccessful profile).
"""

from __future__ import annotations

import numpy as np

from ..flags import Flag
from .params import ForceProcessingParams
from .readers import ForceRecord

__all__ = [
    "ForceDataError",
    "Flag",
    "nan_runs",
    "find_clipping",
    "check_channels",
    "check_window_covered",
    "check_record_covers_slide",
    "check_flat_segment",
    "check_flat_rest",
    "check_resampling",
]


class ForceDataError(ValueError):
    """Force data that cannot be turned into a trustworthy ``F_T(x)``."""


def nan_runs(x) -> list[tuple[int, int]]:
    """Runs of NaN in a 1-D signal, as ``(start, length)`` pairs in samples."""
    bad = ~np.isfinite(np.asarray(x, dtype=np.float64))
    if not bad.any():
        return []
    d = np.diff(np.concatenate(([0], bad.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    return [(int(s), int(e - s)) for s, e in zip(starts, ends, strict=True)]


def _fill_nan(x: np.ndarray) -> np.ndarray:
    bad = ~np.isfinite(x)
    if not bad.any():
        return x
    out = x.copy()
    i = np.arange(x.size)
    out[bad] = np.interp(i[bad], i[~bad], x[~bad])
    return out


def find_clipping(x, *, run: int = 10, full_scale: float | None = None) -> list[tuple[int, int, float]]:
    """Clipped stretches of one channel: flat tops at its extreme values, or full scale.

    Parameters
    ----------
    x : (n,) array_like
        One channel in N (NaN ignored).
    run : int
        Minimum number of consecutive identical samples at the channel's maximum or
        minimum to call a flat top. Default 10. A noisy, unclipped signal does not sit on
        its extreme value for several consecutive samples.
    full_scale : float, optional
        Acquisition full scale in N; every sample with ``|x| >= full_scale`` counts,
        whatever the run length.

    Returns
    -------
    list of (start, length, value)
        Clipped runs in samples with the value held, N.
    """
    x = np.asarray(x, dtype=np.float64)
    fin = np.isfinite(x)
    if not fin.any():
        return []
    hits = np.zeros(x.size, bool)
    if full_scale is not None:
        hits |= fin & (np.abs(x) >= full_scale)
    flat = np.zeros(x.size, bool)
    for extreme in (np.nanmax(x), np.nanmin(x)):
        flat |= fin & (x == extreme)
    out = []
    for mask, min_len in ((hits, 1), (flat & ~hits, run)):
        if not mask.any():
            continue
        d = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
        for s, e in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True):
            if e - s >= min_len:
                out.append((int(s), int(e - s), float(x[s])))
    return sorted(out)


def check_channels(record: ForceRecord, params: ForceProcessingParams, flags: list) -> tuple:
    """NaN runs (filled when short, else an error) and clipping (an error) of both channels.

    Returns
    -------
    (f1, f2) : ndarray
        The channels in N with the short NaN runs filled by linear interpolation.
    """
    fs = record.fs_hz
    out = []
    for name, x in (("F1", record.f1), ("F2", record.f2)):
        runs = nan_runs(x)
        if runs:
            longest = max(runs, key=lambda r: r[1])
            total = sum(r[1] for r in runs)
            s, n = longest
            if n > params.max_nan_gap or n >= x.size // 2:
                flags.append(
                    Flag(
                        "error",
                        "nan",
                        f"channel {name} has a run of {n} NaN samples starting at sample {s} "
                        f"(t={record.t0_s + s / fs:.4f} s, {n / fs * 1e3:.3g} ms); at most "
                        f"max_nan_gap={params.max_nan_gap} samples can be interpolated",
                    )
                )
            else:
                flags.append(
                    Flag(
                        "warning",
                        "nan-filled",
                        f"channel {name}: {total} NaN sample(s) in {len(runs)} run(s) of at most {n} "
                        "filled by linear interpolation",
                    )
                )
            x = _fill_nan(x) if np.isfinite(x).sum() >= 2 else x
        clips = find_clipping(x, run=params.clip_run, full_scale=params.full_scale_n)
        if clips:
            s, n, v = max(clips, key=lambda c: c[1])
            tot = sum(c[1] for c in clips)
            why = (
                f"at or beyond full_scale_n={params.full_scale_n:g} N"
                if params.full_scale_n is not None and abs(v) >= params.full_scale_n
                else f"held at the channel's extreme value for >= clip_run={params.clip_run} samples"
            )
            flags.append(
                Flag(
                    "error",
                    "clipped",
                    f"channel {name} is clipped: {tot} sample(s) in {len(clips)} run(s), the longest "
                    f"{n} samples at {v:.6g} N from sample {s} (t={record.t0_s + s / fs:.4f} s), {why}; "
                    "the saturated force is unknown, so this trial cannot be used",
                )
            )
        out.append(x)
    return out[0], out[1]


def check_window_covered(x_frames: np.ndarray, window: tuple[float, float], params: ForceProcessingParams,
                         flags: list) -> bool:
    """Whether the finger positions (mm, after any extrapolation) span the whole window; an
    error flag when they do not."""
    x_lo, x_hi = float(np.nanmin(x_frames)), float(np.nanmax(x_frames))
    if x_lo > window[0] or x_hi < window[1]:
        flags.append(
            Flag(
                "error",
                "window",
                f"the finger positions span [{x_lo:.3f}, {x_hi:.3f}] mm, which does not cover the "
                f"{params.window_mm:g} mm window [{window[0]:.3f}, {window[1]:.3f}] mm centred on the "
                f"feature (extrapolate_mm={params.extrapolate_mm:g} mm); the finger must traverse the "
                "whole window",
            )
        )
        return False
    return True


def check_record_covers_slide(record: ForceRecord, t_frames: np.ndarray, x_frames: np.ndarray,
                              window: tuple[float, float], flags: list) -> None:
    """An error flag when the force record does not cover the frames where the finger is in
    the window; a warning when the record and the video last very different times (a
    wrong ``fs_hz``)."""
    t = record.times()
    fs = record.fs_hz
    fin = np.isfinite(x_frames)
    in_win = fin & (x_frames >= window[0]) & (x_frames <= window[1])
    tw0, tw1 = float(t_frames[in_win][0]), float(t_frames[in_win][-1])
    if t[0] > tw0 or t[-1] < tw1:
        flags.append(
            Flag(
                "error",
                "coverage",
                f"the force record covers t=[{t[0]:.4f}, {t[-1]:.4f}] s ({record.n_samples} samples at "
                f"fs_hz={fs:g} Hz, t0_s={record.t0_s:g} s) but the finger crosses the window during "
                f"t=[{tw0:.4f}, {tw1:.4f}] s; check force.fs_hz, force.t0_s and video.t0_s",
            )
        )
    video_span = float(t_frames[-1] - t_frames[0])
    if video_span > 0:
        ratio = record.duration_s / video_span
        if not 0.5 <= ratio <= 2.0:
            flags.append(
                Flag(
                    "warning",
                    "duration",
                    f"the force record lasts {record.duration_s:.4g} s ({record.n_samples} samples at "
                    f"fs_hz={fs:g} Hz) but the video lasts {video_span:.4g} s; a ratio of {ratio:.3g} "
                    "(allowed 0.5 to 2) suggests a wrong fs_hz",
                )
            )


def check_flat_segment(x_at: np.ndarray, mask: np.ndarray, how: str, params: ForceProcessingParams,
                       flags: list) -> bool:
    """Whether the flat segment spans at least ``min_flat_mm`` of finger travel; an error
    flag when it does not."""
    travel = float(np.ptp(x_at[mask])) if mask.sum() >= 2 else 0.0
    if travel < params.min_flat_mm:
        flags.append(
            Flag(
                "error",
                "flat-segment",
                f"the flat segment ({how}) spans {travel:.3f} mm of finger travel "
                f"({int(mask.sum())} samples); at least min_flat_mm={params.min_flat_mm:g} mm is needed "
                "to fit the drift; widen the window or set flat_segment_mm",
            )
        )
        return False
    return True


def check_flat_rest(t: np.ndarray, x_at: np.ndarray, mask: np.ndarray, window: tuple[float, float],
                    flags: list) -> None:
    """A warning when the finger is (nearly) at rest over much of the flat segment: a
    touch-down or a pause there would put static forces into the drift fit."""
    with np.errstate(invalid="ignore"):
        speed = np.abs(np.gradient(x_at, t))
    in_window = np.isfinite(speed) & (x_at >= window[0]) & (x_at <= window[1])
    if in_window.any():
        slow = mask & (speed < 0.1 * float(np.median(speed[in_window])))
        if slow.sum() > 0.05 * mask.sum():
            flags.append(
                Flag(
                    "warning",
                    "flat-rest",
                    f"{100 * slow.sum() / mask.sum():.0f} % of the flat-segment samples have the finger "
                    "(nearly) at rest (below 10 % of its median speed in the window), e.g. a touch-down "
                    "inside the window: the drift fit includes static forces; set flat_segment_mm",
                )
            )


def check_resampling(res, params: ForceProcessingParams, flags: list) -> None:
    """Warnings about the resampling onto positions (a :class:`~.positions.PositionResampling`):
    the finger moving backwards, long interpolated gaps, a stall."""
    if res.max_reversal_mm > params.max_reversal_mm:
        flags.append(
            Flag(
                "warning",
                "reversal",
                f"the finger moved backwards by up to {res.max_reversal_mm:.3f} mm inside the window "
                f"(allowed max_reversal_mm={params.max_reversal_mm:g} mm); forces from the repeated "
                "positions were averaged per bin",
            )
        )
    if res.max_fill_mm > params.max_fill_mm:
        flags.append(
            Flag(
                "warning",
                "gap",
                f"{res.n_filled} empty position bins were interpolated, the longest run "
                f"{res.max_fill_mm:.3f} mm (allowed max_fill_mm={params.max_fill_mm:g} mm): the finger "
                "position jumps (video dropouts or a very fast slide)",
            )
        )
    dwell = res.counts[res.counts > 0]
    med = float(np.median(dwell))
    if dwell.max() > 20 * max(med, 1.0):
        k = int(np.argmax(res.counts))
        flags.append(
            Flag(
                "warning",
                "stall",
                f"the finger stalled near x={res.x[k]:.2f} mm: {int(dwell.max())} samples in one "
                f"{params.resolution_mm:g} mm bin (median {med:g}); the forces there were averaged",
            )
        )
