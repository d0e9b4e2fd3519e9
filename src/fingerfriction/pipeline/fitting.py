"""The fit stage of the study pipeline: every variant of the friction model of Janko et al.
2018 (:mod:`fingerfriction.fit.variants`) fitted to the analysed trials of a results store,
Table 1 for each with bootstrap confidence intervals, the out-of-sample validation of each
(leave one surface out, :func:`fingerfriction.pipeline.validation.validate_models`), and the choice of
the variant the data support, or the refusal of all (:mod:`fingerfriction.fit.select`).

``model='auto'`` (the default) uses the chosen variant; a variant's name forces it. The
chosen (or forced) variant is the one that ``predict``, ``validate`` and ``render`` use,
whose flags are the study's, and that the report and the console show first; the other
variants are shown beside it as a comparison, their flags as notes on it. The trials are
read by :meth:`fingerfriction.study.store.ResultsStore.read_fit_trial`, the same reader
the validation uses; everything is written through the store (``fit.json`` as a
:class:`~fingerfriction.study.results.FitResult`), and the fit's settings reach the
validation in memory.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from .. import fit as fitmod
from .._check import check_option
from .._progress import ProgressBar
from ..fit.select import Evidence, Selection, residual_structure, select_model
from ..fit.variants import MODELS, FitSettings, get
from ..model import FrictionModel
from ..model.stats import correlation_table
from ..predict.forward import FORWARD_STEP_MM
from ..study.results import FitResult
from ..study.store import ResultsStore, now
from .trial import one_line
from .validation import OutOfSample, validate_models, write_validation

__all__ = ["Comparison", "FitSummary", "compare_variants", "fit", "summary_lines", "MODEL_CHOICES"]

logger = logging.getLogger(__name__)

#: What ``fit(model=...)`` takes: ``'auto'`` (choose) or a variant's name (force it).
MODEL_CHOICES = ("auto", *MODELS)


@dataclass(frozen=True)
class FitSummary:
    """Summary of :func:`fit`.

    Attributes
    ----------
    model : str
        The variant used downstream: the chosen one (``requested='auto'``) or the forced one.
    requested : str
        ``'auto'`` or the variant's name the caller gave.
    selection : Selection
        The comparison of the variants and the choice (or the refusal), with its reason.
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
        The study's flags: those of ``model``, and ``model-rejected`` when no variant passes.
    notes : tuple of FitFlag
        The other variants' flags: notes on the comparison, not findings about the study.
    lines : tuple of str
        One summary line per subject and model (what ``--verbose`` prints).
    table1 : pandas.DataFrame
        Table 1 of every variant (column ``model``, ``model``'s rows first), with bootstrap
        confidence intervals.
    cpu_s : dict of str to float
        CPU time in s of each variant's fit (reading the trials not included).
    loso : pandas.DataFrame or None
        The out-of-sample validation (leave one surface out, rho per held-out surface, every
        variant, column ``model``), also in ``fit/loso.csv``; None when not computed (one
        surface only, ``validate=False``, or it failed: see ``loso_message``).
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
    requested: str = "auto"
    selection: Selection | None = None
    notes: tuple = ()

    @property
    def rejected(self) -> bool:
        """True when no variant passes the bars (the study-level error ``model-rejected``)."""
        return self.selection is not None and self.selection.rejected

    @property
    def title(self) -> str:
        """The used variant's title, e.g. 'Load-consistent Eq. 4 (load)'."""
        return f"{get(self.model).title} ({self.model})"

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
        n_warn = sum(f.level == "warning" for f in self.flags)
        out.append(f"{self.n_trials} trials fitted with every model variant ({self.model} used), {n_err} "
                   f"error flags, {n_warn} warnings -> {store.fit_dir}")
        return out


def _settings(mu_grid, method: str | None, median_kernel: int | None, seed: int) -> FitSettings:
    """The fit's settings; an argument left None is the options dataclasses' default."""
    kernel = {} if median_kernel is None else {"median_kernel": int(median_kernel)}
    grid = [None if v is None else float(v) for v in (mu_grid or (None, None, None))]
    return FitSettings(paper=fitmod.FitOptions(**kernel),
                       load=fitmod.LoadFitOptions(**kernel, seed=int(seed)),
                       grid=fitmod.mu_grid(*grid), **({} if method is None else {"method": method}))


def fit(
    results: str | os.PathLike,
    *,
    model: str = "auto",
    mu_grid: tuple[float | None, float | None, float | None] | None = None,
    method: str | None = None,
    median_kernel: int | None = None,
    progress: bool = True,
    validate: bool = True,
    seed: int = 0,
) -> FitSummary:
    """Fit every variant of the friction model to every finished trial of a results folder,
    and choose the one the data support (or refuse).

    Parameters
    ----------
    results : path
        A results folder written by :func:`analyze`.
    model : {'auto', 'load', 'pressure', 'interlock', 'paper'}
        ``'auto'`` (default): the variant chosen by :func:`fingerfriction.fit.select.select_model`;
        a variant's name: that one (the choice is still made and reported).
    mu_grid : (start, stop, step), optional
        Inclusive ``mu`` grid of the paper variant; None, or an entry None, is that of
        :data:`fingerfriction.fit.paper.MU_GRID` (0.30 to 0.90 by 0.01).
    method : {'lstsq', 'nelder-mead'}, optional
        How the paper variant fits ``p0, p1`` (closed form, or Nelder-Mead as the paper);
        default :class:`~fingerfriction.fit.variants.FitSettings`'s (lstsq).
    median_kernel : int, optional
        Median filter window in samples on the models (odd; 1 = off); default
        :class:`~fingerfriction.fit.FitOptions`'s (11).
    progress : bool
        Show a progress bar.
    validate : bool
        Also run the leave-one-surface-out validation of every variant on two surfaces or
        more (the choice rests on it; without it, on Table 1 alone).
    seed : int
        Seed of the bootstrap confidence intervals.

    Returns
    -------
    FitSummary

    Writes ``RESULTS/fit/`` (layout in :mod:`fingerfriction.study.store`, every variant); a
    validation that fails is logged and recorded in ``fit.json``, the fit itself stands.
    """
    check_option("model", model, MODEL_CHOICES)
    store = ResultsStore(results)
    settings = _settings(mu_grid, method, median_kernel, seed)
    surfaces = store.surfaces()
    analysis = store.analysis_digests()  # what is fitted, so that the report can tell it changed since
    meta = {t["id"]: t for t in store.analysed_trials()}
    if not meta:
        raise ValueError(f"{str(store.root)!r} has no successfully analysed trial to fit")

    bar = ProgressBar(progress, len(meta) + len(MODELS) + 1, "fit")
    try:
        trials, grids, failures = _read_trials(store, meta, surfaces, settings.paper.flat_margin, bar)
        store.clear_loso()  # the folder never holds a validation of another fit
        comp = compare_variants(trials, settings, validate=validate, seed=seed, advance=bar.advance)
    finally:
        bar.close()
    fits, table1, loso, loso_message = comp.fits, comp.table1, comp.loso, comp.loso_message
    selection, cpu = comp.selection, comp.cpu_s
    used = selection.model if model == "auto" else model
    order = [used, *[m for m in MODELS if m != used]]
    all_flags = {m: get(m).flags(fits[m]) for m in MODELS}
    flags = selection.flags() + all_flags[used]
    notes = [f for m in order[1:] for f in all_flags[m]]
    failures += [(tf.labels["trial"], tf.message) for sf in fits[used].values() for tf in sf.trials
                 if not tf.success]
    table1_all = pd.concat([table1[m].assign(model=m) for m in order], ignore_index=True)
    loso_all = None
    if loso is not None:
        loso_all = pd.concat([loso[m].table for m in order], ignore_index=True)
        write_validation(OutOfSample(table=loso_all, estimates=loso[used].estimates), store.loso_path)
    _write_outputs(store, trials, grids, meta, fits, order)
    store.write_fit_csv("table1", table1_all)
    store.write_fit_csv("comparison", selection.comparison)
    record = _fit_record(model, used, selection, fits, cpu, settings, flags, notes, len(trials), failures)
    record["analysis"] = {"trials": analysis}  # per trial: the digest of its stored tables
    record["loso"] = {"computed": loso is not None, "message": loso_message,
                      "csv": "loso.csv" if loso is not None else None}
    store.write_fit(FitResult(record))
    return FitSummary(model=used, requested=model, selection=selection, mu=record["mu"],
                      mu_ci={s: tuple(v) for s, v in record["mu_ci"].items()},
                      n_trials=len(trials), n_failed=len(failures), failures=tuple(failures),
                      messages=record["messages"], flags=tuple(flags), notes=tuple(notes),
                      lines=tuple(summary_lines(fits, flags + notes, order)), table1=table1_all, cpu_s=cpu,
                      loso=loso_all, loso_message=loso_message)


@dataclass(frozen=True)
class Comparison:
    """Every variant fitted to the same trials, validated and compared (:func:`compare_variants`).

    Attributes
    ----------
    fits : dict
        Variant -> subject -> subject fit.
    table1 : dict
        Variant -> its Table 1 (:func:`fingerfriction.model.stats.correlation_table`).
    loso : dict or None
        Variant -> its leave-one-surface-out validation (OutOfSample); None when not
        computed (see ``loso_message``).
    loso_message : str
    selection : Selection
    cpu_s : dict
        Variant -> CPU time in s of its fit.
    """

    fits: dict
    table1: dict
    loso: dict | None
    loso_message: str
    selection: Selection
    cpu_s: dict


def compare_variants(trials: Sequence, settings: FitSettings | None = None, *, validate: bool = True,
                     forward_step: float = FORWARD_STEP_MM, seed: int = 0, n_boot: int | None = 1000,
                     advance=None) -> Comparison:
    """Fit every variant to ``trials``, validate each out of sample (leave one surface out,
    on two surfaces or more) and choose (:func:`fingerfriction.fit.select.select_model`).

    Parameters
    ----------
    trials : sequence of fingerfriction.fit.Trial
    settings : FitSettings, optional
        The fits' settings (default: the defaults).
    validate : bool
        Run the leave-one-surface-out validation (the choice rests on it).
    forward_step : float
        Finger step in mm of the forward model's sweeps (trials on a coarser grid need the
        same step).
    seed : int
        Seed of the bootstrap intervals of Table 1.
    n_boot : int or None
        Bootstrap resamples of Table 1's intervals (None: none).
    advance : callable, optional
        Called with a label after each variant's fit and after the validation (a progress bar).

    Returns
    -------
    Comparison
    """
    settings = settings or FitSettings()
    trials = list(trials)
    advance = advance or (lambda _label: None)
    fits, cpu = _fit_all(trials, settings, advance)
    table1 = {m: correlation_table(fits[m], seed=seed, n_boot=n_boot) for m in MODELS}
    loso, loso_message = _validate(trials, settings, table1, validate, forward_step)
    advance("leave one surface out")
    selection = select_model({m: _evidence(m, fits[m], trials, table1[m], loso) for m in MODELS})
    return Comparison(fits=fits, table1=table1, loso=loso, loso_message=loso_message, selection=selection,
                      cpu_s=cpu)


def _evidence(name: str, fits: dict, trials: list, table1: pd.DataFrame, loso: dict | None) -> Evidence:
    """What one variant's fit shows, for the choice."""
    tfs = [tf for sf in fits.values() for tf in sf.trials]
    by_id = {t.id: t for t in trials}
    xs, meas, res, groups = [], [], [], []
    for tf in tfs:
        t = by_id.get(tf.labels.get("trial", ""))
        if t is None or not tf.success:
            continue
        used = tf.used
        xs.append(t.x[used])
        meas.append(tf.measured[used])
        res.append((tf.measured - tf.estimate)[used])
        groups.append((t.subject, t.surface.name))
    # a subject whose fit failed as a whole has no trial fits: its trials count as failed
    n_fitted = len(tfs)
    n_bad = sum(not tf.success for tf in tfs) + max(len(trials) - n_fitted, 0)
    return Evidence(table1=table1, loso=loso[name].table if loso is not None else None,
                    n_trials=len(trials), n_unphysical=n_bad,
                    residual=residual_structure(xs, meas, res, groups))


def _fit_record(requested: str, used: str, selection: Selection, fits: dict, cpu: dict, settings: FitSettings,
                flags: list, notes: list, n_trials: int, failures: list) -> dict:
    """The content of ``fit/fit.json`` (without ``loso``)."""
    v = get(used)
    s = settings
    return {
        "model": used,
        "requested": requested,
        "selection": selection.to_dict(),
        "model_notes": {m: get(m).note for m in MODELS},
        "footing": v.footing,
        "mu": {sub: sf.mu for sub, sf in fits[used].items()},
        "mu_ci": {sub: list(v.mu_ci(sf)) for sub, sf in fits[used].items()},
        "models": {m: _model_record(m, fits[m], cpu[m]) for m in MODELS},
        "mu_grid": {"start": float(s.grid[0]), "stop": float(s.grid[-1]),
                    "step": float(s.grid[1] - s.grid[0]) if s.grid.size > 1 else 0.0, "n": int(s.grid.size)},
        "method": s.method, "options": dataclasses.asdict(s.paper),
        "load_options": dataclasses.asdict(s.load),
        "messages": {sub: sf.message for sub, sf in fits[used].items()},
        "flags": [f.to_dict() for f in flags],
        "notes": [f.to_dict() for f in notes],
        "n_trials": n_trials, "failures": [{"trial": t, "reason": r} for t, r in failures],
        "finished": now(),
    }


def _read_trials(store: ResultsStore, meta: dict, surfaces: dict, flat_margin: float, bar):
    """``(trials, grids, failures)``: the analysed trials as fit inputs, per trial the
    positions with translated regions, and the trials that could not be prepared (why)."""
    trials, grids, failures = [], {}, []
    for tid in meta:
        try:  # a trial without a flat segment (the fit detrends over it) must not stop the others
            trial = store.read_fit_trial(meta[tid], surfaces, flat_margin=flat_margin)
            grids[tid] = trial.translated
            trials.append(trial)
        except (ValueError, KeyError, OSError) as exc:
            failures.append((tid, one_line(exc)))
        bar.advance(tid)
    if not trials:
        reasons = "; ".join(r for _, r in failures[:3])
        raise ValueError(f"no trial could be prepared for fitting: {reasons}")
    return trials, grids, failures


def _fit_all(trials: list, settings: FitSettings, advance) -> tuple[dict, dict]:
    """Every variant fitted to every subject: ``(fits, cpu_s)`` keyed by variant."""
    fits, cpu = {}, {}
    for m in MODELS:
        c0 = time.process_time()
        fits[m] = get(m).fit(trials, settings)
        cpu[m] = time.process_time() - c0
        advance(f"{m} model")
    return fits, cpu


def _model_record(name: str, fits: dict, cpu_s: float) -> dict:
    """The per-variant part of ``fit.json``."""
    v = get(name)
    return {"title": v.title, "family": v.family, "note": v.note, "footing": v.footing,
            "selectable": v.selectable, "cpu_s": round(cpu_s, 3),
            "mu": {s: sf.mu for s, sf in fits.items()},
            "success": {s: bool(sf.success) for s, sf in fits.items()},
            "messages": {s: sf.message for s, sf in fits.items()}, **v.record(fits)}


def _write_outputs(store: ResultsStore, trials: list, grids: dict, meta: dict, fits: dict,
                   order: list) -> None:
    """``fit/trials.csv``, ``fit/subjects.csv`` and ``fit/model/<trial-id>.parquet``; the
    first variant of ``order`` (the one used) gives the unprefixed columns."""
    by_id = {t.labels["trial"]: t for t in trials}
    per_trial: dict[str, dict[str, Any]] = {}
    rows, subj_rows = [], []
    for m in order:
        v = get(m)
        for subject, sf in fits[m].items():
            subj_rows.append({"subject": subject, "model": m, **v.subject_row(sf), "n_trials": len(sf.trials),
                              "n_failed": sum(not t.success for t in sf.trials), "success": sf.success,
                              "message": sf.message})
            for tf in sf.trials:
                tid = tf.labels["trial"]
                e = meta[tid]
                rows.append({"trial": tid, "model": m, "subject": subject, "surface": e["surface"],
                             "speed_mm_s": e["speed_mm_s"], "repetition": e.get("repetition"),
                             **v.trial_row(tf), "success": tf.success, "message": tf.message})
                per_trial.setdefault(tid, {})[m] = tf
    models: dict[str, FrictionModel] = {}
    names = ("F_T_N", "F_hat_N", "F_model_N", "F_int_N", "F_def_N", "p0_N_per_mm")
    for tid, by_model in per_trial.items():
        tr = by_id[tid]
        fm = models.setdefault(tr.surface.name, FrictionModel(tr.surface))
        nan = np.full(tr.n, np.nan)
        cols: dict[str, np.ndarray] = {}
        for m in order:  # a variant that could not fit this trial's subject: NaN columns
            got = get(m).columns(by_model[m], tr, fm) if m in by_model else {}
            cols.update({f"{m}_{name}": got.get(name, nan) for name in names})
        used = order[0]
        default = {name: cols[f"{used}_{name}"] for name in names[:5]}
        extra = {"F_N_N": tr.normal_abs if tr.has_absolute else nan,
                 "F_T_raw_N": tr.force, "regions_translated": grids[tid]}
        store.write_model(tid, pd.DataFrame({"x_mm": tr.x, **default, **extra, **cols}))
    store.write_fit_tables(pd.DataFrame(rows), pd.DataFrame(subj_rows))


def summary_lines(fits: dict, flags: Sequence, order: Sequence[str]) -> list[str]:
    """One line per subject and model (``order``: the used variant first): the parameters,
    then the flags grouped by kind with a count and the first example (never one line per
    trial)."""
    out = []
    for m in order:
        v = get(m)
        for subject, sf in fits[m].items():
            tag = f"subject {subject}, {v.title} ({m})" + (" (used)" if m == order[0] else "")
            n = len(sf.trials)
            head = v.summary(sf)
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


def _validate(trials: Sequence, settings: FitSettings, table1: dict, validate: bool, forward_step: float):
    """Leave-one-surface-out validation of every variant: ({variant: OutOfSample} or None,
    message)."""
    if not validate:
        return None, "not requested"
    n_surf = len({t.labels["surface"] for t in trials})
    if n_surf < 2:
        return None, f"needs at least two surfaces, the study has {n_surf}"
    t0 = time.perf_counter()
    try:
        res = validate_models(list(trials), MODELS, settings, in_sample=table1, forward_step=forward_step)
    except (ValueError, KeyError, OSError, RuntimeError, np.linalg.LinAlgError) as exc:
        # RuntimeError: no training fit succeeded for a held-out surface (pipeline.validation);
        # the fit itself stands, the validation is recorded as failed
        logger.warning("out-of-sample validation failed: %s", one_line(exc))
        return None, f"failed: {one_line(exc)}"
    logger.info("out-of-sample validation: %.1f s", time.perf_counter() - t0)
    return res, ""
