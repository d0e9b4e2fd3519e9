"""The consistency stage: does it catch each mistake a manifest can carry, how
often does it flag a clean trial, does ``--sync auto`` recover scattered clocks, and what
does it cost.

Runs on a fresh clone with no arguments (everything generated goes to the gitignored
``benchmarks/out``; studies are shared through ``benchmarks/_studies.py``)::

    python benchmarks/selfcheck.py                # the realism study, then the confirmation study
    python benchmarks/selfcheck.py --no-confirm   # the realism study only
    python benchmarks/selfcheck.py --confirm-options="--world interlocking --chain realistic --seed 5"

1. **Clean trials and cost.** The virtual study (2 subjects x 6 surfaces x 3 speeds,
   ``simulate --realism``, 1 repetition) through ``fingerfriction analyze`` (``--sync
   check``): every flag on these unmodified trials is a false flag; the stage's time (its
   per-trial checks and the study-level synchronisation, as recorded in ``status.json``
   and ``run.json``) against the whole run's, measured in the same run.
2. **Mistakes.** Every trial copied with each mistake applied to its manifest entry or its
   force file (a study folder of copies, video files hard-linked) and run through the
   pipeline's own functions (``check_files``, ``run_video``, ``check_trial_inputs``,
   ``process_trial_forces``; the video analysis of a copy that shares its original's video
   and calibration is not run twice), then synchronised against the unmodified trials.
   Printed per mistake: the share of copies caught (an error, or a warning) and by which
   flag.
3. **Scattered clocks.** The study with every trial's force clock moved by a random offset
   in +-50 ms, through ``analyze --sync auto``; the recovered offsets against the applied
   ones (absolutely, and relative to what ``--sync auto`` measures on the unshifted study),
   and mu of the fit against the unshifted study's.
4. **Confirmation.** The thresholds were decided on study 1 (``docs/selfcheck.md``); their
   false-flag rate is confirmed on studies made under other assumptions: the simulator's
   ``interlocking`` and ``constant-pressure`` worlds with the realistic measurement chain
   (second-order sensor of unknown cut-off, crosstalk, curved drift, a normal force that
   follows the relief; ``docs/worlds.md``), other seeds.
   With part 3 (and 5) run on the first confirmation study as well: the touch-down's use
   was decided on study 1 and is confirmed there.
5. **The touch-down and the press** (what fixes each finger's level in part 3,
   ``docs/selfcheck.md``): on the unmodified study, each trial's touch-down as the analysis
   measured it in the video (the finger's gap closing) and in the force record (F_N's
   onset) against the simulator's truth, the offset they give, the offset each finger's
   trials share by them (``--sync check``), the lift-off's coverage, and how the video's
   contact grows with the load during the press.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import shlex
import shutil
import sys
import time
from collections import Counter, defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _studies import OUT, cli, simulated_study  # noqa: E402 - the benchmarks' shared helper

WORK = OUT / "selfcheck"
STUDY_OPTIONS = ("--realism", "--reps", "1", "--seed", "0")
#: the confirmation studies: the simulator's worlds the thresholds were not decided on, with
#: the realistic measurement chain (docs/worlds.md)
CONFIRM_OPTIONS = (
    "--world interlocking --chain realistic --seed 2 --reps 1",
    "--world constant-pressure --chain realistic --seed 3 --reps 1",
)

#: (name, kind, argument): the mistakes a manifest can carry, applied to a copy of every trial
MISTAKES = [
    ("fs +1 %", "fs", 1.01),
    ("fs -1 %", "fs", 0.99),
    ("fs +3 %", "fs", 1.03),
    ("fs -3 %", "fs", 0.97),
    ("t0 +5 ms", "t0", 0.005),
    ("t0 -5 ms", "t0", -0.005),
    ("t0 +15 ms", "t0", 0.015),
    ("t0 -15 ms", "t0", -0.015),
    ("t0 +40 ms", "t0", 0.040),
    ("t0 -40 ms", "t0", -0.040),
    ("fps +2 %", "fps", 1.02),
    ("fps -2 %", "fps", 0.98),
    ("F1/F2 swapped", "swap", None),
    ("F1 negated", "neg", "F1"),
    ("F2 negated", "neg", "F2"),
    ("mN labelled N", "mN", None),
    ("sensitivity 10x (one channel)", "sens", "F1"),
    ("sensitivity 10x (both channels)", "sens", "both"),
    ("surface height x2", "height", 2.0),
    ("another surface type", "type", None),
    ("unmodified", "none", None),
]
#: the bar: caught in >= 95 % of trials (each copy among its finger's unmodified trials; the
#: both-channel sensitivity's other reading, the whole study's sensitivity off, is measured
#: beside it: docs/selfcheck.md)
MUST_CATCH = {m[0] for m in MISTAKES if m[1] != "none"}
OTHER_SHAPE = {"bump": "step-up", "step-up": "step-down", "step-down": "bump"}


def _link(src: Path, dst: Path) -> None:
    dst.parent.mkdir(parents=True, exist_ok=True)
    if dst.exists():
        return
    try:
        os.link(src, dst)
    except OSError:
        shutil.copy2(src, dst)


def _forces(path: Path) -> tuple[np.ndarray, np.ndarray]:
    with np.load(path, allow_pickle=False) as z:
        return np.asarray(z["F1"], float), np.asarray(z["F2"], float)


def make_mistakes(study: Path, out: Path) -> tuple[Path, dict]:
    """A study folder with every trial's copies, one per mistake; returns it and
    ``{copy id: (mistake, original id)}``."""
    manifest = json.loads((study / "manifest.json").read_text())
    if (out / "manifest.json").is_file() and (out / "copies.json").is_file():
        return out, {k: tuple(v) for k, v in json.loads((out / "copies.json").read_text()).items()}
    surfaces = dict(manifest.get("surfaces", {}))
    trials, index = [], {}
    for t in manifest["trials"]:
        src_force = study / t["force"]["path"]
        f1, f2 = _forces(src_force)
        for k, (name, kind, arg) in enumerate(MISTAKES):
            e = json.loads(json.dumps(t))
            cid = f"{t['id']}-m{k:02d}"
            e["id"] = cid
            e.pop("truth", None)
            vpath = f"videos/{t['id']}.{t['video']['path'].rsplit('.', 1)[-1]}"
            _link(study / t["video"]["path"], out / vpath)
            e["video"]["path"] = vpath
            fpath = f"forces/{t['id']}.npz"
            _link(src_force, out / fpath)
            e["force"]["path"] = fpath
            if kind == "fs":
                e["force"]["fs_hz"] = t["force"]["fs_hz"] * arg
            elif kind == "t0":
                e["force"]["t0_s"] = t["force"].get("t0_s", 0.0) + arg
            elif kind == "fps":
                e["video"]["fps"] = t["video"]["fps"] * arg
            elif kind == "swap":
                e["force"]["channels"] = {"F1": "F2", "F2": "F1"}
            elif kind in ("neg", "mN", "sens"):
                g1, g2 = f1.copy(), f2.copy()
                if kind == "neg":
                    g1, g2 = (-g1, g2) if arg == "F1" else (g1, -g2)
                elif kind == "mN":
                    g1, g2 = 1000 * g1, 1000 * g2
                else:  # the file in volts of a 10 N/V amplifier; the manifest's sensitivity 10x off
                    g1, g2 = g1 / 10.0, g2 / 10.0
                    e["force"]["units"] = "V"
                    e["force"]["sensitivity_n_per_v"] = (
                        {"F1": 100.0, "F2": 10.0} if arg == "F1" else {"F1": 100.0, "F2": 100.0}
                    )
                fpath = f"forces/{cid}.npz"
                (out / "forces").mkdir(parents=True, exist_ok=True)
                np.savez(out / fpath, F1=g1, F2=g2)
                e["force"]["path"] = fpath
            elif kind == "height":
                spec = dict(surfaces.get(t["surface"]) or {})
                if not spec:
                    from fingerfriction.surfaces import get_surface

                    spec = get_surface(t["surface"]).to_dict()
                name2 = f"{t['surface']}-h2"
                surfaces[name2] = {**spec, "height": spec["height"] * arg, "name": name2}
                e["surface"] = name2
                e["calibration"] = {"surface_height_mm": e["calibration"]["surface_height_mm"] * arg}
            elif kind == "type":
                from fingerfriction.surfaces import surface_from_spec

                s = surface_from_spec(surfaces.get(t["surface"]) or t["surface"])
                name2 = f"{OTHER_SHAPE[s.shape]}-{s.width:g}mm"
                e["surface"] = name2
            e["_copy"] = [name, t["id"]]
            index[cid] = (name, t["id"])
            trials.append(e)
    clean = [{k: v for k, v in e.items() if k != "_copy"} for e in trials]
    out.mkdir(parents=True, exist_ok=True)
    (out / "copies.json").write_text(json.dumps({e["id"]: e["_copy"] for e in trials}))
    (out / "manifest.json").write_text(json.dumps({**manifest, "surfaces": surfaces, "trials": clean}))
    return out, index


_STUDY = {}


def _one_original(root: str, copy_ids: list[str]) -> list[dict]:
    """Every copy of one original trial through the pipeline's functions (worker process)."""
    import logging
    import warnings

    from fingerfriction.pipeline.params import AnalysisParams, force_params, video_options
    from fingerfriction.pipeline.trial import (
        TrialInput,
        check_trial_inputs,
        one_line,
        process_trial_forces,
        read_trial_forces,
        run_video,
    )
    from fingerfriction.study.check import check_files
    from fingerfriction.study.manifest import load_manifest

    warnings.simplefilter("ignore")  # the video stage's warnings about the mistaken scales: expected
    logging.getLogger("fingerfriction").setLevel(logging.ERROR)
    if root not in _STUDY:
        _STUDY[root] = load_manifest(root)
    st = _STUDY[root]
    params = AnalysisParams()
    videos: dict = {}
    out = []
    for cid in copy_ids:
        rec = st.trial(cid)
        row = {"id": cid, "level": "ok", "codes": [], "reason": "", "onset": None, "selfcheck_s": 0.0,
               "scale": None}
        checked, problems = check_files(st, [rec])
        if problems:
            row.update(
                level="error",
                codes=["check: " + problems[0].field.rsplit(".", 1)[-1]],
                reason=str(problems[0]),
            )
            out.append(row)
            continue
        rec = checked[cid]
        trial = TrialInput(Path(st.root), rec, dict(st.surfaces[rec.surface]))
        key = (rec.video.path, trial.height_mm, json.dumps(trial.surface_spec, sort_keys=True))
        try:
            if key not in videos:
                videos[key] = run_video(trial, video_options(params.video, rec.video.calibration_frame))
            v = videos[key]
            record = read_trial_forces(trial.root, rec)
            tc = check_trial_inputs(trial, v, record, params)
            row["selfcheck_s"] = tc.elapsed_s
            f_level = (tc.figures.get("forces") or {}).get("f_n_level_n")
            length = tc.figures.get("contact_flat_mm")
            row["scale"] = [str(rec.subject), math.nan if f_level is None else f_level,
                            math.nan if length is None else length]
            found = [c for c in tc.checks if c.finding]
            row["codes"] = [f"{c.level} {c.code}" for c in found]
            if tc.error is not None:
                row.update(level="error", reason=tc.reason())
                out.append(row)
                continue
            if found:
                row["level"] = "warning"
            process_trial_forces(
                trial,
                v.x_mm,
                params=force_params(params.forces),
                regions=v.regions,
                on_error="raise",
                record=tc.record,
            )
            row["onset"] = None if tc.onset is None else tc.onset.to_dict()
        except (ValueError, OSError) as exc:
            row.update(
                level="error", codes=[*row["codes"], "error " + type(exc).__name__], reason=one_line(exc)
            )
        out.append(row)
    return out


