"""Command line interface: a thin layer over the package's functions.

Each command only parses options, calls the stage's public function and prints the
result; user errors (bad files, bad options) are caught and shown as one line, exit 2.
The commands live by stage (``init``: the manifest from lab files; ``study``: check ...
report and demo; ``stages``: one trial's overlay and forces; ``sim``: simulate;
``predict``: the forward model's commands); each
imports its stage when it runs, so ``--help`` stays fast. They are registered below, in
the order ``--help`` lists them.
"""

from __future__ import annotations

import typer

from .. import __version__
from . import init, predict, sim, stages, study
from ._common import console
from ._help import readable_help_types

__all__ = ["app", "main"]

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="fingerfriction: finger contact, tactile blind spots and friction forces on relief surfaces.",
)

readable_help_types()


def _print_version(value: bool) -> None:
    if value:
        console.print(f"fingerfriction {__version__}", highlight=False)
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", is_eager=True, callback=_print_version,
                                 help="Print the version and exit."),
) -> None:
    """fingerfriction: finger contact, tactile blind spots and friction forces on relief surfaces."""
    # A callback keeps typer in sub-command mode even while only one command exists.


#: ``(name, function)`` of every command, in the order ``--help`` lists them.
COMMANDS = [
    ("demo", study.demo),
    ("predict-contact", predict.predict_contact),
    ("simulate", sim.simulate_cmd),
    ("overlay", stages.overlay_cmd),
    ("forces", stages.forces_cmd),
    ("analyze", study.analyze_cmd),
    ("check", study.check_cmd),
    ("fit", study.fit_cmd),
    ("report", study.report_cmd),
    ("predict", predict.predict_cmd),
    ("render", predict.render_cmd),
    ("validate", predict.validate_cmd),
    ("init", init.init_cmd),
    ("calibrate-finger", predict.calibrate_finger_cmd),
]
for _name, _command in COMMANDS:
    app.command(_name)(_command)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``fingerfriction`` console script."""
    try:
        app(args=argv, standalone_mode=True)
    except SystemExit as exc:  # typer exits through SystemExit
        return int(exc.code or 0)
    return 0

