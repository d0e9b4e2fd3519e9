"""The sensor's high-pass cut-off estimated on the unloaded rests before the touch and after
the lift-off (:func:`estimate_highpass`, opt-in: ``ForceProcessingParams.estimate_highpass``).
Beyond the paper; ``docs/forces.md`` has why and the measured figures. The compensation that
uses the cut-off is :func:`fingerfriction.forces.sensor.compensate_highpass`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal
from scipy.optimize import least_squares

from .._check import check_freq as _check_freq
from .._check import check_fs as _check_fs
from .._check import positive as _positive

__all__ = ["HighpassEstimate", "estimate_highpass"]


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
        carries from the whole record into the rest after the lift-off (see docs/forces.md,
        'High-pass estimate'); NaN when not determined. It covers the noise only, not
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


def _scaled_condition(J: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Condition number of ``J`` with its columns scaled to unit norm (the cut-off, ~30
    rad/s, and the drift, ~1e-3 N, differ by 1e4), the scaled matrix and the scales."""
    scale = np.sqrt(np.sum(J**2, axis=0))
    scale[scale == 0] = 1.0
    return float(np.linalg.cond(J / scale)), J / scale, scale


def _rest_runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Contiguous runs of rest samples as ``(start, length)`` in the rest samples' own
    numbering (for the residuals' autocorrelation)."""
    d = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
    starts, ends = np.flatnonzero(d == 1), np.flatnonzero(d == -1)
    runs = zip(np.cumsum(np.concatenate(([0], ends - starts)))[:-1], ends - starts, strict=True)
    return [(int(s0), int(length)) for s0, length in runs]


def _cutoff_standard_error(r: np.ndarray, m: np.ndarray, Js: np.ndarray, scale: np.ndarray, w: float,
                           fs: float) -> tuple[float, float]:
    """Standard error in Hz of the estimated cut-off and the residuals' mean integrated
    autocorrelation time in samples (see docs/forces.md, 'High-pass estimate').

    The linearised estimate is ``w + g . e``, with ``e`` the residual at the truth,
    ``C_w[noise] = noise + w I[noise]`` on the rest samples. The integral carries the noise
    of the whole record, the contact included, into the rest after the lift-off: besides the
    short-range part (the noise's autocovariance summed over lags, from the residuals),
    ``Var(g . e)`` has the random walk's part (``dt**2 sum_m G_m**2``, ``G_m = sum_{j >= m}
    g_j`` over every sample ``m``) and their covariance; channels are taken as independent.
    """
    k, n_rest = r.shape
    n = m.size
    runs = _rest_runs(m)
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
    se_w = math.sqrt(max(var_w, 0.0))
    return se_w / (2.0 * math.pi) / (1.0 + (w / (2.0 * fs)) ** 2), float(np.mean(taus))  # d fc / d w


class _RestModel:
    """The rests' model of :func:`estimate_highpass`, for ``k`` channels ``y`` (N) sampled
    at ``fs`` (Hz) with the rest samples ``mask``: the parameters ``p = [w, b_1, a_1, ...]``
    (``w`` the angular cut-off in rad/s, ``b_c + a_c u`` channel c's drift line, ``u`` the
    time in record durations), the residual at the rest samples and its Jacobian."""

    def __init__(self, y, mask, fs: float):
        Y = np.atleast_2d(np.asarray(y, dtype=np.float64))
        m = np.asarray(mask, dtype=bool)
        if Y.ndim != 2 or m.ndim != 1 or m.shape[0] != Y.shape[1]:
            raise ValueError(
                f"y must be (n,) or (k, n) and mask (n,) with the same n, got {np.shape(y)} and {m.shape}"
            )
        if not np.all(np.isfinite(Y)):
            raise ValueError("y contains NaN or infinite values; fill or remove them before the estimate")
        self.mask, self.n_rest = m, int(m.sum())
        if self.n_rest < 8:
            raise ValueError(f"the cut-off estimate needs at least 8 rest samples in mask, got {self.n_rest}")
        self.k, n = Y.shape
        tau = np.arange(n) / fs
        span = max(float(tau[-1]), 1.0 / fs)
        u = tau / span  # slope per record duration: columns of order 1
        self.iy = _trapezoid_integral(Y, fs)[:, m]
        self.i1 = _trapezoid_integral(np.ones(n), fs)[m]
        self.iu = _trapezoid_integral(u, fs)[m]
        self.yr, self.ur = Y[:, m], u[m]

    def drift(self, w: float) -> np.ndarray:
        """(b_c, a_c) per channel, least squares at a fixed w: (k, 2)."""
        A = np.column_stack([1.0 + w * self.i1, self.ur + w * self.iu])
        coef, *_ = np.linalg.lstsq(A, (self.yr + w * self.iy).T, rcond=None)
        return coef.T

    def residual(self, p: np.ndarray) -> np.ndarray:
        w, ba = p[0], p[1:].reshape(self.k, 2)
        r = self.yr + w * self.iy - ba[:, :1] * (1.0 + w * self.i1) - ba[:, 1:] * (self.ur + w * self.iu)
        return r.ravel()

    def jacobian(self, p: np.ndarray) -> np.ndarray:
        w, ba = p[0], p[1:].reshape(self.k, 2)
        n_rest = self.n_rest
        J = np.zeros((self.k * n_rest, 1 + 2 * self.k))
        for c in range(self.k):
            rows = slice(c * n_rest, (c + 1) * n_rest)
            J[rows, 0] = self.iy[c] - ba[c, 0] * self.i1 - ba[c, 1] * self.iu
            J[rows, 1 + 2 * c] = -(1.0 + w * self.i1)
            J[rows, 2 + 2 * c] = -(self.ur + w * self.iu)
        return J


def estimate_highpass(y, mask, fs: float, prior: float, *, max_rel_se: float = 0.1) -> HighpassEstimate:
    """Estimate the cut-off of the sensor's first-order high-pass from the unloaded rests.

    Beyond the paper (which states "approximately 5 Hz"): the cut-off and each channel's
    drift are fitted jointly on the rests, iterated from the prior (Levenberg-Marquardt);
    only the rest after the lift-off determines the cut-off.

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
    The model, the fit and the standard error (Sokal's integrated autocorrelation time):
    see docs/forces.md, 'High-pass estimate'.
    """
    fs = _check_fs(fs, "fs")
    prior = _check_freq("prior", prior, fs)
    max_rel_se = _positive("max_rel_se", max_rel_se, "(dimensionless)")
    rest = _RestModel(y, mask, fs)
    k, n_rest, m = rest.k, rest.n_rest, rest.mask
    drift, residual, jacobian = rest.drift, rest.residual, rest.jacobian
    w_prior = 2.0 * fs * math.tan(math.pi * prior / fs)  # bilinear transform's prewarping

    def fail(msg: str, nfev: int = 0, rms: float = float("nan"), ac: float = float("nan")):
        return HighpassEstimate(prior, float("nan"), prior, n_rest, k, nfev, rms, ac, False, msg)

    undetermined = (
        "the rests do not determine the cut-off (condition number {:.3g} of the fit): the rest after the "
        "lift-off is missing or too short, or the record carries no load"
    )
    p0 = np.concatenate([[w_prior], drift(w_prior).ravel()])
    cond0 = _scaled_condition(jacobian(p0))[0]
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
    cond, Js, scale = _scaled_condition(jacobian(sol.x))
    if not cond < 1e8:
        return fail(undetermined.format(cond), sol.nfev, rms)
    se, ac = _cutoff_standard_error(r, m, Js, scale, w, fs)
    if not fc < 0.5 * fs:
        return fail(f"the fitted cut-off {fc:g} Hz is not below the Nyquist frequency", sol.nfev, rms, ac)
    if not se <= max_rel_se * fc:
        msg = (f"the cut-off is not determined by the rests: {fc:.4g} +- {se:.2g} Hz (standard error "
               f"above max_rel_se={max_rel_se:g} of it)")
        return HighpassEstimate(prior, se, prior, n_rest, k, sol.nfev, rms, ac, False, msg)
    return HighpassEstimate(fc, se, prior, n_rest, k, sol.nfev, rms, ac, True, "ok")
