"""The load-consistent fit's options and results: :class:`LoadFitOptions`, :class:`LoadTrialFit`,
:class:`LoadSubjectFit` (moved from :mod:`fingerfriction.fit.load`, which fits them and re-exports them)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._check import check_bool, check_option, integer, nonnegative, positive
from .common import check_kernel
from .mu import FlatGroundMu

__all__ = ["LoadFitOptions", "LoadTrialFit", "LoadSubjectFit"]

MU_PER = ("subject", "trial")


@dataclass(frozen=True)
class LoadFitOptions:
    """How the load-consistent model is fitted (see the notes of :mod:`fingerfriction.fit.load`).

    Parameters
    ----------
    median_kernel : int
        Median filter window, in positions, on the per-position integrals ``S, K, Q``
        (odd; 1 = off; default 11 as the paper variant).
    inset : 'fit' or float
        Inset in mm of the geometric regions giving the load-bearing contact: fitted per
        subject (default), or fixed (0 = the geometric regions as they are).
    inset_max : float
        Upper bound in mm of the fitted inset (default 1 mm).
    kappa : 'fit' or float
        Rise of a region's pressure with its mean height, in 1/mm: fitted per subject
        (default), or fixed (0 = one uniform pressure over the whole contact, the paper's).
    kappa_max : float
        Upper bound in 1/mm of the fitted rise (default 8: a region 0.125 mm higher than
        another carries e times its pressure).
    transient : bool
        Model a static-to-sliding transient in the flat-ground ratio (default True).
    transient_max_mm : float
        Upper bound in mm of the transient's decay length (default 3 mm).
    mu_per : {'trial', 'subject'}
        The ``mu`` each trial's model uses: the trial's own flat-ground value (default; the
        subject's where the trial has too little flat ground) or the subject's, as the
        paper. Friction varies from trial to trial (skin hydration): with a per-trial
        scatter of ``mu`` the subject's ``mu`` pushes each trial's friction error into the
        contact search, which then collapses, and many trials get ``p1 < 0``; without
        scatter the two agree (``docs/fit.md``).
    n_boot : int
        Bootstrap resamples of the confidence interval of ``mu`` (default 2000).
    seed : int
        Seed of the bootstrap's ``numpy.random.Generator``.
    level : float
        Confidence level (default 0.95).
    nominal_load : float
        Normal force in N used for trials without absolute forces (default 0.3 N, the
        paper's prescribed load).
    min_load : float
        Positions where the measured ``F_N`` is below this (N) are left out (finger
        lifting or not yet loaded; default 0.05 N); 0 keeps every position.
    min_flat_mm : float
        Least flat-ground travel in mm for a trial's own ``mu`` (default 1 mm).
    hac_mm : float
        Bandwidth in mm of the Newey-West standard error of ``p1`` (default 1 mm).
    search_trials : int
        At most this many of a subject's trials, spread evenly over its surfaces, are used
        to find its load-bearing contact (default 36: 6 per surface of the paper's design;
        the two parameters are the finger's, so more trials change them little while the
        search's cost grows with them; ``docs/fit.md``).
    """

    median_kernel: int = 11
    inset: float | str = "fit"
    inset_max: float = 1.0
    kappa: float | str = "fit"
    kappa_max: float = 8.0
    transient: bool = True
    transient_max_mm: float = 3.0
    mu_per: str = "trial"
    n_boot: int = 2000
    seed: int = 0
    level: float = 0.95
    nominal_load: float = 0.3
    min_load: float = 0.05
    min_flat_mm: float = 1.0
    hac_mm: float = 1.0
    search_trials: int = 36

    def __post_init__(self) -> None:
        check_kernel(self.median_kernel)
        for name, what in (("inset", "a length >= 0 in mm"), ("kappa", "a rate >= 0 in 1/mm")):
            v = getattr(self, name)
            if isinstance(v, str):
                if v != "fit":
                    raise ValueError(f"{name} must be 'fit' or {what}, got {v!r}")
            elif isinstance(v, bool) or not (isinstance(v, (int, float)) and math.isfinite(v) and v >= 0):
                raise ValueError(f"{name} must be 'fit' or {what}, got {v!r}")
        for name, unit in (("inset_max", "mm"), ("kappa_max", "1/mm"), ("transient_max_mm", "mm"),
                           ("nominal_load", "N"), ("min_flat_mm", "mm"), ("hac_mm", "mm")):
            object.__setattr__(self, name, positive(name, getattr(self, name), unit))
        object.__setattr__(self, "min_load", nonnegative("min_load", self.min_load, "N", what="force"))
        check_option("mu_per", self.mu_per, MU_PER)
        object.__setattr__(self, "n_boot", integer("n_boot", self.n_boot, 100))
        if not (isinstance(self.level, float) and 0.5 < self.level < 1):
            raise ValueError(f"level must be a confidence level in (0.5, 1), got {self.level!r}")
        object.__setattr__(self, "search_trials", integer("search_trials", self.search_trials, 1))
        object.__setattr__(self, "transient", check_bool("transient", self.transient))


@dataclass(frozen=True, eq=False)
class LoadTrialFit:
    """Result of fitting ``p1`` of the load-consistent Eq. (4) to one trial.

    Attributes
    ----------
    mu : float
        Friction coefficient used (fixed during the fit).
    p1, p1_se : float
        Deformation weight in N/mm and its standard error (Newey-West).
    inset : float
        Inset in mm of the load-bearing contact.
    kappa : float
        Rise of a region's pressure with its height, 1/mm.
    p0_mean : float
        The trial's pressure in N/mm, ``sum F_N / sum (K - mu S)`` over the compared
        positions (the counterpart of the paper's constant ``p0``).
    mu_flat : float
        The trial's own flat-ground ``mu`` (NaN when it has too little flat ground).
    objective : float
        Conventional NMSE of the compared series.
    objective_name, method : str
        ``'nmse'`` and ``'lstsq'``.
    success : bool
        False for a fit that must not be used (unphysical ``p1 < 0``, nothing to compare).
    message : str
    footing : {'absolute', 'flat'}
        The footing of the compared series: absolute forces, or the paper's flat-segment
        footing for a trial without absolute forces.
    used : (n,) bool ndarray
        Positions compared (load-bearing contact and ``F_N >= min_load``).
    measured, estimate : (n,) ndarray
        Measured ``F_T`` and the model, in N, on ``footing`` (NaN where not ``used``).
    interfacial, deformation, pressure : (n,) ndarray
        ``F_int`` (Eq. 2) and ``F_def`` (Eq. 3) in N and ``p0(x)`` in N/mm.
    subject : str
    labels : dict
    flags : tuple of FitFlag
    push_up, push_up_se, push_down, push_down_se : float
        With the interfacial slope push weighed by slope direction (the ``'interlock'``
        variant): the dimensionless weights on ascending and descending slopes
        (:class:`~fingerfriction.model.LoadParams`) and their standard errors (NaN
        otherwise, and where the trial's contact never meets such a slope).
    """

    mu: float
    p1: float
    p1_se: float
    inset: float
    kappa: float
    p0_mean: float
    mu_flat: float
    objective: float
    success: bool
    message: str
    footing: str
    used: np.ndarray
    measured: np.ndarray
    estimate: np.ndarray
    interfacial: np.ndarray
    deformation: np.ndarray
    pressure: np.ndarray
    subject: str = ""
    labels: dict = field(default_factory=dict)
    flags: tuple = ()
    objective_name: str = "nmse"
    method: str = "lstsq"
    push_up: float = math.nan
    push_up_se: float = math.nan
    push_down: float = math.nan
    push_down_se: float = math.nan

    def compared(self) -> tuple[np.ndarray, np.ndarray]:
        """``(measured, estimate)`` over the compared positions, in N (for Table 1)."""
        return self.measured[self.used], self.estimate[self.used]


@dataclass(frozen=True, eq=False)
class LoadSubjectFit:
    """Result of the load-consistent fit of one subject.

    Attributes
    ----------
    subject : str
    mu : float
        Flat-ground ``mu`` (see ``flat``).
    flat : FlatGroundMu or None
        How ``mu`` was measured (None when no trial has absolute forces).
    inset : float
        Load-bearing inset in mm (fitted or given).
    kappa : float
        Rise of a region's pressure with its height in 1/mm (fitted or given).
    fitted : tuple of str
        Which of ``'inset'`` and ``'kappa'`` were fitted.
    trials : tuple of LoadTrialFit
        In the order of the input trials.
    flags : tuple of FitFlag
        Subject-level and trial-level flags.
    success : bool
        False when ``mu`` could not be measured or a trial fit failed.
    message : str
    model : str
        ``'load'``, or ``'interlock'`` for the slope push weighed by slope direction.
    """

    subject: str
    mu: float
    flat: FlatGroundMu | None
    inset: float
    kappa: float
    fitted: tuple
    trials: tuple
    flags: tuple
    success: bool
    message: str
    model: str = "load"

    @property
    def mu_ci(self) -> tuple[float, float]:
        """Confidence interval of ``mu`` (NaN when unavailable)."""
        return self.flat.ci if self.flat is not None else (math.nan, math.nan)
