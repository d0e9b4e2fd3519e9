"""The consistency stage over a study: the video-force synchronisation, which compares
trials with each other, once :func:`~fingerfriction.pipeline.analyze.analyze` has run them
(:func:`synchronise_study`), and ``check --deep`` (:func:`deep_check`), every check
without writing anything.

Per trial, :func:`~fingerfriction.pipeline.trial.process_trial` runs the checks that need only
the trial (:func:`fingerfriction.selfcheck.check_trial`) and stores the start of its slide
in ``status.json`` (``info.selfcheck.onset``). Here the starts of a finger's trials are
compared (:func:`fingerfriction.selfcheck.estimate_offsets`); with ``sync='check'`` a
trial whose force clock is off its finger's other trials by more than ``max(2 frame
periods, 3 SE)`` fails with ``sync-offset``; with ``sync='auto'`` each trial's forces are
processed again on the measured clock, and the shift is recorded in its force history and
in the run record.
"""

from __future__ import annotations

import logging
import math
import os
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

from ..flags import Flag
from ..selfcheck import ORDER, Check, OffsetEstimate, OnsetData, estimate_offsets, scale_checks
from ..study.check import check_study
from ..study.manifest import Study
from ..study.records import Problem
from ..study.store import ResultsStore
from .params import AnalysisParams, force_params, video_options
from .trial import (
    TrialInput,
    check_trial_inputs,
    force_info,
    one_line,
    process_trial_forces,
    read_trial_forces,
    run_video,
)

__all__ = ["SyncOutcome", "synchronise_study", "sync_checks", "deep_check"]

logger = logging.getLogger(__name__)

_STATUS_KEYS = ("trial", "status", "trial_format", "reason")


@dataclass
class SyncOutcome:
    """What :func:`synchronise_study` did.

    Attributes
    ----------
    mode : str
        ``'check'``, ``'auto'`` or ``'manifest'`` (nothing measured).
    estimates : dict
        Trial id -> :class:`~fingerfriction.selfcheck.OffsetEstimate`.
    checks : dict
        Trial id -> its ``sync-offset`` :class:`~fingerfriction.selfcheck.Check`.
    failed : list of (str, str)
        Trials failed here (``sync-offset``, or their forces could not be processed on the
        measured clock) with the one-line reason.
    moved : list of (str, float)
        ``sync='auto'``: trials whose force clock moved by more than
        ``SelfCheckParams.moved_frames`` frame periods, with the shift in s.
    warnings : list of (str, str)
        Trial id, ``'code: message'`` of each warning.
    elapsed_s, cpu_s : float
        Wall and CPU time (this process) the study-level step took, s.
    """

    mode: str
    estimates: dict = field(default_factory=dict)
    checks: dict = field(default_factory=dict)
    failed: list = field(default_factory=list)
    moved: list = field(default_factory=list)
    warnings: list = field(default_factory=list)
    elapsed_s: float = 0.0
    cpu_s: float = 0.0

    def record(self) -> dict:
        """The run record's ``sync`` entry: the mode and each trial's measured offset."""
        return {
            "mode": self.mode,
            "elapsed_s": round(self.elapsed_s, 4),
            "cpu_s": round(self.cpu_s, 4),
            "trials": {
                t: {**e.to_dict(), "check": self.checks[t].to_dict() if t in self.checks else None}
                for t, e in self.estimates.items()
            },
        }


def _onsets(store: ResultsStore, ids) -> dict[str, OnsetData]:
    out = {}
    for tid in ids:
        st = store.status(tid) or {}
        if st.get("status") != "ok":
            continue
        d = ((st.get("info") or {}).get("selfcheck") or {}).get("onset")
        if d:
            out[tid] = OnsetData.from_dict(d)
    return out


