"""Validation across model families: studies simulated with the layered FE finger, predicted
by the default half-space finger, by the study's true FE fingers and by FE fingers calibrated
on the study's own recordings (leave one surface out).

For each finger seed (the three the previous session drew from ``SeedSequence()``: 9167,
6414, 2199; printed with their fingers):

1. ``simulate``: 2 subjects x 6 surfaces x 3 speeds x 1 repetition, study seed 0, the drawn
   layered fingers (``--finger-model fe --finger-seed N``; their contact carries each
   subject's friction), FE tables at ``$FINGERFRICTION_FE_MESH``, by default here the coarse
   mesh :data:`COARSE_MESH` (flat contact edges within 1.5 % of the package's default mesh,
   ``docs/mechanics-fe.md``; a default-mesh table took over 3 min of CPU where these take 4-35 s);
2. ``analyze``; 3. ``fit`` (the study's own mu per subject);
4. ``validate --calibrated-fingers --finger-model fe``: leave-one-surface-out rho with the
   default (half-space) finger and with each subject's FE finger calibrated on the other five
   surfaces, side by side; the blind spots each held-out finger predicts (its forward sweep at
   0.3 N, from the cache) against the measured ones;
5. ``validate --finger S=truth``: the same with the study's true FE fingers (a reference);
6. ``calibrate-finger --finger-model fe`` per subject on all six surfaces: the calibrated
   blind spots (the exact FE finger at the calibrated parameters, at the frames' positions
   and loads) against the measured ones;
7. the table: rho out of sample (nominal load, the fit's model) per subject and surface, and
   the cells >= 0.75 of each column.

``--fit FIELDS`` calibrates other fields of the FE finger (for example
``tissue_modulus,radius,skin_modulus``) in steps 4 and 6, with outputs of their own beside
the default's (``*-fit-FIELDS.*``; the study and the true fingers' validation are shared).

``--position-offset`` adds the offset of the tracked finger position to the calibrated FE
fingers (``calibrate-finger --position-offset``; outputs ``*-offset.*``).

``--thresholds SURFACE`` (for example ``step-up-2mm``) adds, after each seed's table, the
blind-spot widths of each subject's true and calibrated (all six surfaces) fingers over that
surface at contact criteria of 50-90 um instead of 70 um (forward sweeps at 0.3 N, 0.1 mm
steps over the trials' span, cached): how close a blind spot sits to the criterion
(``docs/mechanics-fe.md``).

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

import numpy as np
import pandas as pd

SEEDS = (9167, 6414, 2199)
#: The mesh of the validation when ``$FINGERFRICTION_FE_MESH`` is not set.
COARSE_MESH = {"surface_cell": 0.4, "skin_layers": 1, "tissue_layers": 3, "top_cells": 8}
STEPS = ("simulate", "analyze", "fit", "validate", "true", "calibrate", "table")


def _cpu_children() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run(step: str, args: list[str], log: Path, ok: tuple = (0, 1)) -> None:
    """One CLI command, its output to ``log``; prints CPU and wall time. An exit code outside
    ``ok`` stops the benchmark; exit 2 within ``ok`` (a calibration that did not succeed)
    prints the command's error line and goes on."""
    t, c = time.perf_counter(), _cpu_children()
    with open(log, "w") as fh:
        rc = subprocess.call([sys.executable, "-m", "fingerfriction.cli", *args], stdout=fh,
                             stderr=subprocess.STDOUT)
    print(f"   {step:28s} exit {rc}, {(_cpu_children() - c) / 60:6.1f} min CPU, "
          f"{(time.perf_counter() - t) / 60:6.1f} min wall  ({log.name})", flush=True)
    if rc not in ok:
        print(open(log).read()[-3000:])
        raise SystemExit(f"{step} failed (exit {rc}); see {log}")
    if rc == 2:
        err = [ln for ln in open(log).read().splitlines() if ln.startswith("error:")]
        print(f"      {err[-1] if err else 'exit 2'}")


