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


def _predict_inputs(params):
    """--params: None or a JSON path (FrictionParams JSON or a fit output)."""
    return None if params is None else str(params)


@app.command("predict")
def predict_cmd(
    surface: str = typer.Option(..., "--surface", help="Name (bump-4mm), spec (bump:W=3,H=0.5) or CSV."),
    subject: int = typer.Option(..., "--subject", help="Subject 1 or 2 (calibrated forward-model finger)."),
    params: str = typer.Option(None, "--params", help="JSON parameters: FrictionParams or a fit output."),
    out: str = typer.Option("prediction", "--out", help="Output folder for CSV, JSON and PNG files."),
    load: float = typer.Option(0.3, "--load", help="Normal force in N."),
    step: float = typer.Option(0.01, "--step", help="Finger step in mm."),
    contact: str = typer.Option("geometric", "--contact", help="geometric (70 um) or mechanical."),
    figures: bool = typer.Option(True, "--figures/--no-figures", help="Write PNG figures."),
) -> None:
    """Predict F_T(x), F_int, F_def, contact occupancy and blind spots on any relief."""
    from rich.table import Table

    from .predict import predict

    try:
        pred = predict(surface, subject, _predict_inputs(params), load=load, step=step, contact=contact)
        paths = pred.write(out, figures=figures)
    except (ValueError, OSError, RuntimeError) as exc:
        fail(str(exc))
    p = pred.params
    t = Table(title=f"prediction: {pred.surface.name}, subject {pred.subject} ({pred.contact} contact)")
    t.add_column("quantity")
    t.add_column("value", justify="right")
    t.add_row("mu, p0, p1", f"{p.mu:.3g}, {p.p0:.4g} N/mm, {p.p1:.4g} N/mm")
    t.add_row("parameters from", pred.params_source)
    t.add_row("F_T on flat ground", f"{1e3 * pred.flat_level:.1f} mN")
    t.add_row("F_T max / min", f"{1e3 * pred.F_T.max():.1f} / {1e3 * pred.F_T.min():.1f} mN")
    t.add_row("F_def max", f"{1e3 * pred.F_def.max():.1f} mN")
    t.add_row("max simultaneous contacts", str(pred.max_contacts))
    spots = "; ".join(f"[{a:.2f}, {b:.2f}] ({b - a:.2f} mm)" for a, b in pred.blind_spots.intervals)
    t.add_row("blind spots (mm)", spots or "none")
    console.print(t)
    for kind, path in paths.items():
        console.print(f"  {kind:14s} {path}", highlight=False)


@app.command("render")
def render_cmd(
    surface: str = typer.Option(..., "--surface", help="Paper surface name, spec or CSV profile."),
    subject: int = typer.Option(..., "--subject", help="Subject 1 or 2."),
    out: str = typer.Option(..., "--out", help="Command signal file: .wav (float32) or .csv."),
    params: str = typer.Option(None, "--params", help="JSON parameters: FrictionParams or a fit output."),
    speed: float = typer.Option(80.0, "--speed", help="Sliding speed in mm/s."),
    rate: float = typer.Option(2000.0, "--rate", help="Display update rate in Hz."),
    normal_force: float = typer.Option(None, "--normal-force", help="Display normal force in N."),
    load: float = typer.Option(0.3, "--load", help="Normal force in N of the prediction."),
    mu_min: float = typer.Option(0.0, "--mu-min", help="Lowest mu the display can produce."),
    mu_max: float = typer.Option(5.0, "--mu-max", help="Highest mu the display can produce."),
    table: str = typer.Option(None, "--table", help="Also write the table CSV (x_mm, F_T_N, mu_cmd)."),
    step: float = typer.Option(0.01, "--step", help="Finger step in mm of the prediction."),
) -> None:
    """Friction command for a flat friction-modulating display, as a signal in time."""
    from .render import HapticRenderer

    try:
        r = HapticRenderer.for_surface(surface, subject, _predict_inputs(params), load=load,
                                       normal_force=normal_force, step=step, mu_range=(mu_min, mu_max))
        files = r.write_command(out, speed, rate)
        if table:
            files["table"] = r.write_table(table)
    except (ValueError, OSError, RuntimeError) as exc:
        fail(str(exc))
    d = r.display
    console.print(
        f"{r.prediction.surface.name}, subject {r.prediction.subject}: "
        f"mu_cmd {r.mu_cmd.min():.3f}..{r.mu_cmd.max():.3f}"
        f" (lateral force = mu_cmd x {d.effective_normal_force:.3f} N = p0 x L_flat; "
        f"{r.n_clipped} table entries clipped to [{d.mu_min:g}, {d.mu_max:g}])",
        highlight=False,
    )
    for kind, path in files.items():
        console.print(f"  {kind:8s} {path}", highlight=False)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``fingerfriction`` console script."""
    try:
        app(args=argv, standalone_mode=True)
    except SystemExit as exc:  # typer exits through SystemExit
        return int(exc.code or 0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
