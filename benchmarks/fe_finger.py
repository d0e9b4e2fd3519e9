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
5. Sensitivity (``--only sensitivity``): which FE finger parameters move the 70 um contact
   ends, and how much of the drawn fingers' spread a calibration of 1 to 4 of them can
   absorb. The layered finger of subject 1 (friction 0.55) and the same finger with each
   parameter x 1.25 (the FE calibration's tables: same positions, cells and cache), at 0.34 N
   (one of the calibration's table loads), on the six surfaces; each end of the base
   finger's regions at every position moves by ``dd / sqrt(d'^2 + s_min^2)`` (the
   calibration's end residual, mm). With each parameter's
   log-ratio spread of the drawn fingers (uniform +-25 %, the pulp +-12.5 %), the RMS end
   movement a calibration of a subset cannot absorb (linearised least squares) ranks the
   subsets. Nothing here uses a simulated study: it decides which parameters to fit before
   any data is seen.
6. Mesh (``--only mesh --surfaces step-up-2mm``): the contact tables of subject 1's layered
   finger (friction 0.55, 0.3 N, 0.1 mm steps) on one surface at the coarse mesh of the
   acceptance runs, an intermediate one and the default mesh: blind spots (70 um and p > 0)
   and the per-position contact ends against the default mesh's, with the CPU of each.

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
        state, rows, lf, lb = None, [], [], []
        xs = np.arange(-4.0, 0.01, 0.1)
        for xc in xs:
            sol, state = s.solve(surf, xc, load=0.1, warm=state)
            b = bem.solve(surf, xc, load=0.1)
            _, p = sol.on_grid(bem.grid(xc), 0.1, 10.0)
            lf.append((p > 0).sum())
            lb.append((b.pressure > 0).sum())
            rows.append(lf[-1] / lb[-1] - 1)
        k = int(np.argmax(np.abs(rows)))
        # where the length changes fast (a region lost as the cylinder leaves the flat), a
        # relative length error is a position error: the BEM's length slope turns it into mm
        slope = np.gradient(np.asarray(lb, float) * bem.dx, xs)[k]
        shift = (lf[k] - lb[k]) * bem.dx / slope if slope else float("nan")
        print(f"   {surf.name:22s} (max slope {surf.max_slope_angle():.2f} rad): largest |FE/BEM - 1| over "
              f"{xs.size} positions {abs(rows[k]):.2%} at x = {xs[k]:+.1f} mm (the BEM's length changes "
              f"{slope:+.2f} mm/mm there: {abs(shift) * 1000:.0f} um of position), median "
              f"{np.median(np.abs(rows)):.2%}, within 5 % at {int(np.sum(np.abs(rows) <= 0.05))} of "
              f"{xs.size}")


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


def sensitivity(workers: int) -> None:
    import dataclasses
    import itertools

    from fingerfriction.mechanics.fe import FE_SUBJECTS
    from fingerfriction.mechanics.fe.calibration import (
        FE_FIT_FIELDS,
        FECalibrationOptions,
        FECalibrationProblem,
        fe_tables,
        finger_with,
    )
    from fingerfriction.mechanics.fe.provider import default_cache_dir

    print("5. Sensitivity of the 70 um contact ends to the FE finger's parameters (x 1.25 each, 0.34 N)")
    base = dataclasses.replace(FE_SUBJECTS["1"], friction=0.55)
    opts = FECalibrationOptions()
    hw, u = FECalibrationProblem._grid(base, opts)
    mesh = default_mesh()
    fingers = [base] + [finger_with(base, {f: 1.25}) for f in FE_FIT_FIELDS]
    surfaces = [get_surface(n) for n in SURFACE_NAMES]
    t = time.perf_counter()
    tabs, st = fe_tables(fingers, surfaces, loads=(opts.loads[-1],), half_width=hw, step=opts.step,
                         grid_step=opts.grid_step, mesh=mesh, cache_dir=default_cache_dir(), workers=workers)
    print(f"   mesh {mesh}; {st['solved']} tables solved ({st['cpu_s'] / 60:.1f} min CPU, "
          f"{(time.perf_counter() - t) / 60:.1f} min wall), {st['unconverged']} of {st['positions']} "
          "positions unconverged")
    tol, smin, dlog = GEOMETRIC_TOL, opts.s_min, np.log(1.25)
    rows, per_surface = [], {}
    for surf in surfaces:
        pos, Y0 = tabs[0][surf.name]
        X = pos[:, None] + u[None, :]
        H = surf.h(X)

        def dist(Y, H=H):
            y = Y[0].astype(float)
            sl = np.gradient(y, u[1] - u[0], axis=1)
            return (y - H) / np.sqrt(1 + sl * sl)

        d0 = dist(Y0)
        dk = [dist(tabs[k][surf.name][1]) for k in range(1, len(fingers))]
        s_rows = []
        for i in range(pos.size):
            r = d0[i] - tol
            cross = np.flatnonzero(np.sign(r[:-1]) != np.sign(r[1:]))
            for j in cross:
                f = r[j] / (r[j] - r[j + 1])
                slope = (d0[i, j + 1] - d0[i, j]) / (u[1] - u[0])
                den = np.sqrt(slope * slope + smin * smin)
                dd = [(1 - f) * (d[i, j] - d0[i, j]) + f * (d[i, j + 1] - d0[i, j + 1]) for d in dk]
                s_rows.append([v / den / dlog for v in dd])
        S = np.asarray(s_rows)
        per_surface[surf.name] = np.sqrt(np.mean(S * S, axis=0))
        rows.append(S)
    print("   RMS end movement (mm per unit log-ratio), by surface: "
          + "  ".join(f[:12] for f in FE_FIT_FIELDS))
    for name, v in per_surface.items():
        print(f"   {name:14s} " + "  ".join(f"{x:12.3f}" for x in v))
    S = np.vstack(rows)
    # the drawn fingers' spread of each log-ratio: U(0.75, 1.25), the pulp U(0.875, 1.125)
    sd = np.array([np.std(np.log(np.linspace(1 - s, 1 + s, 10001)))
                   for s in (0.125 if f == "pulp_thickness" else 0.25 for f in FE_FIT_FIELDS)])
    total = float(np.sqrt(np.sum((S * sd) ** 2) / S.shape[0]))
    print(f"   {S.shape[0]} ends; RMS end spread of the drawn fingers (linearised): {total:.3f} mm")
    for k in (1, 2, 3, 4):
        res = []
        for sub in itertools.combinations(range(len(FE_FIT_FIELDS)), k):
            A = S[:, sub]
            P = A @ np.linalg.pinv(A)
            R = S - P @ S
            res.append((float(np.sqrt(np.sum((R * sd) ** 2) / S.shape[0])), sub))
        res.sort()
        best = "; ".join(f"{'+'.join(FE_FIT_FIELDS[i] for i in sub)} {v:.3f} mm" for v, sub in res[:4])
        print(f"   fit {k}: left unexplained (RMS) {best}")


MESHES = {
    "coarse": FEMeshParams(surface_cell=0.4, skin_layers=1, tissue_layers=3, top_cells=8),
    "medium": FEMeshParams(surface_cell=0.2, skin_layers=2, tissue_layers=5, top_cells=16),
    "default": FEMeshParams(),
}


def _ends(regions) -> np.ndarray:
    """First start and last end (mm) of each position's regions, ``(n, 2)`` (NaN: none)."""
    a = np.nanmin(regions[..., 0], axis=1)
    b = np.nanmax(regions[..., 1], axis=1)
    return np.stack([a, b], axis=1)


def mesh_convergence(workers: int, surfaces) -> None:
    import dataclasses

    from fingerfriction.mechanics.fe import FE_SUBJECTS
    from fingerfriction.mechanics.fe.provider import default_cache_dir

    print("6. Mesh convergence of the contact tables (subject 1's layered finger, friction 0.55, 0.3 N)")
    finger = dataclasses.replace(FE_SUBJECTS["1"], friction=0.55)
    for name in surfaces:
        surf = get_surface(name)
        res = {}
        for label, mesh in MESHES.items():
            prov = FEProvider(fingers={"1": finger}, mesh=mesh, cache_dir=default_cache_dir())
            t = time.process_time()
            tab = build_table(surf, "1", loads=(0.3,), step=0.1, provider=prov)
            cpu = time.process_time() - t
            mech, geo = _table_regions(tab, surf)
            res[label] = (geo, mech, cpu, int((~prov.last_ok).sum()) if prov.last_ok is not None else 0,
                          prov.computed)
        ref_geo, ref_mech = res["default"][0], res["default"][1]
        print(f"   {name}: {'mesh':8s} {'CPU s':>7s} {'70 um blind spots':>22s} {'p > 0 blind spots':>22s} "
              f"{'70 um ends vs default: max / RMS (mm)':>38s}")
        for label, (geo, mech, cpu, bad, computed) in res.items():
            d = np.abs(_ends(geo) - _ends(ref_geo))
            d = d[np.isfinite(d)]
            dm = np.abs(_ends(mech) - _ends(ref_mech))
            dm = dm[np.isfinite(dm)]
            src = "" if computed else " (cached)"
            print(f"   {'':{len(name) + 1}s} {label:8s} {cpu:7.1f} {_bs(geo):>22s} {_bs(mech):>22s} "
                  f"{d.max():10.3f} / {np.sqrt(np.mean(d * d)):.3f}  (p > 0: {dm.max():.3f} / "
                  f"{np.sqrt(np.mean(dm * dm)):.3f}){src}, {bad} unconverged")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="coarser meshes (minutes)")
    ap.add_argument("--only", choices=("verify", "friction", "blindspots", "sensitivity", "mesh"),
                    default=None)
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
    if args.only == "sensitivity":
        sensitivity(args.workers)
    if args.only == "mesh":
        mesh_convergence(args.workers, surfaces)
    print(f"   (peak memory {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MB)")


if __name__ == "__main__":
    main()