def run_mistakes(root: Path, index: dict, workers: int) -> dict:
    by_orig = defaultdict(list)
    for cid, (_, orig) in index.items():
        by_orig[orig].append(cid)
    rows = {}
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=workers) as ex:
        for res in ex.map(_one_original, [str(root)] * len(by_orig), list(by_orig.values())):
            for r in res:
                rows[r["id"]] = r
            print(f"  {len(rows)} of {len(index)} copies ({time.perf_counter() - t0:.0f} s)", flush=True)
    (root / "rows.json").write_text(json.dumps(rows))  # for inspection
    return rows


def synchronise_copies(root: Path, rows: dict, index: dict) -> None:
    """The study-level synchronisation: each copy against the unmodified trials' starts."""
    from fingerfriction.pipeline.selfcheck import sync_checks
    from fingerfriction.selfcheck import OnsetData, SelfCheckParams, estimate_offsets, scale_checks
    from fingerfriction.study.manifest import load_manifest

    st = load_manifest(root)
    P = SelfCheckParams()
    periods = {t.id: 1.0 / t.video.fps for t in st.trials if t.video.fps}
    onsets = {cid: OnsetData.from_dict(r["onset"]) for cid, r in rows.items() if r["onset"]}
    clean = {cid for cid in onsets if index[cid][0] == "unmodified"}
    est = estimate_offsets(onsets.values(), mode="check", reference=clean, se_floor_s=P.sync_se_floor_s)
    found = list(sync_checks(est, periods, P, mode="check", onsets=onsets).items())
    # the force's scale: each copy against its finger's unmodified trials
    items = {cid: tuple(r["scale"]) for cid, r in rows.items() if r.get("scale") and r["level"] != "error"}
    ref = {cid for cid in items if index[cid][0] == "unmodified"}
    found += list(scale_checks(items, reference=ref).items())
    for cid, c in found:
        r = rows[cid]
        if c.code == "sync-offset":
            r["sync_ms"] = None if not math.isfinite(c.figure) else c.figure
        if c.finding:
            r["codes"].append(f"{c.level} {c.code}")
            if c.level == "error" and r["level"] != "error":
                r.update(level="error", reason=c.line())
            elif r["level"] == "ok":
                r["level"] = "warning"


