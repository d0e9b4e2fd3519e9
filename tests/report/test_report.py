"""Report: figures, tables and the self-contained HTML of fingerfriction.report."""

from __future__ import annotations

import base64
import re
import shutil

import numpy as np
import pandas as pd
import pytest

from fingerfriction.fit.variants import MODELS
from fingerfriction.report import make_report
from fingerfriction.report.data import load_report_data
from fingerfriction.report.figures import FIGURES
from fingerfriction.study.store import ResultsStore
from shared_inputs import once_per_run


@pytest.fixture(scope="module")
def report(synthetic_results, tmp_path_factory):
    """The report of a copy of the synthetic results (the report is written into the
    results folder), made once per run (tests/shared_inputs.py): read-only to the tests."""
    shared, truth = synthetic_results

    def build(folder):
        shutil.copytree(shared, folder / "results")
        return make_report(folder / "results")

    folder, rep = once_per_run(tmp_path_factory, "synthetic-report", build)
    return rep, folder / "results", truth


@pytest.mark.slow
def test_every_figure_written_as_png_and_svg(report):
    rep, results, _ = report
    for stem, *_ in FIGURES:
        png = results / "report" / f"{stem}.png"
        svg = results / "report" / f"{stem}.svg"
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n", stem
        assert b"<svg" in svg.read_bytes()[:2000], stem


@pytest.mark.slow
def test_html_is_self_contained(report):
    rep, results, _ = report
    html = rep.html.read_text()
    imgs = re.findall(r'<img src="([^"]+)"', html)
    assert len(imgs) == len(FIGURES) + 1  # and fit/loso.png
    assert 'alt="Leave one surface out' in html
    for src in imgs:  # every image embedded, none refers to a file next to the report
        assert src.startswith("data:image/png;base64,")
        assert base64.b64decode(src.split(",", 1)[1])[:4] == b"\x89PNG"
    assert "<link" not in html and "<script src" not in html


@pytest.mark.slow
def test_blind_spots_found_where_the_contact_never_was(report):
    rep, _, truth = report
    bs = rep.blindspots
    for name, (a, b) in truth["gaps"].items():
        row = bs[bs["surface"] == name]
        assert len(row) == 1
        assert row["start_mm"].iloc[0] == pytest.approx(a, abs=1e-9)
        assert row["width_mm"].iloc[0] == pytest.approx(b - a, abs=1e-9)


@pytest.mark.slow
def test_table1_and_truth_tables(report):
    rep, results, truth = report
    t1 = rep.table1
    assert t1 is not None
    # every variant, the one used first; per variant 2 subjects + both, x 2 surfaces; forces
    # are Eq. (4) plus 2 mN noise: strong correlation for the variants of Eq. (4) that
    # represent them (here the normal force is the load of a constant pressure, so the
    # load-consistent variant is the paper's)
    assert list(dict.fromkeys(t1["model"])) == [rep.model, *[m for m in MODELS if m != rep.model]]
    for _, m in t1.groupby("model"):
        assert len(m) == 6
    good = t1[t1["model"].isin(["load", "pressure", "paper"])]
    assert (good["rho"] > 0.9).all() and good["significant"].all()
    assert (t1["rho_lo"] <= t1["rho"]).all() and (t1["rho"] <= t1["rho_hi"]).all()
    for ext in ("csv", "md", "tex"):
        assert (results / "report" / f"table1.{ext}").stat().st_size > 0
    mu = rep.truth["mu"]
    assert list(dict.fromkeys(mu["model"])) == [rep.model, *[m for m in MODELS if m != rep.model]]
    mu = mu.set_index(["model", "subject"])
    assert mu.loc[("load", "1"), "mu_true"] == 0.55 and mu.loc[("load", "2"), "mu_true"] == 0.60
    assert np.all(np.abs(mu["error"]) <= 0.03)
    # the load-consistent model measures mu on flat ground: within 0.5 %, with a CI (its
    # coverage is tested on larger samples in tests/test_fit_load.py: 8 trials per subject here)
    load = mu.loc["load"]
    assert np.all(np.abs(load["error"] / load["mu_true"]) < 0.005)
    assert (load["ci95_lo"] < load["mu_fitted"]).all() and (load["mu_fitted"] < load["ci95_hi"]).all()


