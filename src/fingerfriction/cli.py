"""Command line interface: a thin layer over the package's functions.

Each command below only parses options, calls the stage's public function and prints the
result; user errors (bad files, bad options) are caught and shown as one line, exit 2.
"""

from __future__ import annotations

import sys
from typing import Annotated

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


@app.callback()
def _root() -> None:
    """fingerfriction: finger contact, tactile blind spots and friction forces on relief surfaces."""
    # A callback keeps typer in sub-command mode even while only one command exists.


def demo_analysis(*, reps: int = 2, seed: int = 0, method: str = "lstsq", noise: float = 0.1,
                  speeds=(40, 80, 120)) -> dict:
    """Synthetic trials -> per-subject fit -> Table 1 and blind-spot tables.

    The study-pipeline issue replaces the synthetic trials by simulate + analyze; the
    returned dict (``trials``, ``truth``, ``fits``, ``table1``, ``blindspots``) is what the
    printing and writing below consume.
    """
    from .fit import fit_trials
    from .stats import blind_spot_table, correlation_table
    from .synthetic import synthetic_trials

    trials, truth = synthetic_trials(reps=reps, seed=seed, noise=noise, speeds=speeds)
    fits = fit_trials(trials, method=method)
    by_surface: dict[str, list] = {}
    for t in trials:
        by_surface.setdefault(t.surface.name, []).append(t.regions)
    return {"trials": trials, "truth": truth, "fits": fits, "table1": correlation_table(fits),
            "blindspots": blind_spot_table(by_surface)}


def _rich_table(df, title: str):
    from rich.table import Table

    t = Table(title=title)
    for c in df.columns:
        t.add_column(str(c))
    def cell(col, v):
        if col == "p" and isinstance(v, float):
            return "< 1e-300" if v == 0 else f"{v:.2g}"  # p underflows to 0 for large ensembles
        return f"{v:.3g}" if isinstance(v, float) else str(v)

    for row in df.itertuples(index=False):
        t.add_row(*[cell(c, v) for c, v in zip(df.columns, row, strict=True)])
    return t


@app.command()
def demo(
    out: str = typer.Option(None, "--out", help="Directory to write table1.{csv,md,tex} and "
                            "blindspots.{csv,md,tex} into (created if missing)."),
    reps: int = typer.Option(2, min=1, help="Repetitions per subject x surface x speed."),
    seed: int = typer.Option(0, help="Seed of the random generator."),
    method: str = typer.Option("lstsq", help="p0/p1 fit: 'lstsq' (closed form) or 'nelder-mead'."),
) -> None:
    """Fit the friction model to synthetic trials; print Table 1, blind spots and mu."""
    import os

    from .stats import write_table

    try:
        if method not in ("lstsq", "nelder-mead"):
            raise ValueError(f"--method must be 'lstsq' or 'nelder-mead', got {method!r}")
        if out is not None:
            os.makedirs(out, exist_ok=True)
        with console.status("simulating and fitting synthetic trials..."):
            res = demo_analysis(reps=reps, seed=seed, method=method)
        n = len(res["trials"])
        console.print(f"{n} synthetic trials ({reps} reps x 3 speeds x 6 surfaces x 2 subjects), "
                      f"{res['trials'][0].n} positions each, fit by {method}")
        tab = res["table1"][["subject", "scale", "shape", "rho", "p", "n_trials"]]
        console.print(_rich_table(tab, "Table 1: Pearson rho, measured vs model (detrended)"))
        console.print(_rich_table(res["blindspots"], "Tactile blind spots (all trials pooled)"))
        for s, f in res["fits"].items():
            true_mu = res["truth"]["mu"][s]
            status = "ok" if f.success else "[yellow]warning[/]"
            console.print(f"{s}: mu fitted {f.mu:.2f}, true {true_mu:.2f} ({status}: {f.message})")
        if out is not None:
            for name in ("table1", "blindspots"):
                for ext in ("csv", "md", "tex"):
                    write_table(res[name], os.path.join(out, f"{name}.{ext}"))
            console.print(f"tables written to {out}")
    except (ValueError, OSError) as exc:
        fail(str(exc))


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
        out_dir = out or "."
        if not os.path.isdir(out_dir):
            raise ValueError(f"--out {out_dir!r} is not an existing directory")
        surf = surface_from_spec(surface)
        finger = get_subject(subject)
        positions = default_positions(surf, step=step)
        with console.status(f"solving the contact at {positions.size} finger positions..."):
            res = sweep(surf, finger, positions, load=load)
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


