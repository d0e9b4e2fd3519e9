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
import shutil
import sys
import tempfile
import time
from pathlib import Path

from fingerfriction.pipeline import analyze

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


def timed(study: Path, results: Path, workers: int, trials=None):
    shutil.rmtree(results, ignore_errors=True)
    t0 = time.perf_counter()
    res = analyze(study, results, n_workers=workers, progress=False, trials=trials)
    wall = time.perf_counter() - t0
    return wall, res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study")
    ap.add_argument("--speedup-trials", type=int, default=24)
    ap.add_argument("--out", default=str(Path(__file__).parent / "out"))
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    study, origin = find_study(args.study, out)
    n = _n_trials(study)
    print(f"study: {study} ({n} trials; {origin}); machine: {os.cpu_count()} cores")

    tmp = Path(tempfile.mkdtemp(prefix="ff-bench-", dir=out))
    try:
        # 1. the whole study on all cores (the default of `fingerfriction analyze`)
        workers = os.cpu_count() or 1
        wall, res = timed(study, tmp / "all", workers)
        frames = _frames(tmp / "all")
        print(f"analyze, {workers} workers: {res.n_computed} trials OK, {res.n_failed} failed, "
              f"{frames} frames in {wall:.1f} s = {wall / max(n, 1):.2f} s/trial, "
              f"{frames / wall:.0f} frames/s (wall, incl. cluster start-up)")
        for tid, reason in res.failures[:5]:
            print(f"  failed {tid}: {reason}")
        if n >= PAPER_TRIALS:
            print(f"180-trial study: {wall:.1f} s = {wall / 60:.2f} min (target < 5 min: "
                  f"{'met' if wall < 300 else 'NOT met'})")
        else:
            est = wall / n * PAPER_TRIALS
            print(f"180-trial study: EXTRAPOLATED from {n} trials: {est:.0f} s = {est / 60:.2f} min "
                  f"(target < 5 min: {'met' if est < 300 else 'NOT met'})")

        # 2. speed-up of 2 workers over 1 on the same trials
        ids = [t["id"] for t in json.loads((study / "manifest.json").read_text())["trials"]]
        k = len(ids) if args.speedup_trials <= 0 else min(args.speedup_trials, len(ids))
        sel = ids[:k]
        w1, r1 = timed(study, tmp / "w1", 1, sel)
        w2, r2 = timed(study, tmp / "w2", 2, sel)
        print(f"speed-up on {k} trials: 1 worker {w1:.1f} s, 2 workers {w2:.1f} s, "
              f"2 over 1 = {w1 / w2:.2f}x (ideal 2.00x on 2 free cores)")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