def _touch_contradicts(
    e: OffsetEstimate, onset: OnsetData | None, allowed: float
) -> tuple[float, float] | None:
    """The trial's own touch-down offset against its finger's other trials, ``(offset, SE)``
    in s, when it contradicts an error found at the start of the slide: within ``allowed``
    of 0 and more than 3 combined SE from the start's offset. None otherwise (no touch-down,
    the finger's common offset not placed by touch-downs, or the two agree).

    The touch-down offset less the common offset the finger's touch-downs place
    (:func:`~fingerfriction.selfcheck.touchdown.touch_level`) is what the touch-down says of
    the trial against the others: the same quantity as the start's relative offset, measured
    on another event with no pre-sliding law in between. A wrong force clock moves both
    events alike; an unusual start of the slide moves only the start's reading.
    """
    if onset is None or e.level_by != "touch-down" or not math.isfinite(e.common_s):
        return None
    own = onset.touch_offset_s - e.common_s
    se = math.hypot(onset.touch_se_s, e.common_se_s if math.isfinite(e.common_se_s) else 0.0)
    if not (math.isfinite(own) and math.isfinite(se)):
        return None
    if abs(own) <= allowed and abs(e.offset_s - own) > 3.0 * math.hypot(se, e.se_s):
        return own, se
    return None


def sync_checks(
    estimates: dict, periods: dict, params, *, mode: str = "check", onsets: dict | None = None
) -> dict[str, Check]:
    """The ``sync-offset`` check of each trial from its measured offset.

    Parameters
    ----------
    estimates : dict
        Trial id -> :class:`~fingerfriction.selfcheck.OffsetEstimate`.
    periods : dict
        Trial id -> its video's frame period in s.
    params : SelfCheckParams
    mode : {'check', 'auto'}
        ``'check'``: an offset beyond ``max(sync_frames periods, 3 SE)`` is an error, unless
        the trial's own touch-down contradicts it (:func:`_touch_contradicts`): then a
        warning, the start of that slide being unusual rather than its clock wrong.
        ``'auto'``: it is applied; beyond ``moved_frames`` periods it is a warning.
    onsets : dict, optional
        Trial id -> :class:`~fingerfriction.selfcheck.OnsetData` (their touch-downs); without
        it every offset beyond the bound is an error.
    """
    onsets = onsets or {}
    out = {}
    for tid, e in estimates.items():
        period = periods.get(tid, math.nan)
        if not e.measured:
            out[tid] = Check("sync-offset", "info", math.nan, "ms", f"not measured: {e.message}")
            continue
        ms = 1e3 * e.offset_s
        allowed = max(params.sync_frames * period, 3.0 * e.se_s) if math.isfinite(period) else 3.0 * e.se_s
        text = (
            f"the force clock is {ms:+.2f} +- {1e3 * e.se_s:.2f} ms off the video's ({e.method}: {e.message})"
        )
        if mode == "auto":
            moved = abs(e.offset_s) > params.moved_frames * period
            out[tid] = Check(
                "sync-offset",
                "warning" if moved else "ok",
                ms,
                "ms",
                f"{text}; --sync auto moved the force clock by {ms:+.2f} ms ({ms / (1e3 * period):+.1f} "
                "frames): the manifest's clocks disagree"
                if moved
                else f"{text}; --sync auto applied it",
                "force.t0_s",
            )
        elif abs(e.offset_s) > allowed and (touch := _touch_contradicts(e, onsets.get(tid), allowed)):
            out[tid] = Check(
                "sync-offset",
                "warning",
                ms,
                "ms",
                f"{text}, more than max({params.sync_frames:g} frame periods, 3 SE) = "
                f"{1e3 * allowed:.2f} ms, but the trial's own touch-down puts it at "
                f"{1e3 * touch[0]:+.2f} +- {1e3 * touch[1]:.2f} ms against the finger's other trials: "
                "the start of this slide is unusual, not its clock; look at the trial",
                "force.t0_s",
            )
        elif abs(e.offset_s) > allowed:
            out[tid] = Check(
                "sync-offset",
                "error",
                ms,
                "ms",
                f"{text}, more than max({params.sync_frames:g} frame periods, 3 SE) = "
                f"{1e3 * allowed:.2f} ms: force.t0_s (or fs_hz) looks off by {ms:+.1f} ms; "
                "--sync auto applies the measured offset, --sync manifest keeps yours",
                "force.t0_s",
            )
        else:
            out[tid] = Check("sync-offset", "ok", ms, "ms", text)
    return out


