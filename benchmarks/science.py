"""The fit's science: every figure of the load-consistent variant on the default world, from
one run.

A. **Default model on the seed-0 virtual study** (``fingerfriction simulate --seed 0``,
   ``analyze``): ``fingerfriction.study.fit`` with every variant, the leave-one-surface-out
   validation and ``--model auto``'s choice (on this world, the load-sharing one, the
   load-consistent variant must be chosen). Prints mu per subject with its 95 % CI beside the
   truth (the mean of the trials' simulated ``mu``), the count of failed or unphysical
   trial fits, Table 1 of both variants with bootstrap CIs, leave-one-surface-out rho
   per held-out surface for both, and the CPU time of each variant's fit.
B. **Why mu is not refined jointly**: on the same trials, mu, the inset and kappa fitted
   together by minimising the residual (p1 profiled out per trial) beside mu from flat
   ground.
C. **The paper's variant against the figures first measured** (mu at the grid edge, negative p0,
   Bump 2 mm rho), and the flags it raises.
D. **Realism on** (``simulate --realism``: per-trial mu scatter, mu depending on load,
   normal-force wander): the same as A, with the subjects' mu ``per trial`` (default) and
   ``per subject`` beside each other.
E. **Synthetic Eq. (4) in absolute form** (``fingerfriction.testing``, 10 % noise on F_T
   and F_N, known mu, p0, p1; 4 seeds): recovery of every parameter, with each trial's
   p1 error against its own standard error.

Run: ``.venv/bin/python benchmarks/science.py [--realism]`` (no arguments needed), or on
studies of your own: ``--results RESULTS --study STUDY [--realism-results R2 --realism-study
S2]``. Without them the studies are simulated and analysed on the first run into the
gitignored ``benchmarks/out/studies`` (:mod:`_studies`: ``paper-seed0``, made with
``fingerfriction simulate --seed 0``, and with ``--realism`` also ``realism-seed0``, made
with ``--seed 0 --realism``; about 15 min each on two cores) and reused afterwards; the
benchmark itself takes a few minutes. It writes nothing else outside a temporary folder
(the fit's outputs go to a copy of each results folder).
"""

from __future__ import annotations

import argparse
import math
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import optimize

from _studies import analysed_study, simulated_study  # the benchmarks' shared studies
from fingerfriction.fit import LoadFitOptions, fit_load_subject
from fingerfriction.fit.load import _LoadDesign, _search_designs
from fingerfriction.model import FrictionModel
from fingerfriction.model.stats import BOTH, correlation_table
from fingerfriction.pipeline.fitting import fit as fit_study
from fingerfriction.pipeline.validation import trials_from_results
from fingerfriction.study.store import ResultsStore
from fingerfriction.surfaces import SURFACE_NAMES
from fingerfriction.testing import synthetic_trial


def verdict(ok: bool) -> str:
    return "PASS" if ok else "FAIL"


def truth_mu(study: Path) -> tuple[dict, dict]:
    """(subject -> mean true mu, trial id -> true mu) from the simulator's truth files."""
    per_trial, by_subject = {}, {}
    for p in sorted((study / "truth").glob("*.npz")):
        with np.load(p, allow_pickle=False) as z:  # our own simulator's output
            mu = float(z["mu_trial"])
        per_trial[p.stem] = mu
        by_subject.setdefault(p.stem.split("-")[0].lstrip("s"), []).append(mu)
    return {s: float(np.mean(v)) for s, v in by_subject.items()}, per_trial


def copy_results(results: Path, tmp: Path, name: str) -> Path:
    """A copy of the analysed results (the fit writes fit/ into it)."""
    dst = tmp / name
    shutil.copytree(results, dst, ignore=shutil.ignore_patterns("fit"))
    return dst


def print_mu(summary, truth: dict, tol: float) -> bool:
    ok = True
    for s in sorted(summary.mu):
        mu, (lo, hi) = summary.mu[s], summary.mu_ci[s]
        t = truth.get(s, math.nan)
        err = mu / t - 1
        good = abs(err) <= tol and lo <= t <= hi
        ok &= good
        print(f"  subject {s}: mu = {mu:.5f}, 95 % CI [{lo:.5f}, {hi:.5f}]; truth {t:.5f}; "
              f"error {100 * err:+.3f} % (target |error| <= {100 * tol:g} %, truth in CI): {verdict(good)}")
    return ok


