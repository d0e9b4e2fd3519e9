"""A study's data: what was recorded and what the analysis made of it.

* :mod:`.manifest` (with :mod:`.records`, the fields of its trial entries): the study
  folder's ``manifest.json``, the only manifest parser and path resolver
  (:func:`load_manifest`, :class:`Study`, :class:`TrialRecord`, ...);
* :mod:`.store` (with :mod:`.fitstore` and :mod:`.tables`): the results folder, its only
  reader and writer (:class:`ResultsStore`), and :mod:`.results`, the typed boundary it
  reads and writes (:class:`AnalysedTrial`, :class:`FitResult`);
* :mod:`.init` and :mod:`.patterns`: a manifest built from a folder of lab recordings;
* :mod:`.check`: every problem of a study listed at once.

The stages that read and write these data (one trial, the parallel analysis, the fit, the
validation) are in :mod:`fingerfriction.pipeline`. This package namespace holds the
manifest and the store."""

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
from .results import AnalysedTrial, FitResult, VideoInput
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
    "AnalysedTrial",
    "FitResult",
    "VideoInput",
    "frames_table",
    "regions_from_table",
]
