"""File-name patterns of `fingerfriction init`: fields, pairing, what is left over."""

from __future__ import annotations

import pytest

from fingerfriction.study.patterns import (
    FilePattern,
    PatternError,
    list_candidates,
    match_recordings,
    trial_id,
)

V = "raw/S{subject}_{surface}_{speed}mms_{repetition}.cine"
F = "raw/S{subject}_{surface}_{speed}mms_{repetition}.tdms"


def test_fields_are_split_shortest_first_and_typed():
    p = FilePattern.parse(V)
    assert p.fields == ("subject", "surface", "speed", "repetition")
    assert p.match("raw/S1_step-up-2mm_40mms_3.cine") == {
        "subject": "1", "surface": "step-up-2mm", "speed": "40", "repetition": "3"}
    assert p.match("raw/S1_bump_12.5mms_1.cine")["speed"] == "12.5"
    assert p.match("raw/S1_bump_fastmms_1.cine") is None  # speed must be a number
    assert p.match("raw/S1_bump_40mms_x.cine") is None
    assert p.match("raw/sub/S1_bump_40mms_1.cine") is None  # a field never spans '/'
    assert p.match("raw/S1_bump_40mms_1.cine.bak") is None  # the whole path must match


@pytest.mark.parametrize("text, message", [
    ("", "non-empty"),
    ("/data/{subject}.cine", "relative to the study folder"),
    ("../{subject}.cine", r"'\.\.' is not allowed"),
    ("raw/{subject.cine", "is never closed"),
    ("raw/}{subject}.cine", "closes no field"),
    ("raw/{sub ject}.cine", "field name 'sub ject'"),
    ("{subject}_{subject}.cine", "appears twice"),
    ("{subject}{surface}.cine", "need something between them"),
])
def test_malformed_patterns(text, message):
    with pytest.raises(PatternError, match=message):
        FilePattern.parse(text)


def test_pairs_trials_and_reports_every_leftover():
    paths = [
        "raw/S1_bump-2mm_40mms_1.cine", "raw/S1_bump-2mm_40mms_1.tdms",
        "raw/S1_bump-2mm_40mms_2.cine", "raw/S1_bump-2mm_40mms_2.tdms",
        "raw/S2_step-up-4mm_80mms_1.cine", "raw/S2_step-up-4mm_80.0mms_1.tdms",  # 80 == 80.0
        "raw/S2_step-up-4mm_80mms_2.cine",                                       # no force file
        "raw/S2_step-up-4mm_120mms_1.tdms",                                      # no video
        "raw/notes.txt",
    ]
    res = match_recordings(paths, V, F)
    assert [t.id for t in res.trials] == ["s1-bump-2mm-v040-r1", "s1-bump-2mm-v040-r2",
                                          "s2-step-up-4mm-v080-r1"]
    t = res.trials[2]
    assert (t.subject, t.surface, t.speed_mm_s, t.repetition) == ("2", "step-up-4mm", 80.0, 1)
    assert (t.video, t.force) == ("raw/S2_step-up-4mm_80mms_1.cine", "raw/S2_step-up-4mm_80.0mms_1.tdms")
    left = {u.path: u.reason for u in res.unmatched}
    assert left == {
        "raw/S2_step-up-4mm_120mms_1.tdms": "force file without a video (repetition=1, speed=120, "
                                            "subject=2, surface=step-up-4mm)",
        "raw/S2_step-up-4mm_80mms_2.cine": "video without a force file (repetition=2, speed=80, "
                                           "subject=2, surface=step-up-4mm)",
        "raw/notes.txt": "matches no pattern",
    }


