"""Options of the per-trial analysis (:class:`AnalysisParams`), the one definition of the
video options the study pipeline uses (:data:`VIDEO_DEFAULTS`, :func:`video_options`:
shared by ``analyze`` and ``forces --from-video``), and the presets for simulated studies.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass, field

from .._check import check_option, validate_type
from ..forces import ForceProcessingParams
from ..selfcheck import SelfCheckParams
from ..video import AnalysisOptions
from ..video.options import POSITIONS

__all__ = [
    "AnalysisParams",
    "VIDEO_DEFAULTS",
    "POSITIONS",
    "video_options",
    "force_params",
    "SIM_PARAMS",
    "SIM_CF_CENTROID_PARAMS",
    "sim_params",
]

#: Video options of the study pipeline that differ from the video stage's own defaults
#: (:class:`fingerfriction.video.AnalysisOptions`); an explicit option overrides them.
#: Used by ``analyze`` and by ``forces --from-video`` alike (:func:`video_options`).
#:
#: * ``position='hybrid'``: x(t) is the chord midpoint where the finger's chord is in
#:   view, else one outline edge 4 mm above the feature top offset-matched per video
#:   (:func:`fingerfriction.video.tracking.hybrid_positions`), with contact regions kept
#:   where C_f is out of view. The paper's centroid of C_f (``position='cf-centroid'``)
#:   is tracked only while C_f is whole inside the crop (with the simulated finger and
#:   camera, over about -5 to +5 mm, far short of the paper's 26 mm window).
#: * ``n_max_regions=16``: frames where the finger enters the view can show more than 8
#:   specks of contact, and the video stage then refuses the whole trial.
#:
#: The measurements behind both are in ``docs/study.md``.
VIDEO_DEFAULTS = {"position": "hybrid", "n_max_regions": 16}



def video_options(opts: Mapping | None = None, calibration_frame: int | None = None) -> AnalysisOptions:
    """The video stage's options for a trial of a study: :data:`VIDEO_DEFAULTS` updated by
    ``opts``, with the manifest's calibration frame unless ``opts`` names one.

    Parameters
    ----------
    opts : dict, optional
        Keyword options of :class:`fingerfriction.video.AnalysisOptions`.
    calibration_frame : int, optional
        The trial's ``video.calibration_frame``.

    Raises
    ------
    ValueError
        An unknown or invalid option.
    """
    kw = {**VIDEO_DEFAULTS, **dict(opts or {})}
    if calibration_frame is not None and "calibration_frame" not in kw:
        kw["calibration_frame"] = int(calibration_frame)
    try:
        return AnalysisOptions(**kw)
    except TypeError as exc:  # unknown keyword
        raise ValueError(f"video option: {exc}") from None


def _video_params(opts: Mapping) -> dict:
    d = dataclasses.asdict(video_options(opts))
    d.pop("calibration_frame", None)  # per trial, from the manifest
    return d


def force_params(opts: Mapping | None = None) -> ForceProcessingParams:
    """:class:`fingerfriction.forces.ForceProcessingParams` from keyword options (ValueError
    for an unknown one)."""
    try:
        return ForceProcessingParams(**dict(opts or {}))
    except TypeError as exc:  # unknown keyword
        raise ValueError(f"force option: {exc}") from None


def _force_params(opts: Mapping) -> dict:
    return force_params(opts).to_dict()


@dataclass(frozen=True)
class AnalysisParams:
    """Options of the per-trial analysis: passed through to the two stages.

    Parameters
    ----------
    video : dict
        Keyword options of the video analysis (:class:`fingerfriction.video.AnalysisOptions`);
        empty means the paper's Methods (3 px contact tolerance, the 0.4 mm line, ...)
        except for :data:`VIDEO_DEFAULTS`: x(t) from the hybrid estimator
        (``position='hybrid'``; ``{'position': 'cf-centroid'}`` gives the paper's centroid
        of C_f).
    forces : dict
        Keyword options of :class:`fingerfriction.forces.ForceProcessingParams`; empty
        means the paper's Methods (notches at 50/150/300 Hz, 500 Hz low-pass, a 26 mm
        window on a 0.01 mm grid).
    selfcheck : dict
        Keyword options of :class:`fingerfriction.selfcheck.SelfCheckParams`, the
        consistency stage between the video and the forces: ``{'sync': 'auto'}`` uses the
        measured video-force offset (``analyze --sync``); empty means ``sync='check'`` and
        the documented thresholds.

    Notes
    -----
    :meth:`resolved` expands both into the stages' full parameter sets (defaults
    included); that is what the run record stores and what decides whether a finished
    trial was computed with the same parameters.
    """

    video: Mapping = field(default_factory=dict)
    forces: Mapping = field(default_factory=dict)
    selfcheck: Mapping = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("video", "forces", "selfcheck"):
            object.__setattr__(self, name, dict(validate_type(f"AnalysisParams.{name}", getattr(self, name),
                                                              Mapping, "a dict of options")))

    def resolved(self) -> dict:
        """``{'video': {...}, 'forces': {...}, 'selfcheck': {...}}`` with every stage parameter
        spelled out.

        Raises
        ------
        ValueError
            An unknown or invalid option (from the stage's own validation).
        """
        return {"video": _video_params(self.video), "forces": _force_params(self.forces),
                "selfcheck": self.selfcheck_params().to_dict()}

    def selfcheck_params(self) -> SelfCheckParams:
        """The consistency stage's :class:`~fingerfriction.selfcheck.SelfCheckParams`."""
        return SelfCheckParams.from_mapping(self.selfcheck)



#: Analysis options for simulated studies (the demo, the tests, the benchmark): none
#: beyond the pipeline's defaults (with the hybrid x(t) of :data:`VIDEO_DEFAULTS`, every
#: simulated trial is analysed over the paper's 26 mm window, without x(t) extrapolation
#: or translated regions; ``docs/study.md``).
SIM_PARAMS: dict = {"video": {}, "forces": {}}

#: Documented fallback for ``position='cf-centroid'`` (the paper's x(t)) on simulated
#: studies, where C_f is tracked only over about -5 to +5 mm (the calibrated simulated
#: finger is wide for the simulated camera's 29.4 mm field of view): a 22 mm window, x(t)
#: extended at constant speed by up to 8 mm beyond the tracked frames (flagged per trial;
#: regions outside the tracked span are translated with the finger, see
#: :func:`fingerfriction.regions.regions_on_grid`), and ``contact_half_width_mm=6.5`` (the
#: simulated contact reaches at most 5.9 mm from the finger centre on flat ground) so the
#: 4 mm surfaces keep a 2.5 mm flat segment for the drift fit. Less accurate than the
#: hybrid (``docs/study.md``); kept to reproduce the paper's estimator.
SIM_CF_CENTROID_PARAMS = {"video": {"position": "cf-centroid"},
                          "forces": {"window_mm": 22.0, "extrapolate_mm": 8.0, "contact_half_width_mm": 6.5}}


def sim_params(position: str = "hybrid") -> dict:
    """Analysis options (``{'video': ..., 'forces': ...}``) for a simulated study.

    Parameters
    ----------
    position : {'hybrid', 'cf-centroid', 'chord'}
        The x(t) estimator; 'cf-centroid' gets :data:`SIM_CF_CENTROID_PARAMS`.

    Raises
    ------
    ValueError
        An unknown estimator.
    """
    check_option("position", position, POSITIONS)
    base = SIM_CF_CENTROID_PARAMS if position == "cf-centroid" else SIM_PARAMS
    out = {k: dict(v) for k, v in base.items()}
    out["video"]["position"] = position
    return out
