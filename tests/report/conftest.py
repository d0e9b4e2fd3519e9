"""Fixtures of the report tests."""

from __future__ import annotations

import pytest
from report_synthetic import write_synthetic_results


@pytest.fixture(scope="session")
def synthetic_results(tmp_path_factory):
    """(results folder after analyze-equivalent + fit, truth dict)."""
    from fingerfriction.pipeline.fitting import fit

    base = tmp_path_factory.mktemp("synthetic")
    truth = write_synthetic_results(base / "results", truth_dir=base / "study" / "truth")
    fit(base / "results", progress=False)
    return base / "results", truth
