"""The plan of an ``analyze`` run: which trials of a study to compute, and why (the resume
key), before anything runs (``analyze --dry-run`` prints it).

A trial is computed when it is new, failed before, when its stored tables are not the ones
written, or when anything it depends on changed since: the content of its input files
(SHA-256), its manifest entry, the resolved analysis parameters. A finished trial whose
inputs are missing or unreadable is kept, its results marked. The results folder must be
apart from the study and belong to it (:func:`plan_analysis`).
"""

from __future__ import annotations

import logging
import os
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

from .._outputs import check_output_dir
from ..study.check import check_study
from ..study.manifest import Study, TrialRecord
from ..study.store import (
    TRIAL_FORMAT,
    ResultsStore,
    input_fingerprint,
    params_digest,
    sha256_file,
    sha256_input,
)
from .params import AnalysisParams

__all__ = ["StudyCheckError", "TrialPlan", "AnalysisPlan", "plan_analysis", "trial_entry"]

logger = logging.getLogger(__name__)


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

    ``action`` is ``'compute'``, ``'skip'`` or ``'keep'``; ``reason`` says why: ``'new'``,
    ``'failed before'``, ``'input changed: video'``, ``'manifest entry changed:
    force.t0_s'``, ``'parameters changed: forces.window_mm'``, ``'stored results damaged:
    forces.parquet ...'``, ``'--force'``... or ``'unchanged'``. ``'keep'``: a finished trial
    whose input files are missing or unreadable (``'input missing: video (no such file)'``);
    it cannot be computed, and its last results stay, marked.
    """

    trial_id: str
    action: str
    reason: str
    marked: bool = False  # its results carry an input-missing mark


@dataclass(frozen=True)
class AnalysisPlan:
    """The trials of an :func:`analyze` run and what would be done to each."""

    study: Study
    trials: tuple
    params: dict
    params_sha256: str
    index: dict
    invalid: tuple = ()
    other_study: str | None = None  # the study whose results the folder holds (with --force: removed)

    @property
    def todo(self) -> list[str]:
        return [p.trial_id for p in self.trials if p.action == "compute"]

    @property
    def skipped(self) -> list[str]:
        return [p.trial_id for p in self.trials if p.action == "skip"]

    @property
    def marked(self) -> list[str]:
        """Skipped trials whose results are marked ``input_missing`` (their inputs are back)."""
        return [p.trial_id for p in self.trials if p.action == "skip" and p.marked]

    @property
    def kept(self) -> list[tuple[str, str]]:
        """``(trial_id, reason)`` of the trials whose inputs are missing (results kept)."""
        return [(p.trial_id, p.reason) for p in self.trials if p.action == "keep"]


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


def _first_reasons(store: ResultsStore, study: Study, t: TrialRecord, pdict: dict, pdigest: str,
                   force: bool) -> tuple[list[str], dict | None]:
    """Why a trial must be computed, from what costs nothing to check (its status, stored
    tables, parameters, manifest entry); and its status when it finished OK (its inputs'
    content is compared afterwards, :func:`_input_changes`)."""
    status = store.status(t.id)
    if status is None:
        return ["new"], None
    if status.get("status") != "ok":
        return ["failed before"], None
    if status.get("trial_format", 1) != TRIAL_FORMAT:
        return ["results of an older format"], None
    damaged = store.verify_tables(t.id, status)
    if damaged:
        return [f"stored results damaged: {damaged}"], None
    if force:
        return ["--force"], status
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
    return out, status


def _input_paths(study: Study, t: TrialRecord) -> dict:
    """``{'video': Path, 'force': Path}`` of a trial's inputs (resolved inside the study)."""
    return {key: study.path(getattr(t, key).path, where=f"{key}.path") for key in ("video", "force")}


def _hash_or_why(path: Path) -> tuple[str | None, str | None]:
    """``(sha256, None)`` of an input, or ``(None, why it cannot be read)``."""
    if not path.exists():
        return None, "no such file or folder"
    if not (path.is_file() or path.is_dir()):
        return None, "not a regular file"
    try:
        return sha256_input(path), None
    except OSError as exc:
        return None, f"cannot be read ({exc.strerror or type(exc).__name__})"
    except ValueError as exc:
        return None, " ".join(str(exc).split())


