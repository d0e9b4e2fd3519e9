"""build_manifest (fingerfriction init): trials from file names, fields from the files."""

from __future__ import annotations

import numpy as np
import pytest

from fingerfriction.study.init import InitOptions, build_manifest
from fingerfriction.video.writers import write_video

V = "raw/S{subject}_{surface}_{speed}mms_{repetition}.cine"
VT = "raw/S{subject}_{surface}_{speed}mms_{repetition}.tif"
F = "raw/S{subject}_{surface}_{speed}mms_{repetition}.csv"


def _frames(n=6):
    return np.full((n, 24, 40), 200, np.uint8)


def _csv(path, n=1000, fs=2000.0, volts=True, t_start=0.0):
    t = t_start + np.arange(n) / fs
    a, b = np.sin(t), np.cos(t)
    rows = zip(t.tolist(), a.tolist(), b.tolist(), strict=True)
    path.write_text("".join(f"{ti!r};{ai!r};{bi!r}\n" for ti, ai, bi in rows))


@pytest.fixture
def lab(tmp_path):
    raw = tmp_path / "raw"
    raw.mkdir()
    write_video(raw / "S1_bump-2mm_40mms_1.cine", _frames(6), fps=500.0)
    write_video(raw / "S1_SU4_40mms_1.tif", _frames(7))  # a TIFF states no rate
    _csv(raw / "S1_bump-2mm_40mms_1.csv")
    _csv(raw / "S1_SU4_40mms_1.csv", n=900)
    (raw / "notes.txt").write_text("session notes")
    return tmp_path


def _opts(**kw):
    d = dict(video=(V, VT), forces=(F,), surfaces={"SU4": "step-up-4mm"}, fps=500.0, video_t0_s=0.08,
             force={"csv": {"channels": {"F1": 1, "F2": 2}, "time": 0, "units": "V",
                            "sensitivity_n_per_v": {"F1": 10.0, "F2": 20.0}}})
    d.update(kw)
    return InitOptions(**d)


def test_fields_come_from_the_files_and_the_options(lab):
    res = build_manifest(lab, _opts(), created_by="test")
    assert res.problems == () and res.n_ok == 2
    assert [(u.path, u.reason) for u in res.unmatched] == [("raw/notes.txt", "matches no pattern")]
    by_id = {t["id"]: t for t in res.manifest["trials"]}
    assert set(by_id) == {"s1-bump-2mm-v040-r1", "s1-SU4-v040-r1"}
    cine = by_id["s1-bump-2mm-v040-r1"]
    assert cine["surface"] == "bump-2mm" and cine["calibration"] == {"surface_height_mm": pytest.approx(0.4)}
    assert cine["video"] == {"path": "raw/S1_bump-2mm_40mms_1.cine", "format": "cine", "fps": 500.0,
                             "width": 40, "height": 24, "n_frames": 6, "t0_s": 0.08, "calibration_frame": 0}
    f = cine["force"]
    assert (f["format"], f["n_samples"], f["units"], f["time"]) == ("csv", 1000, "V", 0)
    assert f["fs_hz"] == pytest.approx(2000.0) and f["channels"] == {"F1": 1, "F2": 2}
    assert f["sensitivity_n_per_v"] == {"F1": 10.0, "F2": 20.0}
    tif = by_id["s1-SU4-v040-r1"]
    assert tif["surface"] == "step-up-4mm" and tif["video"]["format"] == "tiff"
    assert tif["video"]["n_frames"] == 7 and tif["force"]["n_samples"] == 900
    assert res.manifest["surfaces"] == {}  # built-in names go into the trials directly


def test_every_problem_is_listed_and_its_trial_left_out(lab):
    (lab / "raw" / "S2_ramp_40mms_1.cine").write_bytes(b"not a cine")
    _csv(lab / "raw" / "S2_ramp_40mms_1.csv")
    write_video(lab / "raw" / "S2_bump-2mm_80mms_1.cine", _frames(), fps=250.0)  # not the --fps
    _csv(lab / "raw" / "S2_bump-2mm_80mms_1.csv", fs=1000.0)
    res = build_manifest(lab, _opts(surfaces={}))
    assert res.n_ok == 1
    text = "\n".join(res.problems)
    assert "surface 'SU4' of the file name: unknown surface 'SU4'" in text
    assert "--surface SU4=NAME_OR_SPEC" in text
    assert "surface 'ramp' of the file name" in text
    assert "S2_bump-2mm_80mms_1.cine: the video states 250 fps but --fps 500 was given" in text
    assert len(res.problems) == 3 and len(res.trials) == 4
    ids = [t["id"] for t in res.manifest["trials"]]
    assert ids == ["s1-bump-2mm-v040-r1"]


