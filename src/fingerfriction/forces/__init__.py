"""Force-sensor stage: read the two piezo channels, process them into ``F_T(x)``.

:mod:`~fingerfriction.forces.readers` reads the formats of the study manifest (CSV, NPZ,
MATLAB v5 / v7.3, TDMS, HDF5); :mod:`~fingerfriction.forces.processing` implements the
paper's "Force data processing" (decomposition, notch and low-pass filters, drift
removal, synchronisation with the video, resampling onto positions).
:func:`process_trial` runs both on one trial of a study.
"""

from __future__ import annotations

import os
from collections.abc import Mapping

import numpy as np

from .processing import (
    Flag,
    ForceDataError,
    ForceProcessingParams,
    ForceProfile,
    ForceSignals,
    HighpassEstimate,
    compensate_highpass,
    compose,
    decompose,
    design_lowpass,
    design_notch,
    detect_baseline,
    detect_post_baseline,
    estimate_highpass,
    extrapolate_positions,
    find_clipping,
    fit_baseline,
    fit_linear_drift,
    fit_rest_drift,
    flat_mask_from_regions,
    flat_segment_from_positions,
    lowpass_filter,
    nan_runs,
    notch_filter,
    positions_at_times,
    process_forces,
    remove_linear_drift,
    resample_to_positions,
)
from .readers import FORCE_FORMATS, ForceFileError, ForceRecord, read_force_file, read_trial_forces

__all__ = [
    "FORCE_FORMATS",
    "Flag",
    "ForceDataError",
    "ForceFileError",
    "ForceProcessingParams",
    "ForceProfile",
    "ForceRecord",
    "ForceSignals",
    "compensate_highpass",
    "compose",
    "decompose",
    "detect_baseline",
    "detect_post_baseline",
    "design_lowpass",
    "design_notch",
    "extrapolate_positions",
    "find_clipping",
    "fit_baseline",
    "fit_linear_drift",
    "fit_rest_drift",
    "estimate_highpass",
    "HighpassEstimate",
    "flat_mask_from_regions",
    "flat_segment_from_positions",
    "frame_times",
    "lowpass_filter",
    "nan_runs",
    "notch_filter",
    "positions_at_times",
    "process_forces",
    "process_trial",
    "read_force_file",
    "read_trial_forces",
    "remove_linear_drift",
    "resample_to_positions",
]


def frame_times(trial: Mapping) -> np.ndarray:
    """Frame times in s on the trial's common clock, ``video.t0_s + k / video.fps``.

    Parameters
    ----------
    trial : mapping
        One entry of a study manifest's ``trials`` (``docs/study-format.md``).

    Returns
    -------
    (n_frames,) ndarray
    """
    tid = trial.get("id", "?")
    video = trial.get("video")
    if not isinstance(video, Mapping):
        raise ValueError(f"trial {tid!r}: manifest entry has no 'video' object")
    for key in ("fps", "n_frames"):
        if key not in video:
            raise ValueError(f"trial {tid!r}: manifest field video.{key} is missing")
    fps = float(video["fps"])
    n = int(video["n_frames"])
    if not (np.isfinite(fps) and fps > 0) or n < 2:
        raise ValueError(
            f"trial {tid!r}: video.fps ({video['fps']!r}) must be positive and video.n_frames "
            f"({video['n_frames']!r}) at least 2"
        )
    return float(video.get("t0_s", 0.0)) + np.arange(n) / fps


def process_trial(
    study_dir: str | os.PathLike,
    manifest: Mapping,
    trial_id: str,
    x_frames,
    *,
    params: ForceProcessingParams | None = None,
    regions=None,
    on_error: str = "raise",
) -> ForceProfile:
    """Read and process the forces of one trial of a study.

    Parameters
    ----------
    study_dir : path-like
        The study folder.
    manifest : mapping
        Its parsed ``manifest.json``.
    trial_id : str
        The trial's ``id``.
    x_frames : (n_frames,) array_like
        Finger centre in mm at each video frame (NaN: no finger), e.g. from the video
        analysis.
    params, regions, on_error
        As in :func:`~fingerfriction.forces.processing.process_forces`.

    Returns
    -------
    ForceProfile
    """
    from ..surfaces import surface_from_spec

    trials = {t.get("id"): t for t in manifest.get("trials", [])}
    if trial_id not in trials:
        known = sorted(k for k in trials if k)
        more = "..." if len(known) > 5 else ""
        raise ValueError(f"no trial {trial_id!r} in the manifest; trials: {known[:5]}{more}")
    trial = trials[trial_id]
    surfaces = manifest.get("surfaces", {})
    if trial.get("surface") not in surfaces:
        raise ValueError(
            f"trial {trial_id!r}: surface {trial.get('surface')!r} is not in the manifest's surfaces"
        )
    surface = surface_from_spec(surfaces[trial["surface"]])
    record = read_trial_forces(study_dir, trial)
    tf = frame_times(trial)
    xf = np.asarray(x_frames, dtype=np.float64)
    if xf.shape != tf.shape:
        raise ValueError(f"x_frames has shape {xf.shape} but trial {trial_id!r} has {tf.size} frames")
    return process_forces(
        record,
        tf,
        xf,
        feature_extent_mm=tuple(surface.feature_extent),
        params=params,
        regions=regions,
        on_error=on_error,
    )
