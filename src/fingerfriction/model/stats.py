"""Pearson correlation of measured and modelled forces per condition (Table 1), and the
blind-spot table (Fig. 3); pure (no file I/O: tables are written by
:func:`fingerfriction.study.store.write_table`).

Table 1 of Janko et al. 2018: "Pearson's correlation coefficient values, rho, for the
ensemble of measurements in each condition ... All correlations were computed on
detrended data"; data from all three speeds grouped. Here the *ensemble* of a condition
is formed as follows (the paper does not spell it out):

1. each trial's measured series and model estimate (as compared by the fit, see
   :class:`fingerfriction.fit.TrialFit`) are detrended separately with
   ``scipy.signal.detrend(type='linear')`` over the whole trial;
2. the detrended series of all trials in the condition (all speeds and repetitions) are
   concatenated, measured with measured and model with model;
3. one ``scipy.stats.pearsonr`` on the two concatenated vectors gives rho and p.

Conditions: subject x scale (2 mm, 4 mm) x shape (Bump, Step Up, Step Down), plus
"Both subjects" (the trials of every subject pooled).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import pandas as pd
from scipy import signal, stats

from .blindspots import blind_spots

__all__ = [
    "ensemble_correlation", "bootstrap_correlation_ci", "correlation_table", "table1_wide",
    "blind_spot_table", "BOTH",
]

BOTH = "Both subjects"
_SHAPE_LABELS = {"bump": "Bump", "step-up": "Step Up", "step-down": "Step Down"}


def _detrended_pairs(measured: Sequence, estimate: Sequence) -> list[tuple[np.ndarray, np.ndarray]]:
    """Each trial's pair, validated and linearly detrended (step 1 of the module notes)."""
    if len(measured) != len(estimate) or len(measured) == 0:
        raise ValueError(
            "measured and estimate must be non-empty lists of equal length, "
            f"got {len(measured)} and {len(estimate)}"
        )
    out = []
    for k, (f, g) in enumerate(zip(measured, estimate, strict=True)):
        f = np.asarray(f, dtype=float)
        g = np.asarray(g, dtype=float)
        if f.ndim != 1 or f.shape != g.shape or f.size < 3:
            raise ValueError(
                f"trial {k}: measured {f.shape} and estimate {g.shape} must be equal 1-D, >= 3 samples"
            )
        if not (np.all(np.isfinite(f)) and np.all(np.isfinite(g))):
            raise ValueError(f"trial {k}: measured/estimate contain non-finite values")
        out.append((signal.detrend(f, type="linear"), signal.detrend(g, type="linear")))
    return out


def ensemble_correlation(measured: Sequence, estimate: Sequence) -> tuple[float, float, int]:
    """Pearson rho and p-value of the detrended, concatenated ensemble of trials.

    Parameters
    ----------
    measured, estimate : sequence of (n_k,) array_like
        One measured and one modelled force series (N) per trial; pairs must have equal
        lengths (trials may differ).

    Returns
    -------
    rho : float
    p : float
        Two-sided p-value of ``scipy.stats.pearsonr`` (no relationship hypothesis).
    n : int
        Number of samples in the ensemble.
    """
    pairs = _detrended_pairs(measured, estimate)
    f = np.concatenate([a for a, _ in pairs])
    g = np.concatenate([b for _, b in pairs])
    if np.ptp(f) == 0 or np.ptp(g) == 0:
        return math.nan, math.nan, int(f.size)
    r = stats.pearsonr(f, g)
    return float(r.statistic), float(r.pvalue), int(f.size)


