"""Validation across model families: studies simulated with the layered FE finger, predicted
by the default half-space finger, by the study's true FE fingers and by FE fingers calibrated
on the study's own recordings (leave one surface out).

For each finger seed (the three the previous session drew from ``SeedSequence()``: 9167,
6414, 2199; printed with their fingers):

1. ``simulate``: 2 subjects x 6 surfaces x 3 speeds x 1 repetition, study seed 0, the drawn
   layered fingers (``--finger-model fe --finger-seed N``; their contact carries each
   subject's friction), FE tables at ``$FINGERFRICTION_FE_MESH``;
2. ``analyze``; 3. ``fit`` (the study's own mu per subject);
4. ``calibrate-finger --finger-model fe`` per subject on all six surfaces: the calibrated
   blind spots (the exact FE finger at the calibrated parameters, at the frames' positions
   and loads) against the measured ones;
5. ``validate --calibrated-fingers --finger-model fe``: leave-one-surface-out rho with the
   default (half-space) finger and with each subject's FE finger calibrated on the other five
   surfaces, side by side;
6. ``validate --finger S=truth``: the same with the study's true FE fingers (a reference);
7. the table: rho out of sample (nominal load, the fit's model) per subject and surface, and
   the cells >= 0.75 of each column.

Every step whose output exists is skipped (``--redo STEP`` to run it again); each prints its
CPU time (user + sys of its processes) and wall time. The FE tables are cached
(``$FINGERFRICTION_CACHE``) and shared between steps and seeds.

Run: ``PYTHONPATH=src python benchmarks/fe_validation.py --seeds 9167 [--workers 2]``
(outputs in ``benchmarks/out/fe-validation/seed-N``, or ``--out``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd

SEEDS = (9167, 6414, 2199)
STEPS = ("simulate", "analyze", "fit", "calibrate", "validate", "true", "table")


def _cpu_children() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(step: str, args: list[str], log: Path) -> None:
    """One CLI command, its output to ``log``; prints CPU and wall time."""
    t, c = time.perf_counter(), _cpu_children()
    with open(log, "w") as fh:
        rc = subprocess.call([sys.executable, "-m", "fingerfriction.cli", *args], stdout=fh,
                             stderr=subprocess.STDOUT)
    print(f"   {step:28s} exit {rc}, {(_cpu_children() - c) / 60:6.1f} min CPU, "
          f"{(time.perf_counter() - t) / 60:6.1f} min wall  ({log.name})", flush=True)
    if rc not in (0, 1):
        print(open(log).read()[-3000:])
        raise SystemExit(f"{step} failed (exit {rc}); see {log}")


def seed_run(seed: int, root: Path, workers: int, redo: set, until: str = "table") -> dict | None:
    out = root / f"seed-{seed}"
    out.mkdir(parents=True, exist_ok=True)
    study, results, fingers = out / "study", out / "results", out / "fingers"
    fingers.mkdir(exist_ok=True)
    done = {
        "simulate": (study / "manifest.json").is_file(),
        "analyze": (results / "run.json").is_file(),
        "fit": (results / "fit" / "fit.json").is_file(),
        "calibrate": all((fingers / f"fe-s{s}.json").is_file() for s in ("1", "2")),
        "validate": (out / "loso-calibrated.csv").is_file(),
        "true": (out / "loso-true.csv").is_file(),
    }
    print(f"finger seed {seed}: {out}")
    w = str(workers)
    if "simulate" in redo or not done["simulate"]:
        run("simulate", ["simulate", "--out", str(study), "--finger-model", "fe", "--finger-seed", str(seed),
                         "--reps", "1", "--seed", "0", "--workers", w, "--quiet"], out / "simulate.log")
    truth = json.loads((study / "truth" / "study.json").read_text())
    for s, d in sorted(truth["subjects"].items()):
        f = d["finger"]
        (fingers / f"true-s{s}.json").write_text(json.dumps(f))
        print(f"   true finger {s}: " + ", ".join(f"{k}={f[k]:.4g}" for k in (
            "radius", "semi_height", "tissue_modulus", "skin_modulus", "skin_thickness", "pulp_thickness",
            "friction")) + f"; mesh {f['mesh']}")
    if "analyze" in redo or not done["analyze"]:
        run("analyze", ["analyze", str(study), "--out", str(results), "--workers", w, "--quiet"],
            out / "analyze.log")
    if "fit" in redo or not done["fit"]:
        run("fit", ["fit", str(results), "--quiet"], out / "fit.log")
    if until == "fit":
        return None
    for s in ("1", "2"):
        if "calibrate" in redo or not (fingers / f"fe-s{s}.json").is_file():
            run(f"calibrate-finger s{s} (FE)", ["calibrate-finger", str(results), "--subject", s,
                                                 "--finger-model", "fe", "--workers", w,
                                                 "--out", str(fingers / f"fe-s{s}.json")],
                out / f"calibrate-s{s}.log")
    if until == "calibrate":
        return None
    if "validate" in redo or not done["validate"]:
        run("validate, calibrated FE", ["validate", str(results), "--calibrated-fingers", "--finger-model",
                                         "fe", "--workers", w, "--out", str(out / "loso-calibrated.csv")],
            out / "validate-calibrated.log")
    if "true" in redo or not done["true"]:
        run("validate, true FE fingers", ["validate", str(results),
                                           "--finger", f"1={fingers / 'true-s1.json'}",
                                           "--finger", f"2={fingers / 'true-s2.json'}",
                                           "--out", str(out / "loso-true.csv")], out / "validate-true.log")
    return table(seed, out, fingers)


def _blind_spots(path: Path) -> list:
    """``(surface, measured, predicted)`` widths (mm) of a calibrated finger file's provenance."""
    d = json.loads(path.read_text())
    cal = d.get("calibration") or {}
    rows = []
    for s in cal.get("surfaces", []):
        m = [b - a for a, b in s["measured_blind_spots_mm"]]
        p = [b - a for a, b in s["predicted_blind_spots_mm"]]
        rows.append((s["surface"], m, p, s["rms_end_mm"]))
    return rows


