"""Finger calibration from recordings: recovery, blind spots, CPU time.

From one run:

A. **Unknown fingers.** A virtual study of 2 subjects whose fingers are drawn around the
   calibrated defaults (``fingerfriction simulate --finger-seed S``: radius, modulus and
   flat length within +-25 %; seed printed), 6 surfaces x 3 speeds x 2 repetitions,
   simulated with ``fingerfriction simulate`` and analysed with ``fingerfriction analyze``
   (both resume, so a re-run reuses the folders). Each subject's finger is calibrated
   from the results folder, starting from the default finger of its label, and compared
   with the simulator's true finger (target: within 5 %); its predicted blind spots (the
   calibrated model at the frames' positions and forces) beside the measured ones (union
   of the video's regions; target: within 0.05 mm on every surface); the CPU time of one
   subject's calibration (target: under 5 min) and where it goes.
B. **Where the time goes.** Per stage and per pass; one fine-level evaluation (all the
   BEM sweeps of one parameter set) with each warm start, against cold starts.
C. **The paper's fingers come back.** The seed-0 study (the paper's design, simulated and
   analysed into ``benchmarks/out/studies/`` the first time, shared with other benchmarks):
   each subject calibrated starting from the *other* subject's
   default finger (about 20 % away), compared with its true (default) finger.
D. **Predictions that transfer.** On the study of A (after ``fingerfriction fit``):
   leave-one-surface-out with each subject's finger calibrated on the other five surfaces
   (12 calibrations), beside the same validation with the default finger of its label;
   rho per held-out surface (target: >= 0.75 with the calibrated finger, for the default,
   load-consistent model; the paper's model is printed for information).

Run: ``.venv/bin/python benchmarks/calibrate.py [--study DIR] [--finger-seed 1]
[--full-results DIR] [--workers 2]`` (about 20 min the first time: the simulation and
analysis of the 72-trial study; a few minutes after).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from _studies import STUDIES, analysed_study, simulated_study
from fingerfriction.mechanics import SUBJECTS
from fingerfriction.mechanics._calibration_problem import CalibrationProblem
from fingerfriction.mechanics.calibrate import CalibrationOptions
from fingerfriction.mechanics.finger_file import finger_from_mapping
from fingerfriction.model.stats import BOTH
from fingerfriction.pipeline.finger_calibration import (
    calibrate_held_out,
    calibrate_results,
    trials_from_results,
)
from fingerfriction.pipeline.validation import validate_results
from fingerfriction.sim.fingers import DRAWN_FIELDS, relative_difference

TARGET_PARAM = 0.05
TARGET_BS_MM = 0.05
TARGET_CPU_S = 300.0


def run(cmd: list[str]) -> None:
    print("$ " + " ".join(cmd), flush=True)
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        print(r.stdout[-2000:], r.stderr[-2000:])
        raise SystemExit(f"command failed ({r.returncode}): {' '.join(cmd)}")
    last = [ln for ln in r.stdout.splitlines() if ln.strip()][-1:] or [""]
    print(f"  {last[0].strip()[:150]}  [{time.perf_counter() - t0:.0f} s wall]", flush=True)


def verdict(ok: bool) -> str:
    return "PASS" if ok else "FAIL"


def report_calibration(res, true, label: str) -> tuple[bool, bool]:
    """Print one subject's calibration; returns (parameters within target, blind spots within target)."""
    print(f"\n  subject {label}: {res.message}; {res.n_trials} trials, {res.n_frames} frames, "
          f"median F_N {res.load_median:.3f} N -> P' = {res.load_per_width:.4f} N/mm "
          f"(D = {res.finger.width:g} mm fixed)")
    for f in res.flags:
        print(f"    flag: {f}")
    print(f"    {'parameter':12s} {'start':>9s} {'calibrated':>11s} {'true':>9s} {'error':>8s} "
          f"{'boot std':>9s} {'+0.5px ends':>11s}")
    ok_p = res.success
    for f in res.fitted:
        v, t, s0 = getattr(res.finger, f), getattr(true, f), getattr(res.initial, f)
        err = v / t - 1
        ok_p &= abs(err) <= TARGET_PARAM
        print(f"    {f:12s} {s0:9.4f} {v:11.4f} {t:9.4f} {100 * err:+7.2f}% {res.std[f]:9.4f} "
              f"{res.systematic[f]:+11.4f}")
    print(f"    parameters within {100 * TARGET_PARAM:.0f} % of the truth: {verdict(ok_p)}")
    head = "blind spots measured -> predicted (mm)"
    print(f"    {'surface':14s} {'frames':>6s} {'end rms':>8s} {head:40s} {'max |diff|':>10s}")
    ok_b = True
    for s in res.surfaces:
        pairs = s.blind_spot_pairs()
        diffs = [abs(m - p) for m, p in pairs]
        worst = max(diffs) if diffs else 0.0
        ok_b &= bool(np.all(np.isfinite(diffs))) and worst <= TARGET_BS_MM
        txt = ", ".join(f"{m:.3f} -> {p:.3f}" for m, p in pairs) or "none -> none"
        print(f"    {s.surface:14s} {s.n_frames:6d} {s.rms_end_mm:8.4f} {txt:40s} {worst:10.3f}")
    print(f"    predicted blind spots within {TARGET_BS_MM} mm of the measured ones on every surface: "
          f"{verdict(ok_b)}")
    return ok_p, ok_b


