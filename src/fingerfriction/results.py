"""Deprecated: the results store now lives in :mod:`fingerfriction.study.store` (and the
atomic writers in :mod:`fingerfriction._atomic`). This module re-exports the former names
for one release."""

from __future__ import annotations

import warnings

from .study.store import (
    RESULTS_FORMAT,
    RESULTS_SCHEMA_VERSION,
    TRIAL_FORMAT,
    ResultsStore,
    atomic_write_bytes,
    atomic_write_json,
    atomic_write_parquet,
    atomic_write_text,
    frames_table,
    params_digest,
    regions_from_table,
    sha256_file,
)

warnings.warn("fingerfriction.results is deprecated: use fingerfriction.study.store", DeprecationWarning,
              stacklevel=2)

__all__ = [
    "RESULTS_FORMAT",
    "RESULTS_SCHEMA_VERSION",
    "TRIAL_FORMAT",
    "ResultsStore",
    "atomic_write_bytes",
    "atomic_write_text",
    "atomic_write_json",
    "atomic_write_parquet",
    "sha256_file",
    "params_digest",
    "frames_table",
    "regions_from_table",
]
