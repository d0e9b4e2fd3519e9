"""Which finger each simulated subject has: the calibrated defaults, a given finger, or a draw.

By default a simulated subject ``'1'`` or ``'2'`` slides the calibrated finger of
:data:`fingerfriction.mechanics.SUBJECTS`, so a calibration or a validation run on such a
study never meets a finger the model did not already know. :class:`~.writer.SimOptions`
therefore takes

* ``fingers``: per-subject overrides, subject label -> :class:`~fingerfriction.mechanics.
  FingerParams` (or its dict / a finger JSON file's object, ``simulate --finger 1=f1.json``);
* ``finger_seed``: draw every subject without an override around its calibrated finger
  (:func:`draw_finger`), from ``numpy.random.SeedSequence(finger_seed, spawn_key=
  (crc32(label),))``: the draw of a subject depends on the seed and its label only.

The fingers actually used are recorded in ``truth/study.json``
(``subjects.<label>.finger``), and the seed in its ``options``.
"""

from __future__ import annotations

import dataclasses
import math
import zlib

import numpy as np

from ..mechanics import FingerParams, get_subject
from ..mechanics.fe import FE_SUBJECTS, FEFingerParams
from ..mechanics.finger_file import fe_finger_from_mapping, finger_from_mapping

__all__ = ["DRAW_SPREAD", "DRAWN_FIELDS", "FE_DRAWN_FIELDS", "draw_finger", "draw_fingers",
           "draw_fe_finger", "check_finger_options", "study_fingers"]

#: Relative half-range of a drawn parameter: uniform in ``[1 - s, 1 + s]`` times the default.
DRAW_SPREAD = 0.25
#: The parameters a draw varies: end radius (mm), effective modulus (MPa), flat pad length (mm).
DRAWN_FIELDS = ("radius", "modulus", "flat_length")


def draw_finger(base: FingerParams, rng: np.random.Generator, *, spread: float = DRAW_SPREAD,
                name: str = "") -> FingerParams:
    """A plausible finger around ``base``: each of :data:`DRAWN_FIELDS` times ``U(1 - s, 1 + s)``.

    Parameters
    ----------
    base : FingerParams
        A stadium (or circle) finger; a circle (``flat_length = 0``) keeps no flat.
    rng : numpy.random.Generator
    spread : float
        ``s`` in ``(0, 1)`` (default 0.25: +-25 %).
    name : str
        Name of the drawn finger.
    """
    if not (isinstance(spread, (int, float)) and 0 < spread < 1):
        raise ValueError(f"spread must be in (0, 1), got {spread!r}")
    factors = rng.uniform(1.0 - spread, 1.0 + spread, size=len(DRAWN_FIELDS))
    kw = {f: float(getattr(base, f)) * float(k) for f, k in zip(DRAWN_FIELDS, factors, strict=True)}
    return dataclasses.replace(base, name=name or base.name, **kw)


#: The parameters an FE draw varies (:func:`draw_fe_finger`): the outline, the two moduli,
#: the skin's and the pulp's thicknesses.
FE_DRAWN_FIELDS = ("radius", "semi_height", "tissue_modulus", "skin_modulus", "skin_thickness",
                   "pulp_thickness")


def draw_fe_finger(base: FEFingerParams, rng: np.random.Generator, *, spread: float = DRAW_SPREAD,
                   name: str = "") -> FEFingerParams:
    """A layered FE finger around ``base``: each of :data:`FE_DRAWN_FIELDS` times
    ``U(1 - s, 1 + s)`` (the pulp thickness within ``s / 2``), the bone scaled with the
    outline (its half-width with ``radius``, its half-height and the pulp with
    ``semi_height``), so that every draw is a valid finger. ``s = 0.25`` spans the
    literature ranges of docs/mechanics-fe.md."""
    if not (isinstance(spread, (int, float)) and 0 < spread < 1):
        raise ValueError(f"spread must be in (0, 1), got {spread!r}")
    k = rng.uniform(1.0 - spread, 1.0 + spread, size=len(FE_DRAWN_FIELDS))
    k[5] = 1.0 + 0.5 * (k[5] - 1.0)
    f = dict(zip(FE_DRAWN_FIELDS, k.tolist(), strict=True))
    return dataclasses.replace(
        base, name=name or base.name, radius=base.radius * f["radius"],
        semi_height=base.semi_height * f["semi_height"],
        tissue_modulus=base.tissue_modulus * f["tissue_modulus"],
        skin_modulus=base.skin_modulus * f["skin_modulus"],
        skin_thickness=base.skin_thickness * f["skin_thickness"],
        pulp_thickness=base.pulp_thickness * f["semi_height"] * f["pulp_thickness"],
        bone_half_width=base.bone_half_width * f["radius"],
        bone_half_height=base.bone_half_height * f["semi_height"])


