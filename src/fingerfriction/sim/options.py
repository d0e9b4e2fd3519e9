"""What to simulate: :class:`SimOptions` (the design, the models, the world and the
measurement chain), the design's trials (:class:`TrialSpec`) and each trial's random
streams (keyed by the study seed and the trial id only)."""

from __future__ import annotations

import math
import os
import zlib
from dataclasses import dataclass, field, replace

import numpy as np

from .._check import check_option
from ..surfaces import SURFACE_NAMES, Surface, surface_from_spec
from .camera import CameraParams
from .chain import CHAIN_NAMES, RealisticChain
from .contact import get_provider
from .fingers import check_finger_options, study_fingers
from .kinematics import KinematicsParams
from .physics import SUBJECT_FORCE_LAWS, RealismParams
from .sensor import SensorParams
from .worlds import get_world

__all__ = ["SimOptions", "TrialSpec", "PAPER_SPEEDS", "VIDEO_EXT"]

PAPER_SPEEDS = (40.0, 80.0, 120.0)
VIDEO_EXT = {"ffv1-mkv": "mkv", "tiff": "tif"}


@dataclass(frozen=True)
class SimOptions:
    """What to simulate (validated; every mistake is a ``ValueError`` naming the option).

    Parameters
    ----------
    reps : int
        Repetitions per condition (>= 1; the paper: 5).
    subjects : tuple of str
        Subject labels known to the contact model and to
        :data:`~fingerfriction.sim.physics.SUBJECT_FORCE_LAWS` (``'1'``, ``'2'``).
    surfaces : tuple of str
        Paper surface names (``bump-2mm`` ...) or parametric specs (``bump:W=3,H=0.5``).
    speeds : tuple of float
        Nominal sliding speeds in mm/s (> 0).
    seed : int
        Study seed (>= 0).
    video_format : {'ffv1-mkv', 'tiff'}
    camera, sensor, kinematics : parameter dataclasses
    contact_model : {'mechanics-bem', 'bridged-foundation', 'fe'}
        The contact provider (:mod:`fingerfriction.sim.contact`; 'fe': the layered
        finite-element finger, :mod:`fingerfriction.mechanics.fe`).
    table_step : float, optional
        Finger-position step of the contact tables in mm (default 0.02; 0.1 for 'fe').
    table_loads : tuple of float
        Normal loads of the contact tables in N.
    video_end_mm : float
        The video stops at the first frame where the finger centre is past this position.
    realism : RealismParams, optional
        A harder experiment (:class:`~fingerfriction.sim.physics.RealismParams`): friction
        drawn per trial, friction falling with load, the normal force wandering over the
        full +-50 mN. None (default) keeps the default study's figures comparable.
    fingers : dict, optional
        Subject label -> finger (``FingerParams``, its dict or a finger file's object):
        overrides the calibrated finger of that subject (:mod:`~fingerfriction.sim.fingers`).
    finger_seed : int, optional
        Draw every subject without an override around its calibrated finger (radius,
        modulus, flat length within +-25 %, :func:`~fingerfriction.sim.fingers.draw_finger`).
    world : str or world object
        The true physics (:mod:`fingerfriction.sim.worlds`): ``'load-sharing'`` (default),
        ``'constant-pressure'``, ``'interlocking'``, or a world object with its own
        parameters (e.g. ``ConstantPressure(p1=0.2)``). Held as the world object.
    chain : {'ideal', 'realistic'} or RealisticChain
        The measurement chain (:mod:`fingerfriction.sim.chain`): ``'ideal'`` (default; the
        first-order high-pass the analysis inverts exactly) or ``'realistic'`` (a
        participant whose normal force follows the relief, motor noise growing with speed,
        a second-order high-pass of unknown cut-off, crosstalk, a curved drift), or a
        :class:`~fingerfriction.sim.chain.RealisticChain` with its own parameters. Held as
        ``'ideal'`` or the ``RealisticChain``.
    """

    reps: int = 5
    subjects: tuple = ("1", "2")
    surfaces: tuple = SURFACE_NAMES
    speeds: tuple = PAPER_SPEEDS
    seed: int = 0
    video_format: str = "ffv1-mkv"
    camera: CameraParams = field(default_factory=CameraParams)
    sensor: SensorParams = field(default_factory=SensorParams)
    kinematics: KinematicsParams = field(default_factory=KinematicsParams)
    contact_model: str = "mechanics-bem"
    table_step: float | None = None
    table_loads: tuple = (0.22, 0.3, 0.38)
    video_end_mm: float = 14.0
    realism: RealismParams | None = None
    fingers: dict = field(default_factory=dict)
    finger_seed: int | None = None
    world: object = "load-sharing"
    chain: object = "ideal"

    def __post_init__(self) -> None:
        object.__setattr__(self, "world", get_world(self.world))
        if isinstance(self.chain, str) and self.chain in CHAIN_NAMES:
            object.__setattr__(self, "chain", RealisticChain() if self.chain == "realistic" else "ideal")
        elif not isinstance(self.chain, RealisticChain):
            raise ValueError(f"unknown chain {self.chain!r}; chains: {', '.join(CHAIN_NAMES)}")
        if self.realism is not None:
            if not isinstance(self.realism, RealismParams):
                raise TypeError(f"realism must be a RealismParams or None, got {type(self.realism).__name__}")
            # the normal force wanders over the full +-50 mN
            object.__setattr__(self, "kinematics", replace(
                self.kinematics, force_sd_trial=self.realism.force_sd_trial, force_sd=self.realism.force_sd))
        if isinstance(self.reps, bool) or not isinstance(self.reps, (int, np.integer)) or self.reps < 1:
            raise ValueError(f"reps must be an integer >= 1, got {self.reps!r}")
        if isinstance(self.seed, bool) or not isinstance(self.seed, (int, np.integer)) or self.seed < 0:
            raise ValueError(f"seed must be an integer >= 0, got {self.seed!r}")
        subs = tuple(str(s) for s in self.subjects)
        if not subs:
            raise ValueError("subjects must not be empty")
        fingers, fseed = check_finger_options(self.fingers, self.finger_seed, subs, self.contact_model)
        object.__setattr__(self, "fingers", fingers)
        object.__setattr__(self, "finger_seed", fseed)
        provider = self.provider(subs)
        for s in subs:
            if s not in SUBJECT_FORCE_LAWS:
                raise ValueError(
                    f"unknown subject {s!r}; simulated subjects: {', '.join(SUBJECT_FORCE_LAWS)}"
                )
            provider.finger_dict(s)  # the contact model must know the subject too
        if len(set(subs)) != len(subs):
            raise ValueError(f"subjects has duplicates: {list(subs)}")
        surfs = tuple(str(s) for s in self.surfaces)
        if not surfs:
            raise ValueError("surfaces must not be empty")
        names = []
        for s in surfs:
            if os.path.exists(s) or s.lower().endswith(".csv"):
                raise ValueError(
                    f"surface {s!r}: the simulator takes surface names or 'shape:W=..,H=..' specs"
                )
            if s not in SURFACE_NAMES and ":" not in s:
                raise ValueError(f"unknown surface {s!r}; known surfaces: {', '.join(SURFACE_NAMES)} "
                                 "(or a spec like 'bump:W=3,H=0.5')")
            try:
                names.append(surface_from_spec(s).name)
            except (ValueError, TypeError) as exc:
                raise ValueError(f"surface {s!r}: {exc}") from None
        if len(set(names)) != len(names):
            raise ValueError(f"surfaces has duplicates: {surfs}")
        sp = []
        for v in self.speeds:
            try:
                f = float(v)
            except (TypeError, ValueError):
                raise ValueError(f"speed {v!r} is not a number (mm/s)") from None
            if not math.isfinite(f) or f <= 0:
                raise ValueError(f"speed must be a positive speed in mm/s, got {v!r}")
            if f > 1000:
                raise ValueError(f"speed {f} mm/s is beyond what the simulator supports (<= 1000 mm/s)")
            sp.append(f)
        if not sp:
            raise ValueError("speeds must not be empty")
        if len(set(sp)) != len(sp):
            raise ValueError(f"speeds has duplicates: {sp}")
        check_option("video_format", self.video_format, VIDEO_EXT)
        if self.table_step is None:  # 0.02 mm; the FE finger's tables (0.4 s a position): 0.1 mm
            object.__setattr__(self, "table_step", 0.1 if self.contact_model == "fe" else 0.02)
        if not (self.table_step > 0 and math.isfinite(self.table_step)):
            raise ValueError(f"table_step must be a positive length in mm, got {self.table_step!r}")
        object.__setattr__(self, "subjects", subs)
        object.__setattr__(self, "surfaces", surfs)
        object.__setattr__(self, "speeds", tuple(sp))
        object.__setattr__(self, "table_loads", tuple(float(v) for v in self.table_loads))
        object.__setattr__(self, "reps", int(self.reps))
        object.__setattr__(self, "seed", int(self.seed))

    def surface(self, spec: str) -> Surface:
        return surface_from_spec(spec)

    def provider(self, subjects=None):
        """The contact provider, with this study's fingers (:mod:`~fingerfriction.sim.fingers`);
        the FE finger's contact carries each subject's sliding friction (its force law's
        ``mu``: the traction shifts the patch against the motion, ``docs/mechanics-fe.md``)."""
        subjects = subjects or self.subjects
        fingers = study_fingers(self.fingers, self.finger_seed, subjects, self.contact_model)
        friction = {s: SUBJECT_FORCE_LAWS[s].mu for s in subjects if s in SUBJECT_FORCE_LAWS}
        return get_provider(self.contact_model, fingers=fingers, friction=friction)

    def trial_specs(self) -> list[TrialSpec]:
        """The design in a fixed order: subject, surface, speed, repetition."""
        out = []
        for subj in self.subjects:
            for s in self.surfaces:
                name = surface_from_spec(s).name
                for v in self.speeds:
                    for r in range(1, self.reps + 1):
                        tid = f"s{subj}-{name}-v{v:03.0f}-r{r}" if float(v).is_integer() else \
                            f"s{subj}-{name}-v{v:g}-r{r}"
                        out.append(TrialSpec(tid, subj, s, name, v, r))
        return out

    def to_dict(self) -> dict:
        """Everything that determines the study's content (used to recognise it on resume)."""
        return {
            "reps": self.reps, "subjects": list(self.subjects), "surfaces": list(self.surfaces),
            "speeds": list(self.speeds), "seed": self.seed, "video_format": self.video_format,
            "camera": self.camera.to_dict(), "sensor": self.sensor.to_dict(),
            "kinematics": self.kinematics.to_dict(), "contact_model": self.contact_model,
            "table_step": self.table_step,
            "table_loads": list(self.table_loads), "video_end_mm": self.video_end_mm,
            # only when set, so that the default study's record is unchanged
            **({"realism": self.realism.to_dict()} if self.realism is not None else {}),
            # only when set, so a default study's description (and resume check) is unchanged
            **({"fingers": self.fingers} if self.fingers else {}),
            **({"finger_seed": self.finger_seed} if self.finger_seed is not None else {}),
            "world": {"name": self.world.name, "params": self.world.to_dict()["params"]},
            "chain": {"name": self.chain_name,
                      **({"params": self.chain.to_dict()} if self.chain_name == "realistic" else {})},
        }

    @property
    def world_name(self) -> str:
        """The world's name (one of :data:`~fingerfriction.sim.worlds.WORLD_NAMES`)."""
        return self.world.name

    @property
    def chain_name(self) -> str:
        """``'ideal'`` or ``'realistic'``."""
        return "ideal" if isinstance(self.chain, str) else "realistic"

    @classmethod
    def from_dict(cls, d: dict) -> SimOptions:
        """The options back from :meth:`to_dict` (e.g. ``truth/study.json``'s ``options``).

        Raises
        ------
        ValueError
            For an unknown or invalid field (named in the message).
        """
        if not isinstance(d, dict):
            raise ValueError(f"simulation options must be a dict, got {type(d).__name__}")
        d = dict(d)
        sub = {"camera": CameraParams, "sensor": SensorParams, "kinematics": KinematicsParams}
        try:
            for key, kind in sub.items():
                if key in d:
                    fields = dict(d[key])
                    fields.pop("lsb_n", None)  # derived, written for the reader's benefit
                    if "mains_n" in fields:
                        fields["mains_n"] = tuple(fields["mains_n"])
                    d[key] = kind(**fields)
            for key in ("subjects", "surfaces", "speeds", "table_loads"):
                if key in d:
                    d[key] = tuple(d[key])
            if d.get("realism") is not None:
                d["realism"] = RealismParams(**dict(d["realism"]))
            if isinstance(d.get("world"), dict):
                w = dict(d["world"])
                d["world"] = type(get_world(w.get("name")))(**dict(w.get("params") or {}))
            if isinstance(d.get("chain"), dict):
                c = dict(d["chain"])
                d["chain"] = RealisticChain.from_dict(c["params"]) if c.get("name") == "realistic" and \
                    c.get("params") is not None else c.get("name")
            return cls(**d)
        except TypeError as exc:  # unknown field names
            raise ValueError(f"simulation options: {exc}") from None