@pytest.mark.slow
def test_fit_recovers_parameters(synthetic_results):
    results, truth = synthetic_results
    df = pd.read_csv(results / "fit" / "trials.csv", dtype={"subject": str})
    assert df["success"].all()
    df = df[df["model"] == "paper"]  # the fixture's forces are the paper's Eq. (4)
    for row in df[df["surface"] == "bump-2mm"].itertuples():  # p1 is well identified on a bump
        p = truth["p"][row.trial]
        assert row.p1 == pytest.approx(p.p1, rel=0.1), row.trial
    model = pd.read_parquet(results / "fit" / "model" / f"{df['trial'].iloc[0]}.parquet")
    assert {"x_mm", "F_T_N", "F_hat_N", "F_int_N", "F_def_N"} <= set(model.columns)
    # Eq. (1): the two parts add up to the model force.
    np.testing.assert_allclose(model["F_int_N"] + model["F_def_N"], model["F_model_N"], atol=1e-12)


# The tests below that write their own results look at the report's page, its tables and
# figures: their reports leave out the trial pages (sample=0, the flagged trials' alone),
# which test_flags_pages.py and the shared report above test.


@pytest.mark.slow
def test_report_before_fit_leaves_out_model_figures(tmp_path):
    from report_synthetic import write_synthetic_results

    write_synthetic_results(tmp_path / "r")
    rep = make_report(tmp_path / "r", sample=0)
    assert rep.table1 is None
    names = {p.name for p in rep.files}
    assert "fig3_occupancy.png" in names and "fig6_model.png" not in names
    assert "fingerfriction fit" in rep.html.read_text()


@pytest.mark.slow
def test_failed_trials_listed(tmp_path):
    from report_synthetic import write_synthetic_results

    write_synthetic_results(tmp_path / "r")
    store = ResultsStore(tmp_path / "r")
    tid = store.trial_ids()[0]
    store.write_failure(tid, "ValueError: video truncated\nat frame 12", {})
    data = load_report_data(tmp_path / "r")
    assert (tid, "ValueError: video truncated at frame 12") in data.failed
    html = make_report(tmp_path / "r", sample=0).html.read_text()
    assert tid in html and "video truncated at frame 12" in html


def test_not_a_results_folder(tmp_path):
    with pytest.raises(ValueError, match="not a results folder"):
        make_report(tmp_path)


@pytest.mark.slow
def test_out_of_sample_validation_next_to_table1(report):
    """``fit`` runs the leave-one-surface-out validation; the report shows it after Table 1."""
    rep, results, _ = report
    loso = rep.loso
    assert loso is not None
    # every variant, the one used first; per variant 2 subjects + both subjects pooled, x 2
    # held-out surfaces
    assert list(dict.fromkeys(loso["model"])) == [rep.model, *[m for m in MODELS if m != rep.model]]
    assert len(loso) == 6 * len(MODELS) and set(loso["surface"]) == {"bump-2mm", "step-down-4mm"}
    assert set(loso["subject"]) == {"1", "2", "Both subjects"}
    assert np.isfinite(loso["rho_out_of_sample"]).all() and np.isfinite(loso["rho_in_sample"]).all()
    # the CSV next to the report is the fit's table (3 significant digits)
    csv = pd.read_csv(results / "report" / "loso.csv", dtype={"subject": str})
    fit_csv = pd.read_csv(results / "fit" / "loso.csv", dtype={"subject": str})
    assert list(csv["surface"]) == list(fit_csv["surface"])
    np.testing.assert_allclose(csv["rho_out_of_sample"], fit_csv["rho_out_of_sample"], rtol=5e-3)
    # rho_in_sample is the report's Table 1 (same fit): one per (model, subject, shape)
    t1 = rep.table1.set_index(["model", "subject", "shape"])["rho"]
    shapes = {"bump-2mm": "Bump", "step-down-4mm": "Step Down"}
    for row in fit_csv.itertuples():
        ref = t1[row.model, row.subject, shapes[row.surface]]
        assert row.rho_in_sample == pytest.approx(ref, abs=1e-6), row
    html = rep.html.read_text()
    i, j = html.index("<h2>Table 1"), html.index("<h2>Out of sample - leave one surface out")
    assert i < j < html.index("Tactile blind spots")
    assert f"{fit_csv['rho_out_of_sample'].iloc[0]:.3g}" in html[j:]


@pytest.mark.slow
def test_fit_without_validation_says_so(tmp_path):
    from report_synthetic import write_synthetic_results

    from fingerfriction.pipeline.fitting import fit

    write_synthetic_results(tmp_path / "r")
    (tmp_path / "r" / "fit").mkdir(parents=True)
    (tmp_path / "r" / "fit" / "loso.csv").write_text("stale,table\n1,2\n")  # from an earlier fit
    summary = fit(tmp_path / "r", progress=False, validate=False)
    assert summary.loso is None and summary.loso_message == "not requested"
    assert not (tmp_path / "r" / "fit" / "loso.csv").exists()  # never a table of another fit
    rep = make_report(tmp_path / "r", sample=0)
    assert rep.loso is None and rep.table1 is not None
    assert "Not computed: not requested" in rep.html.read_text()
    assert "loso.csv" not in {p.name for p in rep.files}


