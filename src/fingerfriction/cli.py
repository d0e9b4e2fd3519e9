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
    out: str = typer.Option(..., "--out", help="Output study folder (new, empty, or the same study to resume)."),
    reps: int = typer.Option(5, "--reps", help="Repetitions per condition (the paper: 5)."),
    seed: int = typer.Option(0, "--seed", help="Study seed: the same seed gives byte-identical studies."),
    surfaces: list[str] = typer.Option(None, "--surfaces", help="Surface names, e.g. bump-2mm,step-up-4mm."),
    subjects: list[str] = typer.Option(None, "--subjects", help="Subjects: 1, 2."),
    speeds: list[str] = typer.Option(None, "--speeds", help="Nominal speeds in mm/s, e.g. 40,80,120."),
    workers: int = typer.Option(0, "--workers", help="Worker processes (0: all cores)."),
    video_format: str = typer.Option("ffv1-mkv", "--video-format", help="ffv1-mkv or tiff."),
) -> None:
    """Simulate recordings (video + force sensor) of the paper's study with known ground truth."""
    import time

    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from .sim import SimOptions, simulate_study
    from .study import ManifestError

    kw: dict = {"reps": reps, "seed": seed, "video_format": video_format}
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


@app.command("overlay")
def overlay_cmd(
    study: str = typer.Argument(..., help="Study folder (or its manifest.json)."),
    trial: str = typer.Argument(..., help="Trial id, as in the manifest."),
    out: str = typer.Option(None, "--out", help="Output .mp4 or .gif (default: <trial>-overlay.mp4)."),
    start: int = typer.Option(0, "--start", help="First frame."),
    stop: int = typer.Option(None, "--stop", help="Stop before this frame (default: the last)."),
    step: int = typer.Option(1, "--step", help="Draw every STEP-th frame."),
    fps: float = typer.Option(30.0, "--fps", help="Playback frame rate of the output (Hz)."),
    level: float = typer.Option(None, "--level", help="Threshold gray level (default: Otsu)."),
    scale: float = typer.Option(1.0, "--scale", help="Resize factor of the 1260x360 crop."),
) -> None:
    """Write a video of a trial's frames with the traced contours and contact regions drawn."""
    from .study import ManifestError, load_manifest
    from .video import AnalysisOptions
    from .video.overlay import write_overlay

    try:
        st = load_manifest(study)
        tr = st.trial(trial)
        opts = AnalysisOptions(level=level, calibration_frame=tr.video.calibration_frame)
        info = write_overlay(
            st.path(tr.video.path), tr.calibration["surface_height_mm"], out or f"{trial}-overlay.mp4",
            surface=st.surface(tr.surface), options=opts, start=start, stop=stop, step=step, fps=fps,
            scale=scale,
        )
    except KeyError as exc:
        fail(str(exc.args[0]) if exc.args else str(exc))
    except (ValueError, OSError, ManifestError) as exc:
        fail(str(exc))
    console.print(f"[green]wrote[/] {info.path}: {info.n_frames} frames ({info.n_flagged} flagged)")



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
