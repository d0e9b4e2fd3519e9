"""What `analyze` decides for a finished trial, from its files and its stored results:
content, not size and modification time; stored tables verified; a missing
input keeps the last results; a results folder belongs to one study; one command at a
time. Fast: the finished trials are written through the store, nothing is analysed."""

from __future__ import annotations

import json
import os
import re
import shutil
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from fingerfriction.pipeline import plan as plan_module
from fingerfriction.pipeline.analyze import analyze, plan_analysis, trial_entry
from fingerfriction.study.results import AnalysedTrial
from fingerfriction.study.store import (
    ResultsInUseError,
    ResultsStore,
    frames_table,
    input_fingerprint,
    sha256_input,
)

sys.path.insert(0, str(Path(__file__).parents[1] / "study"))
from test_check import _small_study  # noqa: E402


def _study(root, n=2):
    """n trials of tiny recordings (tests/study/test_check.py's)."""
    _small_study(root, n=n)
    return root


def _finish(study, results):
    """Every trial of the study written as finished OK, as `analyze` writes it."""
    plan = plan_analysis(study, results)
    store = ResultsStore(results)
    st = plan.study
    store.write_run({"study": str(st.root), "manifest_sha256": sha256_input(study / "manifest.json"),
                     "trials": [{"id": t.id} for t in st.trials]})
    for t in st.trials:
        paths = {k: study / getattr(t, k).path for k in ("video", "force")}
        inputs = {k: {"path": getattr(t, k).path, "sha256": sha256_input(p),
                      "fingerprint": input_fingerprint(p)} for k, p in paths.items()}
        frames = frames_table(np.arange(6) / 250.0, np.linspace(-1, 1, 6), np.full((6, 1, 2), np.nan))
        forces = pd.DataFrame({"x_mm": np.arange(5) * 0.01, "F_T_N": np.ones(5)})
        store.write_trial(AnalysedTrial.from_tables(
            t.id, frames, forces, {"params_sha256": plan.params_sha256, "parameters": plan.params,
                                   "entry": trial_entry(st, t), "inputs": inputs}))
    return store


@pytest.fixture
def finished(tmp_path):
    study = _study(tmp_path / "study")
    results = tmp_path / "results"
    return study, results, _finish(study, results)


def _decisions(study, results, **kw):
    return {p.trial_id: (p.action, p.reason) for p in plan_analysis(study, results, **kw).trials}


def test_unchanged_trials_are_skipped_and_a_touched_file_is_not_a_change(finished):
    study, results, _ = finished
    assert _decisions(study, results) == {"t0": ("skip", "unchanged"), "t1": ("skip", "unchanged")}
    os.utime(study / "raw" / "t0.npz", ns=(1, 1))  # a new time, the same content
    assert _decisions(study, results)["t0"] == ("skip", "unchanged")


