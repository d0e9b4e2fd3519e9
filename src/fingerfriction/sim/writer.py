"""Simulate trials and write a study directory (``docs/study-format.md``).

:func:`simulate_study` validates the options, refuses an output folder that holds anything
else than the same study (nothing is overwritten), precomputes one contact table per
(surface, subject) in parallel, simulates the trials in parallel, and writes the
manifest last. Every file is written atomically; a re-run of the same study into the same
folder skips the trials already complete (resume). Per-trial random streams come from
``numpy.random.SeedSequence(seed, spawn_key=(crc32(trial id),))``, so a trial's files do
not depend on the number of workers, the order of execution, or which other trials are
simulated: the same seed gives byte-identical studies.
"""

from __future__ import annotations

import json
import logging
import os
import shutil
from collections.abc import Callable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass, replace
from pathlib import Path

import cv2
import numpy as np

from .. import __version__
from .._atomic import atomic_write_text
from .._mainguard import check_main_guard
from .._workers import forkserver_context, package_environ
from ..regions import regions_from_mask
from ..study import ForceInfo, Study, TrialRecord, VideoInfo, write_manifest
from ..surfaces import Surface, surface_from_spec
from ..video.writers import VideoWriter
from ._geometry import geometric_distance, geometric_mask
from ._io import write_npz
from .camera import Camera
from .chain import RealisticChain, couple_normal_force, draw_device, draw_trial_chain, speed_scaled_kinematics
from .contact import ContactTable, SimFinger, build_table
from .kinematics import Kinematics, simulate_kinematics
from .options import VIDEO_EXT, SimOptions, TrialSpec, realism_rng, trial_rngs, trial_stream
from .physics import SUBJECT_FORCE_LAWS, ForceLaw
from .sensor import apply_sensor
from .worlds import LoadSharing, TrialMotion

__all__ = ["SimOptions", "TrialSpec", "simulate_study", "simulate_trial", "plan_trial", "StudyFolderError"]

log = logging.getLogger(__name__)

TRUTH_FORMAT = "fingerfriction-sim-truth"


class StudyFolderError(ValueError):
    """The output folder holds something other than this study; nothing was written."""


@dataclass(frozen=True)
class TrialPlan:
    """Kinematics and the file layout of one trial (cheap, deterministic)."""

    spec: TrialSpec
    kin: Kinematics
    frame_idx: np.ndarray  # force-sample index of each frame
    record: TrialRecord


def plan_trial(spec: TrialSpec, opts: SimOptions) -> TrialPlan:
    """Draw the trial's kinematics and compute its manifest record (no files written)."""
    rk, _, _ = trial_rngs(spec, opts.seed)
    kparams = opts.kinematics
    if opts.chain_name == "realistic":  # motor noise grows with speed
        kparams = speed_scaled_kinematics(kparams, spec.speed_mm_s, opts.chain)
    kin = simulate_kinematics(spec.speed_mm_s, rk, kparams)
    cam = opts.camera
    fs = opts.kinematics.fs_hz
    step = fs / cam.fps
    if abs(step - round(step)) > 1e-9:
        raise ValueError(f"the force rate ({fs} Hz) must be a multiple of the frame rate ({cam.fps} Hz)")
    step = int(round(step))
    i0 = int(round(kin.t_descent * fs))
    past = np.flatnonzero((kin.x >= opts.video_end_mm) & (np.arange(kin.x.size) >= i0))
    i_end = int(past[0]) if past.size else kin.x.size - 1
    frame_idx = np.arange(i0, i_end + 1, step)
    surf = surface_from_spec(spec.surface_spec)
    base = f"trials/{spec.id}"
    ext = VIDEO_EXT[opts.video_format]
    rec = TrialRecord(
        id=spec.id, subject=spec.subject, surface=spec.surface_name, speed_mm_s=spec.speed_mm_s,
        repetition=spec.repetition,
        video=VideoInfo(path=f"{base}/video.{ext}", format=opts.video_format, fps=cam.fps,
                        width=int(cam.width), height=int(cam.height), n_frames=int(frame_idx.size),
                        t0_s=float(kin.t[i0]), calibration_frame=0),
        force=ForceInfo(path=f"{base}/forces.npz", format="npz", fs_hz=fs, n_samples=int(kin.t.size),
                        channels={"F1": "F1", "F2": "F2"}, units="N", t0_s=0.0),
        calibration={"surface_height_mm": float(_feature_height(surf))},
        truth=f"truth/{spec.id}.npz",
    )
    return TrialPlan(spec, kin, frame_idx, rec)


def _feature_height(surf: Surface) -> float:
    h = getattr(surf, "height", None)
    return float(h) if h is not None else float(surf.max_height)


