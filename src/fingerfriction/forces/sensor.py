"""The force sensor: the two +-45 degree transducers, their drift and the piezo chain's
first-order high-pass, with its unloaded rests (Methods "Measurement apparatus" and
"Force data processing" of Janko et al. 2018; the high-pass compensation is beyond the
paper, see ``docs/forces.md`` for why and for the measured figures).

* :func:`decompose` / :func:`compose`: transducer channels to normal and tangential force;
* :func:`fit_linear_drift`, :func:`remove_linear_drift`: the paper's flat-segment drift;
* :func:`fit_baseline`: drift line and mains sinusoids on the rest before the touch;
* :func:`compensate_highpass`: the inverse of the sensor's high-pass;
* :func:`detect_baseline`, :func:`detect_post_baseline`: the rests before the touch and
  after the lift-off;
* :func:`fit_rest_drift`: the residual drift through the compensation on both rests;
* :func:`estimate_highpass`: the cut-off itself, fitted on the rests (opt-in; in
  :mod:`fingerfriction.forces.highpass`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage, signal

from .._check import check_freq as _check_freq
from .._check import check_fs as _check_fs
from .._check import positive as _positive
from .highpass import HighpassEstimate, estimate_highpass
from .params import MAINS_HZ

__all__ = [
    "decompose",
    "compose",
    "fit_linear_drift",
    "remove_linear_drift",
    "BaselineFit",
    "fit_baseline",
    "compensate_highpass",
    "detect_baseline",
    "detect_post_baseline",
    "RestDriftFit",
    "fit_rest_drift",
    "HighpassEstimate",
    "estimate_highpass",
]

SQRT2 = math.sqrt(2.0)


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


def fit_baseline(t, y, mask, *, mains_hz: Sequence[float] = MAINS_HZ) -> BaselineFit:
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
    # (1400 x 8, measured)
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
