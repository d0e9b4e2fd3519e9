"""Everything the report flags, per trial and per subject, with the reason.

One :class:`~fingerfriction.flags.Flag` per finding, the type every stage raises (level,
code, message, trial, subject, model; ``''`` where a flag is about something wider), with
``level`` one of ``"error"`` (the trial has no result), ``"warning"`` (a result to look at
before trusting it) or ``"info"`` (a known limit, said once). Flags stored by a stage keep
their level here. Sources:

* the analysis: a failed trial (``analysis-failed``), the force stage's flags
  (``status.json`` ``info.forces.flags``, e.g. ``extrapolated``, ``nan-filled``,
  ``no-absolute``, and the consistency stage's warnings), gaps in x(t) inside the tracked
  span (``position-gap``), contact regions cut by the edge of the field of view (``regions-clipped``, info);
* the fit: trials that could not be fitted or gave an unphysical fit (``fit-failed``),
  contact regions translated from the nearest frame where x(t) was extrapolated
  (``regions-translated``), mu at an end of its search grid (``mu-at-bound``), a failed
  out-of-sample validation (``loso-failed``), and every flag the fit itself recorded for
  the model variant it used, with ``model-rejected`` (an error about the whole study) when
  no variant passes the fit's bars.

The flags of the other variants, fitted for comparison, are not findings about the study:
:func:`comparison_notes` lists them, as notes on the comparison.
"""

from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np

from ..flags import LEVELS, Flag
from ..study.results import AnalysedTrial, FitResult
from .data import ReportData

__all__ = ["LEVELS", "collect_flags", "comparison_notes", "flagged_trials", "group_flags", "position_gaps"]

#: Minimum run of frames without x(t) inside the tracked span reported as a gap.
MIN_GAP_FRAMES = 3


def _flag(level, code, message, *, trial=None, subject=None, model=None) -> Flag:
    return Flag(level, code, str(message), trial="" if trial is None else str(trial),
                subject="" if subject is None else str(subject), model="" if model is None else str(model))


def position_gaps(t: AnalysedTrial, *, min_frames: int = MIN_GAP_FRAMES) -> list[dict]:
    """Runs of frames without x(t) between the first and last tracked frame.

    Returns one ``{"row", "frame", "n", "x_before", "x_after"}`` per run of at least
    ``min_frames`` frames: first row of the run in the per-frame table, its frame index,
    the run's length in frames, and x(t) in mm on either side.
    """
    x = t.frames["x_mm"].to_numpy(float)
    ok = np.flatnonzero(np.isfinite(x))
    if ok.size < 2:
        return []
    gaps = []
    for k in np.flatnonzero(np.diff(ok) > min_frames):
        a, b = int(ok[k]), int(ok[k + 1])
        gaps.append({"row": a + 1, "frame": int(t.frames["frame"].iloc[a + 1]), "n": b - a - 1,
                     "x_before": float(x[a]), "x_after": float(x[b])})
    return gaps


def _gap_reasons(t: AnalysedTrial, first_row: int, n: int) -> str:
    flags = t.frames["flag"].astype(str).to_numpy()[first_row:first_row + n]
    reasons = OrderedDict()
    for f in flags:
        for part in f.split(";"):
            part = part.strip().split(":")[0]
            if part:
                reasons[part] = reasons.get(part, 0) + 1
    return ", ".join(f"{r} ({c})" for r, c in reasons.items()) or "no reason recorded"


