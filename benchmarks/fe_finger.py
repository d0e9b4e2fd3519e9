"""The layered finite-element finger: verification, friction coupling, blind
spots on the paper's surfaces, and the cost of its contact tables.

Sections (each prints measured figures; nothing is asserted):

1. Verification. A homogeneous cylinder (R = 8 mm, E = 0.1 MPa, nu = 0.45, a small rigid
   core) at a small load (a / R = 0.1) against plane-strain Hertz (mechanics/hertz.py) at
   three meshes; the layered finger's flat contact length at 0.3 N at two meshes; the
   homogeneous cylinder against the BEM half-space (mechanics/bem.py) along a slide over a
   shallow bump (small strains) and over the paper's Bump 4 mm.
2. Friction's tangential coupling: a sliding Coulomb traction (mu = 0.6, the paper's
   aluminium figure) applied to the layered finger, against the frictionless contact.
3. Blind spots of the literature finger (docs/mechanics-fe.md) on the six paper surfaces at
   0.3 N, 0.1 mm finger steps: the 70 um geometric criterion of the paper and p > 0, beside
   the paper's figures.
4. Cost: the contact tables of one finger (6 surfaces x 3 loads, 0.1 mm steps) on two
   worker processes from an empty cache, then again from the cache.

Run: ``PYTHONPATH=src python benchmarks/fe_finger.py`` (about half an hour on 2 cores;
``--only SECTION`` runs one section, ``--workers 1`` the tables in this process;
``--quick`` runs coarser meshes; ``$FINGERFRICTION_FE_MESH`` sets the mesh of sections 3-4).
Outputs (the cache) go to ``benchmarks/out/fe``.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from fingerfriction.mechanics import ContactSolver, FingerParams
from fingerfriction.mechanics.bem import GEOMETRIC_TOL
from fingerfriction.mechanics.fe import (
    LITERATURE_FINGER,
    FEContactSolver,
    FEFingerParams,
    FEMeshParams,
    FEProvider,
)
from fingerfriction.mechanics.fe.provider import default_mesh
from fingerfriction.mechanics.hertz import hertz_half_width, hertz_peak_pressure
from fingerfriction.model.blindspots import blind_spots
from fingerfriction.regions import regions_from_mask
from fingerfriction.sim.contact import build_table
from fingerfriction.surfaces import SURFACE_NAMES, RaisedCosine, get_surface

OUT = Path(__file__).resolve().parent / "out" / "fe"
CYLINDER = FEFingerParams(radius=8.0, semi_height=8.0, tissue_modulus=0.1, skin_modulus=0.1,
                          skin_thickness=0.5, poisson=0.45, bone_half_width=1.0, bone_half_height=1.0,
                          pulp_thickness=7.0, nail_modulus=0.1, name="cylinder")
PAPER = {"step-up-2mm": "0.47", "bump-4mm": "1.71-2.6"}
LOADS = (0.22, 0.3, 0.38)


def _flat(x):
    return np.zeros_like(np.asarray(x, float))


def _edges(x, p):
    """Contact edges (mm) of the outermost pressure points, ``p^2`` extrapolated to 0
    (``p ~ sqrt(distance)`` at a smooth contact edge)."""
    i = np.flatnonzero(p > 0)

    def ext(i1, i0):
        q1, q0 = p[i1] ** 2, p[i0] ** 2
        return x[i1] + (x[i1] - x[i0]) * q1 / (q0 - q1) if q0 != q1 else x[i1]

    return ext(i[0], i[1]), ext(i[-1], i[-2])


def verification(quick: bool) -> None:
    print("1. Verification")
    P = 0.0079
    Es = CYLINDER.plane_strain_modulus()
    a_h, p_h = hertz_half_width(P, 8.0, Es), hertz_peak_pressure(P, 8.0, Es)
    print(f"   Hertz (plane strain): P' = {P} N/mm, R = 8 mm, E* = {Es:.4f} MPa: a = {a_h:.4f} mm, "
          f"p0 = {p_h * 1e3:.3f} kPa")
    print(f"   {'surface cell':>12s} {'dofs':>7s} {'a (mm)':>8s} {'err':>7s} {'p0 (kPa)':>9s} {'err':>7s} "
          f"{'length change':>13s} {'time':>6s}")
    prev = None
    for f in ((1, 2) if quick else (1, 2, 4)):
        mp = FEMeshParams(surface_cell=0.08 / f, contact_half_width=2.0, skin_layers=2 * f,
                          tissue_layers=8 * f, top_cells=16 * f)
        t = time.perf_counter()
        s = FEContactSolver(CYLINDER, mp)
        sol, _ = s.solve(_flat, 0.0, load=P * CYLINDER.width)
        dt = time.perf_counter() - t
        xl, xr = _edges(sol.outline_x, sol.outline_pressure)
        a = 0.5 * (xr - xl)
        xg = np.linspace(-2 * a_h, 2 * a_h, 4001)
        _, pg = sol.on_grid(xg, P * CYLINDER.width, CYLINDER.width)
        ch = "" if prev is None else f"{a / prev - 1:+.2%}"
        print(f"   {mp.surface_cell:12.3f} {s.n_dof:7d} {a:8.4f} {a / a_h - 1:+7.2%} {pg.max() * 1e3:9.3f} "
              f"{pg.max() / p_h - 1:+7.2%} {ch:>13s} {dt:5.1f}s  {sol.message}")
        prev = a
    print("   layered literature finger on flat ground at 0.3 N (contact length p > 0 and within 70 um):")
    prev = None
    for f in ((1,) if quick else (1, 2)):
        mp = FEMeshParams().refined(f)
        s = FEContactSolver(LITERATURE_FINGER, mp)
        t = time.perf_counter()
        sol, _ = s.solve(_flat, 0.0, load=0.3)
        xl, xr = _edges(sol.outline_x, sol.outline_pressure)
        g = sol.outline_x[sol.outline_y <= GEOMETRIC_TOL]
        L = xr - xl
        ch = "" if prev is None else f", change {L / prev - 1:+.2%}"
        print(f"   surface cell {mp.surface_cell:.3f} mm, {s.n_dof} dofs: p > 0 {L:.3f} mm, 70 um "
              f"{g.max() - g.min():.3f} mm{ch} ({time.perf_counter() - t:.1f} s)")
        prev = L
    print("   homogeneous cylinder vs BEM half-space (same E*), contact length p > 0, 0.1 N:")
    bem = ContactSolver(FingerParams(radius=8.0, modulus=Es, width=10.0), n=2048, half_width=4.0)
    for surf in (RaisedCosine("bump", 4.0, height=0.2, name="bump 4 mm x 0.2 mm"), get_surface("bump-4mm")):
        s = FEContactSolver(CYLINDER, FEMeshParams(surface_cell=0.04, contact_half_width=3.5, skin_layers=2,
                                                   tissue_layers=12, top_cells=24))
        state, worst, rows = None, 0.0, []
        for xc in np.arange(-4.0, 0.01, 0.1):
            sol, state = s.solve(surf, xc, load=0.1, warm=state)
            b = bem.solve(surf, xc, load=0.1)
            _, p = sol.on_grid(bem.grid(xc), 0.1, 10.0)
            r = (p > 0).sum() / (b.pressure > 0).sum() - 1
            worst = max(worst, abs(r))
            rows.append(r)
        print(f"   {surf.name:22s} (max slope {surf.max_slope_angle():.2f} rad): largest |FE/BEM - 1| over "
              f"41 positions {worst:.2%}, median {np.median(np.abs(rows)):.2%}")


def _table_regions(table, surface, j=0, tol=GEOMETRIC_TOL):
    """Mechanical and geometric contact regions per tabulated position (region format)."""
    geo, mech = [], []
    dx = float(table.xi[1] - table.xi[0])
    for i, xc in enumerate(table.positions):
        x = xc + table.xi
        gap = table.y_f[j, i].astype(float) - surface.h(x)
        for out, m in ((geo, gap <= tol), (mech, table.p[j, i] > 0)):
            r = regions_from_mask(x, m)[0] if m.any() else np.full((1, 2), np.nan)
            out.append(r)
    del dx

    def pad(rows):
        k = max(r.shape[0] for r in rows)
        a = np.full((len(rows), k, 2), np.nan)
        for i, r in enumerate(rows):
            a[i, : r.shape[0]] = r
        return a

    return pad(mech), pad(geo)


def _bs(regions) -> str:
    w = blind_spots(regions, min_width=0.05).widths
    return ", ".join(f"{v:.2f}" for v in w) if w.size else "none"


def friction(quick: bool) -> None:
    print("2. Friction's tangential coupling (sliding traction mu p against the motion, mu = 0.6)")
    mp = FEMeshParams(surface_cell=0.2) if quick else FEMeshParams()
    s = FEContactSolver(LITERATURE_FINGER, mp)
    for mu in (0.0, 0.6):
        sol, _ = s.solve(_flat, 0.0, load=0.3, friction=mu)
        xl, xr = _edges(sol.outline_x, sol.outline_pressure)
        g = sol.outline_x[sol.outline_y <= GEOMETRIC_TOL]
        print(f"   flat, mu = {mu}: p > 0 [{xl:+.3f}, {xr:+.3f}] mm (length {xr - xl:.3f}), 70 um "
              f"[{g.min():+.3f}, {g.max():+.3f}] mm  {sol.message}")
    surf = get_surface("step-up-2mm")
    res = {}
    for mu in (0.0, 0.6):
        prov = FEProvider(mesh=mp, cache_dir=False, friction=mu)
        tab = build_table(surf, "1", loads=(0.3,), step=0.1, provider=prov)
        mech, geo = _table_regions(tab, surf)
        res[mu] = (_bs(geo), _bs(mech))
    print(f"   Step Up 2 mm blind spots (70 um | p > 0), mm: mu = 0: {res[0.0][0]} | {res[0.0][1]}; "
          f"mu = 0.6: {res[0.6][0]} | {res[0.6][1]}")


def _one_table(args):
    name, load, mesh, cache = args
    prov = FEProvider(mesh=mesh, cache_dir=cache)
    t = time.process_time()
    tab = build_table(get_surface(name), "1", loads=(load,), step=0.1, provider=prov)
    print(f"   table {name} {load} N: {time.process_time() - t:.1f} s CPU, {tab.positions.size} positions, "
          f"{prov.failures} not converged", flush=True)
    return name, load, tab, time.process_time() - t, prov.failures


def _map(jobs, workers):
    if workers == 1:
        return [_one_table(j) for j in jobs]
    with ProcessPoolExecutor(workers) as ex:
        return list(ex.map(_one_table, jobs))


def blind_spots_and_cost(quick: bool, workers: int = 2, loads=LOADS, surfaces=SURFACE_NAMES) -> None:
    mesh = FEMeshParams(surface_cell=0.2) if quick else default_mesh()
    print(f"   mesh: {mesh}")
    cache = OUT / "cache"
    shutil.rmtree(cache, ignore_errors=True)
    jobs = [(n, f, mesh, cache) for n in surfaces for f in loads]
    t = time.perf_counter()
    out = _map(jobs, workers)
    wall = time.perf_counter() - t
    cpu = sum(o[3] for o in out)
    fails = sum(o[4] for o in out)
    print("3. Blind spots of the layered literature finger at 0.3 N (0.1 mm steps; widths >= 0.05 mm)")
    print(f"   finger: {LITERATURE_FINGER}")
    print(f"   {'surface':14s} {'70 um (mm)':>22s} {'p > 0 (mm)':>22s} {'paper (3 px)':>13s}")
    for name, load, tab, _, _ in out:
        if load != 0.3:
            continue
        surf = get_surface(name)
        mech, geo = _table_regions(tab, surf)
        print(f"   {name:14s} {_bs(geo):>22s} {_bs(mech):>22s} {PAPER.get(name, '-'):>13s}")
    print(f"4. Cost of the contact tables of one finger ({len(surfaces)} surfaces x {len(loads)} loads, "
          f"0.1 mm steps, {workers} worker(s))")
    for name, load, _, cpu_one, bad in out:
        print(f"   {name:14s} {load:.2f} N: {cpu_one:6.1f} s CPU" + (f", {bad} not converged" if bad else ""))
    print(f"   from an empty cache: {wall / 60:.1f} min wall, {cpu / 60:.1f} min CPU in the workers "
          f"({fails} positions did not converge)")
    t, c = time.perf_counter(), time.process_time()
    _map(jobs, workers)
    print(f"   again, from the cache: {time.perf_counter() - t:.1f} s wall"
          + (f", {time.process_time() - c:.1f} s CPU" if workers == 1 else ""))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="coarser meshes (minutes)")
    ap.add_argument("--only", choices=("verify", "friction", "blindspots"), default=None)
    ap.add_argument("--workers", type=int, default=2, help="processes for the tables of sections 3-4 "
                    "(1: in this process; the CPU figure does not depend on it)")
    ap.add_argument("--loads", default=",".join(map(str, LOADS)),
                    help="normal loads in N of the tables of sections 3-4 (comma list; 0.3: the blind spots)")
    ap.add_argument("--surfaces", default=",".join(SURFACE_NAMES),
                    help="surfaces of sections 3-4 (comma list)")
    args = ap.parse_args()
    loads = tuple(float(v) for v in args.loads.split(","))
    surfaces = tuple(args.surfaces.split(","))
    for n in surfaces:
        if n not in SURFACE_NAMES:
            ap.error(f"--surfaces: unknown surface {n!r}; known: {', '.join(SURFACE_NAMES)}")
    if args.workers < 1:
        ap.error(f"--workers must be >= 1, got {args.workers}")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    OUT.mkdir(parents=True, exist_ok=True)
    if args.only in (None, "verify"):
        verification(args.quick)
    if args.only in (None, "friction"):
        friction(args.quick)
    if args.only in (None, "blindspots"):
        blind_spots_and_cost(args.quick, args.workers, loads, surfaces)
    print(f"   (peak memory {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB)")


if __name__ == "__main__":
    main()
