"""The model variants and the choice among them (fingerfriction.fit.variants, .select,
pipeline.fitting.compare_variants): on small synthetic studies of each true physics,
``--model auto`` picks the variant of that physics; forces no variant explains are refused.

The studies: 2 subjects x 3 surfaces x 3 repetitions whose "video" contact regions are the
forward contact model's (so the leave-one-surface-out prediction from geometry sees the
contact the fit saw: what is tested is the friction law), on a 0.1 mm grid, with the three
worlds' force laws written out here (not the simulator's):

* load-sharing: the contact carries a measured normal force that wanders around 0.3 N
  (the load-consistent Eq. 4 with a pressure rising with height);
* constant-pressure: Eq. (4) as printed with one pressure per trial, and a normal force
  that follows the contact's vertical resultant only partly (a force-control loop);
* interlocking: a normal stress that carries the measured load as one line load over the
  contact (``int q dx = F_N``, not the variants' vertical support), Coulomb friction on it,
  and its horizontal push on slopes asymmetric: twice the elastic push on rising ground, a
  tenth of it on falling ground (the simulator's interlocking world without its
  fluctuations).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from fingerfriction.fit import FitOptions, LoadFitOptions, Trial
from fingerfriction.fit.select import Bars, Evidence, residual_structure, select_model
from fingerfriction.fit.variants import MODELS, SELECTABLE, FitSettings, get, variant_of_params
from fingerfriction.mechanics import SUBJECTS as FINGERS
from fingerfriction.model import FrictionModel, FrictionParams, LoadParams
from fingerfriction.surfaces import get_surface

STEP = 0.1  # mm
SURFACES = ("bump-2mm", "step-up-2mm", "step-down-2mm")
MU = {"1": 0.55, "2": 0.60}
SETTINGS = FitSettings(paper=FitOptions(median_kernel=1), load=LoadFitOptions(median_kernel=1, n_boot=200))


@pytest.fixture(scope="module")
def contact():
    """(surface, finger) -> (x, forward-model regions, FrictionModel)."""
    from fingerfriction.predict import forward_regions

    x = np.round(-13.0 + STEP * np.arange(int(round(26.0 / STEP)) + 1), 9)
    out = {}
    for name in SURFACES:
        s = get_surface(name)
        for subj in MU:
            out[name, subj] = (s, x, forward_regions(s, FINGERS[int(subj)], x), FrictionModel(s))
    return out


def _smooth(rng, n: int, width: int = 60) -> np.ndarray:
    w = np.convolve(rng.standard_normal(n + width), np.hanning(width + 1), "valid")[:n]
    return w / w.std()


def world_trials(contact, world: str, *, seed: int = 0, reps: int = 3) -> list[Trial]:
    """A small study of one world (module notes), forces on the absolute footing with 3 %
    noise on F_T and 1 mN on F_N, mu drawn per trial (3 % SD)."""
    rng = np.random.default_rng(seed)
    trials = []
    for (name, subj), (s, x, reg, fm) in contact.items():
        for r in range(reps):
            mu = MU[subj] * (1 + 0.03 * rng.standard_normal())
            wander = 0.3 + 0.004 * _smooth(rng, x.size)
            if world == "constant-pressure":
                S, K, Q = fm.integrals(reg).T
                L_flat = K[0]  # the finger on flat ground at the window's start
                p0 = 0.3 / L_flat * (1 + 0.1 * rng.standard_normal())
                p1 = 0.08 * (1 + 0.1 * rng.standard_normal())
                F = FrictionModel(s).forces(reg, FrictionParams(mu, p0, p1)).total
                held = p0 * L_flat
                fn = held + 0.3 * (p0 * (K - mu * S) - held)  # follows the resultant by 30 %
            elif world == "interlocking":
                fn = wander
                S, K, _, _, L = fm.region_integrals(reg).sum(axis=1).T
                S_up = fm.region_up(reg).sum(axis=1)[:, 0]
                up, down = 2.0 * (1 + 0.1 * rng.standard_normal()), 0.1
                F = fn * (mu * K + up * S_up + down * (S - S_up)) / L
            else:
                fn = wander
                p1 = 0.05 * (1 + 0.1 * rng.standard_normal())
                F = fm.load_forces(reg, fn, LoadParams(mu, p1, 0.0, 2.0)).total
            F = F + 0.03 * F.std() * rng.standard_normal(x.size)
            fn = fn + 0.001 * rng.standard_normal(x.size)
            labels = {"trial": f"s{subj}-{name}-r{r}", "surface": name, "speed_mm_s": str(40 * (r + 1))}
            trials.append(Trial(x, F - F[:20].mean(), reg, s, subj, labels, force_abs=F, normal_abs=fn))
    return trials


@pytest.mark.slow  # four variants fitted and validated on 18 trials: a few seconds each
@pytest.mark.parametrize(("world", "family"), [("load-sharing", "load"), ("constant-pressure", "pressure"),
                                               ("interlocking", "interlock")])
def test_auto_picks_the_variant_of_the_world(contact, world, family):
    from fingerfriction.pipeline.fitting import compare_variants

    comp = compare_variants(world_trials(contact, world), SETTINGS, forward_step=STEP, n_boot=None)
    sel = comp.selection
    assert not sel.rejected, sel.reason
    assert sel.model == family, sel.reason
    assert get(sel.model).family == world
    table = sel.comparison.set_index("model")
    assert table.loc[family, "passes"] and table.loc[family, "verdict"] == "chosen"
    assert list(table.index) == list(MODELS)
    # every selectable variant measures mu on flat ground, with its confidence interval
    for subj, mu in MU.items():
        sf = comp.fits[family][subj]
        lo, hi = sf.mu_ci
        assert lo < sf.mu < hi and abs(sf.mu / mu - 1) < 0.03
    assert sel.cross_validated and family in sel.reason


@pytest.mark.slow
def test_forces_unrelated_to_the_surface_are_refused(contact):
    from fingerfriction.pipeline.fitting import compare_variants

    trials = world_trials(contact, "load-sharing")
    rng = np.random.default_rng(5)
    noisy = [Trial(t.x, t.force, t.regions, t.surface, t.subject, t.labels,
                   force_abs=t.force_abs[:30].mean() + 0.02 * _smooth(rng, t.n), normal_abs=t.normal_abs)
             for t in trials]
    sel = compare_variants(noisy, SETTINGS, forward_step=STEP, n_boot=None).selection
    assert sel.rejected
    assert sel.reason.startswith("no variant passes the bars (load: ")
    flags = sel.flags()
    assert [(f.level, f.code, f.model) for f in flags] == [("error", "model-rejected", "")]


def _evidence(rho_t1, rho_loso, *, n_bad=0, n=36):
    t1 = pd.DataFrame({"subject": ["1"] * len(rho_t1), "scale": "2 mm",
                       "shape": [f"s{i}" for i in range(len(rho_t1))], "rho": rho_t1})
    loso = pd.DataFrame({"subject": ["1"] * len(rho_loso), "surface": [f"s{i}" for i in range(len(rho_loso))],
                         "rho_out_of_sample": rho_loso, "rho_heldout_params_video": rho_loso})
    return Evidence(table1=t1, loso=loso, n_trials=n, n_unphysical=n_bad)


def test_bars_and_the_one_standard_error_rule():
    good = [0.9, 0.91, 0.88, 0.93, 0.9, 0.92]
    ev = {"load": _evidence(good, good),
          # nearly as good, more complex: the simpler one within one SE is chosen
          "interlock": _evidence(good, [g + 0.003 * (-1) ** i for i, g in enumerate(good)]),
          "pressure": _evidence(good, [0.5] * 6),  # misses the held-out bar
          "paper": _evidence(good, [0.99] * 6)}  # best, but never chosen
    sel = select_model(ev)
    assert sel.model == "load" and not sel.rejected
    assert "within one standard error" in sel.reason or "highest mean" in sel.reason
    # clearly better held out: the more complex variant is chosen
    ev["interlock"] = _evidence(good, [g + 0.05 for g in good])
    assert select_model(ev).model == "interlock"
    # more than 10 % of the trial fits unphysical: that variant fails
    ev["interlock"] = _evidence(good, [g + 0.05 for g in good], n_bad=4)
    sel = select_model(ev)
    assert sel.model == "load" and "4 of 36 trial fits failed or unphysical" in sel.reason
    # 16 of 18 cells: at the bar passes, below fails (here 6 cells: all 6 needed for Table 1)
    assert Bars.needed(16 / 18, 18) == 16 and Bars.needed(15 / 18, 18) == 15 and Bars.needed(16 / 18, 6) == 6
    ev = {"load": _evidence([0.9] * 5 + [0.7], good), "interlock": _evidence(good, [0.69] * 6)}
    sel = select_model(ev)
    assert sel.rejected and "Table 1 rho >= 0.75 in 5 of 6 cells (bar 6)" in sel.reason
    assert "leave-one-surface-out rho >= 0.7 in 0 of 6 cells (bar 5)" in sel.reason
    with pytest.raises(ValueError, match="Bars.max_unphysical must be a share"):
        Bars(max_unphysical=1.5)
    with pytest.raises(ValueError, match="evidence is empty"):
        select_model({})


def test_the_held_out_bar_is_on_the_forward_contact_with_the_measured_load():
    """A held-out surface whose force is mostly the participant's load wander: the nominal
    load misses it whatever the law; the bar reads the prediction with the measured load,
    and a variant without one (NaN there) is read at the nominal load."""
    from fingerfriction.fit.select import CV_COLUMN, NOMINAL_COLUMN, bar_values

    good = [0.9, 0.91, 0.88, 0.93, 0.9, 0.92]
    ev = _evidence(good, good)
    loso = ev.loso.assign(**{NOMINAL_COLUMN: [0.9, 0.91, 0.3, 0.93, 0.9, 0.2], CV_COLUMN: good})
    sel = select_model({"load": Evidence(table1=ev.table1, loso=loso, n_trials=36, n_unphysical=0)})
    row = sel.comparison.set_index("model").loc["load"]
    assert not sel.rejected and row["loso_cells_ok"] == 6 and row["loso_nominal_cells_ok"] == 4
    np.testing.assert_allclose(bar_values(loso.assign(**{CV_COLUMN: [np.nan] * 6})), loso[NOMINAL_COLUMN])
    sel = select_model({"load": Evidence(table1=ev.table1, loso=loso.assign(**{CV_COLUMN: [np.nan] * 6}),
                                         n_trials=36, n_unphysical=0)})
    assert sel.rejected and "leave-one-surface-out rho >= 0.7 in 4 of 6 cells (bar 5)" in sel.reason


def test_without_validation_the_choice_rests_on_table1_and_says_so():
    good = [0.9, 0.91, 0.88]
    ev = {m: Evidence(table1=_evidence(good, good).table1, loso=None, n_trials=10, n_unphysical=0)
          for m in ("load", "pressure")}
    sel = select_model(ev)
    assert not sel.cross_validated and "not cross-validated" in sel.reason and sel.model == "load"


def test_residual_structure_tells_a_missing_term_from_noise():
    rng = np.random.default_rng(0)
    x = np.linspace(0, 10, 500)
    signal = np.sin(x)
    xs, meas, noise_res, sys_res = [], [], [], []
    for _ in range(5):
        m = signal + 0.1 * rng.standard_normal(x.size)
        xs.append(x)
        meas.append(m)
        noise_res.append(0.1 * rng.standard_normal(x.size))
        sys_res.append(0.5 * signal + 0.1 * rng.standard_normal(x.size))
    groups = ["a"] * 5
    assert abs(residual_structure(xs, meas, noise_res, groups)) < 0.01
    # var(0.5 sin x) / var(sin x + noise) over whole periods: 0.125 / 0.51
    assert residual_structure(xs, meas, sys_res, groups) == pytest.approx(0.125 / 0.51, rel=0.1)
    assert math.isnan(residual_structure(xs[:1], meas[:1], noise_res[:1], ["a"]))


def test_registry():
    assert set(SELECTABLE) == {"load", "pressure", "interlock"} and "paper" in MODELS
    assert variant_of_params(LoadParams(0.5, 0.1)).name == "load"
    assert variant_of_params(LoadParams(0.5, 0.0, push_up=2.0, push_down=0.1)).name == "interlock"
    assert variant_of_params(FrictionParams(0.5, 0.1, 0.1)).name == "paper"
    with pytest.raises(ValueError, match="model must be one of"):
        get("hertz")
    for name in MODELS:
        v = get(name)
        assert v.title and v.note and v.family and v.footing


def test_the_slope_push_split_by_slope_direction_on_a_known_geometry():
    """The interlock law on one region over the whole 2 mm bump (kappa 0, no inset):
    ``F_T = F_N (mu K + u S_up + d S_down) / (K - mu S)``, with the integrals of the bump's
    profile taken here by adaptive quadrature; a step up has no descending part, a step down
    no ascending one; both weights 1 is the load variant with p1 = 0."""
    from scipy.integrate import quad

    mu, u, d, fn = 0.55, 2.0, 0.1, 0.3
    s = get_surface("bump-2mm")
    a, b = s.feature_extent
    mid = 0.5 * (a + b)  # the bump's top: rising before, falling after

    def integral(f, lo, hi):
        return quad(lambda x: f(float(s.dhdx(np.array([x]))[0])), lo, hi, limit=200, points=[a, mid, b])[0]

    sin = lambda t: t / math.sqrt(1 + t * t)  # noqa: E731
    cos = lambda t: 1 / math.sqrt(1 + t * t)  # noqa: E731
    S_up, S_down = integral(sin, a - 1, mid), integral(sin, mid, b + 1)
    K = integral(cos, a - 1, b + 1)
    assert S_up > 0.1 and S_down == pytest.approx(-S_up, rel=1e-6)
    expected = fn * (mu * K + u * S_up + d * S_down) / (K - mu * (S_up + S_down))
    fm = FrictionModel(s)
    reg = np.array([[[a - 1, b + 1]]])
    got = fm.load_forces(reg, fn, LoadParams(mu, 0.0, push_up=u, push_down=d))
    assert float(got.total[0]) == pytest.approx(expected, rel=1e-6)
    assert float(got.deformation[0]) == 0.0
    # equal weights of 1: Eq. (2) as the load variant has it
    same = fm.load_forces(reg, fn, LoadParams(mu, 0.0, push_up=1.0, push_down=1.0)).total
    np.testing.assert_allclose(same, fm.load_forces(reg, fn, LoadParams(mu, 0.0)).total, rtol=1e-9)
    for name in ("step-up-4mm", "step-down-2mm"):
        fm = FrictionModel(get_surface(name))
        lo, hi = get_surface(name).feature_extent
        reg = np.array([[[lo - 1, hi + 1]], [[lo - 1, 0.5 * (lo + hi)]], [[lo + 0.3, np.nan]]])
        reg[2, 0, 1] = hi + 2
        U = fm.region_up(reg, inset=0.1)
        S = fm.region_integrals(reg, inset=0.1)[..., 0]
        if name.startswith("step-up"):
            np.testing.assert_allclose(U[..., 0], S, atol=1e-7)
        else:
            np.testing.assert_allclose(U, 0, atol=1e-7)
    text = LoadParams(0.5, 0.0, push_up=1.5, push_down=-0.02).to_json()
    assert LoadParams.from_json(text).push_down == -0.02 and '"model": "interlock"' in text
    assert "push_up" not in LoadParams(0.5, 0.1).to_json()
    with pytest.raises(ValueError, match="push_up and push_down must be given together"):
        LoadParams(0.5, 0.1, push_up=1.0)


def test_the_interlock_fit_recovers_its_weights_per_trial():
    """Forces of the interlock law itself (1 % noise) on four surfaces: each trial's weights
    come back where the trial has that slope direction (NaN where it has none), and the
    contact's pressure rise with height too."""
    from fingerfriction.fit.load import fit_load_subject
    from fingerfriction.predict import forward_regions

    rng = np.random.default_rng(0)
    x = np.round(-13.0 + STEP * np.arange(int(round(26.0 / STEP)) + 1), 9)
    trials, truth = [], {}
    for name in ("bump-2mm", "step-up-2mm", "step-down-2mm", "bump-4mm"):
        s = get_surface(name)
        reg, fm = forward_regions(s, FINGERS[1], x), FrictionModel(s)
        for r in range(2):
            fn = 0.3 + 0.01 * np.sin(x / 3 + r)
            up, down = 2.0 + 0.2 * r, 0.1 - 0.2 * r
            F = fm.load_forces(reg, fn, LoadParams(0.55, 0.0, 0.0, 2.0, push_up=up, push_down=down)).total
            F = F + 0.01 * F.std() * rng.standard_normal(x.size)
            tid = f"s1-{name}-r{r}"
            truth[tid] = (up if not name.startswith("step-down") else math.nan,
                          down if not name.startswith("step-up") else math.nan)
            trials.append(Trial(x, F - F[:20].mean(), reg, s, "1", {"trial": tid, "surface": name},
                                force_abs=F, normal_abs=fn))
    fit = fit_load_subject(trials, LoadFitOptions(median_kernel=1, n_boot=200, inset=0.0), law="push",
                           name="interlock")
    assert fit.success and fit.model == "interlock" and fit.kappa == pytest.approx(2.0, abs=0.1)
    for tf in fit.trials:
        up, down = truth[tf.labels["trial"]]
        for got, want in ((tf.push_up, up), (tf.push_down, down)):
            assert (math.isnan(got) and math.isnan(want)) or got == pytest.approx(want, abs=0.02)
        assert tf.p1 == 0.0 and np.all(tf.deformation[tf.used] == 0)
    # a trial whose descending weight is negative is not flagged: either sign is physical there
    assert not any(f.code.startswith("negative") for f in fit.flags)


