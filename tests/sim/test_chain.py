"""The realistic measurement chain (fingerfriction.sim.chain) against scipy references."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import bilinear, butter, freqz, lfilter, sosfreqz

from fingerfriction.sim import KinematicsParams
from fingerfriction.sim.chain import (
    ChainDraws,
    RealisticChain,
    couple_normal_force,
    cutoff_of_poles,
    draw_device,
    draw_trial_chain,
    highpass2,
    poles_of_cutoff,
    speed_scaled_kinematics,
    tray_response,
)
from fingerfriction.sim.contact import build_table
from fingerfriction.sim.kinematics import Kinematics
from fingerfriction.sim.sensor import SensorParams, apply_sensor, from_channels
from fingerfriction.surfaces import get_surface

FS = 10_000.0


@pytest.mark.parametrize("fc,r", [(3.0, 0.1), (5.0, 0.5), (8.0, 1.0), (4.0, 0.0)])
def test_second_order_highpass_has_its_cutoff(fc, r):
    poles = poles_of_cutoff(fc, r)
    assert poles[1] == pytest.approx(r * poles[0])
    assert cutoff_of_poles(poles) == pytest.approx(fc, rel=1e-9)
    sos = np.concatenate([butter(1, f, btype="highpass", fs=FS, output="sos") for f in poles if f > 0])
    _, h = sosfreqz(sos, worN=[fc], fs=FS)
    assert abs(h[0]) == pytest.approx(1 / math.sqrt(2), rel=1e-3)  # -3 dB (bilinear: prewarp is tiny)


def test_highpass2_is_two_first_order_filters_in_cascade():
    rng = np.random.default_rng(0)
    x = np.cumsum(rng.standard_normal(3000)) * 1e-3 + 0.3
    y = highpass2(x, (4.0, 1.0), FS)
    b1, a1 = butter(1, 4.0, btype="highpass", fs=FS)
    b2, a2 = butter(1, 1.0, btype="highpass", fs=FS)
    np.testing.assert_allclose(y, lfilter(b2, a2, lfilter(b1, a1, x)), rtol=1e-10, atol=1e-13)
    # second order: a step's response crosses zero (undershoot), a first-order one never does
    step = highpass2(np.ones(30000), (4.0, 1.0), FS)
    assert step.min() < -0.05 and lfilter(b1, a1, np.ones(30000)).min() > 0


def test_crosstalk_and_extra_drift_enter_the_channels_exactly():
    quiet = SensorParams(drift_offset_n=0, drift_rate_n_per_s=0, mains_n=(0, 0, 0), noise_n=0)
    n = 2000
    t = np.arange(n) / FS
    fn = 0.3 + 0.02 * np.sin(2 * np.pi * 3 * t)
    ft = 0.15 + 0.03 * np.sin(2 * np.pi * 11 * t)
    M = np.array([[1.0, 0.04], [-0.03, 1.0]])
    drift = np.vstack([1e-3 * t**2, -2e-3 * np.sqrt(t)])
    chain = ChainDraws(poles_hz=np.zeros((2, 2)), crosstalk=M, drift=drift)  # poles 0: no high-pass
    f1, f2 = apply_sensor(fn, ft, np.random.default_rng(0), quiet, chain=chain)
    c1, c2 = (fn + ft) / math.sqrt(2), (fn - ft) / math.sqrt(2)
    lsb = quiet.lsb_n
    assert np.max(np.abs(f1 - (c1 + 0.04 * c2 + drift[0]))) <= lsb / 2 + 1e-12
    assert np.max(np.abs(f2 - (-0.03 * c1 + c2 + drift[1]))) <= lsb / 2 + 1e-12
    # the decomposition now mixes F_N into F_T: (c12 - c21) / 2 of it on flat ground
    fn2, ft2 = from_channels(f1 - drift[0], f2 - drift[1])
    np.testing.assert_allclose(ft2, (1 - 0.005) * ft + 0.035 * fn, atol=2 * lsb)


def test_the_ideal_chain_draws_are_unchanged_by_a_realistic_chain():
    """The realistic chain adds to the ideal one's draws, it does not consume them: with
    a chain whose effects are nil the readings are the ideal chain's without high-pass."""
    P = SensorParams(highpass_hz=0.0)
    n = 1500
    fn, ft = np.full(n, 0.3), np.full(n, 0.16)
    a = apply_sensor(fn, ft, np.random.default_rng(5), P)
    nil = ChainDraws(np.zeros((2, 2)), np.eye(2), np.zeros((2, n)))
    b = apply_sensor(fn, ft, np.random.default_rng(5), P, chain=nil)
    np.testing.assert_array_equal(a[0], b[0])
    np.testing.assert_array_equal(a[1], b[1])