def report_mistakes(rows: dict, index: dict) -> list[str]:
    per = defaultdict(list)
    for cid, r in rows.items():
        per[index[cid][0]].append(r)
    lines = [f"{'mistake':34s} {'caught':>8s} {'as error':>9s}  flags (first finding of each caught copy)"]
    failed = []
    for name, _, _ in MISTAKES:
        rs = per.get(name, [])
        n = len(rs)
        caught = [r for r in rs if r["level"] != "ok"]
        errs = [r for r in rs if r["level"] == "error"]
        kinds = Counter(r["codes"][0] if r["codes"] else "?" for r in caught)
        flags = ", ".join(f"{k} x{v}" for k, v in kinds.most_common(4))
        rate = len(caught) / n if n else math.nan
        label = "false flags" if name == "unmodified" else "caught"
        lines.append(
            f"{name:34s} {100 * rate:7.1f}% {100 * len(errs) / max(n, 1):8.1f}%  ({label}, n={n}) {flags}"
        )
        if name in MUST_CATCH and rate < 0.95:
            failed.append(f"{name}: {100 * rate:.1f} % < 95 %")
        if name == "unmodified" and rate > 0.01:
            failed.append(f"false flags {100 * rate:.1f} % > 1 %")
    lines.append(
        "acceptance (>= 95 % caught, <= 1 % false flags): "
        + ("met" if not failed else "NOT met: " + "; ".join(failed))
    )
    return lines