def _common_warnings(estimates: dict, onsets: dict, periods: dict, params) -> dict[str, Check]:
    """``sync-common``: a finger's trials all off the video's clock by the same amount."""
    out = {}
    by_group: dict = {}
    for tid, e in estimates.items():
        if tid in onsets and math.isfinite(e.common_s) and e.method == "relative":
            by_group.setdefault(onsets[tid].group, []).append(tid)
    for group, ids in by_group.items():
        e = estimates[ids[0]]
        period = min(periods.get(t, math.inf) for t in ids)
        allowed = max(params.sync_frames * period, 3.0 * e.common_se_s)
        if abs(e.common_s) > allowed:
            msg = (
                f"all {len(ids)} trials of finger {group!r} look {1e3 * e.common_s:+.1f} +- "
                f"{1e3 * e.common_se_s:.1f} ms off the video's clock together (more than "
                f"{1e3 * allowed:.1f} ms): check the clock offsets of the session (force.t0_s, video.t0_s); "
                "--sync auto applies the measured offsets"
            )
            for t in ids:
                out[t] = Check("sync-common", "warning", 1e3 * e.common_s, "ms", msg, "force.t0_s")
    return out


def synchronise_study(
    store: ResultsStore, study: Study, params: AnalysisParams | None = None, trial_ids=None
) -> SyncOutcome:
    """Measure every analysed trial's video-force offset and act on it (``params.selfcheck``
    ``sync`` mode).

    Parameters
    ----------
    store : ResultsStore
        The results folder :func:`~fingerfriction.pipeline.analyze.analyze` wrote.
    study : Study
    params : AnalysisParams, optional
    trial_ids : iterable of str, optional
        Trials to act on (default: every finished trial); every finished trial of the
        study serves as a reference.

    Returns
    -------
    SyncOutcome
    """
    t_start, c_start = time.perf_counter(), time.process_time()
    params = params or AnalysisParams()
    P = params.selfcheck_params()
    out = SyncOutcome(P.sync)
    order = [t.id for t in study.trials]
    scale = scale_checks(_scale_items(store, study))  # the force's scale: whatever the sync mode
    if P.sync == "manifest":
        for tid in sorted(set(scale) & set(order if trial_ids is None else trial_ids), key=order.index):
            _act(store, study, params, tid, out, [scale[tid]])
        out.elapsed_s, out.cpu_s = time.perf_counter() - t_start, time.process_time() - c_start
        return out
    onsets = _onsets(store, order)
    todo = set(onsets) if trial_ids is None else set(trial_ids) & set(onsets)
    if not todo:
        out.elapsed_s, out.cpu_s = time.perf_counter() - t_start, time.process_time() - c_start
        return out
    periods = {t.id: 1.0 / t.video.fps for t in study.trials if t.video.fps}
    if P.sync == "check":
        # the trials acted on are measured against all others; ones checked before are the reference
        out.estimates = estimate_offsets(onsets.values(), mode="check", se_floor_s=P.sync_se_floor_s)
        out.checks = sync_checks(out.estimates, periods, P, mode="check", onsets=onsets)
        common = _common_warnings(out.estimates, onsets, periods, P)
    else:
        out.estimates = estimate_offsets(onsets.values(), mode="auto", se_floor_s=P.sync_se_floor_s)
        out.checks = sync_checks(out.estimates, periods, P, mode="auto")
        common = {}
    for tid in sorted(todo, key=order.index):
        _act(store, study, params, tid, out, [c for c in (common.get(tid), scale.get(tid)) if c is not None])
    out.elapsed_s, out.cpu_s = time.perf_counter() - t_start, time.process_time() - c_start
    return out