def bootstrap_correlation_ci(measured: Sequence, estimate: Sequence, *, n_boot: int = 1000,
                             level: float = 0.95, seed: int = 0) -> tuple[float, float]:
    """Percentile confidence interval of :func:`ensemble_correlation`'s rho over trials.

    The trials of the ensemble are resampled with replacement ``n_boot`` times (a seeded
    ``numpy.random.Generator``) and rho is recomputed on each resample from per-trial
    moment sums (so a resample costs O(n_trials), not O(n_samples)).

    Parameters
    ----------
    measured, estimate : sequence of (n_k,) array_like
        As :func:`ensemble_correlation`.
    n_boot : int
        Number of resamples (>= 100).
    level : float
        Confidence level in (0.5, 1).
    seed : int
        Seed of the generator.

    Returns
    -------
    (float, float)
        Lower and upper bounds; NaN with fewer than 2 trials.
    """
    if isinstance(n_boot, bool) or not isinstance(n_boot, (int, np.integer)) or n_boot < 100:
        raise ValueError(f"n_boot must be an integer >= 100, got {n_boot!r}")
    if not 0.5 < float(level) < 1:
        raise ValueError(f"level must be a confidence level in (0.5, 1), got {level!r}")
    pairs = _detrended_pairs(measured, estimate)
    if len(pairs) < 2:
        return math.nan, math.nan
    # per-trial sums: n, sum f, sum g, sum f^2, sum g^2, sum f g
    m = np.array([[f.size, f.sum(), g.sum(), f @ f, g @ g, f @ g] for f, g in pairs])
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, len(pairs), size=(int(n_boot), len(pairs)))
    tot = m[idx].sum(axis=1)
    n, sf, sg, sff, sgg, sfg = tot.T
    cov = sfg - sf * sg / n
    var_f = sff - sf * sf / n
    var_g = sgg - sg * sg / n
    with np.errstate(invalid="ignore", divide="ignore"):
        rho = cov / np.sqrt(var_f * var_g)
    rho = rho[np.isfinite(rho)]
    if rho.size == 0:
        return math.nan, math.nan
    a = 100 * (1 - float(level)) / 2
    return float(np.percentile(rho, a)), float(np.percentile(rho, 100 - a))


def _compared(tf) -> tuple[np.ndarray, np.ndarray]:
    """(measured, estimate) of a trial fit as compared by the fit (both model variants)."""
    compared = getattr(tf, "compared", None)
    return compared() if callable(compared) else (tf.measured, tf.estimate)


def correlation_table(fits, *, alpha: float = 0.01, n_boot: int | None = 1000, level: float = 0.95,
                      seed: int = 0) -> pd.DataFrame:
    """Table 1: rho and p per subject x scale x shape, plus both subjects pooled.

    Parameters
    ----------
    fits : iterable of trial fits, or dict of subject -> subject fit
        Per-trial fits of either model variant (:class:`fingerfriction.fit.TrialFit`,
        :class:`fingerfriction.fit.LoadTrialFit`); each carries its compared measured and
        model series, subject and labels. The condition of a trial comes from
        ``labels['scale']`` and ``labels['shape']`` (set by the fit from the trial's surface).
    alpha : float
        Significance level for the ``significant`` column (paper: p < 0.01).
    n_boot : int or None
        Bootstrap resamples over trials of the confidence interval of rho
        (:func:`bootstrap_correlation_ci`); None leaves the interval out.
    level : float
        Confidence level of the interval.
    seed : int
        Seed of the bootstrap.

    Returns
    -------
    pandas.DataFrame
        Long format, one row per condition, columns ``subject, scale, shape, rho, rho_lo,
        rho_hi, p, significant, n_trials, n_samples`` (a trial fit with fewer than 3
        compared samples, a failed one, is left out; a condition without any: NaN); subjects
        in sorted order then "Both subjects", scales and shapes in the paper's order.
    """
    trial_fits = _flatten(fits)
    groups: dict[tuple[str, str, str], list] = {}
    for tf in trial_fits:
        scale = tf.labels.get("scale", "")
        shape = tf.labels.get("shape", "")
        groups.setdefault((tf.subject, scale, shape), []).append(tf)
        groups.setdefault((BOTH, scale, shape), []).append(tf)
    subjects = sorted({k[0] for k in groups if k[0] != BOTH}) + [BOTH]
    shape_order = {s: i for i, s in enumerate(_SHAPE_LABELS.values())}

    def key(k):
        return (subjects.index(k[0]), _scale_value(k[1]), shape_order.get(k[2], 99), k[2])

    rows = []
    for k in sorted(groups, key=key):
        # a trial fit with fewer than 3 compared samples failed (its fit says why): left out
        series = [sr for sr in (_compared(t) for t in groups[k]) if np.asarray(sr[0]).size >= 3]
        if not series:
            rows.append({"subject": k[0], "scale": k[1], "shape": k[2], "rho": math.nan, "rho_lo": math.nan,
                         "rho_hi": math.nan, "p": math.nan, "significant": False, "n_trials": 0,
                         "n_samples": 0})
            continue
        meas, est = [m for m, _ in series], [e for _, e in series]
        rho, p, n = ensemble_correlation(meas, est)
        lo = hi = math.nan
        if n_boot:
            lo, hi = bootstrap_correlation_ci(meas, est, n_boot=n_boot, level=level, seed=seed)
        rows.append({"subject": k[0], "scale": k[1], "shape": k[2], "rho": rho, "rho_lo": lo, "rho_hi": hi,
                     "p": p, "significant": bool(p < alpha) if math.isfinite(p) else False,
                     "n_trials": len(series), "n_samples": n})
    return pd.DataFrame(rows)


