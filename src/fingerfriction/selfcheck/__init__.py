"""The consistency stage between the video and the forces: catch a wrong clock, sampling
rate, channel map, unit, sensitivity or surface before it becomes a number, and measure
the video-force synchronisation from the data (``docs/selfcheck.md``).

Each check is a named :class:`Check` with a level (``error`` fails the trial, ``warning``
keeps it and is reported) and the figure it measured:

=====================  ===========================================================  =======
check                  figure                                                       module
=====================  ===========================================================  =======
``channel-polarity``   direction of the force while the finger presses (deg)        channels
``channel-gain``       the same: one channel's scale off tilts it                   channels
``force-level``        F_N while the finger presses (N)                             channels
``channel-swap``       F_T / F_N while sliding, signed by the motion in x(t)        channels
``flat-friction``      the same, against a physical range                           channels
``rate-mismatch``      the force clock against the mains hum (%)                    clock
``surface-type``       RMS misfit of the manifest's shape to the calibration frame  geometry
``surface-geometry``   width / height of the feature against the manifest's (%)     geometry
``speed``              sliding speed from x(t) against the manifest's (ratio)       geometry
``sync-offset``        video-force offset against the trial's finger's other trials  sync
``sync-common``        the offset all of a finger's trials share                    sync
=====================  ===========================================================  =======

:func:`check_trial` runs every per-trial check; :func:`estimate_offsets` compares the
starts of the slides of a study's trials.
"""

from .channels import ForceFigures, check_channels, force_figures
from .clock import MainsEstimate, check_force_clock, mains_frequency
from .flags import LEVELS, SYNC_MODES, Check, SelfCheckError, SelfCheckParams, describe_checks, first_error
from .geometry import FeatureFit, check_geometry, check_speed, measure_feature, sliding_speed
from .scale import flat_contact_length, scale_checks
from .stage import ORDER, TrialChecks, check_trial
from .sync import OffsetEstimate, OnsetData, estimate_offsets, onset_data

__all__ = [
    "LEVELS",
    "SYNC_MODES",
    "ORDER",
    "Check",
    "SelfCheckError",
    "SelfCheckParams",
    "TrialChecks",
    "check_trial",
    "describe_checks",
    "first_error",
    "ForceFigures",
    "force_figures",
    "check_channels",
    "MainsEstimate",
    "mains_frequency",
    "check_force_clock",
    "FeatureFit",
    "measure_feature",
    "check_geometry",
    "check_speed",
    "sliding_speed",
    "OnsetData",
    "OffsetEstimate",
    "onset_data",
    "estimate_offsets",
    "flat_contact_length",
    "scale_checks",
]
