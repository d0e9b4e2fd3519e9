"""One trial of a study through the two stages: typed in (:class:`TrialInput`, the
manifest's record of the trial with its surface and study folder), typed out
(:class:`~fingerfriction.study.results.AnalysedTrial`, what the results store writes), the
force processing's history and flags kept.

* :func:`run_video`: the video stage (:func:`fingerfriction.video.analyze_video`) with the
  pipeline's video options (:func:`fingerfriction.pipeline.params.video_options`);
* :func:`read_trial_forces` and :func:`process_trial_forces`: the force stage
  (:func:`fingerfriction.forces.process_forces`) on the trial's force file and frame times;
* :func:`check_trial_inputs`: the consistency stage between them
  (:mod:`fingerfriction.selfcheck`): channels, units, the force clock, the surface;
* :func:`process_trial`: all three, what ``analyze`` runs for every trial;
* :func:`finger_positions`: the per-frame finger positions the ``forces`` command uses
  (from the video, exactly as ``analyze``; a file; or a simulated study's truth).
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pandas as pd

from ..forces import (
    ForceProcessingParams,
    ForceProfile,
    ForceRecord,
    process_forces,
    read_force_file,
    sensor_signals,
)
from ..forces.readers import channel_scale
from ..selfcheck import SelfCheckError, SelfCheckParams, TrialChecks, check_trial
from ..study.manifest import Study, TrialRecord, load_manifest, resolve_path
from ..study.records import FORCE_READER_KEYS
from ..study.results import AnalysedTrial
from ..study.tables import frames_table
from ..surfaces import Surface, surface_from_spec
from ..video import FLAG_REASONS, AnalysisOptions, FrameFlag, PositionSource, analyze_video
from .params import AnalysisParams, force_params, video_options

__all__ = [
    "TrialInput",
    "VideoOutput",
    "run_video",
    "read_trial_forces",
    "process_trial_forces",
    "force_info",
    "check_trial_inputs",
    "process_trial",
    "finger_positions",
    "one_line",
]


@dataclass(frozen=True)
class TrialInput:
    """One trial of a study: what its analysis needs, typed.

    Attributes
    ----------
    root : Path
        The study folder (manifest paths are resolved inside it).
    record : TrialRecord
        The trial's manifest entry.
    surface_spec : dict
        Its surface's spec from the manifest's ``surfaces``.
    """

    root: Path
    record: TrialRecord
    surface_spec: dict

    @classmethod
    def from_study(cls, study: Study | str | os.PathLike, trial: TrialRecord | str) -> TrialInput:
        """The trial (a record or an id) of a study (a :class:`Study` or its folder).

        Raises
        ------
        KeyError
            An id that is not in the study (the message names it).
        ManifestError
            A study folder whose manifest is invalid.
        """
        if not isinstance(study, Study):
            study = load_manifest(study)
        rec = study.trial(trial) if isinstance(trial, str) else trial
        return cls(Path(study.root), rec, dict(study.surfaces[rec.surface]))

    @property
    def id(self) -> str:
        return self.record.id

    @property
    def surface(self) -> Surface:
        """The trial's relief."""
        return surface_from_spec(self.surface_spec)

    @property
    def height_mm(self) -> float:
        """The feature height H in mm that calibrates the image scale: the manifest's
        ``calibration.surface_height_mm``, else the surface's own feature height."""
        if self.record.calibration is not None:
            return float(self.record.calibration["surface_height_mm"])
        return float(self.surface.max_height)

    def path(self, relpath: str, where: str = "path") -> Path:
        """Absolute path of a manifest path of this trial (:func:`~.manifest.resolve_path`)."""
        return resolve_path(self.root, relpath, where=where)


