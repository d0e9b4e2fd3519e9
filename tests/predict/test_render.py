"""Tests of fingerfriction.predict.render: the haptic renderer, its exports and the replay check."""

from __future__ import annotations

import json
import logging

import numpy as np
import pandas as pd
import pytest
from scipy.io import wavfile

from fingerfriction.mechanics import SUBJECTS, solve_contact
from fingerfriction.model import FrictionModel, FrictionParams
from fingerfriction.predict import flat_contact_length, predict
from fingerfriction.predict.render import DisplayModel, HapticRenderer, read_command
from fingerfriction.surfaces import SampledProfile

SPEC = "bump:W=3,H=0.5"


@pytest.fixture(scope="module")
def renderer():
    p0 = 0.3 / flat_contact_length(1)  # flat-ground friction mu * 0.3 N
    return HapticRenderer.for_surface(SPEC, 1, FrictionParams(0.55, p0, 0.1), step=0.05)


def _flat():
    x = np.linspace(-40.0, 40.0, 5)
    return SampledProfile(x, np.zeros_like(x), name="flat")


def _replay_flat(mu_cmd, x, params: FrictionParams, normal_force: float) -> np.ndarray:
    """Independent replay: Eq. (4) on a flat display, mu replaced by the command.

    The flat contact comes from one direct solve of the forward model (not the
    renderer's cached length); it is translated with the finger (flat ground is
    translation invariant). Eq. (4) is linear in mu, so per-sample mu is applied through
    the basis evaluated at mu = 0 and mu = 1.
    """
    flat = _flat()
    sol = solve_contact(flat, SUBJECTS[1], 0.0, load=normal_force, n=1024)
    assert sol.success
    reg = sol.geometric_regions[None, :, :] + x[:, None, None]
    model = FrictionModel(flat)
    b0 = model.basis(reg, 0.0)
    b1 = model.basis(reg, 1.0)
    cols = b0 + mu_cmd[:, None] * (b1 - b0)
    return params.p0 * cols[:, 0] + params.p1 * cols[:, 1]


def _rms_rel(a, b):
    return float(np.sqrt(np.mean((a - b) ** 2)) / np.sqrt(np.mean(b**2)))


@pytest.mark.slow
@pytest.mark.parametrize("ext", [".wav", ".csv"])
def test_exported_command_replayed_on_flat_reproduces_force(renderer, tmp_path, ext):
    speed, rate = 80.0, 2000
    out = renderer.write_command(tmp_path / f"cmd{ext}", speed, rate)
    meta = json.loads(open(out["meta"]).read())
    if ext == ".wav":
        fs, data = wavfile.read(out["signal"])
        assert fs == rate and data.dtype == np.float32
        mu = data.astype(float)
    else:
        mu = pd.read_csv(out["signal"])["mu_cmd"].to_numpy()
    x = meta["x_start_mm"] + speed * np.arange(mu.size) / rate  # time -> position
    pred = renderer.prediction
    target = np.interp(x, pred.positions, pred.F_T)
    replay = _replay_flat(mu, x, pred.params, 0.3)
    err = _rms_rel(replay, target)
    assert err < 0.05, err
    # Against the prediction on its own positions: includes what sampling at the display
    # rate loses (0.04 mm per sample here; measured 0.12 % RMS).
    back = np.interp(pred.positions, x, replay)
    assert _rms_rel(back, pred.F_T) < 0.05
    # and it is not trivially satisfied: a wrong speed in the mapping fails the check
    x_wrong = meta["x_start_mm"] + 1.1 * speed * np.arange(mu.size) / rate
    assert _rms_rel(replay, np.interp(x_wrong, pred.positions, pred.F_T)) > 0.05


@pytest.mark.slow
def test_replay_at_another_normal_force(tmp_path):
    pred = predict(SPEC, 1, FrictionParams(0.6, 0.05, 0.1), step=0.05)
    L = flat_contact_length(1, load=0.5)
    r = HapticRenderer(pred, DisplayModel(normal_force=0.5, p0=0.05, flat_length=L))
    out = r.write_command(tmp_path / "c.wav", 40.0, 1000)
    mu, meta = read_command(out["signal"])
    x = meta["x_start_mm"] + 40.0 * np.arange(mu.size) / 1000
    replay = _replay_flat(mu, x, pred.params, 0.5)
    assert _rms_rel(replay, np.interp(x, pred.positions, pred.F_T)) < 0.05


