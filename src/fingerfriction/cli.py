"""Command line interface: a thin layer over the package's functions.

Each command below only parses options, calls the stage's public function and prints the
result; user errors (bad files, bad options) are caught and shown as one line, exit 2.
"""

from __future__ import annotations

import sys

import typer
from rich.console import Console

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="fingerfriction: finger contact, tactile blind spots and friction forces on relief surfaces.",
)
console = Console()
err_console = Console(stderr=True)


class UserError(Exception):
    """An error in the user's input, shown as one line without a traceback."""


def fail(message: str) -> None:
    """Print a one-line error and exit with status 2."""
    err_console.print(f"[bold red]error:[/] {message}", highlight=False, soft_wrap=True)
    raise typer.Exit(2)


# ---------------------------------------------------------------------------------------
# demo (foundation; the study issue turns it into simulate + analyze + fit + report)
# ---------------------------------------------------------------------------------------


# ---------------------------------------------------------------------------------------
# predict-contact (forward contact model, fingerfriction.mechanics)
# ---------------------------------------------------------------------------------------


# ---------------------------------------------------------------------------------------
# simulate (virtual experiment, fingerfriction.sim)
# ---------------------------------------------------------------------------------------


# ---------------------------------------------------------------------------------------
# overlay (video analysis, fingerfriction.video)
# ---------------------------------------------------------------------------------------


# ---------------------------------------------------------------------------------------
# forces (force processing, fingerfriction.forces)
# ---------------------------------------------------------------------------------------


# ---------------------------------------------------------------------------------------
# analyze / fit / report (study pipeline, fingerfriction.pipeline and .report)
# ---------------------------------------------------------------------------------------


# ---------------------------------------------------------------------------------------
# predict / render (prediction and haptic rendering)
# ---------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``fingerfriction`` console script."""
    try:
        app(args=argv, standalone_mode=True)
    except SystemExit as exc:  # typer exits through SystemExit
        return int(exc.code or 0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