def test_several_patterns_per_kind_and_tiff_folders(tmp_path):
    for name in ("raw/S1_bump_40mms_1.cine", "raw/S1_bump_40mms_1.csv", "raw/S1_bump_40mms_2.csv",
                 "raw/S1_bump_40mms_2/f000.tif", "raw/S1_bump_40mms_2/f001.tif", "manifest.json",
                 ".hidden/x.cine", "raw/.DS_Store"):
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_bytes(b"")
    paths = list_candidates(tmp_path)
    assert paths == ["raw/S1_bump_40mms_1.cine", "raw/S1_bump_40mms_1.csv", "raw/S1_bump_40mms_2.csv",
                     "raw/S1_bump_40mms_2/", "raw/S1_bump_40mms_2/f000.tif", "raw/S1_bump_40mms_2/f001.tif"]
    res = match_recordings(paths, [V, "raw/S{subject}_{surface}_{speed}mms_{repetition}"],
                           "raw/S{subject}_{surface}_{speed}mms_{repetition}.csv")
    assert [(t.video, t.force) for t in res.trials] == [
        ("raw/S1_bump_40mms_1.cine", "raw/S1_bump_40mms_1.csv"),
        ("raw/S1_bump_40mms_2", "raw/S1_bump_40mms_2.csv")]
    assert res.unmatched == ()  # the frames of the TIFF folder belong to its video


def test_two_videos_for_one_trial_are_both_reported():
    paths = ["S1_bump_40mms_1.cine", "S1_bump_40mms_1.tif", "S1_bump_40mms_1.csv"]
    res = match_recordings(paths, ["S{subject}_{surface}_{speed}mms_{repetition}.cine",
                                   "S{subject}_{surface}_{speed}mms_{repetition}.tif"],
                           "S{subject}_{surface}_{speed}mms_{repetition}.csv")
    assert res.trials == ()
    reasons = {u.path: u.reason for u in res.unmatched}
    assert reasons["S1_bump_40mms_1.cine"].startswith("2 videos for one trial")
    assert "S1_bump_40mms_1.tif" in reasons["S1_bump_40mms_1.cine"]
    assert set(reasons) == {"S1_bump_40mms_1.cine", "S1_bump_40mms_1.tif"}


def test_repetition_optional_numbered_by_other_labels():
    paths = [f"{d}/S1_bump_40.{ext}" for d in ("2024-05-02", "2024-05-01") for ext in ("cine", "csv")]
    paths += ["2024-05-01/S1_bump_80.cine", "2024-05-01/S1_bump_80.csv"]
    res = match_recordings(paths, "{date}/S{subject}_{surface}_{speed}.cine",
                           "{date}/S{subject}_{surface}_{speed}.csv")
    got = [(t.speed_mm_s, t.repetition, t.labels["date"], t.id) for t in res.trials]
    assert got == [(40.0, 1, "2024-05-01", "s1-bump-v040-r1-2024-05-01"),
                   (40.0, 2, "2024-05-02", "s1-bump-v040-r2-2024-05-02"),
                   (80.0, 1, "2024-05-01", "s1-bump-v080-r1-2024-05-01")]


def test_wildcards_and_field_rules():
    paths = ["v/S1_bump_40_1_10-02-33.cine", "f/S1_bump_40_1.csv"]
    res = match_recordings(paths, "v/S{subject}_{surface}_{speed}_{repetition}_*.cine",
                           "f/S{subject}_{surface}_{speed}_{repetition}.csv")
    assert [t.id for t in res.trials] == ["s1-bump-v040-r1"]
    with pytest.raises(PatternError, match=r"has no field \{speed\}"):
        match_recordings(paths, "v/S{subject}_{surface}.cine", "f/S{subject}_{surface}.csv")
    with pytest.raises(PatternError, match="different fields"):
        match_recordings(paths, "v/S{subject}_{surface}_{speed}_{repetition}_{time}.cine",
                         "f/S{subject}_{surface}_{speed}_{repetition}.csv")
    res = match_recordings(["S1_bump_0mms_1.cine", "S1_bump_0mms_1.csv"], "S{subject}_{surface}_{speed}mms_"
                           "{repetition}.cine", "S{subject}_{surface}_{speed}mms_{repetition}.csv")
    assert res.trials == () and "not a positive speed" in res.unmatched[0].reason


def test_trial_id_is_a_valid_id():
    assert trial_id("01", "bump:W=3,H=0.5", 40.0, 2) == "s01-bump-W-3-H-0.5-v040-r2"
    assert trial_id("1", "bump-2mm", 12.5, 1) == "s1-bump-2mm-v12.5-r1"
