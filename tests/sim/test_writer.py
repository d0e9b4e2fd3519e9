"""Tests of the study writer: layout, determinism, resume, option mistakes, truth vs video."""

from __future__ import annotations

import hashlib
import os

import av
import numpy as np
import pytest

from fingerfriction.sim import SimOptions, StudyFolderError, simulate_study
from fingerfriction.sim.sensor import from_channels
from fingerfriction.study import load_manifest

from .conftest import tiny_options


def _digest(root) -> dict:
    out = {}
    for dp, _, files in os.walk(root):
        for f in files:
            p = os.path.join(dp, f)
            out[os.path.relpath(p, root)] = hashlib.sha256(open(p, "rb").read()).hexdigest()
    return out


@pytest.fixture(scope="module")
def study_dir(tmp_path_factory):
    d = tmp_path_factory.mktemp("study") / "s"
    simulate_study(d, tiny_options(), workers=1)
    return d


@pytest.mark.slow
def test_layout_and_manifest(study_dir):
    st = load_manifest(study_dir)
    assert len(st.trials) == 1
    t = st.trials[0]
    assert t.id == "s1-bump-2mm-v120-r1" and t.subject == "1" and t.speed_mm_s == 120.0
    assert st.path(t.video.path).is_file() and st.path(t.force.path).is_file() and st.path(t.truth).is_file()
    assert (study_dir / "truth" / "study.json").is_file()
    assert not (study_dir / ".cache").exists()
    assert t.calibration["surface_height_mm"] == pytest.approx(0.4)
    # the video has the announced frames; frame 0 (calibration) has no finger
    with av.open(str(st.path(t.video.path))) as c:
        frames = [f.to_ndarray() for f in c.decode(video=0)]
    assert len(frames) == t.video.n_frames
    assert frames[0].shape == (720, 1280) and frames[0].dtype == np.uint8
    truth = np.load(st.path(t.truth))
    assert not truth["has_finger"][0] and truth["has_finger"][-1]
    assert np.isnan(truth["x_finger_video"][0])
    # finger-free frame: dark only below the surface line (rows >= ~y0_row - feature)
    top_dark = np.argmax(frames[0] < 128, axis=0)
    assert top_dark.min() >= 500 - 0.4 / 0.023 - 2
    # force file: F1, F2 of the announced length; truth clocks consistent with the manifest
    with np.load(st.path(t.force.path)) as f:
        assert set(f.files) == {"F1", "F2"} and f["F1"].shape == (t.force.n_samples,)
    np.testing.assert_allclose(truth["t_video"], t.video.frame_times(), atol=1e-12)
    np.testing.assert_allclose(truth["t_force"], t.force.sample_times(), atol=1e-12)
    for key in ("F_N", "F_T", "F_T_int", "F_T_def", "x_finger_force"):
        assert truth[key].shape == (t.force.n_samples,)
    np.testing.assert_allclose(truth["F_T"], truth["F_T_int"] + truth["F_T_def"], atol=1e-12)
    assert truth["regions_geom"].shape[0] == t.video.n_frames
    assert float(truth["geom_tol_mm"]) == pytest.approx(3 * 0.023)


@pytest.mark.slow
def test_recorded_forces_follow_truth(study_dir):
    """F1, F2 decompose to F_N, F_T that follow the true forces once the sensor's known
    high-pass is applied to the truth (the remaining difference: drift, mains, noise)."""
    from scipy.signal import butter, lfilter

    st = load_manifest(study_dir)
    t = st.trials[0]
    truth = np.load(st.path(t.truth))
    with np.load(st.path(t.force.path)) as f:
        fn, ft = from_channels(f["F1"], f["F2"])
    b, a = butter(1, 5.0, btype="highpass", fs=10000.0)
    ft_hp = lfilter(b, a, truth["F_T"])
    fn_hp = lfilter(b, a, truth["F_N"])
    assert np.std(ft - ft_hp) < 0.01 and np.std(fn - fn_hp) < 0.01
    assert np.max(np.abs(truth["F_N"])) > 0.25  # the finger did press


