"""Force-sensor stage: read the two piezo channels of a trial and process them into ``F_T(x)``
(Methods "Measurement apparatus" and "Force data processing" of Janko et al. 2018).

In the order of the data flow: :mod:`.readers` (CSV, NPZ, MATLAB v5 / v7.3, TDMS, HDF5),
:mod:`.sensor` (decomposition, drift, the sensor's high-pass and its rests),
:mod:`.filters` (notch and low-pass), :mod:`.positions` (synchronisation with the video
and resampling onto positions), :mod:`.checks` (input checks, flags), :mod:`.signals`
(the provenance object), :mod:`.params` (the options) and :mod:`.chain`
(:func:`process_forces`, the whole chain for one trial). The choices and the measured
figures behind them are in ``docs/forces.md``. A trial of a study (its manifest entry) is
processed by :func:`fingerfriction.pipeline.trial.process_trial_forces`.
"""

from __future__ import annotations

from .chain import ForceProfile, SensorSignals, process_forces, sensor_signals
from .checks import Flag, ForceDataError, find_clipping, nan_runs
from .filters import design_lowpass, design_notch, lowpass_filter, notch_filter
from .params import ForceProcessingParams
from .positions import (
    PositionResampling,
    extrapolate_positions,
    flat_mask_from_regions,
    flat_segment_from_positions,
    positions_at_times,
    resample_to_positions,
)
from .readers import FORCE_FORMATS, ForceFileError, ForceRecord, read_force_file
from .sensor import (
    BaselineFit,
    HighpassEstimate,
    RestDriftFit,
    compensate_highpass,
    compose,
    decompose,
    detect_baseline,
    detect_post_baseline,
    estimate_highpass,
    fit_baseline,
    fit_linear_drift,
    fit_rest_drift,
    remove_linear_drift,
)
from .signals import ForceSignals, describe_history, describe_step

__all__ = [
    "FORCE_FORMATS",
    "BaselineFit",
    "Flag",
    "ForceDataError",
    "ForceFileError",
    "ForceProcessingParams",
    "ForceProfile",
    "ForceRecord",
    "ForceSignals",
    "HighpassEstimate",
    "PositionResampling",
    "RestDriftFit",
    "compensate_highpass",
    "compose",
    "decompose",
    "describe_history",
    "describe_step",
    "design_lowpass",
    "design_notch",
    "detect_baseline",
    "detect_post_baseline",
    "estimate_highpass",
    "extrapolate_positions",
    "find_clipping",
    "fit_baseline",
    "fit_linear_drift",
    "fit_rest_drift",
    "flat_mask_from_regions",
    "flat_segment_from_positions",
    "lowpass_filter",
    "nan_runs",
    "notch_filter",
    "positions_at_times",
    "process_forces",
    "sensor_signals",
    "SensorSignals",
    "read_force_file",
    "remove_linear_drift",
    "resample_to_positions",
]
