"""Eq. (4) parameters for a prediction: the documented defaults of subjects 1 and 2
(:func:`default_params`; their provenance is in ``docs/predict.md``), or parameters read
from a file or a fit (:func:`load_params`).
"""

from __future__ import annotations

import functools
import json
import os

import numpy as np

from .._check import parse_json
from ..fit.variants import get
from ..mechanics import FingerParams
from ..model import FrictionModel, FrictionParams, LoadParams
from ..study.store import ResultsStore, read_fit_table
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


def _subject_keys(subject) -> list:
    """Keys a subject may have in a parameters file: '1', 1, 'S1', 's1'."""
    keys = [str(subject), subject]
    digits = "".join(c for c in str(subject) if c.isdigit())
    if digits:
        keys += [digits, f"S{digits}", f"s{digits}"]
    return [k for k in keys if isinstance(k, (str, int))]


def _params_from_mapping(d: dict, subject, where: str) -> FrictionParams:
    """FrictionParams from a JSON object (see :func:`load_params` for the accepted forms)."""
    if {"mu", "p0", "p1"} <= set(d):
        return FrictionParams(mu=d["mu"], p0=d["p0"], p1=d["p1"])
    subjects = d.get("subjects", d)
    if not isinstance(subjects, dict):
        raise ValueError(f"{where}: 'subjects' must be an object keyed by subject")
    entry = next((subjects[k] for k in _subject_keys(subject) if k in subjects), None)
    if entry is None:
        raise ValueError(
            f"{where}: no parameters for subject {subject!r}; the file has {sorted(map(str, subjects))}. "
            "Expected {'mu','p0','p1'} or {'subjects': {'<subject>': {...}}}"
        )
    if not isinstance(entry, dict) or "mu" not in entry:
        raise ValueError(f"{where}: subject {subject!r} entry must be an object with 'mu'")
    if "p0" in entry and "p1" in entry:
        return FrictionParams(mu=entry["mu"], p0=entry["p0"], p1=entry["p1"])
    trials = entry.get("trials")
    if isinstance(trials, list) and trials:
        try:
            p0 = float(np.median([float(t["p0"]) for t in trials]))
            p1 = float(np.median([float(t["p1"]) for t in trials]))
        except (KeyError, TypeError, ValueError):
            raise ValueError(
                f"{where}: subject {subject!r} trials must each have numbers p0 and p1"
            ) from None
        return FrictionParams(mu=entry["mu"], p0=p0, p1=p1)
    raise ValueError(f"{where}: subject {subject!r} entry needs 'p0' and 'p1' or a non-empty 'trials' list")


def _params_from_pipeline_fit(d: dict, subject, path: str, model: str | None = None):
    """``fingerfriction fit`` output: mu per subject in fit.json, p0/p1 per trial in the
    trials.csv beside it; the subject's medians over its successful trials are used.

    ``model`` picks the variant (default: the fit's model, ``fit.json`` ``model``; a fit
    written before the load-consistent model has only the paper's)."""
    model = model or d.get("model") or "paper"
    variant = get(model)
    per_model = (d.get("models") or {}).get(model)
    if per_model is None and model != d.get("model", "paper"):
        raise ValueError(f"{path}: the fit has no {model!r} model (it has {d.get('model', 'paper')!r})")
    mus = per_model["mu"] if per_model else d["mu"]
    key = next((k for k in _subject_keys(subject) if k in mus), None)
    if key is None:
        raise ValueError(f"{path}: no fitted mu for subject {subject!r}; the fit has subjects {sorted(mus)}")
    tcsv = os.path.join(os.path.dirname(path), "trials.csv")
    t = read_fit_table(os.path.dirname(path))
    missing = {"subject", "p0", "p1"} - set(t.columns)
    if missing:
        raise ValueError(f"{tcsv}: missing column(s) {sorted(missing)}")
    sel = t[t["subject"] == key]
    if "model" in sel.columns:
        sel = sel[sel["model"] == model]
    if "success" in sel.columns:
        sel = sel[sel["success"].astype(str).str.lower() == "true"]
    if sel.empty:
        raise ValueError(f"{tcsv}: no successful {model!r} trial fit for subject {subject!r}")
    return variant.params_from_record({**(per_model or {}), "mu": mus}, sel, key)


def load_params(path: str | os.PathLike, subject=None, *, model: str | None = None):
    """Read Eq. (4) parameters from a JSON file.

    Accepted forms: ``FrictionParams.to_json()`` (``{"mu", "p0", "p1"}``); a per-subject
    object ``{"subjects": {"1": {"mu", "p0", "p1"}}}`` (or without the ``subjects``
    level); or a fit output with per-trial values ``{"subjects": {"1": {"mu": ...,
    "trials": [{"p0": ..., "p1": ...}, ...]}}}``, whose subject-level ``p0, p1`` are the
    medians over trials (a prediction has no trial of its own to fit); or the output of
    ``fingerfriction fit`` (``RESULTS``, ``RESULTS/fit`` or ``RESULTS/fit/fit.json``: mu
    per subject, p0 and p1 medians over the subject's successful trials in ``trials.csv``):
    the fit's default model, or ``model`` (``'load'``: :class:`~fingerfriction.model.LoadParams`
    with the subject's flat-ground mu, load-bearing inset, pressure rise kappa and median p1;
    ``'paper'``: :class:`~fingerfriction.model.FrictionParams`). A JSON object with
    ``"model": "load"`` and ``mu, p1`` (optionally ``inset``, ``kappa``) gives LoadParams
    (``LoadParams.to_json()``).

    Returns
    -------
    FrictionParams or LoadParams

    Raises
    ------
    ValueError
        Naming the file and what is missing or malformed.
    """
    path = os.fspath(path)
    if os.path.isdir(path):  # a results folder or its fit/ folder
        for cand in (os.fspath(ResultsStore(path).fit_dir / "fit.json"), os.path.join(path, "fit.json")):
            if os.path.exists(cand):
                path = cand
                break
        else:
            raise ValueError(f"{path}: a folder without fit/fit.json; run 'fingerfriction fit' first")
    try:
        with open(path, "rb") as fh:
            d = parse_json(fh.read(), str(path))  # bounded depth and size: no run out of memory
    except OSError as exc:
        raise ValueError(f"{path}: cannot read parameters ({exc.strerror})") from None
    if not isinstance(d, dict):
        raise ValueError(f"{path}: expected a JSON object, got {type(d).__name__}")
    if isinstance(d.get("mu"), dict):
        return _params_from_pipeline_fit(d, subject, path, model)
    try:
        if d.get("model") is not None and get(d["model"]).params_type is LoadParams:  # LoadParams.to_json()
            return LoadParams.from_json(json.dumps(d))
        return _params_from_mapping(d, subject, path)
    except (TypeError, KeyError) as exc:
        raise ValueError(f"{path}: malformed parameters ({exc})") from None


def resolve_params(params, subject, load: float, model: str | None = None,
                   finger: FingerParams | None = None):
    """``(params, description)`` of the Eq. (4) parameters a prediction uses: the documented
    defaults of ``model`` (default ``'load'``) for ``subject`` at ``load`` (N) when ``params``
    is None (:func:`default_params`, :func:`default_load_params`); ``params`` itself when it is
    a :class:`LoadParams` or :class:`FrictionParams`; a JSON file's read by :func:`load_params`
    when it is a path. ValueError for an unknown ``model``, TypeError for anything else."""
    if model is not None:
        get(model)  # an unknown name: ValueError naming the known ones
    if params is None:
        if get(model or "load").params_type is FrictionParams:  # a constant pressure
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