def draw_fingers(seed: int, subjects, model: str = "mechanics-bem") -> dict:
    """Drawn fingers around the defaults, one per subject label ('1' or '2'): half-space
    fingers around the calibrated ones, or (``model='fe'``) FE fingers around
    :data:`~fingerfriction.mechanics.fe.FE_SUBJECTS`."""
    out = {}
    for s in subjects:
        label = str(s)
        ss = np.random.SeedSequence(int(seed), spawn_key=(zlib.crc32(label.encode()),))
        rng = np.random.default_rng(ss)
        name = f"subject {label} (drawn, finger seed {seed})"
        if model == "fe":
            out[label] = draw_fe_finger(_default_fe(label), rng, name=name)
        else:
            out[label] = draw_finger(_default(label), rng, name=name)
    return out


def _default_fe(label: str) -> FEFingerParams:
    try:
        return FE_SUBJECTS[label]
    except KeyError:
        raise ValueError(f"no default FE finger to draw around for subject {label!r}; give --finger "
                         f"{label}=FILE instead") from None


def _default(label: str) -> FingerParams:
    try:
        return get_subject(int(label))
    except (TypeError, ValueError):
        raise ValueError(f"no calibrated finger to draw around for subject {label!r}; give --finger "
                         f"{label}=FILE instead") from None


def check_finger_options(fingers, finger_seed, subjects, contact_model: str) -> tuple[dict, int | None]:
    """Validate ``SimOptions.fingers`` / ``finger_seed``; returns them normalised.

    ``fingers`` becomes ``{label: FingerParams.to_dict()}`` (JSON-ready, sorted by label).
    """
    if finger_seed is not None and (
        isinstance(finger_seed, bool) or not isinstance(finger_seed, (int, np.integer)) or finger_seed < 0
    ):
        raise ValueError(f"finger_seed must be an integer >= 0 or None, got {finger_seed!r}")
    if fingers is None:
        fingers = {}
    if not isinstance(fingers, dict):
        raise ValueError(f"fingers must be a mapping subject -> finger, got {type(fingers).__name__}")
    out = {}
    read = fe_finger_from_mapping if contact_model == "fe" else finger_from_mapping
    for label, f in fingers.items():
        label = str(label)
        if label not in subjects:
            raise ValueError(f"fingers: subject {label!r} is not simulated (subjects: {', '.join(subjects)})")
        d = read(f, where=f"finger of subject {label}").to_dict()
        out[label] = {"model": "fe", **d} if contact_model == "fe" else d
    if (out or finger_seed is not None) and contact_model not in ("mechanics-bem", "fe"):
        raise ValueError(f"fingers and finger_seed need contact_model 'mechanics-bem' or 'fe', "
                         f"got {contact_model!r}")
    return dict(sorted(out.items())), (None if finger_seed is None else int(finger_seed))


def study_fingers(fingers: dict, finger_seed: int | None, subjects, model: str = "mechanics-bem"):
    """Subject label -> the finger it slides (None: the provider's defaults for all).

    An explicit finger wins over the seed's draw for its subject. ``model='fe'``: FE fingers.
    """
    if not fingers and finger_seed is None:
        return None
    drawn = draw_fingers(finger_seed, subjects, model) if finger_seed is not None else {}
    out = {}
    for s in subjects:
        if s in fingers:
            out[s] = (fe_finger_from_mapping(fingers[s]) if model == "fe"
                      else FingerParams.from_dict(fingers[s]))
        elif s in drawn:
            out[s] = drawn[s]
        else:
            out[s] = _default_fe(s) if model == "fe" else _default(s)
    return out


def relative_difference(a: FingerParams, b: FingerParams) -> dict[str, float]:
    """``a / b - 1`` for each of :data:`DRAWN_FIELDS` (``nan`` where ``b``'s value is 0)."""
    out = {}
    for f in DRAWN_FIELDS:
        va, vb = float(getattr(a, f)), float(getattr(b, f))
        out[f] = va / vb - 1.0 if vb != 0 else (0.0 if va == 0 else math.nan)
    return out