def table1_side_by_side(table1: pd.DataFrame, floor: float) -> dict:
    """Prints Table 1 of both variants; returns model -> (min rho, cells >= floor, cells)."""
    t = table1.copy()
    t["cell"] = t["subject"].astype(str) + " | " + t["scale"].astype(str) + " " + t["shape"].astype(str)
    out = {}
    print(f"  {'cell':34s} {'load rho [95 % CI]':>26s} {'paper rho [95 % CI]':>26s}")
    load, paper = (t[t.model == m].set_index("cell") for m in ("load", "paper"))
    for cell in load.index:
        a, b = load.loc[cell], paper.loc[cell]
        print(f"  {cell:34s} {a.rho:8.3f} [{a.rho_lo:.3f}, {a.rho_hi:.3f}]    "
              f"{b.rho:8.3f} [{b.rho_lo:.3f}, {b.rho_hi:.3f}]")
    for m, d in (("load", load), ("paper", paper)):
        out[m] = (float(d.rho.min()), int((d.rho >= floor).sum()), len(d))
        print(f"  {m}: min rho {out[m][0]:.3f}; {out[m][1]} of {out[m][2]} cells >= {floor}")
    return out


def loso_side_by_side(loso: pd.DataFrame, floor: float) -> dict:
    out = {}
    print(f"  {'subject':8s} {'held-out surface':18s} {'load rho':>9s} {'paper rho':>10s}")
    load = loso[loso.model == "load"].set_index(["subject", "surface"])
    paper = loso[loso.model == "paper"].set_index(["subject", "surface"])
    for key in load.index:
        print(f"  {key[0]:8s} {key[1]:18s} {load.loc[key].rho_out_of_sample:9.3f} "
              f"{paper.loc[key].rho_out_of_sample:10.3f}")
    for m, d in (("load", load), ("paper", paper)):
        r = d.rho_out_of_sample.to_numpy(float)
        out[m] = (float(np.nanmin(r)), int(np.sum(r >= floor)), r.size)
        print(f"  {m}: min rho {out[m][0]:.3f}; {out[m][1]} of {out[m][2]} held-out surfaces >= {floor}")
    return out


def unphysical(summary, model: str) -> tuple[int, dict]:
    """Trial fits of ``model`` that failed or are unphysical, and the error flags by code
    (the variant used: its flags; the others: their notes)."""
    codes: dict = {}
    trials = set()
    for f in (*summary.flags, *summary.notes):
        if f.model == model and f.level == "error":
            codes[f.code] = codes.get(f.code, 0) + 1
            if f.trial:
                trials.add(f.trial)
    return len(trials), codes


def run_fit(results: Path, tmp: Path, name: str, **kw):
    work = copy_results(results, tmp, name)
    c0, w0 = time.process_time(), time.perf_counter()
    summary = fit_study(work, progress=False, **kw)
    print(f"  fit with every variant and leave-one-surface-out: {time.process_time() - c0:.1f} s CPU, "
          f"{time.perf_counter() - w0:.1f} s wall")
    print(f"  --model auto chose: {summary.model}{' (MODEL REJECTED)' if summary.rejected else ''}; "
          f"{summary.selection.reason}")
    return work, summary


# ----------------------------------------------------------------------------- parts


def part_a(results: Path, study: Path, tmp: Path) -> tuple[bool, object, Path]:
    print("\nA. Default (load-consistent) model on the seed-0 study")
    truth, _ = truth_mu(study)
    work, s = run_fit(results, tmp, "a")
    good = s.model == "load" and not s.rejected
    print(f"  the load-sharing world's own variant chosen by --model auto: {verdict(good)}")
    ok = good
    ok &= print_mu(s, truth, 0.01)
    n_bad, codes = unphysical(s, "load")
    good = n_bad == 0
    ok &= good
    print(f"  trial fits failed or unphysical: {n_bad} of {s.n_trials} (error flags {codes or 'none'}): "
          f"{verdict(good)}")
    warn = sorted({f.code for f in s.flags if f.model == "load" and f.level == "warning"})
    info = sorted({f.code for f in s.flags if f.model == "load" and f.level == "info"})
    print(f"  load-model warnings: {warn}; information: {info}")
    t1 = table1_side_by_side(s.table1, 0.75)
    good = t1["load"][1] == t1["load"][2]
    ok &= good
    print(f"  every Table 1 cell rho >= 0.75 (load): {verdict(good)}")
    if s.loso is None:
        print(f"  leave-one-surface-out not computed: {s.loso_message}: FAIL")
        ok = False
    else:
        lo = loso_side_by_side(s.loso, 0.75)
        good = lo["load"][1] == lo["load"][2]
        ok &= good
        print(f"  every held-out surface rho >= 0.75 (load): {verdict(good)}")
    good = s.cpu_s["load"] < 5.0
    ok &= good
    print(f"  CPU of the fit of {s.n_trials} trials: load {s.cpu_s['load']:.2f} s (target < 5 s: "
          f"{verdict(good)}), paper {s.cpu_s['paper']:.2f} s; ratio {s.cpu_s['load'] / s.cpu_s['paper']:.1f}")
    return ok, s, work


