"""The consistency stage of one trial: every check that needs only the trial itself.

:func:`check_trial` runs, in order, the channel and unit checks
(:mod:`.channels`), the force clock against the mains (:mod:`.clock`), the surface
against the calibration frame and the sliding speed (:mod:`.geometry`), and extracts the
start of the slide the synchronisation compares across trials (:mod:`.sync`). It needs
no clock offset: a wrong ``t0_s`` cannot hide a wrong channel. The synchronisation
itself compares trials with each other, so it runs once all of a study's trials are in
(:func:`~fingerfriction.selfcheck.sync.estimate_offsets`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np

from ..forces.readers import ForceRecord
from ..forces.signals import ForceSignals
from ..surfaces import Surface
from .channels import check_channels, force_figures
from .clock import check_force_clock, mains_frequency
from .flags import Check, SelfCheckParams, first_error
from .geometry import check_geometry, check_speed, measure_feature, sliding_speed
from .scale import flat_contact_length
from .sync import OnsetData, onset_data
from .touchdown import touch_force, touch_video

__all__ = ["TrialChecks", "check_trial", "ORDER"]

#: The order in which an error becomes a trial's one-line reason: the force file's
#: channels and units first (they make every later figure meaningless), then its clock,
#: then the surface.
ORDER = (
    "channel-polarity",
    "channel-gain",
    "force-level",
    "channel-swap",
    "flat-friction",
    "rate-mismatch",
    "surface-type",
    "surface-geometry",
    "speed",
)


@dataclass(frozen=True)
class TrialChecks:
    """What the consistency stage found in one trial.

    Attributes
    ----------
    checks : tuple of Check
        Every check, in :data:`ORDER`.
    onset : OnsetData or None
        The start of the slide for the synchronisation (None: not seen, ``onset_message``
        says why).
    onset_message : str
    record : ForceRecord
        The force record to process: the manifest's, or with ``sync='auto'`` its
        sampling rate corrected by the mains.
    figures : dict
        The measured figures (JSON-serialisable).
    elapsed_s : float
        Time the checks took, s.
    cpu_s : float
        CPU time the checks took in this process, s.
    sensor : object or None
        The force signals the checks used, for the force stage to reuse
        (:class:`fingerfriction.forces.SensorSignals`; None when the record changed).
    """

    checks: tuple
    onset: OnsetData | None
    onset_message: str
    record: ForceRecord
    figures: dict = field(default_factory=dict)
    elapsed_s: float = 0.0
    cpu_s: float = 0.0
    sensor: object | None = field(default=None, repr=False, compare=False)

    @property
    def error(self) -> Check | None:
        return first_error(self.checks)

    @property
    def warnings(self) -> list[Check]:
        return [c for c in self.checks if c.level == "warning"]

    def reason(self) -> str:
        """The trial's one-line reason: the first error, and how many more there are."""
        errors = [c for c in self.checks if c.level == "error"]
        if not errors:
            return ""
        more = f" (and {', '.join(c.code for c in errors[1:])})" if len(errors) > 1 else ""
        return errors[0].line() + more

    def to_dict(self) -> dict:
        return {
            "checks": [c.to_dict() for c in self.checks],
            "figures": self.figures,
            "onset": None if self.onset is None else self.onset.to_dict(),
            "onset_message": self.onset_message,
            "elapsed_s": round(self.elapsed_s, 4),
            "cpu_s": round(self.cpu_s, 4),
        }


def _with_touch(onset: OnsetData, t_frames, gap_mm, record: ForceRecord, mains, fs_manifest: float,
                figures: dict) -> OnsetData:
    """``onset`` with the touch-down in both recordings (:mod:`.touchdown`); what each found
    goes to ``figures['touch']``."""
    tv = touch_video(t_frames, gap_mm) if gap_mm is not None else None
    # the hum on the record's clock (the manifest's, or the mains-corrected one of --sync auto)
    hum = mains.frequency_hz * record.fs_hz / fs_manifest if mains.found else math.nan
    tf = touch_force(record.f1, record.f2, record.fs_hz, record.t0_s, mains_hz=hum)
    figures["touch"] = {
        "video": "not measured: the video stage gave no gap" if tv is None else tv.message,
        "force": tf.message,
    }
    if tv is None or not tv.measured:
        return replace(onset, touch_force_s=tf.t_s, touch_force_se_s=tf.se_s)
    return replace(onset, touch_video_s=tv.t_s, touch_video_se_s=tv.se_s, touch_force_s=tf.t_s,
                   touch_force_se_s=tf.se_s)


