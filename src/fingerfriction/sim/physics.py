"""The true force law of the virtual experiment (ground truth, richer than Eq. 4).

For a finger at position ``x_c`` pressing with normal force ``F_N`` the contact table gives
the pressure ``p(x)`` (N/mm^2) over the surface. It is rescaled to the line load
``q(x) = F_N p(x) / int p dx`` (N/mm, so ``int q dx = F_N``) and the tangential force on the
plate is::

    F_T     = g(d) (F_T_int + F_T_def)
    F_T_int = int q (sin a + mu_eff(d) cos a) dx                       (interfacial)
    F_T_def = beta(v) int q s (sin a + mu_eff(d) cos a) dx             (deformation)

with ``a = atan(dh/dx)``, ``s = dh/dx``, ``d`` the distance slid since the slide started
and ``g(d) = minjerk(d / 0.1 mm)`` the build-up of friction as the finger starts to move
(0 while the finger rests, 1 after 0.1 mm):

* the interfacial part is the paper's Eq. (2) projection with the *simulated* pressure
  distribution ``q(x)`` instead of a constant ``p0`` over the contact regions (as in
  Eq. 2, ``q`` is used as the stress normal to the surface and integrated over ``dx``);
* the deformation (ploughing / hysteresis) part is proportional to the local slope and
  the local pressure (Eq. 3 weighted by ``q`` rather than a constant ``p1``), with a mild
  speed dependence ``beta(v) = beta0 (1 + beta_speed (v / v_ref - 1))``, ``v`` the trial's
  mean sliding speed (viscoelastic
  hysteresis grows with speed; the paper saw at most a small effect);
* ``mu_eff(d) = mu (1 + transient exp(-d / transient_mm))``: an initial static-to-sliding
  peak that decays with the distance ``d`` slid since the slide started (Discussion:
  "static to sliding contact transitions");
* per subject ``mu`` = 0.55 and 0.60 (the paper's estimates);
* with :class:`RealismParams` (``SimOptions.realism``, off by default): a friction
  coefficient drawn per trial around the subject's, a mild fall of friction with load,
  and a normal force wandering over the paper's full +-50 mN.

``int p w dx`` for the weights ``1, sin a, cos a, s sin a, s cos a`` are tabulated with the
contact table, so the law costs a bilinear interpolation per force sample.

Because the truth integrates ``q(x)`` (non-uniform, zero at contact edges) and adds the
speed and transient terms, Eq. (4) fitted on the contact regions is an approximation of
it, not a restatement: fits recover ``mu`` and the force pattern, not exact parameters.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from .._check import in_range, nonnegative, positive, validate_type
from .contact import ContactTable
from .kinematics import min_jerk

__all__ = ["ForceLaw", "SUBJECT_FORCE_LAWS", "RealismParams", "true_forces"]


@dataclass(frozen=True)
class ForceLaw:
    """Parameters of the true force law (see the module docstring).

    Parameters
    ----------
    mu : float
        Coefficient of friction (dimensionless, 0..5).
    beta0 : float
        Weight of the deformation term at ``v_ref`` (dimensionless, >= 0).
    beta_speed : float
        Relative change of beta per unit of ``v / v_ref - 1``.
    v_ref : float
        Reference speed in mm/s.
    transient : float
        Relative height of the initial static-to-sliding friction peak (>= 0; 0 disables).
    transient_mm : float
        Decay distance of the peak in mm (> 0).
    """

    mu: float = 0.55
    beta0: float = 0.5
    beta_speed: float = 0.08
    v_ref: float = 80.0
    transient: float = 0.35
    transient_mm: float = 0.6

    def __post_init__(self) -> None:
        own = "ForceLaw"
        for k, v in asdict(self).items():
            validate_type(f"{own}.{k}", v, (int, float), "a number")
        in_range(f"{own}.mu", self.mu, 0.0, 5.0, what="friction coefficient")
        in_range(f"{own}.beta0", self.beta0, 0.0, what="weight")
        in_range(f"{own}.beta_speed", self.beta_speed)
        positive(f"{own}.v_ref", self.v_ref, "mm/s", what="speed")
        in_range(f"{own}.transient", self.transient, 0.0, unit="(relative)", what="peak height")
        positive(f"{own}.transient_mm", self.transient_mm, "mm", what="length")

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass(frozen=True)
class RealismParams:
    """A harder virtual experiment (``SimOptions.realism``; off in the default study).

    Parameters
    ----------
    mu_sd : float
        Relative standard deviation of each trial's friction coefficient around the
        subject's (default 0.10: trial-to-trial changes such as skin hydration). The
        trial's coefficient is ``mu (1 + mu_sd z)``, ``z`` standard normal clipped to +-3.
    mu_load_exponent : float
        Friction falls with load as ``mu (F_N / f_ref_n)^-n`` (default 0.2: 15 % more
        friction when the load halves, 13 % less when it doubles, inside the paper's
        "less than 20 % change if the force is doubled or halved", Discussion).
    f_ref_n : float
        Load in N at which the trial's coefficient applies (default 0.3 N, the prescribed
        force).
    force_sd_trial, force_sd : float
        Standard deviations in N of the trial's normal-force target and of its wander
        within the trial (default 0.025 N each), so that the normal force wanders over the
        paper's full +-50 mN (the kinematics' soft limit), instead of the default
        0.012 N each.
    """

    mu_sd: float = 0.10
    mu_load_exponent: float = 0.2
    f_ref_n: float = 0.3
    force_sd_trial: float = 0.025
    force_sd: float = 0.025

    def __post_init__(self) -> None:
        own = "RealismParams"
        for k, v in asdict(self).items():
            validate_type(f"{own}.{k}", v, (int, float), "a number")
        in_range(f"{own}.mu_sd", self.mu_sd, 0.0, unit="(relative)", what="standard deviation")
        in_range(f"{own}.mu_sd", self.mu_sd, hi=0.3, unit="(relative)")
        in_range(f"{own}.mu_load_exponent", self.mu_load_exponent, 0.0, what="load exponent")
        positive(f"{own}.f_ref_n", self.f_ref_n, "N", what="force")
        for k in ("force_sd_trial", "force_sd"):
            nonnegative(f"{own}.{k}", getattr(self, k), "N", what="standard deviation")

    def to_dict(self) -> dict:
        return asdict(self)

    def trial_mu_scale(self, rng: np.random.Generator) -> float:
        """The trial's friction factor ``1 + mu_sd z`` (one draw from ``rng``)."""
        z = float(np.clip(rng.standard_normal(), -3.0, 3.0))
        return 1.0 + self.mu_sd * z


