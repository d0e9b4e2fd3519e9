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


@app.command("predict-contact")
def predict_contact(
    surface: str = typer.Option(
        ..., "--surface", help="Paper surface name (bump-4mm ...), spec 'bump:W=3,H=0.5' or x,h CSV (mm)."
    ),
    subject: int = typer.Option(1, "--subject", help="Calibrated finger of subject 1 or 2."),
    load: float = typer.Option(0.3, "--load", help="Normal force in N."),
    step: float = typer.Option(0.01, "--step", help="Finger position step in mm over the 26 mm window."),
    kind: str = typer.Option(
        "geometric", "--kind", help="Contact definition: geometric (gap <= 70 um) or mechanical."
    ),
    out: str = typer.Option(
        None, "--out", help="Directory for the occupancy figure (PNG); default: current."
    ),
) -> None:
    """Predict tactile blind spots and simultaneous contacts of a finger sliding over a surface."""
    import os

    from rich.table import Table

    from .mechanics import default_positions, get_subject, sweep
    from .mechanics.figures import save_occupancy_figure
    from .surfaces import surface_from_spec

    try:
        if kind not in ("geometric", "mechanical"):
            raise ValueError(f"--kind must be 'geometric' or 'mechanical', got {kind!r}")
        surf = surface_from_spec(surface)
        finger = get_subject(subject)
        positions = default_positions(surf, step=step)
        with console.status(f"solving the contact at {positions.size} finger positions..."):
            res = sweep(surf, finger, positions, load=load)
        out_dir = out or "."
        if not os.path.isdir(out_dir):
            raise ValueError(f"--out {out_dir!r} is not an existing directory")
        bs = res.blind_spots(kind)
        png = save_occupancy_figure(res, surf, os.path.join(out_dir, f"occupancy-{surf.name}-s{subject}.png"),
                                    kind=kind)
    except (ValueError, TypeError, OSError) as exc:
        fail(str(exc))
        return
    table = Table(title=f"Tactile blind spots: {surf.name}, subject {subject}, {load:g} N ({kind} contact)")
    table.add_column("#", justify="right")
    table.add_column("start (mm)", justify="right")
    table.add_column("end (mm)", justify="right")
    table.add_column("width (mm)", justify="right")
    for i, row in enumerate(bs.as_table(), start=1):
        table.add_row(str(i), f"{row['start_mm']:.3f}", f"{row['end_mm']:.3f}", f"{row['width_mm']:.3f}")
    if len(bs) == 0:
        table.add_row("-", "-", "-", "none")
    console.print(table)
    console.print(f"maximum simultaneous contacts: {res.max_contacts(kind)} ({kind}), "
                  f"{res.max_contacts('mechanical' if kind == 'geometric' else 'geometric')} "
                  f"({'mechanical' if kind == 'geometric' else 'geometric'})")
    if not res.all_converged:
        console.print(
            f"[yellow]warning:[/] {len(res.messages)} positions did not converge; first: {res.messages[0]}"
        )
    console.print(f"occupancy figure: {png}")


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
