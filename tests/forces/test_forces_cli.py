"""The ``fingerfriction forces`` command on a one-trial study written in tmp_path."""

from __future__ import annotations

import json
import re

import numpy as np
import pandas as pd
import pytest

from fingerfriction.cli import app, main

from .test_forces_processing import FS, _feature, synthetic_trial


def run(args):
    """``fingerfriction forces ARGS``. While ``forces`` is the app's only command and there is
    no group callback (this branch before the other stages are merged), typer runs that
    command directly, without its name."""
    single = len(app.registered_commands) == 1 and app.registered_callback is None
    return main(args if single else ["forces", *args])


@pytest.fixture
def study(tmp_path):
    rec, tv, xv = synthetic_trial()
    d = tmp_path / "study"
    (d / "trials" / "t1").mkdir(parents=True)
    (d / "truth").mkdir()
    np.savez(d / "trials" / "t1" / "forces.npz", ai0=rec.f1, ai1=rec.f2)
    np.savez(d / "truth" / "t1.npz", x_finger_video=xv, t_video=tv)
    trial = {
        "id": "t1",
        "subject": "1",
        "surface": "bump-2mm",
        "speed_mm_s": 80.0,
        "repetition": 1,
        "video": {
            "path": "trials/t1/video.mkv",
            "format": "ffv1-mkv",
            "fps": 1000.0,
            "n_frames": int(tv.size),
            "t0_s": float(tv[0]),
            "width": 1280,
            "height": 720,
            "calibration_frame": 0,
        },
        "force": {
            "path": "trials/t1/forces.npz",
            "format": "npz",
            "fs_hz": FS,
            "n_samples": int(rec.n_samples),
            "channels": {"F1": "ai0", "F2": "ai1"},
            "units": "N",
            "t0_s": rec.t0_s,
        },
        "truth": "truth/t1.npz",
    }
    manifest = {
        "format": "fingerfriction-study",
        "schema_version": 1,
        "surfaces": {
            "bump-2mm": {
                "kind": "raised-cosine",
                "shape": "bump",
                "width": 2.0,
                "height": 0.4,
                "center": 0.0,
                "name": "bump-2mm",
            }
        },
        "trials": [trial],
    }
    (d / "manifest.json").write_text(json.dumps(manifest))
    return d, xv


def test_forces_command_writes_csv(study, tmp_path, capsys):
    d, _ = study
    out = tmp_path / "ft.csv"
    assert run([str(d), "t1", "--from-truth", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "F_T(x) on 2601 positions" in text and "compensate_highpass" in text
    df = pd.read_csv(out)
    err = np.sqrt(np.mean((df["F_T_N"] - _feature(df["x_mm"])) ** 2)) / np.ptp(_feature(df["x_mm"]))
    assert err < 0.02


def test_forces_command_positions_file(study, tmp_path, capsys):
    d, xv = study
    pos = tmp_path / "x.csv"
    lost = np.where(np.abs(xv) > 9.5, np.nan, xv)
    pd.DataFrame({"x_mm": lost}).to_csv(pos, index=False)
    assert run([str(d), "t1", "--positions", str(pos)]) == 0
    assert "[extrapolated] x(t) was tracked over" in capsys.readouterr().out


def test_forces_command_user_errors(study, tmp_path, capsys):
    d, xv = study
    assert run([str(d), "nope", "--from-truth"]) == 2
    assert "no trial 'nope'" in capsys.readouterr().err
    assert run([str(d), "t1"]) == 2
    assert "finger positions are needed" in capsys.readouterr().err
    assert run([str(d), "t1", "--from-truth", "--from-video"]) == 2
    assert "give only one of" in capsys.readouterr().err
    short = tmp_path / "x.npy"
    np.save(short, np.where(xv > 3, np.nan, xv))
    assert run([str(d), "t1", "--positions", str(short)]) == 2
    err = capsys.readouterr().err
    assert "does not cover the 26 mm window" in err and "Traceback" not in err


def test_forces_command_estimate_highpass(study, capsys):
    d, _ = study
    # a prior 20 % off: the cut-off (5 Hz in the fixture's sensor) is fitted on the rests
    assert run([str(d), "t1", "--from-truth", "--highpass-hz", "6", "--estimate-highpass"]) == 0
    text = " ".join(capsys.readouterr().out.split())  # rich wraps long lines
    assert "estimate_highpass, compensate_highpass" in text
    m = re.search(r"sensor cut-off estimated on the rests: ([\d.]+) \+- ([\d.]+) Hz \(prior 6 Hz\)", text)
    assert m and float(m.group(1)) == pytest.approx(5.0, rel=0.005)
    # invalid combination: a one-line error, no traceback
    assert run([str(d), "t1", "--from-truth", "--highpass-hz", "0", "--estimate-highpass"]) == 2
    err = capsys.readouterr().err
    assert "estimate_highpass=True needs sensor_highpass_hz" in err and "Traceback" not in err


def _steps(text: str) -> list[str]:
    return " ".join(text.split()).split("steps: ")[1].split(" wrote")[0].split(", ")


def test_forces_command_notch_q_acts_only_with_the_notch(study, capsys):
    d, _ = study
    # the default mains='fit' removes the mains without notches: --notch-q alone changes
    # nothing, and the command says so; with --mains notch the notches run
    assert run([str(d), "t1", "--from-truth", "--notch-q", "30"]) == 0
    out = capsys.readouterr()
    assert "--notch-q: the fit removes the mains" in " ".join(out.err.split())
    assert "notch" not in _steps(out.out)
    assert run([str(d), "t1", "--from-truth", "--mains", "notch", "--notch-q", "30"]) == 0
    out = capsys.readouterr()
    assert "notch" in _steps(out.out) and "--notch-q" not in out.err
    assert run([str(d), "t1", "--from-truth", "--mains", "hum"]) == 2
    assert "mains must be one of fit, notch, both, got 'hum" in " ".join(capsys.readouterr().err.split())
