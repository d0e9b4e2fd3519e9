"""What the long commands (analyze, fit, report, demo, simulate) print: library warnings
grouped by kind instead of one line per trial, fold or grid point; ``--quiet`` and
``--verbose``; the one-line summary every command ends with.

The package logs what it does through :mod:`logging` (``fingerfriction.*`` loggers). While a
command runs, :func:`console_log` replaces their output with a :class:`WarningLog`:

* normal: nothing is printed as it happens (the command prints its own findings, e.g. one
  line per subject whose fits failed); every warning is counted by kind (its logger and
  message template), and the summary line gives each kind with its count and one example;
* ``--verbose`` (verbosity 1): every record from INFO up is printed as it comes, each one;
* ``--quiet`` (verbosity -1): as normal, and the command prints only its summary line.
"""

from __future__ import annotations

import contextlib
import logging
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

__all__ = ["WarningKind", "WarningLog", "console_log", "summary_line", "one_line"]

#: The package's root logger.
LOGGER = "fingerfriction"


def with_ci(value: float, lo: float, hi: float) -> str:
    """``value [lo, hi]`` with enough decimals (3 to 5) that the interval's width shows.

    >>> with_ci(0.550031, 0.549972, 0.550091)
    '0.55003 [0.54997, 0.55009]'
    >>> with_ci(0.55147, 0.54085, 0.56223)
    '0.551 [0.541, 0.562]'
    """
    half = abs(hi - lo) / 2
    d = 3 if not half > 0 else min(5, max(3, math.ceil(-math.log10(half)) + 1))
    return f"{value:.{d}f} [{lo:.{d}f}, {hi:.{d}f}]"


def one_line(text: str, limit: int = 160) -> str:
    """``text`` on one line (whitespace runs collapsed), cut to ``limit`` characters."""
    s = " ".join(str(text).split())
    return s if len(s) <= limit else s[: limit - 3] + "..."


@dataclass
class WarningKind:
    """Warnings of one kind: same logger, same message template."""

    logger: str
    template: str
    count: int
    example: str

    @property
    def label(self) -> str:
        """A short name: the template's text before its first placeholder or parenthesis."""
        head = self.template.split("%", 1)[0].split("(", 1)[0].split("{", 1)[0].strip(" :;,")
        return head or self.template[:40]


class WarningLog(logging.Handler):
    """A logging handler that counts warnings by kind and, when verbose, echoes every record.

    Parameters
    ----------
    echo : callable or None
        Called with one line of text per echoed record.
    verbose : bool
        Echo every record it receives (INFO and up when installed by :func:`console_log`).
    """

    def __init__(self, echo: Callable[[str], None] | None = None, *, verbose: bool = False) -> None:
        super().__init__(logging.DEBUG)
        self.echo = echo
        self.verbose = bool(verbose)
        self._kinds: dict[tuple[str, str], WarningKind] = {}

    def emit(self, record: logging.LogRecord) -> None:
        try:
            text = record.getMessage()
        except (TypeError, ValueError):  # a malformed call in a library: keep its raw text
            text = str(record.msg)
        if record.levelno >= logging.WARNING:
            key = (record.name, str(record.msg))
            k = self._kinds.get(key)
            if k is None:
                self._kinds[key] = WarningKind(record.name, str(record.msg), 1, one_line(text))
            else:
                k.count += 1
        if self.verbose and self.echo is not None:
            self.echo(f"{record.levelname.lower()}: {text}")

    @property
    def kinds(self) -> list[WarningKind]:
        """The kinds of warnings seen, most frequent first."""
        return sorted(self._kinds.values(), key=lambda k: -k.count)

    @property
    def n_warnings(self) -> int:
        return sum(k.count for k in self._kinds.values())

    def summary(self, limit: int = 3) -> str:
        """``"N warnings: 'kind' x12 (e.g. ...); ..."``, or ``""`` when there was none."""
        kinds = self.kinds
        if not kinds:
            return ""
        parts = [f"'{k.label}' x{k.count} (e.g. {one_line(k.example, 110)})" for k in kinds[:limit]]
        more = f"; {len(kinds) - limit} more kinds" if len(kinds) > limit else ""
        n = self.n_warnings
        return f"{n} logged warning{'s' if n != 1 else ''}: " + "; ".join(parts) + more


@contextlib.contextmanager
def console_log(verbosity: int = 0, echo: Callable[[str], None] | None = None) -> Iterator[WarningLog]:
    """Route the package's log records to a :class:`WarningLog` while a command runs.

    Parameters
    ----------
    verbosity : int
        -1 quiet, 0 normal, 1 verbose (every record from INFO up echoed).
    echo : callable, optional
        Prints one line (the CLI's console).
    """
    logger = logging.getLogger(LOGGER)
    handler = WarningLog(echo, verbose=verbosity > 0)
    handler.setLevel(logging.INFO if verbosity > 0 else logging.WARNING)
    old = (logger.level, logger.propagate)
    logger.setLevel(logging.INFO if verbosity > 0 else logging.WARNING)
    logger.propagate = False  # not also printed by a root handler (Python's last resort included)
    logger.addHandler(handler)
    try:
        yield handler
    finally:
        logger.removeHandler(handler)
        logger.setLevel(old[0])
        logger.propagate = old[1]


def summary_line(command: str, facts: list[str], *, elapsed_s: float, output: str | None = None,
                 log: WarningLog | None = None) -> str:
    """The line a command ends with: what it did, how long it took, where the output is, and
    the warnings it logged grouped by kind.

    >>> summary_line("fit", ["36 trials", "2 failed"], elapsed_s=12.04, output="results/fit")
    'fit: 36 trials, 2 failed; 12 s; output in results/fit'
    """
    text = f"{command}: " + ", ".join(f for f in facts if f) + f"; {elapsed_s:.0f} s"
    if output:
        text += f"; output in {output}"
    if log is not None and log.n_warnings:
        text += f"; {log.summary()}"
    return text
