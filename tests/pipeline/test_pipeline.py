"""The study pipeline (fingerfriction.pipeline) and its results store (fingerfriction.results).

Fast tests check the store and the helpers; the tests marked slow run a tiny simulated
study through the real stages on Dask: a LocalCluster, a scheduler and a worker started
as separate processes, an interrupted and resumed run, and a study with a corrupt video.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from fingerfriction.pipeline.analyze import analyze
from fingerfriction.pipeline.fitting import fit
from fingerfriction.pipeline.params import SIM_CF_CENTROID_PARAMS, AnalysisParams, sim_params
from fingerfriction.regions import regions_on_grid
from fingerfriction.study.results import AnalysedTrial
from fingerfriction.study.store import (
    ResultsStore,
    atomic_write_parquet,
    frames_table,
    regions_from_table,
)
from shared_inputs import once_per_run

SRC = Path(__file__).resolve().parents[2] / "src"
# The options of simulated studies (see fingerfriction.pipeline.sim_params): the defaults.
SIM = AnalysisParams(**sim_params())


# --------------------------------------------------------------------------------------
# results store and helpers (fast)
# --------------------------------------------------------------------------------------


def _tables(n=5):
    t = np.arange(n) * 1e-3
    reg = np.full((n, 2, 2), np.nan)
    reg[:, 0] = [-3.0, -1.0]
    reg[2:, 1] = [0.5, 1.25]
    frames = frames_table(t, np.linspace(-1, 1, n), reg, ["no finger"] + [""] * (n - 1))
    forces = pd.DataFrame({"x_mm": [0.0, 0.01], "F_T_N": [0.1, 0.2]})
    return frames, forces, reg


def test_frames_table_round_trip(tmp_path):
    frames, forces, reg = _tables()
    store = ResultsStore(tmp_path)
    store.write_trial(AnalysedTrial.from_tables("t1", frames, forces, {"params_sha256": "p"}))
    back = store.read_frames("t1")
    pd.testing.assert_frame_equal(back, frames)
    np.testing.assert_array_equal(regions_from_table(back), reg)
    assert list(back["n_regions"]) == [1, 1, 2, 2, 2]
    assert back["flag"].iloc[0] == "no finger"


def test_frames_table_rejects_mismatched_lengths():
    with pytest.raises(ValueError, match="x_mm has 3 frames but t_s has 4"):
        frames_table(np.zeros(4), np.zeros(3), np.full((4, 1, 2), np.nan))
    with pytest.raises(ValueError, match="inverted"):
        frames_table(np.zeros(1), np.zeros(1), [[(1.0, 0.0)]])


def test_finished_means_ok_with_same_parameters(tmp_path):
    frames, forces, _ = _tables()
    store = ResultsStore(tmp_path)
    assert not store.is_finished("t1", "p")
    store.write_trial(AnalysedTrial.from_tables("t1", frames, forces, {"params_sha256": "p"}))
    assert store.is_finished("t1", "p")
    assert not store.is_finished("t1", "other parameters")
    (store.trial_dir("t1") / "forces.parquet").unlink()  # a table lost: not finished
    assert not store.is_finished("t1", "p")


def test_failure_is_one_line_and_removes_stale_tables(tmp_path):
    frames, forces, _ = _tables()
    store = ResultsStore(tmp_path)
    store.write_trial(AnalysedTrial.from_tables("t1", frames, forces, {"params_sha256": "p"}))
    store.write_failure("t1", "OSError: truncated\n  file video.mkv", {"params_sha256": "p"})
    st = store.status("t1")
    assert st["status"] == "failed" and st["reason"] == "OSError: truncated file video.mkv"
    assert not (store.trial_dir("t1") / "frames.parquet").exists()
    assert not store.is_finished("t1", "p")
    assert store.summary().to_dict("records")[0]["status"] == "failed"


def test_atomic_write_keeps_old_file_on_error(tmp_path):
    p = tmp_path / "a.parquet"
    good = pd.DataFrame({"a": [1, 2]})
    atomic_write_parquet(p, good)
    before = p.read_bytes()
    bad = pd.DataFrame({"a": [object(), object()]})  # pyarrow cannot serialise this
    with pytest.raises(Exception):  # noqa: B017 - whatever pyarrow raises
        atomic_write_parquet(p, bad)
    assert p.read_bytes() == before
    assert sorted(os.listdir(tmp_path)) == ["a.parquet"]  # no temporary file left behind


@pytest.mark.parametrize("bad", ["../x", "a/b", "", "..", "a b"])
def test_trial_ids_cannot_escape_the_results_folder(tmp_path, bad):
    with pytest.raises(ValueError, match="trial id"):
        ResultsStore(tmp_path).trial_dir(bad)


def test_regions_on_grid_picks_the_frame_at_each_position():
    x = np.array([np.nan, 0.0, 1.0, 2.0, 3.0])
    reg = np.arange(5 * 1 * 2, dtype=float).reshape(5, 1, 2)
    got, moved = regions_on_grid(x, reg, np.array([-0.5, 0.4, 0.6, 2.9, 10.0]), return_translated=True)
    # inside the tracked span: the nearest frame's regions; outside: the end frame's,
    # translated with the finger
    np.testing.assert_array_equal(got[:, 0, 0], reg[[1, 1, 2, 4, 4], 0, 0] + [-0.5, 0, 0, 0, 7.0])
    np.testing.assert_array_equal(got[:, 0, 1] - got[:, 0, 0], 1.0)
    assert moved.tolist() == [True, False, False, False, True]
    with pytest.raises(ValueError, match="at least two frames"):
        regions_on_grid(np.array([np.nan, 1.0]), reg[:2], np.zeros(3))


def test_analysis_params_validated():
    with pytest.raises(ValueError, match="force option"):
        AnalysisParams(forces={"no_such_option": 1}).resolved()
    with pytest.raises(ValueError, match="lowpass_hz"):
        AnalysisParams(forces={"lowpass_hz": -5}).resolved()
    with pytest.raises(TypeError, match="dict of options"):
        AnalysisParams(video=3)


def test_x_estimator_default_and_choice():
    """x(t) from the hybrid estimator by default, the paper's 26 mm window; the paper's
    C_f centroid on request (with its documented fallback for simulated studies)."""
    d = AnalysisParams().resolved()
    assert d["video"]["position"] == "hybrid" and d["forces"]["window_mm"] == 26.0
    assert d["video"]["n_max_regions"] >= 16  # until the video stage handles > 8 specks
    assert AnalysisParams(**sim_params()).resolved() == d  # nothing special for simulated studies
    cf = AnalysisParams(video={"position": "cf-centroid"}).resolved()
    assert cf["video"]["position"] == "cf-centroid" and cf["forces"]["window_mm"] == 26.0
    fb = AnalysisParams(**sim_params("cf-centroid")).resolved()
    assert fb["video"]["position"] == "cf-centroid"
    assert fb["forces"]["window_mm"] == SIM_CF_CENTROID_PARAMS["forces"]["window_mm"] == 22.0
    with pytest.raises(ValueError, match="position must be"):
        sim_params("centre")
    with pytest.raises(ValueError, match="position must be"):
        AnalysisParams(video={"position": "centre"}).resolved()


def test_not_a_results_folder(tmp_path):
    with pytest.raises(ValueError, match="not a results folder"):
        fit(tmp_path)


def _manifest_with_paths(root: Path, video_path: str) -> None:
    from fingerfriction.surfaces import get_surface

    root.mkdir(parents=True, exist_ok=True)
    trial = {
        "id": "t1", "subject": "1", "surface": "bump-2mm", "speed_mm_s": 40.0, "repetition": 1,
        "video": {"path": video_path, "format": "ffv1-mkv", "fps": 1000.0, "width": 1280, "height": 720,
                  "n_frames": 10, "t0_s": 0.0, "calibration_frame": 0},
        "force": {"path": "trials/t1/forces.npz", "format": "npz", "fs_hz": 10000.0, "n_samples": 100,
                  "channels": {"F1": "F1", "F2": "F2"}, "units": "N", "t0_s": 0.0},
        "calibration": {"surface_height_mm": 0.4},
    }
    (root / "manifest.json").write_text(json.dumps({
        "format": "fingerfriction-study", "schema_version": 1,
        "surfaces": {"bump-2mm": get_surface("bump-2mm").to_dict()}, "trials": [trial]}))


def test_manifest_path_escaping_the_study_is_refused(tmp_path):
    _manifest_with_paths(tmp_path / "study", "../../etc/passwd")
    with pytest.raises(ValueError, match=r"escapes the study folder|outside the study folder"):
        analyze(tmp_path / "study", tmp_path / "out", progress=False)
    assert not (tmp_path / "out" / "trials").exists()


def test_manifest_symlink_escaping_the_study_is_refused(tmp_path):
    outside = tmp_path / "secret.mkv"
    outside.write_bytes(b"x")
    _manifest_with_paths(tmp_path / "study", "trials/t1/video.mkv")
    (tmp_path / "study" / "trials" / "t1").mkdir(parents=True)
    (tmp_path / "study" / "trials" / "t1" / "video.mkv").symlink_to(outside)
    with pytest.raises(ValueError, match="outside the study folder"):
        analyze(tmp_path / "study", tmp_path / "out", progress=False)


def test_bad_options(tmp_path):
    with pytest.raises(ValueError, match="n_workers"):
        analyze(tmp_path, tmp_path / "out", n_workers=0, progress=False)
    with pytest.raises(ValueError, match="does not exist"):
        analyze(tmp_path / "nope", tmp_path / "out", progress=False)


# --------------------------------------------------------------------------------------
# a tiny simulated study through the real stages (slow)
# --------------------------------------------------------------------------------------


#: Trials of the tiny study: enough for a run stopped after some (2) with others left to do
#: (and one corrupt trial beside good ones), no more (each is simulated, then analysed again
#: by most tests below).
N_TINY = 3


def make_tiny_study(out: Path) -> Path:
    """1 subject x 1 surface x 1 speed (120 mm/s, the shortest slides) x :data:`N_TINY`
    repetitions."""
    from fingerfriction.sim import SimOptions, simulate_study

    simulate_study(out, SimOptions(reps=N_TINY, subjects=("1",), surfaces=("bump-2mm",), speeds=(120.0,),
                                   seed=3), workers=1)
    return out


# The tiny study and its analysis are built once per run (tests/shared_inputs.py), shared by
# the xdist workers: read-only, a test that writes into one (an edit, a fit, a report) copies it.
@pytest.fixture(scope="module")
def tiny_study(tmp_path_factory):
    folder, _ = once_per_run(tmp_path_factory, "pipeline-tiny-study", lambda f: make_tiny_study(f / "study"))
    return folder / "study"


@pytest.fixture(scope="module")
def clean_results(tiny_study, tmp_path_factory):
    def build(folder):
        return analyze(tiny_study, folder / "results", n_workers=2, progress=False, params=SIM)

    folder, res = once_per_run(tmp_path_factory, "pipeline-clean-results", build)
    return res, folder / "results"


@pytest.fixture(scope="module")
def clean_report(clean_results, tmp_path_factory):
    """``(results, fit summary, report)``: a copy of the clean results, fitted and reported,
    once per run: read-only, for the tests of the fit and report on top of `analyze`."""
    _, shared = clean_results

    def build(folder):
        from fingerfriction.report import make_report

        shutil.copytree(shared, folder / "results")
        return fit(folder / "results", progress=False), make_report(folder / "results")

    folder, (summary, rep) = once_per_run(tmp_path_factory, "pipeline-clean-report", build)
    return folder / "results", summary, rep


def _trial_ids(study: Path) -> list[str]:
    return [t["id"] for t in json.loads((study / "manifest.json").read_text())["trials"]]


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _fingerprint(out: Path, tid: str) -> dict:
    d = out / "trials" / tid
    return {name: (os.stat(d / name).st_mtime_ns, _digest(d / name))
            for name in ("frames.parquet", "forces.parquet", "status.json")}


@pytest.mark.slow
def test_end_to_end_tiny_study(tiny_study, clean_results, clean_report):
    res, out = clean_results
    ids = _trial_ids(tiny_study)
    assert res.n_trials == len(ids) == N_TINY
    assert res.n_computed == N_TINY and res.n_failed == 0 and res.success, res.failures
    assert res.scheduler == "local" and res.n_workers == 2
    store = ResultsStore(out)
    run = store.read_run()
    assert run["state"] == "complete"
    assert run["versions"]["numpy"] == np.__version__ and run["versions"]["dask"]
    assert run["parameters"]["forces"]["lowpass_hz"] == 500.0
    assert run["x_estimator"] == run["parameters"]["video"]["position"] == "hybrid"
    manifest = {t["id"]: t for t in json.loads((tiny_study / "manifest.json").read_text())["trials"]}
    for tid in ids:
        t = manifest[tid]
        assert run["inputs"][tid]["video"]["sha256"] == _digest(tiny_study / t["video"]["path"])
        assert run["inputs"][tid]["force"]["sha256"] == _digest(tiny_study / t["force"]["path"])
        fr, fo = store.read_frames(tid), store.read_forces(tid)
        assert len(fr) == t["video"]["n_frames"]
        tracked = np.isfinite(fr["x_mm"])  # the other frames are flagged, with their reasons
        assert (fr["flag"] == "").sum() == tracked.sum() > 50
        assert fr["x_mm"].min() < -2 and fr["x_mm"].max() > 2  # across the feature
        assert (fr["n_regions"][tracked] > 0).all()
        assert fr["flag"][~tracked].str.len().min() > 0
        # which estimator gave each frame's x(t): the hybrid's chord or an outline edge
        assert set(fr["x_source"][tracked]) <= {"chord", "left-edge", "right-edge"}
        assert (fr["x_source"][tracked] == "chord").any() and (fr["x_source"][~tracked] == "").all()
        assert np.diff(fo["x_mm"]).min() > 0 and np.isfinite(fo["F_T_N"]).all()
        # the paper's 26 mm window, covered by x(t) itself (hybrid): nothing extrapolated
        assert fo["x_mm"].iloc[0] == pytest.approx(-13.0) and fo["x_mm"].iloc[-1] == pytest.approx(13.0)
        assert fr["x_mm"].min() < -12.5 and fr["x_mm"].max() > 12.5
        assert store.status(tid)["info"]["forces"]["flags"] == []
    # the fit and the report on top (of a copy of these results: clean_report)
    _, summary, rep = clean_report
    assert summary.n_trials == N_TINY and set(summary.mu) == {"1"}
    assert rep.html.is_file() and rep.table1 is not None
    assert "mu" in rep.truth  # a simulated study: recovered next to the truth
    mu = rep.truth["mu"]  # one row per model variant, the one used (load-consistent) first
    from fingerfriction.fit.variants import MODELS

    assert mu["model"].tolist() == ["load", *[m for m in MODELS if m != "load"]]
    assert mu["mu_true"].tolist() == [0.55] * len(MODELS)  # the simulator's subject 1
    track = rep.truth["tracking"]
    assert track["n_trials"].tolist() == [N_TINY] and np.all(track["x_rms_max_mm"] < 1.0)


@pytest.mark.slow
def test_interrupted_run_resumes_without_loss_or_recomputation(tiny_study, tmp_path):
    shutil.copytree(tiny_study, tmp_path / "study")  # a force file is edited below
    tiny_study = tmp_path / "study"
    out = tmp_path / "results"
    ids = _trial_ids(tiny_study)
    k = 2

    class Stop(KeyboardInterrupt):
        pass

    done = []

    def stop_after_k(outcome):
        if outcome.status == "ok":
            done.append(outcome.trial_id)
        if len(done) == k:
            raise Stop  # the user presses Ctrl-C after k trials

    with pytest.raises(Stop):
        analyze(tiny_study, out, n_workers=1, progress=False, params=SIM, callback=stop_after_k)
    store = ResultsStore(out)
    assert sorted(t for t in ids if (store.status(t) or {}).get("status") == "ok") == sorted(done)
    assert store.read_run()["state"] == "interrupted"
    before = {tid: _fingerprint(out, tid) for tid in done}

    seen = []
    res = analyze(tiny_study, out, n_workers=1, progress=False, params=SIM, callback=seen.append)
    assert res.n_skipped == k and res.n_computed == len(ids) - k and res.n_failed == 0
    assert sorted(o.trial_id for o in seen if o.status == "skipped") == sorted(done)
    assert sorted(o.trial_id for o in seen if o.status == "ok") == sorted(set(ids) - set(done))
    for tid in done:  # finished trials untouched: same bytes, same modification times
        assert _fingerprint(out, tid) == before[tid]
    runs = store.read_run()["runs"]
    assert [r["interrupted"] for r in runs] == [True, False]
    assert [r["computed"] for r in runs] == [k, len(ids) - k]

    # a third run recomputes nothing (and starts no cluster); other parameters recompute
    again = analyze(tiny_study, out, n_workers=1, progress=False, params=SIM)
    assert again.n_computed == 0 and again.n_skipped == len(ids) and again.scheduler == "none"
    assert not store.is_finished(ids[0], "digest of other parameters")
    # an input file touched (a new modification time, the same bytes) is not a change; one
    # edited in place, its modification time kept, is analysed again (the content decides)
    t0 = json.loads((tiny_study / "manifest.json").read_text())["trials"][0]
    force_file = tiny_study / t0["force"]["path"]
    st, original = force_file.stat(), force_file.read_bytes()
    try:
        os.utime(force_file, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
        touched = analyze(tiny_study, out, n_workers=1, progress=False, params=SIM)
        assert touched.n_computed == 0 and touched.n_skipped == len(ids)
        with np.load(force_file) as z:
            arrays = {k: z[k].copy() for k in z.files}
        arrays["F1"][100] += 1e-6
        np.savez(force_file, **arrays)
        os.utime(force_file, ns=(st.st_atime_ns, st.st_mtime_ns))
        seen = []
        changed = analyze(tiny_study, out, n_workers=1, progress=False, params=SIM, callback=seen.append)
    finally:
        force_file.write_bytes(original)
        os.utime(force_file, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert changed.n_computed == 1 and changed.n_skipped == len(ids) - 1
    assert [o.trial_id for o in seen if o.status == "ok"] == [t0["id"]]


@pytest.mark.slow
def test_corrupt_trial_is_reported_and_the_others_are_intact(tiny_study, clean_results, tmp_path):
    _, clean = clean_results
    study = tmp_path / "study"
    shutil.copytree(tiny_study, study)
    manifest = json.loads((study / "manifest.json").read_text())
    bad = manifest["trials"][1]
    video = study / bad["video"]["path"]
    data = video.read_bytes()
    video.write_bytes(data[: len(data) // 3])  # a truncated video file

    res = analyze(study, tmp_path / "results", n_workers=2, progress=False, params=SIM)
    assert res.n_failed == 1 and res.n_computed == N_TINY - 1
    (tid, reason), = res.failures
    assert tid == bad["id"] and reason and "\n" not in reason
    store = ResultsStore(tmp_path / "results")
    assert store.status(tid)["status"] == "failed"
    assert store.read_run()["trial_status"][tid]["reason"] == reason
    for t in manifest["trials"]:
        if t["id"] == tid:
            continue
        pd.testing.assert_frame_equal(store.read_frames(t["id"]), ResultsStore(clean).read_frames(t["id"]))
        pd.testing.assert_frame_equal(store.read_forces(t["id"]), ResultsStore(clean).read_forces(t["id"]))
    # the fit and report go on with the good trials and list the bad one
    fit(tmp_path / "results", progress=False)
    from fingerfriction.report import make_report

    html = make_report(tmp_path / "results", sample=0).html.read_text()  # the flagged trial's page alone
    assert tid in html


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.mark.slow
def test_run_on_a_separate_dask_scheduler_and_worker(tiny_study, clean_results, tmp_path):
    from distributed import Client

    _, clean = clean_results
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])}
    port = _free_port()
    addr = f"tcp://127.0.0.1:{port}"
    procs = []
    logs = [open(tmp_path / "scheduler.log", "w"), open(tmp_path / "worker.log", "w")]
    try:
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "dask", "scheduler", "--host", "127.0.0.1", "--port", str(port),
             "--no-dashboard"], env=env, stdout=logs[0], stderr=subprocess.STDOUT))
        procs.append(subprocess.Popen(
            [sys.executable, "-m", "dask", "worker", addr, "--host", "127.0.0.1", "--nworkers", "1",
             "--nthreads", "1", "--no-dashboard", "--name", "external-worker",
             "--no-nanny"],  # the worker itself, not a nanny starting it as a third interpreter
            env=env, stdout=logs[1], stderr=subprocess.STDOUT))
        deadline = time.monotonic() + 90
        while True:
            try:
                with Client(addr, timeout="5s") as c:
                    c.wait_for_workers(1, timeout=60)
                    workers = c.scheduler_info()["workers"]
                    break
            except (OSError, TimeoutError):
                if time.monotonic() > deadline or any(p.poll() is not None for p in procs):
                    raise
                time.sleep(0.5)
        assert [w["name"] for w in workers.values()] == ["external-worker"]

        # on a copy of the local cluster's results, with force: everything is recomputed
        shutil.copytree(clean, tmp_path / "results")
        res = analyze(tiny_study, tmp_path / "results", scheduler=addr, force=True, progress=False,
                      params=SIM)
        assert res.scheduler == addr and res.n_workers == 1
        assert res.n_computed == N_TINY and res.n_skipped == 0 and res.n_failed == 0, res.failures
        assert ResultsStore(tmp_path / "results").read_run()["runs"][-1]["scheduler"] == addr
        for tid in _trial_ids(tiny_study):  # same results as on the local cluster
            pd.testing.assert_frame_equal(ResultsStore(tmp_path / "results").read_frames(tid),
                                          ResultsStore(clean).read_frames(tid))
        assert all(p.poll() is None for p in procs)  # the cluster outlives the run
    finally:
        for p in reversed(procs):
            p.terminate()
        for p in reversed(procs):
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        for f in logs:
            f.close()


@pytest.mark.slow
def test_analyze_command_interrupted_by_ctrl_c_then_resumed(tiny_study, tmp_path):
    """A real interruption: SIGINT to `fingerfriction analyze` once a trial is finished."""
    import signal

    out = tmp_path / "results"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")])}
    cmd = [sys.executable, "-m", "fingerfriction.cli", "analyze", str(tiny_study), "--out", str(out),
           "--workers", "1", "--simulated"]
    # a shell's background job inherits SIGINT ignored (and Python then installs no
    # KeyboardInterrupt handler): restore the default, as for a command in a terminal
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                            start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 240
        while time.monotonic() < deadline and proc.poll() is None:
            done = [p.parent.name for p in out.glob("trials/*/status.json")]
            if done:
                break
            time.sleep(0.05)
        assert proc.poll() is None, "analyze finished before it could be interrupted"
        os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C in the terminal
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    store = ResultsStore(out)
    finished = [t for t in _trial_ids(tiny_study) if (store.status(t) or {}).get("status") == "ok"]
    assert 1 <= len(finished) < N_TINY
    before = {tid: _fingerprint(out, tid) for tid in finished}
    res = analyze(tiny_study, out, n_workers=1, progress=False, params=SIM)
    assert res.n_skipped == len(finished) and res.n_computed == N_TINY - len(finished) and res.n_failed == 0
    for tid in finished:
        assert _fingerprint(out, tid) == before[tid]


def test_frames_table_keeps_the_position_source():
    frames = frames_table(np.zeros(3), [np.nan, 1.0, 2.0], np.full((3, 1, 2), np.nan),
                          x_source=["", "chord", "left-edge"])
    assert list(frames["x_source"]) == ["", "chord", "left-edge"]
    assert "x_source" not in frames_table(np.zeros(3), np.zeros(3), np.full((3, 1, 2), np.nan)).columns
    with pytest.raises(ValueError, match="x_source has 2 entries but t_s has 3"):
        frames_table(np.zeros(3), np.zeros(3), np.full((3, 1, 2), np.nan), x_source=["", ""])


@pytest.mark.slow
def test_force_history_is_stored_and_shown_in_the_run_record(clean_results, clean_report):
    """Every step of the force processing, with its fitted values, is in each trial's
    status.json and, as readable lines, in the report's run record."""
    _, out = clean_results
    store = ResultsStore(out)
    tid = store.trial_ids()[0]
    history = store.status(tid)["info"]["forces"]["history"]
    steps = [h["step"] for h in history]
    assert steps == ["decompose", "remove_baseline", "lowpass", "compensate_highpass", "remove_rest_drift",
                     "remove_drift"]
    assert history[3]["cutoff_hz"] == 5.0 and np.isfinite(history[4]["F_T_slope_N_per_s"])
    page = clean_report[2].html.read_text(encoding="utf-8")  # the report of a copy of these results
    assert "sensor high-pass inverted at 5 Hz (first order)" in page
    assert "residual drift fitted through the compensation on the rests" in page
    assert "{&#39;step&#39;" not in page and "{'step'" not in page  # readable lines, not dict text
    assert "<td>forces</td><td>lowpass_hz</td><td>500</td>" in page  # parameters one per row


@pytest.mark.slow
def test_forces_from_video_is_what_analyze_stores(tiny_study, clean_results, tmp_path):
    """`forces --from-video` runs the video stage with the options `analyze` uses: the same
    F_T(x) as the results store holds."""
    from fingerfriction.cli import main

    _, out = clean_results
    tid = _trial_ids(tiny_study)[0]
    csv = tmp_path / "ft.csv"
    assert main(["forces", str(tiny_study), tid, "--from-video", "--out", str(csv)]) == 0
    mine = pd.read_csv(csv)
    stored = ResultsStore(out).read_forces(tid)
    np.testing.assert_allclose(mine["x_mm"], stored["x_mm"], atol=1e-9)
    np.testing.assert_allclose(mine["F_T_N"], stored["F_T_N"], rtol=1e-7, atol=1e-12)
