"""The force clock against the mains hum: a mislabelled sampling rate is read from the
data, a right one is not flagged, a record without hum is said unmeasured."""

from __future__ import annotations

import re

import numpy as np
import pytest

from fingerfriction.selfcheck import check_force_clock, mains_frequency

from .synth import mains, press_and_slide


def _record(fs_true=10_000.0, f0=50.0, seed=0, hum=True):
    rng = np.random.default_rng(seed)
    tr = press_and_slide(fs_hz=fs_true, speed=120.0, rng=rng)
    h = mains(tr.t.size, fs_true, f0=f0, rng=rng) if hum else 0.0
    return tr.f1 + h, tr.f2 + 1.2 * h


@pytest.mark.parametrize("label_ratio", [1.0, 1.01, 0.99, 1.03, 0.97])
def test_a_mislabelled_rate_is_read_from_the_hum(label_ratio):
    f1, f2 = _record()
    fs_label = 10_000.0 * label_ratio
    est = mains_frequency(f1, f2, fs_label)
    assert est.found and est.nominal_hz == 50.0
    assert est.rate_ratio == pytest.approx(label_ratio, abs=3e-4)
    c = check_force_clock(est, fs_label)
    if label_ratio == 1.0:
        assert c.level == "ok" and abs(c.figure) < 0.03
    else:
        assert c.level == "error" and c.field == "force.fs_hz"
        assert re.search(rf"{fs_label:g} Hz given, (9999\.\d+|10000(\.\d+)?) Hz by the mains", c.message)


def test_sixty_hertz_mains():
    f1, f2 = _record(f0=60.0)
    est = mains_frequency(f1, f2, 10_000.0)
    assert est.nominal_hz == 60.0 and est.frequency_hz == pytest.approx(60.0, abs=0.01)
    assert check_force_clock(est, 10_000.0).level == "ok"


def test_standard_error_covers_the_truth():
    """Over seeds, the error stays within 4 standard errors (the bound is not overconfident)."""
    errs = []
    for seed in range(6):
        f1, f2 = _record(seed=seed)
        est = mains_frequency(f1, f2, 10_000.0)
        errs.append((est.frequency_hz - 50.0) / est.se_hz)
    assert np.max(np.abs(errs)) < 4.0, errs


def test_no_hum_is_not_measured():
    f1, f2 = _record(hum=False)
    est = mains_frequency(f1, f2, 10_000.0)
    assert not est.found and "no mains hum" in est.message
    c = check_force_clock(est, 10_000.0)
    assert c.level == "info" and "not measured" in c.message


def test_the_nominal_mains_frequencies_are_the_options_ones():
    import inspect

    from fingerfriction.selfcheck import SelfCheckParams
    from fingerfriction.selfcheck.touchdown import touch_force

    nominal = SelfCheckParams().mains_hz
    assert nominal == (50.0, 60.0)
    assert inspect.signature(mains_frequency).parameters["nominal_hz"].default == nominal
    assert inspect.signature(touch_force).parameters["mains_hz"].default == nominal[0]
