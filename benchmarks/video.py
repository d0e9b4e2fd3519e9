"""Video analysis benchmark: speed (frames/s per core) and accuracy on a simulated study.

Usage::

    python benchmarks/video.py [--study DIR] [--max-trials N] [--speed-frames N]

Speed: the analysis of decoded frames (``FrameAnalyzer.analyze_chunk``: threshold, contour
tracing, outline, C_f tracking, contact regions) in frames/s on one core (OpenCV limited to
one thread), next to OpenCV's threshold + findContours alone on the same crops (the floor),
and the decode rate of every supported format for the same frames.

Accuracy, against the simulator's ground truth (``truth/<trial>.npz``):

* x(t): RMS error after removing one constant offset per trial, over frames with a
  position, and the worst frame; for the paper's C_f centroid, the chord midpoint and the
  hybrid (chord midpoint, else one offset-corrected outline edge: ``position='hybrid'``),
  with the positions each one covers (the force processing needs |x| <= 13 mm);
* contact region end points vs ``regions_geom`` (frames where the region count agrees);
* the number of contact regions per frame;
* blind-spot widths (``fingerfriction.model.blindspots``) from our regions vs from the truth,
  per surface over all its trials (Fig. 3);
* for both contact metrics (euclidean: the paper's; vertical: the simulator's gap), and
  for each outline smoothing of the contact test (``--outline-smooth``, columns of the
  Savitzky-Golay fit; 0 = the paper's raw contour points);
* with ``--truth-geometry``: the contact tables are rebuilt from ``truth/study.json``
  (deterministic; checked by reproducing ``regions_geom``) to get the true
  finger-surface distance along the surface in every frame. Each end point's error is
  then also given as the error in *distance*: the true distance at our end point minus
  the 3 px criterion, next to the slope of the true distance there (px of distance per
  px along the surface). Where that slope is small the end point is ill-conditioned: an
  end point 3 px off is then a distance error of 3 px x slope.

Default study: the paper's seed-0 study, simulated into benchmarks/out/studies/ (gitignored) the
first time and shared with the other benchmarks; the one used is printed.
"""

from __future__ import annotations

import argparse
import json
import os

os.environ.setdefault("OMP_NUM_THREADS", "1")  # one core: numpy/OpenCV single-threaded
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from _studies import simulated_study
from fingerfriction.model.blindspots import blind_spots
from fingerfriction.regions import n_regions
from fingerfriction.study import load_manifest
from fingerfriction.video import (
    AnalysisOptions,
    FrameAnalyzer,
    FrameFlag,
    analyze_video,
    calibrate,
    open_video,
)
from fingerfriction.video.writers import write_video


def pick_study(arg: str | None) -> Path:
    """The study given, else the paper's seed-0 study simulated into benchmarks/out/."""
    return Path(arg) if arg else simulated_study("paper-seed0", "--seed", "0")


def _stack(regions: list[np.ndarray]) -> np.ndarray:
    """Concatenate region arrays of different slot counts (NaN padding)."""
    k = max(r.shape[1] for r in regions)
    return np.concatenate([np.pad(r, ((0, 0), (0, k - r.shape[1]), (0, 0)), constant_values=np.nan)
                           for r in regions])


