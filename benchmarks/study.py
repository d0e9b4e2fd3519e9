"""Wall time of `fingerfriction analyze` on the full study, and the speed-up of 2 workers
over 1.

Usage::

    python benchmarks/study.py [--study DIR] [--speedup-trials N] [--out DIR]

The study is, in order of preference: ``--study``; ``/work/studies/full`` (the paper's
180 trials, written by ``fingerfriction simulate``); the largest study found under
``/work/studies``; else a small study simulated into ``benchmarks/out/`` (gitignored).
When the study has fewer than 180 trials the time for 180 is extrapolated from the
measured time per trial, and the output says so.

The speed-up is measured on the first ``--speedup-trials`` trials (default 24, balanced
over the conditions in manifest order is not guaranteed; use ``0`` for every trial):
one LocalCluster with one worker, then one with two, each writing a fresh results
folder. Timings on a shared machine are noisy: the ratio, measured in the same run, is
the figure to read.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import sys
import tempfile
import time
from pathlib import Path

from fingerfriction.study.analyze import analyze
from fingerfriction.study.params import AnalysisParams, sim_params

PAPER_TRIALS = 180


def _n_trials(study: Path) -> int:
    try:
        return len(json.loads((study / "manifest.json").read_text())["trials"])
    except (OSError, ValueError, KeyError):
        return 0


def find_study(arg: str | None, out: Path) -> tuple[Path, str]:
    if arg:
        return Path(arg), "given with --study"
    full = Path("/work/studies/full")
    if _n_trials(full):
        return full, "/work/studies/full"
    root = Path("/work/studies")
    cands = sorted((p for p in root.glob("*") if _n_trials(p)), key=_n_trials, reverse=True) \
        if root.is_dir() else []
    if cands:
        return cands[0], f"largest study under /work/studies ({cands[0].name})"
    from fingerfriction.sim import SimOptions, simulate_study

    study = out / "study"
    print(f"no study found: simulating 1 subject x 2 surfaces x 3 speeds x 2 reps into {study} ...",
          flush=True)
    simulate_study(study, SimOptions(reps=2, subjects=("1",), surfaces=("bump-2mm", "step-up-2mm"), seed=0))
    return study, "simulated by this benchmark"


def _frames(results: Path) -> int:
    import pandas as pd

    n = 0
    for p in (results / "trials").glob("*/frames.parquet"):
        n += len(pd.read_parquet(p, columns=["frame"]))
    return n


def timed(study: Path, results: Path, workers: int, params: AnalysisParams, trials=None):
    shutil.rmtree(results, ignore_errors=True)
    c0 = _cpu()
    t0 = time.perf_counter()
    res = analyze(study, results, n_workers=workers, progress=False, trials=trials, params=params)
    wall = time.perf_counter() - t0
    return wall, res, _cpu() - c0


def _trial_cpu(results: Path) -> float:
    """Sum of the per-trial CPU seconds measured in the workers (status.json ``cpu_s``)."""
    paths = (results / "trials").glob("*/status.json")
    return sum(json.loads(p.read_text()).get("cpu_s", 0.0) for p in paths)


def _cpu() -> float:
    """CPU seconds of this process and its reaped children (the cluster's worker processes)."""
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study")
    ap.add_argument("--speedup-trials", type=int, default=24)
    ap.add_argument("--out", default=str(Path(__file__).parent / "out"))
    ap.add_argument("--window-mm", type=float, default=None,
                    help="force window (default: the paper's 26 mm; sim_params('cf-centroid') on "
                         "simulated studies with --position cf-centroid)")
    ap.add_argument("--position", default="hybrid", choices=("hybrid", "cf-centroid", "chord"),
                    help="x(t) estimator (default: hybrid, the pipeline's)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    study, origin = find_study(args.study, out)
    n = _n_trials(study)
    simulated = (study / "truth").is_dir()
    opts = sim_params(args.position) if simulated else {"video": {"position": args.position}, "forces": {}}
    if args.window_mm:
        opts["forces"]["window_mm"] = args.window_mm
    params = AnalysisParams(**opts)
    window = params.resolved()["forces"]["window_mm"]
    load = os.getloadavg()[0]
    print(f"study: {study} ({n} trials; {origin}); machine: {os.cpu_count()} cores, "
          f"load average {load:.1f} at start; force window {window:g} mm"
          f"; x(t) estimator {params.resolved()['video']['position']}"
          f"{' (simulated-study options sim_params)' if simulated else ''}")

    tmp = Path(tempfile.mkdtemp(prefix="ff-bench-", dir=out))
    try:
        # 1. the whole study on all cores (the default of `fingerfriction analyze`)
        workers = os.cpu_count() or 1
        wall, res, cpu = timed(study, tmp / "all", workers, params)
        frames = _frames(tmp / "all")
        print(f"analyze, {workers} workers: {res.n_computed} trials OK, {res.n_failed} failed, "
              f"{frames} frames in {wall:.1f} s = {wall / max(n, 1):.2f} s/trial, "
              f"{frames / wall:.0f} frames/s (wall, incl. cluster start-up {wall - res.compute_s:.1f} s); "
              f"CPU {cpu:.0f} s "
              f"= {cpu / max(n, 1):.2f} CPU-s/trial")
        for tid, reason in res.failures[:5]:
            print(f"  failed {tid}: {reason}")
        if n >= PAPER_TRIALS:
            print(f"180-trial study: {wall:.1f} s = {wall / 60:.2f} min (target < 5 min: "
                  f"{'met' if wall < 300 else 'NOT met'})")
        else:
            est = wall / n * PAPER_TRIALS
            print(f"180-trial study: EXTRAPOLATED from {n} trials: {est:.0f} s = {est / 60:.2f} min "
                  f"(target < 5 min: {'met' if est < 300 else 'NOT met'})")
        tcpu = _trial_cpu(tmp / "all")
        print(f"CPU in the workers (per-trial process time, summed): {tcpu:.0f} s = "
              f"{tcpu / max(n, 1):.2f} CPU-s/trial")
        idle = (max(tcpu, cpu) / max(n, 1) * PAPER_TRIALS + (wall - res.compute_s) * workers) / workers
        print(f"180-trial study on {workers} otherwise idle cores, from CPU time (+ start-up): about "
              f"{idle:.0f} s = {idle / 60:.2f} min")

        # 2. speed-up of 2 workers over 1 on the same trials
        ids = [t["id"] for t in json.loads((study / "manifest.json").read_text())["trials"]]
        k = len(ids) if args.speedup_trials <= 0 else min(args.speedup_trials, len(ids))
        sel = ids[:k]
        w1, r1, _ = timed(study, tmp / "w1", 1, params, sel)
        w2, r2, _ = timed(study, tmp / "w2", 2, params, sel)
        print(f"speed-up on {k} trials: 1 worker {w1:.1f} s, 2 workers {w2:.1f} s, "
              f"2 over 1 = {w1 / w2:.2f}x (wall incl. cluster start-up); without start-up "
              f"{r1.compute_s:.1f} s vs {r2.compute_s:.1f} s = {r1.compute_s / max(r2.compute_s, 1e-9):.2f}x "
              f"(ideal 2.00x on 2 free cores); load average now {os.getloadavg()[0]:.1f}")
        c1, c2 = _trial_cpu(tmp / "w1"), _trial_cpu(tmp / "w2")
        print(f"cores actually obtained (worker CPU / wall without start-up): 1 worker "
              f"{c1 / max(r1.compute_s, 1e-9):.2f}, 2 workers {c2 / max(r2.compute_s, 1e-9):.2f} "
              f"(a shared machine gives less than 2; the speed-up follows it)")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