def _scale_items(store: ResultsStore, study: Study) -> dict:
    """Trial id -> ``(finger, F_N level, contact length on flat ground)`` of every finished
    trial, from its ``status.json`` (:func:`fingerfriction.selfcheck.scale_checks`)."""
    out = {}
    for rec in study.trials:
        st = store.status(rec.id) or {}
        if st.get("status") != "ok":
            continue
        figs = ((st.get("info") or {}).get("selfcheck") or {}).get("figures") or {}
        f = (figs.get("forces") or {}).get("f_n_level_n")
        length = figs.get("contact_flat_mm")
        out[rec.id] = (str(rec.subject), math.nan if f is None else float(f),
                       math.nan if length is None else float(length))
    return out


def _act(
    store: ResultsStore,
    study: Study,
    params: AnalysisParams,
    tid: str,
    out: SyncOutcome,
    others: list,
) -> None:
    """Record, fail or re-process one trial after the study-level checks: its
    synchronisation (when measured) and ``others`` (``sync-common``, ``force-scale``)."""
    status = store.status(tid) or {}
    kept = {k: v for k, v in status.items() if k not in _STATUS_KEYS}
    info = dict(kept.get("info") or {})
    sc = dict(info.get("selfcheck") or {})
    est: OffsetEstimate | None = out.estimates.get(tid)
    check = out.checks.get(tid)
    if est is not None and check is not None:
        sc["sync"] = {**est.to_dict(), "check": check.to_dict(), "mode": out.mode}
    mine = [c for c in (check, *others) if c is not None]
    extra = [c for c in mine if c.finding and c.level != "error"]
    sc["checks"] = [*sc.get("checks", []), *(c.to_dict() for c in mine)]
    info["selfcheck"] = sc
    error = next((c for c in mine if c.level == "error"), None)
    if error is not None:
        reason = f"SelfCheckError: {error.line()}"
        store.write_failure(tid, reason, {**kept, "info": info})
        out.failed.append((tid, reason))
        return
    for c in extra:
        out.warnings.append((tid, c.line()))
    if out.mode == "auto" and est is not None and est.measured and abs(est.offset_s) >= 1e-4:
        try:
            forces, finfo = _reprocess(store, study, params, tid, est, info)
        except (ValueError, OSError) as exc:
            reason = (
                f"{one_line(exc)} (after --sync auto moved the force clock by {1e3 * est.offset_s:+.2f} ms)"
            )
            store.write_failure(tid, reason, {**kept, "info": info})
            out.failed.append((tid, reason))
            return
        finfo["flags"] += [c.to_flag().to_dict() for c in extra]
        info["forces"] = finfo
        if check is not None and check.level == "warning":
            out.moved.append((tid, est.offset_s))
        store.write_trial(replace(store.read_trial(tid), forces=forces, status={**kept, "info": info}))
        return
    if extra:
        finfo = dict(info.get("forces") or {})
        finfo["flags"] = [*finfo.get("flags", []), *(c.to_flag().to_dict() for c in extra)]
        info["forces"] = finfo
    store.update_status(tid, {"info": info})


def _reprocess(
    store: ResultsStore, study: Study, params: AnalysisParams, tid: str, est: OffsetEstimate, info: dict
):
    """The trial's forces processed again with its force clock moved by the estimate."""
    rec = study.trial(tid)
    trial = TrialInput(Path(study.root), rec, dict(study.surfaces[rec.surface]))
    stored = store.read_trial(tid)
    frames = stored.frames
    record = read_trial_forces(trial.root, rec)
    old = (info.get("forces") or {}).get("history") or []
    fs = next(
        (h.get("fs_hz_used") for h in old if h.get("step") == "synchronise" and h.get("fs_hz_used")),
        record.fs_hz,
    )
    shifted = replace(record, fs_hz=float(fs), t0_s=record.t0_s + est.offset_s)
    prof = process_trial_forces(
        trial,
        frames["x_mm"].to_numpy(float),
        params=force_params(params.forces),
        regions=stored.regions,
        on_error="raise",
        record=shifted,
    )
    finfo = force_info(prof)
    kept_flags = [
        f
        for f in (info.get("forces") or {}).get("flags", [])
        if f not in finfo["flags"] and Flag.from_dict(f).code in _SELFCHECK_CODES
    ]
    finfo["flags"] += kept_flags
    finfo["history"].insert(
        0,
        {
            "step": "synchronise",
            "mode": "auto",
            "t0_s_manifest": record.t0_s,
            "t0_s_used": shifted.t0_s,
            "offset_ms": round(1e3 * est.offset_s, 4),
            "se_ms": round(1e3 * est.se_s, 4),
            "fs_hz_manifest": record.fs_hz,
            "fs_hz_used": shifted.fs_hz,
            "by": est.method,
        },
    )
    return prof.to_frame(), finfo


