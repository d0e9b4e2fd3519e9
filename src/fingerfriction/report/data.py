"""Loading a results folder into memory for the figures and tables of the report."""

from __future__ import annotations

import json
import logging
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from ..study.store import ResultsStore, regions_from_table
from ..surfaces import Surface

__all__ = ["TrialData", "ReportData", "load_report_data"]

logger = logging.getLogger(__name__)


@dataclass(eq=False)
class TrialData:
    """One analysed trial.

    Attributes
    ----------
    id, subject, surface : str
    speed_mm_s : float
    repetition : int or None
    frames : pandas.DataFrame
        Per-frame table (``frame, t_s, x_mm, n_regions, a1, b1, ..., flag``).
    regions : (n_frames, n_max, 2) ndarray
        Contact regions in mm.
    forces : pandas.DataFrame
        Per-position table (``x_mm, F_T_N, t_s``).
    model : pandas.DataFrame or None
        Fit output per position (``x_mm, F_T_N, F_hat_N, F_model_N, F_int_N, F_def_N``)
        when :func:`fingerfriction.pipeline.fitting.fit` has run.
    status : dict
        The trial's ``status.json`` (inputs, stage diagnostics under ``info``).
    """

    id: str
    subject: str
    surface: str
    speed_mm_s: float
    repetition: int | None
    frames: pd.DataFrame
    regions: np.ndarray
    forces: pd.DataFrame
    model: pd.DataFrame | None = None
    status: dict = field(default_factory=dict)

    def sliding(self, *, min_speed_fraction: float = 0.2, half_span: int = 10) -> np.ndarray:
        """Frames in which the finger slides through the analysis window, ``(n_frames,)`` bool.

        The frames whose position x(t) lies inside the span of the force grid (the
        paper's 26 mm window, "Force data processing") and whose speed, a central
        difference over ``2 * half_span`` frames, is at least ``min_speed_fraction`` of
        the median speed of those frames. This leaves out the rest at touch-down (and
        any pause), in which a recording can spend a tenth of its frames with the
        finger still: counted as contact time, it lights up the resting contact's span
        in the occupancy map (Fig. 3) with a step at its edge.
        """
        fr = self.frames
        x = fr["x_mm"].to_numpy(float)
        t = fr["t_s"].to_numpy(float)
        xg = self.forces["x_mm"].to_numpy(float) if len(self.forces) else np.array([np.nan])
        lo, hi = (np.nanmin(xg), np.nanmax(xg)) if np.isfinite(xg).any() else (-np.inf, np.inf)
        with np.errstate(invalid="ignore"):
            inside = np.isfinite(x) & (x >= lo) & (x <= hi)
        k = int(half_span)
        v = np.full(x.size, np.nan)
        if x.size > 2 * k:
            v[k:-k] = (x[2 * k:] - x[:-2 * k]) / (t[2 * k:] - t[:-2 * k])
        ok = inside & np.isfinite(v)
        if not ok.any():
            return inside
        v_ref = float(np.median(np.abs(v[ok])))
        with np.errstate(invalid="ignore"):
            return inside & (np.abs(v) >= min_speed_fraction * v_ref)

    @property
    def force_history(self) -> list | None:
        """Every step of the trial's force processing with its parameters and fitted values
        (``status.json``, ``info.forces.history``); None for a trial analysed before the
        history was stored."""
        return ((self.status.get("info") or {}).get("forces") or {}).get("history")


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
    trials : list of TrialData
        The trials that finished OK, in manifest order.
    failed : list of (str, str)
        ``(trial_id, reason)`` of failed or unfinished trials.
    fit : dict or None
        ``fit/fit.json`` if present.
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
    """

    root: Path
    run: dict
    surfaces: dict[str, Surface]
    trials: list[TrialData]
    failed: list[tuple[str, str]]
    fit: dict | None = None
    fit_trials: pd.DataFrame | None = None
    truth: dict | None = None
    truth_dir: Path | None = None
    notes: list[str] = field(default_factory=list)
    loso: pd.DataFrame | None = None
    fit_table1: pd.DataFrame | None = None
    stale_fit: str | None = None

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

    def select(self, *, surface=None, subject=None, speed=None) -> list[TrialData]:
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
        frames = store.read_frames(tid)
        model = store.read_model(tid)
        trials.append(TrialData(
            id=tid, subject=str(m.get("subject")), surface=str(m.get("surface")),
            speed_mm_s=float(m.get("speed_mm_s") or math.nan), repetition=m.get("repetition"),
            frames=frames, regions=regions_from_table(frames), forces=store.read_forces(tid), model=model,
            status=st))
    if not trials:
        raise ValueError(f"{str(store.root)!r}: no trial finished OK; nothing to report")
    fit = store.read_fit_record()
    fit_trials = loso = fit_table1 = None
    stale_fit = store.fit_staleness(fit) if fit is not None else None
    if stale_fit is not None:  # a fit of other data is not shown as this data's fit
        fit = None
        for t in trials:
            t.model = None
    if fit is not None:
        fit_trials = store.read_fit_table()
        loso = store.read_loso()
        fit_table1 = store.read_fit_csv("table1")
    truth = truth_dir = None
    notes = []
    if run.get("truth"):
        truth_dir = Path(run["truth"])
        try:
            truth = json.loads((truth_dir / "study.json").read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError) as exc:
            notes.append(f"ground truth not readable ({exc}); the comparison with the truth is left out")
            truth_dir = None
    return ReportData(root=store.root, run=run, surfaces=surfaces, trials=trials, failed=failed, fit=fit,
                      fit_trials=fit_trials, truth=truth, truth_dir=truth_dir, notes=notes, loso=loso,
                      fit_table1=fit_table1, stale_fit=stale_fit)