def test_force_options_per_format_and_missing_channels(lab):
    res = build_manifest(lab, _opts(force={"csv": {"units": "V", "sensitivity_n_per_v": 10.0}}))
    assert res.n_ok == 0
    assert any("no column 'F1' (channel F1)" in p and "no header row" in p for p in res.problems)
    with pytest.raises(ValueError, match="force options for format 'xlsx'"):
        _opts(force={"xlsx": {}})
    with pytest.raises(ValueError, match=r"unknown force option\(s\) \['gain'\]"):
        _opts(force={None: {"gain": 2.0}})


def test_no_fps_for_a_tiff_is_a_problem(lab):
    res = build_manifest(lab, _opts(fps=None))
    assert res.problems == (
        "raw/S1_SU4_40mms_1.tif: the video does not state its frame rate; give it (--fps)",)


def test_command_line_values():
    from fingerfriction.study.init import parse_force_options, parse_mapping

    got = parse_force_options(channels=["tdms:Piezo/ai0,Piezo/ai1", "csv:1,2"], time=["csv:0"], units=["V"],
                              sensitivity=["10,20"], gain=[], fs_hz=["csv:5000"], t0_s=["-0.01"])
    assert got == {
        "tdms": {"channels": {"F1": "Piezo/ai0", "F2": "Piezo/ai1"}},
        "csv": {"channels": {"F1": 1, "F2": 2}, "time": 0, "fs_hz": 5000.0},
        None: {"units": "V", "sensitivity_n_per_v": {"F1": 10.0, "F2": 20.0}, "t0_s": -0.01},
    }
    assert parse_force_options(gain=["0.1"]) == {None: {"gain_v_per_n": 0.1}}
    with pytest.raises(ValueError, match=r"--channels takes two values F1,F2 .* got 'ai0'"):
        parse_force_options(channels=["ai0"])
    with pytest.raises(ValueError, match=r"--sensitivity must be a number, got 'ten'"):
        parse_force_options(sensitivity=["ten"])
    with pytest.raises(ValueError, match=r"--units is given twice for csv files"):
        parse_force_options(units=["csv:V", "csv:mV"])
    assert parse_mapping(["SU4=step-up-4mm", "B=bump:W=3,H=0.5"], "--surface") == {
        "SU4": "step-up-4mm", "B": "bump:W=3,H=0.5"}
    assert parse_mapping(["0.4", "bump-4mm=0.8"], "--surface-height-mm", convert=float,
                         allow_default=True) == {None: 0.4, "bump-4mm": 0.8}
    with pytest.raises(ValueError, match=r"--surface takes KEY=VALUE, got 'SU4'"):
        parse_mapping(["SU4"], "--surface")


@pytest.mark.slow
def test_init_command_refusals_and_skip_bad(lab):
    import json

    from typer.testing import CliRunner

    from fingerfriction.cli import app

    runner = CliRunner()
    args = ["init", str(lab), "--video", V, "--video", VT, "--forces", F, "--surface", "SU4=step-up-4mm",
            "--fps", "500", "--channels", "csv:1,2", "--time", "csv:0", "--units", "V",
            "--sensitivity", "10,20"]
    (lab / "raw" / "S2_bump-2mm_40mms_1.cine").write_bytes(b"not a cine")
    _csv(lab / "raw" / "S2_bump-2mm_40mms_1.csv")

    def run(*extra):
        r = runner.invoke(app, [*args, *extra])
        return r.exit_code, " ".join(r.output.split())

    code, out = run()
    assert code == 2 and "raw/S2_bump-2mm_40mms_1.cine" in out
    assert "1 of 3 trials have problems (listed above); fix them, or give --skip-bad to write the 2 " in out
    assert not (lab / "manifest.json").exists()
    code, out = run("--skip-bad", "--dry-run")  # a trial left out: status 1
    assert code == 1 and "would hold 2 trials (1 with problems left out); nothing was written" in out
    assert not (lab / "manifest.json").exists()
    code, out = run("--skip-bad")
    assert code == 1 and "manifest.json: 2 trials (1 with problems left out)" in out, out
    assert len(json.loads((lab / "manifest.json").read_text())["trials"]) == 2
    code, out = run("--skip-bad")
    assert code == 2 and "manifest.json exists; give --overwrite to replace it" in out
    code, out = run("--skip-bad", "--overwrite")
    assert code == 1
    r = runner.invoke(app, ["init", str(lab), "--video", "raw/{subject}_{surface}_{speed}.avi",
                            "--forces", F])
    assert r.exit_code == 2 and "different fields" in " ".join(r.output.split())
    r = runner.invoke(app, ["init", str(lab), "--video", "nope/" + V.split("/", 1)[1], "--forces", F])
    assert r.exit_code == 2 and "no trial found" in " ".join(r.output.split())
