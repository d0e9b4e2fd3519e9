"""Channels and units: do the two transducer channels give a finger's forces?

Four figures, read from the forces alone (no clock offset is needed, so a wrong one cannot
hide a wrong channel) and the sliding direction of the video's x(t):

* **the loading angle** (``channel-polarity``, ``channel-gain``): the direction, in the
  (F_N, F_T) plane, of the force while the finger first presses, before it slides. A
  finger pressing down gives +F_N with little F_T (0 deg). With the paper's decomposition
  ``F_N = (F1 + F2) / sqrt 2``, ``F_T = (F1 - F2) / sqrt 2`` (Fig. 1C of Janko et al.
  2018) a negated F2 turns the press into +F_T (+90 deg), a negated F1 into -F_T
  (-90 deg), both negated into -F_N (180 deg), and one channel read k times too large
  tilts it to ``atan((k - 1) / (k + 1))`` (39 deg for k = 10): ``F1 / F2 = tan(45 deg +
  angle)`` while the finger presses without sliding.
* **the F_N level** (``force-level``): the median normal force while the finger presses,
  against a finger's plausible range (0.02-20 N); a level a power of ten away from the
  paper's 0.3 N names the unit or the sensitivity.
* **the sliding sign** (``channel-swap``): friction opposes the finger's motion, so F_T
  (the force on the plate) follows the sliding direction from x(t); swapped channels
  negate F_T and leave F_N.
* **the sliding ratio** (``flat-friction``): the median F_T / F_N while sliding (flat
  ground most of the time: the relief covers a minority of the slide), against a
  physical range of friction coefficients.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.signal import butter, sosfiltfilt

from .flags import Check, SelfCheckParams

__all__ = ["ForceFigures", "force_figures", "check_channels", "TYPICAL_LOAD_N"]

#: The paper's prescribed normal force (0.3 +- 0.05 N), the reference a unit mistake is
#: measured against ("1000x too large").
TYPICAL_LOAD_N = 0.3


class ForceFigures:
    """The figures :func:`check_channels` tests, measured on one trial's forces.

    Attributes
    ----------
    level_n : float
        Median magnitude of the force vector while the finger presses, N (NaN: no press).
    f_n_level_n : float
        Median F_N over the same samples, N (signed).
    loading_angle_deg : float
        Direction of the force while the finger first presses, from +F_N towards +F_T,
        degrees in (-180, 180] (NaN when not measured).
    sliding_ratio : float
        Median F_T / F_N while sliding, signed by the sliding direction (positive: F_T
        follows the motion); NaN when not measured.
    message : str
        Why a figure could not be measured ('' otherwise).
    """

    def __init__(
        self,
        level_n=math.nan,
        f_n_level_n=math.nan,
        loading_angle_deg=math.nan,
        sliding_ratio=math.nan,
        message="",
    ):
        self.level_n = float(level_n)
        self.f_n_level_n = float(f_n_level_n)
        self.loading_angle_deg = float(loading_angle_deg)
        self.sliding_ratio = float(sliding_ratio)
        self.message = message

    def to_dict(self) -> dict:
        def num(v):
            return None if not math.isfinite(v) else round(float(v), 6)

        return {
            "level_n": num(self.level_n),
            "f_n_level_n": num(self.f_n_level_n),
            "loading_angle_deg": num(self.loading_angle_deg),
            "sliding_ratio": num(self.sliding_ratio),
            "message": self.message,
        }


def _smooth(y: np.ndarray, fs: float, cutoff: float = 30.0) -> np.ndarray:
    """Zero-phase 30 Hz low-pass (mains and noise out; a press and a slide stay)."""
    if y.shape[-1] < 30 or cutoff >= fs / 2:
        return y
    sos = butter(2, cutoff, fs=fs, output="sos")
    return sosfiltfilt(sos, y, axis=-1)


def force_figures(f_n, f_t, fs_hz: float, direction: int) -> ForceFigures:
    """Measure the loading angle, the F_N level and the sliding ratio of one trial.

    Parameters
    ----------
    f_n, f_t : (n,) array_like
        Normal and tangential force in N as decomposed from the channels (after the
        sensor's steps, :func:`fingerfriction.forces.sensor_signals`).
    fs_hz : float
        Sampling frequency in Hz.
    direction : {1, -1, 0}
        Sliding direction of the finger from the video (+1: towards +x; 0: unknown).

    Returns
    -------
    ForceFigures

    Notes
    -----
    The press is where the force vector's magnitude exceeds a quarter of its 95th
    percentile; the loading angle is the mean direction over the first samples of the
    press, from 20 % to 50 % of its median magnitude (the finger presses before it slides:
    in the simulated trials F_T starts some 30 ms after F_N); the sliding ratio is the
    median of F_T / F_N over the press from 100 ms after it starts, where F_N is at least
    half its median over the press.
    """
    n = np.asarray(f_n, dtype=np.float64)
    t = np.asarray(f_t, dtype=np.float64)
    ok = np.isfinite(n) & np.isfinite(t)
    if ok.sum() < 50:
        return ForceFigures(message="fewer than 50 finite force samples")
    n = np.where(ok, n, 0.0)
    t = np.where(ok, t, 0.0)
    k0 = max(int(0.02 * fs_hz), 5)
    sm = _smooth(np.vstack([n, t]), fs_hz)
    head = np.median(sm[:, :k0], axis=1, keepdims=True)
    tail = np.median(sm[:, -k0:], axis=1, keepdims=True)
    # the rest is the quieter end: a record that starts before the touch, or one that starts
    # already pressed and ends after the lift-off
    starts_at_rest = float(np.hypot(*head[:, 0])) <= float(np.hypot(*tail[:, 0]))
    sm = sm - (head if starts_at_rest else tail)
    mag = np.hypot(sm[0], sm[1])
    top = float(np.percentile(mag, 95))
    if not top > 0:
        return ForceFigures(message="the forces never depart from their first level")
    pressed = mag > 0.25 * top
    level = float(np.median(mag[pressed]))
    first = int(np.flatnonzero(mag > 0.2 * level)[0])
    reach = np.flatnonzero(mag[first:] > 0.5 * level)
    last = first + (int(reach[0]) if reach.size else 1)
    last = max(last, first + 1)
    angle = math.nan
    message = ""
    if first >= k0:
        vec = sm[:, first:last].mean(axis=1)
        angle = math.degrees(math.atan2(vec[1], vec[0]))
    else:
        message = "the record starts with the finger already pressing: the press is not seen"
    f_n_level = float(np.median(sm[0][pressed]))
    ratio = math.nan
    if direction:
        later = (
            pressed & (np.arange(n.size) >= first + int(0.1 * fs_hz)) & (np.abs(sm[0]) > 0.5 * abs(f_n_level))
        )
        if later.sum() >= max(int(0.02 * fs_hz), 5):
            ratio = float(direction * np.median(sm[1][later] / sm[0][later]))
    return ForceFigures(
        level_n=level, f_n_level_n=f_n_level, loading_angle_deg=angle, sliding_ratio=ratio, message=message
    )


def _power_of_ten(level: float) -> int:
    """The power of ten between a level and the typical finger load (1000 for 300 N)."""
    return int(round(math.log10(level / TYPICAL_LOAD_N)))


def _unit_cause(level: float, units: str, too: str) -> tuple[str, str]:
    """(likely cause, manifest field) of a level ``too`` large or small by a power of ten."""
    k = _power_of_ten(level)
    factor = f"{10 ** abs(k):g}x"
    if units in ("V", "mV"):
        return (
            f"forces look {factor} too {too}: the sensitivity (or gain) looks {factor} off",
            "force.sensitivity_n_per_v",
        )
    if too == "large":
        return f"forces look {factor} too large: mN labelled N?", "force.units"
    return f"forces look {factor} too small: volts labelled N, or a scale left out?", "force.units"


def _polarity(a: float, lim: float) -> Check | None:
    """``channel-polarity`` from the loading angle (None: the press is along +F_N)."""
    if abs(a) <= 65.0:
        return None
    if abs(a) > 115.0:
        msg = (
            f"F_N is negative while the finger presses (force direction {a:+.0f} deg from +F_N): "
            "F1 and F2 both look negated"
        )
    elif a > 0:
        msg = (
            f"the finger's press reads as +F_T, not +F_N (force direction {a:+.0f} deg from +F_N, "
            f"expected within +-{lim:g}): F2 looks negated"
        )
    else:
        msg = (
            f"the finger's press reads as -F_T, not +F_N (force direction {a:+.0f} deg from +F_N, "
            f"expected within +-{lim:g}): F1 looks negated"
        )
    return Check("channel-polarity", "error", a, "deg", msg, "force.channels")


def _gain(a: float, lim: float) -> Check:
    """``channel-gain`` from the loading angle: F1 / F2 = tan(45 deg + angle) while pressing."""
    if abs(a) <= lim:
        return Check("channel-gain", "ok", a, "deg", "F1 and F2 agree while the finger presses")
    ratio = math.tan(math.radians(45.0 + a))
    big, small, k = ("F1", "F2", ratio) if ratio > 1 else ("F2", "F1", 1.0 / ratio)
    return Check(
        "channel-gain",
        "error",
        a,
        "deg",
        f"{big} reads {k:.3g}x {small} while the finger presses without sliding (force direction "
        f"{a:+.0f} deg from +F_N, expected within +-{lim:g}): one channel's scale looks off (its "
        "sensitivity or gain)",
        "force.sensitivity_n_per_v",
    )


def _level(level: float, units: str, lo: float, hi: float) -> Check:
    """``force-level``: F_N while the finger presses against a finger's range."""
    text = f"F_N is {level:.4g} N while the finger presses (a finger: {lo:g}-{hi:g} N)"
    if level < 0:
        return Check(
            "force-level",
            "error",
            level,
            "N",
            f"{text}: F_N is negative, F1 and F2 both look negated",
            "force.channels",
        )
    if level > hi or level < lo:
        cause, fld = _unit_cause(level, units, "large" if level > hi else "small")
        return Check("force-level", "error", level, "N", f"{text}: {cause}", fld)
    return Check("force-level", "ok", level, "N", f"F_N {level:.3g} N while the finger presses")


def check_channels(
    fig: ForceFigures, *, units: str = "N", params: SelfCheckParams | None = None
) -> list[Check]:
    """The channel and unit checks on a trial's :class:`ForceFigures`.

    Parameters
    ----------
    fig : ForceFigures
    units : str
        The manifest's ``force.units`` (names the likely cause of a wrong level).
    params : SelfCheckParams, optional

    Returns
    -------
    list of Check
        ``channel-polarity``, ``channel-gain``, ``force-level``, ``channel-swap`` and
        ``flat-friction``, each ``'ok'`` or a finding, in that order; a wiring error stops
        the list (one cause, one line); a check that could not be made is ``info`` with
        the reason.
    """
    P = params or SelfCheckParams()
    lim = P.loading_angle_deg
    a = fig.loading_angle_deg
    if not math.isfinite(fig.level_n):
        return [
            Check(
                "channel-polarity",
                "info",
                math.nan,
                "deg",
                f"not measured: {fig.message or 'no press found in the forces'}",
            )
        ]
    out: list[Check] = []
    if math.isfinite(a):
        bad = _polarity(a, lim)
        if bad is not None:
            return [bad]  # nothing else is read in a wrongly wired record
        out.append(Check("channel-polarity", "ok", a, "deg", f"the press is along +F_N ({a:+.1f} deg)"))
        out.append(_gain(a, lim))
        if out[-1].level == "error":
            return out
    else:
        out.append(Check("channel-polarity", "info", math.nan, "deg", f"not measured: {fig.message}"))
    lo, hi = P.f_n_range_n
    out.append(_level(fig.f_n_level_n, units, lo, hi))
    if out[-1].level == "error":
        return out
    r = fig.sliding_ratio
    if not math.isfinite(r):
        out.append(
            Check(
                "channel-swap",
                "info",
                math.nan,
                "",
                "not measured: no sliding direction from x(t), or no sliding part of the press",
            )
        )
        return out
    rlo, rhi = P.flat_ratio_range
    if r < -rlo:
        out.append(
            Check(
                "channel-swap",
                "error",
                r,
                "",
                f"F_T opposes the sliding direction of x(t) (F_T / F_N = {r:+.3f} while sliding): "
                "F1 and F2 look swapped",
                "force.channels",
            )
        )
        return out
    out.append(
        Check("channel-swap", "ok", r, "", f"F_T follows the sliding direction (F_T / F_N = {r:+.3f})")
    )
    if not rlo <= r <= rhi:
        out.append(
            Check(
                "flat-friction",
                "error",
                r,
                "",
                f"F_T / F_N while sliding is {r:.3g}, outside the physical range of a finger's "
                f"friction [{rlo:g}, {rhi:g}]: check the channels' scales",
                "force.channels",
            )
        )
    else:
        out.append(Check("flat-friction", "ok", r, "", f"F_T / F_N while sliding {r:.3f}"))
    return out