def _split_list(values: list[str] | None) -> list[str] | None:
    """Accept both ``--surfaces a b`` style repeats and comma lists ``--surfaces a,b``."""
    if not values:
        return None
    out: list[str] = []
    for v in values:
        out.extend(p.strip() for p in v.split(",") if p.strip())
    return out


@app.command("simulate")
def simulate_cmd(
    out: Annotated[str, typer.Option("--out", help="Output study folder (new, empty, or same study).")],
    reps: Annotated[int, typer.Option("--reps", help="Repetitions per condition (the paper: 5).")] = 5,
    seed: Annotated[int, typer.Option("--seed", help="Study seed: same seed, byte-identical study.")] = 0,
    surfaces: Annotated[
        list[str] | None, typer.Option("--surfaces", help="Surfaces, e.g. bump-2mm,step-up-4mm (default: 6).")
    ] = None,
    subjects: Annotated[
        list[str] | None, typer.Option("--subjects", help="Subjects: 1, 2 (default: both).")
    ] = None,
    speeds: Annotated[
        list[str] | None, typer.Option("--speeds", help="Nominal speeds in mm/s (default 40,80,120).")
    ] = None,
    workers: Annotated[int, typer.Option("--workers", help="Worker processes (0: all cores).")] = 0,
    video_format: Annotated[str, typer.Option("--video-format", help="ffv1-mkv or tiff.")] = "ffv1-mkv",
    contact_model: Annotated[
        str, typer.Option("--contact-model", help="mechanics-bem (default) or bridged-foundation (fast).")
    ] = "mechanics-bem",
) -> None:
    """Simulate recordings (video + force sensor) of the paper's study with known ground truth."""
    import time

    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from .sim import SimOptions, simulate_study
    from .study import ManifestError

    kw: dict = {"reps": reps, "seed": seed, "video_format": video_format,
                "contact_model": contact_model}
    if _split_list(surfaces):
        kw["surfaces"] = tuple(_split_list(surfaces))
    if _split_list(subjects):
        kw["subjects"] = tuple(_split_list(subjects))
    if _split_list(speeds):
        sp = []
        for v in _split_list(speeds):
            try:
                sp.append(float(v))
            except ValueError:
                fail(f"--speeds: {v!r} is not a number (mm/s)")
        kw["speeds"] = tuple(sp)
    if workers < 0:
        fail(f"--workers must be >= 0 (0: all cores), got {workers}")
    try:
        opts = SimOptions(**kw)
    except ValueError as exc:
        fail(str(exc))
    t0 = time.perf_counter()
    with Progress(
        TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
        TextColumn("{task.fields[label]}"), console=console, transient=False,
    ) as prog:
        tasks: dict = {}

        def report(stage: str, done: int, total: int, label: str) -> None:
            if stage not in tasks:
                name = "contact tables" if stage == "tables" else "trials"
                tasks[stage] = prog.add_task(name, total=total, label="")
            prog.update(tasks[stage], completed=done, label=label)

        try:
            study = simulate_study(out, opts, workers=workers or None, progress=report)
        except (ValueError, OSError, ManifestError) as exc:
            prog.stop()
            fail(str(exc))
    dt = time.perf_counter() - t0
    console.print(
        f"[green]wrote[/] {len(study.trials)} trials to {out}/manifest.json in {dt:.1f} s "
        f"(ground truth in {out}/truth/)"
    )


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