def test_device_and_trial_draws():
    ch = RealisticChain()
    d = draw_device(7, ch)
    assert d == draw_device(7, ch) and d != draw_device(8, ch)
    assert 3.0 <= d["cutoff_hz"] <= 8.0 and 0.1 <= d["pole_ratio"] <= 0.5
    assert cutoff_of_poles(d["poles_hz"]) == pytest.approx(d["cutoff_hz"], rel=1e-9)
    for c in (d["crosstalk"][0][1], d["crosstalk"][1][0]):
        assert 0.02 <= abs(c) <= 0.05
    n = 10_000
    t = np.arange(n) / FS
    curved = 0
    for seed in range(20):
        draws = draw_trial_chain(np.random.default_rng(seed), n, FS, ch, d)
        assert draws.poles_hz.shape == (2, 2) and not np.array_equal(draws.poles_hz[0], draws.poles_hz[1])
        for c in range(2):
            resid = draws.drift[c] - np.polyval(np.polyfit(t, draws.drift[c], 1), t)
            curved += np.sqrt(np.mean(resid**2)) > 5e-6  # 5 uN RMS off the best straight line
    assert curved >= 36  # of 40 channels: the drift is not a straight line (but nearly: below
    # 0.1 mN RMS over 1 s, "the drift could be approximated by a linear trend", Methods)


def test_chain_options_are_validated():
    with pytest.raises(ValueError, match="cutoff_hz must be a finite range"):
        RealisticChain(cutoff_hz=(8.0, 3.0))
    with pytest.raises(ValueError, match="crosstalk must be at most 0.2"):
        RealisticChain(crosstalk=(0.1, 0.3))
    with pytest.raises(ValueError, match="control_hz and drift_wander_hz must be > 0"):
        RealisticChain(control_hz=0.0)
    assert RealisticChain.from_dict(RealisticChain().to_dict()) == RealisticChain()


def test_motor_noise_grows_with_speed():
    k = KinematicsParams()
    ch = RealisticChain()
    slow, fast = (speed_scaled_kinematics(k, v, ch) for v in (40.0, 120.0))
    assert fast.force_sd / slow.force_sd == pytest.approx(3.0)  # proportional to speed
    assert fast.speed_sd > k.speed_sd > slow.speed_sd


class _FlatPad:
    name = "pad"

    def finger_dict(self, subject):
        return {}

    def grid(self, subject):
        return np.linspace(-1.0, 1.0, 401)

    def solve(self, surface, subject, x_centres, load):
        xi = self.grid(subject)
        X = np.asarray(x_centres)[:, None] + xi[None, :]
        return surface.h(X), np.full(X.shape, load / 2.0)  # uniform pressure over 2 mm


def test_normal_force_follows_the_relief_through_the_control_loop():
    """On a step up crossed quickly the support rises by H: the force first rises by about
    k H, then the integral controller brings it back with time constant 1 / (2 pi fc)."""
    surf = get_surface("step-up-2mm")  # H = 0.4 mm
    table = build_table(surf, "1", loads=(0.2, 0.4), step=0.02, provider=_FlatPad())
    n = 6000
    t = np.arange(n) / FS
    x = -5.0 + 400.0 * t  # 400 mm/s: the 3 mm support transit takes 7.5 ms
    kin = Kinematics(t=t, x=x, z=np.zeros(n), f_n=np.full(n, 0.3), sliding_distance=x + 5.0,
                     in_contact=np.ones(n, bool), t_descent=0.0, t_slide_start=0.0, t_stop=0.5,
                     mean_speed=400.0, f_target=0.3)
    ch = RealisticChain(coupling_sd=0.0, control_hz=3.0)
    f_n, info = couple_normal_force(kin, table, ch, np.random.default_rng(0))
    assert info["coupling_n_per_mm"] == pytest.approx(0.05)
    assert np.max(f_n) - 0.3 == pytest.approx(0.05 * 0.4, rel=0.1)
    i_top = np.argmax(f_n)
    later = i_top + int(FS / (2 * np.pi * 3.0))  # one time constant later
    assert (f_n[later] - 0.3) / (f_n[i_top] - 0.3) == pytest.approx(math.exp(-1), rel=0.05)
    np.testing.assert_allclose(f_n[x < -2.0], 0.3)  # flat ground before the step: no change