def _hash_inputs(paths: list[Path], known: dict | None = None, n_threads: int | None = None) -> dict:
    """``{path: (sha256 or None, why not)}``: the inputs hashed on a few threads (hashlib
    releases the GIL: two threads halve the wall time on two cores). ``known``
    (``--quick-resume``): ``{path: (fingerprint, sha256)}`` recorded when analysed; an input
    whose fingerprint is unchanged is given that digest, unread."""
    if not paths:
        return {}
    known = known or {}

    def one(p: Path):
        if p in known:
            try:
                if input_fingerprint(p) == known[p][0]:
                    return known[p][1], None
            except (OSError, ValueError):
                pass
        return _hash_or_why(p)

    n = n_threads or min(4, os.cpu_count() or 1)
    with ThreadPoolExecutor(max_workers=n) as pool:
        return dict(zip(paths, pool.map(one, paths), strict=True))


def _input_changes(status: dict, paths: dict, hashes: dict, study: Study, t: TrialRecord
                   ) -> tuple[list[str], list[str]]:
    """``(changed, missing)``: the inputs whose content (SHA-256) differs from the one
    analysed, and those missing or unreadable (``'video (no such file or folder)'``)."""
    rec = status.get("inputs", {})
    changed, missing = [], []
    for key, p in paths.items():
        digest, why = hashes[p]
        if digest is None:
            missing.append(f"{key} ({getattr(t, key).path}: {why})")
        elif (rec.get(key) or {}).get("sha256") != digest or (rec.get(key) or {}).get("path") != \
                getattr(t, key).path:
            logger.info("trial %s: %s changed since it was analysed", t.id, getattr(t, key).path)
            changed.append(key)
    return changed, missing


def plan_analysis(study: str | os.PathLike, out: str | os.PathLike, *, params: AnalysisParams | None = None,
                  force: bool = False, trials: Sequence[str] | None = None,
                  quick_resume: bool = False) -> AnalysisPlan:
    """Which trials :func:`analyze` would compute, and why; nothing is run or written.

    A trial is computed when it is new, failed before, when its stored tables are not the
    ones written (size and SHA-256, or unreadable), or when anything it depends on changed
    since it was computed: the content of its input files (SHA-256), its manifest entry
    (any field, its surface's spec included), or the resolved analysis parameters.
    ``status.json`` keeps all of them. A finished trial whose input files are missing or
    unreadable is kept (``'keep'``): it cannot be computed, and its results are not lost.

    ``quick_resume=True`` (``analyze --quick-resume``) trusts an input whose fingerprint
    (size, modification and status-change times, inode:
    :func:`~fingerfriction.study.digests.input_fingerprint`) is the one recorded, instead of
    hashing it; any write changes the status-change time, so an edit is still seen on
    local file systems, but not on one that does not keep that time. Hashing costs about
    1.5 s per GB of inputs (``benchmarks/integrity.py``).

    Raises
    ------
    StudyCheckError
        The manifest has mistakes (all listed); see :func:`~fingerfriction.study.check.check_study`.
    ValueError
        A missing study folder, an unknown trial id, a bad option, a results folder inside
        the study or holding another study's results (unless ``force``).
    """
    params = params or AnalysisParams()
    pdict = params.resolved()  # every stage parameter spelled out: recorded, and decides resumption
    pdigest = params_digest(pdict)
    study_dir = Path(study)
    if not study_dir.is_dir():
        raise ValueError(f"study folder {str(study_dir)!r} does not exist or is not a folder")
    check_out_apart(study_dir, Path(out))
    res = check_study(study_dir, files=False)
    fatal = [p for p in res.problems if p.kind != "trial"]
    if fatal:
        raise StudyCheckError(res.manifest, res.problems)
    invalid = tuple((p.trial, str(p)) for p in res.problems if p.kind == "trial")
    st = res.study
    selected = _select(st, trials, invalid)
    # a results folder of its own, or a new or empty one: never mixed with other files
    check_output_dir(out, marker="run.json", what="results folder")
    store = ResultsStore(out)
    other = _check_same_study(store, st, force)
    first = {}
    for t in selected:
        store.trial_dir(t.id)  # validates the id before anything runs
        first[t.id] = _first_reasons(store, st, t, pdict, pdigest, force)
    # the inputs of every trial finished OK are hashed (in parallel): to skip it, to say that
    # they changed, or to keep its results when they are missing
    paths = {t.id: _input_paths(st, t) for t in selected if first[t.id][1] is not None}
    known = {}
    if quick_resume:  # trust an unchanged fingerprint (size, times, inode) instead of hashing
        for tid, ps in paths.items():
            rec = first[tid][1].get("inputs", {})
            for key, p in ps.items():
                r = rec.get(key) or {}
                same_path = r.get("path") == getattr(st.trial(tid), key).path
                if r.get("fingerprint") and r.get("sha256") and same_path:
                    known[p] = (r["fingerprint"], r["sha256"])
    hashes = _hash_inputs(sorted({p for ps in paths.values() for p in ps.values()}), known)
    plans = []
    for t in selected:
        why, status = first[t.id]
        if status is not None:
            changed, missing = _input_changes(status, paths[t.id], hashes, st, t)
            if missing:
                plans.append(TrialPlan(t.id, "keep", "input missing: " + ", ".join(missing)
                                       + ("; " + "; ".join(why) if why else "")))
                continue
            if changed:
                why = [*why, f"input changed: {', '.join(changed)}"]
        marked = bool(status and status.get("input_missing"))
        plans.append(TrialPlan(t.id, "compute" if why else "skip", "; ".join(why) or "unchanged", marked))
    return AnalysisPlan(study=st, trials=tuple(plans), params=pdict, params_sha256=pdigest,
                        index=res.index or {}, invalid=invalid, other_study=other)


