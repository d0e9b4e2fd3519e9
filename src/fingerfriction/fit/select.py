"""Which model variant the data support, or that none does (``fit --model auto``).

Every variant of :mod:`fingerfriction.fit.variants` is fitted to the same trials, then
judged on what it does with data it was not fitted to and on whether its parameters are
physical:

1. **The bars** (:class:`Bars`; where each number comes from is in ``docs/fit.md``). A
   variant passes when
   * at most 10 % of its trial fits fail or are unphysical (the issue's bar);
   * its Table 1 rho (in sample) is >= 0.75 in at least 16 of every 18 cells (the paper's
     own Table 1: rho > 0.75 "in all but one subcondition"; 16 of 18 is what the paper's
     Table 1 itself reaches, 0.74 and 0.65 being its two cells below);
   * its leave-one-surface-out rho (fitted on the other surfaces, the held-out surface
     predicted from its geometry, the forward contact model's regions, with the trials'
     measured normal force: :data:`CV_COLUMN`) is >= 0.70 in at least 15 of every 18
     cells. Not at the nominal load (:data:`NOMINAL_COLUMN`, printed beside it): where a
     surface's friction signal is small, the participant's normal force wandering by a few
     mN is most of what is measured there, and no friction law can predict it from the
     surface; the exact law itself fails that reading (``docs/fit.md``).
2. **The choice** among the selectable variants that pass: the one with the highest mean
   cross-validated rho over the per-subject held-out cells (:data:`CHOICE_COLUMN`: the
   parameters fitted on the other surfaces, on the held-out trials' own contact and
   load), unless a variant with fewer
   free weights per trial is within one standard error of it (the "one-standard-error
   rule" of cross-validation, Hastie, Tibshirani & Friedman, The Elements of Statistical
   Learning, 2nd ed., Sec. 7.10): the standard error is that of the mean of the paired
   per-cell differences. Of two variants the data support equally, the simpler one.
3. **Refusal**: when no selectable variant passes, the study gets the error
   ``model-rejected`` with each variant's reason, and the fit's exit status says so.
4. **Too few surfaces to compare out of sample** (fewer than :data:`MIN_CV_SURFACES` per
   subject: a held-out surface would be predicted from the parameters of a single other
   feature shape, or there is no held-out surface at all): the choice and the bars rest on
   Table 1 and the share of unphysical fits alone, the leave-one-surface-out table is shown
   for information, and :data:`DEFAULT_MODEL` is used when it passes (in sample a variant
   with more free weights always fits at least as well, so an in-sample comparison cannot
   choose between them); the reason says so.

Also reported, not used to choose: the structure left in each variant's residuals
(:func:`residual_structure`), which says how much of the misfit repeats from trial to
trial at the same place on the surface (a missing term) rather than being noise.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from ..model.stats import BOTH
from .common import FitFlag, fit_flag
from .variants import VARIANTS

__all__ = ["Bars", "BARS", "Evidence", "Selection", "select_model", "residual_structure", "CV_COLUMN",
           "NOMINAL_COLUMN", "CHOICE_COLUMN", "MIN_CV_SURFACES", "DEFAULT_MODEL", "bar_values"]

#: The out-of-sample rho the bar is set on (a column of the leave-one-surface-out table):
#: the prediction of a held-out surface from its geometry (the forward contact model) with
#: the trials' measured normal force, an input of the load family's law; a variant without
#: one (the paper's footing) is judged on :data:`NOMINAL_COLUMN`.
CV_COLUMN = "rho_out_of_sample_measured_load"
#: The same at the nominal load (0.3 N): what a user of ``predict`` gets for a surface never
#: recorded; reported, not a bar (module notes, step 1).
NOMINAL_COLUMN = "rho_out_of_sample"
#: The out-of-sample rho the choice among passing variants uses: the parameters fitted on
#: the other surfaces applied to the held-out trials' own contact (video) and load. It
#: judges the friction law alone; what the forward finger model and the trial's load
#: wander add to the error is the same for every variant and only blurs the comparison.
CHOICE_COLUMN = "rho_heldout_params_video"


#: Surfaces per subject a comparison out of sample needs: each held-out surface predicted
#: from the parameters fitted on at least two others (two different feature shapes).
MIN_CV_SURFACES = 3
#: The variant used when the study has too few surfaces to compare the variants out of
#: sample (module notes, step 4): the project's default model (docs/fit.md).
DEFAULT_MODEL = "load"


@dataclass(frozen=True)
class Bars:
    """The figures a variant must reach to be used (module notes, step 1).

    Parameters
    ----------
    max_unphysical : float
        Largest share of trial fits that failed or are unphysical.
    table1_rho, table1_share : float
        Table 1 rho that a cell must reach, and the least share of cells that must.
    loso_rho, loso_share : float
        The same for the leave-one-surface-out rho (:data:`CV_COLUMN`).
    """

    max_unphysical: float = 0.10
    table1_rho: float = 0.75
    table1_share: float = 16 / 18
    loso_rho: float = 0.70
    loso_share: float = 15 / 18

    def __post_init__(self) -> None:
        for name in ("max_unphysical", "table1_share", "loso_share"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and 0 <= v <= 1):
                raise ValueError(f"Bars.{name} must be a share in [0, 1], got {v!r}")
        for name in ("table1_rho", "loso_rho"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and -1 <= v <= 1):
                raise ValueError(f"Bars.{name} must be a correlation in [-1, 1], got {v!r}")

    @staticmethod
    def needed(share: float, n: int) -> int:
        """Cells of ``n`` that must reach the rho: ``ceil(share n)`` (16 of 18 for 16/18)."""
        return int(math.ceil(share * n - 1e-9))


BARS = Bars()


@dataclass(frozen=True)
class Evidence:
    """What one variant's fit shows (the inputs of :func:`select_model`).

    Parameters
    ----------
    table1 : pandas.DataFrame
        Its Table 1 (:func:`fingerfriction.model.stats.correlation_table`), column ``rho``.
    loso : pandas.DataFrame or None
        Its leave-one-surface-out table (:func:`fingerfriction.predict.leave_one_surface_out`),
        None when not computed.
    n_trials, n_unphysical : int
        Trials fitted, and trial fits that failed or are unphysical.
    residual : float
        :func:`residual_structure` (NaN when unknown).
    """

    table1: pd.DataFrame
    loso: pd.DataFrame | None
    n_trials: int
    n_unphysical: int
    residual: float = math.nan


@dataclass(frozen=True)
class Selection:
    """The outcome of :func:`select_model`.

    Attributes
    ----------
    model : str
        The variant chosen; when ``rejected``, the selectable variant with the best
        cross-validated rho (what the outputs show first, with the rejection above it).
    rejected : bool
        No selectable variant passes the bars: the study-level error ``model-rejected``.
    reason : str
        Why this variant (or why none), in one paragraph for people.
    comparison : pandas.DataFrame
        One row per variant: ``model, title, family, selectable, complexity, n_trials,
        n_unphysical, unphysical_share, table1_cells_ok, table1_cells, loso_cells_ok,
        loso_cells, cv_rho_mean, cv_rho_min, loso_rho_min, loso_nominal_cells_ok,
        cv_diff_from_best, cv_diff_se, residual_structure, passes, verdict, why``
        (``loso_cells_ok`` on :func:`bar_values`, ``loso_nominal_cells_ok`` the same count on
        :data:`NOMINAL_COLUMN`, for information; ``verdict``: chosen, passes, fails,
        fails (shown) for the variant shown when all are rejected, comparison only; ``why``:
        the bars it misses).
    bars : Bars
    cross_validated : bool
        False when the study has fewer than :data:`MIN_CV_SURFACES` surfaces per subject in
        the leave-one-surface-out table (or none: one surface, or not computed): the choice
        then rests on Table 1 alone, with :data:`DEFAULT_MODEL` first, and the reason says so.
    """

    model: str
    rejected: bool
    reason: str
    comparison: pd.DataFrame
    bars: Bars = field(default_factory=Bars)
    cross_validated: bool = True

    def flags(self) -> list[FitFlag]:
        """The study-level flag of a rejection (none otherwise)."""
        if not self.rejected:
            return []
        return [fit_flag("error", "model-rejected", "", "", "", self.reason)]

    def to_dict(self) -> dict:
        """The selection for ``fit/fit.json``."""
        b = self.bars
        return {"model": self.model, "rejected": self.rejected, "reason": self.reason,
                "cross_validated": self.cross_validated, "bar_column": CV_COLUMN,
                "nominal_column": NOMINAL_COLUMN,
                "choice_column": CHOICE_COLUMN,
                "bars": {"max_unphysical": b.max_unphysical, "table1_rho": b.table1_rho,
                         "table1_share": b.table1_share, "loso_rho": b.loso_rho, "loso_share": b.loso_share},
                "comparison": self.comparison.to_dict(orient="records")}


def bar_values(loso: pd.DataFrame) -> np.ndarray:
    """The held-out rho each cell of a leave-one-surface-out table is judged on:
    :data:`CV_COLUMN` where the variant has it, else :data:`NOMINAL_COLUMN`."""
    nominal = loso[NOMINAL_COLUMN].to_numpy(float)
    if CV_COLUMN not in loso.columns:
        return nominal
    measured = loso[CV_COLUMN].to_numpy(float)
    return np.where(np.isfinite(measured), measured, nominal)


def _cells_ok(values, bar: float) -> tuple[int, int]:
    v = np.asarray(values, dtype=float)
    return int(np.sum(np.isfinite(v) & (v >= bar))), int(v.size)


def _cv_cells(loso: pd.DataFrame | None, column: str = CHOICE_COLUMN) -> pd.Series:
    """Cross-validated rho per (subject, held-out surface), the pooled rows left out (they
    repeat the subjects' trials)."""
    if loso is None or column not in loso.columns:
        return pd.Series(dtype=float)
    per = loso[loso["subject"] != BOTH]
    keys = list(zip(per["subject"], per["surface"], strict=True))
    return pd.Series(per[column].to_numpy(float), index=keys)


def _t1_cells(table1: pd.DataFrame) -> pd.Series:
    per = table1[table1["subject"] != BOTH]
    return pd.Series(per["rho"].to_numpy(float),
                     index=list(zip(per["subject"], per["scale"], per["shape"], strict=True)))


def _held_out_surfaces(loso: pd.DataFrame | None) -> int:
    """The most surfaces any subject has in the leave-one-surface-out table (0: none)."""
    if loso is None or not len(loso):
        return 0
    per = loso[loso["subject"] != BOTH]
    return int(per.groupby("subject")["surface"].nunique().max()) if len(per) else 0


def _judge(name: str, ev: Evidence, bars: Bars, cross_validated: bool = True) -> dict:
    v = VARIANTS[name]
    share = ev.n_unphysical / ev.n_trials if ev.n_trials else 1.0
    t1_ok, t1_n = _cells_ok(ev.table1["rho"], bars.table1_rho)
    lo_ok, lo_n = _cells_ok(bar_values(ev.loso), bars.loso_rho) if ev.loso is not None else (0, 0)
    cv = _cv_cells(ev.loso)
    fails = []
    if share > bars.max_unphysical:
        fails.append(f"{ev.n_unphysical} of {ev.n_trials} trial fits failed or unphysical "
                     f"(bar {100 * bars.max_unphysical:g} %)")
    if t1_ok < bars.needed(bars.table1_share, t1_n):
        fails.append(f"Table 1 rho >= {bars.table1_rho:g} in {t1_ok} of {t1_n} cells "
                     f"(bar {bars.needed(bars.table1_share, t1_n)})")
    if cross_validated and ev.loso is not None and lo_ok < bars.needed(bars.loso_share, lo_n):
        why = (f"leave-one-surface-out rho >= {bars.loso_rho:g} in {lo_ok} of {lo_n} cells "
               f"(bar {bars.needed(bars.loso_share, lo_n)})")
        if CHOICE_COLUMN in ev.loso.columns:
            own_ok, own_n = _cells_ok(ev.loso[CHOICE_COLUMN], bars.loso_rho)
            if own_ok >= bars.needed(bars.loso_share, own_n):  # the law holds; the geometry does not
                why += (f", although on the held-out trials' own contact and load it reaches "
                        f"{bars.loso_rho:g} in {own_ok} of {own_n}: the contact predicted from the geometry "
                        "misses (the forward finger model)")
        fails.append(why)
    return {"model": name, "title": v.title, "family": v.family, "selectable": v.selectable,
            "complexity": v.complexity, "n_trials": ev.n_trials, "n_unphysical": ev.n_unphysical,
            "unphysical_share": share, "table1_cells_ok": t1_ok, "table1_cells": t1_n,
            "loso_cells_ok": lo_ok if ev.loso is not None else math.nan,
            "loso_cells": lo_n if ev.loso is not None else math.nan,
            "cv_rho_mean": float(cv.mean()) if cv.size else math.nan,
            "cv_rho_min": float(cv.min()) if cv.size else math.nan,
            "loso_rho_min": float(np.nanmin(bar_values(ev.loso))) if ev.loso is not None and len(ev.loso)
            and np.isfinite(bar_values(ev.loso)).any() else math.nan,
            "loso_nominal_cells_ok": _cells_ok(ev.loso[NOMINAL_COLUMN], bars.loso_rho)[0]
            if ev.loso is not None else math.nan,
            "residual_structure": ev.residual, "passes": not fails, "_fails": fails, "_cv": cv,
            "_t1": _t1_cells(ev.table1)}


def _paired(best: pd.Series, other: pd.Series) -> tuple[float, float]:
    """Mean and standard error of ``best - other`` over their common cells."""
    common = [k for k in best.index if k in other.index]
    d = np.array([best[k] - other[k] for k in common], dtype=float)
    d = d[np.isfinite(d)]
    if d.size == 0:
        return math.nan, math.nan
    se = float(np.std(d, ddof=1) / math.sqrt(d.size)) if d.size > 1 else math.nan
    return float(np.mean(d)), se


def select_model(evidence: Mapping[str, Evidence], *, bars: Bars = BARS) -> Selection:
    """Choose the variant the data support, or refuse (module notes).

    Parameters
    ----------
    evidence : dict of str to Evidence
        Per variant name (:data:`fingerfriction.fit.variants.VARIANTS`).
    bars : Bars

    Returns
    -------
    Selection
    """
    if not evidence:
        raise ValueError("evidence is empty: fit at least one model variant")
    n_surf = max(_held_out_surfaces(ev.loso) for ev in evidence.values())
    cross_validated = n_surf >= MIN_CV_SURFACES
    rows = [_judge(n, ev, bars, cross_validated) for n, ev in evidence.items()]
    score = "_cv" if cross_validated else "_t1"

    def mean(r) -> float:
        v = r[score]
        return float(v.mean()) if v.size else -math.inf

    selectable = [r for r in rows if r["selectable"]]
    if not selectable:
        raise ValueError(f"none of {sorted(evidence)} may be chosen: add a selectable variant")
    passing = [r for r in selectable if r["passes"]]
    pool = passing or selectable
    best = max(pool, key=mean)
    for r in rows:
        d, se = _paired(best[score], r[score])
        r["cv_diff_from_best"], r["cv_diff_se"] = d, se
    within = [r for r in pool if r is best or (math.isfinite(r["cv_diff_se"])
                                               and r["cv_diff_from_best"] <= r["cv_diff_se"])]
    chosen = min(within, key=lambda r: (r["complexity"], -mean(r))) if passing else best
    default = next((r for r in passing if r["model"] == DEFAULT_MODEL), None)
    if not cross_validated and default is not None:
        chosen = default
    what = ("held-out (leave one surface out, on the held-out trials' own contact and load)"
            if cross_validated else "Table 1 (in-sample; not cross-validated)")
    few = ("" if cross_validated else
           f"not cross-validated: too few surfaces to compare the variants out of sample "
           f"({n_surf or 'none'} held out per subject; the comparison needs {MIN_CV_SURFACES}, each "
           "predicted from at least two others), so the bars are Table 1's and the unphysical fits'")
    if passing:
        reason = (f"{chosen['model']} ({chosen['title']}): passes every bar "
                  f"({chosen['n_unphysical']} of {chosen['n_trials']} trial fits unphysical, Table 1 rho >= "
                  f"{bars.table1_rho:g} in {chosen['table1_cells_ok']} of {chosen['table1_cells']} cells"
                  + (f", leave-one-surface-out rho >= {bars.loso_rho:g} in {chosen['loso_cells_ok']} of "
                     f"{chosen['loso_cells']}" if cross_validated else "") + ")")
        if few and chosen is default:
            reason += (f"; {few}, and it is the default variant (in sample a variant with more free weights "
                       "fits at least as well: an in-sample comparison cannot choose); compare the variants "
                       "on a study with more surfaces, or choose one with --model")
        elif few:
            reason += f" and has the highest mean {what} rho, {mean(best):.3f}; {few}"
        elif chosen is best:
            others = [r["model"] for r in passing if r is not best]
            reason += (f" and has the highest mean {what} rho, {mean(best):.3f}"
                       + (f" (passing too: {', '.join(others)})" if others else ""))
        else:
            reason += (f"; its mean {what} rho {mean(chosen):.3f} is within one standard error "
                       f"({chosen['cv_diff_se']:.3f}) of {best['model']}'s {mean(best):.3f}, with fewer "
                       "free weights per trial")
        failing = [f"{r['model']}: {'; '.join(r['_fails'])}" for r in rows if not r["passes"]]
        if failing:
            reason += ". Not passing: " + " | ".join(failing)
    else:
        reason = ("no variant passes the bars (" + " | ".join(
            f"{r['model']}: {'; '.join(r['_fails'])}" for r in selectable) + ")" + (f"; {few}" if few else "")
            + "; the tables show "
            f"{best['model']}, the best {what}, only for reference")
    for r in rows:
        r["verdict"] = ("chosen" if r is chosen and passing else "fails (shown)" if r is chosen
                        else "passes" if r["passes"] and r["selectable"]
                        else "comparison only" if not r["selectable"] else "fails")
        r["why"] = "; ".join(r["_fails"])
    table = pd.DataFrame([{k: v for k, v in r.items() if not k.startswith("_")} for r in rows])
    return Selection(model=chosen["model"], rejected=not passing, reason=reason, comparison=table, bars=bars,
                     cross_validated=cross_validated)


def residual_structure(x: Sequence[np.ndarray], measured: Sequence[np.ndarray],
                       residuals: Sequence[np.ndarray], groups: Sequence) -> float:
    """The share of the measured force's variance that the model misses the same way in
    every trial: the feature-locked part of the residual (0 = none, about 1 = the model
    explains nothing that repeats).

    Per group of trials (a subject on a surface), on the positions all its ``N`` trials
    share, with ``r_k(x)`` the residual of trial ``k`` and ``rbar`` their mean: the
    systematic residual variance ``var_x(rbar) - mean_k var_x(r_k - rbar) / (N - 1)``
    (the mean's variance less what independent noise leaves in it) over the measured
    variance ``mean_k var_x(F_k)``. The result is the median over the groups with at least
    2 trials.

    Parameters
    ----------
    x : sequence of (n_k,) ndarray
        Positions in mm of each trial's compared samples.
    measured : sequence of (n_k,) ndarray
        The measured force (N) at those positions, as compared.
    residuals : sequence of (n_k,) ndarray
        Measured minus model (N) at those positions.
    groups : sequence
        A hashable group label per trial.

    Returns
    -------
    float
        NaN when no group has 2 trials sharing 10 positions.
    """
    by: dict = {}
    for xi, fi, ri, g in zip(x, measured, residuals, groups, strict=True):
        key = np.round(np.asarray(xi, dtype=float), 6).tolist()
        pairs = zip(np.asarray(fi, dtype=float).tolist(), np.asarray(ri, dtype=float).tolist(), strict=True)
        by.setdefault(g, []).append(dict(zip(key, pairs, strict=True)))
    out = []
    for series in by.values():
        if len(series) < 2:
            continue
        common = sorted(set.intersection(*(set(s) for s in series)))
        if len(common) < 10:
            continue
        FR = np.array([[s[c] for c in common] for s in series])  # (N, n, 2)
        F, R = FR[..., 0], FR[..., 1]
        signal = float(np.mean(np.var(F, axis=1)))
        if not signal > 0:
            continue
        R = R - R.mean(axis=1, keepdims=True)
        rbar = R.mean(axis=0)
        n = R.shape[0]
        noise = float(np.mean(np.var(R - rbar, axis=1))) / (n - 1)
        out.append(max(float(np.var(rbar)) - noise, 0.0) / signal)
    return float(np.median(out)) if out else math.nan
