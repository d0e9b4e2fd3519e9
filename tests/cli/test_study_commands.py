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
    r = runner.invoke(app, ["report", str(tmp_path / "r"), "--sample", "0"])  # the page, not the trials'
    assert r.exit_code == 0, r.output  # the report was written; the error is the fit's
    assert "error: model rejected" in r.output
    html = (tmp_path / "r" / "report" / "index.html").read_text()
    assert html.index('id="model-rejected"') < html.index("<h2>Summary</h2>")


def test_fit_on_a_folder_that_is_not_a_results_folder(tmp_path):
    r = runner.invoke(app, ["fit", str(tmp_path)])
    assert r.exit_code == 2 and "not a results folder" in r.output
    r = runner.invoke(app, ["report", str(tmp_path)])
    assert r.exit_code == 2 and "not a results folder" in r.output


def _captured_params(monkeypatch, tmp_path, *options):
    """The analysis parameters ``analyze`` would run with, given ``options`` (the run itself
    replaced by a stand-in that records them and stops)."""
    import fingerfriction.pipeline.analyze as stage

    seen = {}

    def stand_in(study, out, *, params, **kw):
        seen["params"] = params
        raise ValueError("stand-in: not run")

    monkeypatch.setattr(stage, "analyze", stand_in)
    r = runner.invoke(app, ["analyze", str(tmp_path), "--out", str(tmp_path / "out"), *options])
    assert "stand-in: not run" in r.output, r.output
    from fingerfriction.pipeline.params import force_params

    return force_params(seen["params"].forces)


def test_analyze_takes_the_sensors_high_pass(monkeypatch, tmp_path):
    """A lab whose sensor has a second pole, or another cut-off, says so on the command line."""
    f = _captured_params(monkeypatch, tmp_path)
    assert (f.highpass_model, f.sensor_highpass_hz, f.estimate_highpass) == ("first-order", 5.0, False)
    f = _captured_params(monkeypatch, tmp_path, "--highpass-model", "second-order", "--highpass-hz", "4")
    assert (f.highpass_model, f.sensor_highpass_hz) == ("second-order", 4.0)
    f = _captured_params(monkeypatch, tmp_path, "--estimate-highpass", "--highpass-hz", "6")
    assert f.estimate_highpass and f.sensor_highpass_hz == 6.0
    f = _captured_params(monkeypatch, tmp_path, "--highpass-hz", "0")
    assert f.sensor_highpass_hz is None


@pytest.mark.parametrize("options, says", [
    (("--highpass-model", "third-order"), "--highpass-model"),
    (("--highpass-model", "second-order", "--highpass-hz", "0"), "needs sensor_highpass_hz"),
    (("--highpass-hz", "-1"), "--highpass-hz must be in [0, 1000] Hz"),
])
def test_analyze_bad_high_pass_is_one_line_error(tmp_path, options, says):
    r = runner.invoke(app, ["analyze", str(tmp_path), "--out", str(tmp_path / "out"), *options])
    assert r.exit_code == 2 and says in r.output, r.output
    assert "Traceback" not in r.output