def frame_outline(kin: Kinematics, table: ContactTable, i: int) -> tuple[float, np.ndarray, np.ndarray]:
    """The finger's lower outline at force sample ``i``, as the camera draws it.

    Parameters
    ----------
    kin : Kinematics
        The trial's kinematics (:attr:`TrialPlan.kin`).
    table : ContactTable
        The trial's contact table.
    i : int
        Force-sample index (``TrialPlan.frame_idx[k]`` for frame ``k``).

    Returns
    -------
    x_c : float
        Finger centre in mm.
    y_f : (m,) ndarray
        Outline heights in mm on ``x_c + table.xi`` (lifted by the finger's height when
        it is off the surface).
    p : (m,) ndarray
        Contact pressure on the same grid (zero off the surface).
    """
    x_c = float(kin.x[i])
    y_f, p = table.profile(x_c, float(kin.f_n[i]), pad=kin.pad)
    z = float(kin.z[i])
    if z > 0 or not kin.in_contact[i]:
        y_f = y_f + z
        p = np.zeros_like(p)
    return x_c, y_f, p


def simulate_trial(plan: TrialPlan, opts: SimOptions, table: ContactTable, law: ForceLaw | None = None,
                   root: Path | None = None) -> TrialRecord:
    """Simulate one trial and write its video, force and truth files under ``root``.

    ``law`` overrides the subject's :data:`~fingerfriction.sim.physics.SUBJECT_FORCE_LAWS`
    in the ``load-sharing`` world (other worlds ignore it).
    """
    if root is None:
        raise TypeError("simulate_trial needs root, the study folder")
    spec, rec = plan.spec, plan.record
    kin, forces, F1, F2, truth_extra = _trial_forces(plan, opts, table, law)
    surf = surface_from_spec(spec.surface_spec)
    frames = _write_video(plan, opts, table, kin, surf, root / rec.video.path)
    write_npz(root / rec.force.path, {"F1": F1, "F2": F2})
    load_exp = truth_extra.pop("mu_load_exponent")
    write_npz(root / rec.truth, {
        "t_force": kin.t, "x_finger_force": kin.x, "F_N": kin.f_n, "F_T": forces.f_t,
        "F_T_int": forces.f_int, "F_T_def": forces.f_def, **frames,
        "geom_tol_mm": np.float64(3.0 * opts.camera.mm_per_px),
        "mm_per_px": np.float64(opts.camera.mm_per_px),
        "x0_px": np.float64(opts.camera.x0_px), "y0_row": np.float64(opts.camera.y0_row),
        "mean_speed_mm_s": np.float64(kin.mean_speed), "z_finger_force": kin.z,
        "mu_load_exponent": np.float64(load_exp),
        "world": np.array(opts.world.name), "chain": np.array(opts.chain_name),
        "F_N_target": np.float64(kin.f_target),
        "approach_speed_mm_s": np.float64(kin.approach_speed), "t_touch_s": np.float64(kin.t_contact),
        **{k: np.asarray(v, np.float64) if np.ndim(v) == 0 else np.asarray(v)
           for k, v in forces.truth.items()},
        **{k: np.asarray(v) for k, v in truth_extra.items()},
    })
    return rec


def _trial_forces(plan: TrialPlan, opts: SimOptions, table: ContactTable, law: ForceLaw | None):
    """The trial's normal force (the participant's coupling to the relief with the realistic
    chain), the world's forces and the recorded channels: ``(kin, WorldForces, F1, F2,
    truth)``, ``kin`` with the normal force on the plate, ``truth`` the chain's per-trial
    values (and ``mu_load_exponent``)."""
    spec, kin = plan.spec, plan.kin
    _, rs, _ = trial_rngs(spec, opts.seed)
    fs = opts.kinematics.fs_hz
    truth: dict = {}
    if opts.chain_name == "realistic":
        rp = trial_stream(spec, opts.seed, "participant")
        f_n, participant = couple_normal_force(kin, table, opts.chain, rp)
        kin = replace(kin, f_n=f_n)
        truth.update(participant)
    mu_scale, load_exp, f_ref = 1.0, 0.0, 0.3
    if opts.realism is not None:
        mu_scale = opts.realism.trial_mu_scale(realism_rng(spec, opts.seed))
        load_exp, f_ref = opts.realism.mu_load_exponent, opts.realism.f_ref_n
    motion = TrialMotion(t=kin.t, x=kin.x, f_n=kin.f_n, sliding_distance=kin.sliding_distance,
                         in_contact=kin.in_contact, mean_speed=kin.mean_speed, f_target=kin.f_target,
                         t_slide_start=kin.t_slide_start)
    world = opts.world
    kw = {"law": law} if isinstance(world, LoadSharing) else {}
    forces = world.trial_forces(table, motion, spec.subject, trial_stream(spec, opts.seed, "world"),
                                mu_scale=mu_scale, load_exponent=load_exp, f_ref_n=f_ref, **kw)
    # friction follows contact length, not load, in the constant-pressure world
    truth["mu_load_exponent"] = 0.0 if world.name == "constant-pressure" else load_exp
    chain = None
    if opts.chain_name == "realistic":
        chain = draw_trial_chain(trial_stream(spec, opts.seed, "chain"), kin.t.size, fs, opts.chain,
                                 _device(opts.seed, opts.chain))
        truth.update(chain.truth(fs))
    F1, F2 = apply_sensor(kin.f_n, forces.f_t, rs, opts.sensor, chain=chain)
    return kin, forces, F1, F2, truth


