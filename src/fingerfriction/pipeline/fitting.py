"""The fit stage of the study pipeline: both variants of the friction model of Janko et al.
2018 (:mod:`fingerfriction.fit`) fitted to the analysed trials of a results store, Table 1
for each with bootstrap confidence intervals, the flags of everything unphysical or doubtful,
then the out-of-sample validation (leave one surface out,
:func:`fingerfriction.pipeline.validation.validate_results`).

* ``'load'`` (the default model): the load-consistent Eq. (4), ``mu`` per subject from
  flat-ground Coulomb friction with a confidence interval, the load-bearing contact
  (inset, pressure rise with height) per subject, ``p1`` per trial, on the absolute forces;
* ``'paper'``: Eq. (4) as printed, ``mu`` per subject by grid search, ``p0, p1`` per trial
  on the paper's flat-segment footing.

Both are always fitted, so the report can show them side by side; ``model`` names the one
that ``predict``, ``validate`` and ``render`` use and the report puts first. The trials are
read by :meth:`fingerfriction.study.store.ResultsStore.read_fit_trial`, the same reader the
validation uses; everything is written through the store.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from .. import fit as fitmod
from .._progress import ProgressBar
from ..model import MODELS, FrictionModel
from ..model.stats import correlation_table
from ..study.store import ResultsStore, now
from .trial import one_line
from .validation import validate_results

__all__ = ["FitSummary", "fit", "summary_lines"]

logger = logging.getLogger(__name__)

#: One sentence per model for the report and the console: which is the default and why.
MODEL_NOTES = {
    "load": "load-consistent Eq. (4): the pressure at each position carries the measured normal force, "
            "mu is measured on flat ground (where Eq. 4 is Amontons' law), the load-bearing contact and "
            "the deformation weight p1 are fitted on absolute forces; the default, because its parameters "
            "are identified and physical.",
    "paper": "Eq. (4) as printed: one constant pressure p0 per trial and mu by grid search on the paper's "
             "flat-segment footing; kept to reproduce the paper, but mu is not identifiable there "
             "((mu, p0, p1) and (p0/p1, p1 mu, p1) give the same forces) and p0 can turn negative.",
}


#: How each model puts measurement and model on one footing (the report's figure titles).
FOOTING = {
    "load": "absolute (drift removed on the unloaded rests only; no detrend of either)",
    "paper": "detrended (a line fitted on the flat before the feature, subtracted from both)",
}


@dataclass(frozen=True)
class FitSummary:
    """Summary of :func:`fit`.

    Attributes
    ----------
    model : str
        The default model of this fit (``'load'`` or ``'paper'``).
    mu : dict of str to float
        Per-subject friction coefficient of ``model``.
    mu_ci : dict of str to (float, float)
        Its 95 % confidence interval (NaN for the paper variant, which has none).
    n_trials : int
        Trials fitted.
    n_failed : int
        Trials that could not be prepared, plus trial fits of ``model`` that did not
        succeed.
    failures : tuple of (str, str)
        ``(trial_id, reason)``, the same.
    messages : dict of str to str
        Per-subject message of ``model``.
    flags : tuple of FitFlag
        Everything flagged, for both models.
    lines : tuple of str
        One summary line per subject and model (what the command line prints).
    table1 : pandas.DataFrame
        Table 1 of both models (column ``model``), with bootstrap confidence intervals.
    cpu_s : dict of str to float
        CPU time in s of each model's fit (reading the trials not included).
    loso : pandas.DataFrame or None
        The out-of-sample validation (:func:`fingerfriction.pipeline.validation.validate_results`:
        leave one surface out, rho per held-out surface, both models), also in
        ``fit/loso.csv``; None when not computed (one surface only, ``validate=False``, or
        it failed: see ``loso_message``).
    loso_message : str
        How the validation went ('' when computed).
    """

    model: str
    mu: dict
    mu_ci: dict
    n_trials: int
    n_failed: int
    failures: tuple[tuple[str, str], ...]
    messages: dict
    flags: tuple = ()
    lines: tuple = ()
    table1: Any = None
    cpu_s: dict = field(default_factory=dict)
    loso: Any = None
    loso_message: str = ""

    def console_lines(self, store: ResultsStore) -> list[str]:
        """What ``fingerfriction fit`` prints: trials that could not be read (one line), one
        line per subject and model, where the validation is, and a closing count."""
        out = []
        unread = [(t, r) for t, r in self.failures if not any(f.trial == t for f in self.flags)]
        if unread:
            out.append(f"{len(unread)} trial(s) could not be prepared for the fit, e.g. {unread[0][0]}: "
                       f"{unread[0][1]}")
        out += list(self.lines)
        where = store.loso_path if self.loso is not None else self.loso_message
        out.append(f"out-of-sample validation (leave one surface out): {where}")
        n_err = sum(f.level == "error" for f in self.flags)
        out.append(f"{self.n_trials} trials fitted with both models ({self.model} the default), {n_err} "
                   f"error flags, {len(self.flags) - n_err} warnings -> {store.fit_dir}")
        return out


def fit(
    results: str | os.PathLike,
    *,
    model: str = "load",
    mu_grid: tuple[float, float, float] = (0.30, 0.90, 0.01),
    method: str = "lstsq",
    median_kernel: int = 11,
    progress: bool = True,
    validate: bool = True,
    seed: int = 0,
) -> FitSummary:
    """Fit both variants of the friction model to every finished trial of a results folder.

    Parameters
    ----------
    results : path
        A results folder written by :func:`analyze`.
    model : {'load', 'paper'}
        The default model (see the module notes): the one ``predict``, ``validate`` and
        ``render`` use with this fit, and the report's first.
    mu_grid : (start, stop, step)
        Inclusive ``mu`` grid of the paper variant (default 0.30 to 0.90 by 0.01).
    method : {'lstsq', 'nelder-mead'}
        How the paper variant fits ``p0, p1`` (closed form, or Nelder-Mead as the paper).
    median_kernel : int
        Median filter window in samples on the models (odd; 1 = off).
    progress : bool
        Show a progress bar.
    validate : bool
        Also run the leave-one-surface-out validation of both models
        (:func:`fingerfriction.pipeline.validation.validate_results`) on two surfaces or more.
    seed : int
        Seed of the bootstrap confidence intervals.

    Returns
    -------
    FitSummary

    Writes ``RESULTS/fit/`` (layout in :mod:`fingerfriction.study.store`, both models); a
    validation that fails is logged and recorded in ``fit.json``, the fit itself stands.
    """
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS}, got {model!r}")
    store = ResultsStore(results)
    start, stop, step = (float(v) for v in mu_grid)
    grid = fitmod.mu_grid(start, stop, step)
    options = fitmod.FitOptions(median_kernel=int(median_kernel))
    load_options = fitmod.LoadFitOptions(median_kernel=int(median_kernel), seed=int(seed))
    surfaces = store.surfaces()
    analysis = store.analysis_digests()  # what is fitted, so that the report can tell it changed since
    meta = {t["id"]: t for t in store.analysed_trials()}
    if not meta:
        raise ValueError(f"{str(store.root)!r} has no successfully analysed trial to fit")

    bar = ProgressBar(progress, len(meta) + 2, "fit")
    try:
        trials, grids, failures = _read_trials(store, meta, surfaces, options.flat_margin, bar)
        fits, cpu = _fit_both(trials, grid, method, options, load_options, bar)
    finally:
        bar.close()

    flags = [f for sf in fits["load"].values() for f in sf.flags]
    flags += [f for sf in fits["paper"].values() for f in fitmod.paper_flags(sf)]
    failures += [(tf.labels["trial"], tf.message) for sf in fits[model].values() for tf in sf.trials
                 if not tf.success]
    table1 = pd.concat([correlation_table(fits[m], seed=seed).assign(model=m) for m in MODELS],
                       ignore_index=True)
    _write_outputs(store, trials, grids, meta, fits, model)
    store.write_fit_csv("table1", table1)
    record = _fit_record(model, fits, cpu, (start, stop, step, int(grid.size)), method, options, load_options,
                         flags, len(trials), failures)
    record["analysis"] = {"trials": analysis}  # per trial: the digest of its stored tables
    store.write_fit_record(record)  # validate_results reads the grid and options from it
    loso, loso_message = _validate_after_fit(store, trials, validate)
    record["loso"] = {"computed": loso is not None, "message": loso_message,
                      "csv": "loso.csv" if loso is not None else None}
    store.write_fit_record(record)
    return FitSummary(model=model, mu=record["mu"], mu_ci={s: tuple(v) for s, v in record["mu_ci"].items()},
                      n_trials=len(trials), n_failed=len(failures), failures=tuple(failures),
                      messages=record["messages"], flags=tuple(flags),
                      lines=tuple(summary_lines(fits, flags, model)), table1=table1, cpu_s=cpu,
                      loso=loso, loso_message=loso_message)


def _fit_record(model: str, fits: dict, cpu: dict, grid: tuple, method: str, options, load_options,
                flags: list, n_trials: int, failures: list) -> dict:
    """The content of ``fit/fit.json`` (without ``loso``, added once validated)."""
    return {
        "model": model,
        "model_notes": MODEL_NOTES,
        "footing": FOOTING[model],
        "mu": {s: sf.mu for s, sf in fits[model].items()},
        "mu_ci": {s: list(_mu_ci(sf)) for s, sf in fits[model].items()},
        "models": {m: _model_record(m, fits[m], cpu[m]) for m in MODELS},
        "mu_grid": dict(zip(("start", "stop", "step", "n"), grid, strict=True)),
        "method": method, "options": dataclasses.asdict(options),
        "load_options": dataclasses.asdict(load_options),
        "curves": {s: {"grid": sf.grid, "objective": sf.curve} for s, sf in fits["paper"].items()},
        "messages": {s: sf.message for s, sf in fits[model].items()},
        "flags": [f.to_dict() for f in flags],
        "n_trials": n_trials, "failures": [{"trial": t, "reason": r} for t, r in failures],
        "finished": now(),
    }


def _read_trials(store: ResultsStore, meta: dict, surfaces: dict, flat_margin: float, bar):
    """``(trials, grids, failures)``: the analysed trials as fit inputs, per trial the
    positions with translated regions, and the trials that could not be prepared (why)."""
    trials, grids, failures = [], {}, []
    for tid in meta:
        try:  # a trial without a flat segment (the fit detrends over it) must not stop the others
            trial, grids[tid] = store.read_fit_trial(meta[tid], surfaces, flat_margin=flat_margin)
            trials.append(trial)
        except (ValueError, KeyError, OSError) as exc:
            failures.append((tid, one_line(exc)))
        bar.advance(tid)
    if not trials:
        reasons = "; ".join(r for _, r in failures[:3])
        raise ValueError(f"no trial could be prepared for fitting: {reasons}")
    return trials, grids, failures


def _fit_both(trials: list, grid, method: str, options, load_options, bar) -> tuple[dict, dict]:
    """Both model variants fitted to every subject: ``(fits, cpu_s)`` keyed by model."""
    cpu: dict[str, float] = {}
    c0 = time.process_time()
    fits = {"load": fitmod.fit_load_trials(trials, load_options)}
    cpu["load"] = time.process_time() - c0
    bar.advance("load-consistent model")
    c0 = time.process_time()
    fits["paper"] = fitmod.fit_trials(trials, grid=grid, method=method, options=options)
    cpu["paper"] = time.process_time() - c0
    bar.advance("paper's model")
    return fits, cpu


def _mu_ci(sf) -> tuple[float, float]:
    return tuple(getattr(sf, "mu_ci", (math.nan, math.nan)))


def _model_record(name: str, fits: dict, cpu_s: float) -> dict:
    """The per-model part of ``fit.json``."""
    rec: dict = {"note": MODEL_NOTES[name], "cpu_s": round(cpu_s, 3),
                 "mu": {s: sf.mu for s, sf in fits.items()},
                 "success": {s: bool(sf.success) for s, sf in fits.items()},
                 "messages": {s: sf.message for s, sf in fits.items()}}
    if name == "load":
        rec["mu_ci"] = {s: list(sf.mu_ci) for s, sf in fits.items()}
        rec["mu_trials"] = {s: (sf.flat.mu_trials if sf.flat else {}) for s, sf in fits.items()}
        rec["transient_mm"] = {s: (sf.flat.transient_mm if sf.flat else math.nan) for s, sf in fits.items()}
        rec["inset_mm"] = {s: sf.inset for s, sf in fits.items()}
        rec["kappa_per_mm"] = {s: sf.kappa for s, sf in fits.items()}
        rec["fitted"] = {s: list(sf.fitted) for s, sf in fits.items()}
        rec["p1_median"] = {s: _median([t.p1 for t in sf.trials if t.success]) for s, sf in fits.items()}
    else:
        rec["p0_median"] = {s: _median([t.p0 for t in sf.trials if t.success]) for s, sf in fits.items()}
        rec["p1_median"] = {s: _median([t.p1 for t in sf.trials if t.success]) for s, sf in fits.items()}
    return rec


def _median(v: list) -> float:
    return float(np.median(v)) if v else math.nan


def _write_outputs(store: ResultsStore, trials: list, grids: dict, meta: dict, fits: dict,
                   model: str) -> None:
    """``fit/trials.csv``, ``fit/subjects.csv`` and ``fit/model/<trial-id>.parquet``."""
    by_id = {t.labels["trial"]: t for t in trials}
    per_trial: dict[str, dict[str, Any]] = {}
    rows, subj_rows = [], []
    for m in MODELS:
        for subject, sf in fits[m].items():
            subj_rows.append(_subject_row(m, subject, sf))
            for tf in sf.trials:
                tid = tf.labels["trial"]
                e = meta[tid]
                rows.append({"trial": tid, "model": m, "subject": subject, "surface": e["surface"],
                             "speed_mm_s": e["speed_mm_s"], "repetition": e.get("repetition"),
                             "mu": tf.mu, "p0": tf.p0_mean if m == "load" else tf.p0, "p1": tf.p1,
                             "p1_se": getattr(tf, "p1_se", math.nan),
                             "inset_mm": getattr(tf, "inset", math.nan),
                             "kappa_per_mm": getattr(tf, "kappa", math.nan),
                             "footing": getattr(tf, "footing", "flat"), "objective": tf.objective,
                             "success": tf.success, "message": tf.message})
                per_trial.setdefault(tid, {})[m] = tf
    models: dict[str, FrictionModel] = {}
    for tid, by_model in per_trial.items():
        tr = by_id[tid]
        cols: dict[str, np.ndarray] = {"x_mm": tr.x}
        for m, tf in by_model.items():
            if m == "load":
                cols.update({"load_F_T_N": tf.measured, "load_F_hat_N": tf.estimate,
                             "load_F_int_N": tf.interfacial, "load_F_def_N": tf.deformation,
                             "load_p0_N_per_mm": tf.pressure})
            else:
                fm = models.setdefault(tr.surface.name, FrictionModel(tr.surface))
                # Eq. (2)-(4) with the fitted p0, p1 as they are (FrictionParams would refuse
                # the unphysical p0 < 0 of a failed fit; its row in trials.csv says it failed).
                B = fm.basis(tr.regions, tf.mu)
                cols.update({"paper_F_T_N": tf.measured, "paper_F_hat_N": tf.estimate,
                             "paper_F_model_N": tf.p0 * B[:, 0] + tf.p1 * B[:, 1],
                             "paper_F_int_N": tf.p0 * B[:, 0], "paper_F_def_N": tf.p1 * B[:, 1]})
        nan = np.full(tr.n, np.nan)  # a model that could not fit this trial's subject
        for name in ("F_T_N", "F_hat_N", "F_int_N", "F_def_N"):
            for m in MODELS:
                cols.setdefault(f"{m}_{name}", nan)
        cols.setdefault("load_p0_N_per_mm", nan)
        cols.setdefault("paper_F_model_N", nan)
        p = model
        default = {"F_T_N": cols[f"{p}_F_T_N"], "F_hat_N": cols[f"{p}_F_hat_N"],
                   "F_model_N": cols.get(f"{p}_F_model_N", cols[f"{p}_F_hat_N"]),
                   "F_int_N": cols[f"{p}_F_int_N"], "F_def_N": cols[f"{p}_F_def_N"]}
        extra = {"F_N_N": tr.normal_abs if tr.has_absolute else np.full(tr.n, np.nan),
                 "F_T_raw_N": tr.force, "regions_translated": grids[tid]}
        store.write_model(tid, pd.DataFrame({"x_mm": tr.x, **default, **extra,
                                             **{k: v for k, v in cols.items() if k != "x_mm"}}))
    store.write_fit_tables(pd.DataFrame(rows), pd.DataFrame(subj_rows))


def _subject_row(model: str, subject: str, sf) -> dict:
    n_bad = sum(not t.success for t in sf.trials)
    lo, hi = _mu_ci(sf)
    return {"subject": subject, "model": model, "mu": sf.mu, "mu_lo": lo, "mu_hi": hi,
            "inset_mm": getattr(sf, "inset", math.nan), "kappa_per_mm": getattr(sf, "kappa", math.nan),
            "transient_mm": sf.flat.transient_mm if getattr(sf, "flat", None) else math.nan,
            "n_trials": len(sf.trials), "n_failed": n_bad, "success": sf.success, "message": sf.message}


def summary_lines(fits: dict, flags: Sequence, model: str) -> list[str]:
    """One line per subject and model: the parameters, then the flags grouped by kind with a
    count and the first example (never one line per trial)."""
    out = []
    for m in (model, *[x for x in MODELS if x != model]):
        for subject, sf in fits[m].items():
            tag = f"subject {subject}, {'load-consistent' if m == 'load' else 'paper'} model"
            tag += " (default)" if m == model else ""
            n = len(sf.trials)
            if m == "load":
                lo, hi = sf.mu_ci
                p1 = _median([t.p1 for t in sf.trials if t.success])
                head = (f"mu = {sf.mu:.4f} (95 % CI {lo:.4f}-{hi:.4f}), load-bearing inset "
                        f"{sf.inset:.2f} mm, pressure rise {sf.kappa:.2f}/mm, p1 median {p1:.3g} N/mm")
            else:
                p0 = _median([t.p0 for t in sf.trials])
                head = f"mu = {sf.mu:.3f} (grid search), p0 median {p0:.3g} N/mm"
            mine = [f for f in flags if f.subject == subject and f.model == m]
            groups: dict[str, list] = {}
            for f in mine:
                groups.setdefault(f.code, []).append(f)
            parts = []
            for code, fs in groups.items():
                trial_flags = [f for f in fs if f.trial]
                first = fs[0]
                where = f"{first.trial}: " if first.trial else ""
                count = f"{len(trial_flags)} of {n} trials " if trial_flags else ""
                parts.append(f"{first.level} {code}: {count}e.g. {where}{first.message}")
            n_bad = sum(not t.success for t in sf.trials)
            tail = f"{n - n_bad} of {n} trial fits OK"
            out.append(f"{tag}: {head}; {tail}" + ("; " + "; ".join(parts) if parts else ""))
    return out


def _validate_after_fit(store: ResultsStore, trials: Sequence, validate: bool):
    """Leave-one-surface-out validation after :func:`fit`: (table or None, message).

    A previous run's ``fit/loso.*`` is removed first, so the folder never holds a
    validation of another fit.
    """
    store.clear_loso()
    if not validate:
        return None, "not requested"
    n_surf = len({t.labels["surface"] for t in trials})
    if n_surf < 2:
        return None, f"needs at least two surfaces, the study has {n_surf}"
    t0 = time.perf_counter()
    try:
        res = validate_results(store.root, trials=list(trials))
    except (ValueError, KeyError, OSError, RuntimeError, np.linalg.LinAlgError) as exc:
        # RuntimeError: no training fit succeeded for a held-out surface (pipeline.validation);
        # the fit itself stands, the validation is recorded as failed
        logger.warning("out-of-sample validation failed: %s", one_line(exc))
        return None, f"failed: {one_line(exc)}"
    logger.info("out-of-sample validation: %.1f s", time.perf_counter() - t0)
    return res.table, ""
