"""What the report flags (report/flags.py) and the trial pages (report/trial_pages.py)."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from fingerfriction.report import make_report
from fingerfriction.report.data import load_report_data
from fingerfriction.report.flags import collect_flags, flagged_trials, group_flags, position_gaps
from fingerfriction.report.trial_pages import choose_pages
from fingerfriction.study.store import ResultsStore


@pytest.fixture()
def results(tmp_path):
    from report_synthetic import write_synthetic_results

    write_synthetic_results(tmp_path / "r")
    return tmp_path / "r"


def _with_gap(t, rows=slice(200, 230), reason="finger leaves the field of view: C_f is cut"):
    fr = t.frames.copy()
    fr.loc[fr.index[rows], "x_mm"] = np.nan
    flags = fr["flag"].astype(object).to_numpy().copy()
    flags[rows] = reason
    fr["flag"] = flags
    return dataclasses.replace(t, frames=fr)


@pytest.mark.slow
def test_position_gap_flagged_with_its_frames_and_reasons(results):
    data = load_report_data(results)
    t = _with_gap(data.trials[0])
    gaps = position_gaps(t)
    assert len(gaps) == 1 and gaps[0]["n"] == 30 and gaps[0]["frame"] == 200
    data = dataclasses.replace(data, trials=[t, *data.trials[1:]])
    flags = [f for f in collect_flags(data) if f["code"] == "position-gap"]
    assert len(flags) == 1 and flags[0]["trial"] == t.id and flags[0]["level"] == "warning"
    assert "30 frames from frame 200" in flags[0]["message"]
    assert "finger leaves the field of view (30)" in flags[0]["message"]
    # a one-frame hole is no gap (MIN_GAP_FRAMES)
    assert position_gaps(_with_gap(data.trials[1], rows=slice(300, 301))) == []


@pytest.mark.slow
def test_failed_trials_and_fit_failures_are_flagged_and_get_a_page(results):
    store = ResultsStore(results)
    tid = store.trial_ids()[3]
    store.write_failure(tid, "ValueError: video truncated at frame 12", {})
    from fingerfriction.pipeline.fitting import fit

    # the paper's variant forced, its mu at the edge of its grid
    fit(results, progress=False, validate=False, mu_grid=(0.30, 0.50, 0.05), model="paper")
    rep = make_report(results, sample=0)
    codes = {(f["level"], f["code"]) for f in rep.flags}
    # the fit records the flags of the variant it used (fit.json): mu at the edge of the grid
    assert ("error", "analysis-failed") in codes and ("error", "mu-at-grid-edge") in codes
    assert rep.flags[0]["level"] == "error"  # most serious first
    assert flagged_trials(rep.flags) == [tid]  # mu-at-grid-edge is about a subject, not a trial
    assert set(rep.pages) == {tid}
    page = rep.pages[tid].read_text()
    assert "Not analysed: ValueError: video truncated at frame 12" in page
    html = rep.html.read_text()
    assert f'href="trials/{tid}.html"' in html  # from the warnings block and the failed-trials table
    groups = {g["code"]: g for g in group_flags(rep.flags)}
    assert groups["mu-at-grid-edge"]["count"] == 2 and groups["mu-at-grid-edge"]["n_trials"] == 0
    # chosen by --model auto, a variant on the absolute footing is used: the paper variant's
    # flags are notes on the comparison, not flags of the study
    fit(results, progress=False, validate=False, mu_grid=(0.30, 0.50, 0.05))
    rep = make_report(results, sample=0)
    assert rep.model != "paper" and "mu-at-grid-edge" not in {f["code"] for f in rep.flags}
    assert {(n["model"], n["code"]) for n in rep.notes} >= {("paper", "mu-at-grid-edge")}
    html = rep.html.read_text()
    assert html.index('id="comparison-notes"') > html.index('id="model-choice"')


@pytest.mark.slow
def test_choose_pages_flagged_plus_an_even_sample(results):
    data = load_report_data(results)
    order = [m["id"] for m in data.run["trials"]]
    assert choose_pages(data, [order[5]], 0) == [order[5]]
    three = choose_pages(data, [order[5]], 3)
    assert len(three) == 4 and order[5] in three and three == [t for t in order if t in three]
    assert three == choose_pages(data, [order[5]], 3)  # deterministic
    assert choose_pages(data, [], None) == order
    with pytest.raises(ValueError, match="sample must be >= 0"):
        choose_pages(data, [], -1)


@pytest.mark.slow
def test_trial_page_has_three_plots_and_says_why_there_is_no_animation(results):
    rep = make_report(results, sample=1)
    assert len(rep.pages) == 1
    page = next(iter(rep.pages.values())).read_text()
    plots = re.findall(r'<img class="plot" id="plot-(x_t|f_t|f_n)" src="data:image/svg\+xml;base64,', page)
    assert sorted(plots) == ["f_n", "f_t", "x_t"]
    # the synthetic results have no study folder with videos
    assert 'id="animation-missing"' in page and "manifest is not reachable" in page
    assert "No flag" in page


def test_record_values_read_as_text_not_python_reprs():
    from fingerfriction.report.trial_pages import readable

    assert readable({"CALIBRATION": 1, "OUT_OF_VIEW": 5}) == "CALIBRATION 1, OUT_OF_VIEW 5"
    assert readable([-12.998532789218679, -8.807356476971798]) == "-12.9985, -8.80736"
    assert readable([]) == "none" and readable({}) == "none" and readable(None) == ""
    assert readable("ok") == "ok" and readable(True) == "True" and readable(3) == "3"