SUBJECT_FORCE_LAWS: dict[str, ForceLaw] = {
    "1": ForceLaw(mu=0.55, beta0=0.5),
    "2": ForceLaw(mu=0.60, beta0=0.6),
}


def true_forces(table: ContactTable, law: ForceLaw, x_c: np.ndarray, f_n: np.ndarray,
                sliding_distance: np.ndarray, speed_mm_s: float, in_contact: np.ndarray, *,
                mu_scale: float = 1.0, load_exponent: float = 0.0, f_ref_n: float = RealismParams.f_ref_n):
    """True tangential force of a trial on the force clock.

    Parameters
    ----------
    table : ContactTable
    law : ForceLaw
    x_c, f_n, sliding_distance : (n,) ndarray
        Finger centre (mm), normal force (N), distance slid (mm) per sample.
    speed_mm_s : float
        The trial's mean speed in mm/s (for ``beta(v)``).
    in_contact : (n,) bool ndarray
    mu_scale : float
        The trial's friction factor (:class:`RealismParams`; 1 by default).
    load_exponent, f_ref_n : float
        Load dependence of friction, ``mu (F_N / f_ref_n)^-load_exponent`` (0: none).

    Returns
    -------
    f_t, f_t_int, f_t_def : (n,) ndarray
        Tangential force on the plate in N and its interfacial and deformation parts.
    """
    I = table.interp_integrals(x_c, np.maximum(f_n, 1e-9))
    i_n, i_sin, i_cos, i_ssin, i_scos = I.T
    scale = np.where(in_contact & (i_n > 0), f_n / np.where(i_n > 0, i_n, 1.0), 0.0)
    mu = law.mu * mu_scale * (1.0 + law.transient * np.exp(-np.asarray(sliding_distance) / law.transient_mm))
    if load_exponent:
        mu = mu * (np.maximum(f_n, 1e-6) / f_ref_n) ** (-load_exponent)
    beta = law.beta0 * (1.0 + law.beta_speed * (speed_mm_s / law.v_ref - 1.0))
    f_int = scale * (i_sin + mu * i_cos)
    f_def = scale * beta * (i_ssin + mu * i_scos)
    # before the slide starts the finger rests: no tangential force (g = 0)
    g = min_jerk(np.asarray(sliding_distance) / 0.1)
    f_int = g * f_int
    f_def = g * f_def
    return f_int + f_def, f_int, f_def