@dataclass(frozen=True, eq=False)
class VideoOutput:
    """What the video stage gives the rest of the pipeline for one trial.

    Attributes
    ----------
    t_s : (n_frames,) ndarray
        Frame times in s on the trial's common clock (``video.t0_s + k / fps``).
    x_mm : (n_frames,) ndarray
        Finger position x(t) in mm (NaN where unknown).
    regions : (n_frames, n_max, 2) ndarray
        Contact regions in mm.
    flags : list of str
        Per frame: '' for a good frame, else its flag reasons joined by '; '.
    clipped : (n_frames,) bool ndarray
        A region ends at the edge of the field of view.
    info : dict
        Diagnostics (calibration, threshold, flag counts, timings).
    x_source : list of str or None
        Per frame, the estimator that gave x(t) (:func:`position_sources`).
    surface_rows : (width,) ndarray or None
        The calibration frame's surface profile, sub-pixel row per column of the crop
        (:attr:`fingerfriction.video.calibrate.Calibration.surface_row`).
    gap_mm : (n_frames,) ndarray or None
        The finger's lowest point above the surface per frame in mm (NaN where its outline
        was not found; :attr:`fingerfriction.video.VideoResult.gap_px`).
    """

    t_s: np.ndarray
    x_mm: np.ndarray
    regions: np.ndarray
    flags: list
    clipped: np.ndarray
    info: dict = field(default_factory=dict)
    x_source: list | None = None
    surface_rows: np.ndarray | None = None
    gap_mm: np.ndarray | None = None

    @property
    def frame(self) -> np.ndarray:
        """Frame indices ``0 .. n_frames - 1``."""
        return np.arange(self.t_s.size)


def _frame_reasons(flags: np.ndarray) -> list[str]:
    """One string per frame: '' for a good frame, else its flag reasons joined by '; '."""
    text = {}
    for v in np.unique(flags):
        f = FrameFlag(int(v))
        text[int(v)] = "; ".join(FLAG_REASONS[b] for b in FrameFlag if b in f)
    return [text[int(v)] for v in flags]



def position_sources(res, position: str) -> list[str]:
    """Per frame, the estimator that gave the video stage's x(t): ``chord``, ``left-edge``
    or ``right-edge`` for the hybrid estimator (:class:`~fingerfriction.video.PositionSource`),
    the estimator's own name for ``cf-centroid`` and ``chord``; ``''`` without a position."""
    has_x = np.isfinite(np.asarray(res.x, dtype=float))
    if position == "hybrid" and res.x_source is not None:
        names = {int(s): s.name.lower().replace("_", "-") for s in PositionSource}
        names[int(PositionSource.NONE)] = ""
        return [names.get(int(s), "") if ok else "" for s, ok in zip(res.x_source, has_x, strict=True)]
    return [position if ok else "" for ok in has_x]


def run_video(trial: TrialInput, options: AnalysisOptions | Mapping | None = None) -> VideoOutput:
    """Video stage (:func:`fingerfriction.video.analyze_video`) on one trial.

    Parameters
    ----------
    trial : TrialInput
    options : AnalysisOptions or dict, optional
        The video options; a dict (or None) goes through
        :func:`~fingerfriction.pipeline.params.video_options` with the trial's calibration
        frame, as ``analyze`` does.

    Raises
    ------
    ValueError
        A video that is unusable as a whole: unreadable, truncated (fewer frames than the
        manifest announces, or a decoding error), or without a single tracked frame.
    """
    v = trial.record.video
    opts = options if isinstance(options, AnalysisOptions) else video_options(options, v.calibration_frame)
    res = analyze_video(trial.path(v.path, "video.path"), trial.height_mm, surface=trial.surface,
                        options=opts)
    if res.truncated:
        raise ValueError(f"video {v.path}: {res.message}")
    if res.n_frames != v.n_frames:
        raise ValueError(f"video {v.path} has {res.n_frames} frames, the manifest says {v.n_frames}")
    if not res.success:
        raise ValueError(f"video {v.path}: no frame could be tracked ({res.message})")
    info = {"message": res.message, "mm_per_px": res.mm_per_px, "threshold": res.threshold,
            "area_px": res.area_px, "reference_frame": res.reference_frame,
            "flag_counts": res.flag_counts(), "timings": res.timings,
            "clipped_frames": int(np.count_nonzero(res.clipped))}
    return VideoOutput(t_s=v.frame_times(), x_mm=np.asarray(res.x, dtype=float),
                       regions=np.asarray(res.regions, dtype=float), flags=_frame_reasons(res.flags),
                       clipped=res.clipped, info=info, x_source=position_sources(res, opts.position),
                       surface_rows=np.asarray(res.calibration.surface_row, dtype=float),
                       gap_mm=None if res.gap_px is None else np.asarray(res.gap_px, float) * res.mm_per_px)




