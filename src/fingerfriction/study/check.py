"""Check a study and list every problem at once (``fingerfriction check``; ``analyze`` runs
the same checks first).

Two kinds of problem, each one line naming the file and the field
(:class:`~fingerfriction.study.records.Problem`):

* mistakes in the manifest's text (a missing or malformed field, an unknown surface, a
  duplicate id, a path that leaves the study folder): every one of every trial, where
  :func:`~fingerfriction.study.manifest.load_manifest` stops at the first;
* recordings that do not match their entry (:func:`check_files`): a missing or unreadable
  file, another frame count, frame rate or image size than the manifest says, a force
  channel that is not in the file, another sample count or sampling rate, a time column
  that is not uniform. Fields the manifest leaves to the files are read from them here.
  A video's frame rate is its frames' time stamps' when it has them, its header's setting
  otherwise (:func:`~fingerfriction.video.reader_base.frame_rate`, the rule ``init`` uses).
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path

from ..forces.readers import read_force_file
from ..video.readers import FPS_TOLERANCE, probe_video
from .manifest import Study, TrialRecord, read_manifest_json
from .records import (
    MANIFEST_NAME,
    ForceInfo,
    ManifestError,
    Problem,
    VideoInfo,
    problem_from_error,
    resolve_path,
)

__all__ = ["CheckResult", "check_study", "check_files"]


@dataclass(frozen=True)
class CheckResult:
    """What :func:`check_study` found.

    Attributes
    ----------
    manifest : Path
        The manifest checked.
    study : Study or None
        The trials without a problem (their file-answered fields read from the files when
        they were checked); None when the manifest as a whole is unusable.
    problems : tuple of Problem
        Every problem, in manifest order.
    n_entries : int
        Trial entries in the manifest.
    index : dict
        Trial id -> its position in the manifest's ``trials`` list.
    """

    manifest: Path
    study: Study | None
    problems: tuple
    n_entries: int = 0
    index: dict | None = None

    @property
    def ok(self) -> bool:
        return not self.problems

    @property
    def manifest_problems(self) -> tuple:
        """Mistakes in the manifest's text."""
        return tuple(p for p in self.problems if p.kind == "manifest")

    def by_trial(self) -> dict[str, list[Problem]]:
        """Problems of each trial that has some (by id)."""
        out: dict[str, list[Problem]] = {}
        for p in self.problems:
            if p.trial is not None:
                out.setdefault(p.trial, []).append(p)
        return out

    def lines(self) -> list[str]:
        """One line per problem."""
        return [str(p) for p in self.problems]


def _manifest_path(path: str | os.PathLike) -> Path:
    p = Path(path)
    return p / MANIFEST_NAME if p.is_dir() else p


def check_study(path: str | os.PathLike, *, files: bool | Iterable[str] = True) -> CheckResult:
    """Validate a study: every manifest field of every trial, and its recordings.

    Parameters
    ----------
    path : path-like
        The study folder, or its ``manifest.json``.
    files : bool or iterable of str
        Check the recordings of every trial (True), of none (False), or of these trial ids.

    Returns
    -------
    CheckResult
        Never raises for a problem of the study: they are all in ``problems``.
    """
    mpath = _manifest_path(path)
    shown = str(mpath)
    try:
        data = read_manifest_json(mpath)
    except ManifestError as exc:
        text = str(exc)
        return CheckResult(mpath, None, (Problem(shown, "", text.split(": ", 1)[-1]),))
    problems: list[Problem] = []
    parts: list = []
    study = Study.from_dict(data, root=mpath.parent.resolve(), problems=problems, parts=parts)
    entries = data.get("trials") if isinstance(data, dict) and isinstance(data.get("trials"), list) else []
    index = {e.get("id"): i for i, e in enumerate(entries) if isinstance(e, dict)}
    problems = [replace(p, file=shown) for p in problems]
    if study is None:
        return CheckResult(mpath, None, tuple(problems), len(entries), index)
    good = []
    for t in study.trials:
        where = f"trials[{index.get(t.id, '?')}]"
        bad = False
        for what, rel in (("video.path", t.video.path), ("force.path", t.force.path), ("truth", t.truth)):
            if rel is None:
                continue
            try:
                resolve_path(study.root, rel, where=f"{where}.{what}")
            except ManifestError as exc:
                problems.append(problem_from_error(exc, file=shown, trial=t.id))
                bad = True
        if not bad:
            good.append(t)
    study = replace(study, trials=tuple(good))
    if files is not False:
        wanted = None if files is True else set(files)
        # the recordings of entries with mistakes are checked too, as far as they parsed
        good_ids = {t.id for t in study.trials}
        for i, (tid, video, force) in enumerate(parts):
            if tid is None or tid in good_ids or (wanted is not None and tid not in wanted):
                continue
            if video is not None and _inside(study, video.path):
                _check_video(study, video, tid, f"trials[{i}]", problems)
            if force is not None and _inside(study, force.path):
                _check_force(study, force, tid, f"trials[{i}]", problems)
        todo = [t for t in study.trials if wanted is None or t.id in wanted]
        checked, file_problems = check_files(study, todo, index=index)
        problems += file_problems
        bad_ids = {p.trial for p in file_problems}
        kept = tuple(checked.get(t.id, t) for t in study.trials if t.id not in bad_ids)
        study = replace(study, trials=kept)
    problems.sort(key=lambda p: (index.get(p.trial, -1) if p.trial is not None else -1, p.kind != "manifest"))
    return CheckResult(mpath, study, tuple(problems), len(entries), index)


