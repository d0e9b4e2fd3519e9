"""Eq. (4) parameters for a prediction: the documented defaults of subjects 1 and 2
(:func:`default_params`; their provenance is in ``docs/predict.md``), or parameters read
from a file or a fit (:func:`load_params`).
"""

from __future__ import annotations

import functools
import json
import os
from pathlib import Path

import numpy as np

from .._check import parse_json
from ..fit.select import DEFAULT_MODEL
from ..fit.variants import get
from ..mechanics import FingerParams
from ..model import FrictionModel, FrictionParams, LoadParams
from ..study.results import subject_keys
from ..study.store import ResultsStore
from ..surfaces import Surface, get_surface
from .forward import DEFAULT_LOAD_N, flat_length, forward_regions, resolve_finger, sweep_window

__all__ = ["PAPER_MU", "PAPER_FORCE_RISE_N", "default_params", "default_load_params", "load_params"]

#: Per-subject coefficients of friction found by the paper's grid search.
PAPER_MU = {1: 0.55, 2: 0.60}


#: Rise of F_T at first contact with a raised feature reported by the paper, in N.
PAPER_FORCE_RISE_N = 0.050


#: The raised surfaces over which the default p1 is calibrated.
_P1_CALIBRATION_SURFACES = ("bump-2mm", "bump-4mm", "step-up-2mm", "step-up-4mm")



