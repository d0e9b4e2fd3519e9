"""Speed of the BEM contact solver and of warm-started sweeps, against tamaas cold solves.

For grids of 1024 and 4096 cells (finger: SUBJECTS[1]; surface: Bump 4 mm; 0.3 N):

* ours, cold: the median time of one solve from scratch (tol 1e-8);
* ours, sweep: 2601 positions at 0.01 mm steps over the 26 mm window, warm starts,
  sweep tolerance 1e-6 (the :func:`~fingerfriction.mechanics.sweep` default), and its
  accuracy: the largest pressure error over 101 of the positions (every 26th) against our
  own tightly converged cold solve (tol 1e-12), relative to the peak pressure;
* tamaas (AGPL peer, imported here only) solving the same 101 positions from scratch, at
  several of its tolerances (``PolonskyKeerRey`` has no default tolerance: it is a
  required argument; we try 1e-4 to 1e-10); each tamaas accuracy is measured against its own 1e-12
  solution, so both solvers are judged on how well they solve *their* discretised
  problem. tamaas gets the same composite profile ``h - s`` on the same cells in a period
  of twice the grid (the same FFT size as our zero-padded convolution). Only its
  ``solve()`` call is timed (not the model set-up), our sweep is timed whole (regions,
  gaps and all).

Fairness under noise (2 shared cores): the measurements are interleaved in rounds, each
round timing our full sweep and then tamaas on the 101 positions at every tolerance, and
the ratio is taken per round (median over rounds). Wall and CPU (process) times are both
printed; the machine's load average is printed at the start of each round. The ratio
printed per tamaas tolerance is tamaas' cold time per position over our warm sweep time
per position; "matched accuracy" is the loosest tamaas tolerance whose error is no larger
than our sweep's.

Run: ``PYTHONPATH=src python benchmarks/contact.py [--rounds 3] [--grids 1024 4096]``.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

from fingerfriction.mechanics import SUBJECTS, ContactSolver, default_positions, sweep
from fingerfriction.surfaces import get_surface

try:
    import tamaas as tm
except ImportError:  # pragma: no cover - tamaas is a test extra
    tm = None

TAMAAS_TOLS = (1e-4, 1e-6, 1e-8, 1e-10)


def load_avg() -> str:
    a, b, c = os.getloadavg()
    return f"load avg {a:.1f} {b:.1f} {c:.1f}"


def tamaas_solve(hs: np.ndarray, dx: float, load_per_width: float, modulus: float, tol: float):
    """tamaas cold solve of ``h - s`` on our cells; returns (pressure, wall s, cpu s)."""
    n = hs.size
    N = 2 * n
    L = N * dx
    model = tm.ModelFactory.createModel(tm.model_type.basic_1d, [L], [N])
    model.E = modulus
    model.nu = 0.0
    surf = np.full(N, hs.min() - 10.0)
    i0 = n // 2
    surf[i0 : i0 + n] = hs
    solver = tm.PolonskyKeerRey(model, np.ascontiguousarray(surf), tol)
    t0, c0 = time.perf_counter(), time.process_time()
    solver.solve(load_per_width / L)
    dt, dc = time.perf_counter() - t0, time.process_time() - c0
    return np.array(model.traction).ravel()[i0 : i0 + n].copy(), dt, dc


def run_grid(n: int, rounds: int) -> None:
    finger = SUBJECTS[1]
    surface = get_surface("bump-4mm")
    positions = default_positions(surface)
    sub_idx = np.arange(0, positions.size, 26)
    solver = ContactSolver(finger, n=n)
    solver.solve(surface, 0.0)  # compile / cache warm-up, not timed
    cold = []
    for xf in np.linspace(-8, 8, 9):
        t0 = time.perf_counter()
        sol = solver.solve(surface, xf, tol=1e-8)
        cold.append(time.perf_counter() - t0)
        assert sol.success, sol.message
    t_cold = float(np.median(cold))
    print(f"n = {n}: dx = {solver.dx * 1000:.1f} um, grid half-width {solver.half_width:.2f} mm")
    print(f"  ours   cold solve, tol 1e-8 (median of 9):  {t_cold * 1e3:8.2f} ms")
    P = 0.3 / finger.width
    refs = {}
    if tm is not None:
        for i in sub_idx:
            hs = surface.h(solver.grid(positions[i])) - solver.outline
            refs[i] = (hs, tamaas_solve(hs, solver.dx, P, finger.modulus, 1e-12)[0])
    ratios: dict[float, list[tuple[float, float]]] = {tol: [] for tol in TAMAAS_TOLS}
    tm_errs: dict[float, float] = {}
    ours = []
    res = None
    for k in range(rounds):
        print(f"  round {k + 1}/{rounds} ({load_avg()})")
        t0, c0 = time.perf_counter(), time.process_time()
        res = sweep(surface, finger, positions, tol=1e-6, solver=solver, keep_profiles=True)
        t_sweep, c_sweep = time.perf_counter() - t0, time.process_time() - c0
        per_pos, per_cpu = t_sweep / positions.size, c_sweep / positions.size
        ours.append((t_sweep, c_sweep))
        print(
            f"    ours   sweep of {positions.size}, warm, tol 1e-6: {t_sweep:6.2f} s wall "
            f"({c_sweep:5.2f} s CPU) = {per_pos * 1e3:.3f} ms/position wall, "
            f"{per_cpu * 1e3:.3f} ms CPU; {res.iterations.mean():.1f} CG it/position; "
            f"all converged: {res.all_converged}"
        )
        if tm is None:
            continue
        for tol in TAMAAS_TOLS:
            t_tm = c_tm = err = 0.0
            for i in sub_idx:
                hs, pref = refs[i]
                pt, dt, dc = tamaas_solve(hs, solver.dx, P, finger.modulus, tol)
                t_tm += dt
                c_tm += dc
                err = max(err, float(np.max(np.abs(pt - pref)) / pref.max()))
            tm_errs[tol] = err
            tw, tc = t_tm / sub_idx.size, c_tm / sub_idx.size
            ratios[tol].append((tw / per_pos, tc / per_cpu))
            print(
                f"    tamaas cold, tol {tol:.0e}, {sub_idx.size} positions: {tw * 1e3:7.3f} ms/position wall "
                f"({tc * 1e3:7.3f} CPU; {tw * positions.size:5.1f} s per sweep); "
                f"ratio tamaas/ours-warm {tw / per_pos:5.1f}x wall, {tc / per_cpu:5.1f}x CPU"
            )
    errs = []
    for i in sub_idx:
        ref = solver.solve(surface, positions[i], tol=1e-12, max_iter=5000).pressure
        errs.append(np.max(np.abs(res.pressure[i] - ref)) / ref.max())
    our_err = float(max(errs))
    best = min(ours)
    print(
        f"  summary n = {n}: ours sweep best of {rounds}: {best[0]:.2f} s wall ({best[1]:.2f} s CPU), "
        f"{best[0] / positions.size * 1e3:.3f} ms/position; accuracy max |dp|/peak = {our_err:.1e} "
        f"(vs our tol-1e-12 solve, {sub_idx.size} positions)"
    )
    if tm is None:
        print("  tamaas not installed: no reference\n")
        return
    matched = None
    for tol in TAMAAS_TOLS:
        rw = float(np.median([r[0] for r in ratios[tol]]))
        rc = float(np.median([r[1] for r in ratios[tol]]))
        if matched is None and tm_errs[tol] <= our_err:
            matched = (tol, rw, rc)
        print(
            f"    tamaas tol {tol:.0e}: max |dp|/peak = {tm_errs[tol]:.1e}; median ratio tamaas/ours "
            f"{rw:5.1f}x wall, {rc:5.1f}x CPU"
        )
    if matched:
        print(
            f"  at matched accuracy (tamaas tol {matched[0]:.0e}): ours warm is {matched[1]:.1f}x faster "
            f"per position (wall), {matched[2]:.1f}x (CPU)\n"
        )
    else:
        print("  no tamaas tolerance tried was as loose as our sweep's accuracy\n")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3, help="interleaved rounds per grid (default 3)")
    ap.add_argument("--grids", type=int, nargs="+", default=[1024, 4096], help="grid sizes")
    args = ap.parse_args()
    finger = SUBJECTS[1]
    print(f"finger: {finger}")
    print(f"surface: bump-4mm, 2601 positions, load 0.3 N; {load_avg()}; {os.cpu_count()} CPUs\n")
    if tm is not None:
        tm.set_log_level(tm.LogLevel.error)
    for n in args.grids:
        run_grid(n, args.rounds)


if __name__ == "__main__":
    main()