#: The consistency stage's flag codes (its flags among the force stage's, kept on re-processing).
_SELFCHECK_CODES = (*ORDER, "sync-offset", "sync-common", "force-scale")


def deep_check(
    path: str | os.PathLike, *, params: AnalysisParams | None = None, trials=None, progress=None
) -> tuple[list[Problem], dict]:
    """``check --deep``: every trial through the video stage and the consistency stage,
    nothing written.

    Parameters
    ----------
    path : path-like
        The study folder or its manifest.
    params : AnalysisParams, optional
    trials : iterable of str, optional
        Only these trials.
    progress : callable, optional
        Called with each trial id as it is done.

    Returns
    -------
    problems : list of Problem
        The shallow check's problems, then one per error or warning of the consistency
        checks (``kind='deep'``), naming the trial and the manifest field.
    checks : dict
        Trial id -> list of its :class:`~fingerfriction.selfcheck.Check`.
    """
    params = params or AnalysisParams()
    P = params.selfcheck_params()
    res = check_study(path)
    problems = list(res.problems)
    found: dict[str, list] = {}
    if res.study is None:
        return problems, found
    st = res.study
    shown = str(res.manifest)
    index = res.index or {}
    onsets: dict[str, OnsetData] = {}
    scale_items: dict = {}
    wanted = None if trials is None else set(trials)
    for rec in st.trials:
        if wanted is not None and rec.id not in wanted:
            continue
        trial = TrialInput(Path(st.root), rec, dict(st.surfaces[rec.surface]))
        where = f"trials[{index.get(rec.id, '?')}]"
        try:
            v = run_video(trial, video_options(params.video, rec.video.calibration_frame))
            record = read_trial_forces(trial.root, rec)
            tc = check_trial_inputs(trial, v, record, params)
        except (ValueError, OSError) as exc:
            problems.append(Problem(shown, where, one_line(exc), rec.id, "deep"))
            continue
        found[rec.id] = list(tc.checks)
        if tc.error is None:
            length = tc.figures.get("contact_flat_mm")
            f = (tc.figures.get("forces") or {}).get("f_n_level_n")
            scale_items[rec.id] = (str(rec.subject), math.nan if f is None else float(f),
                                   math.nan if length is None else float(length))
        if tc.onset is not None:
            onsets[rec.id] = tc.onset
        if progress is not None:
            progress(rec.id)
    if P.sync != "manifest" and onsets:
        periods = {t.id: 1.0 / t.video.fps for t in st.trials if t.video.fps}
        est = estimate_offsets(onsets.values(), mode="check", se_floor_s=P.sync_se_floor_s)
        for tid, c in sync_checks(est, periods, P, mode="check", onsets=onsets).items():
            found[tid].append(c)
        for tid, c in _common_warnings(est, onsets, periods, P).items():
            found[tid].append(c)
    for tid, c in scale_checks(scale_items).items():
        found[tid].append(c)
    for rec in st.trials:
        where = f"trials[{index.get(rec.id, '?')}]"
        for c in found.get(rec.id, []):
            if c.finding:
                fld = f"{where}.{c.field}" if c.field else where
                problems.append(Problem(shown, fld, f"{c.level} {c.code}: {c.message}", rec.id, "deep"))
    return problems, found
