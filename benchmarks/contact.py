"""Speed of the BEM contact solver and of warm-started sweeps, against tamaas cold solves.

For grids of 1024 and 4096 cells, prints: the time of one cold solve; the time of a full
sweep of 2601 positions (0.01 mm steps over the 26 mm window on Bump 4 mm) with warm
starts; and tamaas (AGPL peer, imported here only) solving the same problems from scratch
on a subset of the positions (every 26th: 101 positions; the time per position is
scaled), with the ratio per position. tamaas gets the same composite profile on the same
cells in a period of twice the grid (the same FFT size as our zero-padded convolution),
tolerance 1e-10. The agreement of the two pressures on the subset is printed too.

Run: ``PYTHONPATH=src python benchmarks/contact.py``. Timings on a shared machine are
noisy: the ratio measured in the same run is the figure to read.
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


def tamaas_solve(hs: np.ndarray, dx: float, load_per_width: float, modulus: float) -> np.ndarray:
    n = hs.size
    N = 2 * n
    L = N * dx
    model = tm.ModelFactory.createModel(tm.model_type.basic_1d, [L], [N])
    model.E = modulus
    model.nu = 0.0
    surf = np.full(N, hs.min() - 10.0)
    i0 = n // 2
    surf[i0 : i0 + n] = hs
    solver = tm.PolonskyKeerRey(model, np.ascontiguousarray(surf), 1e-10)
    solver.solve(load_per_width / L)
    return np.array(model.traction).ravel()[i0 : i0 + n].copy()


def main() -> None:
    finger = SUBJECTS[1]
    surface = get_surface("bump-4mm")
    positions = default_positions(surface)
    print(f"finger: {finger}")
    print(f"surface: {surface.name}, {positions.size} positions, load 0.3 N, sweep tol 1e-6\n")
    if tm is not None:
        tm.set_log_level(tm.LogLevel.error)
    for n in (1024, 4096):
        solver = ContactSolver(finger, n=n)
        # Cold solves: median over 9 positions.
        cold = []
        for xf in np.linspace(-8, 8, 9):
            t0 = time.perf_counter()
            sol = solver.solve(surface, xf, tol=1e-6)
            cold.append(time.perf_counter() - t0)
            assert sol.success, sol.message
        t_cold = float(np.median(cold))
        t0 = time.perf_counter()
        res = sweep(surface, finger, positions, n=n, tol=1e-6, solver=solver)
        t_sweep = time.perf_counter() - t0
        per_pos = t_sweep / positions.size
        print(f"n = {n}: dx = {solver.dx * 1000:.1f} um, grid half-width {solver.half_width:.2f} mm")
        print(f"  ours  cold solve (median of 9):        {t_cold * 1e3:8.2f} ms")
        print(
            f"  ours  sweep of {positions.size} (warm starts):     {t_sweep:8.2f} s  = "
            f"{per_pos * 1e3:.3f} ms/position, {res.iterations.mean():.1f} CG iterations/position, "
            f"all converged: {res.all_converged}"
        )
        if tm is None:
            print("  tamaas not installed: no reference\n")
            continue
        sub = positions[::26]
        errs = []
        t_tm = 0.0
        for xf in sub:
            sol = solver.solve(surface, xf, tol=1e-10)
            hs = surface.h(sol.x) - solver.outline
            t0 = time.perf_counter()
            pt = tamaas_solve(hs, solver.dx, sol.load_per_width, finger.modulus)
            t_tm += time.perf_counter() - t0
            j = int(np.argmin(np.abs(positions - xf)))
            ours = res.pressure[j] if res.pressure is not None else None
            if ours is None:
                ours = solver.solve(surface, xf, tol=1e-6).pressure
            errs.append(np.max(np.abs(ours - pt)) / pt.max())
        tm_per = t_tm / sub.size
        print(
            f"  tamaas cold, {sub.size} of the positions:       {t_tm:8.2f} s  = "
            f"{tm_per * 1e3:.3f} ms/position (x {positions.size} = {tm_per * positions.size:.1f} s "
            "for the sweep)"
        )
        print(f"  ratio tamaas cold / ours warm per position: {tm_per / per_pos:6.1f}x")
        print(f"  ours cold / tamaas cold per solve:          {t_cold / tm_per:6.2f}")
        print(
            f"  pressure agreement on the subset (ours sweep tol 1e-6 vs tamaas 1e-10, periodic 2x): "
            f"max |dp| / peak = {max(errs):.2e}\n"
        )


if __name__ == "__main__":
    main()
