"""The results store's typed boundary: an analysed trial and a fit come back from the store
as AnalysedTrial and FitResult, the regions written as table columns come back as the same
array, and a fit record of an earlier version reads with its documented defaults."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pandas as pd
import pytest

from fingerfriction.fit import FitOptions, mu_grid
from fingerfriction.flags import Flag
from fingerfriction.regions import region_columns, regions_from_columns
from fingerfriction.study.results import UNRECORDED_MODEL, AnalysedTrial, FitResult
from fingerfriction.study.store import ResultsStore, frames_table

TID = "s1-bump-2mm-v080-r1"


def _store(tmp_path, *, study=None, entry=True) -> tuple[ResultsStore, np.ndarray]:
    store = ResultsStore(tmp_path / "results")
    store.write_run({"study": str(study or tmp_path / "nowhere"), "surfaces": {"bump-2mm": "bump-2mm"},
                     "parameters": {"video": {}},
                     "trials": [{"id": TID, "subject": "1", "surface": "bump-2mm", "speed_mm_s": 80.0,
                                 "repetition": 1}]})
    x = np.linspace(-13.0, 13.0, 50)
    reg = np.full((50, 2, 2), np.nan)
    reg[:, 0] = np.column_stack([x - 6.0, x - 1.0])
    reg[10:20, 1] = np.column_stack([x[10:20] + 0.5, x[10:20] + 2.0])
    frames = frames_table(0.01 * np.arange(50), x, reg)
    forces = pd.DataFrame({"x_mm": x, "F_T_N": np.zeros(50)})
    stored_flags = [Flag("error", "e", "an error").to_dict(), "old-code: a message"]
    status = {"info": {"forces": {"flags": stored_flags}},
              "inputs": {"video": {"path": "videos/t.mkv"}}}
    if entry:
        status["entry"] = {"id": TID, "surface": "bump-2mm", "video": {"path": "videos/t.mkv",
                                                                        "calibration_frame": 3},
                           "surface_spec": "bump-2mm"}
    store.write_trial(AnalysedTrial.from_tables(TID, frames, forces, status))
    return store, reg


def test_regions_come_back_as_they_were_written():
    reg = np.array([[[0.0, 1.0], [2.0, 3.0]], [[0.5, 1.5], [np.nan, np.nan]]])
    cols = region_columns(reg)
    assert list(cols) == ["a1", "b1", "a2", "b2"]
    np.testing.assert_array_equal(regions_from_columns(cols), reg)
    np.testing.assert_array_equal(regions_from_columns(pd.DataFrame({"x": [1, 2]}), empty_ok=True),
                                  np.full((2, 1, 2), np.nan))
    with pytest.raises(ValueError, match="no region columns a1, b1"):
        regions_from_columns(pd.DataFrame({"x": [1, 2]}))


def test_an_analysed_trial_from_the_store(tmp_path):
    store, reg = _store(tmp_path)
    t = store.read_trial(TID)
    assert (t.id, t.subject, t.surface, t.speed_mm_s, t.repetition) == (TID, "1", "bump-2mm", 80.0, 1)
    np.testing.assert_array_equal(t.regions, reg)
    assert t.model is None and store.read_trial(TID, model=True).model is None  # before the fit
    # the stages' flags keep their level; an old 'code: message' string reads as a warning
    assert [(f.level, f.code, f.trial, f.subject) for f in t.flags] == [("error", "e", TID, "1"),
                                                                         ("warning", "old-code", TID, "1")]


def test_the_store_writes_an_analysed_trial_its_regions_from_the_array(tmp_path):
    store, reg = _store(tmp_path)
    t = store.read_trial(TID)
    # what the store keeps of its own (trial, status, tables) is not taken from the status given
    moved = reg + 0.25
    stale = {"trial_format": 1, "tables": {}, "status": "failed"}
    again = replace(t, regions=moved, status={**t.status, **stale})
    store.write_trial(again)
    back = store.read_trial(TID)
    np.testing.assert_array_equal(back.regions, moved)  # the array, not the table's old columns
    np.testing.assert_array_equal(back.frames["a1"], moved[:, 0, 0])
    assert list(back.frames.columns) == list(t.frames.columns)
    st = store.status(TID)
    assert st["status"] == "ok" and st["trial_format"] > 1 and st["tables"]["frames.parquet"]["rows"] == 50
    assert [(f.level, f.code) for f in back.flags] == [(f.level, f.code) for f in t.flags]
    with pytest.raises(ValueError, match="regions has 3 frames but the per-frame table has 50"):
        store.write_trial(replace(t, regions=reg[:3]))
    with pytest.raises(TypeError, match="write_trial takes an AnalysedTrial, got str"):
        store.write_trial(TID)


def test_the_video_of_a_trial_through_the_store_record(tmp_path):
    store, _ = _store(tmp_path)
    with pytest.raises(ValueError, match="manifest is not reachable from here"):
        store.trial_video(TID)
    study = tmp_path / "study"
    study.mkdir()
    (study / "manifest.json").write_text("{}")  # never parsed: the store's record is used
    store, _ = _store(tmp_path, study=study)
    v = store.trial_video(TID)
    assert v.path == study / "videos" / "t.mkv" and v.options.calibration_frame == 3
    assert v.surface.name == "bump-2mm" and v.height_mm == pytest.approx(v.surface.max_height)
    store, _ = _store(tmp_path, study=study, entry=False)
    with pytest.raises(ValueError, match="do not record this trial's video inputs"):
        store.trial_video(TID)


def test_a_fit_record_of_an_earlier_version_reads_with_its_defaults():
    old = FitResult({"mu": {"1": 0.55}, "mu_grid": {"start": 0.3, "stop": 0.9, "step": 0.05},
                     "options": {"median_kernel": 5, "not-an-option": 1},
                     "failures": [{"trial": TID, "reason": "why"}]})
    assert old.model == UNRECORDED_MODEL and old.order == [UNRECORDED_MODEL]
    assert old.mu() == {"1": 0.55} and old.mu("load") == {} and old.mu_ci() == {}
    assert old.flags is None and old.notes == [] and old.failures == [{"trial": TID, "reason": "why"}]
    assert old.footing.startswith("detrended")
    s = old.settings
    assert s.paper == FitOptions(median_kernel=5)
    np.testing.assert_allclose(s.grid, mu_grid(0.3, 0.9, 0.05))


def test_a_fit_record_round_trips_through_the_store(tmp_path):
    rec = {"model": "load", "requested": "auto", "models": {"load": {"mu": {"1": 0.5}, "title": "Load"},
                                                            "paper": {"mu": {"1": 0.6}}},
           "flags": [{"level": "error", "code": "x", "message": "m", "model": "load", "subject": "1"},
                     {"level": "bogus", "code": "y", "message": "n", "model": "load"}],
           "notes": [{"level": "warning", "code": "z", "message": "o", "model": "paper"}]}
    store = ResultsStore(tmp_path / "results")
    assert store.read_fit() is None
    store.write_fit(FitResult(rec))
    fit = store.read_fit()
    assert json.loads(store.fit_json.read_text()) == rec
    assert fit.model == "load" and fit.order == ["load", "paper"] and fit.title("load") == "Load"
    assert fit.title("paper") == "paper" and fit.mu("paper") == {"1": 0.6}
    assert [(f.level, f.code) for f in fit.flags] == [("error", "x"), ("warning", "y")]  # unknown level
    assert [(f.model, f.code) for f in fit.notes] == [("paper", "z")]
    assert fit.fitted_models == ("load", "paper")
    with pytest.raises(TypeError, match="FitResult.record must be a JSON object"):
        FitResult(["not", "a", "dict"])
