"""Does a miss of mu replicate? New repetitions of one subject of a worlds study, and the
flat-ground mu of the original trials against the new ones.

A 95 % confidence interval misses the truth in about one subject of twenty by construction,
so a single miss in the worlds table (``benchmarks/worlds.py``) does not say whether the
analysis is biased there. This benchmark re-simulates the subject with more repetitions of
the same conditions: the trials of the first repetitions are byte-identical to the worlds
study's (a trial's draws come from its own id, ``sim/writer.py``), the later ones are new
and independent draws of the same participant, device and world. A bias of the analysis
shows in both; a fluctuation of the drawn trials does not carry over to the new ones.

Per trial it takes the flat-ground ``mu_k`` of :func:`fingerfriction.fit.mu.flat_ground_mu`
(the estimate every variant on the absolute footing uses) and its error against the trial's
drawn ``mu_trial`` as the sensor records it (``worlds.trial_truth``: the instrument's
residual crosstalk, which no analysis can undo). It prints the error per speed and block of
repetitions (mean, SD, standard error) and each block's mean with its 95 % bootstrap CI
(the fit's own: the percentile interval of 2000 resampled means, seed 0) and whether it
covers the recorded mean.

Default: constant-pressure, seed 2617, subject 2, 80 and 120 mm/s, 6 repetitions (the first
3 are the worlds table's miss: -1.88 % of the recorded mean, CI not covering it;
``docs/worlds.md``): 72 trials, the realistic chain, analysed with the second-order sensor
model as ``worlds.py`` does. About 10 min on two cores.

Run: ``.venv/bin/python benchmarks/replicate_mu.py`` (or ``--world W --seed S --subject N
--speeds 40,80 --reps 6 --original 3``).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _studies import simulated_study  # noqa: E402
from fingerfriction.fit.mu import flat_ground_mu  # noqa: E402
from fingerfriction.pipeline.validation import trials_from_results  # noqa: E402
from worlds import WORLDS, analysed, trial_truth  # noqa: E402

N_BOOT = 2000


def per_trial(results: Path, truth: dict) -> pd.DataFrame:
    """One row per trial taking part in mu: its ``mu_k``, the truth and the error in %."""
    trials = trials_from_results(results)
    rows = []
    for subject in sorted({t.subject for t in trials}):
        flat = flat_ground_mu([t for t in trials if t.subject == subject])
        for tid, mu in flat.mu_trials.items():
            raw, rec = truth[tid]
            rows.append({"trial": tid, "subject": subject, "mu": mu, "raw": raw, "recorded": rec})
    df = pd.DataFrame(rows)
    df["error_pct"] = 100 * (df["mu"] / df["recorded"] - 1)
    df["speed"] = df["trial"].str.extract(r"-v(\d+)-")[0].astype(int)
    df["rep"] = df["trial"].str.extract(r"-r(\d+)$")[0].astype(int)
    return df


def block_line(label: str, d: pd.DataFrame) -> str:
    """The block's mean mu, its bootstrap CI and whether it covers the recorded mean."""
    rng = np.random.default_rng(0)
    mu = d["mu"].to_numpy()
    boots = mu[rng.integers(0, mu.size, size=(N_BOOT, mu.size))].mean(axis=1)
    lo, hi = np.percentile(boots, [2.5, 97.5])
    rec, raw = float(d["recorded"].mean()), float(d["raw"].mean())
    m = float(mu.mean())
    return (f"  {label:22s} {mu.size:3d} trials: mu {m:.5f} [{lo:.5f}, {hi:.5f}]; recorded mean {rec:.5f} "
            f"({100 * (m / rec - 1):+.2f} %, covered: {'yes' if lo <= rec <= hi else 'NO'}); "
            f"raw mean {raw:.5f} ({100 * (m / raw - 1):+.2f} %)")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--world", default="constant-pressure", choices=WORLDS)
    ap.add_argument("--seed", type=int, default=2617)
    ap.add_argument("--subject", default="2")
    ap.add_argument("--speeds", default="80,120", help="nominal speeds in mm/s (comma list)")
    ap.add_argument("--reps", type=int, default=6, help="repetitions simulated")
    ap.add_argument("--original", type=int, default=3, help="the first repetitions: the worlds study's")
    a = ap.parse_args(argv)
    if not 1 <= a.original < a.reps:
        ap.error(f"--original {a.original}: must be at least 1 and below --reps {a.reps}")
    speeds = [s.strip() for s in a.speeds.split(",") if s.strip()]
    name = f"replicate-{a.world}-seed{a.seed}-s{a.subject}-v{'-'.join(speeds)}-reps{a.reps}"
    t0 = time.perf_counter()
    study = simulated_study(name, "--world", a.world, "--chain", "realistic", "--seed", str(a.seed),
                            "--reps", str(a.reps), "--subjects", a.subject,
                            *[x for s in speeds for x in ("--speeds", s)], "--quiet")
    t_sim = time.perf_counter() - t0
    results = analysed(study)
    df = per_trial(results, trial_truth(study))
    df["block"] = np.where(df["rep"] <= a.original, f"r1-{a.original}", f"r{a.original + 1}-{a.reps}")
    print(f"\n=== {a.world}, seed {a.seed}, subject {a.subject}, {', '.join(speeds)} mm/s, "
          f"{a.reps} repetitions ({study}); simulate {t_sim:.0f} s, all {time.perf_counter() - t0:.0f} s")
    g = df.groupby(["speed", "block"])["error_pct"].agg(["mean", "std", "count"])
    g["se"] = g["std"] / np.sqrt(g["count"])
    print("flat-ground mu_k error per trial against the recorded mu_trial (%): mean, SD, trials, SE")
    print(g.round(2).to_string())
    print("error per repetition (%): " + ", ".join(
        f"r{r} {v:+.2f}" for r, v in df.groupby("rep")["error_pct"].mean().items()))
    print("mean mu per block, 95 % bootstrap CI over its trials:")
    for label, d in df.groupby("block"):
        print(block_line(f"repetitions {label.lstrip('r')}", d))
    print(block_line("all", df))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
