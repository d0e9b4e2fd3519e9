"""Fitting the friction model of Janko, Wiertlewski & Visell 2018 to trials.

Variants of Eq. (4) (:mod:`fingerfriction.model`), one object each in the registry of
:mod:`fingerfriction.fit.variants` (:data:`MODELS`):

``'load'``: the load-consistent Eq. (4)
    The pressure at each position carries the measured normal force; ``mu`` per subject
    from flat-ground Coulomb friction with a bootstrap confidence interval, the
    load-bearing inset of the contact regions per subject, ``p1`` per trial with a
    standard error, on the absolute forces (:mod:`fingerfriction.fit.load`).
``'pressure'``: Eq. (4) as printed on the absolute footing
    One constant pressure per trial, from the flat ground's load; ``mu`` from flat ground
    as above; ``p1`` per trial (:mod:`fingerfriction.fit.pressure`).
``'interlock'``: the load-consistent Eq. (4), slope push weighed by slope direction
    ``push_up`` on ascending slopes and ``push_down`` on descending ones, per trial, in
    place of Eq. (3)'s deformation term (:func:`fit_load_trials` with ``law='push'``).
``'paper'``: Eq. (4) as printed
    Constant ``p0`` and ``p1`` per trial, ``mu`` per subject by grid search, on the paper's
    flat-segment footing (:mod:`fingerfriction.fit.paper`). Kept to reproduce the paper's
    procedure; its ``mu`` is not identifiable from forces alone and its fits can turn
    unphysical, which :func:`paper_flags` reports; never chosen by ``--model auto``.

:mod:`fingerfriction.fit.select` chooses the variant the data support out of sample, or
rejects every one. All return per-trial results with ``measured``/``estimate`` series (for
Table 1, :mod:`fingerfriction.model.stats`) and :class:`FitFlag` objects for everything
unphysical or doubtful; nothing here reads or writes files.
"""

from .common import FitFlag, Trial, flat_detrend, flat_segment_mask, median_filter, nmse, nmse_eq5
from .load import LoadFitOptions, LoadSubjectFit, LoadTrialFit, fit_load_subject, fit_load_trials
from .mu import FlatGroundMu, flat_ground_mu
from .paper import FitOptions, SubjectFit, TrialFit, fit_subject, fit_trial, fit_trials, mu_grid, paper_flags
from .pressure import fit_pressure_subject, fit_pressure_trials
from .variants import MODELS, SELECTABLE, FitSettings, get

__all__ = [
    "MODELS",
    "nmse",
    "nmse_eq5",
    "Trial",
    "FitFlag",
    "flat_segment_mask",
    "flat_detrend",
    "median_filter",
    "FitOptions",
    "TrialFit",
    "SubjectFit",
    "fit_trial",
    "fit_subject",
    "fit_trials",
    "mu_grid",
    "paper_flags",
    "LoadFitOptions",
    "FlatGroundMu",
    "LoadTrialFit",
    "LoadSubjectFit",
    "flat_ground_mu",
    "fit_load_subject",
    "fit_load_trials",
    "fit_pressure_subject",
    "fit_pressure_trials",
    "FitSettings",
    "SELECTABLE",
    "get",
]