def speed(study, n_frames: int) -> None:
    cv2.setNumThreads(1)
    tr = study.trials[0]
    path = study.path(tr.video.path)
    with open_video(path) as r:
        # frames from the middle of the trial: the finger is in view and in contact there
        mid = max((r.n_frames - n_frames) // 2, 1)
        frame0 = r.read_frame(tr.video.calibration_frame)
        frames = np.concatenate([c.copy() for _, c in r.iter_chunks(128, start=mid, stop=mid + n_frames)])
    surf = study.surface(tr.surface)
    cal = calibrate(frame0, tr.calibration["surface_height_mm"], surface=surf)
    crops = np.ascontiguousarray(cal.crop.apply(frames))
    k = len(frames)
    print(f"\n== speed: {k} frames (from {mid}) of {tr.id} ({frames.shape[2]}x{frames.shape[1]}, "
          f"crop {cal.crop.width}x{cal.crop.height}), one core (cv2.setNumThreads(1))")

    def floor():
        buf = np.empty(crops.shape[1:], np.uint8)
        for c in crops:
            cv2.threshold(c, cal.level, 255, cv2.THRESH_BINARY_INV, dst=buf)
            cv2.findContours(buf, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)

    def analysis(opts=None):
        an = FrameAnalyzer(cal, opts or AnalysisOptions(), frames.shape[1:])
        for i in range(0, k, 128):
            an.analyze_chunk(i, frames[i:i + 128])

    def analysis_raw():  # without the outline smoothing of the contact test
        analysis(AnalysisOptions(outline_smooth_px=0))

    def best_of(fn, reps=3):
        """frames/s from CPU time (per core, robust to other load) and from wall time."""
        cpu, wall = [], []
        for _ in range(reps):
            c0, w0 = time.process_time(), time.perf_counter()
            fn()
            cpu.append(time.process_time() - c0)
            wall.append(time.perf_counter() - w0)
        return k / min(cpu), k / min(wall)

    load = os.getloadavg()[0]
    print(f"  (load average {load:.1f} on {os.cpu_count()} cores: wall-clock rates are shared; "
          "CPU-time rates are per core)")
    (f_floor, w_floor), (f_an, w_an) = best_of(floor), best_of(analysis)
    print(f"  OpenCV threshold + findContours alone (floor): {f_floor:8.0f} frames/s per core "
          f"(wall {w_floor:.0f})")
    print(f"  full analysis (outline, C_f, x, contact)      : {f_an:8.0f} frames/s per core "
          f"(wall {w_an:.0f}); {f_an / f_floor:.2f} x the floor; target >= 2000")
    f_raw, w_raw = best_of(analysis_raw)
    print(f"  the same without the outline smoothing     : {f_raw:8.0f} frames/s per core "
          f"(wall {w_raw:.0f}); the smoothing costs {1e6 * (1 / f_an - 1 / f_raw):.1f} us per frame")
    print(f"  -> 300,000 frames on 2 cores: {300000 / (2 * f_an):.0f} s of analysis")
    print("  decode rate (same frames, full 1280x720, one thread):")
    with tempfile.TemporaryDirectory() as tmp:
        for fmt, ext in (("tiff", "tif"), ("ffv1-mkv", "mkv"), ("avi", "avi"), ("mp4", "mp4"),
                         ("cine", "cine")):
            p = os.path.join(tmp, f"v.{ext}")
            write_video(p, frames, fmt=fmt, crf=18 if fmt == "mp4" else 0)
            size = os.path.getsize(p) / k / 1e3

            def dec(p=p):
                with open_video(p) as r:
                    for _ in r.iter_chunks(64):
                        pass
            note = " (H.264 crf 18, lossy)" if fmt == "mp4" else ""
            c, wl = best_of(dec, 2)
            print(f"    {fmt:9s}: {c:8.0f} frames/s per core (wall {wl:5.0f}), {size:7.1f} kB/frame{note}")


def accuracy(study, max_trials: int | None, metrics=("euclidean", "vertical"), stride: int = 1,
             smooths=(None,), geometry: TruthGeometry | None = None) -> None:
    trials = list(study.trials)[::stride]
    trials = trials[:max_trials] if max_trials else trials
    every = f" (every {stride}th)" if stride > 1 else ""
    print(f"\n== accuracy on {len(trials)} trials of {study.root}{every}")
    default_smooth = AnalysisOptions().outline_smooth_px
    for metric, smooth in ((m, sm) for m in metrics for sm in smooths):
        smooth = default_smooth if smooth is None else smooth
        print(f"\n-- contact metric: {metric}" + (
            " (the paper's: distance between outline points; the simulator's regions_geom uses "
            "the same perpendicular distance)" if metric == "euclidean" else " (vertical gap)")
            + f"; outline smoothing for the contact test: {smooth} columns"
            + (" (default)" if smooth == default_smooth else "")
            + (" (raw contour points, as in the paper)" if smooth <= 1 else ""))
        cond_err, cond_slope, n_repro, n_checked = [], [], 0, 0
        rows = []
        per_surface: dict[str, tuple[list, list]] = {}
        all_ep, n_same, n_tot = [], 0, 0
        n_too_many = 0
        worst = (0.0, None)
        worst_c = (0.0, None)
        worst_h = (0.0, None)
        ranges = {"cf": [], "chord": [], "hybrid": []}
        src_counts = np.zeros(4, int)
        rms_h_win = []
        for tr in trials:
            z = np.load(study.path(tr.truth))
            tol_px = float(z["geom_tol_mm"] / z["mm_per_px"])
            # default n_max_regions and contact-region cleanup; frames with too many
            # regions are flagged (TOO_MANY_REGIONS) and counted below
            opt = AnalysisOptions(contact_metric=metric, contact_tol_px=tol_px, outline_smooth_px=smooth)
            res = analyze_video(study.path(tr.video.path), tr.calibration["surface_height_mm"],
                                surface=study.surface(tr.surface), options=opt,
                                n_frames=tr.video.n_frames)
            xt = z["x_finger_video"]
            n_too_many += int(np.count_nonzero((res.flags & FrameFlag.TOO_MANY_REGIONS) & z["has_finger"]))
            v = (res.flags == 0) & np.isfinite(xt)
            e = res.x_cf[v] - xt[v]
            e -= e.mean()
            ec = res.x_chord[v] - xt[v]
            okc = np.isfinite(ec)
            ec = ec[okc] - ec[okc].mean()
            i = int(np.argmax(np.abs(e)))
            fr = int(np.flatnonzero(v)[i])
            if abs(e[i]) > abs(worst[0]):
                worst = (float(e[i]), (tr.id, fr, float(xt[fr])))
            if ec.size:
                j = int(np.argmax(np.abs(ec)))
                frc = int(np.flatnonzero(v)[okc][j])
                if abs(ec[j]) > abs(worst_c[0]):
                    worst_c = (float(ec[j]), (tr.id, frc, float(xt[frc])))
            # the hybrid, computed in every mode (x_hybrid; frames with the finger seen)
            vh = np.isfinite(res.x_hybrid) & np.isfinite(xt)
            eh = res.x_hybrid[vh] - xt[vh]
            eh -= eh.mean()
            j = int(np.argmax(np.abs(eh)))
            frh = int(np.flatnonzero(vh)[j])
            if abs(eh[j]) > abs(worst_h[0]):
                worst_h = (float(eh[j]), (tr.id, frh, float(xt[frh]), int(res.x_source[frh])))
            inw = np.abs(xt[vh]) <= 13.0
            rms_h_win.append(float(np.sqrt(np.mean(eh[inw] ** 2))))
            src_counts += np.bincount(res.x_source[vh], minlength=4)[:4]
            for key, xs in (("cf", res.x_cf), ("chord", res.x_chord), ("hybrid", res.x_hybrid)):
                ok = np.isfinite(xs) & np.isfinite(xt)
                ranges[key].append((xt[ok].min(), xt[ok].max()) if ok.any() else (np.nan, np.nan))
            nt = n_regions(z["regions_geom"][v])
            nm = n_regions(res.regions[v])
            same = nt == nm
            n_same += int(same.sum())
            n_tot += int(v.sum())
            T = z["regions_geom"][v][same]
            M = res.regions[v][same]
            kk = min(T.shape[1], M.shape[1])
            d = np.abs(M[:, :kk] - T[:, :kk]) / z["mm_per_px"]
            all_ep.append(d[np.isfinite(d)])
            if geometry is not None and metric == "euclidean":
                frames = np.flatnonzero(v)[same]
                ce, cs, rep, nck = end_point_conditioning(
                    geometry.trial(tr.id), frames, T, M, float(z["geom_tol_mm"]), float(z["mm_per_px"]))
                cond_err.append(ce)
                cond_slope.append(cs)
                n_repro += rep
                n_checked += nck
            s = per_surface.setdefault(tr.surface, ([], []))
            s[0].append(z["regions_geom"][v])
            s[1].append(res.regions[v])
            cal = res.calibration
            rows.append((tr.id, v.sum(), int(z["has_finger"].sum()), np.sqrt(np.mean(e**2)), e[i], fr,
                         np.sqrt(np.mean(ec**2)) if ec.size else np.nan, same.mean(),
                         np.sqrt(np.mean(eh**2)), int(vh.sum()), *ranges["hybrid"][-1],
                         100 * (cal.mm_per_px / float(z["mm_per_px"]) - 1), cal.x0_px - float(z["x0_px"]),
                         res.timings["frames_per_s"]))
        rms_h_win = np.array(rms_h_win)
        print(f"  {'trial':26s} {'tracked':>11s} {'x rms':>7s} {'worst':>7s} {'@frame':>6s} "
              f"{'chord':>7s} {'hybrid':>7s} {'h frames':>8s} {'h range mm':>15s} {'n ok':>6s} "
              f"{'scale%':>7s} {'x0 px':>6s}")
        for r in rows:
            print(f"  {r[0]:26s} {r[1]:5d}/{r[2]:5d} {r[3]:7.4f} {r[4]:7.3f} {r[5]:6d} {r[6]:7.4f} "
                  f"{r[8]:7.4f} {r[9]:8d} [{r[10]:6.2f},{r[11]:6.2f}] "
                  f"{r[7]:6.3f} {r[12]:7.3f} {r[13]:6.2f}")
        rms = np.array([r[3] for r in rows])
        rmsc = np.array([r[6] for r in rows])
        ep = np.concatenate(all_ep) if all_ep else np.zeros(0)
        print(f"  x(t), C_f centroid (paper): RMS per trial max {rms.max():.4f} mm, median "
              f"{np.median(rms):.4f} mm (target < 0.05); worst frame {worst[0]:+.3f} mm "
              f"({worst[1][0]}, frame {worst[1][1]}, x = {worst[1][2]:.2f} mm)")
        print(f"  x(t), chord midpoint     : RMS per trial max {np.nanmax(rmsc):.4f} mm, median "
              f"{np.nanmedian(rmsc):.4f} mm; worst frame {worst_c[0]:+.3f} mm ({worst_c[1][0]}, "
              f"frame {worst_c[1][1]}, x = {worst_c[1][2]:.2f} mm)")
        rmsh = np.array([r[8] for r in rows])
        names = {1: "chord", 2: "left edge", 3: "right edge"}
        print(f"  x(t), hybrid             : RMS per trial max {rmsh.max():.4f} mm, median "
              f"{np.median(rmsh):.4f} mm (all its frames); inside |x| <= 13 mm max "
              f"{rms_h_win.max():.4f}, median {np.median(rms_h_win):.4f} mm; worst frame "
              f"{worst_h[0]:+.3f} mm ({worst_h[1][0]}, frame {worst_h[1][1]}, x = {worst_h[1][2]:.2f} mm, "
              f"{names.get(worst_h[1][3], '?')})")
        print(f"  hybrid frames by estimator: chord {src_counts[1]}, left edge {src_counts[2]}, "
              f"right edge {src_counts[3]}")
        print("  coverage (true finger positions with a position; the force window needs [-13, 13] mm):")
        for key, label in (("cf", "C_f centroid"), ("chord", "chord midpoint"), ("hybrid", "hybrid")):
            rg = np.array(ranges[key], float)
            lo, hi = rg[:, 0], rg[:, 1]
            full = int(np.sum((lo <= -13.0) & (hi >= 13.0)))
            print(f"    {label:15s}: in every trial [{np.nanmax(lo):7.2f}, {np.nanmin(hi):6.2f}] mm; widest "
                  f"[{np.nanmin(lo):7.2f}, {np.nanmax(hi):6.2f}]; window covered in {full} of {len(rg)}")
        print(f"  frames with a position   : {sum(r[1] for r in rows)} of "
              f"{sum(r[2] for r in rows)} finger frames (others flagged, mostly C_f out of view)")
        print(f"  number of regions right  : {n_same / max(n_tot, 1):.4%} of {n_tot} frames (target >= 99%); "
              f"finger frames flagged TOO_MANY_REGIONS/NO_CONTOUR: {n_too_many}")
        if ep.size:
            print(f"  end points (frames with right count): max {ep.max():.2f} px, 99th pct "
                  f"{np.percentile(ep, 99):.2f} px, {np.mean(ep <= 3):.4%} within 3 px (target: all)")
        if cond_err:
            ce, cs = np.concatenate(cond_err), np.concatenate(cond_slope)
            print(f"  true geometry rebuilt (tables {geometry.build_s:.0f} s): truth regions reproduced in "
                  f"{n_repro} of {n_checked} frames (within one table step)")
            print(f"  distance error at our end points (true distance there - {tol_px:g} px): max "
                  f"|{np.abs(ce).max():.3f}| px, 99th pct {np.percentile(np.abs(ce), 99):.3f} px, mean "
                  f"{ce.mean():+.3f} px, sd {ce.std():.3f} px")
            if ep.size == ce.size:
                far = ep > 3
                for lo, hi in ((0.0, 0.02), (0.02, 0.05), (0.05, 0.1), (0.1, np.inf)):
                    sel = (cs >= lo) & (cs < hi)
                    if sel.any():
                        print(f"    slope of the true distance in [{lo:g}, {hi:g}) px/px: {sel.sum():6d} end "
                              f"points, {np.mean(ep[sel] <= 3):.4%} within 3 px, max {ep[sel].max():.2f} px; "
                              f"distance error max |{np.abs(ce[sel]).max():.3f}| px")
                if far.any():
                    print(f"    end points > 3 px off: {far.sum()}, slope there at most {cs[far].max():.4f} "
                          f"px/px, distance error there at most |{np.abs(ce[far]).max():.3f}| px")
                ok = (ep <= 3) | (np.abs(ce) <= 0.1)
                print(f"  well-posed figure: end point within 3 px along the surface OR where the true "
                      f"distance is within 0.1 px of the criterion: {np.mean(ok):.4%} of {ok.size} "
                      f"(target: all)")
        print("  blind spots per surface (all its trials), widths in mm: truth vs ours")
        for name, (T, M) in per_surface.items():
            bt = blind_spots(_stack(T))
            bm = blind_spots(_stack(M))
            wt, wm = bt.widths, bm.widths
            if len(wt) == len(wm):
                diff = np.abs(wt - wm).max(initial=0.0)
                verdict = f"max diff {diff:.3f} mm" + (" OK" if diff <= 0.05 else " (> 0.05)")
            else:
                verdict = f"count differs ({len(wt)} vs {len(wm)})"
            print(f"    {name:14s} truth {np.round(wt, 3).tolist()}  ours {np.round(wm, 3).tolist()}  "
                  f"{verdict}")


class TruthGeometry:
    """True finger-surface distance per frame of a simulated study (contact tables rebuilt)."""

    def __init__(self, root: Path) -> None:
        from fingerfriction.sim.writer import SimOptions

        header = json.loads((Path(root) / "truth" / "study.json").read_text())
        self.opts = SimOptions.from_dict(header["options"])
        self.specs = {s.id: s for s in self.opts.trial_specs()}
        self.tol_mm = float(header["geom_tol_mm"])
        self._tables: dict = {}
        self.build_s = 0.0

    def _table(self, spec):
        from fingerfriction.sim.contact import build_table, get_provider
        from fingerfriction.surfaces import surface_from_spec

        key = (spec.surface_spec, spec.subject)
        if key not in self._tables:
            self._tables.clear()  # trials come grouped by subject and surface
            t0 = time.perf_counter()
            self._tables[key] = build_table(
                surface_from_spec(spec.surface_spec), spec.subject, loads=self.opts.table_loads,
                step=self.opts.table_step, provider=get_provider(self.opts.contact_model))
            self.build_s += time.perf_counter() - t0
        return self._tables[key]

    def trial(self, tid: str):
        """``distance(k) -> (X mm, distance mm)`` for frame ``k`` of trial ``tid``."""
        from fingerfriction.sim.writer import frame_outline, geometric_distance, plan_trial
        from fingerfriction.surfaces import surface_from_spec

        spec = self.specs[tid]
        plan = plan_trial(spec, self.opts)
        table = self._table(spec)
        surf = surface_from_spec(spec.surface_spec)
        reach = 2.0 * self.tol_mm

        def distance(k: int):
            x_c, y_f, _ = frame_outline(plan.kin, table, int(plan.frame_idx[k]))
            X = x_c + table.xi
            h = np.asarray(surf.h(X), float)
            return X, geometric_distance(table.xi, np.asarray(y_f, float), h, reach)

        return distance


def end_point_conditioning(geo_distance, frames, T, M, tol_mm, mm_per_px):
    """Per end point (frames with the right count): distance error at our end, slope at the true end.

    Returns (err_px, slope, reproduced, n_checked): the true distance at our end point minus
    the criterion (px), the true distance's slope at the true end point (px/px), and how
    many of the checked frames' true regions the rebuilt geometry reproduces within one
    table grid step.
    """
    from fingerfriction.regions import regions_from_mask

    errs, slopes = [], []
    reproduced = 0
    for k, tk, mk in zip(frames, T, M, strict=True):
        X, d = geo_distance(int(k))
        r = regions_from_mask(X, d <= tol_mm)[0]
        r = r[np.isfinite(r[:, 0])]
        ok_t = tk[np.isfinite(tk[:, 0])]
        if r.shape[0] == ok_t.shape[0] and np.all(np.abs(r - ok_t) <= 1.01 * (X[1] - X[0])):
            reproduced += 1
        g = np.gradient(d, X)
        for (ta, tb), (ma, mb) in zip(ok_t, mk[np.isfinite(mk[:, 0])], strict=True):
            for te, me in ((ta, ma), (tb, mb)):
                errs.append((np.interp(me, X, d) - tol_mm) / mm_per_px)
                slopes.append(np.interp(te, X, g))
    return np.asarray(errs), np.abs(np.asarray(slopes)), reproduced, len(frames)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--study")
    ap.add_argument("--max-trials", type=int, default=None)
    ap.add_argument("--speed-frames", type=int, default=256)
    ap.add_argument("--stride", type=int, default=1, help="analyse every k-th trial")
    ap.add_argument("--skip-speed", action="store_true")
    ap.add_argument("--skip-accuracy", action="store_true")
    ap.add_argument("--metrics", default="euclidean,vertical",
                    help="contact metrics to evaluate, comma-separated")
    ap.add_argument("--outline-smooth", default=None,
                    help="outline smoothing windows (columns) of the contact test to evaluate, "
                         "comma-separated (default: the library default only; 0 = raw)")
    ap.add_argument("--truth-geometry", action="store_true",
                    help="rebuild the contact tables to express end-point errors as distance errors")
    a = ap.parse_args()
    root = pick_study(a.study)
    study = load_manifest(root)
    print(f"study: {root} ({len(study.trials)} trials)")
    if not a.skip_speed:
        speed(study, a.speed_frames)
    if not a.skip_accuracy:
        smooths = (None,) if a.outline_smooth is None else tuple(int(v) for v in a.outline_smooth.split(","))
        geometry = TruthGeometry(root) if a.truth_geometry else None
        accuracy(study, a.max_trials, tuple(a.metrics.split(",")), stride=max(a.stride, 1),
                 smooths=smooths, geometry=geometry)


if __name__ == "__main__":
    main()