def _direction(x_frames) -> int:
    x = np.asarray(x_frames, float)
    x = x[np.isfinite(x)]
    if x.size < 2 or abs(x[-1] - x[0]) < 1.0:
        return 0
    return 1 if x[-1] > x[0] else -1


def check_trial(
    *,
    trial_id: str,
    group: str,
    record: ForceRecord,
    signals: ForceSignals,
    t_frames,
    x_frames,
    gap_mm=None,
    regions=None,
    surface_rows=None,
    surface: Surface | None = None,
    height_mm: float = math.nan,
    speed_mm_s: float | None = None,
    params: SelfCheckParams | None = None,
) -> TrialChecks:
    """Run the consistency checks of one trial.

    Parameters
    ----------
    trial_id, group : str
        The trial and its finger (subject), for the synchronisation.
    record : ForceRecord
        The force record as the manifest describes it.
    signals : ForceSignals
        Its forces after the sensor's steps (:func:`fingerfriction.forces.sensor_signals`).
    t_frames, x_frames : (n_frames,) array_like
        Frame times (s, the manifest's video clock) and x(t) (mm, NaN unknown).
    gap_mm : (n_frames,) array_like, optional
        The finger's lowest point above the surface per frame (mm, NaN unknown), for the
        touch-down (:mod:`.touchdown`).
    regions : (n_frames, k, 2) array_like, optional
        The video's contact regions per frame (mm), for the contact length on flat ground
        the force's scale is compared with across a finger's trials (:mod:`.scale`).
    surface_rows : (width,) array_like, optional
        The calibration frame's surface profile in rows
        (:attr:`fingerfriction.video.calibrate.Calibration.surface_row`).
    surface : Surface, optional
        The manifest's surface.
    height_mm : float
        The feature height that calibrated the image scale, mm.
    speed_mm_s : float, optional
        The manifest's nominal sliding speed.
    params : SelfCheckParams, optional

    Returns
    -------
    TrialChecks
    """
    P = params or SelfCheckParams()
    t_start, c_start = time.perf_counter(), time.process_time()
    fs_manifest = record.fs_hz
    figures: dict = {}
    direction = _direction(x_frames)
    fig = force_figures(signals.f_n, signals.f_t, signals.fs_hz, direction)
    figures["forces"] = fig.to_dict()
    checks = check_channels(fig, units=record.units, params=P)
    mains = mains_frequency(record.f1, record.f2, record.fs_hz, nominal_hz=P.mains_hz)
    figures["mains"] = {
        "nominal_hz": None if not mains.found else mains.nominal_hz,
        "frequency_hz": None if not mains.found else round(mains.frequency_hz, 6),
        "se_hz": None if not mains.found else round(mains.se_hz, 6),
        "message": mains.message,
    }
    clock = check_force_clock(mains, record.fs_hz, params=P)
    if P.sync == "auto" and clock.level == "error":
        fs_true = record.fs_hz / mains.rate_ratio
        record = replace(record, fs_hz=fs_true)
        signals = replace(signals, fs_hz=fs_true)
        clock = Check(
            "rate-mismatch",
            "warning",
            clock.figure,
            "%",
            clock.message.split("; force.fs_hz")[0] + f"; --sync auto samples the forces at {fs_true:.6g} Hz",
            "force.fs_hz",
        )
    checks.append(clock)
    if surface is not None and surface_rows is not None:
        try:
            feature = measure_feature(surface_rows, getattr(surface, "shape", None))
        except ValueError as exc:
            feature = None
            figures["feature"] = {"message": str(exc)}
        else:
            figures["feature"] = feature.to_dict()
        checks += check_geometry(feature, surface, height_mm, params=P)
    if regions is not None and surface is not None:
        length = flat_contact_length(x_frames, regions, surface.feature_extent)
        figures["contact_flat_mm"] = None if not math.isfinite(length) else round(length, 4)
    if speed_mm_s:
        v = sliding_speed(t_frames, x_frames)
        figures["speed_mm_s"] = None if not math.isfinite(v) else round(v, 4)
        checks.append(check_speed(v, float(speed_mm_s), params=P))
    rank = {c: i for i, c in enumerate(ORDER)}
    checks.sort(key=lambda c: rank.get(c.code, len(ORDER)))
    onset, onset_message = None, ""
    if P.sync != "manifest":
        got = onset_data(
            trial_id, group, t_frames, x_frames, signals.f_n, signals.f_t, signals.fs_hz, signals.t0_s
        )
        if isinstance(got, str):
            onset_message = got
        else:
            onset = _with_touch(got, t_frames, gap_mm, record, mains, fs_manifest, figures)
    return TrialChecks(tuple(checks), onset, onset_message, record, figures, time.perf_counter() - t_start,
                       time.process_time() - c_start)
