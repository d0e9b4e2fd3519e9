"""The two-channel piezoelectric force sensor (Methods "Measurement apparatus", Fig. 1C).

Two transducers at +-45 degrees carry the tray; the paper recovers
``F_N = (F1 + F2) / sqrt 2`` and ``F_T = (F1 - F2) / sqrt 2``, so the channels see::

    F1 = (F_N + F_T) / sqrt 2,    F2 = (F_N - F_T) / sqrt 2.

Each channel then goes through, in this order (defaults in :class:`SensorParams`):

1. the piezo / charge-amplifier high-pass: first-order, cutoff ``highpass_hz`` (5 Hz),
   discretised by the bilinear transform (``scipy.signal.butter(1, ...)`` + ``lfilter``),
   starting from rest (the channel reads 0 before the finger touches);
2. slow drift: an offset ``N(0, drift_offset_n)`` plus a linear trend of slope
   ``N(0, drift_rate_n_per_s)`` per channel (the paper removes a linear trend per slide);
3. mains interference at 50, 150 and 300 Hz with amplitudes ``mains_n`` (same mains
   phase for both channels, per-channel gain ``1 + N(0, 0.2)``, random phase per trial);
4. white noise ``N(0, noise_n)`` per sample;
5. 16-bit quantisation over ``+-full_scale_n`` (LSB = 2 full_scale / 2^16) and clipping.

Values are stored in newtons (the quantised levels ``k * LSB``).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy.signal import bilinear, butter, lfilter, sosfilt

from .._check import check_freq, check_fs, integer, nonnegative, positive

__all__ = ["SensorParams", "to_channels", "from_channels", "apply_sensor", "highpass2", "tray_response",
           "SQRT2"]

SQRT2 = math.sqrt(2.0)


@dataclass(frozen=True)
class SensorParams:
    """Sensor model parameters (forces in N, frequencies in Hz).

    Parameters
    ----------
    fs_hz : float
        Sampling frequency (10 kHz, NI-6229).
    highpass_hz : float
        First-order high-pass cutoff of the piezo chain (0 disables it).
    drift_offset_n : float
        Standard deviation of the per-channel offset, N.
    drift_rate_n_per_s : float
        Standard deviation of the per-channel linear drift rate, N/s.
    mains_n : tuple of 3 float
        Amplitudes of the 50, 150 and 300 Hz interference, N.
    noise_n : float
        Standard deviation of white noise per sample, N.
    bits : int
        ADC resolution (16).
    full_scale_n : float
        The ADC range is ``[-full_scale_n, full_scale_n)`` in N per channel.
    """

    fs_hz: float = 10_000.0
    highpass_hz: float = 5.0
    drift_offset_n: float = 0.002
    drift_rate_n_per_s: float = 0.004
    mains_n: tuple = (0.003, 0.001, 0.0005)
    noise_n: float = 0.0005
    bits: int = 16
    full_scale_n: float = 2.5

    def __post_init__(self) -> None:
        object.__setattr__(self, "fs_hz", check_fs(self.fs_hz, "SensorParams.fs_hz"))
        object.__setattr__(self, "full_scale_n",
                           positive("SensorParams.full_scale_n", self.full_scale_n, "N"))
        for k, unit in (("highpass_hz", "Hz"), ("drift_offset_n", "N"), ("drift_rate_n_per_s", "N/s"),
                        ("noise_n", "N")):
            object.__setattr__(self, k, nonnegative(f"SensorParams.{k}", getattr(self, k), unit))
        if self.highpass_hz > 0:  # 0: no high-pass
            check_freq("SensorParams.highpass_hz", self.highpass_hz, self.fs_hz)
        m = tuple(float(v) for v in self.mains_n)
        if len(m) != 3 or any(not math.isfinite(v) or v < 0 for v in m):
            raise ValueError(f"SensorParams.mains_n must be 3 amplitudes >= 0 (N), got {self.mains_n!r}")
        object.__setattr__(self, "mains_n", m)
        object.__setattr__(self, "bits", integer("SensorParams.bits", self.bits, 2, 32))

    @property
    def lsb_n(self) -> float:
        """Quantisation step in N."""
        return 2.0 * self.full_scale_n / 2**self.bits

    def to_dict(self) -> dict:
        d = asdict(self)
        d["mains_n"] = list(self.mains_n)
        d["lsb_n"] = self.lsb_n
        return d


def to_channels(f_n, f_t):
    """Transducer forces ``(F1, F2)`` in N from normal and tangential force (Fig. 1C)."""
    f_n = np.asarray(f_n, float)
    f_t = np.asarray(f_t, float)
    return (f_n + f_t) / SQRT2, (f_n - f_t) / SQRT2


def from_channels(f1, f2):
    """``(F_N, F_T)`` in N from the transducer forces: the paper's decomposition."""
    f1 = np.asarray(f1, float)
    f2 = np.asarray(f2, float)
    return (f1 + f2) / SQRT2, (f1 - f2) / SQRT2


