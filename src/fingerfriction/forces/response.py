"""The sensor's high-pass as a response of second order, estimated per transducer on the
unloaded rests (beyond the paper; ``ForceProcessingParams(highpass_model="second-order")``).

The paper states only that the piezo chain is high-pass, "approximately 5 Hz". A piezo
transducer with its charge (or IEPE) amplifier and an AC-coupled conditioner has two
high-pass poles, and the two transducers' chains are not identical. The first-order
compensation (:func:`~fingerfriction.forces.sensor.compensate_highpass`) inverts one pole
at a cut-off it is told; a second pole, or a cut-off a few per cent off, leaves errors of
tens of per cent of the force's peak-to-peak (``docs/forces.md``). Here the response

    H(s) = s^2 / (s^2 + a1 s + a0)

(two poles, real or a complex pair; ``a0 = 0`` is the first-order ``s / (s + a1)``) is
inverted exactly in its bilinear discretisation, ``x = y + a1 I[y] + a0 I[I[y]]`` with
``I`` the running trapezoid integral from the record's first sample (:class:`HighpassResponse`),
and ``(a1, a0)`` are fitted for each transducer channel on the rests before the touch and
after the lift-off, where the true force is zero, jointly with the channel's residual
drift line (:func:`estimate_response`): the recorded signal after the lift-off is the
response's decaying tail, which only the right ``(a1, a0)`` cancels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import signal
from scipy.optimize import least_squares

from .._check import check_fs as _check_fs
from .._check import check_option
from .._check import positive as _positive

__all__ = ["HighpassResponse", "ResponseEstimate", "estimate_response", "rest_drift_image"]


def _integral(y: np.ndarray, fs: float) -> np.ndarray:
    """Running trapezoid integral along the last axis from a zero state (s x unit of ``y``)."""
    return signal.lfilter([1.0, 1.0], [1.0, -1.0], y, axis=-1) / (2.0 * fs)


def _prewarp(f_hz: float, fs: float) -> float:
    return 2.0 * fs * math.tan(math.pi * f_hz / fs)


def _unwarp(w: float, fs: float) -> float:
    return fs / math.pi * math.atan(w / (2.0 * fs))


@dataclass(frozen=True)
class HighpassResponse:
    """A high-pass ``s^2 / (s^2 + a1 s + a0)`` in the bilinear transform's (prewarped)
    angular frequencies.

    Parameters
    ----------
    a1 : float
        rad/s (>= 0): the sum of the poles' angular frequencies.
    a0 : float
        rad^2/s^2 (>= 0): their product (0: first order at ``a1``).
    """

    a1: float
    a0: float

    def __post_init__(self) -> None:
        for k in ("a1", "a0"):
            v = getattr(self, k)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"HighpassResponse.{k} must be a finite number >= 0, got {v!r}")

    @classmethod
    def from_poles(cls, poles_hz, fs: float) -> HighpassResponse:
        """The cascade of first-order bilinear high-passes at ``poles_hz`` (one or two, Hz)."""
        w = [_prewarp(float(f), fs) for f in poles_hz if f > 0]
        if len(w) > 2:
            raise ValueError(f"at most two poles, got {list(poles_hz)}")
        return cls(float(sum(w)), float(w[0] * w[1]) if len(w) == 2 else 0.0)

    def invert(self, y, fs: float) -> np.ndarray:
        """The input of the high-pass from its output ``y`` (along the last axis, from rest)."""
        iy = _integral(np.asarray(y, dtype=np.float64), fs)
        y = np.asarray(y, dtype=np.float64)
        return y + self.a1 * iy + (self.a0 * _integral(iy, fs) if self.a0 else 0.0)

    def poles_hz(self, fs: float) -> tuple[complex, complex]:
        """The two poles' frequencies in Hz (real: the roots of ``s^2 - a1 s + a0``
        unwarped; a complex pair is returned as such, in prewarped Hz)."""
        disc = self.a1 * self.a1 - 4.0 * self.a0
        if disc >= 0:
            r = math.sqrt(disc)
            return (_unwarp(0.5 * (self.a1 + r), fs), _unwarp(0.5 * (self.a1 - r), fs))
        r = math.sqrt(-disc)
        return (complex(self.a1, r) / (4 * math.pi), complex(self.a1, -r) / (4 * math.pi))

    def cutoff_hz(self, fs: float) -> float:
        """-3 dB frequency in Hz of the analogue prototype, unwarped (0 for a0 = a1 = 0)."""
        if self.a1 == 0 and self.a0 == 0:
            return 0.0
        lo, hi = 0.0, 10.0 * (self.a1 + math.sqrt(self.a0)) + 1.0
        for _ in range(100):  # |H(jw)|^2 rises with w
            w = 0.5 * (lo + hi)
            g = w**4 / ((self.a0 - w * w) ** 2 + (self.a1 * w) ** 2)
            lo, hi = (w, hi) if g < 0.5 else (lo, w)
        return _unwarp(0.5 * (lo + hi), fs)


def rest_drift_image(y_comp, mask, fs: float, response: HighpassResponse) -> tuple[np.ndarray, np.ndarray]:
    """The residual drift line's image through the inverse, fitted on the rests.

    A drift ``b + a u`` (``u`` the time in record durations) left in the recorded signal
    becomes ``b C[1] + a C[u]`` after the inversion ``C``; where the true force is zero
    (``mask``) the compensated signal ``y_comp`` is that image plus noise.

    Returns
    -------
    image : (n,) ndarray
        N, to subtract from ``y_comp``.
    coef : (2,) ndarray
        ``(b, a)``: the drift's offset in N and change over the record in N.
    """
    y = np.asarray(y_comp, dtype=np.float64)
    m = np.asarray(mask, dtype=bool) & np.isfinite(y)
    if m.sum() < 4:
        raise ValueError(f"the rest drift fit needs at least 4 rest samples in mask, got {int(m.sum())}")
    n = y.size
    u = np.arange(n) / max(n - 1, 1)
    W = response.invert(np.vstack([np.ones(n), u]), fs)
    coef, *_ = np.linalg.lstsq(W[:, m].T, y[m], rcond=None)
    return W.T @ coef, coef


@dataclass(frozen=True)
class ResponseEstimate:
    """The high-pass of one channel estimated on its rests (:func:`estimate_response`).

    Attributes
    ----------
    response : HighpassResponse
        The estimate (the prior's first-order response when ``success`` is False).
    cutoff_hz : float
        Its -3 dB frequency in Hz.
    poles_hz : tuple
        Its poles in Hz (:meth:`HighpassResponse.poles_hz`).
    prior_hz : float
        The cut-off the fit started from.
    n_samples : int
        Rest samples fitted.
    iterations : int
        Residual evaluations of the solver.
    rms_residual_n : float
        RMS in N of the compensated signal on the rests after the drift image.
    condition : float
        Condition number of the fit's Jacobian, columns scaled.
    success : bool
    message : str
    """

    response: HighpassResponse
    cutoff_hz: float
    poles_hz: tuple
    prior_hz: float
    n_samples: int
    iterations: int
    rms_residual_n: float
    condition: float
    success: bool
    message: str


def estimate_response(y, mask, fs: float, prior_hz: float, *, order: int = 2) -> ResponseEstimate:
    """Fit the high-pass ``(a1, a0)`` of one channel on its rests.

    Variable projection: for given ``(a1, a0)`` the channel's drift ``(b, a)`` is the
    least-squares image of :func:`rest_drift_image`; ``(a1, a0)`` (``a0 = 0`` with
    ``order=1``) minimise the rests' residual (trust region, ``a1, a0 >= 0``) from two
    starts, the prior's first-order response and one with a second pole at a quarter of
    the prior; the better is kept.

    Parameters
    ----------
    y : (n,) array_like
        The recorded channel in N before the compensation (the drift line and mains fitted
        on the first rest subtracted, low-passed), from the sample the inversion starts at.
    mask : (n,) array_like of bool
        Rest samples (true force zero): before the touch and after the lift-off.
    fs : float
        Sampling frequency in Hz.
    prior_hz : float
        Cut-off in Hz the fit starts from (the stated ~5 Hz).
    order : {1, 2}
        1 fits ``a1`` alone.

    Returns
    -------
    ResponseEstimate
        Never raises for data that do not determine the response: ``success`` False and the
        prior's first-order response.

    Raises
    ------
    ValueError
        Malformed input (shapes, non-finite samples, fewer than 8 rest samples).
    """
    fs = _check_fs(fs, "fs")
    prior_hz = _positive("prior_hz", prior_hz, "Hz")
    check_option("order", order, (1, 2))
    y = np.asarray(y, dtype=np.float64)
    m = np.asarray(mask, dtype=bool)
    if y.ndim != 1 or m.shape != y.shape:
        raise ValueError(f"y and mask must be 1-D of the same length, got {y.shape} and {m.shape}")
    if not np.all(np.isfinite(y)):
        raise ValueError("y contains NaN or infinite values; fill or remove them before the estimate")
    n_rest = int(m.sum())
    if n_rest < 8:
        raise ValueError(f"the response estimate needs at least 8 rest samples in mask, got {n_rest}")
    n = y.size
    u = np.arange(n) / max(n - 1, 1)
    P = np.vstack([np.ones(n), u])
    iy, ip = _integral(y, fs), _integral(P, fs)
    iiy, iip = _integral(iy, fs), _integral(ip, fs)
    yr, iyr, iiyr = y[m], iy[m], iiy[m]
    pr, ipr, iipr = P[:, m], ip[:, m], iip[:, m]
    wp = _prewarp(prior_hz, fs)
    scale = np.array([wp, wp * wp])[:order]

    def parts(p):
        a1, a0 = (p[0], p[1] if order == 2 else 0.0)
        c = yr + a1 * iyr + a0 * iiyr
        A = (pr + a1 * ipr + a0 * iipr).T
        return c, A

    def residual(q):
        c, A = parts(q * scale)
        coef, *_ = np.linalg.lstsq(A, c, rcond=None)
        return c - A @ coef

    prior = HighpassResponse(wp, 0.0)
    starts = [np.array([1.0, 0.0])[:order]] + ([np.array([1.25, 0.25])] if order == 2 else [])
    best = None
    nfev = 0
    for q0 in starts:
        sol = least_squares(residual, q0, bounds=(0.0, np.inf), method="trf", x_scale=1.0,
                            xtol=1e-12, ftol=1e-12, gtol=1e-12)
        nfev += sol.nfev
        if best is None or sol.cost < best.cost:
            best = sol
    a1, a0 = (best.x * scale).tolist() + ([0.0] if order == 1 else [])
    J = best.jac
    cs = np.sqrt(np.sum(J**2, axis=0))
    cs[cs == 0] = 1.0
    cond = float(np.linalg.cond(J / cs))
    rms = float(np.sqrt(np.mean(best.fun**2)))

    def result(resp, ok, msg):
        return ResponseEstimate(resp, resp.cutoff_hz(fs), resp.poles_hz(fs), prior_hz, n_rest, nfev, rms,
                                cond, ok, msg)

    if not best.success:
        return result(prior, False, f"the fit did not converge: {best.message}")
    if not cond < 1e8:
        return result(prior, False, f"the rests do not determine the response (condition number {cond:.3g}): "
                                    "the rest after the lift-off is missing or too short, or the record "
                                    "carries no load")
    resp = HighpassResponse(float(a1), float(a0))
    fc = resp.cutoff_hz(fs)
    if not 0 < fc < 0.25 * fs:
        return result(prior, False, f"the fitted cut-off {fc:g} Hz is implausible")
    return result(resp, True, "ok")
