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


@pytest.mark.parametrize("field, value, message", [
    ("pre_s", -0.1, r"^KinematicsParams.pre_s must be >= 0, got -0.1$"),
    ("force_sd", float("inf"), r"^KinematicsParams.force_sd must be a finite number, got inf$"),
    ("ramp_s", "0.06", r"^KinematicsParams.ramp_s must be a finite number, got '0.06'$"),
])
def test_bad_kinematics_field_one_line(field, value, message):
    with pytest.raises(ValueError, match=message):
        KinematicsParams(**{field: value})


def test_params_must_cover_window():
    with pytest.raises(ValueError, match="window"):
        KinematicsParams(x_start=-10.0)


def test_the_finger_lands_at_its_approach_speed_and_the_load_leaves_zero_with_a_slope():
    P = KinematicsParams()
    speeds = []
    for seed in range(12):
        k = simulate_kinematics(80.0, np.random.default_rng(seed), P)
        speeds.append(k.approach_speed)
        assert P.approach_speed_min <= k.approach_speed <= P.approach_speed_max
        i = int(np.flatnonzero(k.t >= k.t_contact)[0])
        assert abs(k.t_contact - P.pre_s - P.descent_s) <= P.descent_jitter * P.descent_s + 1e-12
        # the descent is monotone and reaches the surface at -v_a (finite differences, 0.1 ms),
        # decelerating (a reach aimed beyond the surface)
        assert np.all(np.diff(k.z[: i + 1]) <= 1e-12) and k.z[i] == pytest.approx(0.0, abs=1e-12)
        c = np.polyfit(k.t[i - 4 : i] - k.t_contact, k.z[i - 4 : i], 3)
        assert c[-1] == pytest.approx(0.0, abs=1e-6)  # it reaches 0 at the touch
        v_end = -c[-2]
        assert v_end == pytest.approx(k.approach_speed, rel=0.01)
        assert k.z[i - 40] - k.z[i - 20] > k.z[i - 20] - k.z[i]
        # the load is 0 before the touch and rises at k_pad v_a (N/s) just after it
        assert np.all(k.f_n[:i] == 0)
        slope = k.f_n[i + 5] / (k.t[i + 5] - k.t_contact)
        assert slope == pytest.approx(P.pad_stiffness * k.approach_speed, rel=0.05)
        # and it keeps rising to the press (no overshoot) over load_s
        n_load = int(P.load_s * P.fs_hz)
        assert np.all(np.diff(k.f_n[i : i + n_load]) > -2e-4)
    assert np.ptp(np.log(speeds)) > 0.5  # drawn per trial over the range


def test_the_zero_speed_landing_is_the_minimum_jerk_one():
    P0 = KinematicsParams(approach_speed_min=0.0, approach_speed_max=0.0)
    a = simulate_kinematics(80.0, np.random.default_rng(3), P0)
    assert a.approach_speed == 0.0 and a.pad is None and a.t_contact == P0.pre_s + P0.descent_s
    desc = (a.t >= P0.pre_s) & (a.t < a.t_contact)
    np.testing.assert_allclose(a.z[desc], P0.z_top * (1 - min_jerk((a.t[desc] - P0.pre_s) / P0.descent_s)),
                               atol=1e-12)
    load = (a.t >= a.t_contact) & (a.t < a.t_contact + P0.load_s)
    ramp = min_jerk((a.t[load] - a.t_contact) / P0.load_s)
    assert np.all(a.f_n[load] <= 0.35 * ramp + 1e-12) and np.all(a.f_n[load] >= 0.25 * ramp - 1e-12)
    b = simulate_kinematics(80.0, np.random.default_rng(3))
    assert b.pad is not None and b.approach_speed > 0


def test_pad_law_round_trip_and_its_order_of_magnitude():
    pad = KinematicsParams().pad
    f = np.array([0.0, 0.01, 0.3, 1.0])
    np.testing.assert_allclose(pad.force(pad.indentation(f)), f, atol=1e-12)
    assert 0.7 < pad.indentation(0.3) < 1.3 and 1.5 < pad.indentation(1.0) < 2.5  # mm


@pytest.mark.parametrize("kw, match", [
    (dict(approach_speed_min=50.0, approach_speed_max=20.0), "approach_speed_min"),
    (dict(approach_speed_min=0.0, approach_speed_max=20.0), "approach_speed_min"),
    (dict(approach_speed_max=200.0), "overshoots"),
    (dict(pad_stiffness=0.0), "pad_stiffness"),
])
def test_bad_landing_params(kw, match):
    with pytest.raises(ValueError, match=match):
        KinematicsParams(**kw)
