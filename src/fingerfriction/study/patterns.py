"""File-name patterns: which recordings of a lab folder belong to which trial.

``fingerfriction init`` builds a study manifest from a folder of recordings named after
a pattern, e.g. ``raw/S{subject}_{surface}_{speed}mms_{repetition}.cine`` for the videos
and the same with ``.tdms`` for the force files. This module is the pure part of it: from
a list of relative paths and the patterns, the trials found (one video and one force file
each, with their labels) and every path that could not be used, with the reason.

Pattern syntax
--------------
``{name}``
    A field: one or more characters, never ``/``. Known fields: ``subject`` (the
    subject label), ``surface`` (the surface, a name or a token mapped to one later),
    ``speed`` (the nominal speed in mm/s: digits, optionally ``.`` and decimals) and
    ``repetition`` (digits). Other names (``{session}``, ``{date}``) are labels that
    take part in pairing a video with its force file and in the trial id.
``*``
    Any characters except ``/``, not captured (parts of a name that differ between the
    video and the force file, such as a time stamp).
Anything else is matched literally. The whole relative path must match (``/`` as the
separator). Fields are matched shortest first, so ``{surface}_{speed}mms`` splits
``step-up-2mm_40mms`` as expected.

``subject``, ``surface`` and ``speed`` are required; ``repetition`` is optional: without
it, trials of the same subject, surface and speed are numbered 1, 2, ... in the order of
their other labels (or their paths). All video and force patterns must have the same
fields, since the fields pair a video with its force file.
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

__all__ = [
    "KNOWN_FIELDS",
    "REQUIRED_FIELDS",
    "PatternError",
    "FilePattern",
    "MatchedTrial",
    "Unmatched",
    "MatchResult",
    "match_recordings",
    "list_candidates",
    "trial_id",
]

#: Regular expression of each known field's text.
KNOWN_FIELDS = {
    "subject": r"[^/]+?",
    "surface": r"[^/]+?",
    "speed": r"\d+(?:\.\d+)?",
    "repetition": r"\d+",
}
#: Fields every pattern must have.
REQUIRED_FIELDS = ("subject", "surface", "speed")
_OTHER_FIELD = r"[^/]+?"
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*\Z")
_ID_BAD = re.compile(r"[^A-Za-z0-9_.\-]+")


class PatternError(ValueError):
    """A malformed file-name pattern; the message names the pattern and what is wrong."""


@dataclass(frozen=True)
class FilePattern:
    """One parsed file-name pattern (see the module docstring for the syntax).

    Attributes
    ----------
    text : str
        The pattern as given.
    fields : tuple of str
        Field names in the order they appear.
    """

    text: str
    fields: tuple
    _regex: re.Pattern = field(repr=False, compare=False)

    @classmethod
    def parse(cls, text: str, *, what: str = "pattern") -> FilePattern:
        """Parse a pattern.

        Parameters
        ----------
        text : str
            E.g. ``'raw/S{subject}_{surface}_{speed}mms_{repetition}.cine'``.
        what : str
            What to call it in error messages (``'--video'``).

        Raises
        ------
        PatternError
            An empty or absolute pattern, ``..``, unbalanced braces, a bad or repeated
            field name, two fields with nothing between them.
        """
        if not isinstance(text, str) or not text.strip():
            raise PatternError(f"{what} must be a non-empty file-name pattern, got {text!r}")
        if text.startswith("/") or re.match(r"^[A-Za-z]:[\\/]", text) or "\\" in text:
            raise PatternError(f"{what} {text!r} must be a path relative to the study folder, with '/'")
        if any(part == ".." for part in text.split("/")):
            raise PatternError(f"{what} {text!r} must stay inside the study folder ('..' is not allowed)")
        regex, fields, i = [], [], 0
        last_was_field = False
        while i < len(text):
            c = text[i]
            if c == "{":
                j = text.find("}", i)
                if j < 0:
                    raise PatternError(f"{what} {text!r}: '{{' at position {i} is never closed")
                name = text[i + 1:j]
                if not _NAME.match(name):
                    raise PatternError(f"{what} {text!r}: field name {name!r} must be a name like "
                                       "'subject' (letters, digits, '_')")
                if name in fields:
                    raise PatternError(f"{what} {text!r}: field {{{name}}} appears twice")
                if last_was_field:
                    raise PatternError(f"{what} {text!r}: fields {{{fields[-1]}}} and {{{name}}} need "
                                       "something between them to be told apart")
                fields.append(name)
                regex.append(f"(?P<{name}>{KNOWN_FIELDS.get(name, _OTHER_FIELD)})")
                last_was_field = True
                i = j + 1
                continue
            if c == "}":
                raise PatternError(f"{what} {text!r}: '}}' at position {i} closes no field")
            regex.append(r"[^/]*" if c == "*" else re.escape(c))
            last_was_field = False
            i += 1
        return cls(text=text, fields=tuple(fields), _regex=re.compile("".join(regex) + r"\Z"))

    def match(self, relpath: str) -> dict | None:
        """The fields of ``relpath`` (a relative path with ``/``), or None if it does not match."""
        m = self._regex.match(relpath)
        return None if m is None else dict(m.groupdict())


@dataclass(frozen=True)
class MatchedTrial:
    """One trial found: its labels and its two files.

    Attributes
    ----------
    id : str
        Trial id: ``s<subject>-<surface>-v<speed>-r<repetition>`` (plus other labels),
        characters outside letters, digits, ``-``, ``_``, ``.`` replaced by ``-``.
    subject, surface : str
        As written in the file name.
    speed_mm_s : float
    repetition : int
        From the file name, or numbered when the patterns have no ``{repetition}``.
    video, force : str
        Relative paths.
    labels : dict
        Every field's text, as captured (the other labels included).
    """

    id: str
    subject: str
    surface: str
    speed_mm_s: float
    repetition: int
    video: str
    force: str
    labels: dict


@dataclass(frozen=True)
class Unmatched:
    """A path that is not used, and why."""

    path: str
    reason: str


@dataclass(frozen=True)
class MatchResult:
    """What :func:`match_recordings` found.

    Attributes
    ----------
    trials : tuple of MatchedTrial
        Sorted by subject, surface, speed, repetition.
    unmatched : tuple of Unmatched
        Paths matching no pattern, videos without a force file and force files without a
        video, two files for one trial: sorted by path.
    fields : tuple of str
        The patterns' fields.
    """

    trials: tuple
    unmatched: tuple
    fields: tuple


def trial_id(subject: str, surface: str, speed_mm_s: float, repetition: int,
             extra: Sequence[str] = ()) -> str:
    """The trial id ``s<subject>-<surface>-v<speed>-r<repetition>`` (the simulator's form,
    e.g. ``s1-bump-2mm-v040-r1``), with ``extra`` labels appended, made a valid id."""
    parts = [f"s{subject}", surface, f"v{speed_mm_s:03g}", f"r{repetition}", *extra]
    return _ID_BAD.sub("-", "-".join(str(p) for p in parts)).strip("-.") or "trial"


def _key(values: dict) -> tuple:
    out = []
    for k in sorted(values):
        v = values[k]
        if k == "speed":
            v = float(v)
        elif k == "repetition":
            v = int(v)
        out.append((k, v))
    return tuple(out)


def _describe(key: tuple) -> str:
    return ", ".join(f"{k}={v:g}" if isinstance(v, float) else f"{k}={v}" for k, v in key)


def match_recordings(paths: Iterable[str], video_patterns: Sequence[str] | str,
                     force_patterns: Sequence[str] | str) -> MatchResult:
    """Pair videos and force files by the fields of their names.

    Parameters
    ----------
    paths : iterable of str
        Relative paths (``/`` separators) of the files, and of the folders of TIFF
        frames, of a study folder (:func:`list_candidates`).
    video_patterns, force_patterns : str or sequence of str
        One or more patterns each (e.g. one for ``.cine`` and one for ``.tif`` videos).

    Returns
    -------
    MatchResult

    Raises
    ------
    PatternError
        A malformed pattern, a required field missing, patterns with different fields.
    """
    vps = [FilePattern.parse(p, what="--video") for p in _as_list(video_patterns, "--video")]
    fps = [FilePattern.parse(p, what="--forces") for p in _as_list(force_patterns, "--forces")]
    _check_fields(vps, fps)
    unmatched: list[Unmatched] = []
    videos, forces = _bin_paths(paths, vps, fps, unmatched)
    pairs = _pair(videos, forces, unmatched)
    extra = [f for f in vps[0].fields if f not in KNOWN_FIELDS]
    trials = _trials(pairs, "repetition" in vps[0].fields, extra, unmatched)
    return MatchResult(trials=tuple(trials), unmatched=tuple(sorted(unmatched, key=lambda u: u.path)),
                       fields=tuple(vps[0].fields))


def _check_fields(vps: list[FilePattern], fps: list[FilePattern]) -> None:
    """Every pattern has the required fields, and all have the same fields."""
    fields = set(vps[0].fields)
    for p in vps + fps:
        missing = [f for f in REQUIRED_FIELDS if f not in p.fields]
        if missing:
            raise PatternError(
                f"pattern {p.text!r} has no field {', '.join('{' + m + '}' for m in missing)}; every pattern "
                f"needs {', '.join('{' + f + '}' for f in REQUIRED_FIELDS)} (and may have {{repetition}})"
            )
        if set(p.fields) != fields:
            raise PatternError(
                f"patterns {vps[0].text!r} and {p.text!r} have different fields "
                f"({sorted(fields)} and {sorted(p.fields)}); the fields pair a video with its force file, "
                "so every pattern needs the same ones (use '*' for parts that differ)"
            )


def _bin_paths(paths: Iterable[str], vps: list[FilePattern], fps: list[FilePattern],
               unmatched: list[Unmatched]) -> tuple[dict, dict]:
    """Videos and force files by the key of their fields; the rest into ``unmatched``. A
    folder (a path ending in ``/``) can only be a video (a folder of TIFF frames), and the
    files inside a folder that is a video belong to it."""
    paths = sorted(set(paths))
    videos: dict[tuple, list[tuple[str, dict]]] = {}
    forces: dict[tuple, list[tuple[str, dict]]] = {}
    used_dirs: list[str] = []
    left: list[Unmatched] = []
    for path in paths:
        is_dir = path.endswith("/")
        name = path.rstrip("/")
        hit = None
        for pats, table in ((vps, videos), (() if is_dir else fps, forces)):
            vals = next((v for v in (pat.match(name) for pat in pats) if v is not None), None)
            if vals is not None:
                hit = (table, vals)
                break
        if hit is None:
            if not is_dir:
                left.append(Unmatched(name, "matches no pattern"))
            continue
        table, vals = hit
        table.setdefault(_key(vals), []).append((name, vals))
        if is_dir:
            used_dirs.append(name + "/")
    unmatched.extend(u for u in left if not any(u.path.startswith(d) for d in used_dirs))
    return videos, forces


def _pair(videos: dict, forces: dict, unmatched: list[Unmatched]) -> list[tuple[str, str, dict]]:
    """``(video, force file, fields)`` of each key with exactly one of each."""
    pairs = []
    for key in sorted(set(videos) | set(forces), key=repr):
        vs, fs = videos.get(key, []), forces.get(key, [])
        what = _describe(key)
        if len(vs) > 1 or len(fs) > 1:
            for kind, lst in (("videos", vs), ("force files", fs)):
                if len(lst) > 1:
                    others = ", ".join(p for p, _ in lst)
                    unmatched.extend(Unmatched(p, f"{len(lst)} {kind} for one trial ({what}): {others}")
                                     for p, _ in lst)
        elif not fs:
            unmatched.append(Unmatched(vs[0][0], f"video without a force file ({what})"))
        elif not vs:
            unmatched.append(Unmatched(fs[0][0], f"force file without a video ({what})"))
        else:
            pairs.append((vs[0][0], fs[0][0], vs[0][1]))
    return pairs


def _trials(pairs: list, has_repetition: bool, extra: list[str], unmatched: list[Unmatched]) -> list:
    """The trials of the pairs: repetitions numbered when the names have none, speeds and
    repetitions checked, ids unique."""
    numbered = []
    if has_repetition:
        numbered = [(vals, int(vals["repetition"]), v, f) for v, f, vals in pairs]
    else:
        groups: dict[tuple, list] = {}
        for v, f, vals in pairs:
            g = (vals["subject"], vals["surface"], float(vals["speed"]))
            groups.setdefault(g, []).append((tuple(vals[e] for e in extra), v, f, vals))
        for members in groups.values():
            for rep, (_, v, f, vals) in enumerate(sorted(members, key=lambda m: (m[0], m[1])), start=1):
                numbered.append((vals, rep, v, f))
    out = []
    for vals, rep, v, f in numbered:
        speed = float(vals["speed"])
        if speed <= 0:
            why = f"speed {vals['speed']!r} in the name is not a positive speed in mm/s"
            unmatched.append(Unmatched(v, why))
        elif rep < 1:
            unmatched.append(Unmatched(v, f"repetition {vals['repetition']!r} in the name must be >= 1"))
        else:
            tid = trial_id(vals["subject"], vals["surface"], speed, rep, [vals[e] for e in extra])
            out.append(MatchedTrial(id=tid, subject=vals["subject"], surface=vals["surface"],
                                    speed_mm_s=speed, repetition=rep, video=v, force=f, labels=dict(vals)))
    out.sort(key=lambda t: (t.subject, t.surface, t.speed_mm_s, t.repetition, t.id))
    seen: dict[str, MatchedTrial] = {}
    final = []
    for t in out:
        if t.id in seen:
            why = f"its trial id {t.id!r} is the same as that of {seen[t.id].video}"
            unmatched.append(Unmatched(t.video, why))
        else:
            seen[t.id] = t
            final.append(t)
    return final


def _as_list(patterns, what: str) -> list[str]:
    lst = [patterns] if isinstance(patterns, str) else list(patterns or [])
    if not lst:
        raise PatternError(f"give at least one {what} pattern")
    return lst


def list_candidates(root: str | os.PathLike, *, skip: Iterable[str] = ("manifest.json",)) -> list[str]:
    """Relative paths (``/`` separators) of the files under a study folder, and of its
    folders holding ``.tif``/``.tiff`` files (with a trailing ``/``: a folder of frames
    can be one video). Hidden files and folders (``.name``) and ``skip`` are left out.
    """
    root = Path(root)
    skip = set(skip)
    out: list[str] = []
    for dirpath, dirnames, filenames in os.walk(root):
        dirnames[:] = sorted(d for d in dirnames if not d.startswith("."))
        rel = Path(dirpath).relative_to(root).as_posix()
        prefix = "" if rel == "." else rel + "/"
        names = sorted(f for f in filenames if not f.startswith("."))
        if prefix and any(n.lower().endswith((".tif", ".tiff")) for n in names):
            out.append(prefix)
        out.extend(prefix + n for n in names if prefix + n not in skip)
    return out
