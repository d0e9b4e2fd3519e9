"""Tests of the trial kinematics (fingerfriction.sim.kinematics)."""

from __future__ import annotations

import numpy as np
import pytest

from fingerfriction.sim.kinematics import KinematicsParams, min_jerk, simulate_kinematics


@pytest.mark.parametrize("speed", [40.0, 80.0, 120.0])
def test_slide_covers_window_at_about_the_nominal_speed(speed):
    P = KinematicsParams()
    k = simulate_kinematics(speed, np.random.default_rng(int(speed)), P)
    assert k.t[1] - k.t[0] == pytest.approx(1e-4)
    assert k.x[0] == P.x_start and k.x.max() > P.window / 2
    assert np.all(np.diff(k.x) >= 0)  # left to right, never backwards
    inwin = (k.x > -P.window / 2) & (k.x < P.window / 2)
    v = np.gradient(k.x, k.t)[inwin]
    # the trial's mean speed is within +-20 % of nominal (human variability)
    assert 0.75 * speed < np.mean(v) < 1.25 * speed
    assert 0.8 <= k.mean_speed / speed <= 1.2
    # speed fluctuates (not a constant)
    assert np.std(v[len(v) // 4: -len(v) // 4]) > 0.01 * speed
    # normal force while sliding: 0.3 N +- 50 mN, and fluctuating
    sliding = (k.sliding_distance > 0) & (k.t < k.t_stop)
    fn = k.f_n[sliding & (k.t > k.t_descent + P.descent_s + P.load_s)]
    assert np.all(np.abs(fn - 0.3) <= 0.05 + 1e-12)
    assert np.std(fn) > 1e-3
    # finger starts above the surface and is down while sliding
    assert k.z[0] == pytest.approx(P.z_top) and np.all(k.z[sliding] == 0)


def test_same_generator_same_kinematics():
    a = simulate_kinematics(80.0, np.random.default_rng(1))
    b = simulate_kinematics(80.0, np.random.default_rng(1))
    c = simulate_kinematics(80.0, np.random.default_rng(2))
    assert np.array_equal(a.x, b.x) and np.array_equal(a.f_n, b.f_n)
    assert not np.array_equal(a.x, c.x)


def test_min_jerk_end_points():
    assert min_jerk(0.0) == 0 and min_jerk(1.0) == 1 and min_jerk(0.5) == pytest.approx(0.5)
    assert min_jerk(-1.0) == 0 and min_jerk(2.0) == 1


@pytest.mark.parametrize("speed", [0.0, -40.0, float("nan"), "fast"])
def test_bad_speed(speed):
    with pytest.raises(ValueError, match="speed_mm_s"):
        simulate_kinematics(speed, np.random.default_rng(0))


def test_params_must_cover_window():
    with pytest.raises(ValueError, match="window"):
        KinematicsParams(x_start=-10.0)