def _write_video(plan: TrialPlan, opts: SimOptions, table: ContactTable, kin: Kinematics, surf: Surface,
                 path: Path) -> dict:
    """Render and write the trial's video; return the per-frame truth (``t_video``,
    ``x_finger_video``, ``has_finger``, ``regions_mech``, ``regions_geom``, ``field_mm``,
    ``regions_geom_clipped``)."""
    rec = plan.record
    _, _, rc = trial_rngs(plan.spec, opts.seed)
    cam = Camera(surf, opts.camera)
    tol = 3.0 * opts.camera.mm_per_px
    xi = table.xi
    n_f = plan.frame_idx.size
    has_finger = np.zeros(n_f, bool)
    geom_masks, mech_masks, grids = [], [], []
    cp = cam.params
    vw = VideoWriter(path, opts.video_format, cp.width, cp.height, cp.fps)
    try:
        for k, i in enumerate(plan.frame_idx):
            if k == rec.video.calibration_frame:
                vw.write(cam.render(None, rc))
                geom_masks.append(None)
                mech_masks.append(None)
                grids.append(None)
                continue
            x_c, y_f, p = frame_outline(kin, table, i)
            rows = cam.finger_rows(x_c, xi, y_f)
            has_finger[k] = bool(np.any(rows > -0.5))
            vw.write(cam.render(rows, rc))
            X = x_c + xi
            h = np.asarray(surf.h(X), float)
            grids.append(X)
            geom_masks.append(geometric_mask(xi, y_f, h, tol))
            mech_masks.append(p > 0)
        vw.close()
    except BaseException:
        vw.abort()
        raise
    reg_geom = _stack_regions(grids, geom_masks)
    field_mm = np.array([(-0.5 - cp.x0_px) * cp.mm_per_px, (cp.width - 0.5 - cp.x0_px) * cp.mm_per_px])
    with np.errstate(invalid="ignore"):
        clipped = (np.any(reg_geom[..., 0] < field_mm[0], axis=1)
                   | np.any(reg_geom[..., 1] > field_mm[1], axis=1))
    return {"t_video": kin.t[plan.frame_idx],
            "x_finger_video": np.where(has_finger, kin.x[plan.frame_idx], np.nan),
            "has_finger": has_finger, "regions_mech": _stack_regions(grids, mech_masks),
            "regions_geom": reg_geom, "field_mm": field_mm, "regions_geom_clipped": clipped}


_DEVICES: dict = {}


def _device(seed: int, chain: RealisticChain) -> dict:
    """The study's sensor device (:func:`~fingerfriction.sim.chain.draw_device`), cached."""
    key = (int(seed), chain)
    if key not in _DEVICES:
        _DEVICES.clear()
        _DEVICES[key] = draw_device(seed, chain)
    return _DEVICES[key]


def _stack_regions(grids, masks) -> np.ndarray:
    per = []
    for X, m in zip(grids, masks, strict=True):
        if X is None or not m.any():
            per.append(np.full((1, 1, 2), np.nan))
        else:
            per.append(regions_from_mask(X, m))
    k = max(r.shape[1] for r in per)
    out = np.full((len(per), k, 2), np.nan)
    for t, r in enumerate(per):
        out[t, : r.shape[1]] = r[0]
    return out


# ---------------------------------------------------------------------------------------
# the study