def where_time_goes(res) -> None:
    t = res.timings
    print(f"    CPU {t['total']:.1f} s: coarse pass {t['coarse_pass']:.1f} s ({res.nfev['coarse']} "
          f"evaluations), fine pass {t['fine_pass']:.1f} s ({res.nfev['fine']}), BEM sweeps {t['bem']:.1f} s "
          f"({100 * t['bem'] / t['total']:.0f} %), residuals {t['residuals']:.1f} s, bootstrap "
          f"{t['bootstrap']:.2f} s, blind spots {t['predict']:.2f} s")
    n = max(res.n_solves, 1)
    print(f"    {res.n_solves} BEM solves, {res.cg_iterations / n:.1f} CG iterations per solve, "
          f"{1e3 * t['bem'] / n:.3f} ms CPU per solve")


def warm_start_table(results: str, subject: str, finger) -> None:
    """One fine-level evaluation (every BEM sweep of one parameter set) per warm start."""
    trials, _ = trials_from_results(results, subject)
    print(f"    one fine-level evaluation at the calibrated finger of subject {subject} "
          "(6 surfaces x 3 loads, 0.05 mm steps), then a 0.5 % step in each parameter:")
    base = None
    for mode in ("none", "positions", "parameters"):
        opts = CalibrationOptions(warm_start=mode)
        pb = CalibrationProblem(trials, finger, opts)
        z = np.zeros(len(opts.fit))
        pb.tables(z, "fine", opts.fine_step)  # the base sweep (cold or position-started)
        n0, it0, t0 = pb.n_solves, pb.cg_iterations, pb.t_bem
        for k in range(z.size):
            zk = z.copy()
            zk[k] += opts.diff_step
            pb.tables(zk, "fine", opts.fine_step, perturbed=True)
        n1, it1, t1 = pb.n_solves - n0, pb.cg_iterations - it0, pb.t_bem - t0
        if base is None:
            base = t1
        print(f"      {mode:10s} base {t0:6.2f} s ({it0 / n0:5.1f} it/solve); 3 perturbed {t1:6.2f} s "
              f"({it1 / n1:5.1f} it/solve), {base / t1:4.2f}x the cold start")


