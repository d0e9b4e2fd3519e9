"""Tests of fingerfriction.model.stats: Table 1 against hand-computed rho, exports, blind-spot table."""

import math

import numpy as np
import pandas as pd
import pytest
from scipy import signal
from scipy import stats as sps

from fingerfriction.fit import FitOptions, TrialFit, fit_trials
from fingerfriction.model.stats import (
    BOTH,
    blind_spot_table,
    bootstrap_correlation_ci,
    correlation_table,
    ensemble_correlation,
    table1_wide,
)
from fingerfriction.study.store import write_table
from fingerfriction.testing import synthetic_trials


def tf(subject, shape, scale, measured, estimate):
    return TrialFit(mu=0.5, p0=0.1, p1=0.2, objective=0.0, objective_name="nmse", method="lstsq",
                    success=True, message="", n_iter=0, n_fev=0, measured=np.asarray(measured, float),
                    estimate=np.asarray(estimate, float), subject=subject,
                    labels={"shape": shape, "scale": scale})


# Hand computation (detrend = subtract the least-squares line over i = 0..3):
#   trial A: f = [1, -1, -1, 1] has no linear part; g = [1, -1, 0, 0] has slope -0.2 and
#            mean 0, so detrended g = [0.7, -1.1, 0.1, 0.3].
#   trial B: f = [0, 2, 2, 0] -> [-1, 1, 1, -1]; g = [-1, 1.5, 2, 0.5] = [-1, 1, 1, -1] + 0.5 i
#            -> [-1, 1, 1, -1].
#   Concatenated (zero mean): sum fg = 2 + 4 = 6, sum f^2 = 8, sum g^2 = 1.8 + 4 = 5.8.
A = ([1, -1, -1, 1], [1, -1, 0, 0])
B = ([0, 2, 2, 0], [-1, 1.5, 2, 0.5])
RHO_A = 2 / math.sqrt(4 * 1.8)
RHO_AB = 6 / math.sqrt(8 * 5.8)


def p_value(r, n):
    t = r * math.sqrt((n - 2) / (1 - r * r))
    return 2 * sps.t.sf(abs(t), n - 2)


def test_ensemble_correlation_hand_computed():
    rho, p, n = ensemble_correlation([A[0]], [A[1]])
    assert rho == pytest.approx(RHO_A, rel=1e-12)
    assert n == 4
    rho, p, n = ensemble_correlation([A[0], B[0]], [A[1], B[1]])
    assert rho == pytest.approx(RHO_AB, rel=1e-12)
    assert p == pytest.approx(p_value(RHO_AB, 8), rel=1e-9)


def test_table1_layout_and_values():
    fits = [
        tf("S1", "Bump", "2 mm", *A),
        tf("S1", "Bump", "2 mm", *B),
        tf("S2", "Bump", "2 mm", *A),
        tf("S2", "Step Up", "4 mm", *B),
        tf("S1", "Step Down", "4 mm", *A),
    ]
    t = correlation_table(fits)
    assert list(t.columns) == ["subject", "scale", "shape", "rho", "rho_lo", "rho_hi", "p", "significant",
                               "n_trials", "n_samples"]
    keys = list(zip(t.subject, t.scale, t["shape"], strict=True))
    assert keys == [
        ("S1", "2 mm", "Bump"), ("S1", "4 mm", "Step Down"),
        ("S2", "2 mm", "Bump"), ("S2", "4 mm", "Step Up"),
        (BOTH, "2 mm", "Bump"), (BOTH, "4 mm", "Step Up"), (BOTH, "4 mm", "Step Down"),
    ]
    row = t.set_index(["subject", "scale", "shape"])
    assert row.loc[("S1", "2 mm", "Bump"), "rho"] == pytest.approx(RHO_AB, rel=1e-12)
    assert row.loc[("S2", "2 mm", "Bump"), "rho"] == pytest.approx(RHO_A, rel=1e-12)
    # Both subjects, 2 mm Bump: A, B (S1) and A (S2): sum fg = 2+4+2, f^2 = 12, g^2 = 7.6
    assert row.loc[(BOTH, "2 mm", "Bump"), "rho"] == pytest.approx(8 / math.sqrt(12 * 7.6), rel=1e-12)
    assert row.loc[(BOTH, "2 mm", "Bump"), "n_trials"] == 3
    # Step Up, S2: B alone is a perfect correlation after detrending.
    assert row.loc[("S2", "4 mm", "Step Up"), "rho"] == pytest.approx(1.0)
    wide = table1_wide(t)
    assert list(wide.index) == ["rho", "p < 0.01"]
    assert wide.shape == (2, 7)


