"""The consistency stage in ``analyze`` and ``check --deep``, on a tiny simulated study
with mistaken copies of a trial: each mistake fails its copy with its one-line reason, the
clean trials pass, ``--sync auto`` moves a wrong clock and says so."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from fingerfriction.cli import app
from fingerfriction.flags import Flag
from fingerfriction.pipeline.analyze import analyze
from fingerfriction.pipeline.params import AnalysisParams
from fingerfriction.report.data import load_report_data
from fingerfriction.report.flags import collect_flags
from fingerfriction.sim import KinematicsParams, SimOptions, simulate_study
from fingerfriction.study.store import ResultsStore

pytestmark = pytest.mark.slow
runner = CliRunner()

#: the tiny study's slides are 6 mm long: a 4 mm window and a flat segment before the bump
FORCES = {"window_mm": 4.0, "flat_segment_mm": (-2.0, -0.5)}


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """3 clean trials of one finger at 50, 80 and 130 mm/s, and copies of the 80 mm/s one
    with a mistake each."""
    root = tmp_path_factory.mktemp("selfcheck") / "study"
    simulate_study(
        root,
        SimOptions(
            reps=1,
            subjects=("1",),
            surfaces=("bump-2mm",),
            speeds=(50.0, 80.0, 130.0),
            seed=3,
            kinematics=KinematicsParams(window=4.0, x_start=-3.0, x_stop=2.5),
            video_end_mm=2.5,
            contact_model="bridged-foundation",
            table_step=0.05,
            table_loads=(0.3,),
        ),
        workers=1,
    )
    clean = json.loads((root / "manifest.json").read_text())
    (root / "clean.json").write_text(json.dumps(clean))
    base = next(t for t in clean["trials"] if t["speed_mm_s"] == 80.0)
    with np.load(root / base["force"]["path"]) as z:
        f1, f2 = z["F1"], z["F2"]

    def copy(tid, *, force=None, arrays=None, **top):
        t = json.loads(json.dumps(base))
        t["id"] = tid
        t.pop("truth", None)
        t.update(top)
        if arrays is not None:
            path = f"raw/{tid}.npz"
            (root / "raw").mkdir(exist_ok=True)
            np.savez(root / path, F1=arrays[0], F2=arrays[1])
            t["force"]["path"] = path
        t["force"].update(force or {})
        return t

    mistakes = [
        copy("bad-t0", force={"t0_s": 0.010}),
        copy("bad-f2", arrays=(f1, -f2)),
        copy("bad-mn", arrays=(1000 * f1, 1000 * f2)),
        copy("bad-fs", force={"fs_hz": 10_300.0, "n_samples": None}),
        copy("bad-height", calibration={"surface_height_mm": 0.8}),
    ]
    for t in mistakes:
        if t["force"].get("n_samples") is None:
            t["force"].pop("n_samples", None)
    (root / "manifest.json").write_text(json.dumps({**clean, "trials": clean["trials"] + mistakes}))
    return root


def _run(study, out, sync="check"):
    return analyze(
        study,
        out,
        n_workers=1,
        progress=False,
        params=AnalysisParams(forces=FORCES, selfcheck={"sync": sync}),
    )


def test_analyze_fails_each_mistake_with_its_reason(study, tmp_path):
    res = _run(study, tmp_path / "res")
    reasons = dict(res.failures)
    assert set(reasons) == {"bad-t0", "bad-f2", "bad-mn", "bad-fs", "bad-height"}, reasons
    assert (
        "sync-offset" in reasons["bad-t0"] and "force.t0_s (or fs_hz) looks off by -10" in reasons["bad-t0"]
    )
    assert "channel-polarity" in reasons["bad-f2"] and "F2 looks negated" in reasons["bad-f2"]
    assert "forces look 1000x too large: mN labelled N?" in reasons["bad-mn"]
    assert "rate-mismatch" in reasons["bad-fs"] and "10300 Hz given" in reasons["bad-fs"]
    assert "surface-geometry" in reasons["bad-height"] and "H 0.8 mm" in reasons["bad-height"]
    store = ResultsStore(res.results)
    for tid in ("s1-bump-2mm-v050-r1", "s1-bump-2mm-v080-r1", "s1-bump-2mm-v130-r1"):
        st = store.status(tid)
        assert st["status"] == "ok"
        sc = st["info"]["selfcheck"]
        assert all(c["level"] in ("ok", "info") for c in sc["checks"]), sc["checks"]
        assert sc["sync"]["check"]["level"] == "ok" and abs(sc["sync"]["offset_ms"]) < 2.0
    run = store.read_run()
    assert run["runs"][-1]["sync"]["mode"] == "check"
    assert run["parameters"]["selfcheck"]["sync"] == "check"
    assert store.status("bad-t0")["status"] == "failed"


def test_sync_auto_moves_the_wrong_clock(study, tmp_path):
    clean = json.loads((study / "clean.json").read_text())
    one = tmp_path / "study"
    shutil.copytree(study, one, ignore=shutil.ignore_patterns("manifest.json"))
    full = json.loads((study / "manifest.json").read_text())
    keep = [t for t in full["trials"] if t["id"] in {c["id"] for c in clean["trials"]} | {"bad-t0"}]
    (one / "manifest.json").write_text(json.dumps({**full, "trials": keep}))
    res = _run(one, tmp_path / "res", sync="auto")
    assert res.n_failed == 0, res.failures
    st = ResultsStore(res.results).status("bad-t0")
    step = st["info"]["forces"]["history"][0]
    assert step["step"] == "synchronise" and step["offset_ms"] == pytest.approx(-10.0, abs=1.0)
    assert st["info"]["selfcheck"]["sync"]["check"]["level"] == "warning"
    stored = [Flag.from_dict(f) for f in st["info"]["forces"]["flags"]]  # Flag records, level kept
    assert any(f.code == "sync-offset" and f.level == "warning" and "moved the force clock" in f.message
               for f in stored)
    assert res.sync["trials"]["bad-t0"]["check"]["level"] == "warning"
    # the report's warnings block takes it from the force stage's flags (its existing path)
    flags = collect_flags(load_report_data(res.results))
    mine = [f for f in flags if f["trial"] == "bad-t0" and f["code"] == "sync-offset"]
    assert mine and mine[0]["level"] == "warning" and "moved the force clock" in mine[0]["message"]


def test_check_deep_lists_the_mistakes(study):
    r = runner.invoke(app, ["check", str(study), "--deep"])
    assert r.exit_code == 2, r.output
    text = " ".join(r.output.split())
    for code in ("sync-offset", "channel-polarity", "force-level", "rate-mismatch", "surface-geometry"):
        assert f"error {code}:" in text
    assert "trials[3].force.t0_s" in text  # the field of the trial
    assert "s1-bump-2mm-v050-r1" not in text  # clean trials say nothing


def test_bad_sync_option_is_refused(study, tmp_path):
    r = runner.invoke(app, ["analyze", str(study), "--out", str(tmp_path / "r"), "--sync", "never"])
    assert r.exit_code == 2 and "--sync must be one of check, auto, manifest" in " ".join(r.output.split())


def test_manifest_mode_trusts_the_manifest(study, tmp_path):
    one = tmp_path / "study"
    shutil.copytree(study, one, ignore=shutil.ignore_patterns("manifest.json"))
    full = json.loads((study / "manifest.json").read_text())
    keep = [t for t in full["trials"] if t["id"] in ("s1-bump-2mm-v050-r1", "bad-t0")]
    (one / "manifest.json").write_text(json.dumps({**full, "trials": keep}))
    res = _run(one, tmp_path / "res", sync="manifest")
    assert res.n_failed == 0 and not res.sync.get("trials")  # nothing measured
    assert Path(res.results, "trials", "bad-t0", "forces.parquet").is_file()
