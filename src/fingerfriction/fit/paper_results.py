"""The paper fit's options and results: :class:`FitOptions`, :class:`TrialFit`, :class:`SubjectFit`
(moved from :mod:`fingerfriction.fit.paper`, which fits them and re-exports them)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from .._check import check_bool, check_option, integer, nonnegative, positive
from ..model import FrictionParams
from .common import check_kernel

__all__ = ["FitOptions", "TrialFit", "SubjectFit"]

OBJECTIVES = ("nmse", "nmse_eq5")
#: What the median filter runs on (``FitOptions.median_on``).
MEDIAN_ON = ("basis", "estimate")


@dataclass(frozen=True)
class FitOptions:
    """How measurement and model are compared (see :mod:`fingerfriction.fit.paper`).

    Parameters
    ----------
    objective : {'nmse', 'nmse_eq5'}
        Conventional NMSE (default) or Eq. (5) as printed.
    median_kernel : int
        Median filter window in samples (odd; 1 = off). Default 11 (0.11 mm on the
        paper's 0.01 mm grid).
    median_on : {'basis', 'estimate'}
        Filter the per-frame integrals (default; keeps the model linear) or the combined
        estimate (the literal reading of Methods; nonlinear).
    flat_margin : float
        Clearance in mm between the flat segment and the feature start (default 0).
    detrend : bool
        Apply the same flat-segment linear detrend to model and measurement (default True:
        the right choice for drift-corrected measurements, see point 1 of
        :mod:`fingerfriction.fit.paper`). False compares absolute forces, for data whose
        flat-ground level is real (no drift correction, e.g. a simulated or DC-coupled
        sensor): the flat level ``p0 mu L`` then pins ``p0`` directly and per-trial
        estimates are several times tighter.
    xatol, fatol : float
        Nelder-Mead tolerances on the *relative* parameters (default 1e-6) and on the
        objective (default 1e-10).
    maxiter : int
        Nelder-Mead iteration limit.
    """

    objective: str = "nmse"
    median_kernel: int = 11
    median_on: str = "basis"
    flat_margin: float = 0.0
    detrend: bool = True
    xatol: float = 1e-6
    fatol: float = 1e-10
    maxiter: int = 2000

    def __post_init__(self) -> None:
        check_option("objective", self.objective, OBJECTIVES)
        check_kernel(self.median_kernel)
        check_option("median_on", self.median_on, MEDIAN_ON)
        object.__setattr__(self, "flat_margin",
                           nonnegative("flat_margin", self.flat_margin, "mm", what="length"))
        for name in ("xatol", "fatol"):
            object.__setattr__(self, name, positive(name, getattr(self, name), "(relative)"))
        object.__setattr__(self, "maxiter", integer("maxiter", self.maxiter, 1, what="iterations"))
        object.__setattr__(self, "detrend", check_bool("detrend", self.detrend))


@dataclass(frozen=True, eq=False)
class TrialFit:
    """Result of fitting ``p0, p1`` to one trial at a given ``mu``.

    Attributes
    ----------
    mu : float
        Friction coefficient used (fixed during the fit).
    p0, p1 : float
        Fitted parameters in N/mm (D absorbed; Eq. 4).
    objective : float
        Value of the objective (``objective_name``) at the solution, on the exact
        compared series (detrended measurement vs detrended, median-filtered model).
    objective_name : str
    method : str
        'lstsq' or 'nelder-mead'.
    success : bool
    message : str
        Why the fit failed, or a short description of what converged.
    n_iter, n_fev : int
        Iterations and objective evaluations (0 for the closed form).
    measured : (n,) ndarray
        Measurement as compared (N): drift-corrected again over the flat segment.
    estimate : (n,) ndarray
        Model as compared (N): Eq. (4), median-filtered, detrended over the flat segment.
    subject : str
    labels : dict
    """

    mu: float
    p0: float
    p1: float
    objective: float
    objective_name: str
    method: str
    success: bool
    message: str
    n_iter: int
    n_fev: int
    measured: np.ndarray
    estimate: np.ndarray
    subject: str = ""
    labels: Mapping[str, str] = field(default_factory=dict)

    @property
    def params(self) -> FrictionParams:
        """The fitted parameters (raises ``ValueError`` if they are unphysical, p0 < 0)."""
        return FrictionParams(mu=self.mu, p0=self.p0, p1=self.p1)

    @property
    def used(self) -> np.ndarray:
        """``(n,)`` bool: the positions compared (where the estimate is defined), as the
        absolute-footing variants' ``used``."""
        return np.isfinite(self.estimate)


@dataclass(frozen=True, eq=False)
class SubjectFit:
    """Result of the per-subject grid search for ``mu``.

    Attributes
    ----------
    subject : str
    mu : float
        Grid value minimising the summed objective.
    grid : (m,) ndarray
        The ``mu`` values tried.
    curve : (m,) ndarray
        Sum over the subject's trials of each trial's minimal objective at each ``mu``.
    trials : tuple of TrialFit
        Per-trial fits at the selected ``mu`` (same order as the input trials).
    success : bool
        False if any trial fit failed or the minimum is at an end of the grid (the true
        optimum may lie outside it).
    message : str
    method : str
    """

    subject: str
    mu: float
    grid: np.ndarray
    curve: np.ndarray
    trials: tuple[TrialFit, ...]
    success: bool
    message: str
    method: str
