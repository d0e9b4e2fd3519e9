"""Speed of the BEM contact solver and of warm-started sweeps, against tamaas cold solves.

For grids of 1024 and 4096 cells (finger: SUBJECTS[1]; surface: Bump 4 mm; 0.3 N):

* ours, cold: the median time of one solve from scratch (tol 1e-8);
* ours, sweep: 2601 positions at 0.01 mm steps over the 26 mm window, warm starts,
  sweep tolerance 1e-6, and its accuracy: the largest pressure error over 101 of the
  positions (every 26th) against our own tightly converged cold solve (tol 1e-12),
  relative to the peak pressure;
* tamaas (AGPL peer, imported here only) solving the same 101 positions from scratch, at
  several of its tolerances; each tamaas accuracy is measured against its own 1e-12
  solution, so both solvers are judged on how well they solve *their* discretised problem.
  tamaas gets the same composite profile ``h - s`` on the same cells in a period of twice
  the grid (the same FFT size as our zero-padded convolution). Its time per position is
  the subset's mean (101 positions, scaled to 2601 for the sweep figure).

The ratio printed per tamaas tolerance is tamaas' cold time per position over our warm
sweep time per position; "matched accuracy" is the loosest tamaas tolerance whose error is
no larger than our sweep's. Timings on a shared machine are noisy: read the ratios.

Run: ``PYTHONPATH=src python benchmarks/contact.py``.
"""

from __future__ import annotations

import time

import numpy as np

from fingerfriction.mechanics import SUBJECTS, ContactSolver, default_positions, sweep
from fingerfriction.surfaces import get_surface

try:
    import tamaas as tm
except ImportError:  # pragma: no cover - tamaas is a test extra
    tm = None


def tamaas_solve(hs: np.ndarray, dx: float, load_per_width: float, modulus: float, tol: float):
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
    t0 = time.perf_counter()
    solver.solve(load_per_width / L)
    dt = time.perf_counter() - t0
    return np.array(model.traction).ravel()[i0 : i0 + n].copy(), dt


def main() -> None:
    finger = SUBJECTS[1]
    surface = get_surface("bump-4mm")
    positions = default_positions(surface)
    sub_idx = np.arange(0, positions.size, 26)
    print(f"finger: {finger}")
    print(f"surface: {surface.name}, {positions.size} positions, load 0.3 N\n")
    if tm is not None:
        tm.set_log_level(tm.LogLevel.error)
    for n in (1024, 4096):
        solver = ContactSolver(finger, n=n)
        cold = []
        for xf in np.linspace(-8, 8, 9):
            t0 = time.perf_counter()
            sol = solver.solve(surface, xf, tol=1e-8)
            cold.append(time.perf_counter() - t0)
            assert sol.success, sol.message
        t_cold = float(np.median(cold))
        t0 = time.perf_counter()
        res = sweep(surface, finger, positions, tol=1e-6, solver=solver, keep_profiles=True)
        t_sweep = time.perf_counter() - t0
        per_pos = t_sweep / positions.size
        errs = []
        for i in sub_idx:
            ref = solver.solve(surface, positions[i], tol=1e-12, max_iter=5000).pressure
            errs.append(np.max(np.abs(res.pressure[i] - ref)) / ref.max())
        our_err = float(max(errs))
        print(f"n = {n}: dx = {solver.dx * 1000:.1f} um, grid half-width {solver.half_width:.2f} mm")
        print(f"  ours   cold solve, tol 1e-8 (median of 9):  {t_cold * 1e3:8.2f} ms")
        print(
            f"  ours   sweep of {positions.size}, warm, tol 1e-6:     {t_sweep:8.2f} s = "
            f"{per_pos * 1e3:.3f} ms/position; {res.iterations.mean():.1f} CG iterations/position; "
            f"all converged: {res.all_converged}; max |dp|/peak = {our_err:.1e}"
        )
        if tm is None:
            print("  tamaas not installed: no reference\n")
            continue
        refs = {}
        for i in sub_idx:
            x = solver.grid(positions[i])
            hs = surface.h(x) - solver.outline
            refs[i] = (hs, tamaas_solve(hs, solver.dx, res.load / finger.width, finger.modulus, 1e-12)[0])
        matched = None
        for tol in (1e-4, 1e-6, 1e-8, 1e-10):
            t_tm = 0.0
            err = 0.0
            for i in sub_idx:
                hs, pref = refs[i]
                pt, dt = tamaas_solve(hs, solver.dx, res.load / finger.width, finger.modulus, tol)
                t_tm += dt
                err = max(err, float(np.max(np.abs(pt - pref)) / pref.max()))
            tm_per = t_tm / sub_idx.size
            ratio = tm_per / per_pos
            if matched is None and err <= our_err:
                matched = (tol, ratio)
            print(
                f"  tamaas cold, tol {tol:.0e}, {sub_idx.size} positions: {tm_per * 1e3:8.3f} ms/position "
                f"({tm_per * positions.size:6.1f} s per sweep); max |dp|/peak = {err:.1e}; "
                f"ratio tamaas/ours-warm = {ratio:5.1f}x; ours cold / tamaas = {t_cold / tm_per:4.2f}"
            )
        if matched:
            print(
                f"  at matched accuracy (tamaas tol {matched[0]:.0e}): "
                f"ours warm is {matched[1]:.1f}x faster\n"
            )
        else:
            print("  no tamaas tolerance tried was as loose as our sweep's accuracy\n")


if __name__ == "__main__":
    main()
