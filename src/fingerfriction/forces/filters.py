"""Zero-phase filters of the force stage: mains notches and the low-pass (Methods "Force
data processing").

Design apart from application, as :func:`scipy.signal.iirnotch` beside
:func:`scipy.signal.sosfiltfilt`: :func:`design_notch` and :func:`design_lowpass` return
second-order sections; :func:`notch_filter` and :func:`lowpass_filter` apply them forwards
and backwards.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from scipy import signal

from .._check import check_freq as _check_freq
from .._check import check_fs as _check_fs
from .._check import positive as _positive
from .params import MAINS_HZ, ForceProcessingParams

#: The force stage's default options: their values are the filters' defaults.
_OPTS = ForceProcessingParams()

__all__ = ["design_notch", "design_lowpass", "notch_filter", "lowpass_filter", "zero_phase"]


def design_notch(fs: float, freqs: Sequence[float] = MAINS_HZ, q: float = _OPTS.notch_q) -> np.ndarray:
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


def design_lowpass(fs: float, cutoff: float = _OPTS.lowpass_hz,
                   order: int = _OPTS.lowpass_order) -> np.ndarray:
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
    x, fs: float, freqs: Sequence[float] = MAINS_HZ, *, q: float = _OPTS.notch_q, axis: int = -1
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


def lowpass_filter(x, fs: float, cutoff: float = _OPTS.lowpass_hz, *, order: int = _OPTS.lowpass_order,
                   axis: int = -1) -> np.ndarray:
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


#: Public name of the zero-phase application of second-order sections.
zero_phase = _zero_phase