def transfer(exe: list[str], results: str, true: dict) -> list:
    """Part D; returns the summary lines."""
    run([*exe, "fit", results])
    t0 = time.process_time()
    held = calibrate_held_out(results)
    dt = time.process_time() - t0
    n = len(held.calibrations) + len([k for k in held.errors if k not in held.calibrations])
    print(f"   {n} calibrations (each subject without each surface) in {dt:.0f} s CPU "
          f"({dt / max(n, 1):.0f} s each)")
    for (surf, subj), why in sorted(held.errors.items()):
        print(f"   no calibrated finger for subject {subj} without {surf}: {why}")
    print(f"   {'subject':8s} {'held out':14s} " + " ".join(f"{f:>16s}" for f in DRAWN_FIELDS)
          + "   (error against the true finger)")
    for (surf, subj), res in sorted(held.calibrations.items(), key=lambda kv: (kv[0][1], kv[0][0])):
        errs = " ".join(f"{getattr(res.finger, f):9.4f} "
                        f"{100 * (getattr(res.finger, f) / getattr(true[subj], f) - 1):+5.1f}%"
                        for f in DRAWN_FIELDS)
        print(f"   {subj:8s} {surf:14s} {errs}")
    res = validate_results(results, calibrated_fingers=held.fingers())
    tab = res.table
    print(f"   {'model':6s} {'subject':14s} {'held out':14s} {'in sample':>9s} {'default finger':>14s} "
          f"{'calibrated':>10s} {'change':>7s}")
    ok = True
    for r in tab.itertuples():
        d, c = r.rho_out_of_sample, r.rho_out_of_sample_calibrated_finger
        if r.model == "load":
            ok &= bool(np.isfinite(c) and c >= 0.75)
        print(f"   {r.model:6s} {str(r.subject):14s} {r.surface:14s} {r.rho_in_sample:9.3f} {d:14.3f} "
              f"{c:10.3f} {c - d:+7.3f}")
    for m in dict.fromkeys(tab["model"]):
        sel = tab[tab["model"] == m]
        diff = sel["rho_out_of_sample_calibrated_finger"] - sel["rho_out_of_sample"]
        print(f"   {m} model: calibration changes the out-of-sample rho by {diff.mean():+.3f} on average "
              f"({diff.min():+.3f} .. {diff.max():+.3f}); lowest with the default finger "
              f"{sel['rho_out_of_sample'].min():.3f}, with the calibrated one "
              f"{sel['rho_out_of_sample_calibrated_finger'].min():.3f}")
    per = tab[tab["subject"] != BOTH]
    for m in dict.fromkeys(per["model"]):
        sel = per[per["model"] == m]
        gd = (sel["rho_out_of_sample"] - sel["rho_heldout_params_video"]).abs()
        gc = (sel["rho_out_of_sample_calibrated_finger"] - sel["rho_heldout_params_video"]).abs()
        print(f"   {m} model: |rho out of sample - rho with the video's own regions| (same held-out "
              f"parameters): default finger {gd.mean():.3f} (max {gd.max():.3f}), calibrated {gc.mean():.3f} "
              f"(max {gc.max():.3f})")
    print(f"   rho >= 0.75 on every held-out surface with the calibrated finger (load-consistent model): "
          f"{verdict(ok)}")
    return [("D leave-one-surface-out, calibrated finger, rho >= 0.75 (load model)", ok)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study", default=None,
                    help="simulated study folder (A; default benchmarks/out/studies/finger-seedS)")
    ap.add_argument("--results", default=None, help="its results folder (default STUDY-results)")
    ap.add_argument("--finger-seed", type=int, default=1)
    ap.add_argument("--full", default=None, help="seed-0 study (C; default: simulated into benchmarks/out/)")
    ap.add_argument("--full-results", default=None, help="its results (C; default: analysed beside it)")
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    # the command line through this interpreter (a venv's console script need not exist)
    exe = [sys.executable, "-m", "fingerfriction.cli"]
    study = args.study or str(STUDIES / f"finger-seed{args.finger_seed}")
    results = args.results or study.rstrip("/") + "-results"
    summary = []

    print("A. Recovery of unknown fingers")
    print(f"   finger seed {args.finger_seed}; 2 subjects x 6 surfaces x 3 speeds x 2 repetitions")
    run([*exe, "simulate", "--out", study, "--reps", "2", "--finger-seed", str(args.finger_seed),
         "--workers", str(args.workers)])
    run([*exe, "analyze", study, "--out", results, "--workers", str(args.workers)])
    truth = json.loads((Path(study) / "truth" / "study.json").read_text())
    true = {s: finger_from_mapping(v["finger"]) for s, v in truth["subjects"].items()}
    print(f"   drawn fingers (seed {truth['options'].get('finger_seed')}), relative to the defaults:")
    for s, f in true.items():
        rel = {k: relative_difference(f, SUBJECTS[k]) for k in SUBJECTS}
        vs = "; ".join(f"vs default {k}: " + ", ".join(f"{n} {100 * rel[k][n]:+.1f} %" for n in DRAWN_FIELDS)
                       for k in SUBJECTS)
        print(f"     subject {s}: R = {f.radius:.3f} mm, E* = {f.modulus:.4f} MPa, "
              f"L = {f.flat_length:.3f} mm; {vs}")
    cpu = {}
    calibrated = {}
    for s in sorted(true):
        t0 = time.process_time()
        res = calibrate_results(results, s)
        cpu[s] = time.process_time() - t0
        calibrated[s] = res
        ok_p, ok_b = report_calibration(res, true[s], s)
        where_time_goes(res)
        print(f"    CPU of this subject's calibration: {cpu[s]:.1f} s (target < {TARGET_CPU_S:.0f} s): "
              f"{verdict(cpu[s] < TARGET_CPU_S)}")
        summary += [(f"A subject {s} parameters within 5 %", ok_p),
                    (f"A subject {s} blind spots within 0.05 mm", ok_b),
                    (f"A subject {s} CPU < 5 min", cpu[s] < TARGET_CPU_S)]

    print("\nB. Where the time goes (warm starts)")
    s0 = sorted(true)[0]
    warm_start_table(results, s0, calibrated[s0].finger)

    print("\nC. The paper's fingers come back (seed-0 study, started from the other subject's default)")
    if args.full is None:
        full = simulated_study("paper-seed0", "--seed", "0")
        given = Path(args.full_results) if args.full_results else None
        args.full_results = str(analysed_study(full, results=given))
    elif args.full_results is None:
        args.full_results = str(analysed_study(Path(args.full)))
    if not (Path(args.full_results) / "run.json").is_file():
        print(f"   {args.full_results} has no results: run `fingerfriction analyze {args.full} --out DIR` "
              "and pass --full-results DIR")
    else:
        other = {"1": SUBJECTS[2], "2": SUBJECTS[1]}
        for s in ("1", "2"):
            t0 = time.process_time()
            res = calibrate_results(args.full_results, s, initial=other[s])
            dt = time.process_time() - t0
            ok_p, ok_b = report_calibration(res, SUBJECTS[int(s)], s)
            print(f"    CPU {dt:.1f} s")
            summary += [(f"C subject {s} default finger within 5 %", ok_p)]

    print("\nD. Leave one surface out with each subject's finger calibrated on the other five surfaces")
    summary += transfer(exe, results, true)

    print("\nSummary")
    for name, ok in summary:
        print(f"  {verdict(ok)}  {name}")


if __name__ == "__main__":
    os.environ.setdefault("PYTHONHASHSEED", "0")
    main()