def clean_run(study: Path, results: Path, sync: str = "check") -> dict:
    """``analyze --sync SYNC`` and what it says about the unmodified trials and the cost."""
    # --force: the figures are this code's, measured in this run; the command's CPU time
    # (user + sys of it and its workers) beside its wall time
    r0, w0 = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    cli("analyze", str(study), "--out", str(results), "--sync", sync, "--quiet", "--force", ok=(0, 1))
    r1, wall = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter() - w0
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    from fingerfriction.study.store import ResultsStore

    store = ResultsStore(results)
    run = store.read_run()
    flags, failed, stage, total, stage_cpu = [], [], 0.0, 0.0, 0.0
    for t in run["trials"]:
        st = store.status(t["id"]) or {}
        if st.get("status") != "ok":
            failed.append((t["id"], st.get("reason", "")))
            continue
        sc = (st.get("info") or {}).get("selfcheck") or {}
        stage += float(sc.get("elapsed_s") or 0.0)
        stage_cpu += float(sc.get("cpu_s") or 0.0)
        total += float(st.get("elapsed_s") or 0.0)
        flags += [
            (t["id"], c["code"], c["message"])
            for c in sc.get("checks", [])
            if c["level"] in ("error", "warning")
        ]
    sync_rec = next((r.get("sync") for r in reversed(run["runs"]) if r.get("sync")), {}) or {}
    sync_s = float(sync_rec.get("elapsed_s") or 0.0)
    return {
        "n": len(run["trials"]),
        "failed": failed,
        "flags": flags,
        "stage_s": stage + sync_s,
        "total_s": total + sync_s,
        "stage_cpu_s": stage_cpu + float(sync_rec.get("cpu_s") or 0.0),
        "command_wall_s": wall,
        "command_cpu_s": cpu,
        "sync": sync_rec,
    }