@pytest.mark.slow
def test_the_constant_pressure_variant_leaves_out_where_the_camera_cut_the_contact(contact):
    """Near the window's ends the camera's field cuts the flat-ground contact: the regions
    seen are shorter than the contact that makes the force. The constant-pressure law (in
    the contact's length) measures p0 where the whole contact is seen."""
    from fingerfriction.fit.pressure import fit_pressure_subject

    s, x, reg, fm = contact["step-up-2mm", "1"]
    mu, p0, p1 = 0.55, 0.025, 0.08
    F = fm.forces(reg, FrictionParams(mu, p0, p1)).total
    fn = np.full(x.size, p0 * fm.integrals(reg)[0, 1])  # the flat contact's load, held
    edge = -14.0  # the camera's left edge (mm): the contact at the window's start runs past it
    cut = reg.copy()
    cut[..., 0] = np.where(np.isfinite(cut[..., 0]), np.maximum(cut[..., 0], edge), np.nan)
    clipped = np.any(reg[..., 0] < edge, axis=1)
    assert 0.05 < clipped.mean() < 0.4
    opts = LoadFitOptions(median_kernel=1, n_boot=200, transient=False)
    trials = [Trial(x, F, cut, s, "1", {"trial": f"t{k}"}, force_abs=F, normal_abs=fn,
                    clipped=clipped if k < 3 else None) for k in range(6)]
    with_flag = fit_pressure_subject(trials[:3], opts)
    without = fit_pressure_subject(trials[3:], opts)
    assert with_flag.trials[0].p0_mean == pytest.approx(p0, rel=1e-3)
    assert without.trials[0].p0_mean > 1.05 * p0  # the cut contact read as a higher pressure
    assert "clipped-left-out" in {f.code for f in with_flag.trials[0].flags}
    assert not with_flag.trials[0].used[clipped].any()


