"""Worlds the model was not built on: simulate -> analyze -> fit (``--model auto``) ->
validate, in every world of the simulator, and judge each outcome against the truth.

For each world (``load-sharing``, ``constant-pressure``, ``interlocking``; the realistic
measurement chain, which the analysis does not invert exactly) and seed it prints:

* the variant ``fit --model auto`` chose and why (or that it rejected every one);
* mu per subject against the realised mean of the trials' drawn ``mu_trial``
  (``truth/<trial>.npz``), its error and whether the 95 % CI covers it; and against that
  mean as the sensor records it: the lab's crosstalk calibration is off by about 10 %, so
  0.2-0.5 % of crosstalk reaches the files and moves the flat-ground F_T / F_N by up to
  about 2 % (``docs/worlds.md``), a systematic error of the instrument that no analysis of
  its recordings can undo, nor put in a statistical interval (the truth records the
  matrices);
* Table 1 and the leave-one-surface-out rho of every variant, cell by cell;
* the study-level flags;
* the outcome: **Correct** (mu within 2 % of the realised mean, with the CI covering that
  mean as the sensor records it (the raw mean's coverage is printed beside it),
  Table 1 rho >= 0.75 in at least 16 of 18 cells and leave-one-surface-out rho >= 0.70
  in at least 15 of 18, for the variant used), **Refused** (the study-level error
  ``model-rejected``), or **WRONG** (neither: a result without that error that misses
  these figures). In load-sharing and constant-pressure the outcome must be Correct with
  the world's own family chosen (the benchmark says so when it is not).

The held-out rho has two readings, both printed: the held-out surface predicted from its
geometry with the trials' measured normal force (the bar of ``fit --model auto``,
``fit.select.CV_COLUMN``, and the outcome's), and from its geometry alone at the nominal
load (``fit.select.NOMINAL_COLUMN``; the outcome under it is printed beside). The second
is not a test of a friction law: the participant's normal force follows the relief by a
few tens of mN, which no law can predict from the surface, and where a surface's friction
signal is small (Step Down in the interlocking world) that is most of what is measured;
the exact law fails it on synthetic data (``docs/fit.md``).

The study: the paper's design with three repetitions per condition, 2 subjects x 6
surfaces x 3 speeds x 3 = 108 trials (every cell of Table 1 holds 9 trials per subject,
18 pooled; every held-out surface 18 trials), simulated with ``--chain realistic`` into
``benchmarks/out/studies/worlds-WORLD-seedS-repsN`` (gitignored; reused by later runs)
and analysed with the second-order sensor model the realistic chain needs. Why 108: at
one repetition (36 trials) the constant-pressure world's flat-ground F_T / F_N scatters
so much from trial to trial (the participant's force-control loop wanders, and the
interfacial force does not follow it) that 18 trials a subject put the 2 % bar at one to
two standard errors (``docs/worlds.md``, with what a run costs).

Run: ``.venv/bin/python benchmarks/worlds.py`` (every world, the default seeds), or
``--world interlocking --seed 7`` (repeatable; ``--reps 1`` for 36 trials per study).
The default seeds are drawn, not chosen: the first three of
``numpy.random.default_rng(20).integers(1, 10_000, 3)``. Seed-major order: every world's
first seed comes before any world's second.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _studies import simulated_study  # noqa: E402
from fingerfriction.fit.select import CV_COLUMN, NOMINAL_COLUMN, bar_values  # noqa: E402
from fingerfriction.fit.variants import MODELS, get  # noqa: E402
from fingerfriction.model.stats import BOTH  # noqa: E402
from fingerfriction.pipeline.analyze import analyze  # noqa: E402
from fingerfriction.pipeline.fitting import fit  # noqa: E402
from fingerfriction.pipeline.params import AnalysisParams, sim_params  # noqa: E402

WORLDS = ("load-sharing", "constant-pressure", "interlocking")
#: The world whose own family must be chosen (``None``: a refusal with its reason is
#: acceptable, a variant that represents it is better).
MUST_BE_CORRECT = {"load-sharing": True, "constant-pressure": True, "interlocking": False}
DEFAULT_SEEDS = tuple(int(s) for s in np.random.default_rng(20).integers(1, 10_000, 3))
REPS = 3
MU_TOL = 0.02


def through_sensor(mu: float, crosstalk, calibration) -> float:
    """The flat-ground ratio F_T / F_N that a sensor with the crosstalk matrix ``crosstalk``
    (on the transducers' forces, ``sim.sensor``) records for a true ``mu`` after the lab's
    ``calibration`` (its inverse applied to the channels; None: uncalibrated). What is left
    of the crosstalk is not in the files' information: no analysis can undo it."""
    E = np.asarray(crosstalk, float)
    if calibration is not None:
        E = np.linalg.solve(np.asarray(calibration, float), E)
    f1, f2 = E @ np.array([1.0 + mu, 1.0 - mu])  # F_N = 1, F_T = mu on the transducers (x sqrt 2)
    return float((f1 - f2) / (f1 + f2))


def trial_truth(study: Path) -> dict[str, tuple[float, float]]:
    """Per trial id, its drawn ``mu_trial`` (truth files) and the same seen through the
    sensor (:func:`through_sensor`; equal with the ideal chain)."""
    out = {}
    for p in sorted((study / "truth").glob("*.npz")):
        with np.load(p, allow_pickle=False) as z:  # our own simulator's output
            if "mu_trial" in z.files:
                mu = float(z["mu_trial"])
                seen = mu
                if "sensor_crosstalk" in z.files:
                    cal = z["sensor_calibration"] if "sensor_calibration" in z.files else None
                    seen = through_sensor(mu, z["sensor_crosstalk"], cal)
                out[p.stem] = (mu, seen)
    return out


def realised_mu(study: Path) -> tuple[dict[str, float], dict[str, float]]:
    """Per subject, the mean of the trials' drawn friction coefficients and the same mean
    seen through the sensor (:func:`trial_truth`)."""
    by: dict[str, list[tuple[float, float]]] = {}
    for tid, v in trial_truth(study).items():
        by.setdefault(tid.split("-")[0].lstrip("s"), []).append(v)
    return ({s: float(np.mean([a for a, _ in v])) for s, v in by.items()},
            {s: float(np.mean([b for _, b in v])) for s, v in by.items()})


def crosstalk(study: Path) -> str:
    """The realistic chain's crosstalk matrix, as the truth records it ('' otherwise)."""
    import json

    try:
        head = json.loads((study / "truth" / "study.json").read_text())
        c = ((head.get("chain") or {}).get("device") or {}).get("crosstalk")
        return f"sensor crosstalk {np.round(np.asarray(c, float), 4).tolist()}" if c is not None else ""
    except (OSError, ValueError):
        return ""


def analysed(study: Path) -> Path:
    """The study analysed as a simulated one, with the second-order sensor model (the
    realistic chain's two-pole high-pass is not the first-order one the default inverts)."""
    results = study.with_name(study.name + "-results")
    opts = sim_params()
    opts["forces"] = {**opts["forces"], "highpass_model": "second-order"}
    analyze(study, results, params=AnalysisParams(**opts), progress=False)
    return results


def cells_ok(values, bar: float) -> int:
    v = np.asarray(values, dtype=float)
    return int(np.sum(np.isfinite(v) & (v >= bar)))


def print_rho_tables(summary) -> None:
    t1 = summary.table1.pivot_table(index=["subject", "scale", "shape"], columns="model", values="rho",
                                    sort=False)[list(MODELS)]
    print("  Table 1 rho (in sample), every variant:")
    print("    " + t1.round(3).to_string().replace("\n", "\n    "))
    if summary.loso is None:
        print(f"  leave one surface out: not computed ({summary.loso_message})")
        return
    lo = summary.loso.pivot_table(index=["subject", "surface"], columns="model", values=NOMINAL_COLUMN,
                                  sort=False)[list(MODELS)]
    print("  leave-one-surface-out rho (held-out surface predicted from its geometry alone, nominal load), "
          "every variant:")
    print("    " + lo.round(3).to_string().replace("\n", "\n    "))
    absolute = [m for m in MODELS if get(m).footing.startswith("absolute")]
    ml = summary.loso.pivot_table(index=["subject", "surface"], columns="model",
                                  values=CV_COLUMN, sort=False)[absolute]
    print("  leave-one-surface-out rho from its geometry and the trial's measured normal force (the bar's "
          "reading), every variant on the absolute footing:")
    print("    " + ml.round(3).to_string().replace("\n", "\n    "))
    own = summary.loso.pivot_table(index=["subject", "surface"], columns="model",
                                   values="rho_heldout_params_video", sort=False)[list(MODELS)]
    own = own[[i[0] != BOTH for i in own.index]]
    print("  held-out rho on the trials' own contact and load (what the choice compares), mean per variant: "
          + ", ".join(f"{m} {own[m].mean():.3f}" for m in MODELS))


def judge(world: str, seed: int, summary, truth: tuple[dict, dict]) -> str:
    """Print the verdict lines; return 'Correct', 'Refused' or 'WRONG'.

    ``truth``: per subject the realised mean of the trials' mu, and the same seen through
    the sensor's residual crosstalk (:func:`realised_mu`). mu must be within 2 % of the
    first; the 95 % CI (a statistical interval over trials) is judged on the second, the
    truth the files hold, and its coverage of the first is printed beside it: a systematic
    error of the sensor's calibration is in no interval computed from its recordings."""
    raw, seen = truth
    used = summary.model
    t1 = summary.table1[summary.table1["model"] == used]
    lo = summary.loso[summary.loso["model"] == used] if summary.loso is not None else None
    n1, n1_ok = len(t1), cells_ok(t1["rho"], 0.75)
    nl, nl_ok = (len(lo), cells_ok(bar_values(lo), 0.70)) if lo is not None else (0, 0)
    nn_ok = cells_ok(lo[NOMINAL_COLUMN], 0.70) if lo is not None else 0
    mu_ok, literal_ok, recorded_ok = True, True, True
    for s in sorted(summary.mu):
        mu, (a, b) = summary.mu[s], summary.mu_ci[s]
        t, ts = raw.get(s, math.nan), seen.get(s, math.nan)
        err, err_s = mu / t - 1, mu / ts - 1
        cover, cover_s = a <= t <= b, a <= ts <= b
        mu_ok &= abs(err) <= MU_TOL and cover_s
        literal_ok &= cover
        recorded_ok &= abs(err_s) <= MU_TOL and cover_s
        print(f"  subject {s}: mu = {mu:.5f}, 95 % CI [{a:.5f}, {b:.5f}]; realised mean of the trials' mu "
              f"{t:.5f}; error {100 * err:+.2f} % (target 2 %), CI covers it: {'yes' if cover else 'NO'}")
        print(f"    through the sensor's residual crosstalk (after the lab's calibration) that mean reads "
              f"{ts:.5f} ({100 * (ts / t - 1):+.2f} %, no analysis can undo it); error against it "
              f"{100 * err_s:+.2f} %, CI covers it: {'yes' if cover_s else 'NO'}")
    t1_ok = n1_ok >= math.ceil(16 / 18 * n1 - 1e-9)
    lo_ok = lo is not None and nl_ok >= math.ceil(15 / 18 * nl - 1e-9)
    nominal_ok = lo is not None and nn_ok >= math.ceil(15 / 18 * nl - 1e-9)
    print(f"  {used}: Table 1 rho >= 0.75 in {n1_ok} of {n1} cells; leave-one-surface-out rho >= 0.70 in "
          f"{nl_ok} of {nl} from geometry with the measured normal force (the bar's reading), {nn_ok} of "
          f"{nl} from geometry alone at the nominal load")
    flags = [f for f in summary.flags if not f.trial]
    print("  study-level flags: " + ("; ".join(f"{f.level} {f.code}" + (f" (subject {f.subject})" if f.subject
                                                                         else "") for f in flags) or "none"))
    def verdict(held_out_ok: bool, mu_fine: bool = mu_ok) -> str:
        if summary.rejected:
            return "Refused"
        return "Correct" if mu_fine and t1_ok and held_out_ok else "WRONG"

    outcome = verdict(lo_ok)
    if outcome == "Correct" and not literal_ok:
        outcome += " (CI covers the mean as recorded, not the raw one)"
    if outcome == "WRONG" and verdict(lo_ok, recorded_ok) == "Correct":
        # both readings printed: the 2 % is of the raw mean, which the instrument's
        # own residual crosstalk moves by up to about 2 % before any analysis
        outcome += " (against the mean as recorded: Correct, within 2 % and covered)"
    if verdict(nominal_ok) != verdict(lo_ok):
        outcome += f" [at the nominal load: {verdict(nominal_ok)}, held out {nn_ok} of {nl}]"
    family_ok = get(used).family == world
    note = ""
    if MUST_BE_CORRECT[world] and not (outcome.startswith("Correct") and family_ok):
        note = f" (NOT MET: this world needs Correct with its own family, {world})"
    elif outcome.startswith("Correct") and not family_ok:
        note = f" (correct figures, but the variant chosen is of the {get(used).family} family)"
    print(f"  OUTCOME {world} seed {seed}: {outcome}, {used} ({get(used).family}){note}")
    return outcome if not note.startswith(" (NOT MET") else outcome + " (not met)"


def run(world: str, seed: int, reps: int = REPS) -> str:
    name = f"worlds-{world}-seed{seed}-reps{reps}"
    t0 = time.perf_counter()
    study = simulated_study(name, "--world", world, "--chain", "realistic", "--seed", str(seed),
                            "--reps", str(reps))
    t_sim = time.perf_counter() - t0
    t0 = time.perf_counter()
    results = analysed(study)
    t_an = time.perf_counter() - t0
    t0, c0 = time.perf_counter(), time.process_time()
    summary = fit(results, progress=False)
    t_fit, c_fit = time.perf_counter() - t0, time.process_time() - c0
    print(f"\n=== world {world}, seed {seed}: {summary.n_trials} trials ({study}); simulate {t_sim:.0f} s, "
          f"analyze {t_an:.0f} s, fit and validation {t_fit:.0f} s ({c_fit:.0f} s CPU)")
    x = crosstalk(study)
    if x:
        print(f"  {x}")
    rejected = " -- MODEL REJECTED" if summary.rejected else ""
    print(f"  chosen: {summary.model} ({get(summary.model).title}){rejected}")
    print(f"  why: {summary.selection.reason}")
    comp = summary.selection.comparison
    cols = ["model", "family", "n_unphysical", "table1_cells_ok", "loso_cells_ok", "loso_nominal_cells_ok",
            "cv_rho_mean", "residual_structure", "verdict"]
    print("    " + comp[cols].round(3).to_string(index=False).replace("\n", "\n    "))
    print_rho_tables(summary)
    return judge(world, seed, summary, realised_mu(study))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--world", action="append", choices=WORLDS, help="a world (repeatable; default: all)")
    ap.add_argument("--seed", action="append", type=int, help="a seed (repeatable; default: the drawn set)")
    ap.add_argument("--reps", type=int, default=REPS,
                    help=f"repetitions per condition (default {REPS}: {36 * REPS} trials; the paper's: 5)")
    args = ap.parse_args(argv)
    worlds = args.world or list(WORLDS)
    seeds = args.seed or list(DEFAULT_SEEDS)
    print(f"worlds {worlds}, seeds {seeds}" + ("" if args.seed else " (drawn: default_rng(20).integers(1, "
                                                                    "10_000, 3))")
          + f"; {args.reps} repetition(s) per condition ({36 * args.reps} trials per study)")
    outcomes = {}
    for s in seeds:
        for w in worlds:
            outcomes[w, s] = run(w, s, args.reps)
    print("\nsummary")
    print(pd.Series({f"{w} seed {s}": o for (w, s), o in outcomes.items()}).to_string())
    bad = [k for k, o in outcomes.items() if o.startswith("WRONG") or o.endswith("(not met)")]
    print("every outcome Correct or Refused, and Correct in load-sharing and constant-pressure: "
          + ("PASS" if not bad else f"FAIL ({bad})"))
    return 0 if not bad else 1


if __name__ == "__main__":
    sys.exit(main())
