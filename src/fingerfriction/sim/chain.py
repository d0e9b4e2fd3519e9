"""The measurement chain between a world's forces and the recorded files
(``SimOptions.chain``).

``'ideal'`` (the historical chain, :class:`~fingerfriction.sim.sensor.SensorParams`): a
first-order 5 Hz high-pass and a straight-line drift, which the analysis inverts
exactly (it is told the cut-off), and a normal force that ignores the relief.

``'realistic'`` (:class:`RealisticChain`): one the analysis does not invert exactly.

* **The participant** (:func:`couple_normal_force`): a person holding 0.3 N through a
  compliant arm and finger (vertical stiffness ``coupling_n_per_mm``) with a force-control
  loop of finite bandwidth (an integral controller, ``control_hz``). As the finger rides
  over relief its support rises by ``z(t)`` (the pressure-weighted height of the ground
  under it), and the normal force changes by ``k z`` high-passed at the loop's bandwidth:
  fast feature transits show in ``F_N`` (about +-30 mN on the 4 mm features at the
  paper's speeds), slow ones are corrected. Motor noise grows with speed
  (signal-dependent noise): the normal-force and speed wander scale as ``(v / 80
  mm/s)^motor_noise_exponent``.
* **The sensor** (:func:`apply_chain_sensor` via :func:`fingerfriction.sim.sensor.
  apply_sensor`): each transducer's transverse sensitivity mixes 2-5 % of the other
  channel into it (a device property, drawn per study, random signs); the charge
  amplifier and the transducer's own discharge make the high-pass second order (two real
  poles, the faster drawn per study so that the -3 dB cut-off lies in 3-8 Hz, the slower
  a fraction ``pole_ratio`` of it), with a small per-trial, per-channel spread
  (temperature); the drift adds, to the straight line of the ideal chain, a thermal
  settling ``A (1 - exp(-t / tau))`` and a smooth random wander.
* **The tray** (:func:`tray_response`): the tray and its transducers are a mass on
  springs, so the device's response is flat only well below their resonance ("a nearly
  flat frequency response from 15 to 500 Hz", Methods): a second-order resonance per
  axis (normal, tangential), drawn per study above 1.5 kHz, applied to the forces on
  the plate before the transducers.

The analysis is told none of this. Draws: the device (cut-off, pole ratio, crosstalk)
from the study seed alone (:func:`draw_device`), the rest from the trial's own ``chain``
and ``participant`` streams, so the kinematics, sensor noise and camera draws are those
of the ideal chain.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import asdict, dataclass, replace

import numpy as np
from scipy.signal import butter, lfilter

from .contact import ContactTable
from .kinematics import Kinematics, KinematicsParams, smooth_noise
from .sensor import highpass2, tray_response

__all__ = [
    "CHAIN_NAMES",
    "RealisticChain",
    "ChainDraws",
    "draw_device",
    "draw_trial_chain",
    "couple_normal_force",
    "speed_scaled_kinematics",
    "highpass2",
    "cutoff_of_poles",
    "poles_of_cutoff",
    "tray_response",
]

#: The chains ``SimOptions.chain`` accepts.
CHAIN_NAMES = ("ideal", "realistic")


def _range(name: str, v, lo: float = 0.0) -> tuple[float, float]:
    try:
        a, b = (float(u) for u in v)
    except (TypeError, ValueError):
        raise ValueError(f"RealisticChain.{name} must be a (low, high) pair, got {v!r}") from None
    if not (math.isfinite(a) and math.isfinite(b) and lo <= a <= b):
        raise ValueError(f"RealisticChain.{name} must be a finite range with {lo:g} <= low <= high, "
                         f"got {v!r}")
    return a, b


@dataclass(frozen=True)
class RealisticChain:
    """Parameters of the realistic measurement chain (see the module docstring).

    Parameters
    ----------
    coupling_n_per_mm : float
        Vertical stiffness in N/mm through which a rise of the finger's support changes
        the normal force (default 0.05: about +-30 mN on the 4 mm features at 120 mm/s).
    coupling_sd : float
        Log-SD of the trial's stiffness (default 0.2).
    control_hz : float
        Bandwidth in Hz of the participant's force control (default 3).
    motor_noise_exponent : float
        The normal-force and speed wander scale as ``(v / 80 mm/s)^exponent`` (default 1:
        signal-dependent motor noise, its SD proportional to the movement commanded).
    cutoff_hz : (float, float)
        Range of the study's -3 dB high-pass cut-off in Hz (default 3-8).
    pole_ratio : (float, float)
        Range of the slower pole's frequency as a fraction of the faster one (default
        0.1-0.5).
    cutoff_jitter : float
        Relative SD of each channel's poles per trial (default 0.03).
    crosstalk : (float, float)
        Range of the magnitude of each channel's pickup of the other (default 0.02-0.05;
        signs random).
    crosstalk_calibration : float or None
        The lab's calibration of the crosstalk: the acquisition applies the inverse of the
        crosstalk matrix as the lab measured it, each off-diagonal term with this relative
        error (default 0.1: 0.2-0.5 % of crosstalk reaches the files). None: the channels
        are recorded uncalibrated (the flat-ground F_T / F_N then differs from mu by a few
        per cent, a bias no analysis can remove).
    drift_settle_n_per_s : float
        SD in N/s of the initial rate ``A / tau`` of the thermal settling ``A (1 -
        exp(-t / tau))`` per channel (default 0.002, half the ideal chain's linear drift
        rate SD).
    drift_settle_s : (float, float)
        Range of its time constant in s (default 2-20: the electronics' thermal time
        constants; within a 1 s record the settling bends the drift line by up to about
        0.5 mN).
    drift_wander_n : float
        SD in N of the low-frequency (1/f-like) wander per channel (default 3e-5: the
        white noise's density, 7 uN/sqrt(Hz), with a 10 Hz flicker corner).
    drift_wander_hz : float
        Its bandwidth in Hz (default 1).
    tray_hz : (float, float)
        Range in Hz of the tray's resonance on each axis, drawn per study (default
        1500-3000: within +1 dB of flat up to 500 Hz, "a nearly flat frequency response
        from 15 to 500 Hz").
    tray_q : (float, float)
        Range of its quality factor (default 2-8: aluminium on quartz transducers, damped
        by the finger resting on the plate).
    """

    coupling_n_per_mm: float = 0.05
    coupling_sd: float = 0.2
    control_hz: float = 3.0
    motor_noise_exponent: float = 1.0
    cutoff_hz: tuple = (3.0, 8.0)
    pole_ratio: tuple = (0.1, 0.5)
    cutoff_jitter: float = 0.03
    crosstalk: tuple = (0.02, 0.05)
    crosstalk_calibration: float | None = 0.1
    drift_settle_n_per_s: float = 0.002
    drift_settle_s: tuple = (2.0, 20.0)
    drift_wander_n: float = 3e-5
    drift_wander_hz: float = 1.0
    tray_hz: tuple = (1500.0, 3000.0)
    tray_q: tuple = (2.0, 8.0)

    def __post_init__(self) -> None:
        for k in ("coupling_n_per_mm", "coupling_sd", "control_hz", "motor_noise_exponent", "cutoff_jitter",
                  "drift_settle_n_per_s", "drift_wander_n", "drift_wander_hz"):
            v = getattr(self, k)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise ValueError(f"RealisticChain.{k} must be a finite number >= 0, got {v!r}")
        cal = self.crosstalk_calibration
        if cal is not None and (isinstance(cal, bool) or not isinstance(cal, (int, float))
                                or not math.isfinite(cal) or not 0 <= cal <= 1):
            raise ValueError("RealisticChain.crosstalk_calibration must be None or a relative error in "
                             f"[0, 1], got {cal!r}")
        if self.control_hz <= 0 or self.drift_wander_hz <= 0:
            raise ValueError("RealisticChain.control_hz and drift_wander_hz must be > 0 (Hz)")
        cut = _range("cutoff_hz", self.cutoff_hz)
        if cut[0] <= 0 or cut[1] >= 100:
            raise ValueError(f"RealisticChain.cutoff_hz must lie in (0, 100) Hz, got {self.cutoff_hz!r}")
        ratio = _range("pole_ratio", self.pole_ratio)
        if ratio[1] > 1:
            raise ValueError(f"RealisticChain.pole_ratio must lie in [0, 1], got {self.pole_ratio!r}")
        xt = _range("crosstalk", self.crosstalk)
        if xt[1] > 0.2:
            raise ValueError(f"RealisticChain.crosstalk must be at most 0.2, got {self.crosstalk!r}")
        tray = _range("tray_hz", self.tray_hz)
        if tray[0] <= 500 or tray[1] >= 4000:
            raise ValueError(f"RealisticChain.tray_hz must lie in (500, 4000) Hz (above the 500 Hz the "
                             f"device is flat to, below the 5 kHz Nyquist), got {self.tray_hz!r}")
        tq = _range("tray_q", self.tray_q)
        if tq[0] < 0.5:
            raise ValueError(f"RealisticChain.tray_q must be >= 0.5, got {self.tray_q!r}")
        settle = _range("drift_settle_s", self.drift_settle_s)
        if settle[0] <= 0:
            raise ValueError(f"RealisticChain.drift_settle_s must be positive times in s, "
                             f"got {self.drift_settle_s!r}")
        for k, v in (("cutoff_hz", cut), ("pole_ratio", ratio), ("crosstalk", xt),
                     ("drift_settle_s", settle), ("tray_hz", tray), ("tray_q", tq)):
            object.__setattr__(self, k, v)

    def to_dict(self) -> dict:
        d = asdict(self)
        for k in ("cutoff_hz", "pole_ratio", "crosstalk", "drift_settle_s", "tray_hz", "tray_q"):
            d[k] = list(d[k])
        return d

    @classmethod
    def from_dict(cls, d: dict) -> RealisticChain:
        return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in dict(d).items()})


def poles_of_cutoff(cutoff_hz: float, ratio: float) -> tuple[float, float]:
    """Poles ``(f1, r f1)`` in Hz of two cascaded first-order high-passes whose -3 dB point
    is ``cutoff_hz``: ``(1 + u)(1 + r^2 u) = 2`` with ``u = (f1 / fc)^2``."""
    r2 = float(ratio) ** 2
    if r2 == 0:
        return float(cutoff_hz), 0.0
    u = (-(1 + r2) + math.sqrt((1 + r2) ** 2 + 4 * r2)) / (2 * r2)
    f1 = cutoff_hz * math.sqrt(u)
    return f1, ratio * f1


def cutoff_of_poles(poles) -> float:
    """-3 dB frequency in Hz of cascaded first-order high-passes with these poles (Hz)."""
    p = np.asarray([float(f) for f in poles if f > 0])
    lo, hi = 0.0, float(p.max()) * 2 + 1.0
    for _ in range(80):  # |H|^2 = prod f^2 / (f^2 + p^2) rises with f: bisection
        f = 0.5 * (lo + hi)
        if np.prod(f * f / (f * f + p * p)) < 0.5:
            lo = f
        else:
            hi = f
    return 0.5 * (lo + hi)


def draw_device(seed: int, chain: RealisticChain) -> dict:
    """The study's sensor device: cut-off, poles and crosstalk, from the study seed alone.

    Returns
    -------
    dict
        ``cutoff_hz``, ``pole_ratio``, ``poles_hz`` ([f1, f2]), ``crosstalk`` (2 x 2
        matrix ``M``: the transducers' outputs are ``M @ (F1, F2)``, ones on the diagonal)
        and, with ``crosstalk_calibration``, ``calibration`` (the lab's measurement of
        ``M``; the files hold its inverse applied to the digitised channels), ``tray_hz``
        and ``tray_q`` (the tray's resonance on the normal and tangential axes, Hz and
        quality factor).
    """
    rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(zlib.crc32(b"sensor-device"),)))
    fc = float(rng.uniform(*chain.cutoff_hz))
    r = float(rng.uniform(*chain.pole_ratio))
    mags = rng.uniform(*chain.crosstalk, size=2)
    signs = np.where(rng.random(2) < 0.5, -1.0, 1.0)
    c12, c21 = (mags * signs).tolist()
    # drawn whatever the option, so that the other draws do not depend on it
    err = np.clip(rng.standard_normal(2), -3.0, 3.0)
    out = {"cutoff_hz": fc, "pole_ratio": r, "poles_hz": list(poles_of_cutoff(fc, r)),
           "crosstalk": [[1.0, c12], [c21, 1.0]]}
    if chain.crosstalk_calibration is not None:
        k = chain.crosstalk_calibration
        out["calibration"] = [[1.0, c12 * (1 + k * err[0])], [c21 * (1 + k * err[1]), 1.0]]
    # drawn after the others, so that they are those of a chain without the tray
    out["tray_hz"] = rng.uniform(*chain.tray_hz, size=2).tolist()
    out["tray_q"] = rng.uniform(*chain.tray_q, size=2).tolist()
    return out


@dataclass(frozen=True)
class ChainDraws:
    """One trial's realised sensor chain.

    Attributes
    ----------
    poles_hz : (2, 2) ndarray
        Per channel (F1, F2) the two high-pass poles in Hz.
    crosstalk : (2, 2) ndarray
        ``M``: the transducers' outputs are ``M @ (F1, F2)``.
    drift : (2, n) ndarray
        The drift added to each channel beyond the ideal chain's straight line, N.
    calibration : (2, 2) ndarray or None
        The lab's measurement of ``M``: the files hold its inverse applied to the
        digitised channels (None: uncalibrated).
    tray : (2, 2) ndarray or None
        Rows (normal, tangential): the tray's resonance in Hz and its quality factor
        (:func:`tray_response`; None: a rigid tray).
    """

    poles_hz: np.ndarray
    crosstalk: np.ndarray
    drift: np.ndarray
    calibration: np.ndarray | None = None
    tray: np.ndarray | None = None

    def truth(self, fs: float) -> dict:
        cal = {} if self.calibration is None else {"sensor_calibration": self.calibration}
        if self.tray is not None:
            cal["sensor_tray"] = self.tray
        return {**cal, "sensor_poles_hz": self.poles_hz, "sensor_crosstalk": self.crosstalk,
                "sensor_cutoff_hz": np.array([cutoff_of_poles(p) for p in self.poles_hz]),
                "sensor_extra_drift": self.drift.astype(np.float32)}


def draw_trial_chain(rng: np.random.Generator, n: int, fs: float, chain: RealisticChain,
                     device: dict) -> ChainDraws:
    """Draw a trial's chain: per-channel pole jitter and the drift beyond a straight line."""
    base = np.asarray(device["poles_hz"], float)
    poles = np.stack([base * (1.0 + chain.cutoff_jitter * float(np.clip(rng.standard_normal(), -3, 3)))
                      for _ in range(2)])
    t = np.arange(n) / fs
    drift = np.empty((2, n))
    for c in range(2):
        tau = rng.uniform(*chain.drift_settle_s)
        a = chain.drift_settle_n_per_s * tau * rng.standard_normal()
        w = smooth_noise(rng, n, fs, chain.drift_wander_hz) if n > 1 else np.zeros(n)
        drift[c] = a * (1.0 - np.exp(-t / tau)) + chain.drift_wander_n * w
    cal = device.get("calibration")
    tray = np.column_stack([device["tray_hz"], device["tray_q"]]) if "tray_hz" in device else None
    return ChainDraws(poles, np.asarray(device["crosstalk"], float), drift,
                      None if cal is None else np.asarray(cal, float), tray)


def speed_scaled_kinematics(params: KinematicsParams, speed_mm_s: float,
                            chain: RealisticChain) -> KinematicsParams:
    """The kinematics with motor noise grown with speed: the normal-force wander (within
    and between trials) and the relative speed fluctuation times ``(v / 80)^exponent``."""
    k = (float(speed_mm_s) / 80.0) ** chain.motor_noise_exponent
    return replace(params, force_sd=params.force_sd * k, force_sd_trial=params.force_sd_trial * k,
                   speed_sd=params.speed_sd * k)


def couple_normal_force(kin: Kinematics, table: ContactTable, chain: RealisticChain,
                        rng: np.random.Generator) -> tuple[np.ndarray, dict]:
    """The normal force on the plate with the participant's coupling to the relief.

    ``F_N = F_kin + min(F_kin / F_target, 1) HP[k z](t)``: ``z`` the pressure-weighted
    height of the ground under the finger (mm, from the table at ``F_kin``), ``k`` the
    trial's stiffness (``coupling_n_per_mm`` times a log-normal draw), ``HP`` a first-order
    high-pass at ``control_hz`` (the error of an integral force controller).

    Returns
    -------
    f_n : (n,) ndarray
        N.
    truth : dict
        ``F_N_command`` (the kinematics' force), ``z_support_mm``, ``coupling_n_per_mm``.
    """
    f_kin = np.asarray(kin.f_n, float)
    k = chain.coupling_n_per_mm * float(np.exp(chain.coupling_sd * np.clip(rng.standard_normal(), -3, 3)))
    fs = 1.0 / float(kin.t[1] - kin.t[0])
    load = np.maximum(f_kin, 1e-9)
    i_n = table.interp_integrals(kin.x, load)[:, 0]
    i_h = table.interp_extra(kin.x, load)["h"]
    z = np.where(kin.in_contact & (i_n > 0), i_h / np.where(i_n > 0, i_n, 1.0), 0.0)
    b, a = butter(1, chain.control_hz, btype="highpass", fs=fs)
    d = lfilter(b, a, k * z)
    f_target = kin.f_target if math.isfinite(kin.f_target) else float(np.max(f_kin))
    f_n = f_kin + np.clip(f_kin / f_target, 0.0, 1.0) * d
    return f_n, {"F_N_command": f_kin, "z_support_mm": z.astype(np.float32), "coupling_n_per_mm": k}