def check_files(study: Study, trials: Iterable[TrialRecord], *, index: dict | None = None
                ) -> tuple[dict[str, TrialRecord], list[Problem]]:
    """Check the recordings of some trials against their manifest entries.

    Parameters
    ----------
    study : Study
        With its ``root``.
    trials : iterable of TrialRecord
    index : dict, optional
        Trial id -> position in the manifest's ``trials`` (for the field names).

    Returns
    -------
    checked : dict
        Trial id -> the record with its file-answered fields filled in, for the trials
        without a problem.
    problems : list of Problem
        ``kind='file'``, naming the recording and the manifest field.
    """
    checked: dict[str, TrialRecord] = {}
    problems: list[Problem] = []
    for t in trials:
        where = f"trials[{(index or {}).get(t.id, '?')}]"
        before = len(problems)
        video = _check_video(study, t.video, t.id, where, problems)
        force = _check_force(study, t.force, t.id, where, problems)
        if t.truth is not None and not study.path(t.truth).exists():
            problems.append(Problem(t.truth, f"{where}.truth", "no such file", t.id, "file"))
        if len(problems) == before:
            checked[t.id] = replace(t, video=video, force=force)
    return checked, problems


def _inside(study: Study, rel: str) -> bool:
    try:
        study.path(rel)
    except ManifestError:
        return False
    return True


def _check_video(study: Study, v: VideoInfo, tid: str, where: str, problems: list) -> VideoInfo | None:
    def bad(field: str, msg: str) -> None:
        problems.append(Problem(v.path, f"{where}.video.{field}", msg, tid, "file"))

    full = study.path(v.path)
    if not full.exists():
        bad("path", "no such file or folder")
        return None
    try:
        info = probe_video(full)
    except (ValueError, OSError) as exc:
        bad("path", f"cannot be read as a video: {_short(exc, full, v.path)}")
        return None
    found = {"width": info.width, "height": info.height, "n_frames": info.n_frames}
    for k, val in found.items():
        said = getattr(v, k)
        if said is not None and said != val:
            bad(k, f"the manifest says {said}, the file has {val}")
    if v.fps is not None and info.fps is not None and abs(v.fps - info.fps) > FPS_TOLERANCE * info.fps:
        if info.rate.source == "time stamps":
            header = f" (its header's {info.rate.nominal:g} Hz is not what the camera ran at)" \
                if info.rate.note else ""
            bad("fps", f"the manifest says {v.fps:g} Hz, the file's frame time stamps say {info.fps:.6g} Hz"
                       f"{header}")
        else:
            bad("fps", f"the manifest says {v.fps:g} Hz, the file says {info.fps:g} Hz")
    if v.fps is None and info.fps is None:
        bad("fps", "not given, and the file does not state its frame rate; give it")
    if v.calibration_frame >= info.n_frames:
        bad("calibration_frame", f"{v.calibration_frame} is past the file's {info.n_frames} frames")
    fill = {k: val for k, val in {**found, "fps": info.fps}.items() if getattr(v, k) is None}
    return replace(v, **fill) if fill else v


#: words of a reader's message -> the manifest field it is about
_FORCE_FIELDS = (("channel", "channels"), ("column index", "channels"), ("n_samples", "n_samples"),
                 ("time column", "time"), ("sampling rate", "fs_hz"), ("fs_hz", "fs_hz"),
                 ("delimiter", "delimiter"), ("format", "format"))


def _check_force(study: Study, f: ForceInfo, tid: str, where: str, problems: list) -> ForceInfo | None:
    full = study.path(f.path)
    if not full.exists():
        problems.append(Problem(f.path, f"{where}.force.path", "no such file", tid, "file"))
        return None
    try:
        rec = read_force_file(full, **f.reader_options())
    except (ValueError, OSError, TypeError) as exc:
        msg = _short(exc, full, f.path)
        field = next((fld for word, fld in _FORCE_FIELDS if word in msg), "path")
        problems.append(Problem(f.path, f"{where}.force.{field}", msg, tid, "file"))
        return None
    fill = {}
    if f.fs_hz is None:
        fill["fs_hz"] = float(f"{rec.fs_hz:.12g}")
    if f.n_samples is None:
        fill["n_samples"] = rec.n_samples
    return replace(f, **fill) if fill else f


def _short(exc: BaseException, full: Path, rel: str) -> str:
    """The message on one line, with the absolute path shown as the manifest's."""
    msg = " ".join(str(exc).split())
    for form in (repr(str(full)), str(full)):
        msg = msg.replace(form, rel)
    return msg