def _calibration_sweep(surface: Surface, finger, load: float, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Finger positions (mm) and forward-model regions of a calibration sweep."""
    lo, hi = sweep_window(surface)
    x = np.arange(lo, hi + 0.5 * step, step)
    regions = forward_regions(surface, finger, x, load=load)
    return x, regions


@functools.lru_cache(maxsize=8)
def _default_params_cached(key, finger, load: float, step: float) -> FrictionParams:
    mu = PAPER_MU[key]
    L = flat_length(finger, load)
    p0 = load / L
    peaks = []
    for name in _P1_CALIBRATION_SURFACES:
        s = get_surface(name)
        x, regions = _calibration_sweep(s, finger, load, step)
        peaks.append(float(np.max(FrictionModel(s).basis(regions, mu)[:, 1])))
    m = float(np.mean(peaks))
    if not m > 0:
        raise RuntimeError("could not calibrate the default p1: the deformation basis is zero")
    # F_def = p1 * basis: linear, so the calibration is closed-form.
    return FrictionParams(mu, p0, PAPER_FORCE_RISE_N / m)


def default_params(subject, *, load: float = DEFAULT_LOAD_N, step: float = 0.05,
                   finger: FingerParams | None = None) -> FrictionParams:
    """Documented default Eq. (4) parameters of subject 1 or 2 (``docs/predict.md``).

    ``mu`` from the paper; ``p0 = F_N / L_flat`` (flat-ground friction ``mu F_N``);
    ``p1`` such that the mean peak of ``F_def`` over the paper's four raised surfaces is
    50 mN. Computed from forward-model sweeps at ``step`` mm (cached per finger).

    Parameters
    ----------
    subject : int
        1 or 2 (a custom FingerParams has no paper mu: give parameters instead).
    load : float
        Normal force in N (default 0.3).
    step : float
        Finger step in mm of the calibration sweeps (default 0.05).
    finger : FingerParams, optional
        The subject's own finger (e.g. from ``calibrate-finger``) instead of its default:
        the paper's ``mu`` of the subject, ``p0`` and ``p1`` from this finger's sweeps.
    """
    key, default = resolve_finger(subject)
    finger = default if finger is None else finger
    if key not in PAPER_MU:
        raise ValueError(
            f"no default friction parameters for subject {subject!r}: give params "
            f"(FrictionParams or a JSON file); defaults exist for subjects {sorted(PAPER_MU)}"
        )
    return _default_params_cached(key, finger, float(load), float(step))


def _params_of(d, where: str):
    """Parameters from their JSON object (``FrictionParams.to_json()`` or
    ``LoadParams.to_json()``, told apart by its ``model``, a variant's name)."""
    if not isinstance(d, dict):
        raise ValueError(f"{where}: parameters must be a JSON object, got {type(d).__name__}")
    try:
        if d.get("model") is not None:
            ptype = get(d["model"]).params_type
            return (LoadParams if ptype is LoadParams else FrictionParams).from_json(json.dumps(d))
        return FrictionParams.from_json(json.dumps(d))
    except KeyError as exc:
        raise ValueError(f"{where}: malformed parameters (missing {exc}); {PARAMS_SHAPE}") from None
    except TypeError as exc:
        raise ValueError(f"{where}: malformed parameters ({exc})") from None


#: The one shape of a parameters file, as error messages name it.
PARAMS_SHAPE = ("expected the JSON of FrictionParams or LoadParams ({'mu', 'p0', 'p1'} or {'model': 'load', "
                "'mu', 'p1', ...}), or {'subjects': {'<subject>': <those>}}, or a fit's results folder")


def load_params(path: str | os.PathLike, subject=None, *, model: str | None = None):
    """Read Eq. (4) parameters from a JSON file or from a fit.

    A parameters file has one shape: the JSON of the parameters
    (:meth:`FrictionParams.to_json() <fingerfriction.model.FrictionParams.to_json>`,
    ``{"mu", "p0", "p1"}``; or :meth:`LoadParams.to_json() <fingerfriction.model.LoadParams.to_json>`,
    ``{"model": "load", "mu", "p1", "inset", "kappa"}``), for every subject, or per subject
    under ``subjects``: ``{"subjects": {"1": {...}, "2": {...}}}`` (a subject found as
    ``'1'``, ``'S1'`` or ``'s1'``).

    The output of ``fingerfriction fit`` is read through the results store
    (``RESULTS``, ``RESULTS/fit`` or ``RESULTS/fit/fit.json``,
    :meth:`~fingerfriction.study.store.ResultsStore.prediction_params`): the subject's ``mu``
    and contact of the fit's variant (or ``model``), and the medians of its successful trial
    fits' weights.

    Returns
    -------
    FrictionParams or LoadParams

    Raises
    ------
    ValueError
        Naming the file and what is missing or malformed.
    """
    path = os.fspath(path)
    store = _results_of(path)
    if store is not None:
        return store.prediction_params(subject, model=model)
    try:
        with open(path, "rb") as fh:
            d = parse_json(fh.read(), str(path))  # bounded depth and size: no run out of memory
    except OSError as exc:
        raise ValueError(f"{path}: cannot read parameters ({exc.strerror})") from None
    if not isinstance(d, dict):
        raise ValueError(f"{path}: expected a JSON object, got {type(d).__name__}")
    if "subjects" not in d:
        return _params_of(d, path)
    subjects = d["subjects"]
    if not isinstance(subjects, dict):
        raise ValueError(f"{path}: 'subjects' must be an object keyed by subject")
    entry = next((subjects[k] for k in subject_keys(subject) if k in subjects), None)
    if entry is None:
        raise ValueError(f"{path}: no parameters for subject {subject!r}; the file has "
                         f"{sorted(map(str, subjects))}")
    return _params_of(entry, f"{path}: subject {subject!r}")


def _results_of(path: str) -> ResultsStore | None:
    """The results store a path names (``RESULTS``, ``RESULTS/fit``, ``RESULTS/fit/fit.json``),
    None for a parameters file."""
    p = Path(path)
    if p.is_dir():
        root = p.parent if p.name == "fit" and not (p / "fit").is_dir() and (p / "fit.json").is_file() else p
        store = ResultsStore(root)
        if not store.fit_json.is_file():
            raise ValueError(f"{path}: a folder without fit/fit.json; run 'fingerfriction fit' first")
        return store
    if p.name == "fit.json" and p.parent.name == "fit":
        return ResultsStore(p.parent.parent)
    return None


def resolve_params(params, subject, load: float, model: str | None = None,
                   finger: FingerParams | None = None):
    """``(params, description)`` of the Eq. (4) parameters a prediction uses: the documented
    defaults of ``model`` (default :data:`fingerfriction.fit.select.DEFAULT_MODEL`) for
    ``subject`` at ``load`` (N) when ``params``
    is None (:func:`default_params`, :func:`default_load_params`); ``params`` itself when it is
    a :class:`LoadParams` or :class:`FrictionParams`; a JSON file's read by :func:`load_params`
    when it is a path. ValueError for an unknown ``model``, TypeError for anything else."""
    if model is not None:
        get(model)  # an unknown name: ValueError naming the known ones
    if params is None:
        if get(model or DEFAULT_MODEL).params_type is FrictionParams:  # a constant pressure
            return (default_params(subject, load=load, finger=finger),
                    "default (paper mu; p0 = F_N/L_flat; p1: 50 mN peak F_def)")
        return (default_load_params(subject, load=load, finger=finger),
                "default (paper mu; one uniform pressure carrying F_N; p1: 50 mN peak F_def)")
    if isinstance(params, (LoadParams, FrictionParams)):
        return params, "given"
    if isinstance(params, (str, os.PathLike)):
        return load_params(params, subject, model=model), f"file {os.fspath(params)}"
    raise TypeError("params must be None, LoadParams, FrictionParams or a JSON path, got "
                    f"{type(params).__name__}")


def default_load_params(subject, *, load: float = DEFAULT_LOAD_N, step: float = 0.05,
                        finger: FingerParams | None = None) -> LoadParams:
    """Documented default parameters of the load-consistent model for subject 1 or 2.

    The paper's ``mu``; the paper's pressure assumption, one uniform pressure over the
    geometric contact (``inset = 0``, ``kappa = 0``), here carrying the normal force;
    ``p1`` as :func:`default_params` (the deformation term is the same in both variants).
    A fit of a lab's own study gives the subject's inset and ``kappa``: prefer it.
    """
    p = default_params(subject, load=load, step=step, finger=finger)
    return LoadParams(mu=p.mu, p1=p.p1)
