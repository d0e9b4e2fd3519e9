"""The true physics of the virtual experiment: pluggable *worlds* (``SimOptions.world``).

A world is the law that turns a trial's motion (finger position, normal force, distance
slid, on the 10 kHz force clock) and the finger's contact with the surface (a
:class:`~fingerfriction.sim.contact.ContactTable`, from any contact provider) into the
true tangential force on the plate and its interfacial and deformation parts. The
friction model fitted by ``fingerfriction fit`` was built on the paper's Eq. (4); a
virtual experiment that obeys only that model's assumptions cannot test it, so the
simulator offers several worlds, each physically motivated and documented, with its
equations and the paper's statements it is meant to reproduce, in ``docs/worlds.md``:

* ``load-sharing`` (:class:`LoadSharing`): the law of :mod:`~fingerfriction.sim.physics`
  (the simulated pressure carries the measured normal force; Coulomb friction on it, and
  a slope-weighted deformation term);
* ``constant-pressure`` (:class:`ConstantPressure`): the paper's Eq. (4) taken literally on
  the geometric (70 um) contact regions, a constant ``p0`` per trial carrying the
  flat-ground load and a ``p1`` scattered between trials;
* ``interlocking`` (:class:`Interlocking`): Coulomb friction on the simulated pressure plus
  an asymmetric, speed-dependent deformation (hysteresis) force: the finger's leading side
  pushes against rising ground, and its viscoelastic tissue gives little back on falling
  ground; variability is produced at the contact, per trial and within the trial.

Every world returns, besides the forces, the trial's realised parameters (``truth``: at
least ``mu_trial``, the friction coefficient on flat ground at the trial's target load),
written to ``truth/<trial>.npz``. Random draws come from the generator the simulator
passes in (the trial's own ``world`` stream), so a world never changes the draws of the
kinematics, the sensor or the camera.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import numpy as np

from .._check import in_range
from .contact import ContactTable
from .kinematics import min_jerk, smooth_noise
from .physics import SUBJECT_FORCE_LAWS, RealismParams, true_forces

__all__ = [
    "WORLD_NAMES",
    "DEFAULT_WORLD",
    "TrialMotion",
    "WorldForces",
    "LoadSharing",
    "ConstantPressure",
    "Interlocking",
    "get_world",
]

#: The worlds :func:`get_world` knows, in the order the documentation presents them.
WORLD_NAMES = ("load-sharing", "constant-pressure", "interlocking")
#: The world of ``SimOptions()`` (see ``docs/worlds.md``, "The default world").
DEFAULT_WORLD = "load-sharing"

#: Distance in mm over which sliding friction builds up as the finger starts to move
#: (``g(d) = minjerk(d / START_MM)``, shared by every world: at rest there is none).
START_MM = 0.1


@dataclass(frozen=True)
class TrialMotion:
    """What a world needs of a trial, on the force clock (``n`` samples).

    Attributes
    ----------
    t : (n,) ndarray
        Time in s.
    x : (n,) ndarray
        Finger centre in mm.
    f_n : (n,) ndarray
        True normal force on the plate in N.
    sliding_distance : (n,) ndarray
        Distance slid since the slide started, mm (0 before).
    in_contact : (n,) bool ndarray
    mean_speed : float
        The trial's drawn mean sliding speed in mm/s.
    f_target : float
        The trial's target normal force in N (the participant's intended load).
    t_slide_start : float
        Time in s at which the slide starts.
    """

    t: np.ndarray
    x: np.ndarray
    f_n: np.ndarray
    sliding_distance: np.ndarray
    in_contact: np.ndarray
    mean_speed: float
    f_target: float
    t_slide_start: float


@dataclass(frozen=True)
class WorldForces:
    """A world's forces for one trial.

    Attributes
    ----------
    f_t, f_int, f_def : (n,) ndarray
        True tangential force on the plate in N (``f_int + f_def``) and its interfacial
        and deformation parts, as the world defines them (``docs/worlds.md``).
    truth : dict
        The trial's realised parameters (name -> float or array), written to the trial's
        truth file; always holds ``mu_trial``.
    """

    f_t: np.ndarray
    f_int: np.ndarray
    f_def: np.ndarray
    truth: dict


def _check_fields(obj, ranges: dict) -> None:
    """Every field of a world's parameters through :func:`fingerfriction._check.in_range`:
    ``ranges`` maps a field to ``(lo, hi, open_lo)`` (``None``: no bound)."""
    name = type(obj).__name__
    for f in fields(obj):
        lo, hi, open_lo = ranges.get(f.name, (None, None, False))
        v = getattr(obj, f.name)
        if isinstance(v, str):  # the field stays as given: text would reach the arithmetic
            raise ValueError(f"{name}.{f.name} must be a number, got {v!r}")
        in_range(f"{name}.{f.name}", v, lo, hi, open_lo=open_lo)


def _start(motion: TrialMotion) -> np.ndarray:
    """``g(d)``: 0 while the finger rests, 1 once it has slid :data:`START_MM`."""
    return min_jerk(np.asarray(motion.sliding_distance) / START_MM)


def _mu(subject: str) -> float:
    try:
        return SUBJECT_FORCE_LAWS[str(subject)].mu
    except KeyError:
        raise ValueError(f"unknown subject {subject!r}; simulated subjects: "
                         f"{', '.join(SUBJECT_FORCE_LAWS)}") from None


def _lognormal(rng: np.random.Generator, sd: float) -> float:
    """A factor with median 1 and log-SD ``sd`` (clipped at 3 SD)."""
    return float(np.exp(sd * np.clip(rng.standard_normal(), -3.0, 3.0)))


# ---------------------------------------------------------------------------------------
# load-sharing


@dataclass(frozen=True)
class LoadSharing:
    """Today's law (:func:`~fingerfriction.sim.physics.true_forces`, parameters per subject
    in :data:`~fingerfriction.sim.physics.SUBJECT_FORCE_LAWS`): the simulated pressure is
    scaled to carry the normal force, Coulomb friction acts on it (Eq. 2 with the
    simulated pressure for ``p0``), and a deformation term weights it by the slope (Eq. 3),
    with a mild speed dependence and a start transient. No parameters of its own."""

    name = "load-sharing"

    def to_dict(self) -> dict:
        return {"name": self.name, "params": {},
                "subjects": {s: law.to_dict() for s, law in SUBJECT_FORCE_LAWS.items()}}

    def trial_forces(self, table: ContactTable, motion: TrialMotion, subject: str,
                     rng: np.random.Generator, *, mu_scale: float = 1.0, load_exponent: float = 0.0,
                     f_ref_n: float = RealismParams.f_ref_n, law=None) -> WorldForces:
        """The trial's forces (see :class:`ConstantPressure.trial_forces` for the parameters;
        ``law``, a :class:`~fingerfriction.sim.physics.ForceLaw`, overrides the subject's).
        Draws nothing from ``rng``."""
        if law is None:
            _mu(subject)  # a one-line error for an unknown subject
            law = SUBJECT_FORCE_LAWS[str(subject)]
        f_t, f_int, f_def = true_forces(table, law, motion.x, motion.f_n, motion.sliding_distance,
                                        motion.mean_speed, motion.in_contact, mu_scale=mu_scale,
                                        load_exponent=load_exponent, f_ref_n=f_ref_n)
        beta = law.beta0 * (1.0 + law.beta_speed * (motion.mean_speed / law.v_ref - 1.0))
        return WorldForces(f_t, f_int, f_def, {"mu_trial": law.mu * mu_scale, "beta_trial": beta})


# ---------------------------------------------------------------------------------------
# constant-pressure


@dataclass(frozen=True)
class ConstantPressure:
    """The paper's Eq. (4) taken literally, on the geometric contact regions.

    ``F_T = g(d) sum_i int_{C_i} (p0 + p1 dh/dx) (sin a + mu cos a) dx``, with ``C_i`` the
    surface points within 3 camera pixels (70 um) of the deformed finger outline (the
    paper's contact, "Image analysis"), taken over the whole finger whether or not the
    camera sees it; ``p0`` constant in the trial with ``p0 L_flat = F_target`` (``L_flat``
    the geometric contact length on flat ground at the target load); ``p1`` per trial,
    ``p1 (1 + p1_sd z)``; ``mu`` the subject's (times the realism draw). The normal force
    does not enter ``F_T``: the interfacial stress is the membrane's pressure, an
    adhesion-like friction proportional to contact length (``docs/worlds.md``).

    Parameters
    ----------
    p1 : float
        Deformation weight in N/mm (default 0.14: deformation peaks of about 50 mN on the
        paper's raised features with the calibrated fingers, "rising on the order of 50 mN",
        Results).
    p1_sd : float
        Relative standard deviation of ``p1`` between trials (default 0.15).
    """

    p1: float = 0.14
    p1_sd: float = 0.15

    name = "constant-pressure"

    def __post_init__(self) -> None:
        _check_fields(self, {"p1": (0, None, False), "p1_sd": (0, 0.3, False)})

    def to_dict(self) -> dict:
        return {"name": self.name, "params": asdict(self),
                "subjects": {s: {"mu": law.mu} for s, law in SUBJECT_FORCE_LAWS.items()}}

    def trial_forces(self, table: ContactTable, motion: TrialMotion, subject: str,
                     rng: np.random.Generator, *, mu_scale: float = 1.0, load_exponent: float = 0.0,
                     f_ref_n: float = RealismParams.f_ref_n) -> WorldForces:
        """The trial's forces.

        Parameters
        ----------
        table : ContactTable
            With :attr:`~ContactTable.extra` (the geometric-contact integrals).
        motion : TrialMotion
        subject : str
        rng : numpy.random.Generator
            The trial's world stream (one draw: ``p1``'s).
        mu_scale : float
            The trial's friction factor (the realism option's draw; 1 by default).
        load_exponent, f_ref_n : float
            Unused: in this world friction follows contact length, not load (accepted so
            that every world takes the same arguments).

        Returns
        -------
        WorldForces
            ``truth``: ``mu_trial``, ``p0_trial`` and ``p1_trial`` (N/mm).
        """
        mu = _mu(subject) * mu_scale
        p1 = self.p1 * (1.0 + self.p1_sd * float(np.clip(rng.standard_normal(), -3.0, 3.0)))
        f_n = np.asarray(motion.f_n, float)
        g_len0 = table.interp_extra(table.positions[:1], np.array([motion.f_target]))["g_len"][0]
        p0 = motion.f_target / g_len0
        E = table.interp_extra(motion.x, f_n)
        # below the table's lowest load the contact shrinks as a line contact's,
        # half-width ~ sqrt(load) (loading and unloading only)
        shrink = np.sqrt(np.clip(f_n / float(table.loads[0]), 0.0, 1.0)) * motion.in_contact
        g = _start(motion) * shrink
        f_int = g * p0 * (E["g_sin"] + mu * E["g_cos"])
        f_def = g * p1 * (E["g_ssin"] + mu * E["g_scos"])
        return WorldForces(f_int + f_def, f_int, f_def,
                           {"mu_trial": mu, "p0_trial": p0, "p1_trial": p1, "L_flat_mm": g_len0})


# ---------------------------------------------------------------------------------------
# interlocking


@dataclass(frozen=True)
class Interlocking:
    """Coulomb friction on the simulated pressure plus an asymmetric, speed-dependent
    deformation (hysteresis) force.

    With ``q = F_N p / int p dx`` the line load (N/mm) the contact provider's pressure
    carries, ``a = atan(dh/dx)``::

        F_int = g(d) mu_t(d) int q cos a dx
        F_def = g(d) (1 + e(t)) [ (1 + psi_up(v)) int_{s>0} q sin a dx
                                 + r_down(v) int_{s<0} q sin a dx ]

    ``F_int`` is the horizontal part of the interfacial (Coulomb) shear; ``F_def`` the
    horizontal push of the normal stress on sloping ground, which the elastic contact
    gives symmetrically (back on rising ground, forward on falling ground) and the
    finger's viscoelastic tissue makes asymmetric: where the ground rises under it the
    tissue is being compressed and pushes harder (``psi_up``); where it falls the surface
    recedes faster than the relaxed tissue recovers and the skin stays behind, so only a
    small fraction ``r_down`` of the elastic forward push is returned. ``psi_up`` grows
    with the trial's speed ``v`` as ``(v / v_ref)^speed_exponent`` and ``r_down`` falls as
    its inverse (the faster the slide, the less time the skin has to follow); both are
    drawn per trial (log-normal, ``psi_sd``); ``e(t)`` is a smooth random process
    (``fluct_hz``) whose size grows with speed: the interlocking at the leading edge is
    the unsteady part, while the interfacial friction on talc-treated aluminium is steady
    within a trial ("treated with a small amount of talc to reduce stick-slip effects",
    Methods). ``mu_t(d) / mu`` (:meth:`static_peak`) is the static-to-sliding peak of the
    rate-and-state aging law at the trial's speed: static friction grows with the
    contact's age, and the slide erases it over a slip distance (``memory_mm``), not a
    time. ``docs/worlds.md`` gives the paper's statements each term reproduces.

    Parameters
    ----------
    psi_up : float
        Relative increase of the push on rising ground at ``v_ref`` (>= 0).
    down_return : float
        Fraction of the elastic forward push on falling ground returned at ``v_ref``
        (0..1; default 0.02: "negligibly small" deformation forces on the Step Down
        surfaces, Fig. S3; ``docs/worlds.md``).
    speed_exponent : float
        ``psi`` grows as ``(v / v_ref)^speed_exponent``.
    v_ref : float
        Reference speed in mm/s.
    psi_sd : float
        Log-SD of the per-trial factor on ``psi_up`` (its inverse on ``down_return``) (skin hydration,
        finger orientation).
    mu_sd : float
        Relative SD of the trial's friction coefficient (on top of the realism option's).
    fluct_sd : float
        Relative SD, at ``v_ref``, of the within-trial fluctuation of the deformation force;
        grows as ``sqrt(v / v_ref)``.
    fluct_hz : float
        Bandwidth of the within-trial fluctuations in Hz.
    aging : float
        Rate-and-state ``b / mu``: the static friction's relative gain per e-fold of
        ``v theta0 / memory_mm`` (>= 0; 0: no start transient).
    memory_mm : float
        Slip distance in mm over which the slide erases the contact's memory (the
        rate-and-state ``D_c``; > 0).
    """

    psi_up: float = 1.0
    down_return: float = 0.02
    speed_exponent: float = 0.3
    v_ref: float = 80.0
    psi_sd: float = 0.25
    mu_sd: float = 0.03
    fluct_sd: float = 0.15
    fluct_hz: float = 15.0
    aging: float = 0.05
    memory_mm: float = 0.1

    name = "interlocking"

    def __post_init__(self) -> None:
        nonneg, positive = (0, None, False), (0, None, True)
        _check_fields(self, {"psi_up": nonneg, "down_return": (0, 1, False), "speed_exponent": nonneg,
                             "psi_sd": nonneg, "mu_sd": (0, 0.3, False), "fluct_sd": (0, 0.5, False),
                             "aging": nonneg, "v_ref": positive, "fluct_hz": positive,
                             "memory_mm": positive})

    def to_dict(self) -> dict:
        return {"name": self.name, "params": asdict(self),
                "subjects": {s: {"mu": law.mu} for s, law in SUBJECT_FORCE_LAWS.items()}}

    def psi(self, speed_mm_s: float) -> tuple[float, float]:
        """``(psi_up, r_down)`` at a speed in mm/s, before the trial's draw."""
        k = (speed_mm_s / self.v_ref) ** self.speed_exponent
        return self.psi_up * k, min(self.down_return / k, 1.0)

    def static_peak(self, motion: TrialMotion) -> np.ndarray:
        """``mu_t / mu`` along the trial: the rate-and-state aging law at the trial's mean
        speed ``v`` from the contact's age ``theta0`` at the slide's start (the time since
        the first sample in contact),
        ``1 + aging ln(1 + max(C - 1, 0) exp(-d / memory_mm))``, ``C = v theta0 / memory_mm``
        (Dieterich's state ``theta`` at constant slip speed: ``theta0`` decays to the
        steady ``memory_mm / v`` over the slip distance ``memory_mm``)."""
        d = np.asarray(motion.sliding_distance, float)
        touch = np.flatnonzero(np.asarray(motion.in_contact, bool))
        t = np.asarray(motion.t, float)
        age = max(float(motion.t_slide_start) - float(t[touch[0]]), 0.0) if touch.size else 0.0
        c = float(motion.mean_speed) * age / self.memory_mm
        if self.aging == 0 or c <= 1:
            return np.ones_like(d)
        return 1.0 + self.aging * np.log1p((c - 1.0) * np.exp(-np.maximum(d, 0.0) / self.memory_mm))

    def trial_forces(self, table: ContactTable, motion: TrialMotion, subject: str,
                     rng: np.random.Generator, *, mu_scale: float = 1.0, load_exponent: float = 0.0,
                     f_ref_n: float = RealismParams.f_ref_n) -> WorldForces:
        """The trial's forces (parameters as :meth:`ConstantPressure.trial_forces`; the load
        exponent applies to ``mu``: ``mu (F_N / f_ref_n)^-load_exponent``).

        Returns
        -------
        WorldForces
            ``truth``: ``mu_trial``, ``psi_up_trial``, ``down_return_trial``,
            ``static_gain_trial`` (the static friction's gain at the slide's start,
            :meth:`static_peak`).
        """
        v = float(motion.mean_speed)
        mu = _mu(subject) * mu_scale * (1.0 + self.mu_sd * float(np.clip(rng.standard_normal(), -3.0, 3.0)))
        k_trial = _lognormal(rng, self.psi_sd)
        up, down = self.psi(v)
        up, down = up * k_trial, min(down / k_trial, 1.0)
        n = motion.x.size
        amp = self.fluct_sd * math.sqrt(v / self.v_ref)
        e_def = np.zeros(n)
        if n > 1 and amp > 0:  # a smooth fluctuation on the force clock
            fs = 1.0 / float(motion.t[1] - motion.t[0])
            e_def = np.maximum(amp * smooth_noise(rng, n, fs, self.fluct_hz), -0.9)

        f_n = np.asarray(motion.f_n, float)
        I = table.interp_integrals(motion.x, np.maximum(f_n, 1e-9))
        E = table.interp_extra(motion.x, np.maximum(f_n, 1e-9))
        i_n = I[:, 0]
        scale = np.where(motion.in_contact & (i_n > 0), f_n / np.where(i_n > 0, i_n, 1.0), 0.0)
        peak = self.static_peak(motion)
        mu_t = mu * peak
        if load_exponent:
            mu_t = mu_t * (np.maximum(f_n, 1e-6) / f_ref_n) ** (-load_exponent)
        g = _start(motion)
        f_int = g * scale * mu_t * I[:, 2]
        f_def = g * scale * (1.0 + e_def) * ((1.0 + up) * E["sin_up"] + down * E["sin_down"])
        return WorldForces(f_int + f_def, f_int, f_def,
                           {"mu_trial": mu, "psi_up_trial": up, "down_return_trial": down,
                            "static_gain_trial": float(peak.max()) if peak.size else 1.0})


_WORLDS = {"load-sharing": LoadSharing, "constant-pressure": ConstantPressure, "interlocking": Interlocking}


def get_world(name):
    """A world by name (its default parameters), or a world object passed through.

    Raises
    ------
    ValueError
        For an unknown name: one line naming the worlds there are.
    """
    if isinstance(name, (LoadSharing, ConstantPressure, Interlocking)):
        return name
    if not isinstance(name, str) or name not in _WORLDS:
        raise ValueError(f"unknown world {name!r}; worlds: {', '.join(WORLD_NAMES)}")
    return _WORLDS[name]()
