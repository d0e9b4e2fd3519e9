"""Force data processing of the paper's Methods: from two piezo channels to ``F_T(x)``.

Implements "Measurement apparatus" and "Force data processing" of Janko, Wiertlewski &
Visell (2018):

1. decomposition of the two +-45 degree transducer channels into normal and tangential
   force, ``F_N = (F1 + F2) / sqrt(2)`` and ``F_T = (F1 - F2) / sqrt(2)``
   (:func:`decompose`);
2. removal of the mains interference at 50, 150 and 300 Hz: the paper's zero-phase notch
   filters (:func:`notch_filter`, ``mains="notch"``) or, by default, sinusoids fitted on
   the unloaded rest before the touch and subtracted (:func:`fit_baseline`, see below);
3. a zero-phase low-pass at 500 Hz (:func:`lowpass_filter`);
4. removal of the sensor drift: the best linear fit (in time) to the force over the flat
   segment before the feature is subtracted from the whole record
   (:func:`remove_linear_drift`), preceded, beyond the paper, by the compensation of the
   piezo chain's high-pass (:func:`fit_baseline`, :func:`compensate_highpass`,
   :func:`fit_rest_drift`; see below);
5. synchronisation with the video clock and association of ``F_T(t)`` with the finger
   position ``x(t)`` (:func:`positions_at_times`);
6. resampling onto positions at 0.01 mm over the 26 mm window centred on the feature
   (:func:`resample_to_positions`).

Order of the steps in :func:`process_forces`: decomposition; baseline (drift line and
mains fitted on the rest before the touch) subtracted; notch (if ``mains`` asks for it);
low-pass; high-pass compensation (at the cut-off estimated on the rests with
``estimate_highpass``); residual drift fitted through the compensation on the rests
before the touch and after the lift-off, subtracted; flat-segment linear fit removed;
positions.

The pure functions above are wrapped by :class:`ForceSignals`, a small object that
records every step applied to its data (``history``, in the manner of MNE-Python's
``Raw``), and by :func:`process_forces`, which runs the whole chain for one trial, checks
the input (NaN runs, clipping, sampling rate, window coverage) and returns a
:class:`ForceProfile` with its flags.

Notes
-----
**Forces and positions: which one is interpolated.** The forces are sampled at 10 kHz, the
video at 1 kHz. We keep the forces at their own rate and interpolate the finger position
``x(t)`` (smooth: the finger moves 0.04 to 0.12 mm per frame) linearly from the frame
times to the force sample times. Decimating the forces to the frame rate instead would put
the 500 Hz low-pass exactly at the 1 kHz Nyquist frequency, aliasing whatever the filter
leaves above it. The paper's text says the forces were "downsampled and filtered to
match the video sampling period of 0.1 ms"; 0.1 ms is the *force* sampling period and the
video period is 1 ms (Methods "Measurement apparatus"), so that sentence cannot be taken
literally; we read it as "associated with the video frames" and do the association in
the direction that loses nothing.

**Positions to grid.** ``F_T`` is averaged over every force sample whose finger position
falls in each 0.01 mm bin (bin centres ``x_k``, edges ``x_k +- 0.005 mm``). This is exact
for a monotonic slide and stays well defined when the finger stalls (many samples in one
bin are averaged) or moves back a little (the visits are averaged): both are flagged.
Bins no sample fell in (a fast slide moves 0.012 mm per sample at 120 mm/s) are filled
by linear interpolation between their neighbours and counted.

**The flat segment.** By default it is defined from the finger position: the finger
contact (about 16 mm wide, so ``contact_half_width_mm = 8``) lies entirely on the flat
ground before the feature while the finger centre is left of ``feature_start - 8 mm``;
the segment runs from the window's left end to there (``[-13, -9]`` mm for a 2 mm
feature centred at 0). It can also be given in mm, or derived from contact regions
(frames whose contact lies entirely left of the feature).

**Drift and the flat-ground friction level.** The piezo transducers are high-pass
(about 5 Hz) and drift; the fit on the flat segment removes the drift *and* whatever
constant/linear level the true force has there, so the recovered ``F_T(x)`` is the force
relative to its flat-ground trend, not the absolute friction force.

**The sensor's high-pass (beyond the paper).** A first-order high-pass at 5 Hz has a time
constant of 32 ms, while a slide across the 26 mm window lasts 0.2 to 0.65 s: the
recorded force is the *derivative-like* response of the true force (the friction level
set up when the slide starts decays away, slow features are distorted), and no linear
trend fitted on the flat segment can undo that. Measured on simulated trials, the paper's
procedure alone leaves RMS errors of 24 to 179 % of the peak-to-peak force (worst trial per
surface and speed; all 180 simulated trials are above 5 %; see
``benchmarks/forces.py``). We therefore invert the high-pass (:func:`compensate_highpass`,
``sensor_highpass_hz``, default 5 Hz as stated in the paper's Methods; ``None`` gives the
paper's procedure). The inverse is an integrator, so it turns a linear drift ``a t + b``
into ``b + (a + 2 pi fc b) t + pi fc a t**2``, which a linear fit no longer removes: the
drift line is therefore first estimated on the unloaded rest at the start of the record
(before the finger touches, where the true force is zero; :func:`fit_baseline`, fitted
together with the mains sinusoids, which the notch filters only remove later) and
subtracted, then the high-pass is inverted. That rest lasts only about 0.1 s, so the
slope of the line is uncertain, and a slope error ``da`` becomes ``da w0 t**2 / 2`` after
the inversion: on its own this left up to 5.4 % of the peak-to-peak at 40 mm/s (long
slides, small features; 1 of the 180 simulated trials above 5 %). The record usually also
ends with an unloaded rest after the lift-off (:func:`detect_post_baseline`,
``post_baseline``), where the true force is again zero: the images through the inversion
of an offset and a slope, ``C[1]`` and ``C[t]``, are fitted jointly on both rests and
subtracted (:func:`fit_rest_drift`); the lever arm of the whole record pins the slope.
Then the paper's flat-segment fit is applied. Measured on the 180 simulated trials
(``benchmarks/forces.py``, true positions): worst trial 5.43 % with the first rest alone,
2.30 % with both (40 mm/s: 5.43 -> 1.32 %). The mains sinusoids are not refitted on the
second rest: what is left of them there is at most 0.14 mN (0.5 % of the smallest
peak-to-peak, at the noise level; measured on 30 trials). Without a rest after the
lift-off (the record ends in contact) the first rest is used alone, with a flag. The
result depends on knowing the cut-off: a 5 % error in ``sensor_highpass_hz`` costs up to
18 % of the peak-to-peak force with the default flat segment, the same with the first rest
alone (18.5 %; measured in the benchmark).

**The cut-off estimated on the rests (opt-in, beyond the paper).** With
``estimate_highpass=True`` the cut-off itself is fitted on the two rests
(:func:`estimate_highpass`): the compensated signal is affine in ``w0 = 2 pi fc``, its
derivative being the running integral of the recorded signal, so ``w0`` (shared by ``F_N``
and ``F_T``) and each channel's drift offset and slope are fitted jointly on the rests,
iterated to convergence (Levenberg-Marquardt), then the record is compensated at the
estimate. Measured on the 180 simulated trials (true cut-off 5 Hz, ``benchmarks/forces.py``,
true positions): the estimates span 4.987-5.011 Hz (SD 0.005 Hz, 0.1 %) from priors of
4.75, 5 and 5.25 Hz alike; the worst trial is 2.62 % of the peak-to-peak with a prior off by
5 % either way (18 % without the estimate) and 2.62 % with the right prior (2.30 % with the
cut-off given exactly: the estimate's own scatter costs that much, the sensitivity being
3.6 % per 1 % of cut-off). Its standard error matches the scatter (RMS of the standardised
error 1.15 on the study). A single linearisation at the prior, not iterated, depends on the
prior: on synthetic records it erred by up to 1.1 % (5.5 %) of the cut-off with a prior 20 %
(40 %) off, against 0.4 % iterated. It stays opt-in: the simulated sensor is exactly first
order, and a real chain (a second pole in the charge amplifier, a cut-off that drifts with
temperature) needs checking first, e.g. that the estimates agree across the trials of a
session. Without a rest after the lift-off the cut-off is not determined (on the first rest
alone the integral is collinear with the drift): the prior is used, with a flag; an
estimate more than ``highpass_max_change`` (30 %) from the prior is used and flagged.

**Mains: fit rather than notch (beyond the paper).** A zero-phase notch removes the force's
own content within its band and rings for ``Q / (pi f0)`` s; a step-like force change
crossed at 80-120 mm/s has much energy near 50 Hz, and the 50 Hz notch then changes
``F_T(x)`` by up to 19 % of its peak-to-peak (measured on simulated trials). On the
unloaded rest the recorded signal is drift + interference + noise only, so the
interference's amplitude and phase are fitted there (with the drift line) and the
sinusoids subtracted from the whole record. This assumes a mains frequency stable over
the record (about 1 s); ``mains="both"`` adds the notch after the fit, ``mains="notch"``
is the paper's filtering.

References
----------
.. [1] M. Janko, M. Wiertlewski, Y. Visell, "Contact geometry and mechanics predict
   friction forces during tactile surface exploration", Sci. Rep. 8, 4868 (2018),
   Methods.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field, replace

import numpy as np
from scipy import ndimage, signal

from .._atomic import atomic_write
from .._check import check_freq as _check_freq
from .._check import check_fs as _check_fs
from .._check import interval as _interval
from .._check import positive as _positive
from .readers import ForceRecord

__all__ = [
    "ForceDataError",
    "ForceProcessingParams",
    "Flag",
    "ForceSignals",
    "ForceProfile",
    "decompose",
    "compose",
    "design_notch",
    "design_lowpass",
    "notch_filter",
    "lowpass_filter",
    "fit_linear_drift",
    "remove_linear_drift",
    "fit_baseline",
    "BaselineFit",
    "compensate_highpass",
    "detect_baseline",
    "detect_post_baseline",
    "fit_rest_drift",
    "RestDriftFit",
    "estimate_highpass",
    "HighpassEstimate",
    "positions_at_times",
    "flat_segment_from_positions",
    "extrapolate_positions",
    "flat_mask_from_regions",
    "resample_to_positions",
    "PositionResampling",
    "nan_runs",
    "find_clipping",
    "process_forces",
]

logger = logging.getLogger(__name__)

SQRT2 = math.sqrt(2.0)


class ForceDataError(ValueError):
    """Force data that cannot be turned into a trustworthy ``F_T(x)``."""


# --------------------------------------------------------------------------------------
# parameters
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ForceProcessingParams:
    """Options of the force processing chain (defaults: the paper's Methods).

    Parameters
    ----------
    notch_hz : tuple of float
        Mains interference frequencies in Hz: the centres of the zero-phase notch filters,
        or the sinusoids fitted on the baseline (see ``mains``). Default
        ``(50.0, 150.0, 300.0)`` (mains and its odd harmonics). Empty: none removed.
    mains : {"fit", "notch", "both"}
        How the interference is removed. ``"notch"``: zero-phase notch filters (the
        paper's Methods). ``"fit"`` (default): sinusoids at ``notch_hz`` fitted on the
        unloaded baseline, where the true force is zero, are subtracted from the whole
        record; unlike a notch this leaves the force's own content near 50 Hz intact (a
        50 Hz notch changes by up to 19 % of the peak-to-peak the force of a step crossed at
        80-120 mm/s, measured on simulated trials), but it assumes a stable mains
        frequency over the record. Falls back to the notch (with a warning flag) when no
        baseline is found. ``"both"``: the fit, then the notch.
    notch_q : float
        Quality factor of each notch (centre frequency / -3 dB bandwidth of one pass).
        Default 10.0 (5 Hz wide at 50 Hz). Higher Q removes less signal but rings longer
        (time constant ``Q / (pi f0)``: 64 ms at Q = 10, 50 Hz), which leaves mains
        residue near the ends of short records. The paper does not state its Q.
    lowpass_hz : float or None
        Cut-off in Hz of the zero-phase Butterworth low-pass. Default 500.0. ``None``: no
        low-pass.
    lowpass_order : int
        Order of the Butterworth design (the zero-phase result has twice the attenuation
        in dB). Default 4.
    window_mm : float
        Width in mm of the position window, centred on the feature. Default 26.0.
    resolution_mm : float
        Position grid step in mm. Default 0.01.
    contact_half_width_mm : float
        Half width in mm of the finger contact on flat ground, used to place the default
        flat segment (contact entirely before the feature). Default 8.0 (a 16 mm finger).
    flat_segment_mm : (float, float) or None
        Finger-centre positions ``(x_lo, x_hi)`` in mm of the flat segment; ``None``
        (default) derives it from the window and the feature (see module notes).
    min_flat_mm : float
        Shortest accepted flat segment in mm of finger travel. Default 1.0.
    max_nan_gap : int
        Longest run of NaN samples (per channel) that is filled by linear interpolation
        (and flagged); longer runs are an error. Default 10 (1 ms at 10 kHz).
    clip_run : int
        A run of at least this many identical samples at a channel's maximum or minimum is
        taken as clipping (a flat top). Default 10.
    full_scale_n : float or None
        Full scale of the acquisition in N, when known: any sample at ``+-full_scale_n``
        is clipped. Default ``None``.
    max_reversal_mm : float
        Backward finger travel in mm above which the slide is flagged as non-monotonic.
        Default 0.05.
    max_fill_mm : float
        Longest run of empty position bins in mm that may be filled by interpolation
        without flagging. Default 0.1.
    extrapolate_mm : float
        When x(t) does not cover the window (the video loses the finger near the edges of
        its field), extend it at constant speed by at most this much at each end
        (:func:`extrapolate_positions`), with a warning flag. Default 4.0; 0 disables.
    extrapolate_fit_s : float
        Tracked duration in s used for the speed of the extension. Default 0.03.
    sensor_highpass_hz : float or None
        Cut-off in Hz of the first-order high-pass of the piezo / charge-amplifier chain,
        inverted by :func:`compensate_highpass`. Default 5.0 (Methods: "approximately
        5 Hz"). ``None``: no compensation (the paper's procedure as written).
    baseline : "auto", None or (float, float)
        The unloaded rest at the start of the record on which the drift line is fitted
        before the compensation: ``"auto"`` (default) detects it (from the record start to
        ``baseline_guard_s`` before the force first departs from its initial level by
        ``contact_threshold_n``); a ``(t_lo, t_hi)`` interval in s on the common clock;
        ``None``: no baseline (a warning when compensating).
    contact_threshold_n : float
        Force departure in N that marks the first touch for ``baseline="auto"``. Default
        0.02.
    baseline_guard_s : float
        Time in s left out between the baseline and the detected touch. Default 0.01.
    min_baseline_s : float
        Shortest usable baseline in s (also for ``post_baseline``). Default 0.02.
    post_baseline : "auto", None or (float, float)
        The unloaded rest after the finger lifts off, on which (together with
        ``baseline``) the residual drift offset and slope are fitted through the high-pass
        inverse after the compensation (:func:`fit_rest_drift`; only when
        ``sensor_highpass_hz`` is set): ``"auto"`` (default) detects it
        (:func:`detect_post_baseline`: after the last sample where ``F_N`` exceeds half its
        maximum, from ``baseline_guard_s`` after both forces last change faster than
        ``rest_rate_n_per_s``); a ``(t_lo, t_hi)`` interval in s on the common clock;
        ``None``: not used (the drift line rests on ``baseline`` alone). A record that
        ends in contact, or whose rest is shorter than ``min_baseline_s``, falls back on
        ``baseline`` alone, with a flag.
    rest_rate_n_per_s : float
        For ``post_baseline="auto"``: the rate of change in N/s of the forces (smoothed by
        an 8 ms Gaussian) below which the finger is taken as lifted and at rest. Default
        0.5 (the unloading of a 0.3 N load over 50 ms peaks near 10 N/s; 0.5 mN of white
        noise at 10 kHz gives 0.003 N/s RMS, 0.01 N/s at most over 10 s, measured).
    estimate_highpass : bool
        Opt-in, beyond the paper: estimate the sensor's cut-off from the two rests
        (:func:`estimate_highpass`, starting from ``sensor_highpass_hz`` as the prior) and
        compensate at the estimate. Default False: the stated ``sensor_highpass_hz`` is
        used as is (the simulated sensor is exactly first order; check that a real one is
        before trusting the estimate). Needs ``sensor_highpass_hz`` and ``post_baseline``;
        without a usable rest after the lift-off, or when the rests do not determine the
        cut-off, the prior is used, with a flag.
    highpass_max_change : float
        With ``estimate_highpass``: an estimate further than this fraction from the prior
        is used but flagged (``"highpass-estimate"``). Default 0.3.
    """

    notch_hz: tuple[float, ...] = (50.0, 150.0, 300.0)
    mains: str = "fit"
    notch_q: float = 10.0
    lowpass_hz: float | None = 500.0
    lowpass_order: int = 4
    window_mm: float = 26.0
    resolution_mm: float = 0.01
    contact_half_width_mm: float = 8.0
    flat_segment_mm: tuple[float, float] | None = None
    min_flat_mm: float = 1.0
    max_nan_gap: int = 10
    clip_run: int = 10
    full_scale_n: float | None = None
    max_reversal_mm: float = 0.05
    max_fill_mm: float = 0.1
    extrapolate_mm: float = 4.0
    extrapolate_fit_s: float = 0.03
    sensor_highpass_hz: float | None = 5.0
    baseline: str | tuple[float, float] | None = "auto"
    contact_threshold_n: float = 0.02
    baseline_guard_s: float = 0.01
    min_baseline_s: float = 0.02
    post_baseline: str | tuple[float, float] | None = "auto"
    rest_rate_n_per_s: float = 0.5
    estimate_highpass: bool = False
    highpass_max_change: float = 0.3

    def __post_init__(self) -> None:
        notch = tuple(float(f) for f in np.atleast_1d(np.asarray(self.notch_hz, dtype=float)))
        for f in notch:
            if not (math.isfinite(f) and f > 0):
                raise ValueError(
                    f"notch_hz must hold finite positive frequencies in Hz, got {self.notch_hz!r}"
                )
        object.__setattr__(self, "notch_hz", notch)
        if self.mains not in ("fit", "notch", "both"):
            raise ValueError(f"mains must be 'fit', 'notch' or 'both', got {self.mains!r}")
        object.__setattr__(self, "notch_q", _positive("notch_q", self.notch_q, "(dimensionless)"))
        if self.lowpass_hz is not None:
            object.__setattr__(self, "lowpass_hz", _positive("lowpass_hz", self.lowpass_hz, "Hz"))
        if int(self.lowpass_order) != self.lowpass_order or not 1 <= int(self.lowpass_order) <= 12:
            raise ValueError(f"lowpass_order must be an integer in [1, 12], got {self.lowpass_order!r}")
        object.__setattr__(self, "lowpass_order", int(self.lowpass_order))
        for name, unit in (
            ("window_mm", "mm"),
            ("resolution_mm", "mm"),
            ("contact_half_width_mm", "mm"),
            ("min_flat_mm", "mm"),
            ("max_reversal_mm", "mm"),
            ("max_fill_mm", "mm"),
        ):
            object.__setattr__(self, name, _positive(name, getattr(self, name), unit))
        if self.resolution_mm > self.window_mm / 10:
            raise ValueError(
                f"resolution_mm ({self.resolution_mm:g} mm) must be at most a tenth of window_mm "
                f"({self.window_mm:g} mm)"
            )
        if self.flat_segment_mm is not None:
            object.__setattr__(
                self, "flat_segment_mm",
                _interval("flat_segment_mm", self.flat_segment_mm, "mm", labels=("x_lo", "x_hi")),
            )
        for name in ("max_nan_gap", "clip_run"):
            v = getattr(self, name)
            if int(v) != v or int(v) < (0 if name == "max_nan_gap" else 2):
                raise ValueError(f"{name} must be a non-negative integer number of samples, got {v!r}")
            object.__setattr__(self, name, int(v))
        if self.full_scale_n is not None:
            object.__setattr__(self, "full_scale_n", _positive("full_scale_n", self.full_scale_n, "N"))
        if self.sensor_highpass_hz is not None:
            object.__setattr__(
                self, "sensor_highpass_hz", _positive("sensor_highpass_hz", self.sensor_highpass_hz, "Hz")
            )
        for name in ("baseline", "post_baseline"):
            v = getattr(self, name)
            if isinstance(v, str):
                if v != "auto":
                    raise ValueError(f"{name} must be 'auto', None or (t_lo, t_hi) in s, got {v!r}")
            elif v is not None:
                object.__setattr__(self, name, _interval(name, v, "s", labels=("t_lo", "t_hi")))
        if not (math.isfinite(float(self.extrapolate_mm)) and float(self.extrapolate_mm) >= 0):
            raise ValueError(f"extrapolate_mm must be a length >= 0 in mm, got {self.extrapolate_mm!r}")
        object.__setattr__(self, "extrapolate_mm", float(self.extrapolate_mm))
        for name, unit in (
            ("contact_threshold_n", "N"),
            ("baseline_guard_s", "s"),
            ("min_baseline_s", "s"),
            ("extrapolate_fit_s", "s"),
            ("rest_rate_n_per_s", "N/s"),
            ("highpass_max_change", "(fraction of the prior)"),
        ):
            object.__setattr__(self, name, _positive(name, getattr(self, name), unit))
        if not isinstance(self.estimate_highpass, (bool, np.bool_)):
            raise TypeError(f"estimate_highpass must be True or False, got {self.estimate_highpass!r}")
        object.__setattr__(self, "estimate_highpass", bool(self.estimate_highpass))
        if self.estimate_highpass and (self.sensor_highpass_hz is None or self.post_baseline is None):
            raise ValueError(
                "estimate_highpass=True needs sensor_highpass_hz (the prior, in Hz) and post_baseline "
                f"(the rest after the lift-off carries the information), got sensor_highpass_hz="
                f"{self.sensor_highpass_hz!r}, post_baseline={self.post_baseline!r}"
            )

    def to_dict(self) -> dict:
        """JSON-serialisable dict of the parameters."""
        d = asdict(self)
        d["notch_hz"] = list(self.notch_hz)
        if self.flat_segment_mm is not None:
            d["flat_segment_mm"] = list(self.flat_segment_mm)
        for name in ("baseline", "post_baseline"):
            if isinstance(getattr(self, name), tuple):
                d[name] = list(getattr(self, name))
        return d


# --------------------------------------------------------------------------------------
# decomposition (Methods "Measurement apparatus", Fig. 1C)
# --------------------------------------------------------------------------------------


def decompose(f1, f2) -> tuple[np.ndarray, np.ndarray]:
    """Normal and tangential force from the two +-45 degree transducers.

    ``F_N = (F1 + F2) / sqrt(2)`` and ``F_T = (F1 - F2) / sqrt(2)`` (Methods
    "Measurement apparatus", Fig. 1C of Janko et al. 2018): a rotation by 45 degrees, so
    ``F_N**2 + F_T**2 == F1**2 + F2**2``.

    Parameters
    ----------
    f1, f2 : array_like, same shape
        Forces in N along the two transducer axes.

    Returns
    -------
    f_n, f_t : ndarray, same shape as the inputs
        Normal and tangential force in N.
    """
    a = np.asarray(f1, dtype=np.float64)
    b = np.asarray(f2, dtype=np.float64)
    if a.shape != b.shape:
        raise ValueError(f"f1 and f2 must have the same shape, got {a.shape} and {b.shape}")
    return (a + b) / SQRT2, (a - b) / SQRT2


def compose(f_n, f_t) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`decompose`: transducer forces ``(F1, F2)`` in N from ``F_N, F_T``."""
    n = np.asarray(f_n, dtype=np.float64)
    t = np.asarray(f_t, dtype=np.float64)
    if n.shape != t.shape:
        raise ValueError(f"f_n and f_t must have the same shape, got {n.shape} and {t.shape}")
    return (n + t) / SQRT2, (n - t) / SQRT2


# --------------------------------------------------------------------------------------
# filters
# --------------------------------------------------------------------------------------


def design_notch(fs: float, freqs: Sequence[float] = (50.0, 150.0, 300.0), q: float = 10.0) -> np.ndarray:
    """Second-order sections of a cascade of IIR notch filters.

    Parameters
    ----------
    fs : float
        Sampling frequency in Hz.
    freqs : sequence of float
        Notch centre frequencies in Hz, each below ``fs / 2``. Default (50, 150, 300).
    q : float
        Quality factor of each notch (:func:`scipy.signal.iirnotch`). Default 10.

    Returns
    -------
    (n_sections, 6) ndarray
        One section per notch, for :func:`scipy.signal.sosfiltfilt`.
    """
    fs = _check_fs(fs, "fs")
    q = _positive("q", q, "dimensionless")
    sections = []
    for i, f0 in enumerate(freqs):
        f0 = _check_freq(f"notch frequency freqs[{i}]", f0, fs)
        b, a = signal.iirnotch(f0, q, fs=fs)
        sections.append(signal.tf2sos(b, a))
    if not sections:
        return np.zeros((0, 6))
    return np.vstack(sections)


def design_lowpass(fs: float, cutoff: float = 500.0, order: int = 4) -> np.ndarray:
    """Second-order sections of a Butterworth low-pass (:func:`scipy.signal.butter`).

    Parameters
    ----------
    fs : float
        Sampling frequency in Hz.
    cutoff : float
        -3 dB frequency in Hz of the single-pass design, below ``fs / 2``. Default 500.
    order : int
        Filter order. Default 4.

    Returns
    -------
    (n_sections, 6) ndarray
    """
    fs = _check_fs(fs, "fs")
    cutoff = _check_freq("cutoff", cutoff, fs)
    return signal.butter(int(order), cutoff, btype="lowpass", output="sos", fs=fs)


def _zero_phase(sos: np.ndarray, x, axis: int) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if sos.shape[0] == 0:
        return x.copy()
    if not np.all(np.isfinite(x)):
        raise ValueError("x contains NaN or infinite values; fill or remove them before filtering")
    n = x.shape[axis]
    padlen = 3 * (2 * sos.shape[0] + 1)
    if n <= padlen:
        raise ValueError(
            f"x has {n} samples along axis {axis}; zero-phase filtering needs more than {padlen}"
        )
    return signal.sosfiltfilt(sos, x, axis=axis)


def notch_filter(
    x, fs: float, freqs: Sequence[float] = (50.0, 150.0, 300.0), *, q: float = 10.0, axis: int = -1
) -> np.ndarray:
    """Zero-phase notch filtering (mains interference, Methods "Measurement apparatus").

    The cascade of :func:`design_notch` is applied forwards and backwards
    (:func:`scipy.signal.sosfiltfilt`): zero phase, magnitude response ``|H(f)|**2``.

    Parameters
    ----------
    x : array_like
        Signal(s), finite.
    fs : float
        Sampling frequency in Hz.
    freqs : sequence of float
        Centre frequencies in Hz. Default (50, 150, 300).
    q : float
        Quality factor of each notch. Default 10.
    axis : int
        Time axis. Default -1.

    Returns
    -------
    ndarray, same shape as ``x``
    """
    return _zero_phase(design_notch(fs, freqs, q), x, axis)


def lowpass_filter(x, fs: float, cutoff: float = 500.0, *, order: int = 4, axis: int = -1) -> np.ndarray:
    """Zero-phase Butterworth low-pass (Methods "Force data processing": 500 Hz).

    Forwards-backwards (:func:`scipy.signal.sosfiltfilt`), so the magnitude response is
    ``|H(f)|**2``: -6 dB at ``cutoff`` and a roll-off of ``12 * order`` dB per octave.

    Parameters
    ----------
    x : array_like
        Signal(s), finite.
    fs : float
        Sampling frequency in Hz.
    cutoff : float
        Cut-off frequency in Hz (-3 dB of one pass), below ``fs / 2``. Default 500.
    order : int
        Butterworth order of one pass. Default 4.
    axis : int
        Time axis. Default -1.

    Returns
    -------
    ndarray, same shape as ``x``
    """
    return _zero_phase(design_lowpass(fs, cutoff, order), x, axis)


# --------------------------------------------------------------------------------------
# drift
# --------------------------------------------------------------------------------------


def fit_linear_drift(t, y, mask=None) -> tuple[float, float]:
    """Least-squares line ``y ~ slope * t + intercept`` over the samples in ``mask``.

    Parameters
    ----------
    t : (n,) array_like
        Sample times in s.
    y : (n,) array_like
        Force in N.
    mask : (n,) array_like of bool, optional
        Samples to fit (the flat segment). Default: all.

    Returns
    -------
    slope : float
        N/s.
    intercept : float
        N at ``t = 0``.
    """
    t = np.asarray(t, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if t.ndim != 1 or t.shape != y.shape:
        raise ValueError(f"t and y must be 1-D arrays of the same length, got {t.shape} and {y.shape}")
    m = np.ones(t.shape, bool) if mask is None else np.asarray(mask, dtype=bool)
    if m.shape != t.shape:
        raise ValueError(f"mask must have the shape of t {t.shape}, got {m.shape}")
    m = m & np.isfinite(t) & np.isfinite(y)
    tm, ym = t[m], y[m]
    if tm.size < 2 or np.ptp(tm) == 0:
        raise ValueError(
            f"the drift fit needs at least 2 distinct sample times in mask, got {tm.size} sample(s)"
        )
    # centre t for conditioning: t can be ~1e3 s on a lab clock while the segment lasts 0.03 s
    tc = tm.mean()
    dt = tm - tc
    yc = ym.mean()
    slope = float(np.dot(dt, ym - yc) / np.dot(dt, dt))
    intercept = float(yc - slope * tc)
    return slope, intercept


def remove_linear_drift(t, y, mask=None) -> tuple[np.ndarray, tuple[float, float]]:
    """Subtract the linear drift fitted over the flat segment from the whole signal.

    Methods "Force data processing": "We removed this artifact by computing the best
    linear fit to the force signal during the flat segment, and subtracted it from the
    force measured during the touch interaction."

    Parameters
    ----------
    t : (n,) array_like
        Sample times in s.
    y : (n,) array_like
        Force in N.
    mask : (n,) array_like of bool, optional
        The flat-segment samples. Default: all.

    Returns
    -------
    y_corrected : (n,) ndarray
        ``y - (slope * t + intercept)`` in N.
    (slope, intercept) : tuple of float
        The fitted drift, N/s and N.
    """
    slope, intercept = fit_linear_drift(t, y, mask)
    t = np.asarray(t, dtype=np.float64)
    tc = np.mean(t[np.asarray(mask, bool)]) if mask is not None else np.mean(t)
    # evaluate around the fit's centre, for the same conditioning as the fit
    line = (slope * tc + intercept) + slope * (t - tc)
    return np.asarray(y, dtype=np.float64) - line, (slope, intercept)


@dataclass(frozen=True)
class BaselineFit:
    """Drift line and mains sinusoids fitted on an unloaded baseline (:func:`fit_baseline`).

    Attributes
    ----------
    slope : float
        N/s.
    intercept : float
        N at ``t = 0``.
    mains_hz : tuple of float
        Frequencies in Hz of the sinusoids.
    cos, sin : (n_freqs,) ndarray
        Amplitudes in N of ``cos(2 pi f t)`` and ``sin(2 pi f t)`` (``t`` on the common clock).
    """

    slope: float
    intercept: float
    mains_hz: tuple = ()
    cos: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sin: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def line(self, t) -> np.ndarray:
        """The drift line in N at times ``t`` (s)."""
        return self.slope * np.asarray(t, dtype=np.float64) + self.intercept

    def mains(self, t) -> np.ndarray:
        """The fitted interference in N at times ``t`` (s)."""
        t = np.asarray(t, dtype=np.float64)
        out = np.zeros_like(t)
        for f, c, s_ in zip(self.mains_hz, self.cos, self.sin, strict=True):
            out += c * np.cos(2 * np.pi * f * t) + s_ * np.sin(2 * np.pi * f * t)
        return out

    def amplitudes(self) -> np.ndarray:
        """``(n_freqs,)`` amplitude in N of each mains component."""
        return np.hypot(self.cos, self.sin)


def fit_baseline(t, y, mask, *, mains_hz: Sequence[float] = (50.0, 150.0, 300.0)) -> BaselineFit:
    """Drift line of an unloaded baseline, fitted together with mains sinusoids.

    Least squares of ``y ~ slope * t + intercept + sum_k (c_k cos 2 pi f_k t + s_k sin 2 pi
    f_k t)`` over the samples in ``mask``: on a short baseline (0.1 s holds 5 periods of
    50 Hz) the interference would otherwise bias the slope; and since the true force is
    zero there, the sinusoids are the interference alone, free of any signal content.

    Parameters
    ----------
    t : (n,) array_like
        Sample times in s.
    y : (n,) array_like
        Force in N (unfiltered: the sinusoids are part of the model).
    mask : (n,) array_like of bool
        Baseline samples (the true force is zero, or constant, there).
    mains_hz : sequence of float
        Interference frequencies in Hz. Default (50, 150, 300).

    Returns
    -------
    BaselineFit
    """
    t = np.asarray(t, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    m = np.asarray(mask, dtype=bool)
    if t.ndim != 1 or t.shape != y.shape or m.shape != t.shape:
        raise ValueError(f"t, y and mask must be 1-D of the same length, got {t.shape}, {y.shape}, {m.shape}")
    m = m & np.isfinite(y)
    freqs = tuple(float(f) for f in mains_hz)
    n_par = 2 + 2 * len(freqs)
    if m.sum() < 2 * n_par:
        raise ValueError(f"the baseline fit needs at least {2 * n_par} samples in mask, got {int(m.sum())}")
    tm = t[m]
    tc = tm.mean()
    ts = float(np.std(tm)) or 1.0
    cols = [np.ones_like(tm), (tm - tc) / ts]  # all columns of order 1: a well-conditioned system
    for f in freqs:
        cols += [np.cos(2 * np.pi * f * tm), np.sin(2 * np.pi * f * tm)]
    A = np.column_stack(cols)
    # normal equations: with columns of order 1 the system is well conditioned (a few
    # thousand at worst) and solving it took 0.02 ms against 13 ms for numpy.linalg.lstsq
    # on this machine (1400 x 8, measured)
    try:
        coef = np.linalg.solve(A.T @ A, A.T @ y[m])
    except np.linalg.LinAlgError:  # a mains frequency aliased onto another on a tiny baseline
        coef, *_ = np.linalg.lstsq(A, y[m], rcond=None)
    coef[1] /= ts
    slope = float(coef[1])
    return BaselineFit(
        slope=slope,
        intercept=float(coef[0] - slope * tc),
        mains_hz=freqs,
        cos=np.asarray(coef[2::2], dtype=np.float64),
        sin=np.asarray(coef[3::2], dtype=np.float64),
    )


def compensate_highpass(y, fs: float, cutoff: float, *, axis: int = -1) -> np.ndarray:
    """Invert a first-order high-pass: the force before a piezo / charge-amplifier chain.

    The chain ``H(s) = s / (s + w0)``, ``w0 = 2 pi cutoff``, discretised by the bilinear
    transform (:func:`scipy.signal.butter` of order 1), has the exact inverse
    ``x = y + w0 * integral(y dt)`` with trapezoidal integration, applied here with
    :func:`scipy.signal.lfilter` and the filter's coefficients swapped. The input is
    assumed to start from rest (zero state); otherwise the result is off by a constant.

    Parameters
    ----------
    y : array_like
        Recorded signal(s), finite.
    fs : float
        Sampling frequency in Hz.
    cutoff : float
        High-pass cut-off in Hz, below ``fs / 2``.
    axis : int
        Time axis. Default -1.

    Returns
    -------
    ndarray, same shape as ``y``

    Notes
    -----
    The inverse has a pole at z = 1 (an integrator): an offset ``b`` in ``y`` grows as
    ``b w0 t``, a slope ``a`` as ``a w0 t**2 / 2``. Remove the drift on an unloaded
    baseline first (:func:`fit_baseline`).
    """
    fs = _check_fs(fs, "fs")
    cutoff = _check_freq("cutoff", cutoff, fs)
    y = np.asarray(y, dtype=np.float64)
    if not np.all(np.isfinite(y)):
        raise ValueError("y contains NaN or infinite values; fill or remove them before compensating")
    b, a = signal.butter(1, cutoff, btype="highpass", fs=fs)
    return signal.lfilter(a, b, y, axis=axis)


def detect_baseline(f_n, f_t, fs: float, *, threshold: float = 0.02, guard_s: float = 0.01) -> int:
    """Number of samples of unloaded rest at the start of a record.

    The rest ends ``guard_s`` before the first sample at which ``F_N`` or ``F_T`` departs
    from its initial level (median of the first 5 ms) by more than ``threshold`` N.

    Parameters
    ----------
    f_n, f_t : (n,) array_like
        Normal and tangential force in N (filtered: mains and noise well below
        ``threshold``).
    fs : float
        Sampling frequency in Hz.
    threshold : float
        Departure in N marking the touch. Default 0.02.
    guard_s : float
        Margin in s before the touch. Default 0.01.

    Returns
    -------
    int
        0 when the force departs immediately (no rest) or never does.
    """
    fs = _check_fs(fs, "fs")
    dev = np.zeros(np.shape(f_n))
    k0 = max(int(0.005 * fs), 1)
    for y in (np.asarray(f_n, float), np.asarray(f_t, float)):
        dev = np.maximum(dev, np.abs(y - np.median(y[:k0])))
    above = np.flatnonzero(dev > threshold)
    if above.size == 0:
        return 0
    return max(int(above[0]) - int(round(guard_s * fs)), 0)


def detect_post_baseline(
    f_n, f_t, fs: float, *, max_rate: float = 0.5, guard_s: float = 0.01, smooth_s: float = 0.008
) -> int:
    """First sample of the unloaded rest after the finger lifts off, at the end of a record.

    Relative criteria, so that an offset left in the forces (after the high-pass
    compensation the unloaded ``F_N`` can sit a few hundredths of a newton away from zero)
    does not matter: after the last sample where ``F_N`` exceeds half its maximum (the
    unloading), the rest starts ``guard_s`` after the last sample where ``F_N`` or ``F_T``
    (smoothed by a Gaussian of ``smooth_s``) changes faster than ``max_rate``; and the rest's median
    ``F_N`` must be below a quarter of the maximum (a light touch held at the end is not a
    rest).

    Parameters
    ----------
    f_n, f_t : (n,) array_like
        Normal and tangential force in N (e.g. after the low-pass and the high-pass
        compensation), finite.
    fs : float
        Sampling frequency in Hz.
    max_rate : float
        Rate of change in N/s below which the forces are at rest. Default 0.5.
    guard_s : float
        Margin in s after the last faster change. Default 0.01.
    smooth_s : float
        Standard deviation in s of the Gaussian the forces are smoothed with before
        differentiating (:func:`scipy.ndimage.gaussian_filter1d`). Default 0.008: it
        passes 4 % of a 50 Hz residue; unlike a Butterworth low-pass it does not ring
        after the unloading (a 20 Hz one rang at 1.2 N/s for 30 ms after a 30 ms unloading).

    Returns
    -------
    int
        Index of the first rest sample; ``n`` (an empty rest) when the record ends in
        contact, never carries a load, or ends before the forces settle.
    """
    fs = _check_fs(fs, "fs")
    fn = np.asarray(f_n, dtype=np.float64)
    ft = np.asarray(f_t, dtype=np.float64)
    if fn.ndim != 1 or fn.shape != ft.shape:
        raise ValueError(f"f_n and f_t must be 1-D of the same length, got {fn.shape} and {ft.shape}")
    if not (np.all(np.isfinite(fn)) and np.all(np.isfinite(ft))):
        raise ValueError("f_n and f_t must be finite; fill NaN before detecting the rest")
    smooth_s = _positive("smooth_s", smooth_s, "s")
    n = fn.size
    sigma = smooth_s * fs
    both = np.vstack([fn, ft])
    smooth = ndimage.gaussian_filter1d(both, sigma, axis=1, mode="nearest")
    peak = float(np.max(smooth[0]))
    if not peak > 0:
        return n
    k_load = int(np.flatnonzero(smooth[0] > 0.5 * peak)[-1])
    # derivative of the Gaussian-smoothed forces, N/s
    slope = ndimage.gaussian_filter1d(both, sigma, axis=1, order=1, mode="nearest")
    rate = np.max(np.abs(slope), axis=0) * fs
    moving = np.flatnonzero(rate[k_load:] > max_rate)
    k_still = k_load + (int(moving[-1]) if moving.size else 0) + 1
    start = min(k_still + int(round(guard_s * fs)), n)
    if start < n and np.median(smooth[0, start:]) >= 0.25 * peak:
        return n
    return start


@dataclass(frozen=True)
class RestDriftFit:
    """Residual drift line fitted on the unloaded rests through the high-pass inverse.

    Result of :func:`fit_rest_drift`: the recorded (uncompensated) signal carried a drift
    ``offset + slope * tau`` (``tau`` the time in s since the first sample, where the
    compensation starts from rest) that the compensation turned into ``image``.

    Attributes
    ----------
    offset : float
        N at the first sample (before compensation).
    slope : float
        N/s (before compensation).
    cutoff_hz : float
        The high-pass cut-off in Hz the image was computed with.
    n_samples : int
        Rest samples fitted.
    rms_before, rms_after : float
        RMS in N of the compensated signal on the rest samples before and after removing
        the image (the true force is zero there).
    image : (n,) ndarray
        The compensated drift in N at every sample, what is subtracted.
    """

    offset: float
    slope: float
    cutoff_hz: float
    n_samples: int
    rms_before: float
    rms_after: float
    image: np.ndarray


def fit_rest_drift(y, mask, fs: float, cutoff: float) -> RestDriftFit:
    """Fit the drift line left in a high-pass-compensated signal on its unloaded rests.

    The compensation (:func:`compensate_highpass`) integrates: a residual drift
    ``b + a t`` in the recorded signal (the error of the line fitted on the rest before
    the touch) comes out as ``w_b(t) b + w_a(t) a`` with ``w_b = C[1] = 1 + w0 t`` and
    ``w_a = C[t] = t + w0 t**2 / 2`` (``C`` the compensation, ``w0 = 2 pi cutoff``), a
    quadratic that a later linear fit cannot remove. Where the true force is zero (the
    rest before the touch and the rest after the lift-off) the compensated signal is that
    image plus noise, so ``(b, a)`` are the least-squares solution of
    ``y[mask] ~ [w_b, w_a][mask] @ (b, a)``; the image is then known at every sample. With
    rests at both ends of the record the slope is pinned by a lever arm of the whole
    record rather than by the ~0.1 s before the touch.

    Parameters
    ----------
    y : (n,) array_like
        Compensated force in N, sampled uniformly at ``fs`` from the sample the
        compensation started at (its rest state).
    mask : (n,) array_like of bool
        Samples where the true force is zero (the unloaded rests), at least 4.
    fs : float
        Sampling frequency in Hz.
    cutoff : float
        The compensated high-pass cut-off in Hz.

    Returns
    -------
    RestDriftFit
        ``y - fit.image`` is the corrected signal.
    """
    fs = _check_fs(fs, "fs")
    cutoff = _check_freq("cutoff", cutoff, fs)
    y = np.asarray(y, dtype=np.float64)
    m = np.asarray(mask, dtype=bool)
    if y.ndim != 1 or m.shape != y.shape:
        raise ValueError(f"y and mask must be 1-D of the same length, got {y.shape} and {m.shape}")
    m = m & np.isfinite(y)
    if m.sum() < 4:
        raise ValueError(f"the rest drift fit needs at least 4 rest samples in mask, got {int(m.sum())}")
    tau = np.arange(y.size) / fs  # time since the compensation started, s
    span = max(float(tau[-1]), 1.0 / fs)
    # columns of order 1 (slope per record duration) for conditioning
    w = compensate_highpass(np.vstack([np.ones_like(tau), tau / span]), fs, cutoff)
    A = w[:, m].T
    coef, *_ = np.linalg.lstsq(A, y[m], rcond=None)
    image = w.T @ coef
    return RestDriftFit(
        offset=float(coef[0]),
        slope=float(coef[1] / span),
        cutoff_hz=cutoff,
        n_samples=int(m.sum()),
        rms_before=float(np.sqrt(np.mean(y[m] ** 2))),
        rms_after=float(np.sqrt(np.mean((y[m] - image[m]) ** 2))),
        image=image,
    )


@dataclass(frozen=True)
class HighpassEstimate:
    """The sensor's high-pass cut-off estimated on the unloaded rests (:func:`estimate_highpass`).

    Attributes
    ----------
    fc_hz : float
        Estimated cut-off in Hz (the prior when ``success`` is False).
    se_hz : float
        Standard error of ``fc_hz`` in Hz propagated from the noise seen in the fit
        residuals (its autocovariance summed over lags: low-passed noise is not white)
        through the linearised fit, including the noise the compensation's integral
        carries from the whole record into the rest after the lift-off (see the Notes of
        :func:`estimate_highpass`); NaN when not determined. It covers the noise only, not
        a sensor that is not first order.
    prior_hz : float
        The cut-off in Hz the fit started from.
    n_samples : int
        Rest samples used per channel.
    n_channels : int
        Channels fitted jointly (sharing the cut-off).
    iterations : int
        Evaluations of the residual by the Levenberg-Marquardt solver.
    rms_residual_n : float
        RMS in N of the residual on the rests at the solution.
    autocorr_samples : float
        Integrated autocorrelation time of the residuals in samples (1 for white noise),
        mean over the channels.
    success : bool
        False when the cut-off is not determined by the rests (see ``message``).
    message : str
        "ok" or why the estimate was not determined.
    """

    fc_hz: float
    se_hz: float
    prior_hz: float
    n_samples: int
    n_channels: int
    iterations: int
    rms_residual_n: float
    autocorr_samples: float
    success: bool
    message: str

    @property
    def rel_change(self) -> float:
        """``fc_hz / prior_hz - 1`` (dimensionless)."""
        return self.fc_hz / self.prior_hz - 1.0


def _trapezoid_integral(y: np.ndarray, fs: float) -> np.ndarray:
    """Running trapezoid integral along the last axis from a zero state (s times the unit of
    ``y``): the integrator of :func:`compensate_highpass`, ``C[y] = y + w * I[y]``."""
    return signal.lfilter([1.0, 1.0], [1.0, -1.0], y, axis=-1) / (2.0 * fs)


def _noise_power(r: np.ndarray, runs: list[tuple[int, int]], c: float = 5.0) -> tuple[float, float]:
    """Low-frequency power of residuals ``(n_rest,)`` made of contiguous ``runs`` (start,
    length): ``(sum_j R_j, tau)``, the autocovariance summed over all lags in N**2 (the
    variance of a sum of samples per sample) and the integrated autocorrelation time
    ``tau = 1 + 2 sum rho_j`` in samples, summed up to Sokal's self-consistent window
    (the smallest lag ``M >= c * tau(M)``). Each run's mean is removed."""
    max_lag = max(1, min(length for _, length in runs) // 4)
    acov = np.zeros(max_lag + 1)
    count = np.zeros(max_lag + 1)
    for s0, length in runs:
        seg = r[s0 : s0 + length] - r[s0 : s0 + length].mean()
        nfft = 1 << int(np.ceil(np.log2(2 * length)))
        acov += np.fft.irfft(np.abs(np.fft.rfft(seg, nfft)) ** 2, nfft)[: max_lag + 1]
        count += length - np.arange(max_lag + 1)
    acov /= count
    if not acov[0] > 0:
        return 0.0, 1.0
    tau = 1.0 + 2.0 * np.cumsum(acov[1:] / acov[0])
    ok = np.flatnonzero(np.arange(1, max_lag + 1) >= c * tau)
    t = max(float(tau[ok[0]]) if ok.size else float(tau[-1]), 1.0)
    return float(acov[0] * t), t


def estimate_highpass(y, mask, fs: float, prior: float, *, max_rel_se: float = 0.1) -> HighpassEstimate:
    """Estimate the cut-off of the sensor's first-order high-pass from the unloaded rests.

    Beyond the paper (which states "approximately 5 Hz"). The compensation
    (:func:`compensate_highpass`) at angular cut-off ``w`` is ``C_w[y] = y + w I[y]``,
    ``I`` the running trapezoid integral from the first sample: affine in ``w``. Where the
    true force is zero (the rest before the touch and the rest after the lift-off) the
    signal compensated at the *true* ``w`` is the image of the residual drift ``b + a t``
    alone (:func:`fit_rest_drift`), so ``(w, b_c, a_c)`` are fitted jointly by least
    squares of

        ``y_c + w I[y_c] - b_c (1 + w I[1]) - a_c (t + w I[t])``

    over the rest samples of every channel ``c`` (``F_N`` and ``F_T`` share the sensor's
    ``w``, each has its own drift): a separable problem, bilinear in ``w`` and the drift,
    solved by Levenberg-Marquardt (:func:`scipy.optimize.least_squares`) from the prior and
    the drift fitted at the prior. Iterating to convergence makes the estimate independent
    of the prior (a single linearisation at the prior is not). ``w`` is the
    bilinear-transform (prewarped) cut-off, converted back to Hz exactly.

    The information comes from the rest after the lift-off: there the recorded signal is
    the high-pass's decaying response to the whole loading, whose integral the inverse must
    cancel. On the rest before the touch alone, ``I[y]`` is the drift's integral, collinear
    with the drift columns: the cut-off is then not determined (``success=False``).

    Parameters
    ----------
    y : (n,) or (k, n) array_like
        The recorded forces in N *before* the compensation (after the drift line and mains
        fitted on the first rest are subtracted and the low-pass), one row per channel,
        sampled uniformly at ``fs`` from the sample the compensation starts at.
    mask : (n,) array_like of bool
        Samples where the true force is zero (the rests).
    fs : float
        Sampling frequency in Hz.
    prior : float
        Assumed cut-off in Hz (the start of the fit), below ``fs / 2``.
    max_rel_se : float
        The estimate is reported as not determined when its standard error exceeds this
        fraction of it. Default 0.1.

    Returns
    -------
    HighpassEstimate
        ``fc_hz`` is the prior when ``success`` is False; never raises for data that do not
        determine the cut-off.

    Raises
    ------
    ValueError
        For malformed arguments (shapes, non-finite ``y``, ``prior`` at or above Nyquist,
        fewer than 8 rest samples).

    Notes
    -----
    The standard error is the linearised fit's response to the noise: at the truth the
    residual is the compensated noise ``n + w I[n]``, whose integral accumulates over the
    whole record, the contact included, and reaches the rest after the lift-off as a
    random offset, besides the short-range noise seen in the residuals (its
    autocovariance, estimated on the rest runs, summed over lags). Both parts are
    propagated; the channels are taken as independent. Measured: the RMS of
    ``(fc_hz - true) / se_hz`` was 1.15 over the 180 trials of the simulated study and 0.96
    over 300 synthetic records (2-10 Hz). Without the random offset it was 1.42 on the
    study; the residuals' integrated autocorrelation time is 10-25 samples (noise
    low-passed at 500 Hz), so the white-noise formula ``s**2 (J^T J)^-1`` would understate
    the error 3-5 fold.

    References
    ----------
    .. [1] A. D. Sokal, "Monte Carlo methods in statistical mechanics: foundations and new
       algorithms" (1996), section 3: the integrated autocorrelation time and its
       self-consistent window.
    """
    from scipy.optimize import least_squares

    fs = _check_fs(fs, "fs")
    prior = _check_freq("prior", prior, fs)
    max_rel_se = _positive("max_rel_se", max_rel_se, "(dimensionless)")
    Y = np.atleast_2d(np.asarray(y, dtype=np.float64))
    m = np.asarray(mask, dtype=bool)
    if Y.ndim != 2 or m.ndim != 1 or m.shape[0] != Y.shape[1]:
        raise ValueError(
            f"y must be (n,) or (k, n) and mask (n,) with the same n, got {np.shape(y)} and {m.shape}"
        )
    if not np.all(np.isfinite(Y)):
        raise ValueError("y contains NaN or infinite values; fill or remove them before the estimate")
    n_rest = int(m.sum())
    if n_rest < 8:
        raise ValueError(f"the cut-off estimate needs at least 8 rest samples in mask, got {n_rest}")
    k, n = Y.shape
    tau = np.arange(n) / fs
    span = max(float(tau[-1]), 1.0 / fs)
    u = tau / span  # slope per record duration: columns of order 1
    iy = _trapezoid_integral(Y, fs)[:, m]
    i1 = _trapezoid_integral(np.ones(n), fs)[m]
    iu = _trapezoid_integral(u, fs)[m]
    yr, ur = Y[:, m], u[m]
    w_prior = 2.0 * fs * math.tan(math.pi * prior / fs)  # bilinear transform's prewarping

    def drift(w: float) -> np.ndarray:
        """(b_c, a_c) per channel, least squares at a fixed w: (k, 2)."""
        A = np.column_stack([1.0 + w * i1, ur + w * iu])
        coef, *_ = np.linalg.lstsq(A, (yr + w * iy).T, rcond=None)
        return coef.T

    def residual(p: np.ndarray) -> np.ndarray:
        w, ba = p[0], p[1:].reshape(k, 2)
        r = yr + w * iy - ba[:, :1] * (1.0 + w * i1) - ba[:, 1:] * (ur + w * iu)
        return r.ravel()

    def jacobian(p: np.ndarray) -> np.ndarray:
        w, ba = p[0], p[1:].reshape(k, 2)
        J = np.zeros((k * n_rest, 1 + 2 * k))
        for c in range(k):
            rows = slice(c * n_rest, (c + 1) * n_rest)
            J[rows, 0] = iy[c] - ba[c, 0] * i1 - ba[c, 1] * iu
            J[rows, 1 + 2 * c] = -(1.0 + w * i1)
            J[rows, 2 + 2 * c] = -(ur + w * iu)
        return J

    def fail(msg: str, nfev: int = 0, rms: float = float("nan"), ac: float = float("nan")):
        return HighpassEstimate(prior, float("nan"), prior, n_rest, k, nfev, rms, ac, False, msg)

    def condition(J: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
        # scale the columns: w (~30 rad/s) and the drift (~1e-3 N) differ by 1e4
        scale = np.sqrt(np.sum(J**2, axis=0))
        scale[scale == 0] = 1.0
        return float(np.linalg.cond(J / scale)), J / scale, scale

    undetermined = (
        "the rests do not determine the cut-off (condition number {:.3g} of the fit): the rest after the "
        "lift-off is missing or too short, or the record carries no load"
    )
    p0 = np.concatenate([[w_prior], drift(w_prior).ravel()])
    cond0 = condition(jacobian(p0))[0]
    if not cond0 < 1e8:
        return fail(undetermined.format(cond0))
    sol = least_squares(residual, p0, jac=jacobian, method="lm", x_scale="jac", xtol=1e-12, ftol=1e-12)
    w = float(sol.x[0])
    r = sol.fun.reshape(k, n_rest)
    rms = float(np.sqrt(np.mean(r**2)))
    if not sol.success:
        return fail(f"the least-squares fit did not converge: {sol.message}", sol.nfev, rms)
    if not (math.isfinite(w) and w > 0):
        return fail(f"the fit gave a non-positive angular cut-off ({w:.3g} rad/s)", sol.nfev, rms)
    fc = float(fs / math.pi * math.atan(w / (2.0 * fs)))
    # contiguous runs of rest samples, for the residuals' autocorrelation
    d = np.diff(np.concatenate(([0], m.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    runs = list(zip(np.cumsum(np.concatenate(([0], ends - starts)))[:-1], ends - starts, strict=True))
    runs = [(int(s0), int(length)) for s0, length in runs]
    cond, Js, scale = condition(jacobian(sol.x))
    if not cond < 1e8:
        return fail(undetermined.format(cond), sol.nfev, rms)
    # standard error: the linearised estimate is w + g . e, with e the residual at the truth,
    # C_w[noise] = noise + w I[noise] on the rest samples. The integral carries the noise of
    # the whole record, the contact included, into the rest after the lift-off: besides the
    # short-range part (the noise's autocovariance summed over lags, from the residuals),
    # Var(g . e) has the random walk's part (dt**2 sum_m G_m**2, G_m = sum_{j >= m} g_j over
    # every sample m) and their covariance; channels are taken as independent
    g = (Js @ np.linalg.inv(Js.T @ Js)[:, 0]) / scale[0]
    idx = np.flatnonzero(m)
    dt = 1.0 / fs
    var_w = 0.0
    taus = []
    for c in range(k):
        s2, tau_c = _noise_power(r[c], runs)
        taus.append(tau_c)
        gc = g[c * n_rest : (c + 1) * n_rest]
        full = np.zeros(n)
        full[idx] = gc
        G = np.cumsum(full[::-1])[::-1]
        var_w += s2 * (gc @ gc + (w * dt) ** 2 * (G @ G) + 2 * w * dt * (gc @ (G[idx] - 0.5 * gc)))
    ac = float(np.mean(taus))
    se_w = math.sqrt(max(var_w, 0.0))
    se = se_w / (2.0 * math.pi) / (1.0 + (w / (2.0 * fs)) ** 2)  # d fc / d w
    if not fc < 0.5 * fs:
        return fail(f"the fitted cut-off {fc:g} Hz is not below the Nyquist frequency", sol.nfev, rms, ac)
    if not se <= max_rel_se * fc:
        msg = (f"the cut-off is not determined by the rests: {fc:.4g} +- {se:.2g} Hz (standard error "
               f"above max_rel_se={max_rel_se:g} of it)")
        return HighpassEstimate(prior, se, prior, n_rest, k, sol.nfev, rms, ac, False, msg)
    return HighpassEstimate(fc, se, prior, n_rest, k, sol.nfev, rms, ac, True, "ok")


# --------------------------------------------------------------------------------------
# synchronisation and positions
# --------------------------------------------------------------------------------------


def positions_at_times(t, t_frames, x_frames) -> np.ndarray:
    """Finger position at arbitrary times by linear interpolation between frames.

    Parameters
    ----------
    t : (n,) array_like
        Times in s on the common clock (the force samples).
    t_frames : (m,) array_like
        Frame times in s on the same clock, increasing.
    x_frames : (m,) array_like
        Finger centre in mm at each frame; NaN where there is no finger.

    Returns
    -------
    (n,) ndarray
        Position in mm; NaN outside ``[t_frames[0], t_frames[-1]]`` and wherever one of
        the two bracketing frames is NaN.
    """
    t = np.asarray(t, dtype=np.float64)
    tf = np.asarray(t_frames, dtype=np.float64)
    xf = np.asarray(x_frames, dtype=np.float64)
    if tf.ndim != 1 or tf.shape != xf.shape:
        raise ValueError(
            f"t_frames and x_frames must be 1-D of the same length, got {tf.shape} and {xf.shape}"
        )
    if tf.size < 2 or np.any(np.diff(tf) <= 0):
        raise ValueError("t_frames must hold at least 2 strictly increasing times in s")
    k = np.searchsorted(tf, t, side="right") - 1
    inside = (k >= 0) & (t <= tf[-1])
    k = np.clip(k, 0, tf.size - 2)
    t0, t1 = tf[k], tf[k + 1]
    w = (t - t0) / (t1 - t0)
    x = xf[k] * (1 - w) + xf[k + 1] * w
    # exactly on a frame: do not let a NaN next frame poison a valid sample
    on_frame = w == 0
    x = np.where(on_frame, xf[k], x)
    x[~inside] = np.nan
    return x


def extrapolate_positions(
    t_frames, x_frames, *, max_mm: float, fit_s: float = 0.03
) -> tuple[np.ndarray, tuple[float, float]]:
    """Extend a tracked x(t) at constant speed beyond its first and last tracked frames.

    The video may lose the finger near the edges of its field of view (the finger is
    about 16 mm wide; the field about 29 mm) while the 26 mm window needs positions up to
    13 mm from the feature. Before the first and after the last tracked frame, the
    position is extended along a line fitted over ``fit_s`` s of tracked frames, for as
    long as it stays within ``max_mm`` of the tracked end. Frames in between (flagged
    frames inside the tracked span) are left as they are.

    Parameters
    ----------
    t_frames : (m,) array_like
        Frame times in s.
    x_frames : (m,) array_like
        Finger position in mm, NaN where not tracked.
    max_mm : float
        Longest extension in mm at each end.
    fit_s : float
        Duration in s of tracked frames used for the speed at each end. Default 0.03.

    Returns
    -------
    x : (m,) ndarray
        Positions in mm with the extensions.
    (before_mm, after_mm) : tuple of float
        Length of each extension in mm (0 where nothing was added).
    """
    tf = np.asarray(t_frames, dtype=np.float64)
    x = np.asarray(x_frames, dtype=np.float64).copy()
    fin = np.flatnonzero(np.isfinite(x))
    if fin.size < 2:
        return x, (0.0, 0.0)
    k0, k1 = int(fin[0]), int(fin[-1])
    ext = [0.0, 0.0]
    for side, k, sel in ((0, k0, fin[tf[fin] <= tf[k0] + fit_s]), (1, k1, fin[tf[fin] >= tf[k1] - fit_s])):
        if sel.size < 2:
            continue
        slope, icpt = np.polyfit(tf[sel], x[sel], 1)
        idx = np.arange(0, k0) if side == 0 else np.arange(k1 + 1, x.size)
        xe = slope * tf[idx] + icpt
        keep = np.abs(xe - x[k]) <= max_mm
        x[idx[keep]] = xe[keep]
        if keep.any():
            ext[side] = float(np.max(np.abs(xe[keep] - x[k])))
    return x, (ext[0], ext[1])


def flat_segment_from_positions(
    feature_start_mm: float, *, window: tuple[float, float], contact_half_width_mm: float = 8.0
) -> tuple[float, float]:
    """Default flat segment, in finger-centre positions (mm).

    From the window's left end to ``feature_start_mm - contact_half_width_mm``: while the
    finger centre is left of that point its contact (``2 * contact_half_width_mm`` wide)
    lies entirely on the flat ground before the feature.

    Returns
    -------
    (x_lo, x_hi) : tuple of float
        mm; ``x_hi <= x_lo`` when the window leaves no flat segment (the caller reports it).
    """
    return float(window[0]), float(feature_start_mm) - float(contact_half_width_mm)


def flat_mask_from_regions(t, t_frames, regions, feature_start_mm: float, *, return_known: bool = False):
    """Samples whose nearest frame has contact entirely on the flat ground before the feature.

    Parameters
    ----------
    t : (n,) array_like
        Sample times in s.
    t_frames : (m,) array_like
        Frame times in s, increasing.
    regions : (m, k, 2) array_like
        Contact regions per frame in mm (``fingerfriction.regions`` format).
    feature_start_mm : float
        Left end of the feature in mm.

    return_known : bool
        Also return where the nearest frame has any contact region at all.

    Returns
    -------
    (n,) ndarray of bool
        True where the nearest frame has at least one contact region and every region ends
        (``b_i``) before ``feature_start_mm``.
    known : (n,) ndarray of bool
        With ``return_known``: True where the nearest frame has contact regions.
    """
    from ..regions import as_regions

    r = as_regions(regions, name="regions")
    tf = np.asarray(t_frames, dtype=np.float64)
    if r.shape[0] != tf.size:
        raise ValueError(f"regions has {r.shape[0]} frames but t_frames has {tf.size} times")
    b = r[..., 1]
    has = np.any(np.isfinite(b), axis=1)
    flat_frame = has & np.all(np.where(np.isfinite(b), b < feature_start_mm, True), axis=1)
    t = np.asarray(t, dtype=np.float64)
    k = np.clip(np.searchsorted(tf, t), 1, tf.size - 1)
    nearest = np.where(np.abs(t - tf[k - 1]) <= np.abs(tf[k] - t), k - 1, k)
    inside = (t >= tf[0] - 0.5 * (tf[1] - tf[0])) & (t <= tf[-1] + 0.5 * (tf[-1] - tf[-2]))
    if return_known:
        return flat_frame[nearest] & inside, has[nearest] & inside
    return flat_frame[nearest] & inside


@dataclass(frozen=True)
class PositionResampling:
    """Result of :func:`resample_to_positions`.

    Attributes
    ----------
    x : (L,) ndarray
        Bin centres in mm.
    values : (L,) ndarray
        Per bin, the mean of its samples placed at their mean position, linearly
        interpolated onto the bin centres (empty bins are filled by the same interpolation).
    counts : (L,) ndarray of int
        Samples averaged in each bin (0: filled).
    n_filled : int
        Number of empty bins filled.
    max_fill_mm : float
        Longest run of consecutive filled bins, in mm.
    max_reversal_mm : float
        Largest backward excursion of the finger (running maximum minus position) among
        the samples used, in mm; 0 for a monotonic slide.
    """

    x: np.ndarray
    values: np.ndarray
    counts: np.ndarray
    n_filled: int
    max_fill_mm: float
    max_reversal_mm: float


def resample_to_positions(
    x, y, *, window: tuple[float, float], resolution: float = 0.01
) -> PositionResampling:
    """Associate samples with positions and average them per position bin.

    Parameters
    ----------
    x : (n,) array_like
        Finger position in mm at each sample (NaN: unknown, ignored).
    y : (n,) array_like
        Values (force in N) at each sample.
    window : (float, float)
        First and last bin centre in mm.
    resolution : float
        Bin width in mm. Default 0.01.

    Returns
    -------
    PositionResampling

    Raises
    ------
    ValueError
        If no sample falls in the window, or a bin at either end of the window is empty
        (the finger does not span the window: nothing to interpolate from).
    """
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if x.shape != y.shape or x.ndim != 1:
        raise ValueError(f"x and y must be 1-D arrays of the same length, got {x.shape} and {y.shape}")
    res = _positive("resolution", resolution, "mm")
    lo, hi = float(window[0]), float(window[1])
    n_bins = int(round((hi - lo) / res)) + 1
    grid = lo + res * np.arange(n_bins)
    ok = np.isfinite(x) & np.isfinite(y)
    if not ok.any():
        raise ValueError("no sample has both a finite finger position and a finite value")
    x_min, x_max = float(x[ok].min()), float(x[ok].max())
    if x_min > lo + res / 2 or x_max < hi - res / 2:
        raise ValueError(
            f"the finger positions cover [{max(x_min, lo):.3f}, {min(x_max, hi):.3f}] mm of the window "
            f"[{lo:g}, {hi:g}] mm; the whole window must be traversed"
        )
    # bins on the window extended by a margin, so that an empty bin at either end of the
    # window is interpolated from samples just outside it
    margin = 50
    idx = np.rint((x - lo) / res) + margin
    use = ok & (idx >= 0) & (idx < n_bins + 2 * margin)
    idx = idx[use].astype(np.intp)
    counts_ext = np.bincount(idx, minlength=n_bins + 2 * margin)
    sums = np.bincount(idx, weights=y[use], minlength=n_bins + 2 * margin)
    sums_x = np.bincount(idx, weights=x[use], minlength=n_bins + 2 * margin)
    have = counts_ext > 0
    # each bin's mean force sits at the bin's mean sample position (not exactly its centre);
    # interpolating those points onto the centres makes the result exact for a force linear
    # in x and reduces to linear interpolation when bins hold one sample or none.
    x_mean = sums_x[have] / counts_ext[have]
    y_mean = sums[have] / counts_ext[have]
    values = np.interp(grid, x_mean, y_mean)
    counts = counts_ext[margin : margin + n_bins]
    filled = counts == 0
    # longest run of filled bins
    max_run = 0
    if filled.any():
        d = np.diff(np.concatenate(([0], filled.astype(np.int8), [0])))
        starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
        max_run = int(np.max(ends - starts))
    xs = x[ok & (x >= lo - res / 2) & (x <= hi + res / 2)]
    reversal = float(np.max(np.maximum.accumulate(xs) - xs)) if xs.size else 0.0
    return PositionResampling(
        x=grid,
        values=values,
        counts=counts,
        n_filled=int(filled.sum()),
        max_fill_mm=max_run * res,
        max_reversal_mm=reversal,
    )


# --------------------------------------------------------------------------------------
# input checks
# --------------------------------------------------------------------------------------


def nan_runs(x) -> list[tuple[int, int]]:
    """Runs of NaN in a 1-D signal, as ``(start, length)`` pairs in samples."""
    bad = ~np.isfinite(np.asarray(x, dtype=np.float64))
    if not bad.any():
        return []
    d = np.diff(np.concatenate(([0], bad.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    return [(int(s), int(e - s)) for s, e in zip(starts, ends, strict=True)]


def _fill_nan(x: np.ndarray) -> np.ndarray:
    bad = ~np.isfinite(x)
    if not bad.any():
        return x
    out = x.copy()
    i = np.arange(x.size)
    out[bad] = np.interp(i[bad], i[~bad], x[~bad])
    return out


def find_clipping(x, *, run: int = 10, full_scale: float | None = None) -> list[tuple[int, int, float]]:
    """Clipped stretches of one channel: flat tops at its extreme values, or full scale.

    Parameters
    ----------
    x : (n,) array_like
        One channel in N (NaN ignored).
    run : int
        Minimum number of consecutive identical samples at the channel's maximum or
        minimum to call a flat top. Default 10. A noisy, unclipped signal does not sit on
        its extreme value for several consecutive samples.
    full_scale : float, optional
        Acquisition full scale in N; every sample with ``|x| >= full_scale`` counts,
        whatever the run length.

    Returns
    -------
    list of (start, length, value)
        Clipped runs in samples with the value held, N.
    """
    x = np.asarray(x, dtype=np.float64)
    fin = np.isfinite(x)
    if not fin.any():
        return []
    hits = np.zeros(x.size, bool)
    if full_scale is not None:
        hits |= fin & (np.abs(x) >= full_scale)
    flat = np.zeros(x.size, bool)
    for extreme in (np.nanmax(x), np.nanmin(x)):
        flat |= fin & (x == extreme)
    out = []
    for mask, min_len in ((hits, 1), (flat & ~hits, run)):
        if not mask.any():
            continue
        d = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
        for s, e in zip(np.flatnonzero(d == 1), np.flatnonzero(d == -1), strict=True):
            if e - s >= min_len:
                out.append((int(s), int(e - s), float(x[s])))
    return sorted(out)


# --------------------------------------------------------------------------------------
# provenance object
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class ForceSignals:
    """Normal and tangential force of one trial in time, with the steps applied to them.

    Every method returns a new object whose ``history`` has one more entry (the step's
    name and parameters), in the spirit of MNE-Python's ``Raw`` objects.

    Attributes
    ----------
    f_n, f_t : (n,) ndarray
        Normal and tangential force in N.
    fs_hz : float
        Sampling frequency in Hz.
    t0_s : float
        Time in s of sample 0 on the trial's common clock.
    history : tuple of dict
        Steps applied, oldest first.
    """

    f_n: np.ndarray
    f_t: np.ndarray
    fs_hz: float
    t0_s: float = 0.0
    history: tuple = ()

    @classmethod
    def from_record(cls, record: ForceRecord) -> ForceSignals:
        """Decompose a :class:`~fingerfriction.forces.readers.ForceRecord` (Fig. 1C)."""
        f_n, f_t = decompose(record.f1, record.f2)
        step = {"step": "decompose", "formula": "F_N=(F1+F2)/sqrt2, F_T=(F1-F2)/sqrt2", "source": record.path}
        return cls(f_n, f_t, record.fs_hz, record.t0_s, (step,))

    @property
    def n_samples(self) -> int:
        return int(self.f_t.shape[0])

    def times(self) -> np.ndarray:
        """``(n,)`` sample times in s on the common clock."""
        return self.t0_s + np.arange(self.n_samples) / self.fs_hz

    def _with(self, step: dict, **changes) -> ForceSignals:
        logger.info("forces: %s", step)
        return replace(self, history=self.history + (step,), **changes)

    def notch(self, freqs: Sequence[float] = (50.0, 150.0, 300.0), *, q: float = 10.0) -> ForceSignals:
        """Zero-phase notch filters at ``freqs`` Hz (:func:`notch_filter`)."""
        if len(freqs) == 0:
            return self
        sos = design_notch(self.fs_hz, freqs, q)
        both = _zero_phase(sos, np.vstack([self.f_n, self.f_t]), -1)
        step = {"step": "notch", "freqs_hz": [float(f) for f in freqs], "q": float(q), "zero_phase": True}
        return self._with(step, f_n=both[0], f_t=both[1])

    def lowpass(self, cutoff: float = 500.0, *, order: int = 4) -> ForceSignals:
        """Zero-phase Butterworth low-pass at ``cutoff`` Hz (:func:`lowpass_filter`)."""
        sos = design_lowpass(self.fs_hz, cutoff, order)
        both = _zero_phase(sos, np.vstack([self.f_n, self.f_t]), -1)
        step = {"step": "lowpass", "cutoff_hz": float(cutoff), "order": int(order), "zero_phase": True}
        return self._with(step, f_n=both[0], f_t=both[1])

    def remove_baseline(
        self, mask, *, mains_hz: Sequence[float] = (50.0, 150.0, 300.0), subtract_mains: bool = False
    ) -> ForceSignals:
        """Subtract the drift line fitted on an unloaded baseline (:func:`fit_baseline`), and
        with ``subtract_mains`` the mains sinusoids fitted with it, from the whole record."""
        t = self.times()
        out = {}
        sel = np.flatnonzero(mask)
        step: dict = {
            "step": "remove_baseline",
            "n_samples": int(sel.size),
            "t_s": [float(t[sel[0]]), float(t[sel[-1]])],
            "mains_subtracted_hz": [float(f) for f in mains_hz] if subtract_mains else [],
        }
        for name in ("f_n", "f_t"):
            fit = fit_baseline(t, getattr(self, name), mask, mains_hz=mains_hz)
            model = fit.line(t) + (fit.mains(t) if subtract_mains else 0.0)
            out[name] = getattr(self, name) - model
            key = "F_" + name[2:].upper()
            step[f"{key}_slope_N_per_s"] = fit.slope
            step[f"{key}_intercept_N"] = fit.intercept
            step[f"{key}_mains_amplitude_N"] = [float(a) for a in fit.amplitudes()]
        return self._with(step, **out)

    def compensate_highpass(self, cutoff: float) -> ForceSignals:
        """Invert the sensor's first-order high-pass at ``cutoff`` Hz (:func:`compensate_highpass`)."""
        both = compensate_highpass(np.vstack([self.f_n, self.f_t]), self.fs_hz, cutoff)
        step = {"step": "compensate_highpass", "cutoff_hz": float(cutoff), "order": 1, "from_rest": True}
        return self._with(step, f_n=both[0], f_t=both[1])

    def estimate_highpass(
        self, mask, prior: float, *, rests: str = "", max_rel_se: float = 0.1
    ) -> tuple[ForceSignals, HighpassEstimate]:
        """Estimate the sensor's cut-off from the unloaded rests ``mask`` (:func:`estimate_highpass`,
        ``F_N`` and ``F_T`` jointly, before the compensation). The data are unchanged; the
        returned object's history records the estimate."""
        both = np.vstack([self.f_n, self.f_t])
        est = estimate_highpass(both, mask, self.fs_hz, prior, max_rel_se=max_rel_se)
        step = {
            "step": "estimate_highpass",
            "rests": rests,
            "prior_hz": est.prior_hz,
            "cutoff_hz": est.fc_hz,
            "se_hz": est.se_hz,
            "n_samples": est.n_samples,
            "iterations": est.iterations,
            "rms_residual_N": est.rms_residual_n,
            "success": est.success,
            "message": est.message,
        }
        return self._with(step), est

    def remove_rest_drift(self, mask, cutoff: float, *, rests: str = "") -> ForceSignals:
        """Subtract the residual drift fitted through the high-pass inverse on the unloaded
        rests ``mask`` (:func:`fit_rest_drift`) from both compensated forces."""
        out = {}
        sel = np.flatnonzero(mask)
        step: dict = {
            "step": "remove_rest_drift",
            "rests": rests,
            "cutoff_hz": float(cutoff),
            "n_samples": int(sel.size),
            "t_s": [float(self.t0_s + sel[0] / self.fs_hz), float(self.t0_s + sel[-1] / self.fs_hz)],
        }
        for name in ("f_n", "f_t"):
            fit = fit_rest_drift(getattr(self, name), mask, self.fs_hz, cutoff)
            out[name] = getattr(self, name) - fit.image
            key = "F_" + name[2:].upper()
            step[f"{key}_offset_N"] = fit.offset
            step[f"{key}_slope_N_per_s"] = fit.slope
            step[f"{key}_rest_rms_N"] = [fit.rms_before, fit.rms_after]
        return self._with(step, **out)

    def remove_drift(self, mask, *, segment: str = "") -> ForceSignals:
        """Subtract a line in time fitted over ``mask`` (the flat segment) from both forces."""
        t = self.times()
        f_t, (a_t, b_t) = remove_linear_drift(t, self.f_t, mask)
        f_n, (a_n, b_n) = remove_linear_drift(t, self.f_n, mask)
        step = {
            "step": "remove_drift",
            "segment": segment,
            "n_samples": int(np.count_nonzero(mask)),
            "F_T_slope_N_per_s": a_t,
            "F_T_intercept_N": b_t,
            "F_N_slope_N_per_s": a_n,
            "F_N_intercept_N": b_n,
        }
        return self._with(step, f_n=f_n, f_t=f_t)


# --------------------------------------------------------------------------------------
# the whole chain
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Flag:
    """One finding about a trial's input: ``severity`` is ``"warning"`` or ``"error"``."""

    code: str
    message: str
    severity: str = "warning"


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
        import pandas as pd

        nan = np.full(self.x.shape, np.nan)
        f_t_abs = self.f_t_abs if self.f_t_abs is not None else nan
        f_n_abs = self.f_n_abs if self.f_n_abs is not None else nan
        return pd.DataFrame({"x_mm": self.x, "F_T_N": self.f_t, "F_N_N": self.f_n, "F_T_abs_N": f_t_abs,
                             "F_N_abs_N": f_n_abs, "n_samples": self.counts})

    def write_csv(self, path) -> None:
        """Write :meth:`to_frame` to ``path`` atomically (temporary file, then rename)."""
        frame = self.to_frame()
        atomic_write(path, lambda tmp: frame.to_csv(tmp, index=False, float_format="%.9g"))


def _check_channels(record: ForceRecord, params: ForceProcessingParams, flags: list) -> tuple:
    fs = record.fs_hz
    out = []
    for name, x in (("F1", record.f1), ("F2", record.f2)):
        runs = nan_runs(x)
        if runs:
            longest = max(runs, key=lambda r: r[1])
            total = sum(r[1] for r in runs)
            s, n = longest
            if n > params.max_nan_gap or n >= x.size // 2:
                flags.append(
                    Flag(
                        "nan",
                        f"channel {name} has a run of {n} NaN samples starting at sample {s} "
                        f"(t={record.t0_s + s / fs:.4f} s, {n / fs * 1e3:.3g} ms); at most "
                        f"max_nan_gap={params.max_nan_gap} samples can be interpolated",
                        "error",
                    )
                )
            else:
                flags.append(
                    Flag(
                        "nan-filled",
                        f"channel {name}: {total} NaN sample(s) in {len(runs)} run(s) of at most {n} "
                        "filled by linear interpolation",
                    )
                )
            x = _fill_nan(x) if np.isfinite(x).sum() >= 2 else x
        clips = find_clipping(x, run=params.clip_run, full_scale=params.full_scale_n)
        if clips:
            s, n, v = max(clips, key=lambda c: c[1])
            tot = sum(c[1] for c in clips)
            why = (
                f"at or beyond full_scale_n={params.full_scale_n:g} N"
                if params.full_scale_n is not None and abs(v) >= params.full_scale_n
                else f"held at the channel's extreme value for >= clip_run={params.clip_run} samples"
            )
            flags.append(
                Flag(
                    "clipped",
                    f"channel {name} is clipped: {tot} sample(s) in {len(clips)} run(s), the longest "
                    f"{n} samples at {v:.6g} N from sample {s} (t={record.t0_s + s / fs:.4f} s), {why}; "
                    "the saturated force is unknown, so this trial cannot be used",
                    "error",
                )
            )
        out.append(x)
    return out[0], out[1]


def _baseline_mask(sig: ForceSignals, params: ForceProcessingParams, flags: list) -> np.ndarray | None:
    """The unloaded-rest samples before the high-pass compensation, or None (flagged)."""
    t = sig.times()
    fs = sig.fs_hz
    consequence = (
        "; the drift is not removed before the high-pass compensation (it becomes quadratic in time: "
        "only a rest after the lift-off, post_baseline, can remove it then; the flat-segment fit removes "
        "only its linear part)"
        if params.sensor_highpass_hz is not None
        else ""
    )
    if params.baseline is None:
        flags.append(Flag("no-baseline", "baseline=None" + consequence))
        return None
    if params.baseline == "auto":
        quick = lowpass_filter(np.vstack([sig.f_n, sig.f_t]), fs, min(50.0, 0.4 * fs))
        n = detect_baseline(
            quick[0], quick[1], fs, threshold=params.contact_threshold_n, guard_s=params.baseline_guard_s
        )
        mask = np.arange(t.size) < n
        how = (
            f"the record starts with {n / fs:.4f} s of rest before the force departs by "
            f"contact_threshold_n={params.contact_threshold_n:g} N"
        )
    else:
        lo, hi = params.baseline
        mask = (t >= lo) & (t <= hi)
        how = f"baseline=({lo:g}, {hi:g}) s holds {int(mask.sum())} samples"
    if mask.sum() < params.min_baseline_s * fs:
        flags.append(
            Flag(
                "no-baseline",
                f"no usable unloaded baseline: {how}, less than min_baseline_s={params.min_baseline_s:g} s"
                + consequence
                + ". Record a rest before the touch, or set baseline=(t_lo, t_hi)",
            )
        )
        return None
    return mask


def _post_baseline_mask(sig: ForceSignals, params: ForceProcessingParams, flags: list):
    """The unloaded rest after the lift-off, as (mask, description), or None (flagged)."""
    if params.post_baseline is None:
        return None
    t = sig.times()
    fs = sig.fs_hz
    if params.post_baseline == "auto":
        k = detect_post_baseline(
            sig.f_n, sig.f_t, fs, max_rate=params.rest_rate_n_per_s, guard_s=params.baseline_guard_s
        )
        mask = np.arange(t.size) >= k
        how = (
            f"the record ends with {(t.size - k) / fs:.4f} s of rest after the lift-off (forces changing "
            f"slower than rest_rate_n_per_s={params.rest_rate_n_per_s:g} N/s, F_N below a quarter of its "
            "maximum)"
        )
    else:
        lo, hi = params.post_baseline
        mask = (t >= lo) & (t <= hi)
        how = f"post_baseline=({lo:g}, {hi:g}) s holds {int(mask.sum())} samples"
    if mask.sum() < max(params.min_baseline_s * fs, 4):
        flags.append(
            Flag(
                "no-post-baseline",
                f"no usable unloaded rest after the lift-off: {how}, less than "
                f"min_baseline_s={params.min_baseline_s:g} s (the record ends in contact or too soon); the "
                "drift line under the high-pass compensation rests on the baseline before the touch alone, "
                "whose slope error grows quadratically through the compensation (up to 5.5 % of the "
                "peak-to-peak at 40 mm/s on simulated trials, against 1 % with both rests). Record a rest "
                "after the lift-off, or set post_baseline=(t_lo, t_hi)",
            )
        )
        return None
    return mask, how


def _rests_text(base, post) -> str:
    which = "after the lift-off" if base is None else "before the touch and after the lift-off"
    return f"{which}; {post[1]}"


def _estimated_compensation(raw: ForceSignals, base, params: ForceProcessingParams, flags: list):
    """Compensate the high-pass at the cut-off estimated on the rests (:func:`estimate_highpass`).

    The rest after the lift-off is detected on the forces compensated at the prior. A wrong
    cut-off leaves there a decaying error (a fraction ``fc / prior - 1`` of the high-pass
    tail, time constant ``1 / (2 pi fc)``) that can delay or hide the rest: when none is
    found at the prior, the detection is tried at the prior times 0.9, 1.1, 0.8, 1.2, 0.7,
    1.3. After the estimate the rest is detected again at the estimate, and the estimate
    repeated (at most twice) while the rest changes. Falls back on the prior, with a flag,
    when no rest after the lift-off is found or the rests do not determine the cut-off.

    Returns
    -------
    (cutoff_hz, signals, post) : the cut-off used, ``raw`` compensated at it (with the
    estimate in its history), and the rest after the lift-off as for
    :func:`_post_baseline_mask` (or None).
    """
    prior = params.sensor_highpass_hz
    tried: list[Flag] = []
    post = _post_baseline_mask(raw.compensate_highpass(prior), params, tried)
    if post is None and params.post_baseline == "auto":
        for s in (0.9, 1.1, 0.8, 1.2, 0.7, 1.3):
            post = _post_baseline_mask(raw.compensate_highpass(s * prior), params, [])
            if post is not None:
                break
    if post is None:
        flags.extend(tried)
        flags.append(
            Flag(
                "highpass-estimate",
                "estimate_highpass=True but there is no usable rest after the lift-off (see the "
                "no-post-baseline flag), so the cut-off is not determined; the prior "
                f"sensor_highpass_hz={prior:g} Hz was used",
            )
        )
        return prior, raw.compensate_highpass(prior), None
    for _ in range(3):
        rests = post[0] if base is None else post[0] | base
        sig, est = raw.estimate_highpass(rests, prior, rests=_rests_text(base, post))
        if not est.success:
            flags.append(
                Flag(
                    "highpass-estimate",
                    f"estimate_highpass=True but {est.message}; the prior sensor_highpass_hz={prior:g} Hz "
                    "was used",
                )
            )
            return prior, sig.compensate_highpass(prior), post
        again = sig.compensate_highpass(est.fc_hz)
        if params.post_baseline != "auto":
            break
        new = _post_baseline_mask(again, params, [])
        if new is None or np.array_equal(new[0], post[0]):
            break
        post = new
    if abs(est.rel_change) > params.highpass_max_change:
        flags.append(
            Flag(
                "highpass-estimate",
                f"the sensor cut-off estimated on the rests, {est.fc_hz:.4g} +- {est.se_hz:.2g} Hz, is "
                f"{100 * est.rel_change:+.0f} % from the prior sensor_highpass_hz={prior:g} Hz (allowed "
                f"highpass_max_change={params.highpass_max_change:g}); it was used: check the sensor's "
                "specification, and that the rests are free of contact",
            )
        )
    return est.fc_hz, again, post


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


def process_forces(
    record: ForceRecord,
    t_frames,
    x_frames,
    *,
    feature_extent_mm: tuple[float, float] = (0.0, 0.0),
    params: ForceProcessingParams | None = None,
    regions=None,
    on_error: str = "raise",
) -> ForceProfile:
    """Run the Methods' force processing on one trial: ``F_T(x)`` on the position grid.

    Steps: input checks, decomposition, notch, low-pass, drift removal over the flat
    segment, synchronisation with the video clock, association with positions, resampling
    on the grid (see the module notes for the choices made).

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
    if on_error not in ("raise", "flag"):
        raise ValueError(f"on_error must be 'raise' or 'flag', got {on_error!r}")
    params = ForceProcessingParams() if params is None else params
    if not isinstance(params, ForceProcessingParams):
        raise TypeError(f"params must be a ForceProcessingParams, got {type(params).__name__}")
    fs = record.fs_hz
    # filter designs first: a cut-off above Nyquist is an argument error, not a data flag
    design_notch(fs, params.notch_hz, params.notch_q)
    if params.lowpass_hz is not None:
        design_lowpass(fs, params.lowpass_hz, params.lowpass_order)
    a, b = (float(v) for v in feature_extent_mm)
    if not (math.isfinite(a) and math.isfinite(b) and b >= a):
        raise ValueError(
            f"feature_extent_mm must be (start, end) in mm with start <= end, got {feature_extent_mm!r}"
        )
    centre = 0.5 * (a + b)
    window = (centre - params.window_mm / 2, centre + params.window_mm / 2)
    tf = np.asarray(t_frames, dtype=np.float64)
    xf = np.asarray(x_frames, dtype=np.float64)
    flags: list[Flag] = []

    def finish_error() -> ForceProfile:
        err = next(f for f in flags if f.severity == "error")
        if on_error == "raise":
            raise ForceDataError(err.message)
        return _empty_profile(params, window, flat_mm, flags)

    if params.flat_segment_mm is not None:
        flat_mm = params.flat_segment_mm
    else:
        flat_mm = flat_segment_from_positions(
            a, window=window, contact_half_width_mm=params.contact_half_width_mm
        )

    # --- input checks -----------------------------------------------------------------
    f1, f2 = _check_channels(record, params, flags)
    t = record.times()
    fin = np.isfinite(xf)
    if not fin.any():
        flags.append(Flag("no-finger", "x_frames holds no finger position (all NaN)", "error"))
        return finish_error()
    x_lo, x_hi = float(np.nanmin(xf)), float(np.nanmax(xf))
    if params.extrapolate_mm > 0 and (x_lo > window[0] or x_hi < window[1]):
        xf, ext = extrapolate_positions(tf, xf, max_mm=params.extrapolate_mm, fit_s=params.extrapolate_fit_s)
        if ext[0] > 0 or ext[1] > 0:
            flags.append(
                Flag(
                    "extrapolated",
                    f"x(t) was tracked over [{x_lo:.3f}, {x_hi:.3f}] mm only; it was extended at constant "
                    f"speed (fitted over {params.extrapolate_fit_s * 1e3:g} ms of tracked frames) by "
                    f"{ext[0]:.2f} mm before and {ext[1]:.2f} mm after (allowed extrapolate_mm="
                    f"{params.extrapolate_mm:g} mm)",
                )
            )
        fin = np.isfinite(xf)
        x_lo, x_hi = float(np.nanmin(xf)), float(np.nanmax(xf))
    x_at = positions_at_times(t, tf, xf)
    if x_lo > window[0] or x_hi < window[1]:
        flags.append(
            Flag(
                "window",
                f"the finger positions span [{x_lo:.3f}, {x_hi:.3f}] mm, which does not cover the "
                f"{params.window_mm:g} mm window [{window[0]:.3f}, {window[1]:.3f}] mm centred on the "
                f"feature (extrapolate_mm={params.extrapolate_mm:g} mm); the finger must traverse the "
                "whole window",
                "error",
            )
        )
        return finish_error()
    # when is the finger in the window on the video clock, and does the force record cover it?
    in_win = fin & (xf >= window[0]) & (xf <= window[1])
    tw0, tw1 = float(tf[in_win][0]), float(tf[in_win][-1])
    if t[0] > tw0 or t[-1] < tw1:
        flags.append(
            Flag(
                "coverage",
                f"the force record covers t=[{t[0]:.4f}, {t[-1]:.4f}] s ({record.n_samples} samples at "
                f"fs_hz={fs:g} Hz, t0_s={record.t0_s:g} s) but the finger crosses the window during "
                f"t=[{tw0:.4f}, {tw1:.4f}] s; check force.fs_hz, force.t0_s and video.t0_s",
                "error",
            )
        )
    video_span = float(tf[-1] - tf[0])
    if video_span > 0:
        ratio = record.duration_s / video_span
        if not 0.5 <= ratio <= 2.0:
            flags.append(
                Flag(
                    "duration",
                    f"the force record lasts {record.duration_s:.4g} s ({record.n_samples} samples at "
                    f"fs_hz={fs:g} Hz) but the video lasts {video_span:.4g} s; a ratio of {ratio:.3g} "
                    "(allowed 0.5 to 2) suggests a wrong fs_hz",
                )
            )
    if any(f.severity == "error" for f in flags):
        return finish_error()

    # --- signals ----------------------------------------------------------------------
    sig = ForceSignals.from_record(replace(record, f1=f1, f2=f2))
    fit_mains = params.mains in ("fit", "both") and bool(params.notch_hz)
    notch = params.mains in ("notch", "both") and bool(params.notch_hz)
    base = None
    if params.sensor_highpass_hz is not None or fit_mains:
        base = _baseline_mask(sig, params, flags)
        if base is not None:
            sig = sig.remove_baseline(base, mains_hz=params.notch_hz, subtract_mains=fit_mains)
        elif fit_mains:
            notch = True
            flags.append(
                Flag(
                    "mains-notch",
                    "mains='fit' needs an unloaded baseline; the interference was removed by notch "
                    f"filters at {list(params.notch_hz)} Hz instead (they also remove the force's "
                    "own content there)",
                )
            )
    if notch:
        sig = sig.notch(params.notch_hz, q=params.notch_q)
    if params.lowpass_hz is not None:
        sig = sig.lowpass(params.lowpass_hz, order=params.lowpass_order)
    post = None
    if params.sensor_highpass_hz is not None:
        if params.estimate_highpass:
            fc, sig, post = _estimated_compensation(sig, base, params, flags)
        else:
            fc = params.sensor_highpass_hz
            sig = sig.compensate_highpass(fc)
            post = _post_baseline_mask(sig, params, flags)
        if post is not None:
            rests = post[0] if base is None else post[0] | base
            sig = sig.remove_rest_drift(rests, fc, rests=_rests_text(base, post))

    # --- flat segment and drift ---------------------------------------------------------
    if params.flat_segment_mm is None and regions is not None:
        # frames with regions decide by their contact; frames without (the video did not
        # track the finger there, e.g. near the edge of its field) fall back on the position
        # criterion, so the segment can still start at the window's left end
        flat_r, known = flat_mask_from_regions(t, tf, regions, a, return_known=True)
        by_pos = (x_at >= flat_mm[0]) & (x_at <= flat_mm[1])
        mask = np.where(known, flat_r, by_pos) & (x_at >= window[0])
        how = (
            "contact regions entirely before the feature (finger centre in "
            f"[{flat_mm[0]:.3f}, {flat_mm[1]:.3f}] mm where a frame has no regions), inside the window"
        )
        if mask.any():
            flat_mm = (float(np.nanmin(x_at[mask])), float(np.nanmax(x_at[mask])))
    else:
        mask = (x_at >= flat_mm[0]) & (x_at <= flat_mm[1])
        how = f"finger centre in [{flat_mm[0]:.3f}, {flat_mm[1]:.3f}] mm"
    travel = float(np.ptp(x_at[mask])) if mask.sum() >= 2 else 0.0
    if travel < params.min_flat_mm:
        flags.append(
            Flag(
                "flat-segment",
                f"the flat segment ({how}) spans {travel:.3f} mm of finger travel "
                f"({int(mask.sum())} samples); at least min_flat_mm={params.min_flat_mm:g} mm is needed "
                "to fit the drift; widen the window or set flat_segment_mm",
                "error",
            )
        )
        return finish_error()
    # the finger should be sliding over the flat segment: a touch-down or a pause there would
    # put static forces into the drift fit
    with np.errstate(invalid="ignore"):
        speed = np.abs(np.gradient(x_at, t))
    in_window = np.isfinite(speed) & (x_at >= window[0]) & (x_at <= window[1])
    if in_window.any():
        slow = mask & (speed < 0.1 * float(np.median(speed[in_window])))
        if slow.sum() > 0.05 * mask.sum():
            flags.append(
                Flag(
                    "flat-rest",
                    f"{100 * slow.sum() / mask.sum():.0f} % of the flat-segment samples have the finger "
                    "(nearly) at rest (below 10 % of its median speed in the window), e.g. a touch-down "
                    "inside the window: the drift fit includes static forces; set flat_segment_mm",
                )
            )
    # The absolute footing is the signal before the paper's flat-segment line: it keeps the
    # flat-ground level mu F_N that the line removes.
    absolute, absolute_message = _absolute_footing(params, base, post)
    if not absolute:
        flags.append(Flag("no-absolute", absolute_message))
    sig_abs = sig
    sig = sig.remove_drift(mask, segment=how)

    # --- positions --------------------------------------------------------------------
    try:
        res_t = resample_to_positions(x_at, sig.f_t, window=window, resolution=params.resolution_mm)
        res_n = resample_to_positions(x_at, sig.f_n, window=window, resolution=params.resolution_mm)
        f_t_abs = f_n_abs = None
        if absolute:
            f_t_abs = resample_to_positions(x_at, sig_abs.f_t, window=window,
                                            resolution=params.resolution_mm).values
            f_n_abs = resample_to_positions(x_at, sig_abs.f_n, window=window,
                                            resolution=params.resolution_mm).values
    except ValueError as exc:  # the force samples, not just the frames, must span the window
        flags.append(Flag("window", f"at the force sample times, {exc}", "error"))
        return finish_error()
    if res_t.max_reversal_mm > params.max_reversal_mm:
        flags.append(
            Flag(
                "reversal",
                f"the finger moved backwards by up to {res_t.max_reversal_mm:.3f} mm inside the window "
                f"(allowed max_reversal_mm={params.max_reversal_mm:g} mm); forces from the repeated "
                "positions were averaged per bin",
            )
        )
    if res_t.max_fill_mm > params.max_fill_mm:
        flags.append(
            Flag(
                "gap",
                f"{res_t.n_filled} empty position bins were interpolated, the longest run "
                f"{res_t.max_fill_mm:.3f} mm (allowed max_fill_mm={params.max_fill_mm:g} mm): the finger "
                "position jumps (video dropouts or a very fast slide)",
            )
        )
    dwell = res_t.counts[res_t.counts > 0]
    med = float(np.median(dwell))
    if dwell.max() > 20 * max(med, 1.0):
        k = int(np.argmax(res_t.counts))
        flags.append(
            Flag(
                "stall",
                f"the finger stalled near x={res_t.x[k]:.2f} mm: {int(dwell.max())} samples in one "
                f"{params.resolution_mm:g} mm bin (median {med:g}); the forces there were averaged",
            )
        )
    for f in flags:  # returned in the profile's flags; logged for the record
        logger.info("forces: %s: %s", f.code, f.message)
    return ForceProfile(
        x=res_t.x,
        f_t=res_t.values,
        f_n=res_n.values,
        counts=res_t.counts,
        signals=sig,
        x_at_samples=x_at,
        flat_segment_mm=flat_mm,
        window_mm=window,
        flags=tuple(flags),
        flat_mask=mask,
        success=True,
        message="ok",
        params=params,
        f_t_abs=f_t_abs,
        f_n_abs=f_n_abs,
        absolute=absolute,
        absolute_message=absolute_message,
    )


def _absolute_footing(params: ForceProcessingParams, base, post) -> tuple[bool, str]:
    """Whether the forces have an absolute level, and why not (a one-line message)."""
    if params.sensor_highpass_hz is None:
        return False, ("sensor_highpass_hz=None: the sensor's high-pass is not inverted, so the forces "
                       "are known only relative to the flat segment (the paper's footing)")
    if base is None and post is None:
        return False, ("no unloaded rest before the touch or after the lift-off anchors the drift: the "
                       "forces are known only relative to the flat segment (the paper's footing)")
    return True, ""
