"""The console of `fingerfriction fit` on a study whose fits fail: one warning line per
subject and one summary line, not one line per trial, fold and grid point."""

from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from report_synthetic import SUBJECTS, write_synthetic_results
from typer.testing import CliRunner

from fingerfriction.cli import app
from fingerfriction.study.store import ResultsStore

#: One speed: 8 trials, 2 subjects x 2 surfaces x 2 repetitions (what the console groups;
#: the synthetic results' second speed would only double every count and the fits' time).
SPEED = 120.0
N_TRIALS = len(SUBJECTS) * 2 * 2


@pytest.fixture(scope="module")
def failing(tmp_path_factory):
    """Synthetic results where every second repetition's force is upside down: p0 < 0 (the
    paper's model) and p1 < 0 (the load-consistent one), unphysical fits, for both subjects."""
    root = tmp_path_factory.mktemp("failing") / "r"
    write_synthetic_results(root, speeds=(SPEED,))
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


def _fit(results: Path, *args: str) -> tuple[list[str], list[str], int]:
    """(stdout lines, stderr lines, exit status) of `fingerfriction fit`, run in this process
    (CliRunner keeps stdout and stderr apart; the console is 200 columns wide, tests/conftest.py):
    the fits of one study share the forward sweeps of their validation (the process's memo)."""
    r = CliRunner().invoke(app, ["fit", str(results), *args])
    assert r.exit_code in (0, 1), r.output + repr(r.exception)
    out = [ln for ln in r.stdout.splitlines() if ln.strip()]
    return out, [ln for ln in r.stderr.splitlines() if ln.strip()], r.exit_code


@pytest.mark.slow
def test_fit_console_one_warning_per_subject_and_one_summary(failing):
    # the paper's variant forced: its flags are the study's
    out, err, status = _fit(failing, "--model", "paper")
    warnings = [ln for ln in err if ln.startswith("warning:")]
    summary = [ln for ln in out if ln.startswith("fit:")]
    assert len(summary) == 1 and len(warnings) == len(SUBJECTS), err
    for subj in SUBJECTS:  # each subject's failed fits: counted by kind, with one example
        line = next(ln for ln in warnings if ln.startswith(f"warning: subject {subj}:"))
        assert f"paper model negative-p0 in {N_TRIALS // 4} trials (e.g. s" in line and "unphysical" in line
        assert line.count("negative-p0") == 1
    # a study half of whose forces are upside down: no variant passes, exit status 1, the
    # error with its reason on its own line, and the summary says it
    assert status == 1 and [ln for ln in err if ln.startswith("error: model rejected: no variant passes")]
    # the summary: counts, time, where the output is, the logged warnings grouped by kind
    s = summary[0]
    assert f"{N_TRIALS} trials" in s and f"{N_TRIALS // 2} failed" in s and " s; output in " in s
    assert str(failing / "fit") in s
    assert "paper model used (forced, MODEL REJECTED)" in s
    kinds = s.split("logged warning")[-1]
    for k in ("leave-one-surface-out", "out-of-sample validation failed"):  # each kind once
        assert kinds.count(f"'{k}'") <= 1
    # the tables: Table 1 of the model used, titled with it, before the comparison
    text = "\n".join(out)
    assert text.index("Table 1 of The paper's Eq. 4 (paper)") < text.index("Which model the data support")
    # quiet: the summary line alone; verbose: every failed trial on its own line
    out_q, err_q, status_q = _fit(failing, "--quiet", "--model", "paper")
    assert out_q == summary[:1] or (len(out_q) == 1 and out_q[0].startswith(f"fit: {N_TRIALS} trials"))
    assert err_q == [] and status_q == 1
    out_v, err_v, _ = _fit(failing, "--verbose", "--model", "paper")
    assert sum(ln.startswith("warning: error negative-p0 (paper model) s") for ln in err_v) == N_TRIALS // 2
    assert len(err_v) > len(err)


@pytest.mark.slow
def test_fit_console_by_default_the_comparison_variants_flags_are_notes(failing):
    out, err, _ = _fit(failing)
    # the paper variant's unphysical p0 is a note on the comparison, not a warning of the study
    assert not any("paper model" in ln for ln in err if ln.startswith("warning:"))
    notes = [ln for ln in out if ln.startswith("notes on the comparison variants")]
    assert len(notes) == 1 and f"paper negative-p0 x{N_TRIALS // 2}" in notes[0]


def test_the_comparison_prints_when_a_column_is_unknown_in_every_variant(capsys):
    """fit.json writes NaN as null: a study without two trials per surface has no residual
    structure in any variant, a column of nulls; the console shows '-' (it crashed)."""
    from fingerfriction.cli.study import _print_fit_tables
    from fingerfriction.report import comparison_frame

    rows = [{"model": m, "title": m, "family": m, "verdict": v, "why": "", "n_trials": 2, "n_unphysical": 0,
             "table1_cells_ok": 2, "table1_cells": 2, "loso_cells_ok": None, "loso_cells": None,
             "cv_rho_mean": None, "residual_structure": None}
            for m, v in (("load", "chosen"), ("paper", "comparison only"))]
    comp = comparison_frame(rows)
    assert comp["residual_structure"].dtype.kind == "f" and comp["model"].tolist() == ["load", "paper"]
    _print_fit_tables("load", None, None, comp)
    out = capsys.readouterr().out
    assert "Which model the data support" in out and "* load" in out and "Traceback" not in out
