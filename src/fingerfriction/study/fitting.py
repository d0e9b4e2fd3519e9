"""The fit stage of the study pipeline: the friction model (Eq. 1-5 of Janko et al. 2018,
through :mod:`fingerfriction.fit`) fitted to the analysed trials of a results store:
``mu`` per subject by grid search, ``p0, p1`` per trial, the model forces with their
interfacial (Eq. 2) and deformation (Eq. 3) parts, then the out-of-sample validation
(leave one surface out, :func:`fingerfriction.predict.validate_results`).

The trials are read by :meth:`fingerfriction.study.store.ResultsStore.read_fit_trial`, the
same reader the validation uses; everything is written through the store.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from .. import fit as fitmod
from .._progress import ProgressBar
from ..model import FrictionModel
from ..predict.loso import validate_results
from .store import ResultsStore, now
from .trial import one_line

__all__ = ["FitSummary", "fit"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class FitSummary:
    """Summary of :func:`fit`.

    Attributes
    ----------
    mu : dict of str to float
        Per-subject friction coefficient.
    n_trials : int
        Trials fitted.
    n_failed : int
        Trial fits that did not succeed (or trials that could not be prepared).
    failures : tuple of (str, str)
        ``(trial_id, reason)``.
    messages : dict of str to str
        Per-subject grid-search message.
    loso : pandas.DataFrame or None
        The out-of-sample validation (:func:`fingerfriction.predict.validate_results`:
        leave one surface out, rho per held-out surface, one row per subject or "Both
        subjects" and surface), also in ``fit/loso.csv``; None when not computed (one
        surface only, ``validate=False``, or it failed: see ``loso_message``).
    loso_message : str
        How the validation went ('' when computed).
    """

    mu: dict
    n_trials: int
    n_failed: int
    failures: tuple[tuple[str, str], ...]
    messages: dict
    loso: Any = None
    loso_message: str = ""



def fit(
    results: str | os.PathLike,
    *,
    mu_grid: tuple[float, float, float] = (0.30, 0.90, 0.01),
    method: str = "lstsq",
    median_kernel: int = 11,
    progress: bool = True,
    validate: bool = True,
) -> FitSummary:
    """Fit the friction model to every finished trial of a results folder.

    ``mu`` per subject by grid search (every trial refitted at each grid value), ``p0``
    and ``p1`` per trial (:func:`fingerfriction.fit.fit_trials`), then the model forces
    of Eq. (4) with their parts F_int (Eq. 2) and F_def (Eq. 3) on each trial's grid.

    Parameters
    ----------
    results : path
        A results folder written by :func:`analyze`.
    mu_grid : (start, stop, step)
        Inclusive ``mu`` grid (default 0.30 to 0.90 by 0.01, 61 values).
    method : {'lstsq', 'nelder-mead'}
        How ``p0, p1`` are fitted (closed form by default; Nelder-Mead as the paper).
    median_kernel : int
        Median filter window in samples on the model (odd; 1 = off).
    progress : bool
        Show a progress bar.
    validate : bool
        Also run the out-of-sample validation (leave one surface out,
        :func:`fingerfriction.predict.validate_results`) when the study has at least two
        surfaces: ``fit/loso.csv`` and ``fit/loso.png``, shown next to Table 1 by the
        report. It costs about 20 s for 36 simulated trials (one process; measured).

    Returns
    -------
    FitSummary

    Writes ``fit/fit.json``, ``fit/subjects.csv``, ``fit/trials.csv``,
    ``fit/model/<trial-id>.parquet`` and, with ``validate``, ``fit/loso.csv`` and
    ``fit/loso.png`` (layout in :mod:`fingerfriction.study.store`). A validation that fails
    is logged and recorded in ``fit.json`` (``loso``); the fit itself stands.
    """
    store = ResultsStore(results)
    start, stop, step = (float(v) for v in mu_grid)
    grid = fitmod.mu_grid(start, stop, step)
    options = fitmod.FitOptions(median_kernel=int(median_kernel))
    surfaces = store.surfaces()
    meta = {t["id"]: t for t in store.analysed_trials()}

    trials, tids, failures = [], [], []
    ok_ids = list(meta)
    if not ok_ids:
        raise ValueError(f"{str(store.root)!r} has no successfully analysed trial to fit")
    bar = ProgressBar(progress, len(ok_ids) + 1, "fit")
    grids: dict[str, np.ndarray] = {}  # per trial: positions with translated regions
    try:
        for tid in ok_ids:
            try:  # a trial without a flat segment (the fit detrends over it) must not stop the others
                trial, grids[tid] = store.read_fit_trial(meta[tid], surfaces, flat_margin=options.flat_margin)
                trials.append(trial)
                tids.append(tid)
            except (ValueError, KeyError, OSError) as exc:
                failures.append((tid, one_line(exc)))
            bar.advance(tid)
        if not trials:
            reasons = "; ".join(r for _, r in failures[:3])
            raise ValueError(f"no trial could be prepared for fitting: {reasons}")
        fits = fitmod.fit_trials(trials, grid=grid, method=method, options=options)
        bar.advance("grid search")
    finally:
        bar.close()

    rows, subj_rows = [], []
    by_id = {t.labels["trial"]: t for t in trials}
    models: dict[str, Any] = {}
    for subject, sf in fits.items():
        subj_rows.append({"subject": subject, "mu": sf.mu, "objective": float(np.min(sf.curve)),
                          "success": sf.success, "message": sf.message})
        for tf in sf.trials:
            tid = tf.labels["trial"]
            tr = by_id[tid]
            m = meta[tid]
            rows.append({"trial": tid, "subject": subject, "surface": m["surface"],
                         "speed_mm_s": m["speed_mm_s"], "repetition": m.get("repetition"),
                         "mu": tf.mu, "p0": tf.p0, "p1": tf.p1, "objective": tf.objective,
                         "success": tf.success, "message": tf.message})
            if not tf.success:
                failures.append((tid, tf.message))
            model = models.setdefault(m["surface"], FrictionModel(tr.surface))
            # Eq. (2)-(4) with the fitted p0, p1 as they are (FrictionParams would refuse
            # the unphysical p0 < 0 of a failed fit; its row in trials.csv says it failed).
            B = model.basis(tr.regions, tf.mu)
            f_int, f_def = tf.p0 * B[:, 0], tf.p1 * B[:, 1]
            f_tot = f_int + f_def
            df = pd.DataFrame({"x_mm": tr.x, "F_T_N": tf.measured, "F_hat_N": tf.estimate,
                               "F_model_N": f_tot, "F_int_N": f_int, "F_def_N": f_def,
                               "F_T_raw_N": tr.force, "regions_translated": grids[tid]})
            store.write_model(tid, df)
    trials_df = pd.DataFrame(rows)
    subj_df = pd.DataFrame(subj_rows)
    store.write_fit_tables(trials_df, subj_df)
    record = {
        "mu_grid": {"start": start, "stop": stop, "step": step, "n": int(grid.size)},
        "method": method, "options": dataclasses.asdict(options),
        "mu": {s: sf.mu for s, sf in fits.items()},
        "curves": {s: {"grid": sf.grid, "objective": sf.curve} for s, sf in fits.items()},
        "messages": {s: sf.message for s, sf in fits.items()},
        "n_trials": len(trials), "failures": [{"trial": t, "reason": r} for t, r in failures],
        "finished": now(),
    }
    store.write_fit_record(record)  # validate_results reads the grid from it
    loso, loso_message = _validate_after_fit(store, trials, validate)
    record["loso"] = {"computed": loso is not None, "message": loso_message,
                      "csv": "loso.csv" if loso is not None else None}
    store.write_fit_record(record)
    return FitSummary(mu={s: sf.mu for s, sf in fits.items()}, n_trials=len(trials), n_failed=len(failures),
                      failures=tuple(failures), messages={s: sf.message for s, sf in fits.items()},
                      loso=loso, loso_message=loso_message)


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
        res = validate_results(store.root)
    except (ValueError, KeyError, OSError, RuntimeError, np.linalg.LinAlgError) as exc:
        # RuntimeError: no training fit succeeded for a held-out surface (predict.loso);
        # the fit itself stands, the validation is recorded as failed
        logger.warning("out-of-sample validation failed: %s", one_line(exc))
        return None, f"failed: {one_line(exc)}"
    logger.info("out-of-sample validation: %.1f s", time.perf_counter() - t0)
    return res.table, ""