def print_false_flags(res: dict) -> None:
    """The flags of a clean study (every one is a false flag), from :func:`clean_run`."""
    n_flag = len({t for t, *_ in res["flags"]} | {t for t, _ in res["failed"]})
    print(
        f"trials {res['n']}; failed {len(res['failed'])}; flagged {n_flag} "
        f"({100 * n_flag / res['n']:.1f} % false flags)"
    )
    for t, code, msg in res["flags"][:10]:
        print(f"  {t}: {code}: {msg[:140]}")
    for t, reason in res["failed"][:10]:
        print(f"  {t} FAILED: {reason[:160]}")


def shifted_study(study: Path, out: Path, seed: int = 21) -> tuple[Path, dict]:
    """The study with every trial's force clock moved by a random offset in +-50 ms (the
    manifest's ``force.t0_s`` says the old value: the true offset is the applied one)."""
    manifest = json.loads((study / "manifest.json").read_text())
    rng = np.random.default_rng(seed)
    shifts = {t["id"]: float(rng.uniform(-0.05, 0.05)) for t in manifest["trials"]}
    if not (out / "manifest.json").is_file():
        trials = []
        for t in manifest["trials"]:
            e = json.loads(json.dumps(t))
            for key in ("video", "force"):
                _link(study / t[key]["path"], out / t[key]["path"])
            e.pop("truth", None)
            e["force"]["t0_s"] = t["force"].get("t0_s", 0.0) + shifts[t["id"]]
            trials.append(e)
        (out / "manifest.json").write_text(json.dumps({**manifest, "trials": trials}))
    return out, shifts


def _mu(results: Path) -> dict:
    from fingerfriction.pipeline.fitting import fit

    res = fit(results, progress=False, validate=False)
    return dict(res.mu)


def step_clean(study: Path) -> None:
    print("\n== 1. the unmodified study through analyze --sync check (false flags, cost)", flush=True)
    clean = clean_run(study, WORK / "realism-check")
    print_false_flags(clean)
    share = clean["stage_s"] / clean["total_s"] if clean["total_s"] else math.nan
    cpu_share = clean["stage_cpu_s"] / clean["command_cpu_s"] if clean["command_cpu_s"] else math.nan
    print(
        f"stage cost, wall: {clean['stage_s']:.1f} s of {clean['total_s']:.1f} s of analysis "
        f"({100 * share:.1f} %; bar <= 10 %), measured in the same run"
    )
    print(
        f"stage cost, CPU (user+sys): {clean['stage_cpu_s']:.1f} s of the analyze command's "
        f"{clean['command_cpu_s']:.1f} s, workers included ({100 * cpu_share:.1f} %; bar <= 10 %); "
        f"the command's wall time {clean['command_wall_s']:.1f} s"
    )


