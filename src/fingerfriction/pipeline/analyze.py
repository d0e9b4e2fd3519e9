"""The study pipeline's orchestration: every trial of a study through
:func:`~fingerfriction.pipeline.trial.process_trial`, in parallel on Dask, into a resumable
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
from dataclasses import dataclass, field, replace
from importlib import metadata
from pathlib import Path

import dask
from distributed import Client, LocalCluster, as_completed
from distributed.utils import get_mp_context

from .. import __version__
from .._mainguard import check_main_guard
from .._outputs import check_output_dir
from .._progress import ProgressBar
from .._workers import forkserver_context, package_environ
from ..study.check import check_files
from ..study.manifest import Study, TrialRecord
from ..study.store import ResultsStore, input_fingerprint, now, sha256_file, sha256_input
from .params import AnalysisParams
from .plan import AnalysisPlan, StudyCheckError, TrialPlan, check_out_apart, plan_analysis, trial_entry
from .selfcheck import synchronise_study
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

    ``status`` is ``'ok'``, ``'failed'``, ``'skipped'`` or ``'input missing'`` (its files are
    missing or unreadable; its last results are kept, marked); ``reason`` is the one-line
    reason of a failure or a missing input (empty otherwise); ``elapsed_s`` the processing
    time in s.
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
    input_missing : tuple of (str, str)
        ``(trial_id, reason)`` of the trials whose input files are missing or unreadable:
        their last good results are kept, marked ``input_missing`` in ``status.json``.
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
    input_missing: tuple = ()
    sync: dict = field(default_factory=dict)

    @property
    def success(self) -> bool:
        """True if every trial of the study is finished OK from its present input files
        (the command's exit status 0; 1 otherwise)."""
        return (self.n_failed == 0 and not self.input_missing
                and self.n_computed + self.n_skipped == self.n_trials)



def _run_trial(trial: TrialInput, params: dict) -> dict:
    """Dask task: process one trial, never raise; return it analysed (``trial``, an
    :class:`~fingerfriction.study.results.AnalysedTrial`) or a one-line reason."""
    t0 = time.perf_counter()
    c0 = time.process_time()  # CPU of this worker process (all its threads)
    inputs: dict[str, dict] = {}
    try:
        for key in ("video", "force"):
            rel = getattr(trial.record, key).path
            p = trial.path(rel, f"{key}.path")
            st = p.stat()
            inputs[key] = {"path": rel, "sha256": sha256_input(p), "bytes": st.st_size,
                           "mtime_ns": st.st_mtime_ns, "fingerprint": input_fingerprint(p)}
        res = process_trial(trial, AnalysisParams(**params))
        return {"ok": True, "trial": res, "inputs": inputs,
                "elapsed_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0}
    except Exception as exc:  # a failing trial is recorded, the others go on
        logger.debug("trial %s failed:\n%s", trial.id, traceback.format_exc())
        return {"ok": False, "reason": one_line(exc), "inputs": inputs,
                "elapsed_s": time.perf_counter() - t0, "cpu_s": time.process_time() - c0}


def _local_cluster_config() -> dict:
    """Dask settings of the local cluster.

    * ``allowed-failures=0``: a trial that kills its worker (a crash in a decoder) is
      reported at once instead of being retried on, and killing, the others.
    * Worker processes start from the package's ``forkserver`` (``fingerfriction._workers``),
      where the platform has one and the user's Dask configuration keeps the default
      ``spawn``.
    """
    cfg: dict = {"distributed.scheduler.allowed-failures": 0}
    method = dask.config.get("distributed.worker.multiprocessing-method", "spawn")
    if method == "spawn" and forkserver_context() is not None:
        cfg["distributed.worker.multiprocessing-method"] = "forkserver"
        with dask.config.set(cfg):
            get_mp_context()  # Dask sets its own preload list the first time: ours replaces it
        forkserver_context()
    return cfg


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
            trials: Sequence[str] | None = None, quick_resume: bool = False) -> AnalyzeResult:
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
    quick_resume : bool
        Trust the file system's fingerprint of an unchanged input instead of hashing it
        (see :func:`plan_analysis`); default False: every input is compared by content.

    Returns
    -------
    AnalyzeResult

    Raises
    ------
    ValueError
        A missing or invalid study, a bad option.
    """
    params = params or AnalysisParams()
    if n_workers is not None and (not isinstance(n_workers, int) or not 1 <= n_workers <= MAX_WORKERS):
        raise ValueError(f"n_workers must be an integer in [1, {MAX_WORKERS}], got {n_workers!r}")
    if scheduler is not None and (not isinstance(scheduler, str) or not scheduler.strip()):
        raise ValueError(f"scheduler must be an address such as 'tcp://127.0.0.1:8786', got {scheduler!r}")
    if scheduler is None:
        check_main_guard("analyze", alternative="or pass the address of a running Dask scheduler")
    study_dir, out = Path(study), Path(out)
    if not study_dir.is_dir():
        raise ValueError(f"study folder {str(study_dir)!r} does not exist or is not a folder")
    check_out_apart(study_dir, out)
    check_output_dir(out, marker="run.json", what="results folder")
    created = not out.exists()
    store = ResultsStore(out)
    try:
        with store.lock("analyze"):  # one command at a time in a results folder
            return _analyze_locked(study_dir, store, scheduler=scheduler, n_workers=n_workers, force=force,
                                   progress=progress, params=params, callback=callback, trials=trials,
                                   quick_resume=quick_resume)
    except BaseException:
        if created:  # a folder this call made and left empty (a study that could not be run)
            (out / ".lock").unlink(missing_ok=True)
            try:
                out.rmdir()
            except OSError:
                pass
        raise


#: The most worker processes :func:`analyze` starts on this machine.
MAX_WORKERS = 256


def _analyze_locked(study_dir: Path, store: ResultsStore, *, scheduler, n_workers, force, progress, params,
                    callback, trials, quick_resume) -> AnalyzeResult:
    """:func:`analyze` once it holds the results folder."""
    plan = plan_analysis(study_dir, store.root, params=params, force=force, trials=trials,
                         quick_resume=quick_resume)
    if plan.other_study is not None:  # --force on another study's results folder
        gone = store.purge({t.id for t in plan.study.trials})
        logger.warning("results folder %s held another study's results (%s): %d trial(s), fit and report "
                       "removed (--force)", store.root, plan.other_study, len(gone))
    st, pdict, pdigest = plan.study, plan.params, plan.params_sha256
    todo_trials = [st.trial(p.trial_id) for p in plan.trials]
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
    n_all = len(todo_trials) + len(plan.invalid)
    bar = ProgressBar(progress, n_all, "analyze")
    try:
        run.invalid(plan.invalid, bar)
        run.keep(plan.kept, plan.marked, bar)
        run.run_all(st, skipped, bad, todo, raw, scheduler, n_workers, bar)
        run.synchronise(st, params)
    finally:
        bar.close()
        elapsed = time.perf_counter() - t_start
        this_run = run.summary(started, elapsed, force=force, n_skipped=len(skipped), n_trials=n_all)
        _write_run_record(store, st, base_record, started, [*previous, this_run], plan.invalid)

    return AnalyzeResult(results=store.root, n_trials=n_all, n_computed=run.n_ok,
                         n_skipped=len(skipped), n_failed=run.n_fail, failures=tuple(run.failures),
                         elapsed_s=elapsed, scheduler=run.scheduler, n_workers=run.n_workers,
                         compute_s=run.compute_s, plan=plan.trials, input_missing=tuple(plan.kept),
                         sync=run.sync)


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


def _write_run_record(store: ResultsStore, st, base_record: dict, started: str, runs: list,
                      invalid: tuple = ()) -> None:
    """The run record at the end of a run (``runs[-1]``, complete or interrupted): every
    trial's input statistics and status as the store now holds them, and the entries that
    could not be run (``invalid``: an id too long to name a folder...)."""
    inputs = {}
    trial_status = {}
    for tid in (t.id for t in st.trials):
        status = store.status(tid) or {}
        inputs[tid] = status.get("inputs", {})
        trial_status[tid] = {"status": status.get("status", "not run"),
                             "reason": status.get("reason", "")}
        if status.get("input_missing"):
            trial_status[tid]["input_missing"] = status["input_missing"]
    store.write_run({**base_record, "state": "interrupted" if runs[-1]["interrupted"] else "complete",
                     "started": started, "finished": runs[-1]["finished"], "runs": runs, "inputs": inputs,
                     "trial_status": trial_status,
                     "invalid_entries": [{"trial": tid, "reason": why} for tid, why in invalid]})


class _Run:
    """The trials of one :func:`analyze` run on a Dask cluster, each result written as it
    arrives (counts, failures and timings for the run record)."""

    def __init__(self, store: ResultsStore, pdigest: str, callback, params: dict, entries: dict):
        self.store, self.pdigest, self.callback = store, pdigest, callback
        self.params, self.entries = params, entries
        self.n_ok = self.n_fail = self.n_kept = 0
        self.failures: list[tuple[str, str]] = []
        self.ok_ids: list[str] = []
        self.sync: dict = {}
        self.scheduler, self.n_workers = "none", 0
        self.t_submit = self.t_done = None

    def invalid(self, invalid: tuple, bar: ProgressBar) -> None:
        """Entries that cannot be run (an id too long to name a folder): failed, the others go on."""
        for tid, reason in invalid:
            self.n_fail += 1
            self.failures.append((tid, reason))
            logger.warning("trial %s failed: %s", tid, reason)
            bar.advance(f"{tid} FAILED")
            if self.callback is not None:
                self.callback(TrialOutcome(tid, "failed", reason))

    def keep(self, kept: list, marked: list[str], bar: ProgressBar) -> None:
        """Trials whose inputs are missing: their results kept, marked; the skipped ones
        unmarked (their inputs are back, unchanged)."""
        for tid, reason in kept:
            self.store.mark_input_missing(tid, reason)
            self.n_kept += 1
            logger.warning("trial %s: %s; its last results are kept, marked 'input missing'", tid, reason)
            bar.advance(f"{tid} (input missing)")
            if self.callback is not None:
                self.callback(TrialOutcome(tid, "input missing", reason))
        for tid in marked:  # skipped: their inputs are back, unchanged
            self.store.mark_input_missing(tid, None)

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
        # the local cluster's settings hold while it runs: a worker killed by its trial is
        # started again by its nanny, with the same start method
        with dask.config.set(_local_cluster_config()):
            self._on_dask(todo, raw, scheduler, n_workers, bar)

    def _on_dask(self, todo: list[TrialInput], raw: dict, scheduler: str | None, n_workers: int | None,
                 bar: ProgressBar) -> None:
        cluster = None
        if scheduler is None:
            nw = n_workers or os.cpu_count() or 1
            # dashboard_address=":0": a free port; None still tries 8787 and warns on the
            # console when another cluster holds it (measured with distributed 2026.8)
            # env: the caller's package variables, which a forked worker would not have
            cluster = LocalCluster(n_workers=nw, threads_per_worker=1, processes=True,
                                   dashboard_address=":0", silence_logs=logging.ERROR,
                                   env=package_environ())
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
                "input_missing": self.n_kept,
                "interrupted": self.n_ok + self.n_fail + n_skipped + self.n_kept < n_trials,
                **({"sync": self.sync} if self.sync else {})}

    def record(self, t: TrialRecord, res: dict, bar: ProgressBar) -> None:
        """Write one trial's result (or failure) into the store; count it; report it."""
        status = {"params_sha256": self.pdigest, "parameters": self.params, "entry": self.entries.get(t.id),
                  "inputs": res.get("inputs", {}),
                  "elapsed_s": round(float(res.get("elapsed_s", 0.0)), 4),
                  "cpu_s": round(float(res.get("cpu_s", 0.0)), 4),
                  "finished": now(),
                  "labels": {k: getattr(t, k) for k in _LABELS}}
        try:
            if res["ok"]:
                at = res["trial"]
                self.store.write_trial(replace(at, status={**status, "info": at.info}))
            else:
                self.store.write_failure(t.id, res["reason"], status)
        except OSError as exc:  # a full disk, a name too long for the file system: this trial only
            res = {"ok": False, "reason": f"cannot write its results: {one_line(exc)}"}
            logger.warning("trial %s: %s", t.id, res["reason"])
        if res["ok"]:
            self.n_ok += 1
            self.ok_ids.append(t.id)
            for c in (res["trial"].info.get("selfcheck") or {}).get("checks", []):
                if c.get("level") == "warning":  # the console summary groups them by kind (code)
                    logger.warning(f"{c.get('code')} in trial %s: %s", t.id, c.get("message"))
            outcome = TrialOutcome(t.id, "ok", "", status["elapsed_s"])
        else:
            self.n_fail += 1
            self.failures.append((t.id, res["reason"]))
            logger.warning("trial %s failed: %s", t.id, res["reason"])
            outcome = TrialOutcome(t.id, "failed", res["reason"], status["elapsed_s"])
        self.t_done = time.perf_counter()
        bar.advance(t.id if res["ok"] else f"{t.id} FAILED")
        if self.callback is not None:
            self.callback(outcome)


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

