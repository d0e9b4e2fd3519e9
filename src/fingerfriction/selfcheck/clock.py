"""The force clock against the mains: a sampling rate read from the data.

Force recordings pick up the mains (the paper notches 50, 150 and 300 Hz; the simulated
sensor adds them). The grid's frequency is held within about 0.1 % of its nominal 50 or
60 Hz, so the hum's frequency measured on the record's own time axis says how far the
``fs_hz`` the manifest gives is from the rate the samples were taken at: a record
labelled 10 kHz that was sampled at 10.1 kHz shows its hum at 50.5 Hz.

The frequency is the maximum of the periodogram of both channels summed over the hum's
harmonics, refined to a fraction of its resolution (:func:`mains_frequency`); its standard
error follows the Cramer-Rao bound of a sinusoid in noise (Rife & Boorstyn 1974).

References
----------
.. [1] D. C. Rife and R. R. Boorstyn, "Single-tone parameter estimation from discrete-time
   observations", IEEE Trans. Inf. Theory 20(5), 591-598 (1974).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import butter, sosfiltfilt, zoom_fft

from .flags import Check, SelfCheckParams

_DEFAULTS = SelfCheckParams()  # the nominal mains frequencies' one definition: SelfCheckParams.mains_hz

__all__ = ["MainsEstimate", "mains_frequency", "check_force_clock"]

#: Smallest ratio of the hum's periodogram peak to the band's median for it to count as a
#: mains line (below it the record has no clear hum and its clock is not measured).
MIN_CONTRAST = 5.0


@dataclass(frozen=True)
class MainsEstimate:
    """The mains hum found in a force record.

    Attributes
    ----------
    nominal_hz : float
        The nominal mains frequency it belongs to (50 or 60 Hz); NaN when no hum was found.
    frequency_hz : float
        Its frequency on the record's time axis (``fs_hz`` as given), Hz.
    se_hz : float
        Standard error of ``frequency_hz``, Hz.
    amplitude_n : float
        Amplitude of the hum in N (both channels' root mean square).
    contrast : float
        Periodogram peak over the band's median.
    message : str
        Why no hum was found ('' otherwise).
    """

    nominal_hz: float
    frequency_hz: float = math.nan
    se_hz: float = math.nan
    amplitude_n: float = math.nan
    contrast: float = math.nan
    message: str = ""

    @property
    def found(self) -> bool:
        return math.isfinite(self.nominal_hz)

    @property
    def rate_ratio(self) -> float:
        """``frequency_hz / nominal_hz``: the true sampling rate is ``fs_hz / rate_ratio``."""
        return self.frequency_hz / self.nominal_hz

    @property
    def rate_ratio_se(self) -> float:
        return self.se_hz / self.nominal_hz


def _dtft_power(y: np.ndarray, freqs: np.ndarray, fs: float) -> np.ndarray:
    """``sum over channels |Y(f)|^2`` of ``y`` (channels, n) at the uniformly spaced ``freqs``
    (a zoom FFT: the chirp z-transform, O(n log n))."""
    f1, f2 = float(freqs[0]), float(freqs[-1])
    if freqs.size == 1:
        t = np.arange(y.shape[1]) / fs
        return np.array([float(np.sum(np.abs(y @ np.exp(-2j * np.pi * f1 * t)) ** 2))])
    z = zoom_fft(y, [f1, f2 + (f2 - f1) / (freqs.size - 1)], m=freqs.size, fs=fs, endpoint=False, axis=-1)
    return np.sum(np.abs(z) ** 2, axis=0)


def mains_frequency(
    f1, f2, fs_hz: float, *, nominal_hz=_DEFAULTS.mains_hz, search: float = 0.05, harmonics=(1, 2, 3, 4, 5, 6)
) -> MainsEstimate:
    """The mains hum's frequency on a force record's time axis.

    Parameters
    ----------
    f1, f2 : (n,) array_like
        The two channels (any unit; NaN treated as 0).
    fs_hz : float
        The sampling rate the record is labelled with, Hz.
    nominal_hz : sequence of float
        Nominal mains frequencies looked for, Hz (default
        :attr:`SelfCheckParams.mains_hz <fingerfriction.selfcheck.flags.SelfCheckParams>`:
        50 and 60 Hz).
    search : float
        Relative half-width of the search around each nominal frequency (0.05: a record
        labelled up to 5 % off is still read).
    harmonics : sequence of int
        Harmonics of the mains used together (the friction force itself has much of its
        power near 50 Hz when the finger slides fast; the hum's harmonics stand out above
        it, and each pins the frequency ``k`` times more finely).

    Returns
    -------
    MainsEstimate

    Notes
    -----
    The channels are high-passed at 0.7 times the lowest nominal frequency (zero phase);
    the periodogram of each harmonic ``k`` over ``k f`` is divided by its median over the
    search band (noise and friction), and the sum over harmonics is maximised over
    ``f``. A harmonic's peak-to-median ratio ``c_k`` (times ln 2: the median of a noise
    periodogram is ln 2 times its mean) is its signal-to-noise ratio ``A^2 N / (4
    sigma^2)``, so the Cramer-Rao bound of a sinusoid gives ``var f = 3 / ((2 pi T)^2
    sum_k k^2 (c_k - 1))`` over a record of ``T`` s.
    """
    fs = float(fs_hz)
    y = np.vstack([np.asarray(f1, float), np.asarray(f2, float)])
    y = np.where(np.isfinite(y), y, 0.0)
    n = y.shape[1]
    ks = [int(k) for k in harmonics if max(nominal_hz) * (1 + search) * int(k) < 0.45 * fs]
    if n < 10 * fs / min(nominal_hz) or not ks:
        return MainsEstimate(
            math.nan,
            message=f"the record ({n} samples at {fs:g} Hz) is too short or too "
            "slowly sampled to measure the mains",
        )
    sos = butter(4, 0.7 * min(nominal_hz), btype="highpass", fs=fs, output="sos")
    y = sosfiltfilt(sos, y - y.mean(axis=1, keepdims=True), axis=1)
    duration = n / fs
    best = None
    for f0 in nominal_hz:
        grid = f0 * (1 + np.linspace(-search, search, 401))
        medians = {}
        total = np.zeros(grid.size)
        for k in ks:
            p = _dtft_power(y, k * grid, fs)
            medians[k] = float(np.median(p))
            total += p / medians[k]
        j = int(np.argmax(total))
        contrast = float(total[j] / np.median(total))
        if best is None or contrast > best[0]:
            best = (contrast, f0, grid, j, medians, total)
        if contrast >= 4 * MIN_CONTRAST:
            break  # a clear hum: the other nominal frequency need not be searched
    contrast, f0, grid, j, medians, total = best
    if contrast < MIN_CONTRAST:
        return MainsEstimate(
            math.nan,
            contrast=contrast,
            message=f"no mains hum near {', '.join(f'{v:g}' for v in nominal_hz)} Hz "
            f"(periodogram contrast {contrast:.1f} < {MIN_CONTRAST:g})",
        )
    f = float(grid[j])
    if 0 < j < grid.size - 1:  # the parabola through the peak and its neighbours
        y0, y1, y2 = total[j - 1 : j + 2]
        den = y0 - 2 * y1 + y2
        if den < 0:
            f += 0.5 * (y0 - y2) / den * float(grid[1] - grid[0])
    info = 0.0
    amp2 = 0.0
    for k in ks:
        c = float(_dtft_power(y, np.array([k * f]), fs)[0]) / medians[k] * math.log(2.0)
        info += k * k * max(c - 1.0, 0.0)
        if k == 1:
            amp2 = 4.0 * float(_dtft_power(y, np.array([f]), fs)[0]) / (2 * n * n)
    se = math.sqrt(3.0 / ((2 * math.pi * duration) ** 2 * info)) if info > 0 else math.inf
    return MainsEstimate(f0, f, se, math.sqrt(amp2), contrast)


def check_force_clock(est: MainsEstimate, fs_hz: float, *, params: SelfCheckParams | None = None) -> Check:
    """``rate-mismatch``: the force clock against the mains.

    Fires (an error) when the hum is off its nominal frequency by more than
    ``params.rate_tolerance`` (relative) and by more than 3 standard errors; ``info``
    when the record has no measurable hum.
    """
    P = params or SelfCheckParams()
    if not est.found:
        return Check("rate-mismatch", "info", math.nan, "%", f"force clock not measured: {est.message}")
    rel = est.rate_ratio - 1.0
    se = est.rate_ratio_se
    true_fs = fs_hz / est.rate_ratio
    text = (
        f"the mains hum is at {est.frequency_hz:.3f} +- {est.se_hz:.3f} Hz on the force clock "
        f"({est.nominal_hz:g} Hz nominal): the force clock is {100 * rel:+.2f} % off"
    )
    if abs(rel) > P.rate_tolerance and abs(rel) > 3 * se:
        return Check(
            "rate-mismatch",
            "error",
            100 * rel,
            "%",
            f"{text}; force.fs_hz looks wrong: {fs_hz:g} Hz given, {true_fs:.6g} Hz by the mains",
            "force.fs_hz",
        )
    return Check("rate-mismatch", "ok", 100 * rel, "%", text)
