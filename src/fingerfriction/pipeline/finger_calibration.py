"""Calibrate a subject's finger from a results folder (``fingerfriction calibrate-finger``).

A thin reader over :func:`fingerfriction.mechanics.calibrate.calibrate_finger`: it builds
one :class:`~fingerfriction.mechanics.calibrate.CalibrationTrial` per analysed trial of
the subject from what ``fingerfriction analyze`` wrote (``frames.parquet``: ``x_mm`` and
the contact regions ``a1, b1, ...`` per frame; ``forces.parquet``: the absolute normal
force ``F_N_abs_N`` on the 0.01 mm position grid; ``status.json``: the calibrated pixel
size), and hands them to the calibration.

Frames used: a finite ``x_mm``, no flag, no region cut by the field of view
(``clipped``), at least one region, and a normal force at that position. The contact
tolerance of a trial is its analysis' ``contact_tol_px`` (default 3 px) times its
calibrated ``mm_per_px`` (0.070 mm when the status has none); its ``min_gap_px`` and
``min_region_px`` (the video's cleanup) are applied to the model's regions as well.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .._check import check_option
from ..mechanics import FingerParams, get_subject
from ..mechanics.bem import GEOMETRIC_TOL
from ..mechanics.calibrate import (
    CalibrationError,
    CalibrationTrial,
    FingerCalibration,
    calibrate_finger,
)
from ..mechanics.fe import FE_SUBJECTS, FEFingerParams
from ..mechanics.fe.calibration import FECalibrationOptions, calibrate_fe_finger
from ..predict.defaults import load_params
from ..study.store import ResultsStore
from ..surfaces import surface_from_spec

__all__ = ["trials_from_results", "calibrate_results", "HeldOutCalibration", "calibrate_held_out",
           "FINGER_FAMILIES", "FRICTION_STEP", "fitted_friction"]

#: The finger families a calibration can fit: the plane-strain half-space
#: (:func:`~fingerfriction.mechanics.calibrate.calibrate_finger`) and the layered FE finger
#: (:func:`~fingerfriction.mechanics.fe.calibration.calibrate_fe_finger`).
FINGER_FAMILIES = ("halfspace", "fe")

#: The FE finger's sliding friction is the fit's flat-ground ``mu`` rounded to this step: the
#: patch moves ~0.46 mm per unit of ``mu`` (docs/mechanics-fe.md), so rounding moves it by at
#: most ~0.012 mm, and studies whose fits land near the same coefficient share the FE tables.
FRICTION_STEP = 0.05

log = logging.getLogger(__name__)


def _video_px(run: dict, name: str, default: float) -> float:
    """A pixel setting of the run's video analysis (``run.json`` ``parameters.video``)."""
    params = run.get("parameters") or {}
    v = (params.get("video") or {}).get(name) if isinstance(params, dict) else None
    try:
        v = float(v)
    except (TypeError, ValueError):
        return default
    return v if math.isfinite(v) and v >= 0 else default


def _mm_per_px(status: dict) -> float | None:
    info = status.get("info") or {}
    for key in ("video", None):
        d = info.get(key) if key else info
        if isinstance(d, dict) and "mm_per_px" in d:
            try:
                v = float(d["mm_per_px"])
            except (TypeError, ValueError):
                return None
            return v if math.isfinite(v) and v > 0 else None
    return None


def _trusted_positions(fr) -> np.ndarray:
    """x(t) in mm from a per-frame table, NaN where the frame is flagged or a contact
    region is clipped by the field of view."""
    x = fr["x_mm"].to_numpy(float).copy()
    bad = np.zeros(len(fr), dtype=bool)
    if "flag" in fr.columns:
        bad |= fr["flag"].fillna("").astype(str).to_numpy() != ""
    if "clipped" in fr.columns:
        bad |= fr["clipped"].to_numpy(bool)
    x[bad] = np.nan
    return x