def seed_run(seed: int, root: Path, workers: int, redo: set, until: str = "table",
             fit: str = "", thresholds: str = "", offset: bool = False) -> dict | None:
    out = root / f"seed-{seed}"
    # a non-default --fit or --position-offset: outputs of their own
    tag = (f"-fit-{fit.replace(',', '+')}" if fit else "") + ("-offset" if offset else "")
    fit_args = (["--fit", fit] if fit else []) + (["--position-offset"] if offset else [])
    out.mkdir(parents=True, exist_ok=True)
    study, results, fingers = out / "study", out / "results", out / "fingers"
    fingers.mkdir(exist_ok=True)
    done = {
        "simulate": (study / "manifest.json").is_file(),
        "analyze": (results / "run.json").is_file(),
        "fit": (results / "fit" / "fit.json").is_file(),
        "calibrate": all((fingers / f"fe-s{s}{tag}.json").is_file() for s in ("1", "2")),
        "validate": (out / f"loso-calibrated{tag}.csv").is_file(),
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
    if "validate" in redo or not done["validate"]:
        run("validate, calibrated FE", ["validate", str(results), "--calibrated-fingers", "--finger-model",
                                         "fe", "--workers", w, *fit_args,
                                         "--out", str(out / f"loso-calibrated{tag}.csv")],
            out / f"validate-calibrated{tag}.log")
    if until == "validate":
        return None
    if "true" in redo or not done["true"]:
        run("validate, true FE fingers", ["validate", str(results),
                                           "--finger", f"1={fingers / 'true-s1.json'}",
                                           "--finger", f"2={fingers / 'true-s2.json'}",
                                           "--out", str(out / "loso-true.csv")], out / "validate-true.log")
    if until == "true":
        return table(seed, out, fingers, tag)
    for s in ("1", "2"):
        if "calibrate" in redo or not (fingers / f"fe-s{s}{tag}.json").is_file():
            run(f"calibrate-finger s{s} (FE)", ["calibrate-finger", str(results), "--subject", s,
                                                 "--finger-model", "fe", "--workers", w, *fit_args,
                                                 "--out", str(fingers / f"fe-s{s}{tag}.json")],
                out / f"calibrate-s{s}{tag}.log", ok=(0, 1, 2))
    summary = table(seed, out, fingers, tag)
    if thresholds:
        threshold_widths(results, fingers, tag, thresholds)
    return summary


THRESHOLDS_UM = (50, 60, 65, 70, 75, 80, 90)


def threshold_widths(results: Path, fingers: Path, tag: str, surface_name: str) -> None:
    """Print the blind-spot widths (>= 0.05 mm) of each subject's true and calibrated FE
    fingers over ``surface_name`` at the contact criteria :data:`THRESHOLDS_UM`."""
    from fingerfriction.mechanics.fe.provider import FEProvider
    from fingerfriction.mechanics.finger_file import fe_finger_from_mapping
    from fingerfriction.model.blindspots import blind_spots
    from fingerfriction.pipeline.validation import trials_from_results
    from fingerfriction.regions import regions_from_mask

    trials = [t for t in trials_from_results(results) if t.surface.name == surface_name]
    if not trials:
        print(f"   --thresholds: no analysed trial on {surface_name!r}")
        return
    surf = trials[0].surface
    print(f"   blind-spot widths (mm, >= 0.05) on {surface_name} at contact criteria (um) "
          + " ".join(f"{t:>5d}" for t in THRESHOLDS_UM))
    for subj in sorted({t.subject for t in trials}):
        ts = [t for t in trials if t.subject == subj]
        lo, hi = min(float(t.x[0]) for t in ts), max(float(t.x[-1]) for t in ts)
        xs = lo + 0.1 * np.arange(int(math.ceil((hi - lo) / 0.1 - 1e-9)) + 1)
        for label, path in (("true", fingers / f"true-s{subj}.json"),
                            ("calibrated", fingers / f"fe-s{subj}{tag}.json")):
            if not path.is_file():
                print(f"      s{subj} {label:10s} no finger file")
                continue
            prov = FEProvider(fingers={"f": fe_finger_from_mapping(json.loads(path.read_text()))})
            y, _ = prov.solve(surf, "f", xs, 0.3)
            xg = xs[:, None] + prov.grid("f")[None, :]
            gap = y - np.asarray(surf.h(xg), float)
            cells = []
            for um in THRESHOLDS_UM:
                rows = [regions_from_mask(xg[i], m)[0] if m.any() else np.empty((0, 2))
                        for i, m in enumerate(gap <= um / 1000)]
                k = max(max(r.shape[0] for r in rows), 1)
                arr = np.full((xs.size, k, 2), np.nan)
                for i, r in enumerate(rows):
                    arr[i, : r.shape[0]] = r
                iv = blind_spots(arr, min_width=0.05).intervals
                cells.append(",".join(f"{b - a:.2f}" for a, b in iv) or "-")
            print(f"      s{subj} {label:10s} " + " ".join(f"{c:>5s}" for c in cells))


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


def _pad(rows: list) -> np.ndarray:
    k = max((r.shape[1] for r in rows), default=1)
    n = sum(r.shape[0] for r in rows)
    a = np.full((n, k, 2), np.nan)
    i = 0
    for r in rows:
        a[i: i + r.shape[0], : r.shape[1]] = r
        i += r.shape[0]
    return a


def heldout_blind_spots(results: Path, held: dict, true: dict) -> float:
    """Blind spots (>= 0.05 mm) of each subject and surface: measured (the union of the video
    regions of its trials) against the forward sweep at 0.3 N that validate made for the
    held-out surface (its positions, from the cache) with the finger calibrated without it,
    and with the true finger. Returns the largest |calibrated - measured| width (mm)."""
    from fingerfriction.mechanics.finger_file import fe_finger_from_mapping
    from fingerfriction.model.blindspots import blind_spots
    from fingerfriction.pipeline.validation import trials_from_results
    from fingerfriction.predict.forward import forward_regions

    trials = trials_from_results(results)
    worst = 0.0
    print("   held-out blind spots (mm, >= 0.05): measured | calibrated without the surface | true finger")
    for surf_name in sorted({t.surface.name for t in trials}):
        for subj in sorted({t.subject for t in trials}):
            ts = [t for t in trials if t.surface.name == surf_name and t.subject == subj]
            entry = (held.get(surf_name) or {}).get(subj) or {}
            if not ts:
                continue
            surf = ts[0].surface
            lo, hi = min(float(t.x[0]) for t in ts), max(float(t.x[-1]) for t in ts)
            xs = lo + 0.01 * np.arange(int(math.ceil((hi - lo) / 0.01 - 1e-9)) + 1)  # validate's sweep
            meas = blind_spots(_pad([t.regions for t in ts]), min_width=0.05).intervals
            got = {}
            for label, f in (("calibrated", entry.get("finger")), ("true", true[subj])):
                if f is None:
                    got[label] = None
                    continue
                try:
                    reg = forward_regions(surf, fe_finger_from_mapping(f), xs, load=0.3)
                except RuntimeError:  # the solver failed (validate's "not predicted" line says where)
                    got[label] = "not predicted"
                    continue
                got[label] = blind_spots(reg, min_width=0.05).intervals
            cells = []
            for label in ("calibrated", "true"):
                pr = got[label]
                if pr is None or isinstance(pr, str):
                    cells.append(pr or "no finger")
                    if label == "calibrated" and pr:
                        worst = math.inf  # a surface without a prediction is not within the criterion
                    continue
                pairs = _pair(meas, pr)
                if label == "calibrated":
                    for m, q in pairs:
                        worst = max(worst, _width_error(m, q))
                cells.append(", ".join(f"{q:.3f}" if math.isfinite(q) else "-" for _, q in pairs) or "none")
            mtxt = ", ".join(f"{b - a:.3f}" for a, b in meas) or "none"
            print(f"      s{subj} {surf_name:14s} {mtxt:>14s} | {cells[0]:>14s} | {cells[1]:>14s}")
    print(f"   largest |calibrated without the surface - measured| blind spot: {worst:.3f} mm "
          "(criterion 0.1)")
    return worst


def _width_error(measured: float, predicted: float) -> float:
    """|predicted - measured| blind-spot width (mm); a blind spot without a partner (NaN on
    the other side) counts its whole width: none is a width of 0."""
    return abs((0.0 if math.isnan(predicted) else predicted) - (0.0 if math.isnan(measured) else measured))


def _pair(meas: np.ndarray, pred: np.ndarray) -> list:
    """``(measured, predicted)`` widths paired by overlap (NaN: no partner), every one of both."""
    out, used = [], set()
    for a, b in meas:
        best = max(((min(b, d) - max(a, c), j) for j, (c, d) in enumerate(pred) if j not in used),
                   default=(-1.0, None))
        if best[1] is not None and best[0] > -0.5:
            used.add(best[1])
            c, d = pred[best[1]]
            out.append((b - a, d - c))
        else:
            out.append((b - a, math.nan))
    out += [(math.nan, d - c) for j, (c, d) in enumerate(pred) if j not in used]
    return out


def table(seed: int, out: Path, fingers: Path, tag: str = "") -> dict:
    cal = pd.read_csv(out / f"loso-calibrated{tag}.csv", dtype={"subject": str})
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
        p = fingers / f"fe-s{s}{tag}.json"
        if not p.is_file():
            print(f"   subject {s}: no calibrated FE finger (see calibrate-s{s}{tag}.log)")
            worst = math.inf  # no finger: its surfaces are not within the criterion
            continue
        d = json.loads(p.read_text())
        f, fitted = d["finger"], d["calibration"]["fitted"]  # calibrate-finger's provenance
        print(f"   subject {s} calibrated FE finger: "
              + ", ".join(f"{k} {f[k]:.4g} {'MPa' if 'modulus' in k else 'mm'}" for k in fitted)
              + f", friction {f['friction']:g}"
              + (f", position offset {d['calibration']['position_offset_mm']:+.3f} mm"
                 if "position_offset_mm" in d["calibration"] else "")
              + "; blind spots measured -> calibrated (mm):")
        for surf, m, pr, rms in _blind_spots(p):
            pairs = []
            for i in range(max(len(m), len(pr))):
                a = m[i] if i < len(m) else math.nan
                b = pr[i] if i < len(pr) else math.nan
                pairs.append(f"{a:.3f} -> {b:.3f}")
                worst = max(worst, _width_error(a, b))
            print(f"      {surf:14s} end RMS {rms:.3f} mm; " + (", ".join(pairs) or "none"))
    print(f"   largest |calibrated (all six surfaces) - measured| blind spot: {worst:.3f} mm "
          "(criterion 0.1 mm)")
    held_path = out / f"loso-calibrated{tag}-fingers.json"
    held_worst = math.nan
    if held_path.is_file():
        true = {s: json.loads((fingers / f"true-s{s}.json").read_text()) for s in ("1", "2")}
        held_worst = heldout_blind_spots(out / "results", json.loads(held_path.read_text()), true)
    return {"seed": seed, **counts, "n": n, "worst_blind_spot_mm": worst, "heldout_worst_mm": held_worst}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default=",".join(map(str, SEEDS)), help="finger seeds (comma list)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent / "out" / "fe-validation"))
    ap.add_argument("--redo", default="", help=f"steps to run again (comma list of {', '.join(STEPS)})")
    ap.add_argument("--until", default="table", choices=("fit", "validate", "true", "table"),
                    help="stop after this step")
    ap.add_argument("--fit", default="", help="the calibrated FE fingers' fields (comma list; default: "
                    "calibrate-finger's); a non-default list writes its own outputs beside the default's")
    ap.add_argument("--position-offset", action="store_true",
                    help="the calibrated FE fingers also fit the offset of the tracked position "
                    "(calibrate-finger --position-offset); outputs of their own (*-offset.*)")
    ap.add_argument("--thresholds", default="", metavar="SURFACE",
                    help="also print each finger's blind spots on SURFACE at contact criteria of 50-90 um")
    args = ap.parse_args()
    redo = {s for s in args.redo.split(",") if s}
    for s in redo:
        if s not in STEPS:
            ap.error(f"--redo: unknown step {s!r}; steps: {', '.join(STEPS)}")
    os.environ.setdefault("FINGERFRICTION_FE_MESH", json.dumps(COARSE_MESH))  # the commands' mesh
    print(f"mesh: FINGERFRICTION_FE_MESH={os.environ['FINGERFRICTION_FE_MESH']}; "
          f"cache: {os.environ.get('FINGERFRICTION_CACHE', '~/.cache/fingerfriction')}")
    summary = [seed_run(int(s), Path(args.out), args.workers, redo, args.until, args.fit, args.thresholds,
                        args.position_offset)
               for s in args.seeds.split(",")]
    summary = [r for r in summary if r is not None]
    print("summary: " + "; ".join(f"seed {r['seed']}: calibrated FE {r['calibrated']}/{r['n']} cells >= 0.75 "
                                  f"(default {r['default']}, true FE {r['true']}), largest blind-spot "
                                  f"error {r['worst_blind_spot_mm']:.3f} mm (all surfaces), "
                                  f"{r['heldout_worst_mm']:.3f} mm (held out)" for r in summary))


if __name__ == "__main__":
    main()
