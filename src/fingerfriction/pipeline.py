"""The study pipeline: every trial through video analysis and force processing, in
parallel on Dask, into a resumable results store; then the model fit.

Data flow of one trial (:func:`process_trial`)::

    video file --(fingerfriction.video)--> per frame: t, x(t), contact regions C_i, flags
    force file --(fingerfriction.forces)--> F_T(t) -> with x(t) -> F_T(x) on a 0.01 mm grid

:func:`analyze` runs :func:`process_trial` for every trial of a study on a
``dask.distributed`` cluster (a :class:`~distributed.LocalCluster` of one single-threaded
process per core by default, or an existing scheduler given by address), and the client
writes each result into the :class:`~fingerfriction.results.ResultsStore` as it arrives.
Finished trials are skipped on the next run unless ``force=True``; a trial that fails is
recorded with a one-line reason and the others go on.

:func:`fit` then fits the friction model (Eq. 1-5 of Janko et al. 2018, through
:mod:`fingerfriction.fit`) to the stored trials: ``mu`` per subject by grid search,
``p0, p1`` per trial, and writes the model forces with their interfacial (Eq. 2) and
deformation (Eq. 3) parts.

The results folder layout is documented in :mod:`fingerfriction.results`.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
import platform
import sys
import time
import traceback
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from ._atomic import atomic_write_json, atomic_write_text
from ._progress import ProgressBar as _Progress
from ._progress import stage_progress
from .predict import validate_results
from .regions import regions_on_grid
from .results import (
    ResultsStore,
    atomic_write_parquet,
    frames_table,
    params_digest,
    regions_from_table,
    sha256_file,
)

__all__ = [
    "AnalysisParams",
    "TrialResult",
    "TrialOutcome",
    "AnalyzeResult",
    "FitSummary",
    "process_trial",
    "analyze",
    "fit",
    "regions_on_grid",
    "sim_params",
    "POSITIONS",
    "PIPELINE_VIDEO_DEFAULTS",
    "SIM_PARAMS",
    "SIM_CF_CENTROID_PARAMS",
]

logger = logging.getLogger(__name__)

_LABELS = ("subject", "surface", "speed_mm_s", "repetition")

#: Packages whose versions go into the run record.
_VERSIONED = (
    "fingerfriction", "numpy", "scipy", "pandas", "pyarrow", "dask", "distributed",
    "opencv-python-headless", "scikit-image", "av", "tifffile", "h5py", "nptdms",
    "matplotlib", "jinja2",
)


# --------------------------------------------------------------------------------------
# parameters and per-trial results
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class AnalysisParams:
    """Options of the per-trial analysis: passed through to the two stages.

    Parameters
    ----------
    video : dict
        Keyword options of the video analysis (:class:`fingerfriction.video.AnalysisOptions`);
        empty means the paper's Methods (3 px contact tolerance, the 0.4 mm line, ...)
        except for :data:`PIPELINE_VIDEO_DEFAULTS`: x(t) from the hybrid estimator
        (``position='hybrid'``; ``{'position': 'cf-centroid'}`` gives the paper's centroid
        of C_f).
    forces : dict
        Keyword options of :class:`fingerfriction.forces.ForceProcessingParams`; empty
        means the paper's Methods (notches at 50/150/300 Hz, 500 Hz low-pass, a 26 mm
        window on a 0.01 mm grid).

    Notes
    -----
    :meth:`resolved` expands both into the stages' full parameter sets (defaults
    included); that is what the run record stores and what decides whether a finished
    trial was computed with the same parameters.
    """

    video: Mapping = field(default_factory=dict)
    forces: Mapping = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("video", "forces"):
            v = getattr(self, name)
            if not isinstance(v, Mapping):
                raise TypeError(f"AnalysisParams.{name} must be a dict of options, got {type(v).__name__}")
            object.__setattr__(self, name, dict(v))

    def resolved(self) -> dict:
        """``{'video': {...}, 'forces': {...}}`` with every stage parameter spelled out.

        Raises
        ------
        ValueError
            An unknown or invalid option (from the stage's own validation).
        """
        return {"video": _video_params(self.video), "forces": _force_params(self.forces)}


def _force_params(opts: Mapping) -> dict:
    from .forces import ForceProcessingParams

    try:
        return ForceProcessingParams(**dict(opts)).to_dict()
    except TypeError as exc:  # unknown keyword
        raise ValueError(f"force option: {exc}") from None


#: Video options of the pipeline that differ from the video stage's own defaults
#: (:class:`fingerfriction.video.AnalysisOptions`); an explicit option overrides them.
#:
#: * ``position='hybrid'``: x(t) is the chord midpoint where the finger's chord is in
#:   view, else one outline edge 4 mm above the feature top offset-matched per video
#:   (:func:`fingerfriction.video.tracking.hybrid_positions`), with contact regions kept
#:   where C_f is out of view. The paper's centroid of C_f (``position='cf-centroid'``)
#:   is tracked only while C_f is whole inside the crop: with the calibrated simulated
#:   finger and the 29.4 mm field of view, over about -5 to +5 mm, far short of the
#:   paper's 26 mm window. Measured on /work/studies/small (36 simulated trials): the
#:   hybrid covers the 26 mm window in 36 of 36 trials with no force-stage flag (no x(t)
#:   extrapolation, no translated regions); on /work/studies/full its x(t) RMS error is
#:   <= 0.022 mm per trial (video benchmark).
#: * ``n_max_regions=16``: frames where the finger enters the view can show more than 8
#:   specks of contact, and the video stage then refuses the whole trial (2 of 36 trials
#:   of /work/studies/small with 8). To drop once the video stage handles such frames.
PIPELINE_VIDEO_DEFAULTS = {"position": "hybrid", "n_max_regions": 16}

#: The x(t) estimators the pipeline accepts (``AnalysisOptions.position``).
POSITIONS = ("hybrid", "cf-centroid", "chord")


def _video_options(opts: Mapping, calibration_frame: int | None = None):
    from .video import AnalysisOptions

    kw = {**PIPELINE_VIDEO_DEFAULTS, **dict(opts)}
    if calibration_frame is not None and "calibration_frame" not in kw:
        kw["calibration_frame"] = int(calibration_frame)
    try:
        return AnalysisOptions(**kw)
    except TypeError as exc:  # unknown keyword
        raise ValueError(f"video option: {exc}") from None


def _video_params(opts: Mapping) -> dict:
    d = dataclasses.asdict(_video_options(opts))
    d.pop("calibration_frame", None)  # per trial, from the manifest
    return d


@dataclass(frozen=True, eq=False)
class TrialResult:
    """What :func:`process_trial` returns for one trial.

    Attributes
    ----------
    trial_id : str
    frames : pandas.DataFrame
        Per-frame table (:func:`fingerfriction.results.frames_table`).
    forces : pandas.DataFrame
        Per-position table: ``x_mm``, ``F_T_N``, ``F_N_N`` (paper's footing), ``F_T_abs_N``,
        ``F_N_abs_N`` (absolute footing, NaN when unavailable), ``n_samples``.
    info : dict
        Stage diagnostics (calibration, threshold used, flagged-frame counts, ...).
    """

    trial_id: str
    frames: pd.DataFrame
    forces: pd.DataFrame
    info: dict = field(default_factory=dict)


@dataclass(frozen=True)
class TrialOutcome:
    """What happened to one trial in :func:`analyze` (passed to the callback).

    ``status`` is ``'ok'``, ``'failed'`` or ``'skipped'``; ``reason`` is the one-line
    reason of a failure (empty otherwise); ``elapsed_s`` the processing time in s.
    """

    trial_id: str
    status: str
    reason: str = ""
    elapsed_s: float = 0.0


@dataclass(frozen=True)
class AnalyzeResult:
    """Summary of an :func:`analyze` run.

    Attributes
    ----------
    results : Path
        The results folder.
    n_trials, n_computed, n_skipped, n_failed : int
        Trials in the study; computed OK in this run; skipped (already finished);
        failed in this run.
    failures : tuple of (str, str)
        ``(trial_id, reason)`` of each failure of this run.
    elapsed_s : float
        Wall time of the run in s.
    compute_s : float
        Wall time in s from the first trial submitted to the last result written (the run
        without connecting to or starting the cluster).
    scheduler : str
        Scheduler address used (or ``'local'`` for a LocalCluster started here).
    n_workers : int
        Number of workers that ran the trials.
    """

    results: Path
    n_trials: int
    n_computed: int
    n_skipped: int
    n_failed: int
    failures: tuple[tuple[str, str], ...]
    elapsed_s: float
    scheduler: str
    n_workers: int
    compute_s: float = 0.0

    @property
    def success(self) -> bool:
        """True if every trial of the study is finished OK."""
        return self.n_failed == 0 and self.n_computed + self.n_skipped == self.n_trials


# --------------------------------------------------------------------------------------
# the per-trial work (runs on a Dask worker)
# --------------------------------------------------------------------------------------


def _trial_dict(trial: Any) -> dict:
    """The manifest record of a trial as a plain dict."""
    if isinstance(trial, Mapping):
        return dict(trial)
    for attr in ("to_dict", "as_dict"):
        f = getattr(trial, attr, None)
        if callable(f):
            return dict(f())
    if dataclasses.is_dataclass(trial):
        return dataclasses.asdict(trial)
    raise TypeError(f"trial must be a manifest trial record or a dict, got {type(trial).__name__}")


def _resolve(study_dir: Path, rel: str, what: str) -> Path:
    """Resolve a manifest path inside the study folder (refusing escapes)."""
    from .study import resolve_path

    return Path(resolve_path(study_dir, rel, where=what))


def _frame_reasons(flags: np.ndarray) -> list[str]:
    """One string per frame: '' for a good frame, else its flag reasons joined by '; '."""
    from .video import FLAG_REASONS, FrameFlag

    text = {}
    for v in np.unique(flags):
        f = FrameFlag(int(v))
        text[int(v)] = "; ".join(FLAG_REASONS[b] for b in FrameFlag if b in f)
    return [text[int(v)] for v in flags]


def _run_video(study_dir: Path, trial: dict, surface_spec: dict, options: Mapping) -> dict:
    """Video stage (:func:`fingerfriction.video.analyze_video`) on one trial.

    Returns t_s, x_mm, regions, flags (one string per frame), frame, info. Raises
    ``ValueError`` for a video that is unusable as a whole: unreadable, truncated (fewer
    frames than the manifest announces, or a decoding error), or without a single
    tracked frame.
    """
    from .surfaces import surface_from_spec
    from .video import analyze_video

    v = trial["video"]
    path = _resolve(study_dir, v["path"], "video.path")
    surface = surface_from_spec(surface_spec) if surface_spec else None
    H = float((trial.get("calibration") or {}).get("surface_height_mm", math.nan))
    if not math.isfinite(H) and surface is not None:
        H = surface.max_height
    opts = _video_options(options, v.get("calibration_frame"))
    res = analyze_video(path, H, surface=surface, options=opts)
    if res.truncated:
        raise ValueError(f"video {v['path']}: {res.message}")
    n_expected = v.get("n_frames")
    if n_expected is not None and res.n_frames != int(n_expected):
        raise ValueError(f"video {v['path']} has {res.n_frames} frames, the manifest says {n_expected}")
    if not res.success:
        raise ValueError(f"video {v['path']}: no frame could be tracked ({res.message})")
    fps = float(v.get("fps") or res.fps)
    k = np.arange(res.n_frames)
    info = {"message": res.message, "mm_per_px": res.mm_per_px, "threshold": res.threshold,
            "area_px": res.area_px, "reference_frame": res.reference_frame,
            "flag_counts": res.flag_counts(), "timings": res.timings,
            "clipped_frames": int(np.count_nonzero(res.clipped))}
    return {"t_s": float(v.get("t0_s", 0.0)) + k / fps, "x_mm": np.asarray(res.x, dtype=float),
            "regions": np.asarray(res.regions, dtype=float), "flags": _frame_reasons(res.flags),
            "frame": k, "info": info,
            "clipped": res.clipped}


def _run_forces(study_dir: Path, trial: dict, surface_spec: dict, video_out: dict, options: Mapping):
    """Force stage adapter: the trial's F_T(x) table and diagnostics."""
    from . import forces

    manifest = {"trials": [trial], "surfaces": {trial.get("surface"): surface_spec}}
    prof = forces.process_trial(
        study_dir, manifest, trial["id"], video_out["x_mm"],
        params=forces.ForceProcessingParams(**dict(options)), regions=video_out["regions"], on_error="raise",
    )
    info = {"flags": [f"{f.code}: {f.message}" for f in prof.flags],
            "flat_segment_mm": list(prof.flat_segment_mm), "message": prof.message,
            "absolute": bool(prof.absolute), "absolute_message": prof.absolute_message}
    if not prof.success:  # on_error='raise' should have raised; never keep unusable values
        raise ValueError(f"force processing failed: {prof.message}")
    return prof.to_frame(), info


def process_trial(study_dir: str | os.PathLike, trial, params: AnalysisParams | None = None,
                  *, surface_spec: dict | None = None) -> TrialResult:
    """Run one trial through video analysis, then force processing.

    Parameters
    ----------
    study_dir : path
        The study folder (manifest paths are resolved inside it).
    trial : dict or manifest trial record
        The trial's manifest entry (``docs/study-format.md``).
    params : AnalysisParams, optional
        Analysis options; the paper's by default.
    surface_spec : dict, optional
        The trial's surface spec from the manifest's ``surfaces`` (passed to the stages).

    Returns
    -------
    TrialResult

    Raises
    ------
    ValueError, OSError
        Unusable input (a path escaping the study, a corrupt file, ...), from the stages.
    """
    params = params or AnalysisParams()
    study_dir = Path(study_dir)
    rec = _trial_dict(trial)
    tid = rec.get("id")
    v = _run_video(study_dir, rec, surface_spec or {}, params.video)
    forces_df, f_info = _run_forces(study_dir, rec, surface_spec or {}, v, params.forces)
    frames = frames_table(v["t_s"], v["x_mm"], v["regions"], v["flags"], frame=v["frame"],
                          clipped=v["clipped"])
    n_flag = int(sum(1 for s in v["flags"] if s))
    info = {"video": v["info"], "forces": f_info, "n_frames": len(frames), "n_flagged_frames": n_flag,
            "n_positions": len(forces_df)}
    return TrialResult(trial_id=str(tid), frames=frames, forces=forces_df, info=info)


def _one_line(exc: BaseException) -> str:
    msg = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {msg}" if msg else type(exc).__name__


def _run_trial(study_dir: str, trial: dict, surface_spec: dict, params: dict) -> dict:
    """Dask task: process one trial, never raise; return tables or a one-line reason."""
    t0 = time.perf_counter()
    c0 = time.process_time()  # CPU of this worker process (all its threads)
    study = Path(study_dir)
    inputs: dict[str, dict] = {}
    try:
        for key in ("video", "force"):
            rel = (trial.get(key) or {}).get("path")
            if not rel:
                raise ValueError(f"trial {trial.get('id')!r}: manifest field {key}.path is missing")
            p = _resolve(study, rel, f"{key}.path")
            st = p.stat()
            inputs[key] = {"path": rel, "sha256": sha256_file(p), "bytes": st.st_size,
                           "mtime_ns": st.st_mtime_ns}
        res = process_trial(study, trial, AnalysisParams(**params), surface_spec=surface_spec)
        return {"ok": True, "frames": res.frames, "forces": res.forces, "info": res.info,
                "inputs": inputs, "elapsed_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0}
    except Exception as exc:  # a failing trial is recorded, the others go on
        logger.debug("trial %s failed:\n%s", trial.get("id"), traceback.format_exc())
        return {"ok": False, "reason": _one_line(exc), "inputs": inputs,
                "elapsed_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0}


# --------------------------------------------------------------------------------------
# orchestration
# --------------------------------------------------------------------------------------


def _versions() -> dict:
    from . import __version__

    out = {"python": sys.version.split()[0]}
    for name in _VERSIONED:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    if out.get("fingerfriction") is None:  # running from a source tree
        out["fingerfriction"] = __version__
    return out


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def _load_study(study: str | os.PathLike):
    """(study_dir, manifest dict with 'trials' as plain dicts) via fingerfriction.study."""
    from .study import load_manifest

    study_dir = Path(study)
    if not study_dir.is_dir():
        raise ValueError(f"study folder {str(study_dir)!r} does not exist or is not a folder")
    m = load_manifest(study_dir)
    if isinstance(m, Mapping):
        d = dict(m)
    elif hasattr(m, "to_dict"):
        d = dict(m.to_dict())
    elif dataclasses.is_dataclass(m):
        d = dataclasses.asdict(m)
    else:
        raise TypeError(f"load_manifest returned {type(m).__name__}")
    d["trials"] = [_trial_dict(t) for t in d.get("trials", [])]
    surfaces = d.get("surfaces", {}) or {}
    d["surfaces"] = {k: (v.to_dict() if hasattr(v, "to_dict") else dict(v)) for k, v in surfaces.items()}
    return study_dir, d


def analyze(
    study: str | os.PathLike,
    out: str | os.PathLike,
    *,
    scheduler: str | None = None,
    n_workers: int | None = None,
    force: bool = False,
    progress: bool = True,
    params: AnalysisParams | None = None,
    callback: Callable[[TrialOutcome], None] | None = None,
    trials: Sequence[str] | None = None,
) -> AnalyzeResult:
    """Analyse every trial of a study in parallel on Dask; resumable.

    Parameters
    ----------
    study : path
        The study folder (``manifest.json``, ``docs/study-format.md``).
    out : path
        The results folder (created; layout in :mod:`fingerfriction.results`).
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:port``). By default a
        :class:`~distributed.LocalCluster` is started with one single-threaded worker
        process per core and closed at the end. Workers must see the study folder at
        the same path; results travel back to this process, which writes them.
    n_workers : int, optional
        Workers of the LocalCluster (default: all cores, ``os.cpu_count()``); ignored
        with ``scheduler``.
    force : bool
        Recompute every trial, even finished ones (default False: skip them).
    progress : bool
        Show a rich progress bar on stderr.
    params : AnalysisParams, optional
        Analysis options (the paper's by default). Trials finished with other
        parameters are recomputed.
    callback : callable, optional
        Called in this process with a :class:`TrialOutcome` after each trial is recorded
        (and for each skipped trial). An exception raised by it stops the run; what was
        recorded so far stays.
    trials : sequence of str, optional
        Analyse only these trial ids (default: every trial of the study).

    Returns
    -------
    AnalyzeResult

    Raises
    ------
    ValueError
        A missing or invalid study, a bad option.
    """
    params = params or AnalysisParams()
    if n_workers is not None and (not isinstance(n_workers, int) or n_workers < 1):
        raise ValueError(f"n_workers must be a positive integer, got {n_workers!r}")
    if scheduler is not None and (not isinstance(scheduler, str) or not scheduler.strip()):
        raise ValueError(f"scheduler must be an address such as 'tcp://127.0.0.1:8786', got {scheduler!r}")
    pdict = params.resolved()  # every stage parameter spelled out: recorded, and decides resumption
    pdigest = params_digest(pdict)
    study_dir, manifest = _load_study(study)
    study_dir = study_dir.resolve()
    selected = trials
    trials = all_trials = manifest["trials"]
    if not trials:
        raise ValueError(f"study {str(study_dir)!r} lists no trials")
    ids = [t.get("id") for t in trials]
    dup = sorted({i for i in ids if ids.count(i) > 1})
    if dup:
        raise ValueError(f"study {str(study_dir)!r}: duplicate trial ids {dup}")
    if selected is not None:
        if isinstance(selected, str):
            selected = [selected]
        unknown = sorted(set(selected) - set(ids))
        if unknown:
            raise ValueError(f"trials {unknown} are not in the study {str(study_dir)!r}")
        trials = [t for t in trials if t["id"] in set(selected)]
        ids = [t["id"] for t in trials]
    # Every manifest path must resolve inside the study folder (symbolic links included):
    # a study that points outside itself is refused before anything runs.
    for i, t in enumerate(trials):
        for key in ("video", "force"):
            rel = (t.get(key) or {}).get("path")
            if rel:
                _resolve(study_dir, rel, f"{study_dir / 'manifest.json'}: trials[{i}].{key}.path")
    store = ResultsStore(out)
    for tid in ids:
        store.trial_dir(tid)  # validates the id before anything runs
    raw = {"video": dict(params.video), "forces": dict(params.forces)}
    t_start = time.perf_counter()
    started = _now()

    todo, skipped = [], []
    for t in trials:
        if not force and store.is_finished(t["id"], pdigest) and _inputs_unchanged(study_dir, t, store):
            skipped.append(t["id"])
        else:
            todo.append(t)

    store.root.mkdir(parents=True, exist_ok=True)
    previous = _previous_runs(store)
    manifest_path = study_dir / "manifest.json"
    base_record = {
        "study": str(study_dir),
        "manifest_sha256": sha256_file(manifest_path) if manifest_path.is_file() else None,
        "parameters": pdict,
        "params_sha256": pdigest,
        # the x(t) estimator (also in parameters.video.position): 'hybrid' or the paper's 'cf-centroid'
        "x_estimator": pdict["video"]["position"],
        "versions": _versions(),
        "platform": {"system": platform.system(), "machine": platform.machine(),
                     "node": platform.node(), "cpu_count": os.cpu_count()},
        "surfaces": manifest.get("surfaces", {}),
        "trials": [{"id": t.get("id"), **{k: t.get(k) for k in _LABELS}} for t in all_trials],
        "truth": str(study_dir / "truth") if (study_dir / "truth" / "study.json").is_file() else None,
    }
    store.write_run({**base_record, "state": "running", "started": started, "runs": previous})

    n_ok = n_fail = 0
    failures: list[tuple[str, str]] = []
    bar = _Progress(progress, len(trials), "analyze")
    sched_name, workers_used = "none", 0
    t_submit = t_done = None
    try:
        for tid in skipped:
            bar.advance(f"{tid} (done before)")
            if callback is not None:
                callback(TrialOutcome(tid, "skipped"))
        if todo:
            import dask
            from distributed import Client, LocalCluster, as_completed

            cluster = None
            if scheduler is None:
                nw = n_workers or os.cpu_count() or 1
                # allowed-failures=0: a trial that kills its worker (a crash in a decoder)
                # is reported at once instead of being retried on, and killing, the others.
                with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
                    cluster = LocalCluster(n_workers=nw, threads_per_worker=1, processes=True,
                                           dashboard_address=None, silence_logs=logging.ERROR)
                client = Client(cluster)
                sched_name = "local"
            else:
                client = Client(scheduler, timeout="20s")
                sched_name = scheduler
            try:
                workers_used = len(client.scheduler_info().get("workers", {}))
                surfaces = manifest.get("surfaces", {})
                futures = {}
                t_submit = time.perf_counter()
                for t in todo:
                    fut = client.submit(_run_trial, str(study_dir), t, surfaces.get(t.get("surface"), {}),
                                        raw, key=f"fingerfriction-trial-{t['id']}-{pdigest[:12]}",
                                        pure=False, retries=0)
                    futures[fut] = t
                for fut in as_completed(futures):
                    t = futures[fut]
                    tid = t["id"]
                    try:
                        res = fut.result()
                    except Exception as exc:  # worker died (KilledWorker), cancelled, ...
                        res = {"ok": False, "reason": _one_line(exc), "inputs": {}, "elapsed_s": 0.0}
                    fut.release()
                    status = {"params_sha256": pdigest, "inputs": res.get("inputs", {}),
                              "elapsed_s": round(float(res.get("elapsed_s", 0.0)), 4),
                              "cpu_s": round(float(res.get("cpu_s", 0.0)), 4),
                              "finished": _now(),
                              "labels": {k: t.get(k) for k in _LABELS}}
                    if res["ok"]:
                        store.write_trial(tid, res["frames"], res["forces"], {**status, "info": res["info"]})
                        n_ok += 1
                        outcome = TrialOutcome(tid, "ok", "", status["elapsed_s"])
                    else:
                        store.write_failure(tid, res["reason"], status)
                        n_fail += 1
                        failures.append((tid, res["reason"]))
                        logger.warning("trial %s failed: %s", tid, res["reason"])
                        outcome = TrialOutcome(tid, "failed", res["reason"], status["elapsed_s"])
                    t_done = time.perf_counter()
                    bar.advance(tid if res["ok"] else f"{tid} FAILED")
                    if callback is not None:
                        callback(outcome)
            finally:
                client.close()
                if cluster is not None:
                    cluster.close()
    finally:
        bar.close()
        elapsed = time.perf_counter() - t_start
        compute = (t_done - t_submit) if (t_submit is not None and t_done is not None) else 0.0
        this_run = {"started": started, "finished": _now(), "elapsed_s": round(elapsed, 3),
                    "compute_s": round(compute, 3),
                    "scheduler": sched_name, "n_workers": workers_used, "force": bool(force),
                    "computed": n_ok, "skipped": len(skipped), "failed": n_fail,
                    "interrupted": n_ok + n_fail + len(skipped) < len(trials)}
        inputs = {}
        trial_status = {}
        for tid in (t["id"] for t in all_trials):
            st = store.status(tid) or {}
            inputs[tid] = st.get("inputs", {})
            trial_status[tid] = {"status": st.get("status", "not run"), "reason": st.get("reason", "")}
        store.write_run({**base_record, "state": "interrupted" if this_run["interrupted"] else "complete",
                         "started": started, "finished": this_run["finished"],
                         "runs": [*previous, this_run], "inputs": inputs, "trial_status": trial_status})

    return AnalyzeResult(results=store.root, n_trials=len(trials), n_computed=n_ok, n_skipped=len(skipped),
                         n_failed=n_fail, failures=tuple(failures), elapsed_s=elapsed,
                         scheduler=sched_name, n_workers=workers_used, compute_s=compute)


def _inputs_unchanged(study_dir: Path, trial: dict, store: ResultsStore) -> bool:
    """True if the trial's input files have the size and modification time recorded when it
    was analysed (a cheap check: hashing every video again would cost as much as reading it)."""
    rec = (store.status(trial["id"]) or {}).get("inputs", {})
    for key in ("video", "force"):
        r = rec.get(key) or {}
        rel = (trial.get(key) or {}).get("path")
        if r.get("path") != rel:
            return False
        try:
            st = _resolve(study_dir, rel, f"{key}.path").stat()
        except (OSError, ValueError):
            return False
        if st.st_size != r.get("bytes") or st.st_mtime_ns != r.get("mtime_ns"):
            logger.info("trial %s: %s changed since it was analysed; recomputing", trial["id"], rel)
            return False
    return True


def _previous_runs(store: ResultsStore) -> list:
    try:
        return list(store.read_run().get("runs", []))
    except ValueError:
        return []


# --------------------------------------------------------------------------------------
# fit
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class FitSummary:
    """Summary of :func:`fit`.

    Attributes
    ----------
    mu : dict of str to float
        Per-subject friction coefficient.
    n_trials : int
        Trials fitted.
    n_failed : int
        Trial fits that did not succeed (or trials that could not be prepared).
    failures : tuple of (str, str)
        ``(trial_id, reason)``.
    messages : dict of str to str
        Per-subject grid-search message.
    loso : pandas.DataFrame or None
        The out-of-sample validation (:func:`fingerfriction.predict.validate_results`:
        leave one surface out, rho per held-out surface, one row per subject or "Both
        subjects" and surface), also in ``fit/loso.csv``; None when not computed (one
        surface only, ``validate=False``, or it failed: see ``loso_message``).
    loso_message : str
        How the validation went ('' when computed).
    """

    mu: dict
    n_trials: int
    n_failed: int
    failures: tuple[tuple[str, str], ...]
    messages: dict
    loso: Any = None
    loso_message: str = ""


def fit(
    results: str | os.PathLike,
    *,
    mu_grid: tuple[float, float, float] = (0.30, 0.90, 0.01),
    method: str = "lstsq",
    median_kernel: int = 11,
    progress: bool = True,
    validate: bool = True,
) -> FitSummary:
    """Fit the friction model to every finished trial of a results folder.

    ``mu`` per subject by grid search (every trial refitted at each grid value), ``p0``
    and ``p1`` per trial (:func:`fingerfriction.fit.fit_trials`), then the model forces
    of Eq. (4) with their parts F_int (Eq. 2) and F_def (Eq. 3) on each trial's grid.

    Parameters
    ----------
    results : path
        A results folder written by :func:`analyze`.
    mu_grid : (start, stop, step)
        Inclusive ``mu`` grid (default 0.30 to 0.90 by 0.01, 61 values).
    method : {'lstsq', 'nelder-mead'}
        How ``p0, p1`` are fitted (closed form by default; Nelder-Mead as the paper).
    median_kernel : int
        Median filter window in samples on the model (odd; 1 = off).
    progress : bool
        Show a progress bar.
    validate : bool
        Also run the out-of-sample validation (leave one surface out,
        :func:`fingerfriction.predict.validate_results`) when the study has at least two
        surfaces: ``fit/loso.csv`` and ``fit/loso.png``, shown next to Table 1 by the
        report. It costs about 20 s for 36 simulated trials (one process; measured).

    Returns
    -------
    FitSummary

    Writes ``fit/fit.json``, ``fit/subjects.csv``, ``fit/trials.csv``,
    ``fit/model/<trial-id>.parquet`` and, with ``validate``, ``fit/loso.csv`` and
    ``fit/loso.png`` (layout in :mod:`fingerfriction.results`). A validation that fails
    is logged and recorded in ``fit.json`` (``loso``); the fit itself stands.
    """
    from . import fit as fitmod
    from .model import FrictionModel
    from .surfaces import surface_from_spec

    store = ResultsStore(results)
    run = store.read_run()
    start, stop, step = (float(v) for v in mu_grid)
    grid = fitmod.mu_grid(start, stop, step)
    options = fitmod.FitOptions(median_kernel=int(median_kernel))
    surfaces = {k: surface_from_spec(v) for k, v in run.get("surfaces", {}).items()}
    meta = {t["id"]: t for t in run.get("trials", [])}

    trials, tids, failures = [], [], []
    ok_ids = [tid for tid in meta if (store.status(tid) or {}).get("status") == "ok"]
    if not ok_ids:
        raise ValueError(f"{str(store.root)!r} has no successfully analysed trial to fit")
    bar = _Progress(progress, len(ok_ids) + 1, "fit")
    grids: dict[str, np.ndarray] = {}  # per trial: positions with translated regions
    try:
        for tid in ok_ids:
            m = meta[tid]
            try:
                fr = store.read_frames(tid)
                fo = store.read_forces(tid)
                x = fo["x_mm"].to_numpy(float)
                F = fo["F_T_N"].to_numpy(float)
                good = np.isfinite(F)
                reg, moved = regions_on_grid(fr["x_mm"].to_numpy(float), regions_from_table(fr), x,
                                             return_translated=True)
                surf = surfaces[m["surface"]]
                n_flat = int(np.count_nonzero(fitmod.flat_segment_mask(reg[good], surf,
                                                                       margin=options.flat_margin)))
                if n_flat < 2:  # the fit detrends over this segment; one such trial must not stop the others
                    raise ValueError(
                        f"no flat segment: {n_flat} positions where all contact lies before the feature "
                        f"(x(t) tracked over [{np.nanmin(fr['x_mm']):.2f}, {np.nanmax(fr['x_mm']):.2f}] mm)")
                trials.append(fitmod.Trial(
                    x=x[good], force=F[good], regions=reg[good], surface=surf, subject=str(m["subject"]),
                    labels={"trial": tid, "surface": m["surface"], "speed_mm_s": f"{m['speed_mm_s']:g}"}))
                tids.append(tid)
                grids[tid] = moved[good]
            except (ValueError, KeyError, OSError) as exc:
                failures.append((tid, _one_line(exc)))
            bar.advance(tid)
        if not trials:
            reasons = "; ".join(r for _, r in failures[:3])
            raise ValueError(f"no trial could be prepared for fitting: {reasons}")
        fits = fitmod.fit_trials(trials, grid=grid, method=method, options=options)
        bar.advance("grid search")
    finally:
        bar.close()

    rows, subj_rows = [], []
    by_id = {t.labels["trial"]: t for t in trials}
    models: dict[str, Any] = {}
    for subject, sf in fits.items():
        subj_rows.append({"subject": subject, "mu": sf.mu, "objective": float(np.min(sf.curve)),
                          "success": sf.success, "message": sf.message})
        for tf in sf.trials:
            tid = tf.labels["trial"]
            tr = by_id[tid]
            m = meta[tid]
            rows.append({"trial": tid, "subject": subject, "surface": m["surface"],
                         "speed_mm_s": m["speed_mm_s"], "repetition": m.get("repetition"),
                         "mu": tf.mu, "p0": tf.p0, "p1": tf.p1, "objective": tf.objective,
                         "success": tf.success, "message": tf.message})
            if not tf.success:
                failures.append((tid, tf.message))
            model = models.setdefault(m["surface"], FrictionModel(tr.surface))
            # Eq. (2)-(4) with the fitted p0, p1 as they are (FrictionParams would refuse
            # the unphysical p0 < 0 of a failed fit; its row in trials.csv says it failed).
            B = model.basis(tr.regions, tf.mu)
            f_int, f_def = tf.p0 * B[:, 0], tf.p1 * B[:, 1]
            f_tot = f_int + f_def
            df = pd.DataFrame({"x_mm": tr.x, "F_T_N": tf.measured, "F_hat_N": tf.estimate,
                               "F_model_N": f_tot, "F_int_N": f_int, "F_def_N": f_def,
                               "F_T_raw_N": tr.force, "regions_translated": grids[tid]})
            atomic_write_parquet(store.fit_dir / "model" / f"{tid}.parquet", df)
    trials_df = pd.DataFrame(rows)
    subj_df = pd.DataFrame(subj_rows)
    atomic_write_text(store.fit_dir / "trials.csv", trials_df.to_csv(index=False))
    atomic_write_text(store.fit_dir / "subjects.csv", subj_df.to_csv(index=False))
    record = {
        "mu_grid": {"start": start, "stop": stop, "step": step, "n": int(grid.size)},
        "method": method, "options": dataclasses.asdict(options),
        "mu": {s: sf.mu for s, sf in fits.items()},
        "curves": {s: {"grid": sf.grid, "objective": sf.curve} for s, sf in fits.items()},
        "messages": {s: sf.message for s, sf in fits.items()},
        "n_trials": len(trials), "failures": [{"trial": t, "reason": r} for t, r in failures],
        "finished": _now(),
    }
    atomic_write_json(store.fit_dir / "fit.json", record)  # validate_results reads the grid from it
    loso, loso_message = _validate_after_fit(store, trials, validate)
    record["loso"] = {"computed": loso is not None, "message": loso_message,
                      "csv": "loso.csv" if loso is not None else None}
    atomic_write_json(store.fit_dir / "fit.json", record)
    return FitSummary(mu={s: sf.mu for s, sf in fits.items()}, n_trials=len(trials), n_failed=len(failures),
                      failures=tuple(failures), messages={s: sf.message for s, sf in fits.items()},
                      loso=loso, loso_message=loso_message)


def _validate_after_fit(store: ResultsStore, trials: Sequence, validate: bool):
    """Leave-one-surface-out validation after :func:`fit`: (table or None, message).

    A previous run's ``fit/loso.*`` is removed first, so the folder never holds a
    validation of another fit.
    """
    for name in ("loso.csv", "loso.png"):
        (store.fit_dir / name).unlink(missing_ok=True)
    if not validate:
        return None, "not requested"
    n_surf = len({t.labels["surface"] for t in trials})
    if n_surf < 2:
        return None, f"needs at least two surfaces, the study has {n_surf}"
    t0 = time.perf_counter()
    try:
        res = validate_results(store.root)
    # RuntimeError: predict finds no successful training fit without a surface (a small study)
    except (ValueError, KeyError, OSError, RuntimeError, np.linalg.LinAlgError) as exc:
        logger.warning("out-of-sample validation failed: %s", _one_line(exc))
        return None, f"failed: {_one_line(exc)}"
    logger.info("out-of-sample validation: %.1f s", time.perf_counter() - t0)
    return res.table, ""


# --------------------------------------------------------------------------------------
# demo: simulate -> analyze -> fit -> report
# --------------------------------------------------------------------------------------

#: Repetitions per condition of the demo: 1 by default (2 subjects x 6 surfaces x 3 speeds
#: = 36 trials, every cell of Table 1 filled and every speed in Fig. 4), 5 with ``full``
#: (the paper's 180 trials). Measured on this project's 2-core machine while shared (load
#: average 3-7): 101 s in all (simulate 61 s, analyze 22 s, fit 12 s of which the
#: leave-one-surface-out validation is most, report 7 s); 104 s wall for the command.
DEMO_REPS = 1
FULL_REPS = 5

#: Analysis options for simulated studies (the demo, the tests, the benchmark): none
#: beyond the pipeline's defaults. With the hybrid x(t) (:data:`PIPELINE_VIDEO_DEFAULTS`)
#: every trial of /work/studies/small (36 trials, all six surfaces) is analysed with the
#: paper's 26 mm window, no x(t) extrapolation and no translated regions.
SIM_PARAMS: dict = {"video": {}, "forces": {}}

#: Documented fallback for ``position='cf-centroid'`` (the paper's x(t)) on simulated
#: studies, where C_f is tracked only over about -5 to +5 mm (the calibrated simulated
#: finger is wide for the simulated camera's 29.4 mm field of view): a 22 mm window, x(t)
#: extended at constant speed by up to 8 mm beyond the tracked frames (flagged per trial;
#: regions outside the tracked span are translated with the finger, see
#: :func:`regions_on_grid`), and ``contact_half_width_mm=6.5`` (the simulated contact
#: reaches at most 5.9 mm from the finger centre on flat ground) so the 4 mm surfaces keep
#: a 2.5 mm flat segment for the drift fit. Measured worse than the hybrid on
#: /work/studies/full (x(t) error 0.23-0.56 mm); kept only to reproduce the paper's
#: estimator.
SIM_CF_CENTROID_PARAMS = {"video": {"position": "cf-centroid"},
                          "forces": {"window_mm": 22.0, "extrapolate_mm": 8.0, "contact_half_width_mm": 6.5}}


def sim_params(position: str = "hybrid") -> dict:
    """Analysis options (``{'video': ..., 'forces': ...}``) for a simulated study.

    Parameters
    ----------
    position : {'hybrid', 'cf-centroid', 'chord'}
        The x(t) estimator; 'cf-centroid' gets :data:`SIM_CF_CENTROID_PARAMS`.

    Raises
    ------
    ValueError
        An unknown estimator.
    """
    if position not in POSITIONS:
        raise ValueError(f"position must be one of {', '.join(map(repr, POSITIONS))}, got {position!r}")
    base = SIM_CF_CENTROID_PARAMS if position == "cf-centroid" else SIM_PARAMS
    out = {k: dict(v) for k, v in base.items()}
    out["video"]["position"] = position
    return out


@dataclass(frozen=True)
class DemoResult:
    """What :func:`demo` produced: the folders, and each step's summary."""

    study: Path
    results: Path
    analysis: AnalyzeResult
    fit: FitSummary
    report: Any
    elapsed_s: dict


def demo(out: str | os.PathLike, *, full: bool = False, reps: int | None = None, seed: int = 0,
         n_workers: int | None = None, progress: bool = True, design: Mapping | None = None) -> DemoResult:
    """Simulate the built-in default study, analyse it, fit the model and write the report.

    Parameters
    ----------
    out : path
        Folder receiving ``study/`` (the virtual experiment) and ``results/``. Re-running
        on the same folder resumes: finished trials are neither simulated nor analysed
        again.
    full : bool
        The paper's full design, 180 trials (5 repetitions); default: :data:`DEMO_REPS`
        repetition(s), 36 trials.
    reps : int, optional
        Repetitions per condition, overriding ``full``.
    seed : int
        Seed of the virtual experiment.
    n_workers : int, optional
        Worker processes for simulation and analysis (default: all cores).
    progress : bool
        Progress bars on stderr.
    design : dict, optional
        Overrides of the simulated design (``subjects``, ``surfaces``, ``speeds``), e.g.
        for a smaller demo; default: the paper's 2 subjects x 6 surfaces x 3 speeds.

    Returns
    -------
    DemoResult
    """
    from .report import make_report
    from .sim import SimOptions, simulate_study

    out = Path(out)
    reps = reps if reps is not None else (FULL_REPS if full else DEMO_REPS)
    study, results = out / "study", out / "results"
    times = {}
    t0 = time.perf_counter()
    cb, close = stage_progress(progress, "simulate")
    try:
        simulate_study(study, SimOptions(reps=reps, seed=seed, **dict(design or {})), workers=n_workers,
                       progress=cb,
                       description="fingerfriction demo: the paper's design, simulated")
    finally:
        close()
    times["simulate"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    ares = analyze(study, results, n_workers=n_workers, progress=progress,
                   params=AnalysisParams(**sim_params()))
    times["analyze"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    fres = fit(results, progress=progress)
    times["fit"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    rep = make_report(results, progress=progress)
    times["report"] = time.perf_counter() - t0
    return DemoResult(study=study, results=results, analysis=ares, fit=fres, report=rep, elapsed_s=times)
