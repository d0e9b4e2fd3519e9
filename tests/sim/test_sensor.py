"""Tests of the force sensor model (fingerfriction.sim.sensor)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.signal import butter, freqz

from fingerfriction.sim.sensor import SensorParams, apply_sensor, from_channels, to_channels

finite = st.floats(-5, 5, allow_nan=False)


@pytest.mark.slow
@given(st.lists(st.tuples(finite, finite), min_size=1, max_size=50))
@settings(max_examples=50, deadline=None)
def test_channel_decomposition_is_an_exact_inverse(pairs):
    fn, ft = np.array(pairs).T
    f1, f2 = to_channels(fn, ft)
    fn2, ft2 = from_channels(f1, f2)
    np.testing.assert_allclose(fn2, fn, atol=1e-12)
    np.testing.assert_allclose(ft2, ft, atol=1e-12)
    # the paper's formulas, written out
    np.testing.assert_allclose((f1 + f2) / np.sqrt(2), fn, atol=1e-12)
    np.testing.assert_allclose((f1 - f2) / np.sqrt(2), ft, atol=1e-12)


def test_round_trip_through_the_sensor_within_quantisation():
    """With the analogue impairments off, F1, F2 -> F_N, F_T recovers the true forces to
    within the quantisation step (an LSB per channel, combined by 1/sqrt 2)."""
    P = SensorParams(highpass_hz=0.0, drift_offset_n=0.0, drift_rate_n_per_s=0.0, mains_n=(0, 0, 0),
                     noise_n=0.0)
    rng = np.random.default_rng(0)
    t = np.arange(5000) / P.fs_hz
    fn = 0.3 + 0.05 * np.sin(2 * np.pi * 3 * t)
    ft = 0.18 + 0.05 * np.sin(2 * np.pi * 7 * t + 1)
    f1, f2 = apply_sensor(fn, ft, rng, P)
    # the readings are on the 16-bit grid
    k = f1 / P.lsb_n
    np.testing.assert_allclose(k, np.rint(k), atol=1e-9)
    assert P.lsb_n == pytest.approx(5.0 / 65536)
    fn2, ft2 = from_channels(f1, f2)
    tol = P.lsb_n / np.sqrt(2) + 1e-12  # |e1 +- e2| / sqrt2 with |e_i| <= LSB/2
    assert np.max(np.abs(fn2 - fn)) <= tol
    assert np.max(np.abs(ft2 - ft)) <= tol


def test_highpass_is_first_order_at_cutoff():
    P = SensorParams()
    b, a = butter(1, P.highpass_hz, btype="highpass", fs=P.fs_hz)
    w, h = freqz(b, a, worN=[P.highpass_hz, 50.0], fs=P.fs_hz)
    assert abs(h[0]) == pytest.approx(1 / np.sqrt(2), rel=1e-3)  # -3 dB at the cutoff
    # a step decays with time constant 1 / (2 pi fc)
    rng = np.random.default_rng(1)
    quiet = SensorParams(drift_offset_n=0, drift_rate_n_per_s=0, mains_n=(0, 0, 0), noise_n=0)
    n = 4000
    f1, f2 = apply_sensor(np.full(n, 0.3), np.zeros(n), rng, quiet)
    tau = 1 / (2 * np.pi * quiet.highpass_hz)
    i = int(tau * quiet.fs_hz)
    assert f1[i] == pytest.approx(0.3 / np.sqrt(2) * np.exp(-1), rel=0.01)


def test_mains_and_noise_present_with_defaults():
    P = SensorParams()
    rng = np.random.default_rng(2)
    n = 10000
    f1, _ = apply_sensor(np.zeros(n), np.zeros(n), rng, P)
    spec = np.abs(np.fft.rfft(f1 - f1.mean())) / n * 2
    freqs = np.fft.rfftfreq(n, 1 / P.fs_hz)
    for f0, amp in zip((50, 150, 300), P.mains_n, strict=True):
        a = spec[np.argmin(np.abs(freqs - f0))]
        assert 0.3 * amp < a < 2.0 * amp, (f0, a, amp)


def test_deterministic_given_generator():
    n = 1000
    a = apply_sensor(np.full(n, 0.3), np.zeros(n), np.random.default_rng(5))
    b = apply_sensor(np.full(n, 0.3), np.zeros(n), np.random.default_rng(5))
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


@pytest.mark.parametrize("kw, match", [
    (dict(highpass_hz=6000.0), "Nyquist"),
    (dict(noise_n=-1.0), "noise_n"),
    (dict(mains_n=(1.0, 2.0)), "mains_n"),
    (dict(bits=1), "bits"),
])
def test_sensor_params_validated(kw, match):
    with pytest.raises(ValueError, match=match):
        SensorParams(**kw)
