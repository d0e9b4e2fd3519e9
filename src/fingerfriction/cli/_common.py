"""What every command shares: the two consoles, one-line errors, ``--finger`` files, and
the console of the long commands (``--verbose``/``--quiet``, grouped warnings, one
summary line)."""

from __future__ import annotations

import typer
from rich.console import Console
from rich.markup import escape

from .._console import one_line

console = Console()
err_console = Console(stderr=True)


def fail(message: str) -> None:
    """Print a one-line error and exit with status 2."""
    err_console.print(f"[bold red]error:[/] {message}", highlight=False, soft_wrap=True)
    raise typer.Exit(2)


def read_fingers(path: str | None = None, items: list[str] | None = None, model: str = "halfspace"):
    """``--finger FILE`` (a finger) or ``--finger SUBJECT=FILE`` items (a dict), one-line errors;
    ``model='fe'`` reads FE finger files."""
    from ..mechanics import finger_file  # small, but only when --finger is given

    try:
        if path is None:
            return finger_file.read_subject_fingers(items, model=model)
        return finger_file.read_finger_file(path, model=model)
    except ValueError as exc:
        fail(str(exc))


# ---------------------------------------------------------------------------------------
# the console of the long commands: --verbose / --quiet, grouped warnings, one summary line
# ---------------------------------------------------------------------------------------

VERBOSE = typer.Option(False, "--verbose", "-v", help="Show every log record and every failure as it comes.")
QUIET = typer.Option(False, "--quiet", "-q", help="Print only the summary line.")


def verbosity_of(verbose: bool, quiet: bool) -> int:
    """-1 quiet, 0 normal, 1 verbose."""
    if verbose and quiet:
        fail("--verbose and --quiet exclude each other")
    return 1 if verbose else -1 if quiet else 0


def show_progress(verbosity: int) -> bool:
    """Progress bars on an interactive terminal only: in a log file they are noise."""
    return verbosity >= 0 and err_console.is_terminal


def echo(text: str) -> None:
    err_console.print(escape(text), highlight=False, soft_wrap=True)


def warn(text: str) -> None:
    err_console.print(f"[yellow]warning:[/] {escape(text)}", highlight=False, soft_wrap=True)


def grouped_failures(failures, what: str, verbosity: int, label_of=None) -> None:
    """Failures as one warning line per group (a subject, or all), with a count and one
    example; every failure with ``--verbose``; nothing with ``--quiet``."""
    failures = list(failures)
    if verbosity < 0 or not failures:
        return
    if verbosity > 0:
        for tid, reason in failures:
            warn(f"{what} failed: {tid}: {one_line(reason, 300)}")
        return
    groups: dict = {}
    for tid, reason in failures:
        groups.setdefault(label_of(tid) if label_of else "", []).append((tid, reason))
    for label, items in groups.items():
        tid, reason = items[0]
        head = f"{label}: " if label else ""
        warn(f"{head}{len(items)} {what} failure{'s' if len(items) != 1 else ''} "
             f"(e.g. {tid}: {one_line(reason, 120)})")


def plural(count: int, noun: str) -> str:
    """'1 trial', '2 trials'."""
    return f"{count} {noun}{'' if count == 1 else 's'}"


def print_summary(text: str) -> None:
    console.print(escape(text), highlight=False, soft_wrap=True)


def csv_list(values: str | None) -> tuple[str, ...] | None:
    return None if not values else tuple(v.strip() for v in values.split(",") if v.strip())


def print_problems(problems) -> None:
    for p in problems:
        err_console.print(escape(str(p)), highlight=False, soft_wrap=True)


