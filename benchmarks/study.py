"""Wall time of `fingerfriction analyze` on the full study, the speed-up of 2 workers
over 1, and the CPU time of `fingerfriction report` on the analysed and fitted study.

Usage::

    python benchmarks/study.py [--study DIR] [--speedup-trials N] [--out DIR]
    python benchmarks/study.py --report-only RESULTS   # fit (if needed) + report of a copy

The report is measured on the results this run analysed (then fitted), or with
``--report-only`` on a copy of an analysed results folder (nothing is written into it):
CPU seconds of the process writing it (figures, tables, trial pages with their
animations, the HTML), target under 60 s for the 180-trial study.

The study is ``--study``, else the paper's 180 trials (seed 0), simulated with
``fingerfriction simulate`` into ``benchmarks/out/studies/`` (gitignored) the first time and
shared with the other benchmarks. When the study has fewer than 180 trials the time for 180
is extrapolated from the measured time per trial, and the output says so.

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

from _studies import simulated_study
from fingerfriction.pipeline.analyze import analyze
from fingerfriction.pipeline.params import AnalysisParams, sim_params

PAPER_TRIALS = 180


def _n_trials(study: Path) -> int:
    try:
        return len(json.loads((study / "manifest.json").read_text())["trials"])
    except (OSError, ValueError, KeyError):
        return 0


def find_study(arg: str | None, out: Path) -> tuple[Path, str]:
    """The study given with --study, else the paper's seed-0 study (simulated into
    benchmarks/out/studies/ the first time, shared with the other benchmarks)."""
    if arg:
        return Path(arg), "given with --study"
    study = simulated_study("paper-seed0", "--seed", "0")
    return study, "the paper's design, seed 0 (benchmarks/out/studies)"


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


def report_timing(results: Path) -> None:
    """Fit ``results`` if it is not fitted, then time its report; print both."""
    from fingerfriction.pipeline.fitting import fit
    from fingerfriction.report import make_report

    if not (results / "fit" / "fit.json").is_file():
        c0, t0 = time.process_time(), time.perf_counter()
        fs = fit(results, progress=False)
        print(f"fit: {fs.n_trials} trials, {fs.n_failed} failed, {time.perf_counter() - t0:.1f} s wall, "
              f"{time.process_time() - c0:.1f} s CPU (this process)")
    c0, t0 = time.process_time(), time.perf_counter()
    rep = make_report(results)
    cpu, wall = time.process_time() - c0, time.perf_counter() - t0
    flagged = {f["trial"] for f in rep.flags if f["trial"] and f["level"] in ("error", "warning")}
    n = rep.n_trials + rep.n_failed
    print(f"report of {n} trials: {cpu:.1f} s CPU ({wall:.1f} s wall), {len(rep.pages)} trial pages "
          f"({len(flagged & set(rep.pages))} of {len(flagged)} flagged trials + "
          f"{len(set(rep.pages) - flagged)} sampled), {len(rep.files)} files")
    if n >= PAPER_TRIALS:
        print(f"180-trial report: {cpu:.1f} s CPU (target < 60 s CPU: {'met' if cpu < 60 else 'NOT met'}; "
              f"pages for every flagged trial: {'yes' if flagged <= set(rep.pages) else 'NO'})")


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
    ap.add_argument("--report-only", metavar="RESULTS",
                    help="only fit (if needed) and report a copy of this analysed results folder")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.report_only:
        tmp = Path(tempfile.mkdtemp(prefix="ff-bench-", dir=out))
        try:
            shutil.copytree(args.report_only, tmp / "results")
            print(f"results: {args.report_only} (copied); load average {os.getloadavg()[0]:.1f}")
            report_timing(tmp / "results")
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        return 0
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
        report_timing(tmp / "all")

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
