"""Tests of fingerfriction.study: manifest round trip, validation errors, path safety."""

from __future__ import annotations

import json
import os

import pytest

from fingerfriction.study import (
    ForceInfo,
    ManifestError,
    Study,
    TrialRecord,
    VideoInfo,
    load_manifest,
    resolve_path,
    validate_id,
    write_manifest,
)
from fingerfriction.surfaces import get_surface


def _trial(tid="s1-bump-2mm-v040-r1", **kw) -> TrialRecord:
    d = dict(
        id=tid, subject="1", surface="bump-2mm", speed_mm_s=40.0, repetition=1,
        video=VideoInfo(path=f"trials/{tid}/video.mkv", format="ffv1-mkv", fps=1000.0, width=1280,
                        height=720, n_frames=812, t0_s=0.0, calibration_frame=0),
        force=ForceInfo(path=f"trials/{tid}/forces.npz", format="npz", fs_hz=10000.0, n_samples=8120,
                        t0_s=-0.0125),
        calibration={"surface_height_mm": 0.4},
        truth=f"truth/{tid}.npz",
    )
    d.update(kw)
    return TrialRecord(**d)


def _study(trials=None) -> Study:
    return Study(trials=trials or [_trial()], surfaces={"bump-2mm": get_surface("bump-2mm").to_dict()},
                 description="test", created_by="tests")


def _write_raw(tmp_path, data) -> str:
    p = tmp_path / "manifest.json"
    p.write_text(json.dumps(data))
    return str(p)


def test_round_trip_and_deterministic_bytes(tmp_path):
    st = _study([_trial(), _trial("s2-bump-2mm-v080-r3", subject="2", speed_mm_s=80.0, repetition=3)])
    p = write_manifest(st, tmp_path)
    back = load_manifest(tmp_path)
    assert back == st
    assert back.root == tmp_path.resolve()
    assert back.trial("s2-bump-2mm-v080-r3").repetition == 3
    first = p.read_bytes()
    write_manifest(back, tmp_path)
    assert p.read_bytes() == first
    # the schema's example fields are all there
    d = json.loads(first)
    assert d["format"] == "fingerfriction-study" and d["schema_version"] == 1
    t = d["trials"][0]
    assert t["video"]["calibration_frame"] == 0 and t["force"]["channels"] == {"F1": "F1", "F2": "F2"}
    assert back.surface("bump-2mm") == get_surface("bump-2mm")


def test_frame_and_sample_times():
    t = _trial()
    ft = t.video.frame_times()
    assert ft.shape == (812,) and ft[1] - ft[0] == pytest.approx(1e-3)
    st = t.force.sample_times()
    assert st[0] == pytest.approx(-0.0125) and st.shape == (8120,)


def _base_dict():
    return _study().to_dict()


@pytest.mark.parametrize(
    "mutate, field, hint",
    [
        (lambda d: d["trials"][0]["video"].__setitem__("fps", -1), r"trials\[0\]\.video\.fps", "positive"),
        (lambda d: d["trials"][0]["video"].pop("n_frames"), r"trials\[0\]\.video\.n_frames",
         "not given, and the video cannot be read"),
        (lambda d: d["trials"][0]["video"].__setitem__("format", "gif"), r"trials\[0\]\.video\.format",
         "ffv1-mkv"),
        (lambda d: d["trials"][0]["video"].__setitem__("calibration_frame", 5000),
         r"trials\[0\]\.video\.calibration_frame", "n_frames"),
        (lambda d: d["trials"][0]["force"].__setitem__("fs_hz", "fast"), r"trials\[0\]\.force\.fs_hz",
         "number"),
        (lambda d: d["trials"][0]["force"].__setitem__("channels", {"F1": "a"}),
         r"trials\[0\]\.force\.channels", "F2"),
        (lambda d: d["trials"][0]["force"].__setitem__("path", "../../etc/passwd"),
         r"trials\[0\]\.force\.path", "escapes"),
        (lambda d: d["trials"][0]["video"].__setitem__("path", "/abs/video.mkv"),
         r"trials\[0\]\.video\.path", "relative"),
        (lambda d: d["trials"][0].__setitem__("id", "bad id/x"), r"trials\[0\]\.id", "letters"),
        (lambda d: d["trials"][0].__setitem__("speed_mm_s", 0), r"trials\[0\]\.speed_mm_s", "positive"),
        (lambda d: d["trials"][0].__setitem__("surface", "bump-9mm"), r"trials\[0\]\.surface", "not in"),
        (lambda d: d["trials"][0]["calibration"].pop("surface_height_mm"),
         r"trials\[0\]\.calibration\.surface_height_mm", "missing"),
        (lambda d: d["trials"].append(dict(d["trials"][0])), r"trials\[1\]\.id", "duplicate"),
        (lambda d: d.__setitem__("schema_version", 7), "schema_version", "schema 1"),
        (lambda d: d.__setitem__("format", "other"), "format", "fingerfriction-study"),
        (lambda d: d["surfaces"]["bump-2mm"].__setitem__("kind", "blob"), r"surfaces\.bump-2mm", "kind"),
        (lambda d: d.__setitem__("trials", {}), "trials", "list"),
    ],
)
def test_malformed_manifest_names_file_and_field(tmp_path, mutate, field, hint):
    d = _base_dict()
    mutate(d)
    path = _write_raw(tmp_path, d)
    with pytest.raises(ManifestError) as ei:
        load_manifest(path)
    msg = str(ei.value)
    assert msg.startswith(path + ": "), msg
    assert __import__("re").search(field, msg), msg
    assert hint in msg, msg
    assert "\n" not in msg