def read_trial_forces(study_dir: str | os.PathLike, trial: TrialInput | TrialRecord | Mapping) -> ForceRecord:
    """Read the force file of one trial of a study (``docs/study-format.md``).

    Parameters
    ----------
    study_dir : path-like
        The study folder (holding ``manifest.json``).
    trial : TrialInput, TrialRecord or dict
        The trial. A dict is one entry of the manifest's ``trials`` list as parsed from
        ``manifest.json``; its ``force`` field gives ``path`` and any of ``format``,
        ``fs_hz``, ``n_samples``, ``channels``, ``units``, ``sensitivity_n_per_v``,
        ``gain_v_per_n``, ``time``, ``delimiter``, ``t0_s`` (the keywords of
        :func:`~fingerfriction.forces.read_force_file`, lab files included).

    Returns
    -------
    ForceRecord

    Raises
    ------
    ValueError
        For a missing path, a bad field, or a path that escapes the study folder
        (:func:`~fingerfriction.study.manifest.resolve_path`); and any error of
        :func:`~fingerfriction.forces.read_force_file`, prefixed with the trial id.
    """
    if isinstance(trial, TrialInput):
        trial = trial.record
    if isinstance(trial, TrialRecord):
        f = trial.force
        return read_force_file(resolve_path(study_dir, f.path, where=f"trial {trial.id!r}: force.path"),
                               **f.reader_options())
    tid = trial.get("id", "?") if isinstance(trial, Mapping) else "?"
    force = trial.get("force") if isinstance(trial, Mapping) else None
    if not isinstance(force, Mapping):
        raise ValueError(f"trial {tid!r}: manifest entry has no 'force' object")
    if "path" not in force:
        raise ValueError(f"trial {tid!r}: manifest field force.path is missing")
    try:
        channel_scale(force.get("units", "N"), force.get("sensitivity_n_per_v"), force.get("gain_v_per_n"))
    except ValueError as exc:
        raise ValueError(f"trial {tid!r}: force.{exc}") from None
    target = resolve_path(study_dir, force["path"], where=f"trial {tid!r}: force.path")
    kw = {k: force[k] for k in FORCE_READER_KEYS if force.get(k) is not None}
    kw.setdefault("t0_s", 0.0)
    return read_force_file(target, **kw)


def process_trial_forces(trial: TrialInput, x_frames, *, params: ForceProcessingParams | None = None,
                         regions=None, on_error: str = "raise",
                         record: ForceRecord | None = None, sensor=None) -> ForceProfile:
    """Read and process the forces of one trial: :func:`~fingerfriction.forces.process_forces`
    on its force file, at its frame times, with the window centred on its surface's feature.

    Parameters
    ----------
    trial : TrialInput
    x_frames : (n_frames,) array_like
        Finger centre in mm at each video frame (NaN: no finger).
    params, regions, on_error
        As in :func:`~fingerfriction.forces.process_forces`.
    record : ForceRecord, optional
        The trial's force record already read (and, after the consistency stage, its
        clock corrected); default: read from its file.
    sensor : SensorSignals, optional
        Its sensor steps already run (:func:`fingerfriction.forces.sensor_signals`).

    Returns
    -------
    ForceProfile
    """
    record = read_trial_forces(trial.root, trial.record) if record is None else record
    tf = trial.record.video.frame_times()
    xf = np.asarray(x_frames, dtype=np.float64)
    if xf.shape != tf.shape:
        raise ValueError(f"x_frames has shape {xf.shape} but trial {trial.id!r} has {tf.size} frames")
    return process_forces(record, tf, xf, feature_extent_mm=tuple(trial.surface.feature_extent),
                          params=params, regions=regions, on_error=on_error, sensor=sensor)


