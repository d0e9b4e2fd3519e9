"""What ``fingerfriction report`` reaches into: the package's modules its code runs in, and
the times the run climbs back up a layer.

``make_report`` runs on a small simulated study (2 surfaces, 2 trials each, analysed and
fitted; simulated into ``benchmarks/out/studies/report-reach`` the first time, see
:mod:`_studies`) under :func:`sys.setprofile`, which sees every Python call. Printed:

* **modules entered**: the package's modules outside ``report/`` whose functions ran, each
  with its layer (``tests/test_layout.py``'s ``LAYERS``), and how many;
* **climbs up a layer**: calls from a module of one layer into a module of a higher layer
  (a function of a lower layer calling back into a higher one, e.g. through an object it
  was handed), counted per call and per distinct (caller, callee) pair; and **re-entries
  below**: how often the run, having come back to the report, goes down again into a
  module of ``study/``, ``pipeline/`` or a stage that reads raw files (``study.manifest``,
  ``study.records``, ``pipeline.*``, ``video.readers``, ``forces.readers``).

Run: ``.venv/bin/python benchmarks/report_reach.py [--results RESULTS]`` (default: the
study above, analysed and fitted beside it). With ``PYTHONPATH=OTHER/src`` it measures
another checkout's package on the same results.
"""

from __future__ import annotations

import argparse
import ast
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _studies import analysed_study, cli, simulated_study  # noqa: E402 - the benchmarks' shared studies

#: Modules that read the study's raw inputs or its manifest, or run a stage again.
RAW = ("study.manifest", "study.records", "pipeline", "video.readers", "video.cine", "forces.readers",
       "forces.containers", "forces.delimited")


def _layers() -> list[tuple[str, list[str]]]:
    """``LAYERS`` of ``tests/test_layout.py`` (read, not imported: the tests are not a package)."""
    src = (Path(__file__).resolve().parents[1] / "tests" / "test_layout.py").read_text()
    for node in ast.parse(src).body:
        if isinstance(node, ast.Assign) and getattr(node.targets[0], "id", "") == "LAYERS":
            return ast.literal_eval(node.value)
    raise RuntimeError("tests/test_layout.py has no LAYERS")


def _layer_of(layers, module: str) -> int:
    best, best_len = -1, -1
    for i, (_, names) in enumerate(layers):
        for n in names:
            match = module == n if n == "" else (module == n or module.startswith(n + "."))
            if match and len(n) > best_len:
                best, best_len = i, len(n)
    return best


def trace_report(results: Path, sample: int):
    """``(modules, climbs, reentries)`` of one ``make_report`` run: module -> calls,
    Counter of (caller, callee) climbs, Counter of modules re-entered below the report."""
    import fingerfriction
    from fingerfriction.report import make_report

    root = Path(fingerfriction.__file__).resolve().parent
    layers = _layers()
    names: dict = {}

    def module(code) -> str | None:
        m = names.get(code.co_filename)
        if m is None:
            p = Path(code.co_filename)
            try:
                rel = p.resolve().relative_to(root).with_suffix("")
            except (ValueError, OSError):
                m = ""
            else:
                parts = list(rel.parts)
                m = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
                m = m or "__root__"
            names[code.co_filename] = m
        return m or None

    calls: Counter = Counter()
    functions: dict = {}
    climbs: Counter = Counter()
    reentries: Counter = Counter()
    last = {"callee": None}

    def prof(frame, event, _arg):
        if event != "call":
            return
        callee = module(frame.f_code)
        if callee is None:
            return
        f = frame.f_back
        caller = None
        while f is not None and caller is None:
            caller = module(f.f_code)
            f = f.f_back
        calls[callee] += 1
        functions.setdefault(callee, Counter())[frame.f_code.co_name] += 1
        if caller is None or caller == callee:
            return
        lc, le = _layer_of(layers, caller), _layer_of(layers, callee.replace("__root__", ""))
        if le > lc:
            climbs[(caller, callee)] += 1
        if caller.startswith("report") and callee.startswith(RAW) and last["callee"] != callee:
            reentries[callee] += 1
        last["callee"] = callee

    sys.setprofile(prof)
    try:
        make_report(results, sample=sample)
    finally:
        sys.setprofile(None)
    return calls, functions, climbs, reentries, layers


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--results", type=Path, help="a fitted results folder (default: simulated, analysed, "
                                                  "fitted into benchmarks/out/studies)")
    ap.add_argument("--sample", type=int, default=1, help="trial pages besides the flagged ones (default 1)")
    args = ap.parse_args()
    results = args.results
    if results is None:
        study = simulated_study("report-reach", "--seed", "3", "--reps", "2", "--subjects", "1",
                                "--surfaces", "bump-2mm,step-up-4mm", "--speeds", "120", "--workers", "1")
        results = analysed_study(study, "--workers", "2")
        if not (results / "fit" / "fit.json").is_file():
            cli("fit", str(results))
    import fingerfriction

    print(f"package: {Path(fingerfriction.__file__).resolve().parent}")
    print(f"results: {results}")
    with tempfile.TemporaryDirectory():
        c0, t0 = time.process_time(), time.perf_counter()
        calls, functions, climbs, reentries, layers = trace_report(results, args.sample)
        print(f"make_report under the profiler: {time.perf_counter() - t0:.1f} s wall, "
              f"{time.process_time() - c0:.1f} s CPU")
    outside = sorted(m for m in calls if not m.startswith("report"))
    print(f"\nmodules entered outside report/: {len(outside)}")
    for m in outside:
        lay = layers[_layer_of(layers, m.replace("__root__", ""))][0]
        raw = ""
        if m.startswith(RAW):
            top = ", ".join(f for f, _ in functions[m].most_common(4))
            raw = f"  <- {top}"
        print(f"  {m:32s} {lay:28s} {calls[m]:8d} calls{raw}")
    n_raw = sum(1 for m in outside if m.startswith(RAW))
    print(f"of which in the modules that read the study's inputs or run a stage: {n_raw} (their "
          "functions named)")
    print(f"\nclimbs up a layer: {sum(climbs.values())} calls, {len(climbs)} distinct (caller -> callee)")
    for (a, b), n in sorted(climbs.items(), key=lambda kv: -kv[1]):
        print(f"  {a} -> {b}: {n}")
    print(f"re-entries from report/ into the study's inputs or a stage: {sum(reentries.values())}")
    for m, n in sorted(reentries.items()):
        print(f"  {m}: {n}")


if __name__ == "__main__":
    main()
