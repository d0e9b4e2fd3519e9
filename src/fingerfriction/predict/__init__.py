"""Predict friction on a surface that was never recorded, and render it on a haptic display.

The paper's model, Eq. (4) of Janko, Wiertlewski & Visell 2018, needs the contact regions
``C_i`` of every frame, which the paper measured from video. Here the regions come from
the forward finger-contact model (:mod:`fingerfriction.mechanics`) swept across the
surface (:mod:`.forward`), so a relief that exists only as a spec or a CSV profile gets a
predicted lateral force ``F_T(x)``, its interfacial and deformation parts (Eq. 2 and 3),
the contact occupancy (Fig. 3) and the tactile blind spots (:mod:`.prediction`), with the
documented default parameters of :mod:`.defaults` or fitted ones. :mod:`.render` turns a
prediction into a lookup table for a haptic display. The out-of-sample validation of a
fitted study (leave one surface out) is a stage of the study:
:mod:`fingerfriction.pipeline.validation`. Why the geometric contact and how
the defaults are anchored: ``docs/predict.md``.
"""

from __future__ import annotations

from .defaults import PAPER_FORCE_RISE_N, PAPER_MU, default_load_params, default_params, load_params
from .forward import (
    DEFAULT_LOAD_N,
    GEOM_TOL_MM,
    MAX_SLOPE_ANGLE,
    ProfileTooSteepError,
    check_profile,
    flat_contact_length,
    forward_regions,
    sweep_window,
)
from .prediction import Prediction, known_surface_names, predict, predict_from_regions

__all__ = [
    "GEOM_TOL_MM",
    "DEFAULT_LOAD_N",
    "PAPER_MU",
    "PAPER_FORCE_RISE_N",
    "MAX_SLOPE_ANGLE",
    "ProfileTooSteepError",
    "check_profile",
    "sweep_window",
    "default_params",
    "default_load_params",
    "flat_contact_length",
    "forward_regions",
    "load_params",
    "Prediction",
    "predict",
    "predict_from_regions",
    "known_surface_names",
]
