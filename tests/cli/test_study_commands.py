"""The analyze / fit / report commands: thin, one-line errors, tables printed."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from fingerfriction.cli import app

sys.path.insert(0, str(Path(__file__).parents[1] / "report"))
from report_synthetic import write_synthetic_results  # noqa: E402

runner = CliRunner()


def test_analyze_missing_study_is_one_line_error(tmp_path):
    r = runner.invoke(app, ["analyze", str(tmp_path / "nope"), "--out", str(tmp_path / "out")])
    assert r.exit_code == 2
    assert "does not exist" in r.output and "Traceback" not in r.output


def test_analyze_bad_window_is_one_line_error(tmp_path):
    r = runner.invoke(app, ["analyze", str(tmp_path), "--out", str(tmp_path / "out"), "--window-mm", "-3"])
    assert r.exit_code == 2 and "--window-mm must be in [1, 100] mm" in r.output
    assert "Traceback" not in r.output


@pytest.mark.slow
def test_fit_and_report_on_a_results_folder(tmp_path):
    write_synthetic_results(tmp_path / "r", truth_dir=tmp_path / "study" / "truth")
    r = runner.invoke(app, ["fit", str(tmp_path / "r")])
    assert r.exit_code == 0, r.output
    assert "fit: 16 trials, both models, load the default, mu 0." in r.output and "(subject 1)" in r.output
    r = runner.invoke(app, ["report", str(tmp_path / "r")])
    assert r.exit_code == 0, r.output
    assert "Table 1" in r.output and "blind spots" in r.output and "index.html" in r.output
    assert (tmp_path / "r" / "report" / "index.html").is_file()


def test_fit_on_a_folder_that_is_not_a_results_folder(tmp_path):
    r = runner.invoke(app, ["fit", str(tmp_path)])
    assert r.exit_code == 2 and "not a results folder" in r.output
    r = runner.invoke(app, ["report", str(tmp_path)])
    assert r.exit_code == 2 and "not a results folder" in r.output
