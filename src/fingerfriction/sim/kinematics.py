"""Finger kinematics of one trial: position x(t), height above the surface z(t) and normal
force F_N(t) on the 10 kHz force clock (Methods "Procedure" of Janko et al. 2018).

A trial, on the common clock (t = 0 at the first force sample):

1. ``pre_s`` of rest with the finger raised above the camera's field (no load);
2. descent: the finger comes down at ``x_start`` (minimum-jerk, ``descent_s``) from
   ``z_top`` mm above the surface to touching it; the video starts with this phase, its
   frame 0 (finger still above the field) is the calibration frame (Fig. 7A);
3. loading: F_N rises to the trial's target (minimum-jerk, ``load_s``);
4. slide left to right, starting ``slide_delay_s`` after touch-down (while the load is
   still building, as people do): ramp in (minimum-jerk acceleration, ``ramp_s``), a
   cruise at the trial's mean speed with a slow random fluctuation, ramp out once past
   ``x_stop``;
5. unloading (``unload_s``) and ``post_s`` of rest.

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
from scipy.signal import butter, sosfiltfilt

from .._check import check_fs, positive

__all__ = ["KinematicsParams", "Kinematics", "simulate_kinematics", "min_jerk", "smooth_noise"]


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
    """

    fs_hz: float = 10_000.0
    x_start: float = -15.5
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


def min_jerk(u):
    """Minimum-jerk transition 0 -> 1 for ``u`` in [0, 1] (clipped): ``10u^3 - 15u^4 + 6u^5``."""
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10 - 15 * u + 6 * u * u)


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
    v_mean = speed_mm_s * float(np.clip(1.0 + P.speed_sd_trial * rng.standard_normal(), 0.8, 1.2))
    f_target = P.force_n + P.force_sd_trial * float(rng.standard_normal())

    t_descent = P.pre_s
    t_contact = t_descent + P.descent_s
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

    # height above the surface: descent then 0; lift at the end mirrors the descent
    z = np.zeros(n)
    u_desc = (t - t_descent) / P.descent_s
    z = P.z_top * (1.0 - min_jerk(u_desc))
    t_unload = max(t_slide + x_slide.size * dt, t_contact + P.load_s)
    # normal force: load ramp, fluctuation, soft limit, unload ramp
    ffl = P.force_sd * smooth_noise(rng, n, fs, P.fluct_hz)
    dev = (f_target - P.force_n) + ffl
    dev = P.force_limit * np.tanh(dev / P.force_limit)
    f_n = (P.force_n + dev) * min_jerk((t - t_contact) / P.load_s) * (
        1.0 - min_jerk((t - t_unload) / P.unload_s)
    )
    in_contact = (t >= t_contact) & (t < t_unload + P.unload_s)
    z = np.where(t >= t_unload + P.unload_s, P.z_top * min_jerk((t - t_unload - P.unload_s) / P.descent_s), z)
    return Kinematics(
        t=t, x=x, z=z, f_n=f_n, sliding_distance=slid, in_contact=in_contact,
        t_descent=t_descent, t_slide_start=t_slide, t_stop=t_stop, mean_speed=v_mean,
        f_target=float(P.force_n + P.force_limit * math.tanh((f_target - P.force_n) / P.force_limit)),
    )
