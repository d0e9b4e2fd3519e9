"""Deprecated: the study pipeline now lives in :mod:`fingerfriction.study` and
:mod:`fingerfriction.demo`. This module re-exports the former names for one release.

=============================  ==============================================
former name                    new home
=============================  ==============================================
``AnalysisParams``, presets    :mod:`fingerfriction.study.params`
``process_trial``              :func:`fingerfriction.study.trial.process_trial`
``analyze``                    :func:`fingerfriction.study.analyze.analyze`
``fit``                        :func:`fingerfriction.study.fitting.fit`
``regions_on_grid``            :func:`fingerfriction.regions.regions_on_grid`
``demo``                       :func:`fingerfriction.demo.demo`
=============================  ==============================================
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

from .demo import DEMO_REPS, FULL_REPS, DemoResult, demo
from .regions import regions_on_grid
from .study.analyze import AnalyzeResult, TrialOutcome, analyze
from .study.fitting import FitSummary, fit
from .study.manifest import TrialRecord
from .study.params import (
    PIPELINE_VIDEO_DEFAULTS,
    POSITIONS,
    SIM_CF_CENTROID_PARAMS,
    SIM_PARAMS,
    AnalysisParams,
    sim_params,
)
from .study.trial import TrialInput, TrialResult
from .study.trial import process_trial as _process_trial

warnings.warn("fingerfriction.pipeline is deprecated: use fingerfriction.study (analyze, fitting, params, "
              "trial) and fingerfriction.demo", DeprecationWarning, stacklevel=2)

__all__ = [
    "AnalysisParams",
    "TrialResult",
    "TrialOutcome",
    "AnalyzeResult",
    "FitSummary",
    "DemoResult",
    "process_trial",
    "analyze",
    "fit",
    "demo",
    "regions_on_grid",
    "sim_params",
    "POSITIONS",
    "PIPELINE_VIDEO_DEFAULTS",
    "SIM_PARAMS",
    "SIM_CF_CENTROID_PARAMS",
    "DEMO_REPS",
    "FULL_REPS",
]


def process_trial(study_dir: str | os.PathLike, trial, params: AnalysisParams | None = None, *,
                  surface_spec: dict | None = None) -> TrialResult:
    """Deprecated form of :func:`fingerfriction.study.trial.process_trial`: a trial given as
    its manifest record (or its dict) and its surface spec."""
    rec = trial if isinstance(trial, TrialRecord) else TrialRecord.from_dict(dict(trial))
    return _process_trial(TrialInput(Path(study_dir).resolve(), rec, dict(surface_spec or {})), params)