def check_out_apart(study_dir: Path, out: Path) -> None:
    """The results folder may not lie inside the study folder (nor the study inside it):
    results would become the study's inputs, and a study's files would be results."""
    a, b = study_dir.resolve(), out.resolve()
    if a == b or a in b.parents:
        raise ValueError(f"--out {str(out)!r} is inside the study folder {str(study_dir)!r}; put the results "
                         "folder elsewhere (results are never written into a study)")
    if b in a.parents:
        raise ValueError(f"the study folder {str(study_dir)!r} is inside --out {str(out)!r}; give a results "
                         "folder apart from the study")


def _check_same_study(store: ResultsStore, st: Study, force: bool) -> str | None:
    """A results folder belongs to one study: the one its run record names (its folder), or
    one with the same manifest (moved), or one holding a trial's very recordings (moved and
    edited: a trial of the same id whose force file has the SHA-256 recorded). Another
    study's folder is refused, or with ``force`` that study is returned (``analyze`` then
    removes its trials, fit and report; nothing is removed here)."""
    if not store.run_path.is_file():
        return None
    try:
        rec = store.read_run()
    except ValueError as exc:
        if not force:
            raise ValueError(f"{exc}; use another --out, or --force to start this results folder "
                             "again") from None
        rec = {}
    here = str(Path(st.root).resolve())
    manifest = Path(st.root) / "manifest.json"
    digest = sha256_file(manifest) if manifest.is_file() else None
    if not rec or rec.get("study") == here or (digest and rec.get("manifest_sha256") == digest) \
            or _shares_a_recording(store, st):
        return None
    if not force:
        raise ValueError(
            f"results folder {str(store.root)!r} holds the results of another study ({rec.get('study')!r}, "
            f"its run.json), not of {here!r}; give another --out, or --force to remove that study's "
            "trials, fit and report and analyse this one there")
    return str(rec.get("study"))


def _shares_a_recording(store: ResultsStore, st: Study, tries: int = 3) -> bool:
    """Whether a trial of the study has a result here computed from its very force file
    (same id, same SHA-256): the study moved and was edited, it is not another one."""
    for t in st.trials:
        recorded = ((store.status(t.id) or {}).get("inputs") or {}).get("force") or {}
        if not recorded.get("sha256"):
            continue
        try:
            if sha256_input(st.path(t.force.path)) == recorded["sha256"]:
                return True
        except (OSError, ValueError):
            pass
        tries -= 1
        if tries == 0:
            return False
    return False


def _select(study: Study, selected: Sequence[str] | str | None, invalid: tuple = ()) -> list[TrialRecord]:
    """The trials to analyse, in the study's order (all by default)."""
    trials = list(study.trials)
    if not trials and not invalid:
        raise ValueError(f"study {str(study.root)!r} lists no trials")
    if selected is None:
        return trials
    if isinstance(selected, str):
        selected = [selected]
    unknown = sorted(set(selected) - {t.id for t in trials})
    if unknown:
        raise ValueError(f"trials {unknown} are not in the study {str(study.root)!r}")
    return [t for t in trials if t.id in set(selected)]
