"""`fingerfriction check` and the checks `analyze` runs first: every problem at once."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from fingerfriction.cli import app
from fingerfriction.pipeline.analyze import StudyCheckError, analyze, plan_analysis
from fingerfriction.study.check import check_study
from fingerfriction.study.manifest import load_manifest
from fingerfriction.video.writers import write_video

runner = CliRunner()


def _small_study(root, n=3):
    """n trials of tiny recordings (a 6-frame cine at 250 fps, 500 samples of F1/F2)."""
    raw = root / "raw"
    raw.mkdir(parents=True)
    trials = []
    for i in range(n):
        write_video(raw / f"t{i}.cine", np.full((6, 24, 40), 200, np.uint8), fps=250.0)
        np.savez(raw / f"t{i}.npz", F1=np.zeros(500), F2=np.ones(500))
        trials.append({"id": f"t{i}", "subject": "1", "surface": "bump-2mm", "speed_mm_s": 80,
                       "video": {"path": f"raw/t{i}.cine"},
                       "force": {"path": f"raw/t{i}.npz", "fs_hz": 10000.0}})
    manifest = {"format": "fingerfriction-study", "schema_version": 1, "trials": trials}
    (root / "manifest.json").write_text(json.dumps(manifest, indent=1))
    return manifest


def _write(root, manifest):
    (root / "manifest.json").write_text(json.dumps(manifest, indent=1))


def _results(study):
    """A results folder beside the study (never inside it)."""
    return study.with_name(study.name + "-results")


def test_a_minimal_manifest_leaves_the_rest_to_the_files(tmp_path):
    """No surfaces block, no repetition, no calibration, no frame or sample counts: the
    built-in surface name, the defaults and the files answer."""
    _small_study(tmp_path)
    st = load_manifest(tmp_path)
    t = st.trials[0]
    assert (t.repetition, t.calibration, t.surface) == (1, None, "bump-2mm")
    assert st.surface("bump-2mm").max_height == pytest.approx(0.4)
    assert (t.video.format, t.video.fps, t.video.n_frames, t.video.width, t.video.height) == (
        "cine", 250.0, 6, 40, 24)
    assert (t.force.format, t.force.n_samples, t.force.fs_hz) == ("npz", 500, 10000.0)
    res = check_study(tmp_path)
    assert res.ok and len(res.study.trials) == 3


def test_check_lists_five_mistakes_in_three_trials_at_once(tmp_path):
    m = _small_study(tmp_path)
    t0, t1, t2 = m["trials"]
    t0["video"]["fps"] = -250                       # 1. manifest: a negative frame rate
    t0["force"]["channels"] = {"F1": "F1", "F2": "ai9"}   # 2. file: no such channel
    t1["surface"] = "ramp-3mm"                      # 3. manifest: unknown surface
    t2["video"]["path"] = "raw/missing.cine"        # 4. file: no video
    t2["force"]["units"] = "V"                      # 5. manifest: volts without a sensitivity
    _write(tmp_path, m)
    r = runner.invoke(app, ["check", str(tmp_path)])
    assert r.exit_code == 2, r.output
    mf = str(tmp_path / "manifest.json")
    expected = [
        f"{mf}: trials[0].video.fps: must be positive, got -250",
        "raw/t0.npz: trials[0].force.channels: no array 'ai9' (channel F2) in raw/t0.npz; arrays present: "
        "['F1', 'F2']",
        f"{mf}: trials[1].surface: 'ramp-3mm' is not in 'surfaces' and is not a built-in surface",
        "raw/missing.cine: trials[2].video.path: no such file or folder",
        f"{mf}: trials[2].force.units: units 'V' needs exactly one of sensitivity_n_per_v (N/V) or "
        "gain_v_per_n (V/N), got neither",
    ]
    text = " ".join(r.output.split())
    for e in expected:
        assert " ".join(e.split()) in text, (e, r.output)
    assert "5 problem(s): 0 of 3 trials are fine, 3 have problems" in text
    # the manifest mistakes alone make analyze refuse to start, listing them all
    with pytest.raises(StudyCheckError) as ei:
        plan_analysis(tmp_path, _results(tmp_path))
    assert len(ei.value.problems) == 3
    r = runner.invoke(app, ["analyze", str(tmp_path), "--out", str(_results(tmp_path))])
    assert r.exit_code == 2 and "3 problem(s) in the manifest; nothing was run" in " ".join(r.output.split())
    assert "trials[1].surface" in r.output and not (_results(tmp_path)).exists()


def test_analyze_fails_a_trial_whose_recording_does_not_match_and_records_why(tmp_path):
    m = _small_study(tmp_path, n=1)
    m["trials"][0]["video"]["n_frames"] = 600
    _write(tmp_path, m)
    res = analyze(tmp_path, _results(tmp_path), progress=False)
    assert (res.n_computed, res.n_failed) == (0, 1)
    reason = res.failures[0][1]
    assert reason.startswith("check: raw/t0.cine: trials[0].video.n_frames: the manifest says 600, "
                             "the file has 6")
    status = json.loads((_results(tmp_path) / "trials" / "t0" / "status.json").read_text())
    assert status["status"] == "failed" and status["reason"] == reason
    plan = plan_analysis(tmp_path, _results(tmp_path))
    assert [(p.trial_id, p.action, p.reason) for p in plan.trials] == [("t0", "compute", "failed before")]


def test_an_unreadable_manifest_is_one_problem(tmp_path):
    (tmp_path / "manifest.json").write_text("{not json")
    r = runner.invoke(app, ["check", str(tmp_path)])
    assert r.exit_code == 2 and "not valid JSON (line 1" in r.output
    r = runner.invoke(app, ["check", str(tmp_path / "nowhere")])
    assert r.exit_code == 2 and "no such manifest file" in r.output