def _measured_load(fo, x: np.ndarray) -> tuple[np.ndarray | None, str]:
    """The absolute normal force in N at the positions ``x`` (mm), from a per-position
    table; ``(None, why)`` when the trial has none."""
    if "F_N_abs_N" not in fo.columns:
        return None, ("forces.parquet has no F_N_abs_N (analysed by an older version: re-run analyze, "
                      "or give a load)")
    fx = fo["x_mm"].to_numpy(float)
    fn = fo["F_N_abs_N"].to_numpy(float)
    ok = np.isfinite(fx) & np.isfinite(fn)
    if not ok.any():
        return None, "no absolute normal force (F_N_abs_N is NaN): give a load"
    return np.interp(x, fx[ok], fn[ok], left=np.nan, right=np.nan), ""


def trials_from_results(results: str | os.PathLike, subject, *, load: float | None = None,
                        surfaces=None) -> tuple[list[CalibrationTrial], list[tuple[str, str]]]:
    """The subject's analysed trials as calibration inputs.

    Parameters
    ----------
    results : path-like
        Results folder of ``fingerfriction analyze``.
    subject : str or int
        Subject label as in the study's manifest.
    load : float, optional
        Assume this constant normal force (N) instead of the measured ``F_N_abs_N`` (for
        studies without an absolute normal force; the modulus is then relative to it).
    surfaces : iterable of str, optional
        Use only these surfaces (e.g. five of six for leave-one-surface-out).

    Returns
    -------
    trials : list of CalibrationTrial
    skipped : list of (trial id, reason)
        Trials of the subject that were not used, and why.

    Raises
    ------
    ValueError
        Not a results folder, or the subject has no trial in it (naming the subjects it has).
    """
    store = ResultsStore(results)
    run = store.read_run()
    label = str(subject)
    known = sorted({str(m.get("subject")) for m in run.get("trials", [])})
    mine = [m for m in run.get("trials", []) if str(m.get("subject")) == label]
    if not mine:
        raise ValueError(f"{os.fspath(results)!r}: no trial of subject {label!r}; the results have subjects "
                         f"{', '.join(known) or 'none'}")
    if load is not None and not (isinstance(load, (int, float)) and math.isfinite(load) and load > 0):
        raise ValueError(f"load must be a positive normal force in N, got {load!r}")
    keep = None if surfaces is None else {str(s) for s in surfaces}
    specs = run.get("surfaces", {})
    tol_px = _video_px(run, "contact_tol_px", 3.0) or 3.0
    gap_px = _video_px(run, "min_gap_px", 0.0)
    region_px = _video_px(run, "min_region_px", 0.0)
    trials, skipped = [], []
    for m in mine:
        tid = str(m["id"])
        if keep is not None and str(m.get("surface")) not in keep:
            continue
        st = store.status(tid) or {}
        if st.get("status") != "ok":
            why = f"{st.get('status', 'no status')}: {st.get('reason', '')}".strip(": ")
            skipped.append((tid, f"not analysed ({why})"))
            continue
        try:
            surf = surface_from_spec(specs[m["surface"]])
            at = store.read_trial(m, status=st)
            fr, fo = at.frames, at.forces
            x = _trusted_positions(fr)
            reg = at.regions
            if load is not None:
                F = np.full(x.size, float(load))
            else:
                F, why = _measured_load(fo, x)
                if F is None:
                    skipped.append((tid, why))
                    continue
            mmpp = _mm_per_px(st)
            px = mmpp if mmpp is not None else GEOMETRIC_TOL / 3.0
            tol = tol_px * mmpp if mmpp is not None else GEOMETRIC_TOL
            t = CalibrationTrial(surface=surf, x=x, regions=reg, load=F, label=tid, tol=tol,
                                 min_gap=gap_px * px, min_region=region_px * px)
        except (KeyError, ValueError, OSError) as exc:
            skipped.append((tid, f"unreadable: {' '.join(str(exc).split())}"))
            continue
        if not t.usable().any():
            skipped.append((tid, "no usable frame (position, normal force and a contact region)"))
            continue
        trials.append(t)
    for tid, why in skipped:
        log.warning("trial %s not used for the calibration: %s", tid, why)
    return trials, skipped


