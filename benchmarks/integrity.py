"""What integrity costs: `analyze`, `fit` and `report` on the paper's 180-trial
study with today's code against the code before the integrity work, in the same run.

Usage::

    python benchmarks/integrity.py            # no arguments; about 30 min on 2 cores

The study is ``benchmarks/out/studies/paper-seed0`` (simulated on the first run, shared
with the other benchmarks, :mod:`benchmarks._studies`). The code before is the package of
commit ``BASELINE`` (94a37d8, main before the integrity work: content hashes, verified
tables, locks), extracted once with
``git archive`` into ``benchmarks/out/integrity/`` (gitignored) and run from there; the code
now is this checkout's. Each command runs in its own process, the way a user runs it:

* ``analyze`` of the whole study into a new results folder (the work: every trial computed;
  now with the table digests, the one-study check and the lock);
* ``analyze`` again on the finished folder, every trial skipped: before, a size and time
  comparison of the inputs; now, the SHA-256 of every input (about 0.9 GB here) and of every
  stored table (the default), or with ``--quick-resume`` the inputs' fingerprints and the
  tables' digests; three times each, alternated, the median reported;
* ``fit`` of the analysed results (now also the digests of the analysis it fits);
* ``report`` of the fitted results (now also the check that the fit is of this analysis).

Wall times on a shared machine are noisy: read the ratios, measured in the same run, and
the CPU times beside them (user + system of the command and its worker processes), which
another job on the machine disturbs much less.

Since ``BASELINE`` the commands also do work of other kinds, each with a budget of its own:
``analyze`` runs the consistency stage (its study-level synchronisation step included) and
``fit`` fits every model variant and compares them out of sample. So the whole-command
ratio is not the cost of integrity alone. Part B measures that cost directly, in this
process, on the results ``now`` wrote: the SHA-256 of every input and its file-system
fingerprint and the digest of every stored table (``analyze``), the verification of every
stored table (a resume), the digests of the analysis a fit records (``fit``) and the check
that the fit is of this analysis (``report``), and the results folder's lock; each set
against the command's measured time (the command without it would take that much less).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import resource
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _studies import OUT, simulated_study  # noqa: E402

BASELINE = "94a37d8"
ROOT = Path(__file__).resolve().parents[1]
WORK = OUT / "integrity"


def baseline_src() -> Path:
    """The package as it was at ``BASELINE``, extracted once."""
    dest = WORK / f"baseline-{BASELINE}"
    if not (dest / "src" / "fingerfriction" / "__init__.py").is_file():
        dest.mkdir(parents=True, exist_ok=True)
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", BASELINE, "src"],
                                 capture_output=True)
        if archive.returncode != 0:
            sys.exit(f"benchmark: cannot extract commit {BASELINE} with git archive (a clone with its "
                     f"history is needed): {archive.stderr.decode().strip()}")
        subprocess.run(["tar", "-x", "-C", str(dest)], input=archive.stdout, check=True)
    return dest / "src"


#: CPU seconds (user + system) of every command run so far, by its label (``run``).
CPU: dict = {}


def _children_cpu() -> float:
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return ru.ru_utime + ru.ru_stime


def run(src: Path, *args: str, label: tuple | None = None) -> float:
    """Wall time in s of ``fingerfriction ARGS`` run from the package in ``src``; its CPU time
    (the process and the workers it waited for) goes to ``CPU[label]``."""
    env = {**os.environ, "PYTHONPATH": str(src)}
    c0 = _children_cpu()
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "fingerfriction.cli", *args], env=env, capture_output=True,
                          text=True)
    elapsed = time.perf_counter() - t0
    if label is not None:
        CPU[label] = _children_cpu() - c0
    if proc.returncode not in (0, 1):
        sys.exit(f"benchmark: `fingerfriction {' '.join(args)}` ({src}) exited with {proc.returncode}:\n"
                 f"{proc.stdout[-2000:]}{proc.stderr[-2000:]}")
    return elapsed


def which(src: Path) -> str:
    env = {**os.environ, "PYTHONPATH": str(src)}
    out = subprocess.run([sys.executable, "-c", "import fingerfriction; print(fingerfriction.__file__)"],
                         env=env, capture_output=True, text=True, check=True)
    return out.stdout.strip()


def main() -> int:
    # no options: --help says what it does (without it, any argument would start the 30 min run)
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    study = simulated_study("paper-seed0", "--seed", "0")
    size = sum(p.stat().st_size for p in (study / "trials").rglob("*") if p.is_file())
    n_trials = len(list((study / "trials").iterdir()))
    srcs = {"before": baseline_src(), "now": ROOT / "src"}
    for name, src in srcs.items():
        where = which(src)
        assert where.startswith(str(src)), f"{name}: fingerfriction imported from {where}, not {src}"
    print(f"study: {study} ({n_trials} trials, {size / 1e9:.2f} GB of inputs); before = {BASELINE} "
          f"({srcs['before']}), now = this checkout", flush=True)
    results = {name: WORK / f"{name}-results" for name in srcs}
    times: dict = {}
    for name, src in srcs.items():  # the whole study analysed, into a new folder
        shutil.rmtree(results[name], ignore_errors=True)
        times[("analyze", name)] = run(src, "analyze", str(study), "--out", str(results[name]), "--quiet",
                                       label=("analyze", name))
        print(f"analyze ({name}): {times[('analyze', name)]:.1f} s", flush=True)
    resume: dict = {"before": [], "now": [], "now --quick-resume": []}
    for _ in range(3):  # every trial skipped: alternated, three times each
        resume["before"].append(run(srcs["before"], "analyze", str(study), "--out", str(results["before"]),
                                    "--quiet"))
        resume["now"].append(run(srcs["now"], "analyze", str(study), "--out", str(results["now"]), "--quiet"))
        resume["now --quick-resume"].append(run(srcs["now"], "analyze", str(study), "--out",
                                                str(results["now"]), "--quiet", "--quick-resume"))
    for name, src in srcs.items():
        times[("fit", name)] = run(src, "fit", str(results[name]), "--quiet", label=("fit", name))
        print(f"fit ({name}): {times[('fit', name)]:.1f} s", flush=True)
    for name, src in srcs.items():
        times[("report", name)] = run(src, "report", str(results[name]), "--quiet", label=("report", name))
        print(f"report ({name}): {times[('report', name)]:.1f} s", flush=True)

    print("\nA. The whole commands, before and now (wall; CPU: user + system of the command and its "
          "workers)")
    print(f"{'command':<44}{'before (s)':>12}{'now (s)':>12}{'now / before':>14}"
          f"{'CPU before':>12}{'CPU now':>10}{'CPU ratio':>11}")
    rows = [("analyze, every trial computed", times[("analyze", "before")], times[("analyze", "now")]),
            ("analyze, every trial skipped (median of 3)", statistics.median(resume["before"]),
             statistics.median(resume["now"])),
            ("  the same with --quick-resume", statistics.median(resume["before"]),
             statistics.median(resume["now --quick-resume"])),
            ("fit", times[("fit", "before")], times[("fit", "now")]),
            ("report", times[("report", "before")], times[("report", "now")])]
    cpu_rows = {"analyze, every trial computed": "analyze", "fit": "fit", "report": "report"}
    for label, before, now in rows:
        line = f"{label:<44}{before:>12.1f}{now:>12.1f}{now / before:>14.3f}"
        if label in cpu_rows:
            cb, cn = CPU[(cpu_rows[label], "before")], CPU[(cpu_rows[label], "now")]
            line += f"{cb:>12.1f}{cn:>10.1f}{cn / cb:>11.3f}"
        print(line)
    print("\nskipped runs, each (s): " + "; ".join(f"{k}: {', '.join(f'{v:.1f}' for v in vs)}"
                                                 for k, vs in resume.items()))
    total_b = times[("analyze", "before")] + times[("fit", "before")] + times[("report", "before")]
    total_n = times[("analyze", "now")] + times[("fit", "now")] + times[("report", "now")]
    print(f"analyze + fit + report: before {total_b:.1f} s, now {total_n:.1f} s, "
          f"ratio {total_n / total_b:.3f}")
    runs = read_json(results["now"] / "run.json").get("runs") or []
    computed = [r for r in runs if r.get("computed")]  # the run that analysed the trials, not a resume
    sync_s = (computed[0].get("sync") or {}).get("elapsed_s") if computed else None
    if sync_s is not None:
        print(f"  of now's analyze: the consistency stage's study-level synchronisation step {sync_s:.1f} s "
              f"({sync_s / times[('analyze', 'now')]:.1%}; a budget of its own, not integrity)")
    integrity_part(study, results["now"], times)
    return 0


def read_json(path: Path) -> dict:
    import json
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return {}


def _timed(fn) -> tuple[float, float]:
    """(wall s, CPU s) of ``fn()`` in this process."""
    t0, c0 = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t0, time.process_time() - c0


def integrity_part(study: Path, results: Path, times: dict) -> None:
    """Part B: the integrity work itself, timed in this process on ``results`` (see the module
    docstring), and each command's time with and without it."""
    from fingerfriction.study.digests import input_fingerprint, sha256_input
    from fingerfriction.study.store import ResultsStore

    store = ResultsStore(results)
    ids = store.trial_ids()
    inputs = []
    for tid in ids:
        for rec in ((store.status(tid) or {}).get("inputs") or {}).values():
            inputs.append(study / rec["path"])

    def hash_inputs():
        for p in inputs:
            sha256_input(p)
            input_fingerprint(p)

    def digest_tables():  # what the store does with each table's bytes when it writes them
        for tid in ids:
            for name in ("frames.parquet", "forces.parquet"):
                hashlib.sha256((store.trial_dir(tid) / name).read_bytes()).hexdigest()

    def verify():
        bad = [tid for tid in ids if store.verify_tables(tid) is not None]
        assert not bad, f"damaged tables in {results}: {bad[:3]}"

    def lock():
        with store.lock("benchmark"):
            pass

    costs = {name: _timed(fn) for name, fn in (("inputs", hash_inputs), ("tables", digest_tables),
                                               ("verify", verify), ("fit digests", store.analysis_digests),
                                               ("staleness", store.fit_staleness), ("lock", lock))}
    n_bytes = sum(p.stat().st_size for p in inputs)
    print(f"\nB. The integrity work itself, in this process on {len(ids)} trials of now's results "
          f"({len(inputs)} inputs, {n_bytes / 1e9:.2f} GB; file caches warm, as in part A's runs)")
    print(f"{'work':<60}{'wall (s)':>10}{'CPU (s)':>10}")
    what = {"inputs": "SHA-256 and fingerprint of every input (analyze, resume)",
            "tables": "SHA-256 of every stored table as written (analyze)",
            "verify": "verification of every stored table (resume)",
            "fit digests": "digests of the analysis the fit records (fit)",
            "staleness": "is the fit of this analysis? (report)",
            "lock": "the results folder's lock, taken and released (every command)"}
    for name, (wall, cpu) in costs.items():
        print(f"{what[name]:<60}{wall:>10.2f}{cpu:>10.2f}")
    shares = {"analyze": ("inputs", "tables", "lock"), "fit": ("fit digests", "lock"),
              "report": ("staleness", "lock")}
    print(f"\n{'command':<12}{'now (s)':>10}{'integrity (s)':>15}{'now without it (s)':>20}"
          f"{'now / without':>15}")
    for command, parts in shares.items():
        cost = sum(costs[p][0] for p in parts)  # serial wall time: an upper bound (analyze hashes in its main
        now_s = times[(command, "now")]         # process; the table digests run in its workers)
        print(f"{command:<12}{now_s:>10.1f}{cost:>15.2f}{now_s - cost:>20.1f}{now_s / (now_s - cost):>15.3f}")


if __name__ == "__main__":
    raise SystemExit(main())
