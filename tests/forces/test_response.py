"""The sensor's second-order high-pass, estimated per transducer on the rests
(fingerfriction.forces.response), against scipy references."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import butter, sosfilt

from fingerfriction.forces import ForceProcessingParams, process_forces
from fingerfriction.forces.readers import ForceRecord
from fingerfriction.forces.response import HighpassResponse, estimate_response, rest_drift_image

FS = 10_000.0


def _hp(x, poles):
    sos = np.concatenate([butter(1, f, btype="highpass", fs=FS, output="sos") for f in poles])
    return sosfilt(sos, x)


def _minjerk(u):
    u = np.clip(u, 0, 1)
    return u**3 * (10 - 15 * u + 6 * u * u)


def _load(n=9000, t_on=0.12, t_off=0.75, ramp=0.05):
    t = np.arange(n) / FS
    return t, _minjerk((t - t_on) / ramp) * (1 - _minjerk((t - t_off) / ramp))


@pytest.mark.parametrize("poles", [(4.5, 1.9), (6.0, 0.6), (3.0,)])
def test_response_inverts_cascaded_first_order_highpasses_exactly(poles):
    rng = np.random.default_rng(0)
    x = 0.3 * _load()[1] + 0.01 * np.cumsum(rng.standard_normal(9000)) / 100
    resp = HighpassResponse.from_poles(poles, FS)
    np.testing.assert_allclose(resp.invert(_hp(x, poles), FS), x, atol=1e-12)
    got = sorted(float(p) for p in resp.poles_hz(FS) if p)
    assert got == pytest.approx(sorted(poles), rel=1e-9)


def test_cutoff_is_the_minus_3db_point():
    resp = HighpassResponse.from_poles((4.0, 4.0), FS)
    # two equal real poles: -3 dB at f_p / sqrt(sqrt 2 - 1)
    assert resp.cutoff_hz(FS) == pytest.approx(4.0 / math.sqrt(math.sqrt(2) - 1), rel=1e-6)
    assert HighpassResponse.from_poles((5.0,), FS).cutoff_hz(FS) == pytest.approx(5.0, rel=1e-9)


def test_estimate_recovers_both_poles_from_the_rests():
    rng = np.random.default_rng(3)
    t, g = _load()
    x = 0.21 * g
    poles = (4.4, 1.8)
    n = t.size
    y = _hp(x, poles) + 0.002 + 0.003 * t + 5e-4 * rng.standard_normal(n)  # drift line + noise
    rests = (t < 0.11) | (t > 0.82)
    est = estimate_response(y, rests, FS, prior_hz=5.0)
    assert est.success, est.message
    got = sorted(float(p) for p in est.poles_hz)
    assert got == pytest.approx(sorted(poles), rel=0.03)
    comp = est.response.invert(y, FS)
    image, coef = rest_drift_image(comp, rests, FS, est.response)
    err = comp - image - x
    assert np.sqrt(np.mean(err**2)) < 0.01 * 0.21  # within 1 % of the load
    # order 1 cannot represent it: the rests are left with a large residual
    one = estimate_response(y, rests, FS, prior_hz=5.0, order=1)
    assert one.rms_residual_n > 10 * est.rms_residual_n


def test_estimate_without_a_rest_after_the_lift_off_is_not_determined():
    t, g = _load(n=7000, t_off=0.69)  # the record ends while unloading
    y = _hp(0.3 * g, (5.0, 1.0))
    est = estimate_response(y, t < 0.11, FS, prior_hz=5.0)
    assert not est.success and "do not determine" in est.message
    assert est.response == HighpassResponse(2 * FS * math.tan(math.pi * 5.0 / FS), 0.0)
    with pytest.raises(ValueError, match="at least 8 rest samples"):
        estimate_response(y, np.zeros(t.size, bool), FS, prior_hz=5.0)


def test_process_forces_with_a_second_order_sensor_per_transducer():
    """Two transducers with their own two-pole chains: the second-order model recovers F_T
    within a few per cent of its peak-to-peak; the first-order compensation told 5 Hz does
    not."""
    rng = np.random.default_rng(7)
    t, g = _load(n=10000, t_on=0.12, t_off=0.80)
    slide = (t > 0.2) & (t < 0.78)
    x_t = np.where(slide, -14.0 + 50.0 * (t - 0.2), np.nan)
    bump = np.exp(-0.5 * ((np.nan_to_num(x_t, nan=-99.0)) / 1.0) ** 2)
    f_n = 0.3 * g
    f_t = g * (0.16 + 0.04 * bump * slide)
    f1, f2 = (f_n + f_t) / math.sqrt(2), (f_n - f_t) / math.sqrt(2)
    y1 = _hp(f1, (4.4, 1.8)) + 5e-4 * rng.standard_normal(t.size)
    y2 = _hp(f2, (4.6, 1.9)) + 5e-4 * rng.standard_normal(t.size)
    rec = ForceRecord(f1=y1, f2=y2, fs_hz=FS, t0_s=0.0)
    tf = np.arange(0.0, t[-1], 1e-3)
    xf = np.interp(tf, t[slide], x_t[slide], left=np.nan, right=np.nan)
    truth = {}
    for model in ("second-order", "first-order"):
        prof = process_forces(rec, tf, xf, params=ForceProcessingParams(highpass_model=model))
        ref = 0.04 * np.exp(-0.5 * (prof.x / 1.0) ** 2)
        ref = ref - np.polyval(np.polyfit(prof.x[prof.x < -9], ref[prof.x < -9], 1), prof.x)
        truth[model] = np.sqrt(np.mean((prof.f_t - ref) ** 2)) / np.ptp(ref)
        if model == "second-order":
            step = next(h for h in prof.history if h["step"] == "compensate_response")
            assert step["F1_estimated"] and step["F2_estimated"]
            assert sorted(step["F1_poles_hz"]) == pytest.approx([1.8, 4.4], rel=0.05)
    assert truth["second-order"] < 0.03
    assert truth["first-order"] > 0.2


def test_params_validate_the_model():
    with pytest.raises(ValueError, match="highpass_model must be one of first-order, second-order, got 'th"):
        ForceProcessingParams(highpass_model="third")
    with pytest.raises(ValueError, match="highpass_model='second-order' needs sensor_highpass_hz"):
        ForceProcessingParams(highpass_model="second-order", sensor_highpass_hz=None)