def fitted_friction(results: str | os.PathLike, subject) -> tuple[float | None, str]:
    """``(mu, '')``: the subject's flat-ground ``mu`` of the study's fit (the load-consistent
    variant's) rounded to :data:`FRICTION_STEP`; ``(None, why)`` when the study has no fit."""
    try:
        mu = float(load_params(results, str(subject), model="load").mu)
    except ValueError as exc:
        return None, " ".join(str(exc).split())
    if not (math.isfinite(mu) and mu >= 0):
        return None, f"the fit's mu of subject {subject} is {mu!r}"
    return round(round(mu / FRICTION_STEP) * FRICTION_STEP, 6), ""


def _fe_initial(subject, initial, friction, results) -> tuple[FEFingerParams, list[str]]:
    """The FE calibration's starting finger (default: the subject's FE default, else subject
    1's) with its sliding friction: ``friction``, else the fit's (:func:`fitted_friction`)."""
    notes = []
    if initial is None:
        initial = FE_SUBJECTS.get(str(subject), FE_SUBJECTS["1"])
    if not isinstance(initial, FEFingerParams):
        raise TypeError(f"an FE calibration starts from an FEFingerParams, got {type(initial).__name__}")
    if friction is None:
        friction, why = fitted_friction(results, subject)
        if friction is None:
            friction = 0.0
            notes.append(f"frictionless FE finger: no fitted mu for subject {subject} ({why}); run "
                         "'fingerfriction fit' first or give the friction")
    return dataclasses.replace(initial, friction=float(friction)), notes


def calibrate_results(results: str | os.PathLike, subject, *, initial=None, options=None,
                      load: float | None = None, surfaces=None, model: str = "halfspace",
                      friction: float | None = None) -> FingerCalibration:
    """Calibrate the finger of ``subject`` from a results folder.

    Parameters
    ----------
    results : path-like
        Results folder of ``fingerfriction analyze``.
    subject : str or int
        Subject label.
    initial : FingerParams or FEFingerParams, optional
        Starting finger (default: the subject's default finger of the family, 1 or 2 when
        the label is one of them, else subject 1's).
    options : CalibrationOptions or FECalibrationOptions, optional
    load : float, optional
        Assumed constant normal force in N (default: the measured ``F_N_abs_N``); the
        result is flagged.
    surfaces : iterable of str, optional
        Calibrate on these surfaces only.
    model : {'halfspace', 'fe'}
        The finger family (:data:`FINGER_FAMILIES`): the half-space finger, or the layered
        FE finger (through its surrogate of cached FE tables, ``docs/mechanics-fe.md``).
    friction : float, optional
        FE family: the sliding friction coefficient of the finger's contact (default: the
        study's fitted flat-ground ``mu``, :func:`fitted_friction`; frictionless, flagged,
        when the study has no fit).

    Returns
    -------
    FingerCalibration

    Raises
    ------
    CalibrationError
        Too few usable trials or frames (the message names the skipped trials' reasons).
    """
    check_option("model", model, FINGER_FAMILIES)
    trials, skipped = trials_from_results(results, subject, load=load, surfaces=surfaces)
    notes: list[str] = []
    if model == "fe":
        initial, notes = _fe_initial(subject, initial, friction, results)
    elif initial is None:
        try:
            initial = get_subject(int(str(subject)))
        except ValueError:
            initial = get_subject(1)
    try:
        if model == "fe":
            res = calibrate_fe_finger(trials, initial, options=options or FECalibrationOptions())
        else:
            res = calibrate_finger(trials, initial, options=options)
    except CalibrationError as exc:
        why = ""
        if skipped:
            why = f"; skipped: {skipped[0][0]}: {skipped[0][1]}"
            why += f" (and {len(skipped) - 1} more)" if len(skipped) > 1 else ""
        raise CalibrationError(f"subject {subject}: {exc}{why}") from None
    res.finger = dataclasses.replace(res.finger, name=f"subject {subject} (calibrated)")
    res.flags.extend(notes)
    if load is not None:
        res.flags.append(f"normal force assumed constant at {load:g} N (no measured F_N): the modulus is "
                         "relative to that load")
    if skipped:
        res.flags.append(f"{len(skipped)} trial(s) of subject {subject} not used (first: {skipped[0][0]}: "
                         f"{skipped[0][1]})")
    return res