@pytest.mark.slow
def test_p_values_never_print_as_zero(report):
    """Table 1 and the leave-one-surface-out table: p below the smallest double is '< 1e-300',
    small p in scientific notation; the CSV keeps the numbers."""
    rep, results, _ = report
    html = rep.html.read_text()
    assert (rep.table1["p"] == 0).any()  # the synthetic fit correlates perfectly: p underflows
    assert "&lt; 1e-300" in html
    for table in re.findall(r"<table>.*?</table>", html, flags=re.S):
        head = re.findall(r"<th>([^<]*)</th>", table)
        for col in ("p", "p_out_of_sample"):
            if col in head:
                k = head.index(col)
                for row in re.findall(r"<tr>(.*?)</tr>", table)[1:]:
                    cell = re.findall(r"<td>(.*?)</td>", row)[k]
                    assert cell not in ("0", "0.0", "0.00"), (col, row)
    md = (results / "report" / "table1.md").read_text()
    assert "< 1e-300" in md
    assert pd.read_csv(results / "report" / "table1.csv")["p"].dtype.kind == "f"


@pytest.mark.slow
def test_one_subject_report_does_not_say_both_subjects(tmp_path):
    from report_synthetic import write_synthetic_results

    from fingerfriction.pipeline.fitting import fit

    write_synthetic_results(tmp_path / "r", subjects={"1": 0.55})
    fit(tmp_path / "r", progress=False, validate=False)
    rep = make_report(tmp_path / "r", sample=0)
    html = rep.html.read_text().lower()
    assert "both subjects" not in html
    assert set(rep.table1["subject"]) == {"1"}
    assert "one subject" in html


@pytest.mark.slow
def test_report_before_fit_says_so_at_the_top_and_on_the_console(tmp_path):
    from report_synthetic import write_synthetic_results
    from typer.testing import CliRunner

    from fingerfriction.cli import app

    write_synthetic_results(tmp_path / "r")
    res = CliRunner().invoke(app, ["report", str(tmp_path / "r"), "--sample", "0"])
    assert res.exit_code == 0, res.output
    notes = [ln for ln in res.output.splitlines() if ln.startswith("note:")]
    assert len(notes) == 1 and "not fitted" in notes[0] and "fingerfriction fit" in notes[0]
    html = (tmp_path / "r" / "report" / "index.html").read_text()
    body = html[html.index("<body>"):]
    first_section = body.index("<h2>")
    assert 'class="notice"' in body[:first_section] and "not fitted" in body[:first_section]


@pytest.mark.slow
def test_mu_at_the_end_of_the_grid_is_said(tmp_path):
    from report_synthetic import write_synthetic_results

    from fingerfriction.pipeline.fitting import fit

    write_synthetic_results(tmp_path / "r")
    # the paper's variant forced: its mu is the study's (truth 0.55, 0.60)
    fit(tmp_path / "r", progress=False, validate=False, mu_grid=(0.30, 0.50, 0.05), model="paper")
    rep = make_report(tmp_path / "r", sample=0)
    html = rep.html.read_text()
    summary = html[html.index("<h2>Summary</h2>"):html.index("</ul>", html.index("<h2>Summary</h2>"))]
    assert summary.count("is at the end of the grid [0.30, 0.50]") == 2
    assert "forced by <code>fit --model paper</code>" in summary
    # and in the warnings block at the top, once per subject
    assert [f["subject"] for f in rep.flags if f["code"] == "mu-at-grid-edge"] == ["1", "2"]  # the fit's flag
    assert html.index('id="warnings"') < html.index("<h2>Summary</h2>")


@pytest.mark.slow
def test_run_record_is_a_readable_table(report):
    rep, results, _ = report
    html = rep.html.read_text()
    i = html.index('<section id="record">')
    rec = html[i:html.index("</section>", i)]
    for title in ("Study", "Analysis parameters", "Fit", "Versions and platform"):
        assert title in rec
    assert "{" not in rec and "'" not in rec.replace("&#39;", "")  # no raw Python dict text
    assert "<th>stage</th><th>parameter</th><th>value</th>" in rec
    assert "0.3 to 0.9 by 0.01 (61 values)" in rec
    assert "<td>forces</td><td>notch_hz</td><td>50, 150, 300</td>" in rec
    assert "<td>flat_segment_mm</td><td>default</td>" in rec