def force_info(prof: ForceProfile) -> dict:
    """The force stage's diagnostics stored with a trial's results: flags, flat segment,
    footing, and the history of every processing step (JSON-serialisable)."""
    return {"flags": [f.to_dict() for f in prof.flags],  # Flag records: the level is kept
            "flat_segment_mm": list(prof.flat_segment_mm), "message": prof.message,
            "absolute": bool(prof.absolute), "absolute_message": prof.absolute_message,
            "history": [dict(h) for h in prof.history]}


def check_trial_inputs(trial: TrialInput, video: VideoOutput, record: ForceRecord,
                       params: AnalysisParams | None = None) -> TrialChecks:
    """The consistency stage of one trial (:func:`fingerfriction.selfcheck.check_trial`):
    its forces' channels and units, its force clock against the mains, its surface against
    the calibration frame, and the start of its slide for the synchronisation.

    Parameters
    ----------
    trial : TrialInput
    video : VideoOutput
        The video stage's output (:func:`run_video`).
    record : ForceRecord
        The trial's force record (:func:`read_trial_forces`).
    params : AnalysisParams, optional

    Returns
    -------
    TrialChecks
        Its ``record`` is the one to process (the sampling rate corrected by the mains
        with ``sync='auto'``), its ``sensor`` the force stage's sensor steps already run
        on it (:func:`fingerfriction.forces.sensor_signals`).
    """
    params = params or AnalysisParams()
    sc: SelfCheckParams = params.selfcheck_params()
    sensor = sensor_signals(record, force_params(params.forces))  # the force stage's own steps, reused
    rec = trial.record
    checks = check_trial(trial_id=trial.id, group=str(rec.subject), record=record, signals=sensor.signals,
                         t_frames=video.t_s, x_frames=video.x_mm, gap_mm=video.gap_mm,
                         regions=video.regions, surface_rows=video.surface_rows,
                         surface=trial.surface, height_mm=trial.height_mm, speed_mm_s=rec.speed_mm_s,
                         params=sc)
    return replace(checks, sensor=sensor if checks.record.fs_hz == record.fs_hz else None)


