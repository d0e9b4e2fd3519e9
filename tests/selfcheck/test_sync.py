"""The video-force offset from the start of the slide: a finger's trials against each
other's pre-sliding law."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fingerfriction.selfcheck import OnsetData, estimate_offsets, onset_data

from .synth import press_and_slide

SPEEDS = (40.0, 55.0, 70.0, 90.0, 110.0, 130.0)


def _onset(i, speed, t0=0.0, group="1", seed=0, **kw):
    tr = press_and_slide(
        speed=speed, mu=0.5 * (1 + 0.1 * np.sin(i)), rng=np.random.default_rng(seed + i), **kw
    )
    o = onset_data(f"t{i}", group, tr.t_frames, tr.x_frames, tr.f_n, tr.f_t, tr.fs_hz, t0)
    assert isinstance(o, OnsetData), o
    return o


@pytest.fixture(scope="module")
def finger():
    return [_onset(i, v) for i, v in enumerate(SPEEDS)]


def test_clean_trials_agree(finger):
    est = estimate_offsets(finger, mode="check")
    for e in est.values():
        assert e.method == "relative" and e.n_reference == len(SPEEDS)
        assert abs(e.offset_s) < 1e-3 and abs(e.offset_s) < 3 * e.se_s, e
        assert e.se_s < 1e-3


@pytest.mark.parametrize("wrong_ms", [-40.0, -5.0, 5.0, 15.0])
def test_a_wrong_offset_is_measured(finger, wrong_ms):
    """The manifest says the force record starts ``wrong_ms`` later than it did: the
    correction to add to its t0 is -wrong_ms."""
    bad = _onset(9, 75.0, t0=wrong_ms * 1e-3)
    bad = OnsetData(
        "bad",
        *[
            getattr(bad, f)
            for f in ("group", "t_video", "d_video", "t_motion", "s0", "ds", "ratio", "frame_period")
        ],
    )
    est = estimate_offsets([*finger, bad], mode="check", reference={o.trial_id for o in finger})
    assert est["bad"].offset_s == pytest.approx(-wrong_ms * 1e-3, abs=1e-3)
    assert all(abs(est[o.trial_id].offset_s) < 1e-3 for o in finger)


def test_auto_puts_a_stray_trial_back_on_the_consensus(finger):
    stray = [o if o.trial_id != "t2" else o.shifted(0.012) for o in finger]
    est = estimate_offsets(stray, mode="auto")
    assert est["t2"].offset_s == pytest.approx(-0.012, abs=1e-3)
    assert "consensus" in est["t2"].message


def test_auto_with_every_clock_scattered_keeps_the_trials_consistent(finger):
    """Random offsets of +-50 ms: what the starts tell apart (each trial against the others)
    comes back; what they cannot (a shift common to all, and one growing as speed^-1/4)
    stays at the prior, whose range is in the standard error."""
    rng = np.random.default_rng(5)
    shifts = rng.uniform(-0.05, 0.05, len(finger))
    est = estimate_offsets([o.shifted(s) for o, s in zip(finger, shifts, strict=True)], mode="auto")
    got = np.array([est[o.trial_id].offset_s for o in finger])
    err = got + shifts
    v = np.array(SPEEDS)
    X = np.column_stack([np.ones(v.size), v**-0.25])
    resid = err - X @ np.linalg.lstsq(X, err, rcond=None)[0]
    assert np.max(np.abs(resid)) < 1e-3, resid
    assert np.max(np.abs(err)) < 0.01
    for o in finger:
        e = est[o.trial_id]
        assert e.method == "joint" and abs(err[finger.index(o)]) < 3 * e.se_s


def test_one_trial_alone_gets_the_prior():
    o = _onset(0, 80.0, t0=0.02)
    e = estimate_offsets([o], mode="check")["t0"]
    assert e.method == "prior" and e.se_s > 2e-3
    assert abs(e.offset_s + 0.02) < 3 * e.se_s


def test_common_offset_needs_different_speeds():
    same = [_onset(i, 80.0, seed=7) for i in range(4)]
    est = estimate_offsets(same, mode="check")
    assert all(math.isnan(e.common_s) for e in est.values())


def test_a_video_without_a_rest_cannot_show_the_start():
    tr = press_and_slide()
    x = tr.x_frames.copy()
    x[tr.t_frames < 0.2] = np.nan  # the finger enters the view already sliding
    got = onset_data("t", "1", tr.t_frames, x, tr.f_n, tr.f_t, tr.fs_hz, 0.0)
    assert isinstance(got, str) and "no rest" in got


def test_round_trip_through_json(finger):
    o = finger[0]
    back = OnsetData.from_dict(o.to_dict())
    assert back.trial_id == o.trial_id and np.allclose(back.d_video, o.d_video, atol=1e-5)
    assert np.allclose(back.ratio, o.ratio, atol=1e-5, equal_nan=True)
