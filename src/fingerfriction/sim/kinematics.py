"""Finger kinematics of one trial: position x(t), height above the surface z(t) and normal
force F_N(t) on the 10 kHz force clock (Methods "Procedure" of Janko et al. 2018).

A trial, on the common clock (t = 0 at the first force sample):

1. ``pre_s`` of rest with the finger raised above the camera's field (no load);
2. descent: the finger comes down at ``x_start`` from ``z_top`` mm above the surface and
   lands on it ``descent_s`` later at the trial's approach speed ``v_a`` (drawn per trial,
   log-uniform in ``approach_speed_min``-``approach_speed_max``). The movement is a placing
   one aimed a little beyond the surface: a minimum-jerk path of duration ``T_v`` towards a
   point ``d_v`` below it, which the surface interrupts at the phase ``u_c = descent_s /
   T_v`` of its decelerating flank, ``z = (z_top + d_v)(1 - m(t / T_v)) - d_v``; ``u_c``
   solves ``u m'(u) / m(u) = v_a descent_s / z_top`` (the landing speed; ``v_a -> 0`` is
   the minimum-jerk path that stops on the surface), so the finger lands decelerating,
   as a hand does at the end of a reach. The video starts with this phase, its frame 0
   (finger still above the field) is the calibration frame (Fig. 7A);
3. loading: F_N rises to the trial's target over ``load_s``. The finger arrives at
   ``v_a`` on a pad whose force grows with its indentation ``delta`` as ``F = (k/b)
   (exp(b delta) - 1)`` (:class:`PadLaw`; the fingertip pulp's exponential stiffening,
   Serina, Mote & Rempel 1997; Pawluk & Howe 1999): the load leaves zero with the slope
   ``k v_a`` (N/s), a sharp onset, and the ramp is ``m(u) + c u (1 - u)^3 (1 + 3u)`` with
   ``c = k v_a load_s / F_N(t_touch)`` (the minimum-jerk ramp plus the quintic that adds that
   initial slope and keeps the end at rest);
4. slide left to right, starting ``slide_delay_s`` after touch-down (while the load is
   still building, as people do): ramp in (minimum-jerk acceleration, ``ramp_s``), a
   cruise at the trial's mean speed with a slow random fluctuation, ramp out once past
   ``x_stop``;
5. unloading (``unload_s``) and ``post_s`` of rest.

With ``approach_speed_max = 0`` the finger lands at zero speed on the minimum-jerk path
and the load rises from zero slope (the simulator before the landing speed existed; the
contact tables then hold their lowest load's outline below it).

Human-like variability (all drawn from the trial's generator): the trial's mean speed is
the nominal one times ``1 + N(0, speed_sd_trial)`` (clipped to +-20 %), the instantaneous
speed fluctuates by ``speed_sd`` (relative, low-pass ``fluct_hz``); the normal-force target
is ``F_N0 + N(0, force_sd_trial)`` and fluctuates by ``force_sd`` (low-pass
``fluct_hz``); the sum is softly limited to ``F_N0 +- force_limit`` (0.3 +- 0.05 N, the
range the participants were trained to hold).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy.optimize import brentq
from scipy.signal import butter, sosfiltfilt

from .._check import check_fs, positive
from .pad import PadLaw

__all__ = ["KinematicsParams", "Kinematics", "PadLaw", "simulate_kinematics", "min_jerk", "smooth_noise"]


@dataclass(frozen=True)
class KinematicsParams:
    """Parameters of the trial kinematics (times in s, lengths in mm, forces in N).

    Parameters
    ----------
    fs_hz : float
        Sampling frequency of the kinematics (the force clock), Hz.
    x_start, x_stop : float
        Touch-down position of the finger centre and the position past which it ramps out.
    window : float
        Width of the analysis window centred on the feature (26 mm in the paper); the slide
        must cover it at cruise speed: ``x_start < -window/2`` and ``x_stop > window/2``.
    z_top : float
        Height of the finger's lowest point above the surface at the start of the descent.
    force_n : float
        Prescribed normal force F_N0 (0.3 N).
    approach_speed_min, approach_speed_max : float
        Range of the speed in mm/s at which the finger lands (drawn per trial, log-uniform;
        both 0: it lands at zero speed, the minimum-jerk path). Default 20-80 mm/s: a
        placing movement, well below the descent's mean speed (``z_top / descent_s`` =
        300 mm/s) and below a tap's.
    descent_jitter : float
        With a landing speed, the descent's duration is ``descent_s`` times ``1 + U(-j, j)``
        per trial (default 0.1: a person's timing; the touch falls anywhere between two
        frames).
    pad_stiffness, pad_stiffening : float
        The pad's :class:`PadLaw`: initial stiffness in N/mm and stiffening rate in 1/mm
        (default 0.19 N/mm and 0.85 /mm: an indentation of about 1 mm at 0.3 N and 2 mm
        at 1 N, the fingertip pulp's order of magnitude, Serina et al. 1997).
    """

    fs_hz: float = 10_000.0
    x_start: float = -14.0
    x_stop: float = 14.5
    window: float = 26.0
    z_top: float = 12.0
    pre_s: float = 0.08
    descent_s: float = 0.04
    load_s: float = 0.05
    slide_delay_s: float = 0.02
    ramp_s: float = 0.06
    unload_s: float = 0.05
    post_s: float = 0.08
    force_n: float = 0.3
    force_sd_trial: float = 0.012
    force_sd: float = 0.012
    force_limit: float = 0.05
    speed_sd_trial: float = 0.07
    speed_sd: float = 0.06
    fluct_hz: float = 3.0
    approach_speed_min: float = 20.0
    approach_speed_max: float = 80.0
    pad_stiffness: float = 0.19
    pad_stiffening: float = 0.85
    descent_jitter: float = 0.1

    def __post_init__(self) -> None:
        for k, v in asdict(self).items():
            if not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ValueError(f"KinematicsParams.{k} must be a finite number, got {v!r}")
            if k not in ("x_start", "x_stop") and v < 0:
                raise ValueError(f"KinematicsParams.{k} must be >= 0, got {v!r}")
        if not self.x_start < -self.window / 2 < self.window / 2 < self.x_stop:
            raise ValueError(
                f"KinematicsParams: the slide [{self.x_start}, {self.x_stop}] mm must cover the "
                f"{self.window} mm window centred on 0"
            )
        check_fs(self.fs_hz, "KinematicsParams.fs_hz")
        positive("KinematicsParams.force_n", self.force_n, "N", what="force")
        if self.force_limit >= self.force_n:
            raise ValueError(f"KinematicsParams.force_limit must be below force_n ({self.force_n:g} N), "
                             f"got {self.force_limit!r}")
        if self.approach_speed_min > self.approach_speed_max or (
                self.approach_speed_max > 0 and self.approach_speed_min <= 0):
            raise ValueError(
                "KinematicsParams: approach_speed_min must be > 0 and <= approach_speed_max "
                f"(mm/s; both 0 for a landing at zero speed), got {self.approach_speed_min!r} and "
                f"{self.approach_speed_max!r}")
        if not self.descent_jitter < 0.5:
            raise ValueError(
                f"KinematicsParams.descent_jitter must be in [0, 0.5), got {self.descent_jitter!r}")
        if self.approach_speed_max > 0:
            positive("KinematicsParams.pad_stiffness", self.pad_stiffness, "N/mm", what="stiffness")
            positive("KinematicsParams.pad_stiffening", self.pad_stiffening, "1/mm", what="rate")
            positive("KinematicsParams.descent_s", self.descent_s, "s", what="duration")
            positive("KinematicsParams.load_s", self.load_s, "s", what="duration")
            # the load ramp m(u) + c q(u) rises monotonically for c < 27/8
            f_low = self.force_n - self.force_limit
            c = self.pad_stiffness * self.approach_speed_max * self.load_s / f_low
            if c >= 3.375:
                raise ValueError(
                    f"KinematicsParams: a landing at {self.approach_speed_max:g} mm/s on a pad of "
                    f"{self.pad_stiffness:g} N/mm overshoots a {f_low:g} N press within load_s = "
                    f"{self.load_s:g} s (k v_a load_s / (force_n - force_limit) = {c:.3g}, must be < 3.375)")
            # a minimum-jerk reach lands at most at 3 z_top / descent_s (its start)
            if self.approach_speed_max * self.descent_s * (1 + self.descent_jitter) >= 2.0 * self.z_top:
                raise ValueError(
                    f"KinematicsParams: approach_speed_max {self.approach_speed_max:g} mm/s is too fast "
                    f"for a descent of {self.z_top:g} mm in {self.descent_s:g} s (below "
                    f"{2.0 * self.z_top / self.descent_s:g} mm/s)")

    @property
    def pad(self) -> PadLaw | None:
        """The pad's force-indentation law, or None when the finger lands at zero speed."""
        if self.approach_speed_max <= 0:
            return None
        return PadLaw(self.pad_stiffness, self.pad_stiffening)

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class Kinematics:
    """Sampled kinematics of one trial on the force clock.

    Attributes
    ----------
    t : (n,) ndarray
        Time in s (``t[0] = 0``).
    x : (n,) ndarray
        Finger centre position in mm.
    z : (n,) ndarray
        Height in mm of the finger above its resting contact (0 while in contact).
    f_n : (n,) ndarray
        True normal force in N.
    sliding_distance : (n,) ndarray
        Distance slid since the slide started, mm (0 before).
    in_contact : (n,) bool ndarray
    t_descent, t_slide_start, t_stop : float
        Start of the descent, of the slide, time the finger passes ``x_stop`` (s).
    mean_speed : float
        The trial's target cruise speed in mm/s.
    f_target : float
        The trial's normal-force target in N: the level the force wanders around (the
        drawn target through the soft limit, without the wander).
    approach_speed : float
        The speed in mm/s at which the finger lands (0: the zero-speed landing).
    t_contact : float
        The instant the finger touches the surface, s (the load leaves zero; ``pre_s +``
        the trial's descent duration).
    pad : PadLaw or None
        The pad's force-indentation law (None with the zero-speed landing): what the
        contact tables' outline follows below their lowest load
        (:meth:`~fingerfriction.sim.contact.ContactTable.profile`).
    """

    t: np.ndarray
    x: np.ndarray
    z: np.ndarray
    f_n: np.ndarray
    sliding_distance: np.ndarray
    in_contact: np.ndarray
    t_descent: float
    t_slide_start: float
    t_stop: float
    mean_speed: float
    f_target: float = math.nan
    approach_speed: float = 0.0
    t_contact: float = math.nan
    pad: PadLaw | None = None


def min_jerk(u):
    """Minimum-jerk transition 0 -> 1 for ``u`` in [0, 1] (clipped): ``10u^3 - 15u^4 + 6u^5``."""
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10 - 15 * u + 6 * u * u)


