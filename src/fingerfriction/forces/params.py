"""Options of the force stage: :class:`ForceProcessingParams`, frozen and validated once
(defaults: the paper's Methods; the reasons and measured figures behind the options
beyond the paper are in ``docs/forces.md``)."""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from .._check import check_bool, check_option, integer, interval, nonnegative, positive

__all__ = ["ForceProcessingParams", "MAINS_HZ", "MAINS_MODES", "HIGHPASS_MODELS"]

#: Mains interference frequencies in Hz, the default of ``notch_hz`` (and of the filters
#: and fits of :mod:`.filters` and :mod:`.sensor`): the mains and its odd harmonics.
MAINS_HZ = (50.0, 150.0, 300.0)
#: How the mains interference is removed (``mains``).
MAINS_MODES = ("fit", "notch", "both")
#: The sensor's high-pass responses (``highpass_model``).
HIGHPASS_MODELS = ("first-order", "second-order")


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
        record; unlike a notch this leaves the force's own content near 50 Hz intact
        (``docs/forces.md``), but it assumes a stable mains frequency over the record.
        Falls back to the notch (with a warning flag) when no baseline is found.
        ``"both"``: the fit, then the notch.
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
        (default) derives it from the window and the feature (``docs/forces.md``).
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
        noise at 10 kHz gives about 0.003 N/s RMS, 0.01 N/s at most over 10 s).
    estimate_highpass : bool
        Opt-in, beyond the paper: estimate the sensor's cut-off from the two rests
        (:func:`estimate_highpass`, starting from ``sensor_highpass_hz`` as the prior) and
        compensate at the estimate. Default False: the stated ``sensor_highpass_hz`` is
        used as is (the simulated sensor is exactly first order; check that a real one is
        before trusting the estimate). Needs ``sensor_highpass_hz`` and ``post_baseline``;
        without a usable rest after the lift-off, or when the rests do not determine the
        cut-off, the prior is used, with a flag.
    highpass_model : {"first-order", "second-order"}
        The sensor's high-pass. ``"first-order"`` (default): one pole at
        ``sensor_highpass_hz`` (or its estimate with ``estimate_highpass``), shared by
        ``F_N`` and ``F_T``. ``"second-order"`` (beyond the paper,
        :mod:`fingerfriction.forces.response`): a response ``s^2 / (s^2 + a1 s + a0)``
        estimated for each transducer channel on the rests (``sensor_highpass_hz`` is the
        prior; ``estimate_highpass`` is implied), for chains with a second pole (an
        AC-coupled conditioner) or transducers whose cut-offs differ. Needs
        ``sensor_highpass_hz`` and ``post_baseline``.
    highpass_max_change : float
        With ``estimate_highpass``: an estimate further than this fraction from the prior
        is used but flagged (``"highpass-estimate"``). Default 0.3.
    """

    notch_hz: tuple[float, ...] = MAINS_HZ
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
    highpass_model: str = "first-order"

    def __post_init__(self) -> None:
        notch = tuple(float(f) for f in np.atleast_1d(np.asarray(self.notch_hz, dtype=float)))
        for f in notch:
            if not (math.isfinite(f) and f > 0):
                raise ValueError(
                    f"notch_hz must hold finite positive frequencies in Hz, got {self.notch_hz!r}"
                )
        object.__setattr__(self, "notch_hz", notch)
        check_option("mains", self.mains, MAINS_MODES)
        object.__setattr__(self, "notch_q", positive("notch_q", self.notch_q, "(dimensionless)"))
        if self.lowpass_hz is not None:
            object.__setattr__(self, "lowpass_hz", positive("lowpass_hz", self.lowpass_hz, "Hz"))
        object.__setattr__(self, "lowpass_order", integer("lowpass_order", self.lowpass_order, 1, 12))
        for name, unit in (
            ("window_mm", "mm"),
            ("resolution_mm", "mm"),
            ("contact_half_width_mm", "mm"),
            ("min_flat_mm", "mm"),
            ("max_reversal_mm", "mm"),
            ("max_fill_mm", "mm"),
        ):
            object.__setattr__(self, name, positive(name, getattr(self, name), unit))
        if self.resolution_mm > self.window_mm / 10:
            raise ValueError(
                f"resolution_mm ({self.resolution_mm:g} mm) must be at most a tenth of window_mm "
                f"({self.window_mm:g} mm)"
            )
        if self.flat_segment_mm is not None:
            object.__setattr__(
                self, "flat_segment_mm",
                interval("flat_segment_mm", self.flat_segment_mm, "mm", labels=("x_lo", "x_hi")),
            )
        for name, lo in (("max_nan_gap", 0), ("clip_run", 2)):
            object.__setattr__(self, name, integer(name, getattr(self, name), lo, what="samples"))
        if self.full_scale_n is not None:
            object.__setattr__(self, "full_scale_n", positive("full_scale_n", self.full_scale_n, "N"))
        if self.sensor_highpass_hz is not None:
            object.__setattr__(
                self, "sensor_highpass_hz", positive("sensor_highpass_hz", self.sensor_highpass_hz, "Hz")
            )
        for name in ("baseline", "post_baseline"):
            v = getattr(self, name)
            if isinstance(v, str):
                if v != "auto":
                    raise ValueError(f"{name} must be 'auto', None or (t_lo, t_hi) in s, got {v!r}")
            elif v is not None:
                object.__setattr__(self, name, interval(name, v, "s", labels=("t_lo", "t_hi")))
        object.__setattr__(self, "extrapolate_mm",
                           nonnegative("extrapolate_mm", self.extrapolate_mm, "mm", what="length"))
        for name, unit in (
            ("contact_threshold_n", "N"),
            ("baseline_guard_s", "s"),
            ("min_baseline_s", "s"),
            ("extrapolate_fit_s", "s"),
            ("rest_rate_n_per_s", "N/s"),
            ("highpass_max_change", "(fraction of the prior)"),
        ):
            object.__setattr__(self, name, positive(name, getattr(self, name), unit))
        object.__setattr__(self, "estimate_highpass", check_bool("estimate_highpass", self.estimate_highpass))
        self._check_highpass_model()
        if self.estimate_highpass and (self.sensor_highpass_hz is None or self.post_baseline is None):
            raise ValueError(
                "estimate_highpass=True needs sensor_highpass_hz (the prior, in Hz) and post_baseline "
                f"(the rest after the lift-off carries the information), got sensor_highpass_hz="
                f"{self.sensor_highpass_hz!r}, post_baseline={self.post_baseline!r}"
            )

    def _check_highpass_model(self) -> None:
        check_option("highpass_model", self.highpass_model, HIGHPASS_MODELS)
        if self.highpass_model == "second-order" and (
                self.sensor_highpass_hz is None or self.post_baseline is None):
            raise ValueError(
                "highpass_model='second-order' needs sensor_highpass_hz (the prior, in Hz) and post_baseline "
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