@pytest.mark.slow
def test_query_matches_interpolation_and_batch(renderer):
    rng = np.random.default_rng(7)
    xs = rng.uniform(-16.0, 16.0, 2000)  # includes positions outside the table
    ref = np.interp(xs, renderer.x, renderer.mu_cmd)
    got = np.array([renderer.query(float(v)) for v in xs])
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(renderer.query_many(xs), ref, rtol=0, atol=1e-12)
    fref = np.interp(xs, renderer.x, renderer.force)
    np.testing.assert_allclose([renderer.query_force(float(v)) for v in xs], fref, atol=1e-12)
    np.testing.assert_allclose(renderer.query_force_many(xs), fref, atol=1e-12)
    # the command is F_T / (p0 L_flat): mu on flat ground when p0 L_flat = F_N
    assert renderer.display.effective_normal_force == pytest.approx(0.3)
    assert renderer.query(-100.0) == pytest.approx(0.55, rel=1e-6)
    assert renderer.query_many(np.zeros((3, 4))).shape == (3, 4)


@pytest.mark.slow
def test_table_csv(renderer, tmp_path):
    p = renderer.write_table(tmp_path / "table.csv")
    df = pd.read_csv(p)
    assert list(df.columns) == ["x_mm", "F_T_N", "mu_cmd"]
    np.testing.assert_allclose(df["mu_cmd"] * 0.3, df["F_T_N"], rtol=1e-7)
    assert np.allclose(np.diff(df["x_mm"]), 0.01)


@pytest.mark.slow
def test_display_range_clipping_warns(caplog):
    pred = predict(SPEC, 1, FrictionParams(0.55, 0.0656, 0.1), step=0.1)
    L = flat_contact_length(1)
    disp = DisplayModel(normal_force=0.3, p0=0.0656, flat_length=L, mu_min=0.3, mu_max=0.6)
    with caplog.at_level(logging.WARNING, logger="fingerfriction.predict.render"):
        r = HapticRenderer(pred, disp)
    assert r.n_clipped > 0 and "clipped" in caplog.text
    assert r.mu_cmd.min() >= 0.3 and r.mu_cmd.max() <= 0.6


@pytest.mark.slow
def test_bad_input(renderer, tmp_path):
    with pytest.raises(ValueError, match=r"speed must be a positive number \(mm/s\), got -1"):
        renderer.command_signal(-1, 1000)
    with pytest.raises(ValueError, match=r"rate must be a positive number \(Hz\)"):
        renderer.command_signal(80, 0)
    with pytest.raises(ValueError, match=r"must end in \.wav or \.csv"):
        renderer.write_command(tmp_path / "c.mp3", 80, 1000)
    with pytest.raises(ValueError, match="integer sample rate"):
        renderer.write_command(tmp_path / "c.wav", 80, 1000.5)
    with pytest.raises(ValueError, match=r"DisplayModel.p0 must be > 0"):
        DisplayModel(normal_force=0.3, p0=0.0, flat_length=4.0)
    with pytest.raises(ValueError, match=r"positions must be finite \(mm\); got nan at flat index 1"):
        renderer.query_many([0.0, np.nan])
    with pytest.raises(ValueError, match="sidecar"):
        read_command(tmp_path / "missing.wav")


@pytest.mark.slow
def test_cli_render(tmp_path):
    from typer.testing import CliRunner

    from fingerfriction.cli import app

    pfile = tmp_path / "p.json"
    pfile.write_text(FrictionParams(0.55, 0.0656, 0.1).to_json())
    wav = tmp_path / "cmd.wav"
    r = CliRunner().invoke(app, ["render", "--surface", SPEC, "--subject", "1", "--params", str(pfile),
                                 "--speed", "80", "--rate", "2000", "--out", str(wav), "--step", "0.1",
                                 "--table", str(tmp_path / "t.csv")])
    assert r.exit_code == 0, r.output
    fs, data = wavfile.read(wav)
    assert fs == 2000 and data.size == int(26.0 / 80 * 2000) + 1
    assert (tmp_path / "t.csv").exists() and (tmp_path / "cmd.wav.json").exists()
    bad = CliRunner().invoke(app, ["render", "--surface", SPEC, "--subject", "1", "--params", str(pfile),
                                   "--speed", "0", "--out", str(wav), "--step", "0.1"])
    assert bad.exit_code == 2 and "--speed must be in [0.1, 10000] mm/s" in bad.output
    # without --speed and --rate: those of write_command, recorded in the sidecar
    csv = tmp_path / "cmd.csv"
    r = CliRunner().invoke(app, ["render", "--surface", SPEC, "--subject", "1", "--params", str(pfile),
                                 "--out", str(csv), "--step", "0.1"])
    assert r.exit_code == 0, r.output
    meta = json.loads((tmp_path / "cmd.csv.json").read_text())
    assert (meta["speed_mm_s"], meta["rate_hz"]) == (80.0, 2000.0)
