"""The one rule for a command's output folder (``--out``), the same for every command.

* A folder that does not exist is created (with its parents).
* A folder that exists must be empty, or hold only what the command itself writes there
  (files it names, or the marker file of its own kind of folder, such as a results folder's
  ``run.json``), so that re-running resumes or refreshes it. Anything else is refused with
  a message naming the folder and what it holds: an output never mixes with, or
  overwrites, files it did not write.
* Hidden names (``.name``: an interrupted atomic write, a desktop's index file) are
  ignored.

A command whose ``--out`` is a file creates the file's folder (:func:`output_file`).
A table (Table 1, the blind spots) is written as CSV, Markdown or LaTeX by
:func:`write_table`, atomically (public as :func:`fingerfriction.study.store.write_table`).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING

from ._atomic import atomic_write_text

if TYPE_CHECKING:  # pandas is heavy: the command line imports this module at start
    import pandas as pd

__all__ = ["check_output_dir", "output_dir", "output_file", "write_table"]


def check_output_dir(path: str | os.PathLike, *, option: str = "--out",
                     owns: Callable[[str], bool] | Iterable[str] | None = None,
                     marker: str | None = None, what: str = "output folder") -> Path:
    """Refuse an output folder that holds something else; create nothing.

    Parameters
    ----------
    path : path-like
        The folder.
    option : str
        The option to name in the message (``'--out'``).
    owns : callable or iterable of str, optional
        Names (or a test of a name) of the entries the command writes in the folder.
    marker : str, optional
        A file whose presence shows the folder is the command's own (``'run.json'``).
    what : str
        What the folder is, for the message (``'results folder'``).

    Returns
    -------
    Path

    Raises
    ------
    ValueError
        ``path`` is a file, or a non-empty folder holding entries the command does not
        write (the message lists up to five).
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise ValueError(f"{option} {str(p)!r} is a file; give a folder for the {what}")
    if not p.is_dir() or (marker is not None and (p / marker).is_file()):
        return p
    test = owns if callable(owns) else (lambda n, names=frozenset(owns or ()): n in names)
    others = sorted(n for n in os.listdir(p) if not n.startswith(".") and not test(n))
    if others:
        shown = ", ".join(others[:5]) + (f" and {len(others) - 5} more" if len(others) > 5 else "")
        raise ValueError(f"{option} {str(p)!r} is not empty and is not a {what}: it holds {shown}; "
                         "give a new or empty folder")
    return p


def output_dir(path: str | os.PathLike, **kw) -> Path:
    """:func:`check_output_dir`, then create the folder (and its parents) if missing."""
    p = check_output_dir(path, **kw)
    p.mkdir(parents=True, exist_ok=True)
    return p


def output_file(path: str | os.PathLike, *, option: str = "--out", create: bool = True) -> Path:
    """An output file's path, its folder created if missing (unless ``create`` is False:
    only checked); a folder given as the file is refused, naming it."""
    p = Path(path)
    if p.is_dir():
        raise ValueError(f"{option} {str(p)!r} is a folder; give a file name")
    if create:
        p.parent.mkdir(parents=True, exist_ok=True)
    return p


def write_table(df: pd.DataFrame, path: str | os.PathLike, *, float_format: str = "%.3g") -> None:
    """Write a table atomically; the format follows the suffix: .csv, .md or .tex.

    Raises
    ------
    ValueError
        For another suffix.
    """
    path = os.fspath(path)
    ext = os.path.splitext(path)[1].lower()
    if ext == ".csv":
        text = df.to_csv(index=False)
    elif ext == ".md":
        text = _markdown(df)
    elif ext == ".tex":
        text = df.to_latex(index=False, float_format=lambda v: float_format % v)
    else:
        raise ValueError(f"{path}: unknown table format {ext!r}; allowed: .csv, .md, .tex")
    atomic_write_text(path, text)


def _markdown(df: pd.DataFrame) -> str:
    """Markdown without the optional ``tabulate`` dependency of ``DataFrame.to_markdown``."""
    def cell(v):
        if isinstance(v, float):
            return "" if math.isnan(v) else f"{v:.3g}"
        return str(v)
    head = "| " + " | ".join(map(str, df.columns)) + " |"
    sep = "|" + "|".join("---" for _ in df.columns) + "|"
    body = ["| " + " | ".join(cell(v) for v in row) + " |" for row in df.itertuples(index=False)]
    return "\n".join([head, sep, *body]) + "\n"