def test_a_file_edited_in_place_with_its_size_and_time_kept_is_recomputed(finished):
    study, results, _ = finished
    p = study / "raw" / "t1.npz"
    st = p.stat()
    np.savez(p, F1=np.arange(500.0) * 2, F2=np.ones(500))
    assert p.stat().st_size == st.st_size
    os.utime(p, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert _decisions(study, results)["t1"] == ("compute", "input changed: force")


def test_quick_resume_trusts_an_unchanged_fingerprint_and_hashes_the_rest(finished, monkeypatch):
    study, results, _ = finished
    hashed = []
    real = plan_module.sha256_input
    monkeypatch.setattr(plan_module, "sha256_input", lambda p: hashed.append(p.name) or real(p))
    assert set(_decisions(study, results, quick_resume=True).values()) == {("skip", "unchanged")}
    assert hashed == []  # nothing read
    p = study / "raw" / "t1.npz"
    st = p.stat()
    np.savez(p, F1=np.arange(500.0) * 3, F2=np.ones(500))
    os.utime(p, ns=(st.st_atime_ns, st.st_mtime_ns))  # the size and the time kept: not the ctime
    assert _decisions(study, results, quick_resume=True)["t1"] == ("compute", "input changed: force")
    assert hashed == ["t1.npz"]
    assert _decisions(study, results)["t1"] == ("compute", "input changed: force")  # the default hashes all


@pytest.mark.parametrize("damage,why", [
    (lambda p: p.write_bytes(p.read_bytes()[:-100]),
     r"stored results damaged: forces.parquet has \d+ bytes, \d+ were written"),
    (lambda p: p.unlink(), "stored results damaged: forces.parquet is missing"),
    (lambda p: p.write_bytes(p.read_bytes()[:50] + b"x" + p.read_bytes()[51:]),
     r"stored results damaged: forces.parquet changed since it was written \(SHA-256\)"),
])
def test_damaged_stored_tables_are_recomputed(finished, damage, why):
    study, results, _ = finished
    damage(results / "trials" / "t0" / "forces.parquet")
    action, reason = _decisions(study, results)["t0"]
    assert action == "compute"
    assert re.fullmatch(why, reason), reason


def test_tables_written_before_digests_were_recorded_are_still_checked(finished):
    study, results, store = finished
    status = store.status("t0")
    del status["tables"]
    (results / "trials" / "t0" / "status.json").write_text(json.dumps(status))
    assert _decisions(study, results)["t0"] == ("skip", "unchanged")  # readable: trusted
    p = results / "trials" / "t0" / "frames.parquet"
    p.write_bytes(p.read_bytes()[:-30])  # no Parquet footer any more
    action, reason = _decisions(study, results)["t0"]
    assert action == "compute" and reason.startswith("stored results damaged: frames.parquet cannot be read")


def test_a_missing_or_unreadable_input_keeps_the_last_results(finished):
    study, results, store = finished
    before = {n: (results / "trials" / "t0" / n).read_bytes() for n in ("frames.parquet", "forces.parquet")}
    (study / "raw" / "t0.cine").rename(study / "raw" / "elsewhere.cine")  # a drive not mounted
    plan = plan_analysis(study, results, force=True)
    assert {p.trial_id: p.action for p in plan.trials} == {"t0": "keep", "t1": "compute"}
    assert plan.kept == [("t0", "input missing: video (raw/t0.cine: no such file or folder); --force")]
    res = analyze(study, results, trials=["t0"], progress=False)
    assert res.n_computed == 0 and res.n_failed == 0 and not res.success
    assert res.input_missing == (("t0", "input missing: video (raw/t0.cine: no such file or folder)"),)
    for n, data in before.items():  # the results are where they were
        assert (results / "trials" / "t0" / n).read_bytes() == data
    status = store.status("t0")
    assert status["status"] == "ok" and status["input_missing"]["reason"].startswith("input missing: video")
    run = store.read_run()
    assert run["trial_status"]["t0"]["input_missing"]["reason"].startswith("input missing")
    # the input is back, unchanged: skipped, and the mark is gone
    (study / "raw" / "elsewhere.cine").rename(study / "raw" / "t0.cine")
    res = analyze(study, results, trials=["t0"], progress=False)
    assert res.success and res.n_skipped == 1 and "input_missing" not in store.status("t0")


def test_a_results_folder_belongs_to_one_study(finished, tmp_path):
    study, results, store = finished
    other = _study(tmp_path / "other", n=1)
    m = json.loads((other / "manifest.json").read_text())
    m["trials"][0]["id"] = "x0"
    (other / "manifest.json").write_text(json.dumps(m))
    with pytest.raises(ValueError, match=r"holds the results of another study .*; give another --out, or "
                                         r"--force to remove that study's trials"):
        plan_analysis(other, results)
    (store.fit_dir / "fit.json").parent.mkdir(parents=True)
    (store.fit_dir / "fit.json").write_text("{}")
    plan = plan_analysis(other, results, force=True)  # a plan (the dry run) removes nothing
    assert plan.other_study == str(study.resolve()) and store.fit_dir.exists()
    (other / "raw" / "t0.cine").unlink()  # (the trial fails its check: no cluster started)
    res = analyze(other, results, force=True, progress=False)  # --force: that study's trials, fit... gone
    assert res.n_failed == 1 and sorted(p.name for p in (results / "trials").iterdir()) == ["x0"]
    assert not store.fit_dir.exists()
    # the same study moved elsewhere (the same manifest) is the same study
    moved = tmp_path / "moved"
    shutil.copytree(study, moved)
    _finish(study, tmp_path / "results2")
    assert set(_decisions(moved, tmp_path / "results2").values()) == {("skip", "unchanged")}


def test_results_inside_the_study_are_refused(tmp_path):
    study = _study(tmp_path / "study")
    with pytest.raises(ValueError, match=r"--out .*/study/results' is inside the study folder"):
        plan_analysis(study, study / "results")
    with pytest.raises(ValueError, match=r"the study folder .* is inside --out"):
        plan_analysis(study, tmp_path)
    assert not (study / "results").exists()


def test_one_command_at_a_time(finished):
    study, results, store = finished
    with store.lock("analyze"):
        with pytest.raises(ResultsInUseError, match=r"is in use by `fingerfriction analyze` \(process "
                                                     rf"{os.getpid()}, since"):
            analyze(study, results, progress=False)
    res = analyze(study, results, progress=False)  # released
    assert res.success and res.n_skipped == 2


def test_a_tiff_folder_is_hashed_frame_by_frame(tmp_path):
    import tifffile

    d = tmp_path / "frames"
    d.mkdir()
    for i in range(3):
        tifffile.imwrite(d / f"f{i}.tif", np.full((4, 5), i, np.uint8))
    h = sha256_input(d)
    assert sha256_input(d) == h and len(h) == 64
    tifffile.imwrite(d / "f1.tif", np.full((4, 5), 9, np.uint8))
    assert sha256_input(d) != h
    os.symlink(tmp_path / "outside.tif", d / "f3.tif")
    tifffile.imwrite(tmp_path / "outside.tif", np.zeros((4, 5), np.uint8))
    with pytest.raises(ValueError, match=r"f3.tif: frame file links to .*outside.tif, outside the folder"):
        sha256_input(d)
