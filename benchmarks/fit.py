"""Time to fit the paper's study size: 180 trials x ~2600 positions, mu grid of 61 values.

Closed form (vectorised least squares over the grid; target < 2 s) and Nelder-Mead (one
simplex per trial per grid value, as the paper; target < 30 s). Synthetic trials from
``fingerfriction.testing`` (finger-pad contact changing every frame, Eq. 4 + 10 % noise).
A reference measured in the same run (one ``numpy.linalg.lstsq`` per trial per mu on the
full design, the naive closed form) gives machine-independent ratios. Wall-clock and
process CPU times are both printed: on the shared 2-core machine the wall clock depends on
the other users' load, the CPU time much less.

Run: ``PYTHONPATH=src python benchmarks/fit.py [--reps 5]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from fingerfriction.fit import FitOptions, fit_trials, mu_grid
from fingerfriction.fit.paper import _Design
from fingerfriction.testing import synthetic_trials


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=5, help="repetitions per condition (5 -> 180 trials)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    t0 = time.perf_counter()
    trials, truth = synthetic_trials(reps=args.reps, seed=args.seed)
    t_gen = time.perf_counter() - t0
    n_pos = int(np.mean([t.n for t in trials]))
    grid = mu_grid(0.30, 0.90, 0.01)
    opt = FitOptions()
    print(f"{len(trials)} trials x {n_pos} positions, mu grid of {grid.size} values "
          f"({grid[0]:.2f}..{grid[-1]:.2f}); median kernel {opt.median_kernel} on the basis")
    print(f"synthetic data generation: {t_gen:.2f} s")

    # Reference: the naive closed form, np.linalg.lstsq on the (n, 2) design per trial per mu.
    c0, t0 = time.process_time(), time.perf_counter()
    designs = [_Design(t, opt) for t in trials]
    for d in designs:
        for mu in grid:
            np.linalg.lstsq(d.P @ d.T(mu), d.F, rcond=None)
    t_ref, c_ref = time.perf_counter() - t0, time.process_time() - c0

    c0, t0 = time.process_time(), time.perf_counter()
    res_ls = fit_trials(trials, grid=grid, method="lstsq", options=opt)
    t_ls, c_ls = time.perf_counter() - t0, time.process_time() - c0

    c0, t0 = time.process_time(), time.perf_counter()
    res_nm = fit_trials(trials, grid=grid, method="nelder-mead", options=opt)
    t_nm, c_nm = time.perf_counter() - t0, time.process_time() - c0
    n_nm = sum(len(s.trials) for s in res_nm.values()) * grid.size

    size = f"[{len(trials)} trials x {n_pos} positions x {grid.size} mu]"
    print(f"reference (np.linalg.lstsq per trial per mu): {t_ref:7.2f} s wall, {c_ref:7.2f} s CPU")
    print(f"closed form (lstsq, vectorised over mu):      {t_ls:7.2f} s wall, {c_ls:7.2f} s CPU  "
          f"(target < 2 s; {t_ref / t_ls:.1f}x faster than the reference)  {size}")
    print(f"Nelder-Mead ({n_nm} simplex fits):             {t_nm:7.2f} s wall, {c_nm:7.2f} s CPU  "
          f"(target < 30 s; {t_nm / t_ref:.1f}x the reference)  {size}")
    for s in sorted(res_ls):
        a, b = res_ls[s], res_nm[s]
        dp = max(abs(x.p0 / y.p0 - 1) for x, y in zip(a.trials, b.trials, strict=True))
        print(f"  {s}: true mu {truth['mu'][s]:.2f}; lstsq mu {a.mu:.2f}, Nelder-Mead mu {b.mu:.2f}; "
              f"max |p0_NM / p0_lstsq - 1| = {dp:.1e}; {a.message}")


if __name__ == "__main__":
    main()
