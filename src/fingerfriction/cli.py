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


def _frame_positions(study: str, manifest: dict, trial: dict, positions: str | None, from_truth: bool,
                     from_video: bool):
    """Per-frame finger positions (mm) and contact regions (or None) for the forces command:
    a file, the video analysis, or the study's truth."""
    import numpy as np

    from .forces.readers import study_path

    if sum((positions is not None, from_truth, from_video)) > 1:
        raise ValueError("give only one of --positions, --from-video, --from-truth")
    if from_video:
        from .surfaces import surface_from_spec
        from .video import AnalysisOptions, analyze_video

        v = trial["video"]
        surface = surface_from_spec(manifest["surfaces"][trial["surface"]])
        H = float((trial.get("calibration") or {}).get("surface_height_mm", surface.max_height))
        opts = AnalysisOptions(calibration_frame=int(v.get("calibration_frame", 0)))
        res = analyze_video(study_path(study, v["path"], "video.path"), H, surface=surface, options=opts)
        return np.asarray(res.x, dtype=float), np.asarray(res.regions, dtype=float)
    return _positions_only(study, trial, positions, from_truth), None


def _positions_only(study: str, trial: dict, positions: str | None, from_truth: bool):
    import numpy as np

    from .forces.readers import study_path

    if positions is not None:
        if positions.endswith(".npy"):
            return np.load(positions, allow_pickle=False)
        import pandas as pd

        df = pd.read_csv(positions)
        if "x_mm" not in df.columns:
            raise ValueError(f"{positions!r} has no column 'x_mm' (columns: {list(df.columns)})")
        return df["x_mm"].to_numpy(dtype=float)
    if from_truth:
        if not trial.get("truth"):
            raise ValueError(f"trial {trial.get('id')!r} has no 'truth' file (not a simulated study)")
        path = study_path(study, trial["truth"], f"trial {trial.get('id')!r}: truth")
        with np.load(path, allow_pickle=False) as z:
            return np.asarray(z["x_finger_video"], dtype=float)
    raise ValueError(
        "finger positions are needed: --from-video (run the video analysis), --positions FILE "
        "(x_mm per video frame; .csv with column x_mm or .npy) or --from-truth (simulated studies)"
    )


@app.command("forces")
def forces_cmd(
    study: str = typer.Argument(..., help="study folder (with manifest.json)"),
    trial: str = typer.Argument(..., help="trial id"),
    out: str = typer.Option(None, "--out", help="write F_T(x) to this CSV (x_mm, F_T_N, F_N_N, n_samples)"),
    positions: str = typer.Option(None, "--positions", help="finger x (mm) per frame: .csv x_mm / .npy"),
    from_video: bool = typer.Option(False, "--from-video", help="x(t) and contact regions from the video"),
    from_truth: bool = typer.Option(False, "--from-truth", help="use the simulated study's true finger x"),
    highpass_hz: float = typer.Option(5.0, "--highpass-hz", help="sensor high-pass to invert, Hz; 0: none"),
    notch_q: float = typer.Option(10.0, "--notch-q", help="quality factor of the 50/150/300 Hz notches"),
) -> None:
    """Process the forces of one trial: F_T(x) on a 0.01 mm grid over the 26 mm window."""
    import json
    from pathlib import Path

    import numpy as np

    from .forces import ForceProcessingParams, process_trial

    try:
        manifest = json.loads((Path(study) / "manifest.json").read_text())
        rec = next((t for t in manifest.get("trials", []) if t.get("id") == trial), None)
        if rec is None:
            raise ValueError(f"no trial {trial!r} in {study}/manifest.json")
        x, regions = _frame_positions(study, manifest, rec, positions, from_truth, from_video)
        params = ForceProcessingParams(sensor_highpass_hz=highpass_hz or None, notch_q=notch_q)
        prof = process_trial(study, manifest, trial, x, params=params, regions=regions, on_error="flag")
        if out is not None:
            prof.write_csv(out)
    except (ValueError, OSError, KeyError) as exc:
        fail(str(exc).strip("'\""))
        return
    from rich.markup import escape

    for f in prof.flags:
        colour = "red" if f.severity == "error" else "yellow"
        tag = escape(f"[{f.code}]")
        console.print(f"[{colour}]{f.severity}[/] {tag} {escape(f.message)}", highlight=False)
    if not prof.success:
        fail(prof.message)
    ok = np.isfinite(prof.f_t)
    console.print(
        f"trial {trial}: F_T(x) on {prof.x.size} positions "
        f"[{prof.window_mm[0]:g}, {prof.window_mm[1]:g}] mm, "
        f"flat segment [{prof.flat_segment_mm[0]:.2f}, {prof.flat_segment_mm[1]:.2f}] mm; "
        f"F_T from {np.min(prof.f_t[ok]) * 1e3:.1f} to {np.max(prof.f_t[ok]) * 1e3:.1f} mN "
        f"(peak at x = {prof.x[np.argmax(prof.f_t)]:.2f} mm)",
        highlight=False,
    )
    console.print("steps: " + ", ".join(h["step"] for h in prof.history), highlight=False)
    if out is not None:
        console.print(f"wrote {out}", highlight=False)


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
