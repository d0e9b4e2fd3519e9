"""The study pipeline's orchestration: every trial of a study through
:func:`~fingerfriction.study.trial.process_trial`, in parallel on Dask, into a resumable
results store, with a run record.

:func:`analyze` runs the trials on a ``dask.distributed`` cluster (a
:class:`~distributed.LocalCluster` of one single-threaded process per core by default, or
an existing scheduler given by address), and the client writes each result into the
:class:`~fingerfriction.study.store.ResultsStore` as it arrives. Finished trials are
skipped on the next run unless ``force=True``; a trial that fails is recorded with a
one-line reason and the others go on.
"""

from __future__ import annotations

import logging
import os
import platform
import sys
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

import dask
from distributed import Client, LocalCluster, as_completed

from .. import __version__
from .._outputs import check_output_dir
from .._progress import ProgressBar
from .check import check_files, check_study
from .manifest import Study, TrialRecord, resolve_path
from .params import AnalysisParams
from .selfcheck import synchronise_study
from .store import TRIAL_FORMAT, ResultsStore, now, params_digest, sha256_file
from .trial import TrialInput, one_line, process_trial

__all__ = ["TrialOutcome", "AnalyzeResult", "TrialPlan", "AnalysisPlan", "StudyCheckError", "plan_analysis",
           "analyze", "trial_entry"]

logger = logging.getLogger(__name__)

_LABELS = ("subject", "surface", "speed_mm_s", "repetition")


#: Packages whose versions go into the run record.
_VERSIONED = (
    "fingerfriction", "numpy", "scipy", "pandas", "pyarrow", "dask", "distributed",
    "opencv-python-headless", "scikit-image", "av", "tifffile", "h5py", "nptdms",
    "matplotlib", "jinja2",
)



@dataclass(frozen=True)
class TrialOutcome:
    """What happened to one trial in :func:`analyze` (passed to the callback).

    ``status`` is ``'ok'``, ``'failed'`` or ``'skipped'``; ``reason`` is the one-line
    reason of a failure (empty otherwise); ``elapsed_s`` the processing time in s.
    """

    trial_id: str
    status: str
    reason: str = ""
    elapsed_s: float = 0.0


@dataclass(frozen=True)
class AnalyzeResult:
    """Summary of an :func:`analyze` run.

    Attributes
    ----------
    results : Path
        The results folder.
    n_trials, n_computed, n_skipped, n_failed : int
        Trials in the study; computed OK in this run; skipped (already finished);
        failed in this run.
    failures : tuple of (str, str)
        ``(trial_id, reason)`` of each failure of this run.
    elapsed_s : float
        Wall time of the run in s.
    compute_s : float
        Wall time in s from the first trial submitted to the last result written (the run
        without connecting to or starting the cluster).
    scheduler : str
        Scheduler address used (or ``'local'`` for a LocalCluster started here).
    n_workers : int
        Number of workers that ran the trials.
    plan : tuple of TrialPlan
        What was decided for each trial before the run, and why.
    sync : dict
        The synchronisation of this run's trials (:meth:`.selfcheck.SyncOutcome.record`):
        the mode and each trial's measured video-force offset; empty with
        ``sync='manifest'``.
    """

    results: Path
    n_trials: int
    n_computed: int
    n_skipped: int
    n_failed: int
    failures: tuple[tuple[str, str], ...]
    elapsed_s: float
    scheduler: str
    n_workers: int
    compute_s: float = 0.0
    plan: tuple = ()
    sync: dict = field(default_factory=dict)

    @property
    def success(self) -> bool:
        """True if every trial of the study is finished OK."""
        return self.n_failed == 0 and self.n_computed + self.n_skipped == self.n_trials



