"""A lab's own recordings, end to end on a lab-style folder: `init` -> `check` -> `analyze` -> `fit` with
no hand-written JSON, and edits that recompute only what changed.

The folder (tests/pipeline/lab_folder.py) holds the virtual experiment's recordings rewritten as a
lab would have them: .cine and TIFF videos, TDMS and headerless ';' CSV forces in volts,
lab file names, a stray note and a video without its force file.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from fingerfriction.cli import app

sys.path.insert(0, str(Path(__file__).parent))
from lab_folder import INIT_ARGS, simulate_source, write_lab_folder  # noqa: E402

runner = CliRunner()
pytestmark = pytest.mark.slow


def _run(*args):
    r = runner.invoke(app, [str(a) for a in args])
    return r.exit_code, " ".join(r.output.split())


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    base = tmp_path_factory.mktemp("lab")
    source = simulate_source(base / "source")
    names = write_lab_folder(source, base / "lab")
    return base, source, base / "lab", names


@pytest.fixture(scope="module")
def analysed(lab):
    """`init` then `analyze` on the lab folder (the first acceptance point's first half)."""
    base, source, study, names = lab
    code, out = _run("init", study, *INIT_ARGS, "--dry-run")
    assert code == 0, out
    assert not (study / "manifest.json").exists()  # --dry-run writes nothing
    code, out = _run("init", study, *INIT_ARGS)
    assert code == 0, out
    code, check_out = _run("check", study)
    assert code == 0, check_out
    code, analyze_out = _run("analyze", study, "--out", base / "lab-results", "-j", 2)
    assert code == 0, analyze_out
    return base, source, study, names, out, analyze_out


def test_init_analyze_fit_on_lab_files(analysed):
    base, source, study, names, init_out, analyze_out = analysed
    # init printed the trials it found and the files it did not use
    assert "8 trials found (8 without problems)" in init_out
    assert "2 file(s) not used" in init_out and "raw/notes.txt: matches no pattern" in init_out
    assert "raw/S1_bump-2mm_120mms_3.cine: video without a force file" in init_out
    manifest = json.loads((study / "manifest.json").read_text())
    entries = {Path(t["video"]["path"]).stem: t for t in manifest["trials"]}
    assert set(entries) == set(names)
    src = {t["id"]: t for t in json.loads((source / "manifest.json").read_text())["trials"]}
    for stem, t in entries.items():
        s = src[names[stem]]
        # what the files said about themselves, and what the options said
        assert t["video"]["format"] == ("cine" if stem.startswith("S1_") else "tiff")
        assert (t["video"]["n_frames"], t["video"]["fps"]) == (s["video"]["n_frames"], 250.0)
        assert (t["video"]["width"], t["video"]["height"]) == (1280, 360)
        assert t["video"]["t0_s"] == 0.08 and t["surface"] == s["surface"]
        assert t["force"]["n_samples"] == s["force"]["n_samples"] and t["force"]["fs_hz"] == 10000.0
        assert t["force"]["units"] == "V" and t["force"]["sensitivity_n_per_v"] == {"F1": 10.0, "F2": 20.0}
        assert t["force"]["format"] == ("tdms" if stem.endswith("_1") else "csv")
        assert t["calibration"]["surface_height_mm"] == s["calibration"]["surface_height_mm"]
    assert "8 computed, 0 already done, 0 failed of 8 trials" in analyze_out
    # the lab files give the same results as the simulator's own files, trial by trial
    code, out = _run("analyze", source, "--out", base / "source-results", "-j", 2)
    assert code == 0 and "8 computed" in out, out
    for stem, t in entries.items():
        a = base / "lab-results" / "trials" / t["id"]
        b = base / "source-results" / "trials" / names[stem]
        fa, fb = pd.read_parquet(a / "forces.parquet"), pd.read_parquet(b / "forces.parquet")
        np.testing.assert_allclose(fa["x_mm"], fb["x_mm"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(fa["F_T_N"], fb["F_T_N"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(fa["F_T_abs_N"], fb["F_T_abs_N"], rtol=0, atol=1e-9)
        xa = pd.read_parquet(a / "frames.parquet")["x_mm"]
        np.testing.assert_array_equal(xa, pd.read_parquet(b / "frames.parquet")["x_mm"])
    # the fit of the lab's trials (not its validation, which the fit tests test): --no-validate
    code, out = _run("fit", base / "lab-results", "--no-validate")
    assert code == 0, out
    assert "fit: 8 trials," in out and "not validated: not requested" in out
    assert not (base / "lab-results" / "fit" / "loso.csv").exists()
    fitted = pd.read_csv(base / "lab-results" / "fit" / "trials.csv")
    assert sorted(set(fitted["trial"])) == sorted(t["id"] for t in entries.values())
    from fingerfriction.fit.variants import MODELS

    assert set(fitted["model"]) == set(MODELS)  # one row per trial and model


def test_edits_recompute_only_what_changed(analysed, tmp_path):
    base, source, study, names, *_ = analysed
    # a copy of the study that shares the recordings (hard links) and of its results
    mine = tmp_path / "study"
    for p in study.rglob("*"):
        if p.is_file():
            (mine / p.relative_to(study)).parent.mkdir(parents=True, exist_ok=True)
            os.link(p, mine / p.relative_to(study))
    (mine / "manifest.json").unlink()
    shutil.copy(study / "manifest.json", mine / "manifest.json")
    results = tmp_path / "results"
    shutil.copytree(base / "lab-results", results)

    code, out = _run("analyze", mine, "--out", results, "--dry-run")
    assert code == 0 and "would compute 0 and skip 8 of 8 trials" in out, out

    m = json.loads((mine / "manifest.json").read_text())
    edited = m["trials"][3]
    edited["force"]["t0_s"] = 0.002
    (mine / "manifest.json").write_text(json.dumps(m, indent=2))
    code, out = _run("analyze", mine, "--out", results, "--dry-run")
    assert code == 0 and "would compute 1 and skip 7 of 8 trials" in out, out
    assert f"{edited['id']}: compute (manifest entry changed: force.t0_s)" in out
    assert out.count(": skip (unchanged)") == 7
    code, out = _run("analyze", mine, "--out", results, "-j", 1)
    assert code == 0 and "1 computed, 7 already done, 0 failed of 8 trials" in out, out

    m["trials"][5]["calibration"]["surface_height_mm"] *= 1.01
    (mine / "manifest.json").write_text(json.dumps(m, indent=2))
    code, out = _run("analyze", mine, "--out", results, "--dry-run")
    assert f"{m['trials'][5]['id']}: compute (manifest entry changed: calibration.surface_height_mm)" in out

    (mine / "manifest.json").write_text(json.dumps(json.loads((study / "manifest.json").read_text())))
    edited_file = mine / m["trials"][2]["force"]["path"]  # edited in place, its times kept
    st, data = edited_file.stat(), edited_file.read_bytes()
    edited_file.unlink()  # (a hard link shared with the lab folder: a new file, not an edit of both)
    if edited_file.suffix == ".csv":  # the last digit of the file, one more (or less)
        i = max(k for k in range(len(data)) if data[k:k + 1].isdigit())
        data = data[:i] + (b"8" if data[i:i + 1] == b"9" else bytes([data[i] + 1])) + data[i + 1:]
    else:  # TDMS: the lowest bit of the last sample (of the unused trigger channel)
        data = data[:-8] + bytes([data[-8] ^ 1]) + data[-7:]
    edited_file.write_bytes(data)
    os.utime(edited_file, ns=(st.st_atime_ns, st.st_mtime_ns))
    code, out = _run("analyze", mine, "--out", results, "--dry-run", "--window-mm", 24)
    assert code == 0 and "would compute 8 and skip 0 of 8 trials" in out, out
    assert out.count("parameters changed: forces.window_mm") == 8
    both = "parameters changed: forces.window_mm; "
    assert f"{m['trials'][2]['id']}: compute ({both}input changed: force)" in out
    assert f"{m['trials'][3]['id']}: compute ({both}manifest entry changed: force.t0_s)" in out
    code, out = _run("analyze", mine, "--out", results, "-j", 2, "--window-mm", 24)
    assert code == 0 and "8 computed, 0 already done, 0 failed of 8 trials" in out, out
    code, out = _run("analyze", mine, "--out", results, "-j", 2, "--window-mm", 24)
    assert code == 0 and "0 computed, 8 already done, 0 failed of 8 trials" in out, out
    x = pd.read_parquet(results / "trials" / m["trials"][0]["id"] / "forces.parquet")["x_mm"]
    assert x.iloc[0] == pytest.approx(-12.0) and x.iloc[-1] == pytest.approx(12.0)


def test_a_minimal_manifest_gives_the_same_results(analysed, tmp_path):
    """An entry with only what the files cannot say (no format, rate, size, counts,
    repetition, calibration, surfaces block) is analysed as the full one."""
    base, source, study, names, *_ = analysed
    full = json.loads((study / "manifest.json").read_text())
    t = next(e for e in full["trials"] if e["force"]["format"] == "csv" and e["video"]["format"] == "tiff")
    mine = tmp_path / "study"
    for rel in (t["video"]["path"], t["force"]["path"]):
        (mine / rel).parent.mkdir(parents=True, exist_ok=True)
        os.link(study / rel, mine / rel)
    f = t["force"]
    minimal = {"format": "fingerfriction-study", "schema_version": 1, "trials": [{
        "id": t["id"], "subject": t["subject"], "surface": t["surface"], "speed_mm_s": t["speed_mm_s"],
        "video": {"path": t["video"]["path"], "fps": 250, "t0_s": 0.08},
        "force": {k: f[k] for k in ("path", "channels", "time", "units", "sensitivity_n_per_v")}}]}
    (mine / "manifest.json").write_text(json.dumps(minimal))
    code, out = _run("check", mine)
    assert code == 0 and "1 trials, no problem found" in out, out
    code, out = _run("analyze", mine, "--out", tmp_path / "results", "-j", 1)
    assert code == 0 and "1 computed" in out, out
    a = pd.read_parquet(tmp_path / "results" / "trials" / t["id"] / "forces.parquet")
    b = pd.read_parquet(base / "lab-results" / "trials" / t["id"] / "forces.parquet")
    pd.testing.assert_frame_equal(a, b)
