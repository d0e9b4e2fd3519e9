"""A video's frame rate from its time stamps: the readers, ``init`` and ``check``
share one rule: the frames' time stamps win over the header's nominal setting, which is
kept as a cross-check and named when it disagrees."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from fingerfriction.cli import app
from fingerfriction.study.check import check_study
from fingerfriction.study.init import InitOptions, build_manifest
from fingerfriction.video.cine import read_cine_header, write_cine
from fingerfriction.video.readers import frame_rate, open_video, probe_video

DATA = Path(__file__).resolve().parents[1] / "data"
CINE_781 = DATA / "cine" / "cine_781.cine"
runner = CliRunner()


def test_the_real_phantom_file_reads_at_its_time_stamps_rate():
    """pims' cine_781.cine: SETUP says 90000 fps, the 15 time stamps are 111.07 us apart."""
    hdr = read_cine_header(CINE_781)
    assert hdr.fps == 90000.0 and hdr.image_count == 15
    assert np.diff(hdr.timestamps_s) == pytest.approx(111.07e-6, abs=0.01e-6)
    with open_video(CINE_781) as r:
        assert r.fps == pytest.approx(9003.2, abs=0.1)
        assert r.rate.nominal == 90000.0 and r.rate.source == "time stamps"
        assert "header states 90000 fps" in r.rate.note and "111.07 us" in r.rate.note
        frames = np.concatenate([c.copy() for _, c in r.iter_chunks(8)])
    assert frames.shape == (15, 256, 256) and frames.dtype == np.uint16 and frames.std() > 0


@pytest.mark.parametrize("stamps_fps,expect_fps,noted", [(1000.0, 1000.0, False), (1020.0, 1020.0, True),
                                                         (1000.05, 1000.0, False)])
def test_written_time_stamps_decide_the_rate(tmp_path, stamps_fps, expect_fps, noted):
    """Time stamps within 1e-4 of the nominal rate agree with it (the nominal is kept);
    beyond, they win and the reader says so."""
    p = tmp_path / "a.cine"
    write_cine(p, np.zeros((40, 8, 8), np.uint8), fps=1000.0, timestamps_s=np.arange(40) / stamps_fps)
    info = probe_video(p)
    assert info.fps == pytest.approx(expect_fps, rel=1e-6)
    assert bool(info.rate.note) is noted
    assert info.rate.timestamps == pytest.approx(stamps_fps, rel=1e-6)


def test_a_cine_without_time_stamps_keeps_its_header_rate(tmp_path):
    p = tmp_path / "a.cine"
    write_cine(p, np.zeros((5, 8, 8), np.uint8), fps=250.0)
    assert read_cine_header(p).timestamps_s is None
    info = probe_video(p)
    assert (info.fps, info.rate.source, info.rate.note) == (250.0, "header", "")


def test_frame_rate_rule():
    assert frame_rate(None).source == "none"
    assert frame_rate(None, np.arange(10) / 500.0).fps == pytest.approx(500.0)
    # a time base of 1 ms quantises 30 fps stamps: within the resolution, no disagreement
    t = np.round(np.arange(90) / 30.0, 3)
    r = frame_rate(30.0, t, resolution_s=1e-3)
    assert (r.fps, r.note) == (30.0, "")
    r = frame_rate(30.0, np.arange(90) / 31.0, resolution_s=1e-3)
    assert r.fps == pytest.approx(31.0) and "header states 30 fps" in r.note


def _lab(root: Path) -> Path:
    raw = root / "raw"
    raw.mkdir(parents=True)
    shutil.copy(CINE_781, raw / "S1_bump-2mm_40mms_1.cine")
    np.savez(raw / "S1_bump-2mm_40mms_1.npz", F1=np.zeros(500), F2=np.ones(500))
    return root


def _init_opts(**kw):
    return InitOptions(video="raw/S{subject}_{surface}_{speed}mms_{repetition}.cine",
                       forces="raw/S{subject}_{surface}_{speed}mms_{repetition}.npz",
                       force={None: {"fs_hz": 10000.0}}, **kw)


def test_init_writes_the_time_stamps_rate_and_says_why(tmp_path):
    lab = _lab(tmp_path)
    res = build_manifest(lab, _init_opts())
    assert res.problems == ()
    assert res.manifest["trials"][0]["video"]["fps"] == pytest.approx(9003.21, abs=0.01)
    assert len(res.notes) == 1 and "raw/S1_bump-2mm_40mms_1.cine" in res.notes[0]
    assert "90000" in res.notes[0]


def test_init_lets_a_user_confirm_the_rate_and_refuses_the_header_one(tmp_path):
    lab = _lab(tmp_path)
    ok = build_manifest(lab, _init_opts(fps=9003.0))  # the user's reading of the time stamps
    assert ok.problems == () and ok.manifest["trials"][0]["video"]["fps"] == pytest.approx(9003.21, abs=0.01)
    bad = build_manifest(lab, _init_opts(fps=90000.0))
    assert len(bad.problems) == 1
    assert "time stamps say 9003.21 fps (its header: 90000) but --fps 90000 was given" in bad.problems[0]


def test_init_command_prints_the_note(tmp_path):
    lab = _lab(tmp_path)
    pattern = "raw/S{subject}_{surface}_{speed}mms_{repetition}"
    r = runner.invoke(app, ["init", str(lab), "--video", pattern + ".cine", "--forces", pattern + ".npz",
                            "--fs-hz", "10000"])
    assert r.exit_code == 0, r.output
    assert "note:" in r.output and "111.07 us" in " ".join(r.output.split())
    fps = json.loads((lab / "manifest.json").read_text())["trials"][0]["video"]["fps"]
    assert fps == pytest.approx(9003.21, abs=0.01)


def _manifest(root: Path, fps: float) -> None:
    trial = {"id": "t1", "subject": "1", "surface": "bump-2mm", "speed_mm_s": 40,
             "video": {"path": "raw/S1_bump-2mm_40mms_1.cine", "fps": fps},
             "force": {"path": "raw/S1_bump-2mm_40mms_1.npz", "fs_hz": 10000.0}}
    (root / "manifest.json").write_text(json.dumps({"format": "fingerfriction-study", "schema_version": 1,
                                                    "trials": [trial]}))


def test_check_uses_the_same_rule(tmp_path):
    lab = _lab(tmp_path)
    _manifest(lab, 90000.0)  # what the former reader wrote: the header's setting
    res = check_study(lab)
    assert len(res.problems) == 1
    line = str(res.problems[0])
    assert "trials[0].video.fps" in line and "the file's frame time stamps say 9003.21 Hz" in line
    assert "header's 90000 Hz" in line
    _manifest(lab, 9003.2)  # typed by hand from the time stamps: confirmed
    assert check_study(lab).ok