def _run_trial(trial: TrialInput, params: dict) -> dict:
    """Dask task: process one trial, never raise; return tables or a one-line reason."""
    t0 = time.perf_counter()
    c0 = time.process_time()  # CPU of this worker process (all its threads)
    inputs: dict[str, dict] = {}
    try:
        for key in ("video", "force"):
            rel = getattr(trial.record, key).path
            p = trial.path(rel, f"{key}.path")
            st = p.stat()
            inputs[key] = {"path": rel, "sha256": sha256_file(p), "bytes": st.st_size,
                           "mtime_ns": st.st_mtime_ns}
        res = process_trial(trial, AnalysisParams(**params))
        return {"ok": True, "frames": res.frames, "forces": res.forces, "info": res.info,
                "inputs": inputs, "elapsed_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0}
    except Exception as exc:  # a failing trial is recorded, the others go on
        logger.debug("trial %s failed:\n%s", trial.id, traceback.format_exc())
        return {"ok": False, "reason": one_line(exc), "inputs": inputs,
                "elapsed_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0}


# --------------------------------------------------------------------------------------
# the plan: which trials to compute, and why (the resume key)
# --------------------------------------------------------------------------------------


class StudyCheckError(ValueError):
    """The manifest has mistakes; ``problems`` lists every one (one line each)."""

    def __init__(self, manifest: Path, problems):
        self.problems = tuple(problems)
        lines = "\n".join(f"  {p}" for p in self.problems)
        super().__init__(f"{manifest}: {len(self.problems)} problem(s) in the manifest; nothing was run "
                         f"(`fingerfriction check` lists them too):\n{lines}")


@dataclass(frozen=True)
class TrialPlan:
    """What :func:`plan_analysis` decided for one trial.

    ``action`` is ``'compute'`` or ``'skip'``; ``reason`` says why: ``'new'``, ``'failed
    before'``, ``'input changed: video'``, ``'manifest entry changed: force.t0_s'``,
    ``'parameters changed: forces.window_mm'``, ``'--force'``... or ``'unchanged'``.
    """

    trial_id: str
    action: str
    reason: str


@dataclass(frozen=True)
class AnalysisPlan:
    """The trials of an :func:`analyze` run and what would be done to each."""

    study: Study
    trials: tuple
    params: dict
    params_sha256: str
    index: dict

    @property
    def todo(self) -> list[str]:
        return [p.trial_id for p in self.trials if p.action == "compute"]

    @property
    def skipped(self) -> list[str]:
        return [p.trial_id for p in self.trials if p.action == "skip"]


def trial_entry(study: Study, trial: TrialRecord) -> dict:
    """A trial's manifest entry as the resume key sees it: its fields as written (those
    left to the files absent) and its surface's spec."""
    return {**trial.to_dict(), "surface_spec": dict(study.surfaces[trial.surface])}


def _flat(d, prefix: str = "") -> dict:
    out = {}
    for k, v in (d or {}).items():
        key = f"{prefix}{k}"
        if isinstance(v, dict) and v:
            out.update(_flat(v, key + "."))
        else:
            out[key] = v
    return out


def _changed(old: dict, new: dict, limit: int = 4) -> str:
    a, b = _flat(old), _flat(new)
    keys = sorted(k for k in set(a) | set(b) if a.get(k, _MISSING) != b.get(k, _MISSING))
    more = f" (+{len(keys) - limit} more)" if len(keys) > limit else ""
    return ", ".join(keys[:limit]) + more


_MISSING = object()


def _reasons(store: ResultsStore, study: Study, t: TrialRecord, pdict: dict, pdigest: str) -> list[str]:
    """Why a trial must be computed (empty: it is finished and nothing it depends on changed)."""
    status = store.status(t.id)
    if status is None:
        return ["new"]
    if status.get("status") != "ok":
        return ["failed before"]
    d = store.trial_dir(t.id)
    if not ((d / "frames.parquet").is_file() and (d / "forces.parquet").is_file()):
        return ["results incomplete"]
    if status.get("trial_format", 1) != TRIAL_FORMAT:
        return ["results of an older format"]
    out = []
    if status.get("params_sha256") != pdigest:
        what = _changed(status.get("parameters") or {}, pdict) if status.get("parameters") else ""
        out.append(f"parameters changed: {what}" if what else "parameters changed")
    entry = status.get("entry")
    if entry is None:
        out.append("manifest entry not recorded: results of an older version")
    else:
        what = _changed(entry, trial_entry(study, t))
        if what:
            out.append(f"manifest entry changed: {what}")
    changed = _inputs_changed(Path(study.root), t, status)
    if changed:
        out.append(f"input changed: {', '.join(changed)}")
    return out


def plan_analysis(study: str | os.PathLike, out: str | os.PathLike, *, params: AnalysisParams | None = None,
                  force: bool = False, trials: Sequence[str] | None = None) -> AnalysisPlan:
    """Which trials :func:`analyze` would compute, and why; nothing is run or written.

    A trial is computed when it is new, failed before, or when anything it depends on
    changed since it was computed: its input files (size or modification time), its
    manifest entry (any field, its surface's spec included), or the resolved analysis
    parameters. ``status.json`` keeps all three.

    Raises
    ------
    StudyCheckError
        The manifest has mistakes (all listed); see :func:`~fingerfriction.study.check.check_study`.
    ValueError
        A missing study folder, an unknown trial id, a bad option.
    """
    params = params or AnalysisParams()
    pdict = params.resolved()  # every stage parameter spelled out: recorded, and decides resumption
    pdigest = params_digest(pdict)
    study_dir = Path(study)
    if not study_dir.is_dir():
        raise ValueError(f"study folder {str(study_dir)!r} does not exist or is not a folder")
    res = check_study(study_dir, files=False)
    if res.problems:
        raise StudyCheckError(res.manifest, res.problems)
    st = res.study
    selected = _select(st, trials)
    # a results folder of its own, or a new or empty one: never mixed with other files
    check_output_dir(out, marker="run.json", what="results folder")
    store = ResultsStore(out)
    plans = []
    for t in selected:
        store.trial_dir(t.id)  # validates the id before anything runs
        why = ["--force"] if force else _reasons(store, st, t, pdict, pdigest)
        plans.append(TrialPlan(t.id, "compute" if why else "skip", "; ".join(why) or "unchanged"))
    return AnalysisPlan(study=st, trials=tuple(plans), params=pdict, params_sha256=pdigest,
                        index=res.index or {})


def _versions() -> dict:
    out = {"python": sys.version.split()[0]}
    for name in _VERSIONED:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    if out.get("fingerfriction") is None:  # running from a source tree
        out["fingerfriction"] = __version__
    return out


def _select(study: Study, selected: Sequence[str] | str | None) -> list[TrialRecord]:
    """The trials to analyse, in the study's order (all by default)."""
    trials = list(study.trials)
    if not trials:
        raise ValueError(f"study {str(study.root)!r} lists no trials")
    if selected is None:
        return trials
    if isinstance(selected, str):
        selected = [selected]
    unknown = sorted(set(selected) - {t.id for t in trials})
    if unknown:
        raise ValueError(f"trials {unknown} are not in the study {str(study.root)!r}")
    return [t for t in trials if t.id in set(selected)]


def _base_record(study: Study, pdict: dict, pdigest: str) -> dict:
    """The run record's fields that do not change during the run."""
    study_dir = Path(study.root)
    manifest_path = study_dir / "manifest.json"
    return {
        "study": str(study_dir),
        "manifest_sha256": sha256_file(manifest_path) if manifest_path.is_file() else None,
        "parameters": pdict,
        "params_sha256": pdigest,
        # the x(t) estimator (also in parameters.video.position): 'hybrid' or the paper's 'cf-centroid'
        "x_estimator": pdict["video"]["position"],
        "versions": _versions(),
        "platform": {"system": platform.system(), "machine": platform.machine(),
                     "node": platform.node(), "cpu_count": os.cpu_count()},
        "surfaces": dict(study.surfaces),
        "trials": [{"id": t.id, **{k: getattr(t, k) for k in _LABELS}} for t in study.trials],
        "truth": str(study_dir / "truth") if (study_dir / "truth" / "study.json").is_file() else None,
    }


def analyze(study: str | os.PathLike, out: str | os.PathLike, *, scheduler: str | None = None,
            n_workers: int | None = None, force: bool = False, progress: bool = True,
            params: AnalysisParams | None = None, callback: Callable[[TrialOutcome], None] | None = None,
            trials: Sequence[str] | None = None) -> AnalyzeResult:
    """Analyse every trial of a study in parallel on Dask; resumable.

    Parameters
    ----------
    study : path
        The study folder (``manifest.json``, ``docs/study-format.md``).
    out : path
        The results folder (created; layout in :mod:`fingerfriction.study.store`).
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:port``). By default a
        :class:`~distributed.LocalCluster` is started with one single-threaded worker
        process per core and closed at the end. Workers must see the study folder at
        the same path; results travel back to this process, which writes them.
    n_workers : int, optional
        Workers of the LocalCluster (default: all cores, ``os.cpu_count()``); ignored
        with ``scheduler``.
    force : bool
        Recompute every trial, even finished ones (default False: skip them).
    progress : bool
        Show a rich progress bar on stderr.
    params : AnalysisParams, optional
        Analysis options (the paper's by default). Trials finished with other
        parameters are recomputed.
    callback : callable, optional
        Called in this process with a :class:`TrialOutcome` after each trial is recorded
        (and for each skipped trial). An exception raised by it stops the run; what was
        recorded so far stays.
    trials : sequence of str, optional
        Analyse only these trial ids (default: every trial of the study).

    Returns
    -------
    AnalyzeResult

    Raises
    ------
    ValueError
        A missing or invalid study, a bad option.
    """
    params = params or AnalysisParams()
    if n_workers is not None and (not isinstance(n_workers, int) or n_workers < 1):
        raise ValueError(f"n_workers must be a positive integer, got {n_workers!r}")
    if scheduler is not None and (not isinstance(scheduler, str) or not scheduler.strip()):
        raise ValueError(f"scheduler must be an address such as 'tcp://127.0.0.1:8786', got {scheduler!r}")
    plan = plan_analysis(study, out, params=params, force=force, trials=trials)
    st, pdict, pdigest = plan.study, plan.params, plan.params_sha256
    todo_trials = [st.trial(p.trial_id) for p in plan.trials]
    store = ResultsStore(out)
    raw = {"video": dict(params.video), "forces": dict(params.forces), "selfcheck": dict(params.selfcheck)}
    t_start = time.perf_counter()
    started = now()
    skipped = plan.skipped
    todo, bad = _checked_todo(st, plan)
    store.root.mkdir(parents=True, exist_ok=True)
    previous = _previous_runs(store)
    base_record = _base_record(st, pdict, pdigest)
    store.write_run({**base_record, "state": "running", "started": started, "runs": previous})

    entries = {t.id: trial_entry(st, t) for t in todo_trials}
    run = _Run(store, pdigest, callback, pdict, entries)
    bar = ProgressBar(progress, len(todo_trials), "analyze")
    try:
        run.run_all(st, skipped, bad, todo, raw, scheduler, n_workers, bar)
        run.synchronise(st, params)
    finally:
        bar.close()
        elapsed = time.perf_counter() - t_start
        this_run = run.summary(started, elapsed, force=force, n_skipped=len(skipped),
                               n_trials=len(todo_trials))
        _write_run_record(store, st, base_record, started, [*previous, this_run])

    return AnalyzeResult(results=store.root, n_trials=len(todo_trials), n_computed=run.n_ok,
                         n_skipped=len(skipped), n_failed=run.n_fail, failures=tuple(run.failures),
                         elapsed_s=elapsed, scheduler=run.scheduler, n_workers=run.n_workers,
                         compute_s=run.compute_s, plan=plan.trials, sync=run.sync)


def _checked_todo(st: Study, plan: AnalysisPlan) -> tuple[list[TrialRecord], dict[str, list[str]]]:
    """The trials to compute whose recordings match their entries, and the problems of the
    others by trial id.

    The recordings of the trials to compute are checked against their entries first (and
    the fields the manifest leaves to them read); a trial whose files do not match fails
    with the check's reason, the others go on.
    """
    checked, file_problems = check_files(st, [st.trial(i) for i in plan.todo], index=plan.index)
    bad: dict[str, list[str]] = {}
    for p in file_problems:
        bad.setdefault(p.trial, []).append(str(p))
    return [checked[i] for i in plan.todo if i in checked], bad


def _write_run_record(store: ResultsStore, st, base_record: dict, started: str, runs: list) -> None:
    """The run record at the end of a run (``runs[-1]``, complete or interrupted): every
    trial's input statistics and status as the store now holds them."""
    inputs = {}
    trial_status = {}
    for tid in (t.id for t in st.trials):
        status = store.status(tid) or {}
        inputs[tid] = status.get("inputs", {})
        trial_status[tid] = {"status": status.get("status", "not run"),
                             "reason": status.get("reason", "")}
    store.write_run({**base_record, "state": "interrupted" if runs[-1]["interrupted"] else "complete",
                     "started": started, "finished": runs[-1]["finished"], "runs": runs, "inputs": inputs,
                     "trial_status": trial_status})


class _Run:
    """The trials of one :func:`analyze` run on a Dask cluster, each result written as it
    arrives (counts, failures and timings for the run record)."""

    def __init__(self, store: ResultsStore, pdigest: str, callback, params: dict, entries: dict):
        self.store, self.pdigest, self.callback = store, pdigest, callback
        self.params, self.entries = params, entries
        self.n_ok = self.n_fail = 0
        self.failures: list[tuple[str, str]] = []
        self.ok_ids: list[str] = []
        self.sync: dict = {}
        self.scheduler, self.n_workers = "none", 0
        self.t_submit = self.t_done = None

    def run_all(self, st: Study, skipped: list[str], bad: dict[str, list[str]], todo: list[TrialRecord],
                raw: dict, scheduler: str | None, n_workers: int | None, bar: ProgressBar) -> None:
        """The trials of the run: those finished before reported as skipped, those whose files
        failed their check recorded as failed, the others (``todo``) run on Dask."""
        for tid in skipped:
            bar.advance(f"{tid} (done before)")
            if self.callback is not None:
                self.callback(TrialOutcome(tid, "skipped"))
        for tid, lines in bad.items():
            self.record(st.trial(tid), {"ok": False, "reason": "check: " + " | ".join(lines),
                                        "inputs": _input_stats(st, st.trial(tid))}, bar)
        if todo:
            study_dir = Path(st.root)
            self.on_dask([TrialInput(study_dir, t, dict(st.surfaces[t.surface])) for t in todo], raw,
                         scheduler, n_workers, bar)

    def on_dask(self, todo: list[TrialInput], raw: dict, scheduler: str | None, n_workers: int | None,
                bar: ProgressBar) -> None:
        """Start (or connect to) the cluster, run ``todo``, record each result."""
        cluster = None
        if scheduler is None:
            nw = n_workers or os.cpu_count() or 1
            # allowed-failures=0: a trial that kills its worker (a crash in a decoder)
            # is reported at once instead of being retried on, and killing, the others.
            with dask.config.set({"distributed.scheduler.allowed-failures": 0}):
                # dashboard_address=":0": a free port; None still tries 8787 and warns on the
                # console when another cluster holds it (measured with distributed 2026.8)
                cluster = LocalCluster(n_workers=nw, threads_per_worker=1, processes=True,
                                       dashboard_address=":0", silence_logs=logging.ERROR)
            client = Client(cluster)
            self.scheduler = "local"
        else:
            client = Client(scheduler, timeout="20s")
            self.scheduler = scheduler
        try:
            self.n_workers = len(client.scheduler_info().get("workers", {}))
            futures = {}
            self.t_submit = time.perf_counter()
            for t in todo:
                key = f"fingerfriction-trial-{t.id}-{self.pdigest[:12]}"
                fut = client.submit(_run_trial, t, raw, key=key, pure=False, retries=0)
                futures[fut] = t.record
            for fut in as_completed(futures):
                t = futures[fut]
                try:
                    res = fut.result()
                except Exception as exc:  # worker died (KilledWorker), cancelled, ...
                    res = {"ok": False, "reason": one_line(exc), "inputs": {}, "elapsed_s": 0.0}
                fut.release()
                self.record(t, res, bar)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()

    def synchronise(self, st: Study, params: AnalysisParams) -> None:
        """The study-level part of the consistency stage (:func:`~.selfcheck.synchronise_study`)
        on the trials computed in this run: failed or moved trials are counted and logged."""
        if not self.ok_ids:
            return
        out = synchronise_study(self.store, st, params, self.ok_ids)
        self.sync = out.record()
        for tid, reason in out.failed:
            self.n_ok -= 1
            self.n_fail += 1
            self.failures.append((tid, reason))
            logger.warning("trial %s failed: %s", tid, reason)
        for tid, line in out.warnings:
            code, _, message = line.partition(": ")
            logger.warning(f"{code} in trial %s: %s", tid, message)
        if self.t_done is not None:
            self.t_done = time.perf_counter()

    @property
    def compute_s(self) -> float:
        """Seconds from the first submission to the last result (0 when nothing ran)."""
        timed = self.t_submit is not None and self.t_done is not None
        return (self.t_done - self.t_submit) if timed else 0.0

    def summary(self, started: str, elapsed: float, *, force: bool, n_skipped: int, n_trials: int) -> dict:
        """This run's entry in the run record's ``runs``."""
        return {"started": started, "finished": now(), "elapsed_s": round(elapsed, 3),
                "compute_s": round(self.compute_s, 3),
                "scheduler": self.scheduler, "n_workers": self.n_workers, "force": bool(force),
                "computed": self.n_ok, "skipped": n_skipped, "failed": self.n_fail,
                "interrupted": self.n_ok + self.n_fail + n_skipped < n_trials,
                **({"sync": self.sync} if self.sync else {})}

    def record(self, t: TrialRecord, res: dict, bar: ProgressBar) -> None:
        """Write one trial's result (or failure) into the store; count it; report it."""
        status = {"params_sha256": self.pdigest, "parameters": self.params, "entry": self.entries.get(t.id),
                  "inputs": res.get("inputs", {}),
                  "elapsed_s": round(float(res.get("elapsed_s", 0.0)), 4),
                  "cpu_s": round(float(res.get("cpu_s", 0.0)), 4),
                  "finished": now(),
                  "labels": {k: getattr(t, k) for k in _LABELS}}
        if res["ok"]:
            self.store.write_trial(t.id, res["frames"], res["forces"], {**status, "info": res["info"]})
            self.n_ok += 1
            self.ok_ids.append(t.id)
            for c in (res["info"].get("selfcheck") or {}).get("checks", []):
                if c.get("level") == "warning":  # the console summary groups them by kind (code)
                    logger.warning(f"{c.get('code')} in trial %s: %s", t.id, c.get("message"))
            outcome = TrialOutcome(t.id, "ok", "", status["elapsed_s"])
        else:
            self.store.write_failure(t.id, res["reason"], status)
            self.n_fail += 1
            self.failures.append((t.id, res["reason"]))
            logger.warning("trial %s failed: %s", t.id, res["reason"])
            outcome = TrialOutcome(t.id, "failed", res["reason"], status["elapsed_s"])
        self.t_done = time.perf_counter()
        bar.advance(t.id if res["ok"] else f"{t.id} FAILED")
        if self.callback is not None:
            self.callback(outcome)


def _inputs_changed(study_dir: Path, trial: TrialRecord, status: dict) -> list[str]:
    """The input files (``'video'``, ``'force'``) whose size or modification time differ
    from those recorded when the trial was analysed (a cheap check: hashing every video
    again would cost as much as reading it)."""
    rec = status.get("inputs", {})
    out = []
    for key in ("video", "force"):
        r = rec.get(key) or {}
        rel = getattr(trial, key).path
        try:
            st = resolve_path(study_dir, rel, where=f"{key}.path").stat()
        except (OSError, ValueError):
            out.append(key)
            continue
        if r.get("path") != rel or st.st_size != r.get("bytes") or st.st_mtime_ns != r.get("mtime_ns"):
            logger.info("trial %s: %s changed since it was analysed", trial.id, rel)
            out.append(key)
    return out


def _input_stats(study: Study, trial: TrialRecord) -> dict:
    """Size and modification time of a trial's files that exist (for a failed trial's status)."""
    out = {}
    for key in ("video", "force"):
        rel = getattr(trial, key).path
        try:
            st = study.path(rel).stat()
        except (OSError, ValueError):
            continue
        out[key] = {"path": rel, "bytes": st.st_size, "mtime_ns": st.st_mtime_ns}
    return out


def _previous_runs(store: ResultsStore) -> list:
    try:
        return list(store.read_run().get("runs", []))
    except ValueError:
        return []