def _scale_value(s: str) -> float:
    try:
        return float(s.split()[0])
    except (ValueError, IndexError):
        return math.inf


def _flatten(fits) -> list:
    if isinstance(fits, dict):
        out = []
        for sf in fits.values():
            out.extend(sf.trials)
        return out
    out = list(fits)
    if not out:
        raise ValueError("fits is empty: no trial fits to correlate")
    return out


def shape_label(shape: str) -> str:
    """Paper spelling of a shape: 'step-up' -> 'Step Up'."""
    return _SHAPE_LABELS.get(shape, shape)


def table1_wide(table: pd.DataFrame) -> pd.DataFrame:
    """Table 1 in the paper's layout: rows rho and p < 0.01, columns (subject, scale, shape)."""
    cols = pd.MultiIndex.from_frame(table[["subject", "scale", "shape"]])
    rho = pd.Series(table["rho"].to_numpy(), index=cols).round(2)
    sig = pd.Series(np.where(table["significant"], "*", ""), index=cols)
    return pd.DataFrame([rho, sig], index=["rho", "p < 0.01"])


def blind_spot_table(regions_by_surface: dict, *, min_width: float = 0.0) -> pd.DataFrame:
    """Blind spots per surface (Fig. 3): one row per blind spot.

    Parameters
    ----------
    regions_by_surface : dict of str to (n_frames, n_max, 2) array_like or list of them
        For each surface name, the contact regions of all its frames (all trials and
        subjects pooled, as in Fig. 3); a list of per-trial arrays is concatenated.
    min_width : float
        Ignore gaps narrower than this (mm).

    Returns
    -------
    pandas.DataFrame
        Columns ``surface, start_mm, end_mm, width_mm``; a surface without blind spots
        gets one row with NaN positions and width 0.
    """
    rows = []
    for name, regs in regions_by_surface.items():
        if isinstance(regs, (list, tuple)) and regs and isinstance(regs[0], np.ndarray) and regs[0].ndim == 3:
            k = max(r.shape[1] for r in regs)
            regs = np.concatenate(
                [np.pad(r, ((0, 0), (0, k - r.shape[1]), (0, 0)), constant_values=np.nan) for r in regs]
            )
        bs = blind_spots(regs, min_width=min_width)
        if len(bs) == 0:
            rows.append({"surface": name, "start_mm": math.nan, "end_mm": math.nan, "width_mm": 0.0})
        for r in bs.as_table():
            rows.append({"surface": name, **r})
    return pd.DataFrame(rows, columns=["surface", "start_mm", "end_mm", "width_mm"])
