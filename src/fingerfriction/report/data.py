"""Loading a results folder into memory for the figures and tables of the report: what the
results store returns (:class:`~fingerfriction.study.results.AnalysedTrial` per trial, the
:class:`~fingerfriction.study.results.FitResult`), nothing read around it."""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from ..study.results import AnalysedTrial, FitResult
from ..study.store import ResultsStore
from ..surfaces import Surface

__all__ = ["ReportData", "load_report_data"]

logger = logging.getLogger(__name__)


@dataclass(eq=False)
class ReportData:
    """Everything the report needs.

    Attributes
    ----------
    root : Path
        The results folder.
    run : dict
        The run record (``run.json``).
    surfaces : dict of str to Surface
    trials : list of AnalysedTrial
        The trials that finished OK, in manifest order, with the fit's model forces.
    failed : list of (str, str)
        ``(trial_id, reason)`` of failed or unfinished trials.
    fit : FitResult or None
        The fit (``fit/fit.json``) if present (a JSON object given here is read as one).
    fit_trials : pandas.DataFrame or None
        ``fit/trials.csv`` if present.
    loso : pandas.DataFrame or None
        ``fit/loso.csv`` (the out-of-sample validation written by ``fit``) if present.
    fit_table1 : pandas.DataFrame or None
        ``fit/table1.csv`` (Table 1 of each model variant with bootstrap confidence
        intervals, written by ``fit``) if present.
    stale_fit : str or None
        Why ``fit/`` no longer describes the analysed trials (they were analysed again
        since, :meth:`~fingerfriction.study.store.ResultsStore.fit_staleness`); the fit is
        then left out (``fit`` None) and the report says so at its top.
    truth : dict or None
        ``truth/study.json`` of a simulated study, if the study folder is reachable.
    truth_dir : Path or None
    loso_figure : bytes or None
        ``fit/loso.png``, the figure of the out-of-sample validation, if drawn.
    """

    root: Path
    run: dict
    surfaces: dict[str, Surface]
    trials: list[AnalysedTrial]
    failed: list[tuple[str, str]]
    fit: FitResult | None = None
    fit_trials: pd.DataFrame | None = None
    truth: dict | None = None
    truth_dir: Path | None = None
    notes: list[str] = field(default_factory=list)
    loso: pd.DataFrame | None = None
    fit_table1: pd.DataFrame | None = None
    stale_fit: str | None = None
    loso_figure: bytes | None = None

    def __post_init__(self) -> None:
        if isinstance(self.fit, Mapping):
            self.fit = FitResult.from_dict(self.fit)

    @property
    def surface_names(self) -> list[str]:
        """Surfaces with at least one trial, in the manifest's order."""
        seen = []
        for t in self.trials:
            if t.surface not in seen:
                seen.append(t.surface)
        order = list(self.surfaces)
        return sorted(seen, key=lambda s: order.index(s) if s in order else math.inf)

    @property
    def subjects(self) -> list[str]:
        return sorted({t.subject for t in self.trials})

    @property
    def speeds(self) -> list[float]:
        return sorted({float(t.speed_mm_s) for t in self.trials})

    def select(self, *, surface=None, subject=None, speed=None) -> list[AnalysedTrial]:
        return [
            t for t in self.trials
            if (surface is None or t.surface == surface)
            and (subject is None or t.subject == subject)
            and (speed is None or float(t.speed_mm_s) == float(speed))
        ]


def load_report_data(results) -> ReportData:
    """Read a results folder (after ``analyze``, optionally ``fit``).

    Raises
    ------
    ValueError
        If the folder is not a results folder or no trial finished OK.
    """
    store = ResultsStore(results)
    run = store.read_run()
    surfaces = store.surfaces()
    trials, failed = [], []
    for m in run.get("trials", []):
        tid = m["id"]
        st = store.status(tid)
        if st is None or st.get("status") != "ok":
            failed.append((tid, (st or {}).get("reason") or "not analysed (run interrupted?)"))
            continue
        trials.append(store.read_trial(m, status=st, model=True))
    if not trials:
        raise ValueError(f"{str(store.root)!r}: no trial finished OK; nothing to report")
    fit = store.read_fit()
    fit_trials = loso = fit_table1 = loso_figure = None
    stale_fit = store.fit_staleness(fit) if fit is not None else None
    if stale_fit is not None:  # a fit of other data is not shown as this data's fit
        fit = None
        for t in trials:
            t.model = None
    if fit is not None:
        fit_trials = store.read_fit_table()
        loso = store.read_loso()
        fit_table1 = store.read_fit_csv("table1")
        loso_figure = store.read_loso_figure() if loso is not None else None
    truth, truth_dir, notes = store.read_truth()
    return ReportData(root=store.root, run=run, surfaces=surfaces, trials=trials, failed=failed, fit=fit,
                      fit_trials=fit_trials, truth=truth, truth_dir=truth_dir, notes=notes, loso=loso,
                      fit_table1=fit_table1, stale_fit=stale_fit, loso_figure=loso_figure)