def part_b(work: Path) -> None:
    print("\nB. mu from flat ground vs mu refined jointly with the load-bearing contact")
    trials = trials_from_results(work)
    opts = LoadFitOptions()
    for subject in sorted({t.subject for t in trials}):
        ts = [t for t in trials if t.subject == subject]
        c0 = time.process_time()
        flat = fit_load_subject(ts, opts)
        models: dict = {}
        designs = [_LoadDesign(t, opts, models.setdefault(t.surface, FrictionModel(t.surface)))
                   for t in ts if t.has_absolute]
        search = _search_designs(designs, opts.search_trials)

        def total(q, search=search):
            mu, inset, kappa = q
            if not (0.2 < mu < 1.2 and 0 <= inset <= opts.inset_max and 0 <= kappa <= opts.kappa_max):
                return math.inf
            return sum(d.rss(mu, inset, kappa) for d in search)

        x0 = np.array([flat.mu, flat.inset, flat.kappa])
        simplex = np.vstack([x0, x0 + [0.02, 0, 0], x0 + [0, 0.05, 0], x0 + [0, 0, 0.3]])
        res = optimize.minimize(total, x0, method="Nelder-Mead",
                                options={"xatol": 1e-4, "fatol": 1e-9, "maxfev": 400,
                                         "initial_simplex": simplex})
        print(f"  subject {subject}: flat ground mu {flat.mu:.5f} (inset {flat.inset:.3f} mm, kappa "
              f"{flat.kappa:.2f}/mm); jointly fitted mu {res.x[0]:.5f} (inset {res.x[1]:.3f} mm, kappa "
              f"{res.x[2]:.2f}/mm), residual {res.fun / total(x0):.4f} of the flat-ground fit's "
              f"[{time.process_time() - c0:.0f} s CPU]")


def part_c(s) -> None:
    print("\nC. The paper's variant on the same study (first measured: mu 0.900 / 0.900, 73 of 180 "
          "p0 < 0, Bump 2 mm rho 0.51 / 0.60 / 0.57)")
    n_bad, codes = unphysical(s, "paper")
    print(f"  trial fits failed or unphysical: {n_bad} of {s.n_trials} (error flags {codes})")
    t = s.table1[(s.table1.model == "paper") & (s.table1.scale == "2 mm") & (s.table1["shape"] == "Bump")]
    print("  Bump 2 mm rho: " + ", ".join(f"{r.subject} {r.rho:.2f}" for r in t.itertuples()))
    notes = [*s.flags, *s.notes]
    subj = sorted({f.subject for f in notes if f.model == "paper" and f.subject})
    for sub in subj:
        fl = sorted({f.code for f in notes if f.model == "paper" and f.subject == sub and not f.trial})
        print(f"  subject {sub}: subject-level flags {fl}")


def part_c_mu(work: Path) -> None:
    fit = ResultsStore(work).read_fit()
    print("  paper mu: " + ", ".join(f"subject {k} {v:.3f}" for k, v in fit.mu("paper").items()))


def part_d(results: Path, study: Path, tmp: Path) -> bool:
    print("\nD. Realism on (per-trial mu scatter, mu depending on load, normal-force wander)")
    truth, _ = truth_mu(study)
    ok = True
    work, s = run_fit(results, tmp, "d")
    ok &= print_mu(s, truth, 0.05)
    n_bad, codes = unphysical(s, "load")
    print(f"  trial fits failed or unphysical: {n_bad} of {s.n_trials} (error flags {codes or 'none'})")
    t1 = table1_side_by_side(s.table1, 0.70)
    good = t1["load"][1] == t1["load"][2]
    ok &= good
    print(f"  every Table 1 cell rho >= 0.70 (load): {verdict(good)}")
    if s.loso is not None:
        loso_side_by_side(s.loso, 0.75)
    print(f"  CPU: load {s.cpu_s['load']:.2f} s, paper {s.cpu_s['paper']:.2f} s")
    print("  mu per trial (default) vs per subject, Table 1 of the load model:")
    trials = trials_from_results(work)
    for per in ("trial", "subject"):
        fits = {sub: fit_load_subject([t for t in trials if t.subject == sub], LoadFitOptions(mu_per=per))
                for sub in sorted({t.subject for t in trials})}
        tab = correlation_table(fits)
        both = tab[tab.subject == BOTH]
        print(f"    mu per {per:7s}: Table 1 min rho {tab.rho.min():.3f}, median {tab.rho.median():.3f}; "
              f"both subjects min {both.rho.min():.3f}")
    return ok