def step_mistakes(study: Path, name: str, workers: int) -> None:
    print(f"\n== 2. mistakes: a copy of every trial of {study.name} with each mistake", flush=True)
    root, index = make_mistakes(study, WORK / f"mistakes-{name}")
    rows = run_mistakes(root, index, workers)
    synchronise_copies(root, rows, index)
    for line in report_mistakes(rows, index):
        print(line)
    from fingerfriction.selfcheck import scale_checks

    # the other reading: the sensitivity off on every trial of the study (no unmodified
    # trial to compare with): the copies with that mistake alone
    name10 = "sensitivity 10x (both channels)"
    alone = {c: tuple(r["scale"]) for c, r in rows.items() if index[c][0] == name10 and r.get("scale")}
    got = scale_checks(alone)
    n_err = sum(c.level == "error" for c in got.values())
    print(
        f"{name10}, the whole study's sensitivity off (each finger's trials all 10x): force-scale caught "
        f"{n_err} of {len(got)} ({100 * n_err / max(len(got), 1):.1f} %): nothing to compare with"
    )
    # the absolute reading: one trial's contact against its load, L^2 / F (2-D Hertz:
    # 16 R / (pi E* D)), against the range of fingers
    for label in ("unmodified", name10):
        q = [r["scale"][2] ** 2 / r["scale"][1] for c, r in rows.items()
             if index[c][0] == label and r.get("scale") and r["scale"][1] > 0 and r["scale"][2] > 0]
        if q:
            print(f"absolute reading, {label}: L^2 / F_N = {min(q):.0f}-{max(q):.0f} mm^2/N (n={len(q)})")
    lo, hi = 16 * 7 / (math.pi * 0.4 * 15), 16 * 12 / (math.pi * 0.04 * 10)
    print(
        f"  a finger of radius 7-12 mm, pad modulus E* 0.04-0.4 MPa, width 10-15 mm (2-D Hertz): "
        f"{lo:.0f}-{hi:.0f} mm^2/N, {hi / lo:.0f}x wide: a 10x scale cannot be told from another finger"
    )
    per_stage = [r["selfcheck_s"] for r in rows.values() if r["selfcheck_s"]]
    print(f"per-trial checks: median {1e3 * np.median(per_stage):.0f} ms per copy")