def process_trial(trial: TrialInput, params: AnalysisParams | None = None) -> AnalysedTrial:
    """Run one trial through video analysis, the consistency stage, then force processing.

    Parameters
    ----------
    trial : TrialInput
        The trial (:meth:`TrialInput.from_study`).
    params : AnalysisParams, optional
        Analysis options; the paper's by default.

    Returns
    -------
    AnalysedTrial
        The per-frame table (:func:`fingerfriction.study.tables.frames_table`), the regions
        array, the per-position table (``x_mm``, ``F_T_N``, ``F_N_N`` on the paper's footing,
        ``F_T_abs_N``, ``F_N_abs_N`` on the absolute footing, NaN when unavailable,
        ``n_samples``), and a status holding the stages' diagnostics under ``info``
        (calibration, threshold used, flagged-frame counts, ...; the force stage's flags
        with their level and, under ``info['forces']['history']``, every step of the force
        processing with its parameters and fitted values,
        :attr:`fingerfriction.forces.ForceSignals.history`).

    Raises
    ------
    SelfCheckError
        An error-level consistency check: the recordings contradict each other or the
        manifest (the message is the check's one-line reason).
    ValueError, OSError
        Unusable input (a path escaping the study, a corrupt file, ...), from the stages.
    """
    params = params or AnalysisParams()
    v = run_video(trial, video_options(params.video, trial.record.video.calibration_frame))
    record = read_trial_forces(trial.root, trial.record)
    checks = check_trial_inputs(trial, v, record, params)
    if checks.error is not None:
        raise SelfCheckError(checks.reason())
    prof = process_trial_forces(trial, v.x_mm, params=force_params(params.forces), regions=v.regions,
                                on_error="raise", record=checks.record, sensor=checks.sensor)
    if not prof.success:  # on_error='raise' should have raised; never keep unusable values
        raise ValueError(f"force processing failed: {prof.message}")
    forces_df = prof.to_frame()
    frames = frames_table(v.t_s, v.x_mm, v.regions, v.flags, frame=v.frame, clipped=v.clipped,
                          x_source=v.x_source)
    n_flag = int(sum(1 for s in v.flags if s))
    finfo = force_info(prof)
    finfo["flags"] += [c.to_flag().to_dict() for c in checks.warnings]  # shown in the report's warnings
    if checks.record.fs_hz != record.fs_hz:
        finfo["history"].insert(0, {"step": "synchronise", "fs_hz_manifest": record.fs_hz,
                                    "fs_hz_used": checks.record.fs_hz, "by": "mains frequency"})
    info = {"video": v.info, "forces": finfo, "n_frames": len(frames), "n_flagged_frames": n_flag,
            "n_positions": len(forces_df), "selfcheck": checks.to_dict()}
    rec = trial.record
    return AnalysedTrial(id=trial.id, subject=str(rec.subject), surface=rec.surface,
                         speed_mm_s=rec.speed_mm_s, repetition=rec.repetition, frames=frames,
                         regions=v.regions, forces=forces_df, status={"info": info})


def one_line(exc: BaseException) -> str:
    """``'<ExceptionType>: <message on one line>'``, how a failed trial's reason is recorded."""
    msg = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {msg}" if msg else type(exc).__name__


def finger_positions(trial: TrialInput, *, positions: str | os.PathLike | None = None,
                     from_truth: bool = False, from_video: bool = False, video: Mapping | None = None):
    """Per-frame finger positions in mm, and contact regions when they come from the video.

    Exactly one source: ``from_video`` (the video stage with the pipeline's options,
    :func:`run_video`, as ``analyze`` runs it; ``video`` overrides options), a
    ``positions`` file (``.npy``, or ``.csv`` with a column ``x_mm``, one value per
    frame), or ``from_truth`` (a simulated study's true finger positions).

    Returns
    -------
    x : (n_frames,) ndarray
    regions : (n_frames, n_max, 2) ndarray or None

    Raises
    ------
    ValueError
        No source or several, a file without ``x_mm``, a trial without truth.
    """
    if sum((positions is not None, from_truth, from_video)) > 1:
        raise ValueError("give only one of --positions, --from-video, --from-truth")
    if from_video:
        v = run_video(trial, video)
        return v.x_mm, v.regions
    if positions is not None:
        positions = os.fspath(positions)
        if positions.endswith(".npy"):
            return np.load(positions, allow_pickle=False), None
        df = pd.read_csv(positions)
        if "x_mm" not in df.columns:
            raise ValueError(f"{positions!r} has no column 'x_mm' (columns: {list(df.columns)})")
        return df["x_mm"].to_numpy(dtype=float), None
    if from_truth:
        if not trial.record.truth:
            raise ValueError(f"trial {trial.id!r} has no 'truth' file (not a simulated study)")
        with np.load(trial.path(trial.record.truth, f"trial {trial.id!r}: truth"), allow_pickle=False) as z:
            return np.asarray(z["x_finger_video"], dtype=float), None
    raise ValueError(
        "finger positions are needed: --from-video (run the video analysis), --positions FILE "
        "(x_mm per video frame; .csv with column x_mm or .npy) or --from-truth (simulated studies)"
    )
