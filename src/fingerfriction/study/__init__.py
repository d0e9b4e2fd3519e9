"""A study and its results, in the order a trial flows through them.

* :mod:`.manifest`: the study folder's ``manifest.json``, the only manifest parser and path
  resolver (:func:`load_manifest`, :class:`Study`, :class:`TrialRecord`, ...);
* :mod:`.store`: the results folder, its only reader and writer (:class:`ResultsStore`);
* :mod:`.params`: the analysis options (:class:`~.params.AnalysisParams`) and the one
  definition of the pipeline's video options;
* :mod:`.trial`: one trial through the video and force stages
  (:func:`~.trial.process_trial`);
* :mod:`.analyze`: every trial in parallel on Dask, resumable, with a run record
  (:func:`~.analyze.analyze`);
* :mod:`.fitting`: the friction model fitted to the analysed trials
  (:func:`~.fitting.fit`).

This package namespace holds the manifest and the store (the data layer); the stages are
imported from their modules, e.g. ``from fingerfriction.study.analyze import analyze``.
"""

from __future__ import annotations

from .manifest import (
    FORCE_FORMATS,
    FORMAT_NAME,
    SCHEMA_VERSION,
    VIDEO_FORMATS,
    ForceInfo,
    ManifestError,
    Problem,
    Study,
    TrialRecord,
    VideoInfo,
    load_manifest,
    manifest_bytes,
    resolve_path,
    validate_id,
    write_manifest,
)
from .store import RESULTS_FORMAT, RESULTS_SCHEMA_VERSION, ResultsStore, frames_table, regions_from_table

__all__ = [
    "FORMAT_NAME",
    "SCHEMA_VERSION",
    "VIDEO_FORMATS",
    "FORCE_FORMATS",
    "ManifestError",
    "Problem",
    "VideoInfo",
    "ForceInfo",
    "TrialRecord",
    "Study",
    "validate_id",
    "resolve_path",
    "load_manifest",
    "write_manifest",
    "manifest_bytes",
    "RESULTS_FORMAT",
    "RESULTS_SCHEMA_VERSION",
    "ResultsStore",
    "frames_table",
    "regions_from_table",
]