def _unresolved(err: np.ndarray, speeds: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """``err`` less, per finger, its least-squares part along 1 and speed^-1/4: what the
    starts of the slides cannot tell apart (docs/selfcheck.md)."""
    out = err.copy()
    for g in np.unique(groups):
        k = groups == g
        X = np.column_stack([np.ones(k.sum()), speeds[k] ** -0.25])
        out[k] = err[k] - X @ np.linalg.lstsq(X, err[k], rcond=None)[0]
    return out


def step_auto(study: Path, name: str = "realism") -> None:
    print(
        f"\n== 3. scattered clocks ({study.name}): every force clock moved by a random offset in +-50 ms, "
        "--sync auto",
        flush=True,
    )
    from fingerfriction.study.manifest import load_manifest

    check = WORK / f"{name}-check"
    if not (check / "run.json").is_file():
        clean_run(study, check)
    shifted, shifts = shifted_study(study, WORK / f"shifted-{name}")
    auto = clean_run(shifted, WORK / f"shifted-{name}-auto", sync="auto")
    base = clean_run(study, WORK / f"{name}-auto", sync="auto")
    got = auto["sync"].get("trials", {})
    ref = base["sync"].get("trials", {})
    ids = [t for t in shifts if t in got and got[t]["offset_ms"] is not None]
    err_abs = np.array([got[t]["offset_ms"] + 1e3 * shifts[t] for t in ids])
    err_rel = np.array(
        [
            got[t]["offset_ms"] - (ref.get(t, {}).get("offset_ms") or 0.0) + 1e3 * shifts[t]
            for t in ids
            if ref.get(t, {}).get("offset_ms") is not None
        ]
    )
    st = load_manifest(study)
    speeds = np.array([st.trial(t).speed_mm_s for t in ids], float)
    groups = np.array([st.trial(t).subject for t in ids])
    err_well = _unresolved(err_abs, speeds, groups)
    by = Counter(got[t].get("level_by") or "?" for t in ids)
    print(
        f"trials with a measured offset: {len(ids)} of {len(shifts)}; failed: {len(auto['failed'])}; "
        f"what placed each finger's trials: {dict(by)}"
    )
    print(
        f"recovered offsets, absolute: RMS {np.sqrt(np.mean(err_abs**2)):.2f} ms, "
        f"max {np.max(np.abs(err_abs)):.2f} ms, mean {np.mean(err_abs):+.2f} ms (bar: 1 ms RMS)"
    )
    print(
        f"recovered offsets, relative to --sync auto on the unshifted study: RMS "
        f"{np.sqrt(np.mean(err_rel**2)):.2f} ms, max {np.max(np.abs(err_rel)):.2f} ms"
    )
    print(
        f"recovered offsets, what the starts alone can tell (less, per finger, a common shift and one as "
        f"speed^-1/4): RMS {np.sqrt(np.mean(err_well**2)):.2f} ms, max {np.max(np.abs(err_well)):.2f} ms"
    )
    mu0, mu1 = _mu(check), _mu(WORK / f"shifted-{name}-auto")
    for s in mu0:
        print(
            f"mu subject {s}: unshifted (--sync check) {mu0[s]:.4f}, shifted (--sync auto) "
            f"{mu1.get(s, math.nan):.4f} ({100 * (mu1.get(s, math.nan) / mu0[s] - 1):+.2f} %; bar 1 %)"
        )


def step_confirm(options: str, workers: int, mistakes: bool, steps: str) -> None:
    opts = shlex.split(options)
    name = "selfcheck-confirm-" + "-".join(o.lstrip("-") for o in opts).replace("/", "_")
    print(f"\n== 4. confirmation on another study: simulate {options}", flush=True)
    other = simulated_study(name, *opts)
    check = WORK / f"{name}-check"
    print_false_flags(clean_run(other, check))
    if mistakes:
        step_mistakes(other, name, workers)
    if "3" in steps:
        step_auto(other, name)
    if "5" in steps:
        print("-- the touch-down and the press there (part 5; the manifest's clocks are right)")
        print_events(touch_rows(other, check))


# --------------------------------------------------------------------------------------
# 5. the touch-down and the press in both recordings, against the simulator's truth


def _press(frames, t_force, f_n, t_touch: float, t_motion: float) -> tuple[float, float]:
    """The contact's squared length against the load over the press (frames from the touch
    to the start of the slide): its slope in mm^2/N and the correlation (NaN: too few
    frames). ``frames`` the analysis's table (its regions), ``f_n`` the true load."""
    from fingerfriction.study.store import regions_from_table

    reg = regions_from_table(frames)
    t = frames["t_s"].to_numpy(float)
    length = np.nansum(np.where(np.isfinite(reg[..., 0]), reg[..., 1] - reg[..., 0], 0.0), axis=1)
    sel = (t > t_touch + 0.002) & (t < t_motion) & (length > 0)
    if sel.sum() < 8:
        return math.nan, math.nan
    f = np.interp(t[sel], t_force, f_n)
    L2 = length[sel] ** 2
    if np.ptp(f) <= 0:
        return math.nan, math.nan
    return float(np.polyfit(f, L2, 1)[0]), float(np.corrcoef(f, L2)[0, 1])


def touch_rows(study: Path, results: Path) -> list[dict]:
    """Per trial of an analysed study whose clocks are right: the touch-downs the analysis
    measured (``status.json``) against the simulator's truth, and the press."""
    import pandas as pd

    from fingerfriction.selfcheck import OnsetData
    from fingerfriction.study.manifest import load_manifest
    from fingerfriction.study.store import ResultsStore

    st = load_manifest(study)
    store = ResultsStore(results)
    rows = []
    for rec in st.trials:
        status = store.status(rec.id) or {}
        sc = (status.get("info") or {}).get("selfcheck") or {}
        if not sc.get("onset") or not rec.truth:
            continue
        o = OnsetData.from_dict(sc["onset"])
        with np.load(study / rec.truth, allow_pickle=False) as z:
            t_touch = float(z["t_touch_s"]) if "t_touch_s" in z.files else math.nan
            v_a = float(z["approach_speed_mm_s"]) if "approach_speed_mm_s" in z.files else math.nan
            t_force, f_n = np.asarray(z["t_force"], float), np.asarray(z["F_N"], float)
            t_video = np.asarray(z["t_video"], float)
        on = np.flatnonzero(f_n > 0)
        frames = pd.read_parquet(results / "trials" / rec.id / "frames.parquet")
        slope, r = _press(frames, t_force, f_n, t_touch, o.t_motion)
        rows.append({
            "id": rec.id,
            "subject": str(rec.subject),
            "v_a": v_a,
            "video_err": o.touch_video_s - t_touch,
            "video_se": o.touch_video_se_s,
            "force_err": o.touch_force_s - t_touch,
            "force_se": o.touch_force_se_s,
            "offset_err": o.touch_offset_s,  # the clocks are right: the truth is 0
            "in_video": bool(t_video[0] < t_touch < t_video[-1]),
            "lift_after_ms": 1e3 * (t_force[on[-1]] - t_video[-1]) if on.size else math.nan,
            "press_slope": slope,
            "press_r": r,
            "common_ms": (sc.get("sync") or {}).get("common_ms"),
            "video_msg": (sc.get("figures") or {}).get("touch", {}).get("video", ""),
        })
    return rows


def _rms(v) -> float:
    v = np.asarray(v, float)
    v = v[np.isfinite(v)]
    return float(np.sqrt(np.mean(v**2))) if v.size else math.nan


def print_events(rows: list[dict]) -> None:
    """Print what the touch-downs and the press show (from :func:`touch_rows`)."""
    n = len(rows)
    if not n:
        print("no trial with a start of the slide and a truth file")
        return
    lift = np.array([r["lift_after_ms"] for r in rows])
    v_a = np.array([r["v_a"] for r in rows])
    print(
        f"coverage (the simulator's truth): the finger touches down inside the video in "
        f"{sum(r['in_video'] for r in rows)} of {n} trials, landing at "
        f"{np.nanmin(v_a):.0f}-{np.nanmax(v_a):.0f} mm/s; it lifts off "
        f"{np.nanmin(lift):.0f}-{np.nanmax(lift):.0f} ms after the video's last frame"
    )
    for key, label in (("video", "video (the gap closing)"), ("force", "force (F_N's onset)")):
        e = 1e3 * np.array([r[f"{key}_err"] for r in rows])
        se = 1e3 * np.array([r[f"{key}_se"] for r in rows])
        ok = np.isfinite(e)
        print(
            f"touch-down in the {label}: measured in {ok.sum()} of {n}; error against the truth mean "
            f"{np.mean(e[ok]):+.3f} ms, RMS {_rms(e):.3f} ms, max {np.max(np.abs(e[ok])):.3f} ms; "
            f"median SE {np.median(se[ok]):.3f} ms; |error| < 3 SE in {np.sum(np.abs(e[ok]) < 3 * se[ok])}"
        )
    d = 1e3 * np.array([r["offset_err"] for r in rows])
    print(
        f"touch-down offset per trial (both measured, truth 0): mean {np.nanmean(d):+.3f} ms, "
        f"RMS {_rms(d):.3f} ms"
    )
    common = {}
    for r in rows:
        if r["common_ms"] is not None:
            common[r["subject"]] = r["common_ms"]
    print(
        "the offset each finger's trials share, measured by the touch-downs (--sync check, truth 0): "
        + ", ".join(f"finger {k}: {v:+.3f} ms" for k, v in sorted(common.items()))
    )
    slope = np.array([r["press_slope"] for r in rows])
    corr = np.array([r["press_r"] for r in rows])
    ok = np.isfinite(slope)
    if ok.any():
        print(
            f"the press in the video ({ok.sum()} trials, frames from the touch to the start of the slide): "
            f"the contact's squared length grows with the load by {np.median(slope[ok]):.0f} mm^2/N (median; "
            f"correlation {np.median(corr[ok]):.3f})"
        )


def step_events(study: Path) -> None:
    print(
        "\n== 5. the touch-down and the press in both recordings (the unmodified study, clocks right)",
        flush=True,
    )
    check = WORK / "realism-check"
    if not (check / "run.json").is_file():
        clean_run(study, check)
    print_events(touch_rows(study, check))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--workers", type=int, default=2, help="worker processes (default 2)")
    ap.add_argument("--steps", default="12345", help="which parts to run (default 12345)")
    ap.add_argument("--no-confirm", action="store_true", help="skip the confirmation studies (part 4)")
    ap.add_argument(
        "--confirm-options",
        action="append",
        help=f"simulate options of a confirmation study (repeatable; default {CONFIRM_OPTIONS!r})",
    )
    ap.add_argument(
        "--confirm-mistakes",
        action="store_true",
        help="also copy the confirmation studies' trials with each mistake (part 2 on them)",
    )
    args = ap.parse_args(argv)
    WORK.mkdir(parents=True, exist_ok=True)
    study = simulated_study("realism-seed0-reps1", *STUDY_OPTIONS)
    if "1" in args.steps:
        step_clean(study)
    if "2" in args.steps:
        step_mistakes(study, "realism", args.workers)
    if "3" in args.steps:
        step_auto(study)
    if "5" in args.steps:
        step_events(study)
    if "4" in args.steps and not args.no_confirm:
        for options in args.confirm_options or CONFIRM_OPTIONS:
            step_confirm(options, args.workers, args.confirm_mistakes, args.steps)
    return 0


if __name__ == "__main__":
    sys.exit(main())