def _trial_flags(t: AnalysedTrial) -> list[dict]:
    out = []
    missing = t.status.get("input_missing") or {}
    if missing:  # analyze kept the last results of a trial whose files are gone: say so
        out.append(_flag("warning", "input-missing",
                         f"{missing.get('reason', 'input files missing')} (since "
                         f"{missing.get('since', '?')}): these are the trial's last results, kept",
                         trial=t.id, subject=t.subject))
    info = t.info
    out += t.flags  # the force and consistency stages' flags, their level kept
    for g in position_gaps(t):
        out.append(_flag("warning", "position-gap",
                         f"x(t) missing in {g['n']} frames from frame {g['frame']} (between x = "
                         f"{g['x_before']:+.2f} and {g['x_after']:+.2f} mm): "
                         f"{_gap_reasons(t, g['row'], g['n'])}",
                         trial=t.id, subject=t.subject))
    n_clip = int((info.get("video") or {}).get("clipped_frames") or 0)
    if n_clip == 0 and "clipped" in t.frames.columns:
        n_clip = int(t.frames["clipped"].sum())
    if n_clip:
        out.append(_flag("info", "regions-clipped",
                         f"{n_clip} of {len(t.frames)} frames have a contact region cut by the edge of the "
                         "field of view: its length there is a lower bound", trial=t.id, subject=t.subject))
    if t.model is not None and "regions_translated" in t.model.columns:
        n_tr = int(t.model["regions_translated"].astype(bool).sum())
        if n_tr:
            out.append(_flag("warning", "regions-translated",
                             f"at {n_tr} positions the contact regions were translated from the nearest "
                             "tracked frame (x(t) extrapolated there)", trial=t.id, subject=t.subject))
    return out


def collect_flags(data: ReportData) -> list[Flag]:
    """Every flag of the results, most serious first, then in trial order."""
    labels = {m["id"]: m for m in data.run.get("trials", [])}
    flags: list[Flag] = []
    for tid, reason in data.failed:
        flags.append(_flag("error", "analysis-failed", reason, trial=tid,
                           subject=labels.get(tid, {}).get("subject")))
    for t in data.trials:
        flags += _trial_flags(t)
    fit = data.fit if data.fit is not None else FitResult({})
    by_id = {t.id: t for t in data.trials}
    recorded = fit.flags
    if recorded is not None:  # the fit's own flags, those of the variant it used
        flags += recorded
    else:  # a fit.json written before the fit recorded its flags
        for f in fit.failures:
            tid = f.get("trial")
            subj = by_id[tid].subject if tid in by_id else labels.get(tid, {}).get("subject")
            flags.append(_flag("warning", "fit-failed", f.get("reason", ""), trial=tid, subject=subj))
        grid = fit.mu_grid
        for s, mu in fit.mu().items():
            lo, hi = grid.get("start"), grid.get("stop")
            if lo is not None and hi is not None and (math.isclose(mu, lo) or math.isclose(mu, hi)):
                flags.append(_flag("warning", "mu-at-bound",
                                   f"mu = {mu:g} is at the end of the search grid [{lo:g}, {hi:g}]: not a "
                                   "minimum inside the grid; the true value may lie beyond it (widen the "
                                   "grid)",
                                   subject=s))
    msg = str(fit.loso.get("message") or "")
    if msg.startswith("failed"):
        flags.append(_flag("warning", "loso-failed", f"out-of-sample validation {msg}"))
    order = {lv: i for i, lv in enumerate(LEVELS)}
    trial_order = {m["id"]: i for i, m in enumerate(data.run.get("trials", []))}
    flags.sort(key=lambda f: (order[f.level], bool(f.trial), trial_order.get(f.trial, -1)))
    return flags


def comparison_notes(data: ReportData) -> list[Flag]:
    """The flags of the model variants fitted for comparison (not the one the fit used)."""
    return data.fit.notes if data.fit is not None else []


def flagged_trials(flags: list[Flag], *, levels=("error", "warning")) -> list[str]:
    """Trial ids with at least one flag of the given levels, first-seen order."""
    seen: dict[str, None] = {}
    for f in flags:
        if f.trial and f.level in levels:
            seen.setdefault(f.trial, None)
    return list(seen)


def group_flags(flags: list[Flag]) -> list[dict]:
    """Flags grouped by (level, code): ``{"level", "code", "count", "trials", "example"}``,
    most serious first; ``trials`` counts distinct trials, ``example`` is the first flag."""
    groups: OrderedDict = OrderedDict()
    for f in flags:
        g = groups.setdefault((f.level, f.code), {"level": f.level, "code": f.code, "count": 0,
                                                  "trials": set(), "example": f, "all": []})
        g["count"] += 1
        g["all"].append(f)
        if f.trial:
            g["trials"].add(f.trial)
    out = []
    for g in groups.values():
        g["n_trials"] = len(g.pop("trials"))
        out.append(g)
    return out