def _truth_header(opts: SimOptions) -> dict:
    provider = opts.provider()
    subjects = {
        s: {"finger": provider.finger_dict(s), "force_law": SUBJECT_FORCE_LAWS[s].to_dict()}
        for s in opts.subjects
    }
    chain = {"name": opts.chain_name}
    if opts.chain_name == "realistic":
        chain.update(params=opts.chain.to_dict(), device=_device(opts.seed, opts.chain))
    return {
        "format": TRUTH_FORMAT,
        "schema_version": 1,
        "contact_model": provider.name,
        "geom_tol_mm": 3.0 * opts.camera.mm_per_px,
        "options": opts.to_dict(),
        "subjects": subjects,
        "world": opts.world.to_dict(),
        "chain": chain,
    }


def _check_folder(out: Path, header: dict) -> bool:
    """True if ``out`` already holds this study (resume); raise if it holds anything else."""
    if not out.exists():
        return False
    if not out.is_dir():
        raise StudyFolderError(f"output {out} exists and is not a folder")
    entries = [e for e in os.listdir(out)]
    if not entries:
        return False
    sj = out / "truth" / "study.json"
    if not sj.is_file():
        raise StudyFolderError(
            f"output folder {out} is not empty and holds no simulated study (no truth/study.json); "
            "choose an empty or new folder"
        )
    try:
        old = json.loads(sj.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise StudyFolderError(f"{sj}: cannot read the existing study's description ({exc}); "
                               "choose an empty or new folder") from None
    if old != json.loads(json.dumps(header)):
        diff = _first_difference(old, json.loads(json.dumps(header)))
        raise StudyFolderError(
            f"output folder {out} already holds a different study ({diff}); nothing was written. "
            "Use a new folder, or the same options to resume"
        )
    return True


def _first_difference(a, b, path: str = "") -> str:
    if isinstance(a, dict) and isinstance(b, dict):
        for k in list(a) + [k for k in b if k not in a]:
            if k not in a or k not in b:
                return f"{path + k}: only in {'the existing' if k in a else 'the new'} study"
            if a[k] != b[k]:
                return _first_difference(a[k], b[k], f"{path}{k}.")
    return f"{path.rstrip('.') or 'value'}: existing {a!r}, requested {b!r}"


def _trial_complete(root: Path, rec: TrialRecord) -> bool:
    return all((root / p).is_file() for p in (rec.video.path, rec.force.path, rec.truth))


# worker-side cache: one table at a time (trials are submitted grouped by table)
_TABLE_CACHE: dict = {}


def _get_table(paths: tuple[str, ...]) -> ContactTable:
    if paths not in _TABLE_CACHE:
        _TABLE_CACHE.clear()
        _TABLE_CACHE[paths] = ContactTable.stack([ContactTable.load(p) for p in paths])
    return _TABLE_CACHE[paths]


def _init_worker(env: dict) -> None:
    """The caller's package variables (``_workers.package_environ``); one OpenCV thread per
    worker process: the pool already uses every core."""
    os.environ.update(env)
    cv2.setNumThreads(1)


def _table_task(surface_spec: str, subject: str, load: float, opts: SimOptions, path: str) -> str:
    """Tabulate one load of one (surface, subject): loads are separate tasks so that a
    study with few surfaces still keeps every worker busy."""
    if not os.path.exists(path):
        surf = surface_from_spec(surface_spec)
        table = build_table(surf, subject, loads=(load,), step=opts.table_step,
                            provider=opts.provider(), geom_tol_mm=3.0 * opts.camera.mm_per_px)
        table.save(path)
    return path


def _trial_task(spec: TrialSpec, opts: SimOptions, table_paths: tuple[str, ...], root: str) -> str:
    plan = plan_trial(spec, opts)
    simulate_trial(plan, opts, _get_table(table_paths), SUBJECT_FORCE_LAWS[spec.subject], Path(root))
    return spec.id


def simulate_study(out: str | os.PathLike, opts: SimOptions | None = None, *, workers: int | None = None,
                   description: str = "", progress: Callable[[str, int, int, str], None] | None = None,
                   ) -> Study:
    """Simulate a study into the folder ``out``.

    Parameters
    ----------
    out : path-like
        Output folder: new, empty, or holding the same study (its complete trials are
        kept, the others simulated).
    opts : SimOptions, optional
        The design and models (default: the paper's 180-trial design, seed 0).
    workers : int, optional
        Worker processes (default: ``os.cpu_count()``); results do not depend on it.
    description : str
        Free text for the manifest.
    progress : callable, optional
        ``progress(stage, done, total, label)`` after each table and trial
        (``stage`` is ``'tables'`` or ``'trials'``).

    Returns
    -------
    Study
        The manifest written to ``out/manifest.json``.

    Raises
    ------
    StudyFolderError
        If ``out`` holds anything else than this study; nothing is written.
    ValueError
        For invalid options.
    """
    opts = opts or SimOptions()
    if workers is None:
        workers = os.cpu_count() or 1
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers must be an integer >= 1, got {workers!r}")
    if workers > 1:
        check_main_guard("simulate_study", alternative="or pass workers=1")
    out = Path(out)
    header = _truth_header(opts)
    resume = _check_folder(out, header)
    specs = opts.trial_specs()
    # plan every trial (cheap) to validate the whole design before writing; keep only the
    # records (the workers re-plan their trial: kinematics are deterministic)
    plans = [(s, plan_trial(s, opts).record) for s in specs]

    out.mkdir(parents=True, exist_ok=True)
    if not resume:
        atomic_write_text(out / "truth" / "study.json", json.dumps(header, indent=2) + "\n")
    todo = [(s, r) for s, r in plans if not _trial_complete(out, r)]
    log.info("simulate: %d trials, %d to do (%d complete)", len(plans), len(todo), len(plans) - len(todo))

    cache = out / ".cache"
    groups: dict[tuple[str, str], list[TrialSpec]] = {}
    for p in todo:
        groups.setdefault((p[0].surface_spec, p[0].subject), []).append(p[0])
    table_paths = {
        key: tuple(
            str(cache / f"table-{surface_from_spec(key[0]).name}-s{key[1]}-load{j}.npz")
            for j in range(len(opts.table_loads))
        )
        for key in groups
    }
    if todo:
        _run_tasks(out, opts, groups, table_paths, workers, progress)
    study = _study(opts, [r for _, r in plans], out, description)
    write_manifest(study, out)
    return study


def _run_tasks(out: Path, opts: SimOptions, groups: dict, table_paths: dict, workers: int,
               progress) -> None:
    """The contact tables of every (surface, subject) to simulate, then its trials, in
    ``workers`` processes (in this one for 1); the tables' cache is removed at the end."""
    cache = out / ".cache"
    cache.mkdir(exist_ok=True)
    if workers > 1:
        ex = ProcessPoolExecutor(max_workers=workers, mp_context=forkserver_context(),
                                 initializer=_init_worker, initargs=(package_environ(),))
    else:
        ex = _Serial()
    try:
        futs = {
            ex.submit(_table_task, key[0], key[1], load, opts, table_paths[key][j]): (key, load)
            for key in groups
            for j, load in enumerate(opts.table_loads)
        }
        done_n = 0
        for f in _as_completed(futs):
            f.result()
            done_n += 1
            if progress:
                (surf_spec, subj), load = futs[f]
                progress("tables", done_n, len(futs), f"{surf_spec} s{subj} {load:g} N")
        tfuts = {}
        for key, plist in groups.items():
            for p in plist:
                tfuts[ex.submit(_trial_task, p, opts, table_paths[key], str(out))] = p.id
        done_n = 0
        for f in _as_completed(tfuts):
            f.result()
            done_n += 1
            if progress:
                progress("trials", done_n, len(tfuts), tfuts[f])
    except BaseException:
        ex.shutdown(wait=True, cancel_futures=True)
        raise
    ex.shutdown(wait=True)
    shutil.rmtree(cache, ignore_errors=True)


def _study(opts: SimOptions, records: list, out: Path, description: str) -> Study:
    """The manifest of the simulated study (every trial's record, the surfaces' specs)."""
    surfaces = {}
    for s in opts.surfaces:
        surf = surface_from_spec(s)
        surfaces[surf.name] = surf.to_dict()
    return Study(
        trials=tuple(records),
        surfaces=surfaces,
        description=description or (
            f"virtual experiment: {len(opts.subjects)} subjects x {len(opts.surfaces)} surfaces x "
            f"{len(opts.speeds)} speeds x {opts.reps} repetitions, seed {opts.seed}"
        ),
        created_by=f"fingerfriction {__version__} simulate",
        root=out.resolve(),
    )


def _as_completed(futs):
    pending = set(futs)
    while pending:
        done, pending = wait(pending, return_when=FIRST_COMPLETED)
        # deterministic order among simultaneously finished futures is irrelevant: files
        # do not depend on completion order
        yield from done


class _Serial:
    """A stand-in executor running tasks in the calling process (workers=1)."""

    def shutdown(self, wait: bool = True, cancel_futures: bool = False) -> None:
        pass

    def submit(self, fn, *args):
        f: Future = Future()
        try:
            f.set_result(fn(*args))
        except BaseException as e:  # noqa: BLE001 - re-raised by f.result()
            f.set_exception(e)
        return f


def default_options(**kw) -> SimOptions:
    """:class:`SimOptions` with the paper's design, overridden by ``kw``."""
    return SimOptions(**kw)


__all__ += ["default_options", "SimFinger", "geometric_distance", "geometric_mask"]
