"""Benchmark of the virtual experiment: seconds and bytes per trial, video encoders.

Run: ``PYTHONPATH=src python benchmarks/simulate.py [--trials N] [--out DIR]``

Prints, measured in this run:

* a reference workload (sorting 2e6 floats) so figures can be compared across machines
  and loads (the ratio column);
* the CPU and wall time of one contact table (the default BEM contact model);
* per trial (bump-4mm, subject 1, the three paper speeds): frames, CPU and wall seconds,
  bytes on disk of the video, force and truth files;
* the two lossless video formats on the same rendered frames (bytes/frame, ms/frame),
  and the cost of sensor read noise in bytes/frame;
* the extrapolated full 180-trial study: frames (from the planned kinematics of all 180
  trials), CPU time, and wall time on 2 workers (CPU time / 2, assuming two free cores);
* the worlds and chains: the same three trials simulated in every world with the
  realistic chain and in today's default path (load-sharing world, ideal chain), rounds
  interleaved and the fastest of each kept, CPU per trial and the ratio to the default path
  (accepted: at most 1.2); and the share of a contact table spent on the worlds' extra
  integrals.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np


def _reference() -> float:
    rng = np.random.default_rng(0)
    a = rng.random(2_000_000)
    t = time.process_time()
    for _ in range(3):
        np.sort(a)
    return (time.process_time() - t) / 3


def _encode(frames, fmt: str, **camkw) -> tuple[float, float]:
    from fingerfriction.video.writers import VideoWriter

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / ("v.mkv" if fmt == "ffv1-mkv" else "v.tif")
        t = time.process_time()
        w = VideoWriter(p, fmt, 1280, 720, 1000.0)
        for f in frames:
            w.write(f)
        w.close()
        dt = time.process_time() - t
        return os.path.getsize(p) / len(frames), dt / len(frames)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--keep", help="keep the benchmark study in this folder")
    args = ap.parse_args()

    from fingerfriction.sim import SimOptions
    from fingerfriction.sim.camera import Camera, CameraParams
    from fingerfriction.sim.contact import build_table
    from fingerfriction.sim.physics import SUBJECT_FORCE_LAWS
    from fingerfriction.sim.writer import plan_trial, simulate_trial
    from fingerfriction.surfaces import get_surface

    ref = _reference()
    print(f"reference (np.sort of 2e6 floats, CPU): {ref * 1e3:.1f} ms")
    surf = get_surface("bump-4mm")
    opts = SimOptions(reps=1, subjects=("1",), surfaces=("bump-4mm",))

    t0, w0 = time.process_time(), time.perf_counter()
    table = build_table(surf, "1", loads=opts.table_loads, step=opts.table_step)
    t_tab, w_tab = time.process_time() - t0, time.perf_counter() - w0
    print(f"contact table bump-4mm s1 ({table.positions.size} positions x {table.loads.size} loads, "
          f"{table.provider}): CPU {t_tab:.1f} s, wall {w_tab:.1f} s  (ratio to reference {t_tab / ref:.0f})")

    root = Path(args.keep) if args.keep else Path(tempfile.mkdtemp(prefix="ffsim-bench-"))
    root.mkdir(parents=True, exist_ok=True)
    rows = []
    cpu_per_frame = []
    try:
        for spec in opts.trial_specs():
            plan = plan_trial(spec, opts)
            t0, w0 = time.process_time(), time.perf_counter()
            rec = simulate_trial(plan, opts, table, SUBJECT_FORCE_LAWS["1"], root)
            cpu, wall = time.process_time() - t0, time.perf_counter() - w0
            sizes = [os.path.getsize(root / p) for p in (rec.video.path, rec.force.path, rec.truth)]
            rows.append((spec.id, rec.video.n_frames, cpu, wall, *sizes))
            cpu_per_frame.append(cpu / rec.video.n_frames)
        print("\nper trial (serial, this process):")
        print(f"{'trial':24s} {'frames':>6s} {'CPU s':>6s} {'wall s':>6s} {'video MB':>8s} {'force kB':>8s} "
              f"{'truth kB':>8s} {'B/frame':>8s}")
        for tid, nf, cpu, wall, v, f, tr in rows:
            print(f"{tid:24s} {nf:6d} {cpu:6.2f} {wall:6.2f} {v / 1e6:8.2f} {f / 1e3:8.1f} {tr / 1e3:8.1f} "
                  f"{v / nf:8.0f}")
        nf = sum(r[1] for r in rows)
        tot = sum(sum(r[4:]) for r in rows)
        mean_cpu = np.mean([r[2] for r in rows])
        print(f"mean: {mean_cpu:.2f} s CPU per trial, {tot / len(rows) / 1e6:.2f} MB per trial, "
              f"{sum(r[4] for r in rows) / nf:.0f} video bytes per frame")

        # encoders on the same frames
        cam = Camera(surf)
        rng = np.random.default_rng(0)
        frames = [cam.render(cam.finger_rows(x, table.xi, table.profile(x, 0.3)[0]), rng)
                  for x in np.linspace(-8, 8, 60)]
        print("\nlossless video formats, 60 frames of this trial (CPU per frame):")
        for fmt in ("ffv1-mkv", "tiff"):
            b, s = _encode(frames, fmt)
            print(f"  {fmt:9s} {b / 1e3:7.1f} kB/frame  {s * 1e3:6.2f} ms/frame")
        noisy = Camera(surf, CameraParams(read_noise=0.3, dark=3.0))
        nframes = [noisy.render(noisy.finger_rows(x, table.xi, table.profile(x, 0.3)[0]), rng)
                   for x in np.linspace(-8, 8, 20)]
        b, s = _encode(nframes, "ffv1-mkv")
        print(f"  ffv1-mkv with read noise 0.3 DN on a 3 DN black level: {b / 1e3:.1f} kB/frame "
              f"({s * 1e3:.2f} ms/frame)")

        # extrapolation to the full design
        full = SimOptions()
        frames_full = sum(plan_trial(s, full).record.video.n_frames for s in full.trial_specs())
        cpf = float(np.mean(cpu_per_frame))
        cpu_full = frames_full * cpf + 12 * t_tab
        disk = frames_full * sum(r[4] for r in rows) / nf + 180 * sum(r[5] + r[6] for r in rows) / len(rows)
        print(f"\nfull study (180 trials): {frames_full} frames; CPU {frames_full * cpf:.0f} s for trials + "
              f"{12 * t_tab:.0f} s for 12 contact tables = {cpu_full:.0f} s;")
        print(f"  on 2 workers ~{cpu_full / 2:.0f} s ({cpu_full / 2 / 60:.1f} min) if both cores are free; "
              f"disk ~{disk / 1e9:.2f} GB")
        print(f"ratio (CPU per frame / reference): {cpf / ref:.3f}")
        _worlds(table, surf, root)
    finally:
        if not args.keep:
            shutil.rmtree(root, ignore_errors=True)


def _worlds(table, surf, root: Path, rounds: int = 2) -> None:
    """CPU per trial of every world with the realistic chain against today's default path."""
    from fingerfriction.sim import WORLD_NAMES, SimOptions
    from fingerfriction.sim.contact import _extra_integrals
    from fingerfriction.sim.writer import plan_trial, simulate_trial

    paths = [("load-sharing", "ideal")] + [(w, "realistic") for w in WORLD_NAMES]
    best: dict = {}
    for r in range(rounds):
        for w, c in paths:
            opts = SimOptions(reps=1, subjects=("1",), surfaces=("bump-4mm",), world=w, chain=c)
            out = root / f"worlds-{w}-{c}-{r}"
            for spec in opts.trial_specs():
                plan = plan_trial(spec, opts)
                t0 = time.process_time()
                simulate_trial(plan, opts, table, None, out)
                cpu = time.process_time() - t0
                key = (w, c, spec.id)
                best[key] = min(best.get(key, np.inf), cpu)
    print(f"\nworlds (bump-4mm, subject 1, 3 speeds; CPU per trial, fastest of {rounds} interleaved rounds):")
    base = np.mean([v for (w, c, _), v in best.items() if (w, c) == paths[0]])
    for w, c in paths:
        m = np.mean([v for (ww, cc, _), v in best.items() if (ww, cc) == (w, c)])
        tag = "  (today's default path)" if (w, c) == paths[0] else ""
        print(f"  {w:18s} {c:9s} {m:6.2f} s   ratio {m / base:5.3f}{tag}")
    xi = table.xi
    X = table.positions[:, None] + xi[None, :]
    sl = np.asarray(surf.dhdx(X), float)
    cs = 1.0 / np.sqrt(1.0 + sl * sl)
    weights = np.stack([np.ones_like(sl), sl * cs, cs, sl * sl * cs, sl * cs])
    t0 = time.process_time()
    _extra_integrals(xi, table.y_f[0].astype(float), table.p[0].astype(float), np.asarray(surf.h(X), float),
                     weights, 0.069)
    print(f"  extra integrals of one load of the contact table: CPU {time.process_time() - t0:.2f} s "
          f"(x {table.loads.size} loads, 12 tables per study)")


if __name__ == "__main__":
    main()
