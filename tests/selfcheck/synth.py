"""Small synthetic trials for the consistency stage's tests: a finger that touches down,
presses, then slides, seen by a 1 kHz camera (x(t)) and a 10 kHz two-channel sensor.

The pre-sliding law is ``F_T / F_N = mu G(d)`` with ``G(d) = (1 - exp(-d / d0))`` times a
decaying static peak, ``d`` the distance slid; the slide starts from rest with a
minimum-jerk velocity ramp. Nothing here is the package's simulator: the tests build
their own trials so that what they check does not rest on the code under test.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

SQRT2 = math.sqrt(2.0)


def min_jerk(u):
    u = np.clip(u, 0.0, 1.0)
    return u**3 * (10 - 15 * u + 6 * u * u)


@dataclass
class SynthTrial:
    t: np.ndarray  # force clock, s
    f_n: np.ndarray  # N
    f_t: np.ndarray  # N
    t_frames: np.ndarray  # s
    x_frames: np.ndarray  # mm
    fs_hz: float
    speed: float

    @property
    def f1(self):
        return (self.f_n + self.f_t) / SQRT2

    @property
    def f2(self):
        return (self.f_n - self.f_t) / SQRT2


def press_and_slide(
    *,
    speed: float = 80.0,
    mu: float = 0.5,
    load: float = 0.3,
    direction: int = 1,
    d0: float = 0.04,
    ramp_s: float = 0.06,
    fs_hz: float = 10_000.0,
    fps: float = 1000.0,
    duration_s: float = 0.7,
    t_touch: float = 0.1,
    t_slide: float = 0.14,
    noise: float = 5e-4,
    rng: np.random.Generator | None = None,
) -> SynthTrial:
    """One trial; times on a common clock (the force clock's sample 0 at t = 0)."""
    rng = rng or np.random.default_rng(0)
    t = np.arange(int(duration_s * fs_hz)) / fs_hz
    v = speed * min_jerk((t - t_slide) / ramp_s) * (t >= t_slide)
    d = np.cumsum(v) / fs_hz
    f_n = load * min_jerk((t - t_touch) / 0.05)
    g = (1.0 - np.exp(-d / d0)) * (1.0 + 0.3 * np.exp(-d / 0.5))
    f_t = direction * mu * f_n * g
    f_n = f_n + noise * rng.standard_normal(t.size)
    f_t = f_t + noise * rng.standard_normal(t.size)
    t_frames = np.arange(int(duration_s * fps)) / fps
    x_frames = (
        -10.0 * direction + direction * np.interp(t_frames, t, d) + 0.002 * rng.standard_normal(t_frames.size)
    )
    x_frames[t_frames < t_touch - 0.01] = np.nan  # the finger enters the view as it lands
    return SynthTrial(t, f_n, f_t, t_frames, x_frames, fs_hz, speed)


def mains(
    n: int,
    fs_hz: float,
    *,
    f0: float = 50.0,
    amps=(3e-3, 1e-3, 5e-4),
    harmonics=(1, 3, 6),
    rng: np.random.Generator | None = None,
) -> np.ndarray:
    """Mains interference (N) at ``f0`` and its harmonics, random phases."""
    rng = rng or np.random.default_rng(1)
    t = np.arange(n) / fs_hz
    return sum(
        a * np.sin(2 * np.pi * k * f0 * t + rng.uniform(0, 2 * np.pi))
        for a, k in zip(amps, harmonics, strict=True)
    )


@dataclass
class SynthLanding:
    t: np.ndarray  # force clock, s
    f1: np.ndarray  # N
    f2: np.ndarray  # N
    t_frames: np.ndarray  # s
    gap_mm: np.ndarray  # mm, NaN while the finger is above the field
    fs_hz: float
    t_touch: float


def landing(
    *,
    v: float = 50.0,
    decel: float = 3000.0,
    jerk: float = 2e5,
    k_pad: float = 0.2,
    load: float = 0.3,
    t_touch: float = 0.1204,
    fs_hz: float = 10_000.0,
    fps: float = 1000.0,
    duration_s: float = 0.4,
    noise: float = 5e-4,
    gap_noise_mm: float = 0.002,
    hum: bool = True,
    rng: np.random.Generator | None = None,
) -> SynthLanding:
    """A finger landing at ``v`` mm/s, decelerating at ``decel`` mm/s^2 (jerk ``jerk``
    mm/s^3) as it touches at ``t_touch``: its gap ``v tau + decel tau^2 / 2 + jerk tau^3 /
    6`` (``tau`` the time to the touch), then a load rising at ``k_pad v`` N/s to ``load``
    (an exponential saturation), recorded with noise, the mains and a drift line."""
    rng = rng or np.random.default_rng(0)
    t = np.arange(int(duration_s * fs_hz)) / fs_hz
    tau = np.clip(t - t_touch, 0.0, None)
    slope = k_pad * v
    f_n = load * (1.0 - np.exp(-slope * tau / load))
    drift = 0.002 + 0.004 * t
    f_n = f_n + drift + noise * rng.standard_normal(t.size)
    if hum:
        f_n = f_n + mains(t.size, fs_hz, rng=rng)
    f_t = noise * rng.standard_normal(t.size)
    t_frames = np.arange(int(duration_s * fps)) / fps
    before = np.clip(t_touch - t_frames, 0.0, None)
    gap = v * before + 0.5 * decel * before**2 + jerk * before**3 / 6.0
    gap = np.where(before > 0, gap + gap_noise_mm * rng.standard_normal(t_frames.size), 0.0)
    gap[gap > 3.0] = np.nan  # above the field
    return SynthLanding(t, (f_n + f_t) / SQRT2, (f_n - f_t) / SQRT2, t_frames, np.maximum(gap, 0.0), fs_hz,
                        t_touch)
