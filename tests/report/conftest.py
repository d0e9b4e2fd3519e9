"""Fixtures of the report tests."""

from __future__ import annotations

import pytest
from report_synthetic import write_synthetic_results

from shared_inputs import once_per_run


@pytest.fixture(scope="session")
def synthetic_results(tmp_path_factory):
    """(results folder after analyze-equivalent + fit, truth dict). Built once per run
    (shared by the xdist workers): read-only, a test that writes into it copies it."""

    def build(base):
        from fingerfriction.pipeline.fitting import fit

        truth = write_synthetic_results(base / "results", truth_dir=base / "study" / "truth")
        fit(base / "results", progress=False)
        return truth

    base, truth = once_per_run(tmp_path_factory, "synthetic-results", build)
    return base / "results", truth
