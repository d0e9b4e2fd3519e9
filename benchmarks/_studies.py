"""Studies for the benchmarks, simulated and analysed on demand (shared by every benchmark).

Every benchmark runs on a fresh clone with no arguments: what it needs is simulated with
``fingerfriction simulate`` into ``benchmarks/out/studies/NAME`` (gitignored) the first time,
and analysed with ``fingerfriction analyze`` into ``NAME-results``. Both commands resume, so
a later run (of this benchmark or of another one asking for the same study) reuses them.

The names are shared on purpose: ``paper-seed0`` (the paper's 180-trial design, seed 0) is
simulated once for all the benchmarks that use it. A name stands for one set of options:
asking for an existing name with other options is refused by ``simulate`` itself (it never
overwrites a different study), which this module reports as an error naming the folder.

Examples
--------
>>> study = simulated_study("paper-seed0", "--seed", "0")           # doctest: +SKIP
>>> results = analysed_study(study)                                 # doctest: +SKIP
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

__all__ = ["OUT", "STUDIES", "simulated_study", "analysed_study", "cli"]

#: Root of everything benchmarks generate: ``benchmarks/out`` (gitignored), or the folder in
#: the environment variable ``FINGERFRICTION_BENCH_OUT`` (several checkouts can share one).
OUT = Path(os.environ.get("FINGERFRICTION_BENCH_OUT") or Path(__file__).resolve().parent / "out")
#: Where the shared studies go.
STUDIES = OUT / "studies"


def cli(*args: str, ok: tuple[int, ...] = (0,)) -> int:
    """Run ``fingerfriction ARGS`` with this interpreter; exit with its message unless its
    exit code is in ``ok``; return the exit code."""
    cmd = [sys.executable, "-m", "fingerfriction.cli", *args]
    proc = subprocess.run(cmd, check=False)
    if proc.returncode not in ok:
        sys.exit(f"benchmark: `fingerfriction {' '.join(args)}` exited with {proc.returncode}")
    return proc.returncode


def simulated_study(name: str, *options: str) -> Path:
    """The study ``benchmarks/out/studies/NAME``, simulated with ``options`` unless complete.

    Parameters
    ----------
    name : str
        Folder name; one name, one set of options (``paper-seed0``, ``realism-seed0`` ...).
    *options : str
        Extra ``fingerfriction simulate`` arguments (``--seed 0 --realism``).

    Returns
    -------
    pathlib.Path
        The study folder (its ``manifest.json`` is written last by ``simulate``).
    """
    study = STUDIES / name
    if (study / "manifest.json").is_file():
        return study
    print(f"benchmark: simulating {name} into {study} (fingerfriction simulate {' '.join(options)}); "
          "later runs reuse it", flush=True)
    study.parent.mkdir(parents=True, exist_ok=True)
    cli("simulate", "--out", str(study), *options)
    return study


def analysed_study(study: Path, *options: str, results: Path | None = None) -> Path:
    """``study``'s results folder (default ``NAME-results`` beside it), analysed with ``options``.

    ``analyze`` resumes: trials already analysed with the same parameters are skipped, so
    this costs a few seconds when the results are complete.
    """
    results = results or study.with_name(study.name + "-results")
    # exit code 1: some trials failed (the run's summary names them); the benchmark goes on
    # with the others and reports what it measures on them
    cli("analyze", str(study), "--out", str(results), *options, ok=(0, 1))
    return results
