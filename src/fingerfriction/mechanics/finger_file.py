"""Finger JSON files: one :class:`FingerParams` per file, read by every command that takes
``--finger FILE`` (``simulate``, ``predict``, ``predict-contact``, ``validate``, ``render``)
and written by ``calibrate-finger``.

Two forms are accepted:

* the bare serialisation of :meth:`FingerParams.to_json`, e.g.
  ``{"radius": 26.2, "modulus": 0.14, "width": 10.0, "flat_length": 6.0}`` (omitted
  fields take their defaults);
* the wrapped form written by :func:`write_finger_file`::

      {"format": "fingerfriction-finger", "version": 1,
       "finger": {<FingerParams fields>},
       "calibration": {...}}          # optional provenance, never read back as parameters

An FE finger (:class:`~fingerfriction.mechanics.fe.FEFingerParams`, the layered
finite-element finger of ``simulate --finger-model fe``) is the same file with
``"model": "fe"``, bare (``{"model": "fe", "tissue_modulus": 0.02, ...}``) or wrapped
(``"model": "fe"`` beside ``"format"``); :func:`read_finger_file` reads the model it is asked
for (``model="halfspace"`` by default) and says so in one line when the file holds the other.
"""

from __future__ import annotations

import os
from pathlib import Path

from .._atomic import atomic_write_json
from .._check import parse_json
from .fe.params import FEFingerParams
from .finger import FingerParams

__all__ = ["FINGER_FORMAT", "FINGER_MODELS", "FINGER_RANGES", "register_finger_model", "read_finger_file",
           "write_finger_file", "finger_from_mapping", "read_subject_fingers", "fe_finger_from_mapping",
           "finger_model"]

#: The finger models a file can hold: the half-space finger (``model`` absent or
#: ``'mechanics-bem'``, truth files' provider name) and the FE finger (``'fe'``).
MODELS = {"halfspace": FingerParams, "fe": FEFingerParams}


def finger_model(d) -> str:
    """``'fe'`` or ``'halfspace'``: the model of a decoded finger mapping."""
    if isinstance(d, FEFingerParams):
        return "fe"
    if isinstance(d, dict) and d.get("model") == "fe":
        return "fe"
    return "halfspace"

FINGER_FORMAT = "fingerfriction-finger"
_VERSION = 1

#: The finger models a finger file may name in its ``model`` field (the contact model whose
#: finger it is; ground-truth files of the simulator carry it), name -> what it is. Other
#: models add theirs with :func:`register_finger_model`; an unknown name is refused.
FINGER_MODELS: dict[str, str] = {
    "mechanics-bem": "the plane-strain boundary-element finger (fingerfriction.mechanics)",
    "bridged-foundation": "the simulator's fast simplified stand-in (fingerfriction.sim.contact)",
    "fe": "the layered plane-strain finite-element finger (fingerfriction.mechanics.fe)",
}

#: Physical ranges of a finger file's fields, (low, high, unit): a human fingertip pad is
#: about 8 mm in radius and 0.07-0.2 MPa soft (Pawluk & Howe 1999), its skin up to a few
#: hundred MPa; the ranges are wide around those, and refuse what no finger is (a radius
#: of a metre, a modulus of steel) before a contact model runs on it.
FINGER_RANGES: dict[str, tuple[float, float, str]] = {
    "radius": (0.5, 50.0, "mm"),
    "modulus": (1e-3, 1e3, "MPa"),
    "width": (0.5, 50.0, "mm"),
    "semi_height": (0.5, 50.0, "mm"),
    "flat_length": (0.0, 50.0, "mm"),
    "layer_thickness": (0.01, 50.0, "mm"),
    "skin_modulus": (1e-3, 1e4, "MPa"),
    "skin_thickness": (1e-3, 5.0, "mm"),
}


def register_finger_model(name: str, description: str) -> None:
    """Make ``name`` a known value of a finger file's ``model`` field (:data:`FINGER_MODELS`)."""
    if not isinstance(name, str) or not name.strip():
        raise ValueError(f"a finger model needs a non-empty name, got {name!r}")
    FINGER_MODELS[name] = str(description)


def _check_ranges(finger: FingerParams, where: str) -> None:
    for key, (lo, hi, unit) in FINGER_RANGES.items():
        v = getattr(finger, key, None)
        if v is not None and not lo <= v <= hi:
            raise ValueError(f"{where}: {key} = {v:g} {unit} is outside the physical range [{lo:g}, {hi:g}] "
                             f"{unit} of a fingertip (FINGER_RANGES)")
    if finger.profile is not None:
        u, s = finger.profile
        if u[-1] - u[0] > 2 * FINGER_RANGES["radius"][1] or max(s) > 2 * FINGER_RANGES["radius"][1]:
            raise ValueError(f"{where}: profile spans {u[-1] - u[0]:g} mm across and {max(s):g} mm high, "
                             f"more than a fingertip ({2 * FINGER_RANGES['radius'][1]:g} mm)")


def _unwrap(d: dict, where: str, fields: str) -> dict:
    """The finger's fields of a bare or wrapped mapping (format and version checked)."""
    if "format" not in d:
        return d
    if d["format"] != FINGER_FORMAT:
        raise ValueError(f"{where}: format is {d['format']!r}, expected {FINGER_FORMAT!r}")
    if d.get("version") != _VERSION:
        raise ValueError(f"{where}: finger file version {d.get('version')!r} is not supported "
                         f"(this version reads {_VERSION})")
    if not isinstance(d.get("finger"), dict):
        raise ValueError(f"{where}: the field 'finger' must be an object of {fields} fields")
    return d["finger"]