def test_newey_west_covariance_of_one_column_is_the_standard_error_squared():
    from fingerfriction.fit.weights import column_weights, hac_cov, hac_se

    rng = np.random.default_rng(1)
    b = rng.standard_normal(400)
    e = np.convolve(rng.standard_normal(420), np.ones(21) / 21, "valid")  # autocorrelated
    assert math.sqrt(hac_cov(b[:, None], e, 15)[0, 0]) == pytest.approx(hac_se(b, e, 15), rel=1e-9)
    # a column too small to pin its weight gets 0 and is said to be unidentified
    X = np.column_stack([b, 1e-9 * b])
    p, ok = column_weights(X, 2.0 * b)
    assert ok.tolist() == [True, False] and p == pytest.approx([2.0, 0.0])


def test_with_two_surfaces_the_default_is_used_and_the_held_out_bars_do_not_apply():
    """Leaving one of two surfaces out predicts it from a single other feature shape: no
    comparison out of sample. The default variant is used when it passes in sample, and a
    held-out rho that misses its bar does not reject it."""
    from fingerfriction.fit.select import DEFAULT_MODEL, MIN_CV_SURFACES

    good, poor = [0.95, 0.96], [0.2, 0.3]
    ev = {m: _evidence(good, poor) for m in ("load", "pressure", "interlock")}
    ev["interlock"] = _evidence([0.99, 0.99], poor)  # fits better in sample (more free weights)
    sel = select_model(ev)
    assert MIN_CV_SURFACES == 3 and DEFAULT_MODEL == "load"
    assert sel.model == "load" and not sel.rejected and not sel.cross_validated
    assert sel.reason.startswith("load (Load-consistent Eq. 4): passes every bar (0 of 36 trial fits "
                                 "unphysical, Table 1 rho >= 0.75 in 2 of 2 cells); not cross-validated: "
                                 "too few surfaces to compare the variants out of sample (2 held out per "
                                 "subject; the comparison needs 3")
    assert "and it is the default variant" in sel.reason
    # the default unphysical in sample: another passing variant, said so; none: rejected
    ev["load"] = _evidence(good, poor, n_bad=10)
    sel = select_model(ev)
    assert sel.model in ("pressure", "interlock") and "; not cross-validated: too few surfaces" in sel.reason
    ev = {m: _evidence(good, poor, n_bad=10) for m in ("load", "pressure")}
    sel = select_model(ev)
    assert sel.rejected and "no variant passes the bars (load: 10 of 36 trial fits" in sel.reason