def part_e() -> bool:
    print("\nE. Synthetic Eq. (4) on the absolute footing, 10 % noise on F_T and F_N "
          "(mu 0.55, p0 0.03 N/mm, p1 0.2 N/mm; 6 surfaces x 2 trials per seed; the fixture's rigid pad\n"
          "  is not force-controlled and its forces are not median-filtered: min_load 0, median kernel 1)")
    ok = True
    for seed in range(4):
        rng = np.random.default_rng(seed)
        trials = [synthetic_trial(s, mu=0.55, p0=0.03, p1=0.2, rng=rng, noise=0.1, absolute=True,
                                  labels={"trial": f"S1-{s}-{r}"}) for s in SURFACE_NAMES for r in range(2)]
        f = fit_load_subject(trials, LoadFitOptions(inset=0.0, kappa=0.0, min_load=0.0, median_kernel=1))
        p1 = np.array([t.p1 for t in f.trials])
        se = np.array([t.p1_se for t in f.trials])
        p0 = np.array([t.p0_mean for t in f.trials])
        rel1 = p1 / 0.2 - 1
        rel0 = p0 / 0.03 - 1
        in_se = float(np.mean(np.abs(p1 - 0.2) <= 1.96 * se))
        good = (abs(f.mu / 0.55 - 1) <= 0.02 and f.mu_ci[0] <= 0.55 <= f.mu_ci[1]
                and np.all(np.abs(rel0) <= 0.02) and abs(rel1.mean()) <= 0.02)
        ok &= good
        print(f"  seed {seed}: mu {f.mu:.5f} ({100 * (f.mu / 0.55 - 1):+.2f} %, CI [{f.mu_ci[0]:.4f}, "
              f"{f.mu_ci[1]:.4f}]); p0 max |error| {100 * np.max(np.abs(rel0)):.2f} %; p1 mean "
              f"{100 * rel1.mean():+.2f} %, median |error| {100 * np.median(np.abs(rel1)):.2f} %, max "
              f"{100 * np.max(np.abs(rel1)):.2f} % (its SE median {100 * np.median(se) / 0.2:.2f} %; "
              f"{100 * in_se:.0f} % of trials within 1.96 SE): {verdict(good)}")
    return ok


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study", type=Path, help="the simulated seed-0 study (truth/; default: simulated "
                    "into benchmarks/out/studies/paper-seed0)")
    ap.add_argument("--results", type=Path, help="its analysed results (default: STUDY-results, analysed "
                    "when missing)")
    ap.add_argument("--realism", action="store_true",
                    help="also part D, on the simulated seed-0 --realism study")
    ap.add_argument("--realism-study", type=Path,
                    help="a seed-0 --realism study of your own (implies --realism)")
    ap.add_argument("--realism-results", type=Path, help="analysed seed-0 --realism study")
    ap.add_argument("--skip-joint", action="store_true", help="skip part B (a few minutes)")
    args = ap.parse_args()
    if args.results is None:
        args.study = args.study or simulated_study("paper-seed0", "--seed", "0")
        args.results = analysed_study(args.study)
    elif args.study is None:
        ap.error("--results needs --study (the simulated study whose truth/ it is compared with)")
    if args.realism or args.realism_study is not None or args.realism_results is not None:
        if args.realism_results is None:
            args.realism_study = (args.realism_study
                                  or simulated_study("realism-seed0", "--seed", "0", "--realism"))
            args.realism_results = analysed_study(args.realism_study)
        elif args.realism_study is None:
            ap.error("--realism-results needs --realism-study")
    ok = True
    with tempfile.TemporaryDirectory(prefix="ff-science-") as tmp:
        tmp = Path(tmp)
        a_ok, s, work = part_a(args.results, args.study, tmp)
        ok &= a_ok
        part_c(s)
        part_c_mu(work)
        if not args.skip_joint:
            part_b(work)
        if args.realism_results is not None:
            ok &= part_d(args.realism_results, args.realism_study, tmp)
        ok &= part_e()
    print(f"\nall acceptance figures met: {verdict(ok)}")


if __name__ == "__main__":
    main()
