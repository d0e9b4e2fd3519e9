"""The demo: simulate the built-in default study (the paper's design), analyse it, fit the
friction model and write the report, in one call (``fingerfriction demo``)."""

from __future__ import annotations

import os
import time
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ._progress import stage_progress
from .pipeline.analyze import AnalyzeResult, analyze
from .pipeline.fitting import FitSummary, fit
from .pipeline.params import AnalysisParams, sim_params
from .report import make_report
from .sim import SimOptions, simulate_study

__all__ = ["DEMO_REPS", "FULL_REPS", "DemoResult", "demo"]

#: Repetitions per condition of the demo: 1 by default (2 subjects x 6 surfaces x 3 speeds
#: = 36 trials, every cell of Table 1 filled and every speed in Fig. 4), 5 with ``full``
#: (the paper's 180 trials).
DEMO_REPS = 1
FULL_REPS = 5


@dataclass(frozen=True)
class DemoResult:
    """What :func:`demo` produced: the folders, and each step's summary."""

    study: Path
    results: Path
    analysis: AnalyzeResult
    fit: FitSummary
    report: Any
    elapsed_s: dict



def demo(out: str | os.PathLike, *, full: bool = False, reps: int | None = None, seed: int = 0,
         n_workers: int | None = None, progress: bool = True, design: Mapping | None = None) -> DemoResult:
    """Simulate the built-in default study, analyse it, fit the model and write the report.

    Parameters
    ----------
    out : path
        Folder receiving ``study/`` (the virtual experiment) and ``results/``. Re-running
        on the same folder resumes: finished trials are neither simulated nor analysed
        again.
    full : bool
        The paper's full design, 180 trials (5 repetitions); default: :data:`DEMO_REPS`
        repetition(s), 36 trials.
    reps : int, optional
        Repetitions per condition, overriding ``full``.
    seed : int
        Seed of the virtual experiment.
    n_workers : int, optional
        Worker processes for simulation and analysis (default: all cores).
    progress : bool
        Progress bars on stderr.
    design : dict, optional
        Overrides of the simulated design (``subjects``, ``surfaces``, ``speeds``), e.g.
        for a smaller demo; default: the paper's 2 subjects x 6 surfaces x 3 speeds.

    Returns
    -------
    DemoResult
    """
    out = Path(out)
    reps = reps if reps is not None else (FULL_REPS if full else DEMO_REPS)
    study, results = out / "study", out / "results"
    times = {}
    t0 = time.perf_counter()
    cb, close = stage_progress(progress, "simulate")
    try:
        simulate_study(study, SimOptions(reps=reps, seed=seed, **dict(design or {})), workers=n_workers,
                       progress=cb,
                       description="fingerfriction demo: the paper's design, simulated")
    finally:
        close()
    times["simulate"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    ares = analyze(study, results, n_workers=n_workers, progress=progress,
                   params=AnalysisParams(**sim_params()))
    times["analyze"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    fres = fit(results, progress=progress)
    times["fit"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    rep = make_report(results, progress=progress)
    times["report"] = time.perf_counter() - t0
    return DemoResult(study=study, results=results, analysis=ares, fit=fres, report=rep, elapsed_s=times)
