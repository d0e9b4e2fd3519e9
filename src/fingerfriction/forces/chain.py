"""The force chain of one trial: :func:`process_forces`, from the two transducer channels
to ``F_T(x)`` on the position grid, one call per step, and its result
:class:`ForceProfile` (Methods "Force data processing" of Janko et al. 2018; the order of
the steps and the choices beyond the paper are explained in ``docs/forces.md``).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from .._atomic import atomic_write
from .._check import check_option, validate_type
from ..flags import Flag
from .checks import (
    ForceDataError,
    check_channels,
    check_flat_rest,
    check_flat_segment,
    check_record_covers_slide,
    check_resampling,
    check_window_covered,
)
from .filters import design_lowpass, design_notch
from .params import ForceProcessingParams
from .positions import (
    extrapolate_positions,
    flat_mask_from_regions,
    flat_segment_from_positions,
    positions_at_times,
    resample_to_positions,
)
from .readers import ForceRecord
from .rests import sensor_chain
from .signals import ForceSignals

__all__ = ["ForceProfile", "process_forces", "sensor_signals", "SensorSignals"]

logger = logging.getLogger(__name__)


@dataclass(frozen=True)
class ForceProfile:
    """Processed forces of one trial on the position grid (result of :func:`process_forces`).

    Attributes
    ----------
    x : (L,) ndarray
        Position grid in mm (finger centre), ``resolution_mm`` apart over the window.
    f_t, f_n : (L,) ndarray
        Tangential and normal force in N at each position, relative to their linear trend
        over the flat segment (the paper's footing; NaN when ``success`` is False and
        nothing could be computed).
    f_t_abs, f_n_abs : (L,) ndarray
        The same forces on the absolute footing: the high-pass inverted and the drift
        fitted on the unloaded rests removed, but *not* the paper's flat-segment line, so
        that the flat-ground level ``F_T = mu F_N`` is kept. All NaN when ``absolute`` is
        False.
    absolute : bool
        True when absolute levels could be had: the sensor's high-pass was inverted
        (``sensor_highpass_hz`` set) and at least one unloaded rest (before the touch or
        after the lift-off) anchored the drift. When False, ``absolute_message`` says why
        and only the paper's footing (``f_t``, ``f_n``) exists.
    absolute_message : str
        Why the absolute footing is missing ('' when it is available).
    counts : (L,) ndarray of int
        Force samples averaged per position bin (0: interpolated).
    signals : ForceSignals or None
        The processed time signals (with their history).
    x_at_samples : (n,) ndarray or None
        Finger position in mm at each force sample.
    flat_segment_mm : (float, float)
        Finger positions in mm bounding the flat segment used (regions: their extent).
    flat_mask : (n,) ndarray of bool or None
        The force samples of the flat segment (those the drift line was fitted on).
    window_mm : (float, float)
        First and last grid position in mm.
    flags : tuple of Flag
        Everything noticed about the input, warnings and errors.
    success : bool
        False when an error flag was raised (the values must not be used).
    message : str
        One line: "ok" or the first error.
    params : ForceProcessingParams
    """

    x: np.ndarray
    f_t: np.ndarray
    f_n: np.ndarray
    counts: np.ndarray
    signals: ForceSignals | None
    x_at_samples: np.ndarray | None
    flat_segment_mm: tuple[float, float]
    window_mm: tuple[float, float]
    flags: tuple = ()
    flat_mask: np.ndarray | None = None
    success: bool = True
    message: str = "ok"
    params: ForceProcessingParams = field(default_factory=ForceProcessingParams)
    f_t_abs: np.ndarray | None = None
    f_n_abs: np.ndarray | None = None
    absolute: bool = False
    absolute_message: str = ""

    @property
    def history(self) -> tuple:
        """Processing steps applied to the time signals."""
        return () if self.signals is None else self.signals.history

    def to_frame(self):
        """``pandas.DataFrame`` with columns ``x_mm, F_T_N, F_N_N, F_T_abs_N, F_N_abs_N,
        n_samples`` (the absolute columns are NaN when ``absolute`` is False)."""
        nan = np.full(self.x.shape, np.nan)
        f_t_abs = self.f_t_abs if self.f_t_abs is not None else nan
        f_n_abs = self.f_n_abs if self.f_n_abs is not None else nan
        return pd.DataFrame({"x_mm": self.x, "F_T_N": self.f_t, "F_N_N": self.f_n, "F_T_abs_N": f_t_abs,
                             "F_N_abs_N": f_n_abs, "n_samples": self.counts})

    def write_csv(self, path) -> None:
        """Write :meth:`to_frame` to ``path`` atomically (temporary file, then rename)."""
        frame = self.to_frame()
        atomic_write(path, lambda tmp: frame.to_csv(tmp, index=False, float_format="%.9g"))



def process_forces(record: ForceRecord, t_frames, x_frames, *,
                   feature_extent_mm: tuple[float, float] = (0.0, 0.0),
                   params: ForceProcessingParams | None = None, regions=None,
                   on_error: str = "raise", sensor: SensorSignals | None = None) -> ForceProfile:
    """Run the Methods' force processing on one trial: ``F_T(x)`` on the position grid.

    Steps, one call each: input checks (:mod:`.checks`); decomposition and the sensor
    chain (rest before the touch, mains, low-pass, high-pass compensation, rests' residual
    drift: :func:`_sensor_chain`); the flat segment and the paper's drift line over it;
    synchronisation with the video clock and resampling onto the position grid
    (:mod:`.positions`). ``docs/forces.md`` explains the choices made.

    Parameters
    ----------
    record : ForceRecord
        The two channels (N), with ``fs_hz`` and ``t0_s`` on the common clock.
    t_frames : (m,) array_like
        Frame times in s on the same clock (``video.t0_s + k / fps``).
    x_frames : (m,) array_like
        Finger centre ``x(t)`` in mm at each frame (NaN: no finger), from the video
        analysis or, in benchmarks, the ground truth.
    feature_extent_mm : (float, float)
        ``(x_start, x_end)`` in mm of the relief feature (``Surface.feature_extent``); the
        window is centred on its middle.
    params : ForceProcessingParams, optional
        Defaults: the paper's Methods.
    regions : (m, k, 2) array_like, optional
        Contact regions per frame (mm). When given and ``params.flat_segment_mm`` is None,
        the flat segment is the frames whose contact lies entirely before the feature
        (restricted to finger positions inside the window).
    on_error : {"raise", "flag"}
        ``"raise"`` (default): raise :class:`ForceDataError` on the first error found.
        ``"flag"``: return a :class:`ForceProfile` with ``success=False``, the reasons in
        ``flags`` and NaN forces wherever they could not be computed.
    sensor : SensorSignals, optional
        The sensor's steps already run on this record (:func:`sensor_signals`, with the
        same sampling rate and parameters): they are not run again.

    Returns
    -------
    ForceProfile

    Raises
    ------
    ForceDataError
        (``on_error="raise"``) for a run of NaN longer than ``max_nan_gap``, a clipped
        channel, a force record that does not cover the slide across the window (wrong
        ``fs_hz`` or clock offsets), a finger that never traverses the window, or a flat
        segment shorter than ``min_flat_mm``.
    ValueError
        For invalid arguments (e.g. a filter cut-off at or above Nyquist).
    """
    params, window, feature_start = _arguments(record, feature_extent_mm, params, on_error)
    tf = np.asarray(t_frames, dtype=np.float64)
    xf = np.asarray(x_frames, dtype=np.float64)
    flags: list[Flag] = []
    flat_mm = params.flat_segment_mm
    if flat_mm is None:
        flat_mm = flat_segment_from_positions(feature_start, window=window,
                                              contact_half_width_mm=params.contact_half_width_mm)
    checked = _checked_inputs(record, tf, xf, window, params, flags)
    if checked is None:
        return _failed(on_error, params, window, flat_mm, flags)
    f1, f2, t, x_at = checked
    if sensor is not None and sensor.fs_hz == record.fs_hz and sensor.params == params:
        sig, base, post = replace(sensor.signals, t0_s=record.t0_s), sensor.base, sensor.post
        flags.extend(sensor.flags)
    else:
        raw = ForceSignals.from_record(replace(record, f1=f1, f2=f2))
        sig, base, post = sensor_chain(raw, params, flags)
    mask, flat_mm, how = _flat_segment(t, tf, x_at, regions, feature_start, flat_mm, window, params)
    if not check_flat_segment(x_at, mask, how, params, flags):
        return _failed(on_error, params, window, flat_mm, flags)
    check_flat_rest(t, x_at, mask, window, flags)
    absolute, absolute_message = _absolute_footing(params, base, post, flags)
    sig_abs, sig = sig, sig.remove_drift(mask, segment=how)
    on_grid = _on_positions(x_at, sig, sig_abs if absolute else None, window, params, flags)
    if on_grid is None:
        return _failed(on_error, params, window, flat_mm, flags)
    res_t, res_n, f_t_abs, f_n_abs = on_grid
    for f in flags:  # returned in the profile's flags; logged for the record
        logger.info("forces: %s: %s", f.code, f.message)
    return ForceProfile(x=res_t.x, f_t=res_t.values, f_n=res_n.values, counts=res_t.counts, signals=sig,
                        x_at_samples=x_at, flat_segment_mm=flat_mm, window_mm=window, flags=tuple(flags),
                        flat_mask=mask, success=True, message="ok", params=params, f_t_abs=f_t_abs,
                        f_n_abs=f_n_abs, absolute=absolute, absolute_message=absolute_message)


@dataclass(frozen=True)
class SensorSignals:
    """The forces in time after the sensor's steps (:func:`sensor_signals`).

    Attributes
    ----------
    signals : ForceSignals
        ``F_N``, ``F_T`` in N on the force clock, with their history.
    flags : tuple of Flag
        What the sensor's steps noticed (a missing rest...), not the channels' checks.
    base : (n,) bool ndarray or None
        The unloaded rest before the touch.
    post : tuple or None
        The rest after the lift-off, ``(mask, description)``.
    fs_hz, params : float, ForceProcessingParams
        The sampling rate and parameters they were computed with (:func:`process_forces`
        reuses them only for the same ones).
    """

    signals: ForceSignals
    flags: tuple
    base: np.ndarray | None
    post: tuple | None
    fs_hz: float
    params: ForceProcessingParams


def sensor_signals(record: ForceRecord, params: ForceProcessingParams | None = None) -> SensorSignals:
    """The sensor's steps of :func:`process_forces` alone: the forces in time, before anything
    that needs the video (the clock offsets, positions, the flat segment).

    Decomposition, then the rest before the touch (drift line and mains), notch, low-pass,
    inversion of the sensor's high-pass and the rests' residual drift, as
    :func:`process_forces` does them; short NaN runs are filled as there (a clipped or
    NaN-ridden channel is flagged by :func:`process_forces`, not here).

    Parameters
    ----------
    record : ForceRecord
    params : ForceProcessingParams, optional

    Returns
    -------
    SensorSignals
        Pass it to :func:`process_forces` (``sensor=``) to process the same record
        without running these steps again.
    """
    params = ForceProcessingParams() if params is None else params
    f1, f2 = check_channels(record, params, [])
    f1 = np.where(np.isfinite(f1), f1, 0.0)
    f2 = np.where(np.isfinite(f2), f2, 0.0)
    flags: list[Flag] = []
    sig, base, post = sensor_chain(ForceSignals.from_record(replace(record, f1=f1, f2=f2)), params, flags)
    return SensorSignals(sig, tuple(flags), base, post, float(record.fs_hz), params)


def _failed(on_error: str, params: ForceProcessingParams, window, flat_mm, flags: list) -> ForceProfile:
    """After an error flag: raise the first error as :class:`ForceDataError`
    (``on_error="raise"``), or return the empty profile that carries the flags ("flag")."""
    err = next(f for f in flags if f.severity == "error")
    if on_error == "raise":
        raise ForceDataError(err.message)
    return _empty_profile(params, window, flat_mm, flags)


def _arguments(record: ForceRecord, feature_extent_mm, params, on_error: str):
    """Validated arguments of :func:`process_forces`: ``(params, window, feature_start)``.

    The filters are designed first: a cut-off above Nyquist is an argument error, not a
    data flag.
    """
    check_option("on_error", on_error, ("raise", "flag"))
    params = ForceProcessingParams() if params is None else params
    validate_type("params", params, ForceProcessingParams, "a ForceProcessingParams")
    fs = record.fs_hz
    design_notch(fs, params.notch_hz, params.notch_q)
    if params.lowpass_hz is not None:
        design_lowpass(fs, params.lowpass_hz, params.lowpass_order)
    a, b = (float(v) for v in feature_extent_mm)
    if not (math.isfinite(a) and math.isfinite(b) and b >= a):
        raise ValueError(
            f"feature_extent_mm must be (start, end) in mm with start <= end, got {feature_extent_mm!r}"
        )
    centre = 0.5 * (a + b)
    return params, (centre - params.window_mm / 2, centre + params.window_mm / 2), a


def _checked_inputs(record: ForceRecord, t_frames: np.ndarray, x_frames: np.ndarray, window,
                    params: ForceProcessingParams, flags: list):
    """The checks of the channels and of the finger's positions against the window and the
    record: ``(f1, f2, t, x_at)``, the checked channels (N), the sample times (s) and the
    finger position at each sample (mm, extended when the frames do not cover the window);
    None when an error flag was raised."""
    f1, f2 = check_channels(record, params, flags)
    t = record.times()
    xf = _extended_positions(t_frames, x_frames, window, params, flags)
    if xf is None:
        return None
    x_at = positions_at_times(t, t_frames, xf)
    if not check_window_covered(xf, window, params, flags):
        return None
    check_record_covers_slide(record, t_frames, xf, window, flags)
    if any(f.severity == "error" for f in flags):
        return None
    return f1, f2, t, x_at


def _extended_positions(t_frames: np.ndarray, x_frames: np.ndarray, window, params: ForceProcessingParams,
                        flags: list) -> np.ndarray | None:
    """The frames' finger positions, extended at constant speed when they do not cover the
    window (a warning flag); None, with an error flag, when no frame has a finger."""
    if not np.isfinite(x_frames).any():
        flags.append(Flag("error", "no-finger", "x_frames holds no finger position (all NaN)"))
        return None
    x_lo, x_hi = float(np.nanmin(x_frames)), float(np.nanmax(x_frames))
    if params.extrapolate_mm > 0 and (x_lo > window[0] or x_hi < window[1]):
        x_frames, ext = extrapolate_positions(t_frames, x_frames, max_mm=params.extrapolate_mm,
                                              fit_s=params.extrapolate_fit_s)
        if ext[0] > 0 or ext[1] > 0:
            flags.append(
                Flag(
                    "warning",
                    "extrapolated",
                    f"x(t) was tracked over [{x_lo:.3f}, {x_hi:.3f}] mm only; it was extended at constant "
                    f"speed (fitted over {params.extrapolate_fit_s * 1e3:g} ms of tracked frames) by "
                    f"{ext[0]:.2f} mm before and {ext[1]:.2f} mm after (allowed extrapolate_mm="
                    f"{params.extrapolate_mm:g} mm)",
                )
            )
    return x_frames


def _flat_segment(t, t_frames, x_at, regions, feature_start: float, flat_mm, window,
                  params: ForceProcessingParams):
    """The force samples of the flat segment: ``(mask, flat_mm, description)``.

    By finger position (``flat_mm``), or, with ``regions`` and no ``flat_segment_mm``,
    where the contact lies entirely before the feature: frames with regions decide by
    their contact; frames without (the video did not track the finger there, e.g. near the
    edge of its field) fall back on the position criterion, so the segment can still start
    at the window's left end.
    """
    if params.flat_segment_mm is None and regions is not None:
        flat_r, known = flat_mask_from_regions(t, t_frames, regions, feature_start, return_known=True)
        by_pos = (x_at >= flat_mm[0]) & (x_at <= flat_mm[1])
        mask = np.where(known, flat_r, by_pos) & (x_at >= window[0])
        how = (
            "contact regions entirely before the feature (finger centre in "
            f"[{flat_mm[0]:.3f}, {flat_mm[1]:.3f}] mm where a frame has no regions), inside the window"
        )
        if mask.any():
            flat_mm = (float(np.nanmin(x_at[mask])), float(np.nanmax(x_at[mask])))
        return mask, flat_mm, how
    mask = (x_at >= flat_mm[0]) & (x_at <= flat_mm[1])
    return mask, flat_mm, f"finger centre in [{flat_mm[0]:.3f}, {flat_mm[1]:.3f}] mm"


def _on_positions(x_at, sig: ForceSignals, sig_abs: ForceSignals | None, window,
                  params: ForceProcessingParams, flags: list):
    """Both forces (and, when given, their absolute footing) resampled onto the position grid,
    with the resampling's check: ``(res_t, res_n, f_t_abs or None, f_n_abs or None)``; None,
    with an error flag, when the force samples do not span the window."""
    resolution = params.resolution_mm
    try:  # the force samples, not just the frames, must span the window
        res_t = resample_to_positions(x_at, sig.f_t, window=window, resolution=resolution)
        res_n = resample_to_positions(x_at, sig.f_n, window=window, resolution=resolution)
        f_t_abs = f_n_abs = None
        if sig_abs is not None:
            f_t_abs = resample_to_positions(x_at, sig_abs.f_t, window=window, resolution=resolution).values
            f_n_abs = resample_to_positions(x_at, sig_abs.f_n, window=window, resolution=resolution).values
    except ValueError as exc:
        flags.append(Flag("error", "window", f"at the force sample times, {exc}"))
        return None
    check_resampling(res_t, params, flags)
    return res_t, res_n, f_t_abs, f_n_abs


def _absolute_footing(params: ForceProcessingParams, base, post, flags: list) -> tuple[bool, str]:
    """Whether the forces have an absolute level, and why not (a one-line message, flagged).

    The absolute footing is the signal before the paper's flat-segment line: it keeps the
    flat-ground level mu F_N that the line removes.
    """
    message = ""
    if params.sensor_highpass_hz is None:
        message = ("sensor_highpass_hz=None: the sensor's high-pass is not inverted, so the forces "
                   "are known only relative to the flat segment (the paper's footing)")
    elif base is None and post is None:
        message = ("no unloaded rest before the touch or after the lift-off anchors the drift: the "
                   "forces are known only relative to the flat segment (the paper's footing)")
    if message:
        flags.append(Flag("warning", "no-absolute", message))
    return not message, message


def _empty_profile(params, window, flat, flags, signals=None, x_at=None) -> ForceProfile:
    lo, hi = window
    n = int(round((hi - lo) / params.resolution_mm)) + 1
    x = lo + params.resolution_mm * np.arange(n)
    nan = np.full(n, np.nan)
    first = next(f for f in flags if f.severity == "error")
    return ForceProfile(
        x=x,
        f_t=nan,
        f_n=nan.copy(),
        counts=np.zeros(n, int),
        signals=signals,
        x_at_samples=x_at,
        flat_segment_mm=flat,
        window_mm=window,
        flags=tuple(flags),
        success=False,
        message=first.message,
        params=params,
    )