def highpass2(x: np.ndarray, poles, fs: float) -> np.ndarray:
    """Cascaded first-order high-passes (bilinear transform, from rest) at ``poles`` Hz."""
    secs = [butter(1, float(f), btype="highpass", fs=fs, output="sos") for f in poles if f > 0]
    if not secs:
        return np.asarray(x, float)
    return sosfilt(np.concatenate(secs), np.asarray(x, float))


def tray_response(f: np.ndarray, resonance_hz: float, q: float, fs: float) -> np.ndarray:
    """A force on the plate as the transducers feel it through the tray: the second-order
    resonance ``w^2 / (s^2 + (w / q) s + w^2)`` (unit gain at rest), bilinear with the
    resonance prewarped, from rest.

    Parameters
    ----------
    f : (n,) ndarray
        Force in N on the force clock.
    resonance_hz, q : float
        The axis' resonance in Hz (below ``fs / 2``) and quality factor.
    fs : float
        Sampling frequency in Hz.
    """
    w = 2.0 * fs * math.tan(math.pi * float(resonance_hz) / fs)
    b, a = bilinear([w * w], [1.0, w / float(q), w * w], fs)
    return lfilter(b, a, np.asarray(f, float))


def apply_sensor(f_n: np.ndarray, f_t: np.ndarray, rng: np.random.Generator,
                 params: SensorParams | None = None, *, chain=None) -> tuple[np.ndarray, np.ndarray]:
    """Recorded channels ``(F1, F2)`` in N for true forces sampled at ``params.fs_hz``.

    Parameters
    ----------
    f_n, f_t : (n,) ndarray
        True normal and tangential force on the plate, N.
    rng : numpy.random.Generator
        Every draw of the ideal chain (the same draws with or without ``chain``).
    params : SensorParams, optional
    chain : ChainDraws, optional
        A trial's realistic chain (:mod:`fingerfriction.sim.chain`): the forces go through
        the tray's resonance on each axis (when it has one), the channels are mixed by its
        crosstalk matrix, go through its second-order high-pass (instead of
        the first-order ``params.highpass_hz``), get its extra drift, and, after the
        quantisation, the inverse of the lab's calibration matrix when it has one.

    Returns
    -------
    F1, F2 : (n,) float64 ndarray
        Quantised channel readings in N.
    """
    P = params or SensorParams()
    if chain is not None and chain.tray is not None:
        f_n = tray_response(f_n, chain.tray[0, 0], chain.tray[0, 1], P.fs_hz)
        f_t = tray_response(f_t, chain.tray[1, 0], chain.tray[1, 1], P.fs_hz)
    f1, f2 = to_channels(f_n, f_t)
    n = f1.size
    t = np.arange(n) / P.fs_hz
    if chain is not None:
        M = chain.crosstalk
        f1, f2 = M[0, 0] * f1 + M[0, 1] * f2, M[1, 0] * f1 + M[1, 1] * f2
        f1 = highpass2(f1, chain.poles_hz[0], P.fs_hz)
        f2 = highpass2(f2, chain.poles_hz[1], P.fs_hz)
    elif P.highpass_hz > 0:
        b, a = butter(1, P.highpass_hz, btype="highpass", fs=P.fs_hz)
        f1 = lfilter(b, a, f1)
        f2 = lfilter(b, a, f2)
    phases = rng.uniform(0, 2 * np.pi, 3)
    mains = sum(
        amp * np.sin(2 * np.pi * f * t + ph)
        for amp, f, ph in zip(P.mains_n, (50.0, 150.0, 300.0), phases, strict=True)
    )
    out = []
    for c, ch in enumerate((f1, f2)):
        off = P.drift_offset_n * rng.standard_normal()
        rate = P.drift_rate_n_per_s * rng.standard_normal()
        gain = 1.0 + 0.2 * rng.standard_normal()
        y = ch + off + rate * t + gain * mains + P.noise_n * rng.standard_normal(n)
        if chain is not None:
            y = y + chain.drift[c]
        lsb = P.lsb_n
        k = np.clip(np.rint(y / lsb), -(2 ** (P.bits - 1)), 2 ** (P.bits - 1) - 1)
        out.append(k * lsb)
    if chain is not None and chain.calibration is not None:  # the lab's crosstalk calibration
        out = list(np.linalg.solve(chain.calibration, np.vstack(out)))
    return out[0], out[1]