@dataclass(frozen=True)
class TrialSpec:
    """One trial of the design: ids and conditions."""

    id: str
    subject: str
    surface_spec: str
    surface_name: str
    speed_mm_s: float
    repetition: int

    def seed_sequence(self, seed: int) -> np.random.SeedSequence:
        """The trial's random stream: keyed by the study seed and the trial id only."""
        return np.random.SeedSequence(seed, spawn_key=(zlib.crc32(self.id.encode("utf-8")),))


def trial_rngs(spec: TrialSpec, seed: int):
    """The trial's three streams (kinematics, sensor, camera): the first three children of its
    seed sequence (:meth:`TrialSpec.seed_sequence`), as ``numpy.random.Generator`` objects."""
    kin, sensor, camera = spec.seed_sequence(seed).spawn(3)
    return np.random.default_rng(kin), np.random.default_rng(sensor), np.random.default_rng(camera)


def realism_rng(spec: TrialSpec, seed: int) -> np.random.Generator:
    """A fourth stream of the trial for the realism draws: the first three (kinematics,
    sensor, camera) are the same as without it, so switching realism off changes nothing."""
    return np.random.default_rng(spec.seed_sequence(seed).spawn(4)[3])


#: The trial's further streams, by child index of its seed sequence (0-2: kinematics,
#: sensor, camera; 3: realism): each a stream of its own, so that a world, the participant
#: or the realistic chain never changes the draws of another.
_STREAMS = {"world": 4, "participant": 5, "chain": 6}


def trial_stream(spec: TrialSpec, seed: int, name: str) -> np.random.Generator:
    """The trial's stream ``name`` (:data:`_STREAMS`)."""
    k = _STREAMS[name]
    return np.random.default_rng(spec.seed_sequence(seed).spawn(k + 1)[k])
