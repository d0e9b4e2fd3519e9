"""The console of `fingerfriction fit` on a study whose fits fail: one warning line per
subject and one summary line, not one line per trial, fold and grid point."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest
from report_synthetic import SUBJECTS, write_synthetic_results

from fingerfriction.study.store import ResultsStore

SRC = Path(__file__).resolve().parents[2] / "src"


@pytest.fixture(scope="module")
def failing(tmp_path_factory):
    """Synthetic results where every second repetition's force is upside down: p0 < 0 (the
    paper's model) and p1 < 0 (the load-consistent one), unphysical fits, for both subjects."""
    root = tmp_path_factory.mktemp("failing") / "r"
    write_synthetic_results(root)
    store = ResultsStore(root)
    for tid in store.trial_ids():
        if tid.endswith("-r2"):
            p = store.trial_dir(tid) / "forces.parquet"
            f = pd.read_parquet(p)
            for col in ("F_T_N", "F_T_abs_N"):
                if col in f:
                    f[col] = -f[col]
            f.to_parquet(p)
    return root


def _fit(results: Path, *args: str) -> list[str]:
    env = {"PYTHONPATH": str(SRC), "PATH": "/usr/bin:/bin", "COLUMNS": "200"}
    r = subprocess.run([sys.executable, "-m", "fingerfriction.cli", "fit", str(results), *args],
                       capture_output=True, text=True, env=env, timeout=600)
    assert r.returncode == 1, r.stdout + r.stderr  # 8 trials' fits failed: status 1, all else written
    return [ln for ln in (r.stdout + r.stderr).splitlines() if ln.strip()]


@pytest.mark.slow
def test_fit_console_one_warning_per_subject_and_one_summary(failing):
    lines = _fit(failing)
    warnings = [ln for ln in lines if ln.startswith("warning:")]
    summary = [ln for ln in lines if ln.startswith("fit:")]
    assert len(summary) == 1 and len(lines) == len(warnings) + 1, lines
    assert 1 <= len(warnings) <= len(SUBJECTS), lines
    for subj in SUBJECTS:  # each subject's failed fits: counted by kind, with one example
        line = next(ln for ln in warnings if ln.startswith(f"warning: subject {subj}:"))
        assert "paper model negative-p0 in 4 trials (e.g. s" in line and "unphysical" in line
        assert line.count("negative-p0") == 1
    # the summary: counts, time, where the output is, the logged warnings grouped by kind
    s = summary[0]
    assert "16 trials" in s and "8 failed" in s and " s; output in " in s and str(failing / "fit") in s
    kinds = s.split("logged warning")[-1]
    for k in ("leave-one-surface-out", "out-of-sample validation failed"):  # each kind once
        assert kinds.count(f"'{k}'") <= 1
    # quiet: the summary line alone; verbose: every failed trial on its own line
    quiet = _fit(failing, "--quiet")
    assert len(quiet) == 1 and quiet[0].startswith("fit: 16 trials")
    verbose = _fit(failing, "--verbose")
    assert sum(ln.startswith("warning: error negative-p0 (paper model) s") for ln in verbose) == 8
    assert len(verbose) > len(lines)