def finger_from_mapping(d, where: str = "finger") -> FingerParams:
    """A :class:`FingerParams` from a bare or wrapped finger mapping (see the module notes).

    Parameters
    ----------
    d : dict
        The decoded JSON object.
    where : str
        Named in error messages (a file name).

    Raises
    ------
    ValueError
        Naming ``where`` and the field at fault.
    """
    if isinstance(d, FingerParams):
        return d
    if not isinstance(d, dict):
        raise ValueError(f"{where}: a finger must be a JSON object, got {type(d).__name__}")
    if finger_model(d) == "fe":
        raise ValueError(f"{where}: holds an FE finger (model 'fe'); this needs a half-space finger "
                         "(the finger files of calibrate-finger)")
    d = dict(_unwrap(d, where, "FingerParams"))
    model = d.pop("model", None)  # truth/study.json's finger entries carry the provider's name ...
    if model is not None and model not in FINGER_MODELS:
        raise ValueError(f"{where}: model {str(model)[:60]!r} is not a known finger model; known: "
                         f"{', '.join(sorted(FINGER_MODELS))}")
    for k in ("n", "clearance_mm", "side_radius_mm"):  # ... and its grid settings
        d.pop(k, None)
    try:
        finger = FingerParams.from_dict(d)
    except TypeError as exc:
        if "missing" in str(exc):
            raise ValueError(f"{where}: {exc}; a finger needs at least radius (mm), modulus (MPa) "
                             "and width (mm)") from None
        raise ValueError(f"{where}: {exc}") from None
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None
    _check_ranges(finger, where)
    return finger


def fe_finger_from_mapping(d, where: str = "finger") -> FEFingerParams:
    """An :class:`FEFingerParams` from a bare or wrapped FE finger mapping (``"model": "fe"``).

    Raises
    ------
    ValueError
        One line naming ``where`` and the field at fault.
    """
    if isinstance(d, FEFingerParams):
        return d
    if not isinstance(d, dict):
        raise ValueError(f"{where}: a finger must be a JSON object, got {type(d).__name__}")
    if d.get("model") != "fe":
        raise ValueError(f"{where}: not an FE finger (expected \"model\": \"fe\", got "
                         f"{d.get('model', 'none')!r}); the FE finger model needs FE finger files")
    # a study truth's provider entries: the mesh is the study's, not the finger's; its
    # "friction" (the traction the study's contact carried) is the finger's field
    d = {k: v for k, v in _unwrap(d, where, "FEFingerParams").items() if k not in ("model", "mesh")}
    try:
        return FEFingerParams.from_dict(d)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{where}: {exc}") from None


def read_finger_file(path: str | os.PathLike, model: str = "halfspace"):
    """Read a finger JSON file (either form of the module notes) of the given ``model``
    (``'halfspace'``: a :class:`FingerParams`; ``'fe'``: an :class:`FEFingerParams`;
    ``'any'``: the file's own model).

    Raises
    ------
    ValueError
        One line naming the file and what is wrong (unreadable, not JSON, unknown field,
        invalid value).
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ValueError(f"cannot read finger file {str(p)!r}: {exc.strerror or exc}") from None
    where = f"finger file {str(p)!r}"
    d = parse_json(text, where)
    if model == "any":
        model = finger_model(d)
    return fe_finger_from_mapping(d, where) if model == "fe" else finger_from_mapping(d, where)


def write_finger_file(path: str | os.PathLike, finger: FingerParams, *,
                      calibration: dict | None = None) -> Path:
    """Write ``finger`` in the wrapped form, atomically (temporary file then rename).

    Parameters
    ----------
    path : path-like
        Target file.
    finger : FingerParams or FEFingerParams
    calibration : dict, optional
        JSON-serialisable provenance (kept in the file, ignored by :func:`read_finger_file`).

    Returns
    -------
    Path
    """
    if not isinstance(finger, (FingerParams, FEFingerParams)):
        raise TypeError(f"finger must be a FingerParams or an FEFingerParams, got {type(finger).__name__}")
    doc = {"format": FINGER_FORMAT, "version": _VERSION, "finger": finger.to_dict()}
    if isinstance(finger, FEFingerParams):
        doc = {"format": FINGER_FORMAT, "version": _VERSION, "model": "fe", "finger": finger.to_dict()}
    if calibration is not None:
        doc["calibration"] = calibration
    p = Path(path)
    atomic_write_json(p, doc)  # NaN (an undetermined uncertainty) is written as null
    return p


def read_subject_fingers(items, option: str = "--finger", model: str = "halfspace") -> dict | None:
    """``['SUBJECT=FILE', ...]`` (a command line's repeated option) -> {subject: finger}.

    Returns None for no items; raises ``ValueError`` naming ``option`` and the item, or the
    file and its fault.
    """
    if not items:
        return None
    out = {}
    for item in items:
        label, sep, path = str(item).partition("=")
        if not sep or not label.strip() or not path.strip():
            raise ValueError(f"{option}: expected SUBJECT=FILE (e.g. 1=finger1.json), got {item!r}")
        out[label.strip()] = read_finger_file(path.strip(), model=model)
    return out
