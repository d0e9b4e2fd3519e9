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


def test_clean_trials_of_a_finger_slow_to_slide_agree():
    """A finger whose friction reaches half its level only after about 0.5 mm of travel
    (the prior's far end, a compliant fingertip): its clocks are right, and the offsets are
    measured near 0, not at the edge of a search centred on the prior's middle (there, 20 ms
    from 0 at the slowest trial)."""
    slow = [_onset(i, v, d0=1.0) for i, v in enumerate(SPEEDS)]
    est = estimate_offsets(slow, mode="check")
    for e in est.values():
        assert e.method == "relative"
        assert abs(e.offset_s) < 1e-3 and abs(e.offset_s) < 3 * e.se_s, e


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


def _touched(o, t0, rng, t_touch=0.1, se_v=3e-4, se_f=5e-5):
    """``o`` with touch-downs: seen in the video at the true instant (video clock), in the
    force record at the true instant read on a clock ``t0`` ahead (the manifest's
    ``force.t0_s`` too large by ``t0``: the correction is ``-t0``)."""
    from dataclasses import replace

    return replace(
        o,
        touch_video_s=t_touch + se_v * float(rng.standard_normal()),
        touch_video_se_s=se_v,
        touch_force_s=t_touch + t0 + se_f * float(rng.standard_normal()),
        touch_force_se_s=se_f,
    )


def test_touch_downs_fix_what_a_fingers_starts_share():
    """Every clock scattered by +-50 ms: the starts of the slides align the trials on each
    other, the touch-downs place them."""
    rng = np.random.default_rng(11)
    shifts = rng.uniform(-0.05, 0.05, len(SPEEDS))
    items = [
        _touched(_onset(i, v, t0=float(s)), float(s), rng)
        for i, (v, s) in enumerate(zip(SPEEDS, shifts, strict=True))
    ]
    est = estimate_offsets(items, mode="auto")
    err = np.array([est[o.trial_id].offset_s + s for o, s in zip(items, shifts, strict=True)])
    assert np.sqrt(np.mean(err**2)) < 0.5e-3, err
    for o, e in zip(items, err, strict=True):
        got = est[o.trial_id]
        assert got.level_by == "touch-down" and abs(e) < 3 * got.se_s + 2e-4


def test_a_session_offset_is_measured_by_the_touch_downs():
    """Every trial of a finger 4 ms off together: the starts agree among themselves, the
    touch-downs see the common offset (sync-common); with clean clocks it is ~0."""
    rng = np.random.default_rng(3)
    clean = [_touched(_onset(i, v), 0.0, rng) for i, v in enumerate(SPEEDS)]
    off = [_touched(_onset(i, v, t0=0.004), 0.004, rng) for i, v in enumerate(SPEEDS)]
    for items, want in ((clean, 0.0), (off, -0.004)):
        est = estimate_offsets(items, mode="check")
        e = est[items[0].trial_id]
        assert e.level_by == "touch-down"
        assert e.common_s == pytest.approx(want, abs=4e-4) and e.common_se_s < 4e-4
        # the trials agree among themselves: no sync-offset (2 frame periods)
        assert all(abs(x.offset_s) < 2e-3 for x in est.values())
    auto = estimate_offsets(off, mode="auto")
    assert all(x.offset_s == pytest.approx(-0.004, abs=6e-4) for x in auto.values())


def test_touch_downs_round_trip_through_json_and_move_with_the_clock():
    rng = np.random.default_rng(0)
    o = _touched(_onset(0, 80.0), 0.0, rng)
    back = OnsetData.from_dict(o.to_dict())
    assert back.touch_offset_s == pytest.approx(o.touch_offset_s, abs=1e-7)
    assert back.touch_se_s == pytest.approx(o.touch_se_s, rel=1e-4)
    moved = o.shifted(0.01)
    assert moved.touch_offset_s == pytest.approx(o.touch_offset_s - 0.01, abs=1e-9)
    old = {k: v for k, v in o.to_dict().items() if k != "touch"}  # a status.json of before
    assert math.isnan(OnsetData.from_dict(old).touch_offset_s)


def _checked(bad_start_ms: float, bad_touch_ms: float | None, se_v: float = 3e-4):
    """A finger's six trials with clean clocks and touch-downs, and a seventh whose start of
    the slide is off by ``bad_start_ms`` and whose touch-down by ``bad_touch_ms`` (None: not
    measured), through the analysis' ``sync-offset`` check (``--sync check``)."""
    from fingerfriction.pipeline.selfcheck import sync_checks
    from fingerfriction.selfcheck import SelfCheckParams

    rng = np.random.default_rng(5)
    items = [_touched(_onset(i, v), 0.0, rng) for i, v in enumerate(SPEEDS)]
    bad = _onset(9, 75.0, t0=bad_start_ms * 1e-3)
    if bad_touch_ms is not None:
        bad = _touched(bad, bad_touch_ms * 1e-3, rng, se_v=se_v)
    items.append(bad)
    onsets = {o.trial_id: o for o in items}
    est = estimate_offsets(items, mode="check")
    periods = {o.trial_id: o.frame_period for o in items}
    return est, sync_checks(est, periods, SelfCheckParams(), mode="check", onsets=onsets)


@pytest.mark.parametrize("wrong_ms", [-15.0, -5.0, 5.0, 15.0])
def test_a_wrong_clock_moves_both_events_and_stays_an_error(wrong_ms):
    """The force clock off: the start of the slide and the touch-down move alike, so the
    touch-down corroborates the start's reading and the trial fails."""
    est, checks = _checked(wrong_ms, wrong_ms)
    assert checks["t9"].level == "error", checks["t9"]
    assert est["t9"].offset_s == pytest.approx(-wrong_ms * 1e-3, abs=1e-3)
    assert all(checks[f"t{i}"].level == "ok" for i in range(len(SPEEDS)))


@pytest.mark.parametrize("start_ms", [-5.0, 5.0])
def test_an_unusual_start_contradicted_by_the_touch_down_is_a_warning(start_ms):
    """Only the start of the slide off (the clock right, as its touch-down shows): a warning
    that names both readings, not a failed trial."""
    _, checks = _checked(start_ms, 0.0)
    c = checks["t9"]
    assert c.level == "warning", c
    assert "touch-down" in c.message and "not its clock" in c.message


def test_without_a_touch_down_or_with_a_vague_one_the_start_decides():
    """No touch-down, or one too uncertain to contradict the start (SE 5 ms): an error."""
    _, checks = _checked(5.0, None)
    assert checks["t9"].level == "error", checks["t9"]
    _, checks = _checked(5.0, 0.0, se_v=5e-3)
    assert checks["t9"].level == "error", checks["t9"]
