"""The touch-down in both recordings (fingerfriction.selfcheck.touchdown), on synthetic
landings built here (tests/selfcheck/synth.py), not by the simulator."""

from __future__ import annotations

import math

import numpy as np
import pytest

from fingerfriction.selfcheck.touchdown import TouchDown, touch_force, touch_level, touch_video

from .synth import landing


@pytest.mark.parametrize("v, decel", [(30.0, 8000.0), (45.0, 4000.0), (60.0, 15000.0), (80.0, 2000.0)])
def test_the_video_times_the_landing_from_the_gap_closing(v, decel):
    errs, z = [], []
    for seed in range(8):
        lg = landing(v=v, decel=decel, t_touch=0.1204 + 1.23e-4 * seed, rng=np.random.default_rng(seed))
        td = touch_video(lg.t_frames, lg.gap_mm)
        assert td.measured, td.message
        errs.append(td.t_s - lg.t_touch)
        z.append(errs[-1] / td.se_s)
    # within a few tenths of a ms on average, and the standard error says how far off it is
    assert abs(np.mean(errs)) < 0.5e-3 and np.sqrt(np.mean(np.square(errs))) < 1e-3, errs
    assert np.max(np.abs(z)) < 3.0


def test_a_slow_landing_at_constant_speed_is_timed_less_well_and_says_so():
    for seed in range(6):
        lg = landing(v=25.0, decel=0.0, jerk=0.0, t_touch=0.1204 + 1.23e-4 * seed,
                     rng=np.random.default_rng(seed))
        td = touch_video(lg.t_frames, lg.gap_mm)
        assert td.measured and abs(td.t_s - lg.t_touch) < 3 * td.se_s


def test_the_video_needs_the_approach():
    lg = landing()
    resting = np.where(np.isfinite(lg.gap_mm), 0.0, np.nan)
    td = touch_video(lg.t_frames, resting)
    assert not td.measured and "frames of the finger's approach" in td.message
    never = np.full(lg.t_frames.size, 2.0)
    assert not touch_video(lg.t_frames, never).measured
    assert not touch_video(lg.t_frames[:-1], lg.gap_mm).measured


@pytest.mark.parametrize("v", [20.0, 50.0, 80.0])
def test_the_force_times_the_landing_from_its_onset(v):
    errs = []
    for seed in range(6):
        lg = landing(v=v, t_touch=0.1204 + 3.3e-5 * seed, rng=np.random.default_rng(seed))
        td = touch_force(lg.f1, lg.f2, lg.fs_hz, 0.0, mains_hz=50.0)
        assert td.measured, td.message
        assert abs(td.t_s - lg.t_touch) < 0.15e-3
        errs.append((td.t_s - lg.t_touch) / td.se_s)
    assert np.sqrt(np.mean(np.square(errs))) < 3.0
    # on another clock: the instant moves with it
    td = touch_force(lg.f1, lg.f2, lg.fs_hz, 0.25, mains_hz=50.0)
    assert td.t_s == pytest.approx(lg.t_touch + 0.25, abs=0.15e-3)


def test_the_force_needs_a_rest_before_the_touch():
    lg = landing(t_touch=0.01)
    td = touch_force(lg.f1, lg.f2, lg.fs_hz, 0.0)
    assert not td.measured and "rest" in td.message
    flat = np.zeros(5000)
    assert not touch_force(flat, flat, 10_000.0).measured


def _o(tid, d, se=1e-4):
    from types import SimpleNamespace

    return SimpleNamespace(trial_id=tid, touch_offset_s=d, touch_se_s=se)  # what touch_level reads


def test_the_level_a_fingers_touch_downs_share():
    rng = np.random.default_rng(2)
    speeds = np.array([40.0, 80.0, 120.0] * 4)
    rel = rng.normal(0, 3e-3, speeds.size)
    c, k = 2e-3, 0.01
    d = rel + c + k * speeds**-0.25 + rng.normal(0, 1e-4, speeds.size)
    items = [_o(f"t{i}", float(x)) for i, x in enumerate(d)]
    items.append(_o("wild", 0.05))  # a false touch: dropped
    rels = {f"t{i}": float(r) for i, r in enumerate(rel)} | {"wild": 0.0}
    lev = touch_level(items, rels)
    assert lev.n == speeds.size
    mean_speed_term = float(np.mean(k * speeds**-0.25))
    assert lev.at(1.0)[0] == pytest.approx(c + mean_speed_term, abs=1e-4)
    sp = {f"t{i}": float(v) for i, v in enumerate(speeds)} | {"wild": 80.0}
    lev2 = touch_level(items, rels, speeds=sp)
    for v in (40.0, 120.0):
        got, se = lev2.at(v)
        assert got == pytest.approx(c + k * v**-0.25, abs=3 * se + 1e-5)
    assert touch_level(items[:2], rels) is None
    nan = [_o("t0", math.nan), _o("t1", 0.0), _o("t2", 0.0)]
    assert touch_level(nan, rels) is None


def test_touchdown_is_a_value():
    assert not TouchDown(math.nan, math.nan).measured and TouchDown(0.1, 1e-4).measured