@dataclass
class HeldOutCalibration:
    """Each subject's finger calibrated without each surface (:func:`calibrate_held_out`).

    Attributes
    ----------
    calibrations : dict
        ``(held-out surface, subject) -> FingerCalibration`` (on the other surfaces).
    errors : dict
        ``(held-out surface, subject) -> message`` where no finger could be calibrated.
    """

    calibrations: dict = field(default_factory=dict)
    errors: dict = field(default_factory=dict)

    def fingers(self) -> dict[str, dict]:
        """``{held-out surface: {subject: finger}}`` of the successful calibrations (the
        ``calibrated_fingers`` of :func:`fingerfriction.pipeline.validation.validate_results`)."""
        out: dict[str, dict[str, FingerParams]] = {}
        for (surface, subject), res in self.calibrations.items():
            if res.success:
                out.setdefault(surface, {})[subject] = res.finger
        return out


def calibrate_held_out(results: str | os.PathLike, *, subjects=None, options=None,
                       progress: Callable[[int, int, str], None] | None = None,
                       model: str = "halfspace") -> HeldOutCalibration:
    """For leave-one-surface-out: each subject's finger calibrated on all surfaces but one.

    Parameters
    ----------
    results : path-like
        Results folder of ``fingerfriction analyze``.
    subjects : iterable of str, optional
        Default: every subject of the results.
    options : CalibrationOptions or FECalibrationOptions, optional
        For the FE family, default ``FECalibrationOptions(verify=False)``: the held-out
        surface is predicted by the exact FE finger anyway, and the five calibrations of a
        subject share one grid of FE tables (``docs/mechanics-fe.md``).
    progress : callable, optional
        ``progress(done, total, label)`` after each calibration.
    model : {'halfspace', 'fe'}
        The finger family (:func:`calibrate_results`).

    Returns
    -------
    HeldOutCalibration
        A calibration that raises :class:`CalibrationError` or does not succeed is recorded
        in ``errors`` / with ``success=False``, and the others go on.
    """
    run = ResultsStore(results).read_run()
    by_subject: dict[str, set] = {}
    for m in run.get("trials", []):
        by_subject.setdefault(str(m.get("subject")), set()).add(str(m.get("surface")))
    chosen = sorted(by_subject) if subjects is None else [str(s) for s in subjects]
    for s in chosen:
        if s not in by_subject:
            raise ValueError(f"{os.fspath(results)!r}: no trial of subject {s!r}; the results have subjects "
                             f"{', '.join(sorted(by_subject)) or 'none'}")
    check_option("model", model, FINGER_FAMILIES)
    if model == "fe" and options is None:
        options = FECalibrationOptions(verify=False)
    jobs = [(surf, s) for s in chosen for surf in sorted(by_subject[s])]
    out = HeldOutCalibration()
    for k, (surf, s) in enumerate(jobs, start=1):
        others = sorted(by_subject[s] - {surf})
        try:
            res = calibrate_results(results, s, options=options, surfaces=others, model=model)
            out.calibrations[(surf, s)] = res
            if not res.success:
                out.errors[(surf, s)] = res.message
        except CalibrationError as exc:
            out.errors[(surf, s)] = str(exc)
        if progress is not None:
            progress(k, len(jobs), f"subject {s} without {surf}")
    return out