@pytest.mark.slow
def test_truth_regions_match_video(study_dir):
    """End to end: contact seen in the stored video frames (3-px criterion) overlaps the
    stored geometric regions."""
    from scipy.ndimage import distance_transform_edt

    st = load_manifest(study_dir)
    t = st.trials[0]
    truth = np.load(st.path(t.truth))
    with av.open(str(st.path(t.video.path))) as c:
        frames = [f.to_ndarray() for f in c.decode(video=0)]
    calib = frames[0]
    cols_mm = (np.arange(1280) - float(truth["x0_px"])) * float(truth["mm_per_px"])
    ious = []
    for k in range(1, len(frames), 7):
        reg = truth["regions_geom"][k]
        reg = reg[~np.isnan(reg[:, 0])]
        finger = (frames[k] < 128) & (calib.astype(int) - frames[k].astype(int) > 64)
        if not len(reg) or not finger.any():
            continue
        dist = distance_transform_edt(~finger)
        top = np.argmax(calib < 128, axis=0)
        seen = dist[top, np.arange(1280)] <= 3
        in_truth = np.zeros(1280, bool)
        for a, b in reg:
            in_truth |= (cols_mm >= a) & (cols_mm <= b)
        ious.append(np.sum(seen & in_truth) / max(np.sum(seen | in_truth), 1))
    assert len(ious) >= 5
    assert np.median(ious) > 0.9 and min(ious) > 0.7, ious


@pytest.mark.slow
def test_same_seed_byte_identical_and_resume(study_dir, tmp_path):
    other = tmp_path / "again"
    simulate_study(other, tiny_options(), workers=1)
    assert _digest(other) == _digest(study_dir)
    # re-running into the same folder resumes: complete trials are not rewritten
    v = other / "trials" / "s1-bump-2mm-v120-r1" / "video.mkv"
    m0 = os.stat(v).st_mtime_ns
    simulate_study(other, tiny_options(), workers=1)
    assert os.stat(v).st_mtime_ns == m0
    assert _digest(other) == _digest(study_dir)
    # an incomplete trial (lost truth file) is redone, identically
    os.remove(other / "truth" / "s1-bump-2mm-v120-r1.npz")
    simulate_study(other, tiny_options(), workers=1)
    assert _digest(other) == _digest(study_dir)


@pytest.mark.slow
def test_different_seed_differs(study_dir, tmp_path):
    d = tmp_path / "seed4"
    simulate_study(d, tiny_options(seed=4), workers=1)
    a, b = _digest(d), _digest(study_dir)
    assert a["trials/s1-bump-2mm-v120-r1/forces.npz"] != b["trials/s1-bump-2mm-v120-r1/forces.npz"]


@pytest.mark.slow
def test_workers_do_not_change_results(tmp_path):
    opts = tiny_options(speeds=(120.0, 100.0))
    simulate_study(tmp_path / "w1", opts, workers=1)
    simulate_study(tmp_path / "w2", opts, workers=2)
    assert _digest(tmp_path / "w1") == _digest(tmp_path / "w2")


@pytest.mark.slow
def test_folder_with_a_different_study_is_refused_untouched(study_dir, tmp_path):
    before = _digest(study_dir)
    with pytest.raises(StudyFolderError, match="different study.*seed: existing 3, requested 5"):
        simulate_study(study_dir, tiny_options(seed=5), workers=1)
    with pytest.raises(StudyFolderError, match="different study"):
        simulate_study(study_dir, tiny_options(speeds=(80.0,)), workers=1)
    assert _digest(study_dir) == before
    # a non-empty folder that is not a simulated study
    other = tmp_path / "mine"
    other.mkdir()
    (other / "notes.txt").write_text("my data")
    with pytest.raises(StudyFolderError, match="not empty and holds no simulated study"):
        simulate_study(other, tiny_options(), workers=1)
    assert os.listdir(other) == ["notes.txt"]