def test_unreadable_manifests(tmp_path):
    with pytest.raises(ManifestError, match="no such manifest"):
        load_manifest(tmp_path / "nothing.json")
    p = tmp_path / "manifest.json"
    p.write_text("{not json")
    with pytest.raises(ManifestError, match=r"manifest\.json: not valid JSON \(line 1"):
        load_manifest(tmp_path)
    p.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(ManifestError, match="not UTF-8"):
        load_manifest(p)


def test_subject_number_accepted_as_label(tmp_path):
    d = _base_dict()
    d["trials"][0]["subject"] = 2
    st = load_manifest(_write_raw(tmp_path, d))
    assert st.trials[0].subject == "2"


def test_resolve_path_refuses_escapes(tmp_path):
    root = tmp_path / "study"
    (root / "trials").mkdir(parents=True)
    assert resolve_path(root, "trials/a.mkv") == (root / "trials" / "a.mkv").resolve()
    for bad in ("../x", "trials/../../x", "/etc/passwd", "a\\b"):
        with pytest.raises(ManifestError, match="path"):
            resolve_path(root, bad, where="video.path")
    outside = tmp_path / "outside"
    outside.mkdir()
    os.symlink(outside, root / "link")
    with pytest.raises(ManifestError, match="outside the study folder"):
        resolve_path(root, "link/video.mkv")


def test_manifest_symlink_escape_refused_on_load(tmp_path):
    root = tmp_path / "study"
    root.mkdir()
    outside = tmp_path / "outside"
    outside.mkdir()
    os.symlink(outside, root / "trials")
    write_manifest(_study(), root)
    with pytest.raises(ManifestError, match=r"manifest\.json: trials\[0\]\.video\.path: .*outside"):
        load_manifest(root)


@pytest.mark.parametrize("bad", ["", ".", "..", "a/b", "a b", "é", None, 3])
def test_validate_id(bad):
    with pytest.raises(ManifestError, match="trial id"):
        validate_id(bad)
    assert validate_id("s1-bump_2.mm") == "s1-bump_2.mm"


def test_records_validate_on_construction():
    with pytest.raises(ManifestError, match="video.fps"):
        VideoInfo(path="v.mkv", format="ffv1-mkv", fps=0, width=10, height=10, n_frames=3)
    with pytest.raises(ManifestError, match="force.units"):
        ForceInfo(path="f.npz", format="npz", fs_hz=1.0, n_samples=3, units="mN")
    with pytest.raises(ManifestError, match="repetition"):
        _trial(repetition=0)
    with pytest.raises(ManifestError, match="duplicate"):
        _study([_trial(), _trial()])


def test_write_is_atomic_no_temp_left(tmp_path):
    write_manifest(_study(), tmp_path)
    assert sorted(os.listdir(tmp_path)) == ["manifest.json"]
    assert oct(os.stat(tmp_path / "manifest.json").st_mode & 0o777) != oct(0o600)
