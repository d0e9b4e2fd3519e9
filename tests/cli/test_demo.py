"""The `demo` command: simulate -> analyze -> fit -> report, tables printed, resumable."""

import re
import shutil

import pytest
from typer.testing import CliRunner

from fingerfriction.cli import app
from fingerfriction.fit.variants import get
from shared_inputs import SMALL_DEMO


@pytest.mark.slow
def test_demo_small_design_end_to_end_and_resumed(small_demo, tmp_path):
    demo, output = small_demo  # `demo` on the small design (tests/conftest.py), run once per test run
    assert "Table 1" in output and "Tactile blind spots" in output
    # as a new user reads it: the first Table 1 names its model, the one the fit chose
    text = " ".join(output.split())
    first = re.search(r"Table 1 of the model used, (.+?) \((\w+)\): Pearson rho", text)
    assert first and text.index("Table 1") == first.start(), text[:2000]
    assert first.group(1) == get(first.group(2)).title
    assert "demo: 2 trials," in text and f"{first.group(2)} model: mu 0." in text  # the summary line
    # why that model, after the tables: two surfaces, so no comparison out of sample
    assert f"model: {first.group(2)} (" in text and "not cross-validated: too few surfaces" in text
    assert "2 computed, 0 already done, 0 failed" in text
    assert (demo / "results" / "report" / "index.html").is_file()
    assert (demo / "study" / "manifest.json").is_file()
    shutil.copytree(demo, tmp_path / "demo")  # the second run (on a copy) finds everything done
    r = CliRunner().invoke(app, ["demo", "--out", str(tmp_path / "demo"), *SMALL_DEMO])
    assert r.exit_code == 0, r.output
    assert "0 computed, 2 already done, 0 failed" in " ".join(r.output.split())


def test_demo_bad_options_are_one_line_errors(tmp_path):
    r = CliRunner().invoke(app, ["demo", "--out", str(tmp_path / "d"), "--speeds", "fast"])
    assert r.exit_code == 2 and "--speeds must be numbers" in r.output and "Traceback" not in r.output
    r = CliRunner().invoke(app, ["demo", "--out", str(tmp_path / "d"), "--surfaces", "no-such-surface"])
    assert r.exit_code == 2 and "no-such-surface" in r.output and "Traceback" not in r.output


def test_demo_and_fit_summaries_give_mu_with_its_interval():
    from types import SimpleNamespace

    from fingerfriction.cli.study import _mu_text

    res = SimpleNamespace(mu={"1": 0.550031, "2": 0.6, "3": float("nan")},
                          mu_ci={"1": (0.549972, 0.550091), "2": (float("nan"), float("nan"))})
    assert _mu_text(res) == ("0.55003 [0.54997, 0.55009] (subject 1), 0.600 (subject 2), "
                             "not measured (subject 3)")