@pytest.mark.parametrize("kw, match", [
    (dict(surfaces=("bump-3mm",)), "unknown surface 'bump-3mm'; known surfaces: bump-2mm"),
    (dict(surfaces=("bump:W=-1",)), "surface 'bump:W=-1'"),
    (dict(speeds=(0.0,)), "speed must be a positive speed in mm/s, got 0.0"),
    (dict(speeds=(-40.0,)), "positive speed"),
    (dict(speeds=(float("nan"),)), "positive speed"),
    (dict(subjects=("3",)), "unknown subject '3'"),
    (dict(reps=0), "reps must be an integer >= 1"),
    (dict(seed=-1), "seed must be an integer >= 0"),
    (dict(video_format="gif"), "video_format"),
    (dict(contact_model="rubber"), "unknown contact model"),
    (dict(speeds=()), "speeds must not be empty"),
])
def test_option_mistakes(kw, match, tmp_path):
    out = tmp_path / "out"
    with pytest.raises(ValueError, match=match):
        simulate_study(out, tiny_options(**kw), workers=1)
    assert not out.exists()


def test_bad_workers(tmp_path):
    with pytest.raises(ValueError, match="workers"):
        simulate_study(tmp_path / "x", tiny_options(), workers=0)
    assert not (tmp_path / "x").exists()


def test_paper_design_by_default():
    opts = SimOptions()
    specs = opts.trial_specs()
    assert len(specs) == 180
    assert len({s.id for s in specs}) == 180
    assert {s.speed_mm_s for s in specs} == {40.0, 80.0, 120.0}
    assert specs[0].id == "s1-bump-2mm-v040-r1"


@pytest.mark.slow
def test_tiff_format(tmp_path):
    import tifffile

    d = tmp_path / "tif"
    st = simulate_study(d, tiny_options(video_format="tiff"), workers=1)
    t = st.trials[0]
    assert t.video.path.endswith(".tif") and t.video.format == "tiff"
    with tifffile.TiffFile(st.path(t.video.path)) as tf:
        assert len(tf.pages) == t.video.n_frames
        assert tf.pages[0].shape == (720, 1280)


@pytest.mark.slow
def test_options_round_trip_and_truth_geometry_rebuilt(study_dir):
    """truth/study.json holds everything needed to recompute any frame's true geometry."""
    import json

    from fingerfriction.regions import regions_from_mask
    from fingerfriction.sim import build_table, plan_trial
    from fingerfriction.sim.contact import get_provider
    from fingerfriction.sim.writer import frame_outline, geometric_distance, geometric_mask
    from fingerfriction.surfaces import surface_from_spec

    header = json.loads((study_dir / "truth" / "study.json").read_text())
    opts = SimOptions.from_dict(header["options"])
    assert opts == tiny_options()
    spec = opts.trial_specs()[0]
    plan = plan_trial(spec, opts)
    surf = surface_from_spec(spec.surface_spec)
    table = build_table(surf, spec.subject, loads=opts.table_loads, step=opts.table_step,
                        provider=get_provider(opts.contact_model))
    truth = np.load(load_manifest(study_dir).path(plan.record.truth))
    tol = float(header["geom_tol_mm"])
    checked = 0
    for k in range(1, plan.frame_idx.size, 5):
        x_c, y_f, _ = frame_outline(plan.kin, table, int(plan.frame_idx[k]))
        X = x_c + table.xi
        h = np.asarray(surf.h(X), float)
        d = geometric_distance(table.xi, np.asarray(y_f, float), h, 2 * tol)
        np.testing.assert_array_equal(d <= tol, geometric_mask(table.xi, y_f, h, tol))
        got = regions_from_mask(X, d <= tol)[0]
        want = truth["regions_geom"][k]
        n = int(np.sum(np.isfinite(want[:, 0])))
        assert int(np.sum(np.isfinite(got[:, 0]))) == n
        np.testing.assert_allclose(got[:n], want[:n], atol=1e-9)
        checked += n > 0
    assert checked >= 3
    with pytest.raises(ValueError, match="simulation options: .*unexpected keyword"):
        SimOptions.from_dict({"camera": {"width": 1280, "colour": True}})