def test_the_labs_calibration_leaves_only_its_error_of_the_crosstalk():
    quiet = SensorParams(drift_offset_n=0, drift_rate_n_per_s=0, mains_n=(0, 0, 0), noise_n=0)
    n = 500
    fn, ft = np.full(n, 0.3), np.full(n, 0.165)
    M = np.array([[1.0, -0.033], [0.033, 1.0]])
    exact = ChainDraws(np.zeros((2, 2)), M, np.zeros((2, n)), calibration=M)
    f1, f2 = apply_sensor(fn, ft, np.random.default_rng(0), quiet, chain=exact)
    fn2, ft2 = from_channels(f1, f2)
    assert np.max(np.abs(ft2 / fn2 - 0.55)) < 1e-3  # only the quantisation is left
    raw = ChainDraws(np.zeros((2, 2)), M, np.zeros((2, n)))
    fn3, ft3 = from_channels(*apply_sensor(fn, ft, np.random.default_rng(0), quiet, chain=raw))
    assert np.mean(ft3 / fn3) == pytest.approx((0.55 - 0.033) / (1 + 0.55 * 0.033), rel=1e-3)  # -7.7 %
    d = draw_device(3, RealisticChain())
    for i, j in ((0, 1), (1, 0)):
        assert abs(d["calibration"][i][j] / d["crosstalk"][i][j] - 1) <= 0.3  # 10 % error, clipped at 3 SD
    assert "calibration" not in draw_device(3, RealisticChain(crosstalk_calibration=None))
    # the option does not change the device's other draws
    assert draw_device(3, RealisticChain(crosstalk_calibration=None))["crosstalk"] == d["crosstalk"]


def test_the_tray_is_flat_to_500_hz_and_rings_at_its_resonance():
    """The tray's second-order resonance: unit gain at rest, within about 1 dB of flat up to
    500 Hz at every corner of the default ranges ("a nearly flat frequency response from 15
    to 500 Hz"), |H| = q at the resonance, and, where the force clock resolves the ringing,
    a step's overshoot that of a second-order system, exp(-pi / sqrt(4 q^2 - 1))."""
    ch = RealisticChain()
    for f_r in ch.tray_hz:
        for q in ch.tray_q:
            w = 2.0 * FS * math.tan(math.pi * f_r / FS)
            b, a = bilinear([w * w], [1.0, w / q, w * w], FS)
            _, h = freqz(b, a, worN=[1e-3, 15.0, 100.0, 500.0, f_r], fs=FS)
            g = np.abs(h)
            assert g[0] == pytest.approx(1.0, abs=1e-9) and abs(g[1] - 1) < 1e-4 and abs(g[2] - 1) < 0.01
            assert 1.0 < g[3] < 10 ** (1.05 / 20)
            assert g[4] == pytest.approx(q, rel=1e-6)  # prewarped: the resonance stays at f_r
            step = tray_response(np.ones(4000), f_r, q, FS)
            assert step[-1] == pytest.approx(1.0, abs=1e-9)
    step = tray_response(np.ones(4000), 1500.0, 2.0, FS)
    assert step.max() - 1.0 == pytest.approx(math.exp(-math.pi / math.sqrt(15.0)), rel=0.01)


def test_the_tray_acts_on_the_plates_axes_before_the_transducers():
    quiet = SensorParams(drift_offset_n=0, drift_rate_n_per_s=0, mains_n=(0, 0, 0), noise_n=0)
    n = 3000
    t = np.arange(n) / FS
    fn = 0.3 + 0.05 * (t > 0.1)
    ft = 0.15 * np.sin(2 * np.pi * 300 * t) * (t > 0.05)
    tray = np.array([[1800.0, 3.0], [2400.0, 6.0]])
    chain = ChainDraws(np.zeros((2, 2)), np.eye(2), np.zeros((2, n)), tray=tray)
    fn2, ft2 = from_channels(*apply_sensor(fn, ft, np.random.default_rng(0), quiet, chain=chain))
    np.testing.assert_allclose(fn2, tray_response(fn, 1800.0, 3.0, FS), atol=quiet.lsb_n)
    np.testing.assert_allclose(ft2, tray_response(ft, 2400.0, 6.0, FS), atol=quiet.lsb_n)
    d = draw_device(5, RealisticChain())
    assert all(1500 <= f <= 3000 for f in d["tray_hz"]) and all(2 <= q <= 8 for q in d["tray_q"])
    draws = draw_trial_chain(np.random.default_rng(0), 100, FS, RealisticChain(), d)
    np.testing.assert_array_equal(draws.tray, np.column_stack([d["tray_hz"], d["tray_q"]]))
    with pytest.raises(ValueError, match="tray_hz must lie in"):
        RealisticChain(tray_hz=(300.0, 1000.0))