def _landing_phase(r: float) -> float:
    """The phase ``u`` in (0, 1] of a minimum-jerk movement at which ``u m'(u) / m(u) =
    r`` (``0 <= r < 3``; the ratio falls from 3 at ``u = 0`` to 0 at ``u = 1``)."""
    if r <= 0:
        return 1.0

    def phi(u):
        return 30.0 * (1.0 - u) ** 2 / (10.0 - 15.0 * u + 6.0 * u * u) - r

    return float(brentq(phi, 1e-9, 1.0, xtol=1e-14))


def _launch(u):
    """``u (1 - u)^3 (1 + 3u)`` on [0, 1] (0 outside): the quintic with slope 1 and zero
    value and curvature at 0, and zero value, slope and curvature at 1."""
    u = np.clip(u, 0.0, 1.0)
    return u * (1.0 - u) ** 3 * (1.0 + 3.0 * u)


def smooth_noise(rng: np.random.Generator, n: int, fs: float, fc: float) -> np.ndarray:
    """Unit-variance Gaussian noise low-passed at ``fc`` Hz (zero-phase second-order
    Butterworth), ``n`` samples at ``fs`` Hz; draws ``n + 2 fs / fc`` normals from ``rng``."""
    pad = int(fs / max(fc, 0.1))
    w = rng.standard_normal(n + 2 * pad)
    sos = butter(2, fc, fs=fs, output="sos")
    y = sosfiltfilt(sos, w)[pad : pad + n]
    sd = y.std()
    return y / sd if sd > 0 else y


