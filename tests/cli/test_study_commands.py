"""The analyze / fit / report commands: thin, one-line errors, tables printed."""

from __future__ import annotations

import shutil

import pytest
from typer.testing import CliRunner

from fingerfriction.cli import app

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
def test_fit_and_report_on_a_results_folder(forward_fit, tmp_path):
    # the forward model's contact, forces of a constant pressure: a variant of that family
    fitted, exit_code, output = forward_fit  # `fit` on them (tests/conftest.py)
    assert exit_code == 0, output
    assert "fit: 16 trials, " in output and "model used (chosen by --model auto), mu 0." in output
    assert "(subject 1)" in output and "model rejected" not in output
    # Table 1 of the model used, titled with its name, then the comparison with a model column
    i = output.index("Table 1 of the model used")
    assert i < output.index("Which model the data support") and "every model" in output
    shutil.copytree(fitted, tmp_path / "r")
    r = runner.invoke(app, ["report", str(tmp_path / "r")])
    assert r.exit_code == 0, r.output
    assert "Table 1" in r.output and "blind spots" in r.output and "index.html" in r.output
    assert (tmp_path / "r" / "report" / "index.html").is_file()


@pytest.mark.slow
def test_a_study_no_variant_explains_is_rejected_with_exit_status_1(rejected_fit, tmp_path):
    """Forces unrelated to the surface: every variant fails its bars, the study gets the
    error 'model rejected', printed with its reason, and fit and report say so."""
    fitted, exit_code, output = rejected_fit  # `fit` on them (tests/conftest.py)
    assert exit_code == 1, output
    assert "error: model rejected: no variant passes the bars (load: " in " ".join(output.split())
    assert "MODEL REJECTED" in output and "Traceback" not in output
    shutil.copytree(fitted, tmp_path / "r")
    r = runner.invoke(app, ["report", str(tmp_path / "r")])
    assert r.exit_code == 0, r.output  # the report was written; the error is the fit's
    assert "error: model rejected" in r.output
    html = (tmp_path / "r" / "report" / "index.html").read_text()
    assert html.index('id="model-rejected"') < html.index("<h2>Summary</h2>")


def test_fit_on_a_folder_that_is_not_a_results_folder(tmp_path):
    r = runner.invoke(app, ["fit", str(tmp_path)])
    assert r.exit_code == 2 and "not a results folder" in r.output
    r = runner.invoke(app, ["report", str(tmp_path)])
    assert r.exit_code == 2 and "not a results folder" in r.output
