import json

import av
import numpy as np
import pytest
from typer.testing import CliRunner

from fingerfriction.cli import app
from fingerfriction.surfaces import RaisedCosine
from fingerfriction.video.overlay import write_overlay
from fingerfriction.video.writers import write_video

from .synth import render_video

SURF = RaisedCosine("bump", 2.0)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    root = tmp_path_factory.mktemp("study")
    (root / "trials" / "t1").mkdir(parents=True)
    frames = render_video(np.linspace(-6.0, -2.0, 5), surface=SURF, noise=1.0)
    write_video(root / "trials" / "t1" / "video.mkv", frames)
    manifest = {
        "format": "fingerfriction-study", "schema_version": 1, "created_by": "test",
        "description": "", "surfaces": {"bump-2mm": SURF.to_dict()},
        "trials": [{
            "id": "t1", "subject": "1", "surface": "bump-2mm", "speed_mm_s": 40.0, "repetition": 1,
            "video": {"path": "trials/t1/video.mkv", "format": "ffv1-mkv", "fps": 1000.0,
                      "width": 1280, "height": 720, "n_frames": 6, "t0_s": 0.0,
                      "calibration_frame": 0},
            "force": {"path": "trials/t1/forces.npz", "format": "npz", "fs_hz": 10000.0,
                      "n_samples": 60, "channels": {"F1": "F1", "F2": "F2"}, "units": "N",
                      "t0_s": 0.0},
            "calibration": {"surface_height_mm": 0.4},
        }],
    }
    (root / "manifest.json").write_text(json.dumps(manifest))
    return root


@pytest.mark.slow
def test_write_overlay_mp4_and_gif(study, tmp_path):
    video = study / "trials" / "t1" / "video.mkv"
    info = write_overlay(video, 0.4, tmp_path / "o.mp4", surface=SURF)
    assert info.n_frames == 6 and info.n_flagged == 1
    with av.open(str(tmp_path / "o.mp4")) as c:
        frames = [f.to_ndarray(format="rgb24") for f in c.decode(video=0)]
    assert len(frames) == 6 and frames[0].shape == (360, 1260, 3)
    # contact regions are drawn in red on the surface line of a finger frame
    red = (frames[3][..., 0] > 180) & (frames[3][..., 1] < 80) & (frames[3][..., 2] < 80)
    assert red[300:345].sum() > 200
    info = write_overlay(video, 0.4, tmp_path / "o.gif", surface=SURF, step=2, scale=0.5)
    assert info.n_frames == 3 and (tmp_path / "o.gif").stat().st_size > 0
    with pytest.raises(ValueError, match=r"\.mp4 or \.gif"):
        write_overlay(video, 0.4, tmp_path / "o.avi")


def test_cli_overlay(study, tmp_path):
    runner = CliRunner()
    out = tmp_path / "cli.mp4"
    r = runner.invoke(app, ["overlay", str(study), "t1", "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert out.exists() and "6 frames" in r.output
    r = runner.invoke(app, ["overlay", str(study), "nope"])
    assert r.exit_code == 2 and "no trial 'nope'" in r.output
    r = runner.invoke(app, ["overlay", str(study), "t1", "--out", str(tmp_path / "x.avi")])
    assert r.exit_code == 2 and "must end in .mp4 or .gif" in r.output
    assert not list(tmp_path.glob("*.tmp*"))


@pytest.mark.slow
def test_write_results_overlay_draws_the_stored_results(study, tmp_path):
    """From the per-frame table ``analyze`` stores: only the drawn frames are decoded, the
    regions drawn are the stored ones (here: moved 2 mm, so not what a new analysis finds)."""
    from fingerfriction.study.store import frames_table
    from fingerfriction.video import analyze_video
    from fingerfriction.video.overlay import write_results_overlay

    video = study / "trials" / "t1" / "video.mkv"
    res = analyze_video(video, 0.4, surface=SURF)
    frames = frames_table(np.arange(res.n_frames) * 1e-3, res.x, res.regions,
                          ["calibration frame" if i == 0 else "" for i in range(res.n_frames)])
    info = write_results_overlay(video, frames, 0.4, tmp_path / "r.gif", surface=SURF)
    assert info.n_frames == int(np.isfinite(res.x).sum()) == 5  # the finger frames, not the calibration frame
    with av.open(str(tmp_path / "r.gif")) as c:
        gif = [f.to_ndarray(format="rgb24") for f in c.decode(video=0)]
    assert len(gif) == 5 and gif[0].shape == (180, 630, 3)
    info = write_results_overlay(video, frames, 0.4, tmp_path / "r.mp4", surface=SURF, max_frames=2,
                                 scale=1.0)
    assert info.n_frames == 2
    with pytest.raises(ValueError, match=r"\.mp4 or \.gif"):
        write_results_overlay(video, frames, 0.4, tmp_path / "r.avi")
    no_finger = frames.assign(x_mm=np.nan, n_regions=0, **{c: np.nan for c in frames.columns
                                                           if c[0] in "ab" and c[1:].isdigit()})
    with pytest.raises(ValueError, match="no frame with the finger"):
        write_results_overlay(video, no_finger, 0.4, tmp_path / "n.gif", surface=SURF)