def simulate_kinematics(speed_mm_s: float, rng: np.random.Generator,
                        params: KinematicsParams | None = None) -> Kinematics:
    """Draw the kinematics of one trial.

    Parameters
    ----------
    speed_mm_s : float
        Nominal mean sliding speed in mm/s (> 0).
    rng : numpy.random.Generator
        Source of every random draw.
    params : KinematicsParams, optional

    Returns
    -------
    Kinematics
    """
    P = params or KinematicsParams()
    if not (isinstance(speed_mm_s, (int, float)) and math.isfinite(speed_mm_s) and speed_mm_s > 0):
        raise ValueError(f"speed_mm_s must be a positive speed in mm/s, got {speed_mm_s!r}")
    fs = P.fs_hz
    dt = 1.0 / fs
    # the landing: its speed and the descent's duration (both 1 with the zero-speed landing,
    # which draws nothing here: its other draws are those of the simulator before it)
    pad = P.pad
    v_a, descent_s = 0.0, P.descent_s
    if pad is not None:
        lo, hi = math.log(P.approach_speed_min), math.log(P.approach_speed_max)
        v_a = float(math.exp(lo + (hi - lo) * rng.random()))
        descent_s = P.descent_s * (1.0 + P.descent_jitter * (2.0 * rng.random() - 1.0))
    v_mean = speed_mm_s * float(np.clip(1.0 + P.speed_sd_trial * rng.standard_normal(), 0.8, 1.2))
    f_target = P.force_n + P.force_sd_trial * float(rng.standard_normal())

    t_descent = P.pre_s
    t_contact = t_descent + descent_s
    t_slide = t_contact + P.slide_delay_s
    # slide: distance to travel at cruise, with generous upper bound for the duration
    dist = P.x_stop - P.x_start
    t_cruise_max = 1.6 * dist / v_mean + P.ramp_s
    n_slide_max = int(math.ceil((P.ramp_s + t_cruise_max + P.ramp_s) / dt))
    n_before = int(round(t_slide / dt))
    fluct = smooth_noise(rng, n_slide_max, fs, P.fluct_hz)
    ts = np.arange(n_slide_max) * dt
    ramp_in = min_jerk(ts / P.ramp_s) if P.ramp_s > 0 else np.ones_like(ts)
    v = v_mean * (1.0 + P.speed_sd * fluct) * ramp_in
    xs = P.x_start + np.concatenate([[0.0], np.cumsum(v[:-1]) * dt])
    past = np.flatnonzero(xs >= P.x_stop)
    if past.size == 0:  # cannot happen with the bounds above; keep it explicit
        raise RuntimeError("kinematics: the slide did not reach x_stop")
    k_stop = int(past[0])
    n_ramp = max(int(round(P.ramp_s / dt)), 1)
    v_stop = v[k_stop]
    decel = 1.0 - min_jerk(np.arange(1, n_ramp + 1) / n_ramp)
    x_out = xs[k_stop] + np.cumsum(v_stop * decel) * dt
    x_slide = np.concatenate([xs[: k_stop + 1], x_out])
    t_stop = t_slide + k_stop * dt

    n_after = int(round((P.unload_s + P.post_s) / dt))
    n = n_before + x_slide.size + n_after
    t = np.arange(n) * dt
    x = np.concatenate([np.full(n_before, P.x_start), x_slide, np.full(n_after, x_slide[-1])])
    slid = np.maximum(x - P.x_start, 0.0)

    t_unload = max(t_slide + x_slide.size * dt, t_contact + P.load_s)
    # normal force: load ramp, fluctuation, soft limit, unload ramp
    ffl = P.force_sd * smooth_noise(rng, n, fs, P.fluct_hz)
    dev = (f_target - P.force_n) + ffl
    dev = P.force_limit * np.tanh(dev / P.force_limit)
    # height above the surface: the descent lands at v_a (a minimum-jerk reach towards a
    # point below the surface, interrupted by it), then 0; the lift at the end mirrors
    # the zero-speed descent
    u_c = _landing_phase(v_a * descent_s / P.z_top)
    amp = P.z_top / float(min_jerk(u_c))
    u_reach = u_c * (t - t_descent) / descent_s
    z = np.where(t < t_contact, amp * (1.0 - min_jerk(u_reach)) - (amp - P.z_top), 0.0)
    u_load = (t - t_contact) / P.load_s
    i_c = min(int(round(t_contact / dt)), n - 1)
    c = v_a * P.pad_stiffness * P.load_s / (P.force_n + dev[i_c]) if pad is not None else 0.0
    ramp = min_jerk(u_load) + c * _launch(u_load)
    f_n = (P.force_n + dev) * ramp * (1.0 - min_jerk((t - t_unload) / P.unload_s))
    in_contact = (t >= t_contact) & (t < t_unload + P.unload_s)
    z = np.where(t >= t_unload + P.unload_s, P.z_top * min_jerk((t - t_unload - P.unload_s) / P.descent_s), z)
    return Kinematics(
        t=t, x=x, z=z, f_n=f_n, sliding_distance=slid, in_contact=in_contact,
        t_descent=t_descent, t_slide_start=t_slide, t_stop=t_stop, mean_speed=v_mean,
        f_target=float(P.force_n + P.force_limit * math.tanh((f_target - P.force_n) / P.force_limit)),
        approach_speed=v_a, t_contact=float(t_contact), pad=pad,
    )