def test_exports_atomic_and_formats(tmp_path):
    t = correlation_table([tf("S1", "Bump", "2 mm", *A), tf("S1", "Bump", "2 mm", *B)])
    for ext in ("csv", "md", "tex"):
        write_table(t, tmp_path / f"table1.{ext}")
    back = pd.read_csv(tmp_path / "table1.csv")
    assert back.loc[0, "rho"] == pytest.approx(RHO_AB, rel=1e-12)
    md = (tmp_path / "table1.md").read_text()
    assert md.startswith("| subject | scale | shape | rho |") and "0.881" in md
    assert "\\begin{tabular}" in (tmp_path / "table1.tex").read_text()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".tmp-")]
    with pytest.raises(ValueError, match=r"table1\.xlsx: unknown table format '\.xlsx'"):
        write_table(t, tmp_path / "table1.xlsx")


def test_bad_input_named():
    with pytest.raises(ValueError, match="equal length, got 1 and 2"):
        ensemble_correlation([A[0]], [A[1], B[1]])
    with pytest.raises(ValueError, match=r"trial 0: measured \(4,\) and estimate \(3,\)"):
        ensemble_correlation([A[0]], [[1, 2, 3]])
    with pytest.raises(ValueError, match="fits is empty"):
        correlation_table([])


def test_blind_spot_table_exact_widths():
    regs = {
        "bump-2mm": [np.array([[[-6.0, -2.0], [np.nan, np.nan]], [[-5.0, -1.5], [0.25, 1.0]]]),
                     np.array([[[-4.0, -1.25]]])],
        "step-up-2mm": [[(-3.0, 0.0)], [(0.0, 2.0)]],
    }
    t = blind_spot_table(regs)
    assert list(t.surface) == ["bump-2mm", "step-up-2mm"]
    assert t.loc[0, "width_mm"] == 1.5 and t.loc[0, "start_mm"] == -1.25
    assert t.loc[1, "width_mm"] == 0.0 and math.isnan(t.loc[1, "start_mm"])


@pytest.mark.slow
def test_end_to_end_synthetic_table1():
    trials, truth = synthetic_trials(surfaces=("bump-2mm", "step-up-4mm"), speeds=(40,), reps=2, seed=1)
    fits = fit_trials(trials, options=FitOptions())
    t = correlation_table(fits)
    assert len(t) == 6  # 2 subjects + both, x 2 conditions
    assert (t.rho > 0.9).all() and t.significant.all()


def test_bootstrap_ci_matches_a_brute_force_resampling():
    """The moment-sum bootstrap equals resampling the trials and concatenating them."""
    rng = np.random.default_rng(3)
    meas, est = [], []
    for _ in range(7):
        g = np.cumsum(rng.normal(size=60))
        meas.append(g + rng.normal(scale=3.0, size=60))
        est.append(g)
    lo, hi = bootstrap_correlation_ci(meas, est, n_boot=300, level=0.9, seed=11)
    idx = np.random.default_rng(11).integers(0, 7, size=(300, 7))
    det = [(signal.detrend(m), signal.detrend(e)) for m, e in zip(meas, est, strict=True)]
    rhos = [np.corrcoef(np.concatenate([det[k][0] for k in row]),
                        np.concatenate([det[k][1] for k in row]))[0, 1] for row in idx]
    assert (lo, hi) == pytest.approx((np.percentile(rhos, 5), np.percentile(rhos, 95)), rel=1e-10)
    rho = ensemble_correlation(meas, est)[0]
    assert lo < rho < hi
    assert math.isnan(bootstrap_correlation_ci(meas[:1], est[:1])[0])  # one trial: no interval
    with pytest.raises(ValueError, match="n_boot must be an integer >= 100, got 5"):
        bootstrap_correlation_ci(meas, est, n_boot=5)