def table(seed: int, out: Path, fingers: Path) -> dict:
    cal = pd.read_csv(out / "loso-calibrated.csv", dtype={"subject": str})
    true = pd.read_csv(out / "loso-true.csv", dtype={"subject": str})
    model = cal["model"].iloc[0]
    cal = cal[cal["model"] == model]
    true = true[true["model"] == model].set_index(["subject", "surface"])
    print(f"   leave-one-surface-out rho (the fit's model '{model}', nominal 0.3 N), finger seed {seed}:")
    print(f"   {'subject':8s} {'surface':14s} {'default (half-space)':>21s} {'true FE':>8s} "
          f"{'calibrated FE':>14s}")
    counts = {"default": 0, "true": 0, "calibrated": 0}
    for r in cal.itertuples():
        t = true.loc[(r.subject, r.surface), "rho_out_of_sample"]
        c = getattr(r, "rho_out_of_sample_calibrated_finger", math.nan)
        print(f"   {r.subject:8s} {r.surface:14s} {r.rho_out_of_sample:21.2f} {t:8.2f} {c:14.2f}")
        counts["default"] += r.rho_out_of_sample >= 0.75
        counts["true"] += t >= 0.75
        counts["calibrated"] += c >= 0.75
    n = len(cal)
    print(f"   cells with rho >= 0.75: default {counts['default']}/{n}, true FE {counts['true']}/{n}, "
          f"calibrated FE {counts['calibrated']}/{n}")
    worst = 0.0
    for s in ("1", "2"):
        p = fingers / f"fe-s{s}.json"
        if not p.is_file():
            print(f"   subject {s}: no calibrated FE finger (see calibrate-s{s}.log)")
            continue
        f = json.loads(p.read_text())["finger"]
        print(f"   subject {s} calibrated FE finger: tissue_modulus {f['tissue_modulus']:.4g} MPa, radius "
              f"{f['radius']:.4g} mm, friction {f['friction']:g}; blind spots measured -> calibrated (mm):")
        for surf, m, pr, rms in _blind_spots(p):
            pairs = []
            for i in range(max(len(m), len(pr))):
                a = m[i] if i < len(m) else math.nan
                b = pr[i] if i < len(pr) else math.nan
                pairs.append(f"{a:.3f} -> {b:.3f}")
                worst = max(worst, abs(a - b) if math.isfinite(a - b) else math.inf)
            print(f"      {surf:14s} end RMS {rms:.3f} mm; " + (", ".join(pairs) or "none"))
    print(f"   largest |calibrated - measured| blind spot: {worst:.3f} mm (criterion 0.1 mm)")
    return {"seed": seed, **counts, "n": n, "worst_blind_spot_mm": worst}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default=",".join(map(str, SEEDS)), help="finger seeds (comma list)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent / "out" / "fe-validation"))
    ap.add_argument("--redo", default="", help=f"steps to run again (comma list of {', '.join(STEPS)})")
    ap.add_argument("--until", default="table", choices=("fit", "calibrate", "table"),
                    help="stop after this step")
    args = ap.parse_args()
    redo = {s for s in args.redo.split(",") if s}
    for s in redo:
        if s not in STEPS:
            ap.error(f"--redo: unknown step {s!r}; steps: {', '.join(STEPS)}")
    print(f"mesh: FINGERFRICTION_FE_MESH={os.environ.get('FINGERFRICTION_FE_MESH', '(default mesh)')}; "
          f"cache: {os.environ.get('FINGERFRICTION_CACHE', '~/.cache/fingerfriction')}")
    summary = [seed_run(int(s), Path(args.out), args.workers, redo, args.until)
               for s in args.seeds.split(",")]
    summary = [r for r in summary if r is not None]
    print("summary: " + "; ".join(f"seed {r['seed']}: calibrated FE {r['calibrated']}/{r['n']} cells >= 0.75 "
                                  f"(default {r['default']}, true FE {r['true']}), largest blind-spot "
                                  f"error {r['worst_blind_spot_mm']:.3f} mm" for r in summary))


if __name__ == "__main__":
    main()
