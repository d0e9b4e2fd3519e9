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

Wall times on a shared machine are noisy: run it under the CPU lock, and read the ratios,
measured in the same run.
"""

from __future__ import annotations

import os
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


def run(src: Path, *args: str) -> float:
    """Wall time in s of ``fingerfriction ARGS`` run from the package in ``src``."""
    env = {**os.environ, "PYTHONPATH": str(src)}
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-m", "fingerfriction.cli", *args], env=env, capture_output=True,
                          text=True)
    elapsed = time.perf_counter() - t0
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
        times[("analyze", name)] = run(src, "analyze", str(study), "--out", str(results[name]), "--quiet")
        print(f"analyze ({name}): {times[('analyze', name)]:.1f} s", flush=True)
    resume: dict = {"before": [], "now": [], "now --quick-resume": []}
    for _ in range(3):  # every trial skipped: alternated, three times each
        resume["before"].append(run(srcs["before"], "analyze", str(study), "--out", str(results["before"]),
                                    "--quiet"))
        resume["now"].append(run(srcs["now"], "analyze", str(study), "--out", str(results["now"]), "--quiet"))
        resume["now --quick-resume"].append(run(srcs["now"], "analyze", str(study), "--out",
                                                str(results["now"]), "--quiet", "--quick-resume"))
    for name, src in srcs.items():
        times[("fit", name)] = run(src, "fit", str(results[name]), "--quiet")
        print(f"fit ({name}): {times[('fit', name)]:.1f} s", flush=True)
    for name, src in srcs.items():
        times[("report", name)] = run(src, "report", str(results[name]), "--quiet")
        print(f"report ({name}): {times[('report', name)]:.1f} s", flush=True)

    print(f"\n{'command':<44}{'before (s)':>12}{'now (s)':>12}{'now / before':>14}")
    rows = [("analyze, every trial computed", times[("analyze", "before")], times[("analyze", "now")]),
            ("analyze, every trial skipped (median of 3)", statistics.median(resume["before"]),
             statistics.median(resume["now"])),
            ("  the same with --quick-resume", statistics.median(resume["before"]),
             statistics.median(resume["now --quick-resume"])),
            ("fit", times[("fit", "before")], times[("fit", "now")]),
            ("report", times[("report", "before")], times[("report", "now")])]
    for label, before, now in rows:
        print(f"{label:<44}{before:>12.1f}{now:>12.1f}{now / before:>14.3f}")
    print("\nskipped runs, each (s): " + "; ".join(f"{k}: {', '.join(f'{v:.1f}' for v in vs)}"
                                                 for k, vs in resume.items()))
    total_b = times[("analyze", "before")] + times[("fit", "before")] + times[("report", "before")]
    total_n = times[("analyze", "now")] + times[("fit", "now")] + times[("report", "now")]
    print(f"analyze + fit + report: before {total_b:.1f} s, now {total_n:.1f} s, "
          f"ratio {total_n / total_b:.3f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
