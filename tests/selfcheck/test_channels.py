"""Channels and units: clean trials pass; each classic mistake is an error naming its
likely cause and the manifest field."""

from __future__ import annotations

import re

import numpy as np
import pytest

from fingerfriction.selfcheck import check_channels, force_figures

from .synth import SQRT2, press_and_slide


def _checks(f1, f2, fs, direction, units="N"):
    f_n, f_t = (f1 + f2) / SQRT2, (f1 - f2) / SQRT2
    fig = force_figures(f_n, f_t, fs, direction)
    return fig, {c.code: c for c in check_channels(fig, units=units)}


@pytest.mark.parametrize(
    "mu,direction,load", [(0.5, 1, 0.3), (0.25, 1, 0.1), (1.2, -1, 2.0), (0.6, -1, 0.05)]
)
def test_clean_trials_are_not_flagged(mu, direction, load):
    tr = press_and_slide(mu=mu, direction=direction, load=load, rng=np.random.default_rng(3))
    fig, checks = _checks(tr.f1, tr.f2, tr.fs_hz, direction)
    assert all(c.level == "ok" for c in checks.values()), [
        c.line() for c in checks.values() if c.level != "ok"
    ]
    assert fig.f_n_level_n == pytest.approx(load, rel=0.05)
    assert abs(fig.loading_angle_deg) < 5
    assert fig.sliding_ratio == pytest.approx(mu, rel=0.1)


def test_swapped_channels():
    tr = press_and_slide()
    _, c = _checks(tr.f2, tr.f1, tr.fs_hz, 1)
    assert c["channel-swap"].level == "error" and "F1 and F2 look swapped" in c["channel-swap"].message
    assert c["channel-swap"].field == "force.channels" and c["channel-swap"].figure < 0


@pytest.mark.parametrize(
    "which,angle,text",
    [
        ("F1", -90, "F1 looks negated"),
        ("F2", 90, "F2 looks negated"),
        ("both", 180, "F1 and F2 both look negated"),
    ],
)
def test_negated_channels(which, angle, text):
    tr = press_and_slide()
    f1 = -tr.f1 if which in ("F1", "both") else tr.f1
    f2 = -tr.f2 if which in ("F2", "both") else tr.f2
    fig, c = _checks(f1, f2, tr.fs_hz, 1)
    assert c["channel-polarity"].level == "error" and text in c["channel-polarity"].message
    assert abs(((fig.loading_angle_deg - angle) + 180) % 360 - 180) < 5
    assert "force-level" not in c and "channel-swap" not in c  # one cause, one line


@pytest.mark.parametrize("k,which", [(10.0, "F1"), (0.1, "F1"), (10.0, "F2")])
def test_one_channel_scale_off(k, which):
    """F1 / F2 = tan(45 deg + angle) while the finger presses without sliding."""
    tr = press_and_slide()
    f1 = tr.f1 * (k if which == "F1" else 1.0)
    f2 = tr.f2 * (k if which == "F2" else 1.0)
    fig, c = _checks(f1, f2, tr.fs_hz, 1)
    gain = c["channel-gain"]
    assert gain.level == "error" and gain.field == "force.sensitivity_n_per_v"
    big = which if k > 1 else ("F2" if which == "F1" else "F1")
    assert re.search(rf"{big} reads (9\.\d+|10(\.\d+)?)x", gain.message), gain.message
    ratio = np.tan(np.radians(45 + fig.loading_angle_deg))
    assert max(ratio, 1 / ratio) == pytest.approx(10.0, rel=0.05)


def test_millinewtons_labelled_newtons():
    tr = press_and_slide()
    _, c = _checks(1000 * tr.f1, 1000 * tr.f2, tr.fs_hz, 1, units="N")
    lv = c["force-level"]
    assert lv.level == "error" and lv.field == "force.units"
    assert "forces look 1000x too large: mN labelled N?" in lv.message
    assert lv.figure == pytest.approx(300, rel=0.05)


def test_sensitivity_1000x_off():
    tr = press_and_slide()
    _, c = _checks(1e-3 * tr.f1, 1e-3 * tr.f2, tr.fs_hz, 1, units="V")
    lv = c["force-level"]
    assert lv.level == "error" and lv.field == "force.sensitivity_n_per_v"
    assert "too small: the sensitivity (or gain) looks 1000x off" in lv.message


def test_friction_outside_the_physical_range():
    tr = press_and_slide(mu=4.5, t_slide=0.2)  # pressed well before it slides
    _, c = _checks(tr.f1, tr.f2, tr.fs_hz, 1)
    assert c["flat-friction"].level == "error" and c["flat-friction"].figure == pytest.approx(4.5, rel=0.1)


def test_no_press_is_said_not_measured():
    fig = force_figures(np.zeros(2000), np.zeros(2000), 10_000.0, 1)
    c = check_channels(fig)
    assert len(c) == 1 and c[0].level == "info" and "not measured" in c[0].message


def test_a_record_that_starts_pressed_is_read_from_its_end():
    """No rest before the touch: the press is not seen (info), the level and the sliding
    sign still are, from the rest after the lift-off."""
    tr = press_and_slide(duration_s=1.2)
    t = tr.t
    lift = 1.0 - np.clip((t - 0.9) / 0.05, 0, 1)  # the finger lifts off at 0.9 s
    keep = t >= 0.3  # the record starts mid-slide
    f1, f2 = (tr.f1 * lift)[keep], (tr.f2 * lift)[keep]
    fig, c = _checks(f1, f2, tr.fs_hz, 1)
    assert c["channel-polarity"].level == "info" and "already pressing" in c["channel-polarity"].message
    assert c["force-level"].level == "ok" and c["channel-swap"].level == "ok"
    _, c = _checks(f2, f1, tr.fs_hz, 1)
    assert c["channel-swap"].level == "error"
