"""Command line interface: a thin layer over the package's functions.

Each command below only parses options, calls the stage's public function and prints the
result; user errors (bad files, bad options) are caught and shown as one line, exit 2.
"""

from __future__ import annotations

import os
import sys
import time
from typing import Annotated

import numpy as np
import typer
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from . import __version__
from ._cli_help import readable_help_types
from ._console import console_log, one_line, summary_line
from ._outputs import check_output_dir, output_dir, output_file
from .surfaces import surface_from_spec

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="fingerfriction: finger contact, tactile blind spots and friction forces on relief surfaces.",
)
console = Console()
err_console = Console(stderr=True)


readable_help_types()


class UserError(Exception):
    """An error in the user's input, shown as one line without a traceback."""


def fail(message: str) -> None:
    """Print a one-line error and exit with status 2."""
    err_console.print(f"[bold red]error:[/] {message}", highlight=False, soft_wrap=True)
    raise typer.Exit(2)


def _finger_file(path: str | None = None, items: list[str] | None = None):
    """``--finger FILE`` (a finger) or ``--finger SUBJECT=FILE`` items (a dict), one-line errors."""
    from .mechanics import finger_file  # small, but only when --finger is given

    try:
        return finger_file.read_subject_fingers(items) if path is None else finger_file.read_finger_file(path)
    except ValueError as exc:
        fail(str(exc))


# ---------------------------------------------------------------------------------------
# the console of the long commands: --verbose / --quiet, grouped warnings, one summary line
# ---------------------------------------------------------------------------------------

VERBOSE = typer.Option(False, "--verbose", "-v", help="Show every log record and every failure as it comes.")
QUIET = typer.Option(False, "--quiet", "-q", help="Print only the summary line.")


def _verbosity(verbose: bool, quiet: bool) -> int:
    """-1 quiet, 0 normal, 1 verbose."""
    if verbose and quiet:
        fail("--verbose and --quiet exclude each other")
    return 1 if verbose else -1 if quiet else 0


def _show_progress(verbosity: int) -> bool:
    """Progress bars on an interactive terminal only: in a log file they are noise."""
    return verbosity >= 0 and err_console.is_terminal


def _echo(text: str) -> None:
    err_console.print(escape(text), highlight=False, soft_wrap=True)


def _warn(text: str) -> None:
    err_console.print(f"[yellow]warning:[/] {escape(text)}", highlight=False, soft_wrap=True)


def _grouped_failures(failures, what: str, verbosity: int, label_of=None) -> None:
    """Failures as one warning line per group (a subject, or all), with a count and one
    example; every failure with ``--verbose``; nothing with ``--quiet``."""
    failures = list(failures)
    if verbosity < 0 or not failures:
        return
    if verbosity > 0:
        for tid, reason in failures:
            _warn(f"{what} failed: {tid}: {one_line(reason, 300)}")
        return
    groups: dict = {}
    for tid, reason in failures:
        groups.setdefault(label_of(tid) if label_of else "", []).append((tid, reason))
    for label, items in groups.items():
        tid, reason = items[0]
        head = f"{label}: " if label else ""
        _warn(f"{head}{len(items)} {what} failure{'s' if len(items) != 1 else ''} "
              f"(e.g. {tid}: {one_line(reason, 120)})")


def _n(count: int, noun: str) -> str:
    """'1 trial', '2 trials'."""
    return f"{count} {noun}{'' if count == 1 else 's'}"


def _summary(text: str) -> None:
    console.print(escape(text), highlight=False, soft_wrap=True)


# ---------------------------------------------------------------------------------------
# demo (simulate + analyze + fit + report; fingerfriction.demo)
# ---------------------------------------------------------------------------------------


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


def _csv(values: str | None) -> tuple[str, ...] | None:
    return None if not values else tuple(v.strip() for v in values.split(",") if v.strip())


@app.command()
def demo(
    out: str = typer.Option("fingerfriction-demo", "--out", "-o",
                            help="Folder for the simulated study and its results (resumed if it exists)."),
    full: bool = typer.Option(False, "--full", help="The paper's 180 trials (default: 36, 1 per condition)."),
    reps: int = typer.Option(None, "--reps", min=1, help="Repetitions per condition (overrides --full)."),
    seed: int = typer.Option(0, "--seed", min=0, help="Seed of the virtual experiment."),
    workers: int = typer.Option(None, "--workers", "-j", min=1, help="Worker processes (default: all)."),
    subjects: str = typer.Option(None, hidden=True, help="Comma-separated subjects (a smaller design)."),
    surfaces: str = typer.Option(None, hidden=True, help="Comma-separated surfaces (a smaller design)."),
    speeds: str = typer.Option(None, hidden=True, help="Comma-separated speeds in mm/s (a smaller design)."),
    verbose: bool = VERBOSE,
    quiet: bool = QUIET,
) -> None:
    """Simulate the built-in default study, analyze it, fit the model, write the report;
    print Table 1 and the blind-spot table."""
    from .demo import demo as run_demo  # heavy (every stage); imported when the command runs
    from .study.store import ResultsStore  # heavy (pandas, scipy); imported when the command runs

    verbosity = _verbosity(verbose, quiet)
    try:
        design = {}
        for key, val in (("subjects", _csv(subjects)), ("surfaces", _csv(surfaces))):
            if val:
                design[key] = val
        if speeds:
            try:
                design["speeds"] = tuple(float(v) for v in _csv(speeds))
            except ValueError:
                raise ValueError(f"--speeds must be numbers (mm/s) separated by commas, got {speeds!r}") \
                    from None
        output_dir(out, owns={"study", "results"}, what="demo folder (study/, results/)")
        with console_log(verbosity, _echo) as log:
            res = run_demo(out, full=full, reps=reps, seed=seed, n_workers=workers,
                           progress=_show_progress(verbosity), design=design)
    except (ValueError, OSError) as exc:
        fail(str(exc))
    a, f = res.analysis, res.fit
    _grouped_failures(a.failures, "analysis", verbosity)
    _fit_warnings(f, ResultsStore(res.results), verbosity)
    if verbosity >= 0:
        _print_tables(res.report)
    t = res.elapsed_s
    _summary(summary_line(
        "demo", [_n(a.n_trials, "trial"), f"simulate {t['simulate']:.0f} s",
                 f"analyze {t['analyze']:.0f} s ({a.n_computed} computed, {a.n_skipped} already done, "
                 f"{a.n_failed} failed)", f"fit {t['fit']:.0f} s ({f.n_failed} failed, {f.model} model: mu "
                 + ", ".join(f"{m:.2f} (subject {s})" for s, m in f.mu.items()) + ")",
                 f"report {t['report']:.0f} s ({_n(len(res.report.pages), 'trial page')})"],
        elapsed_s=sum(t.values()), output=str(res.report.html), log=log))


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
        "predict-contact", "--out", help="Folder for the occupancy figure (PNG); created if missing."
    ),
    finger_path: str = typer.Option(
        None, "--finger", help="Finger JSON file (calibrate-finger) instead of the subject's default."
    ),
) -> None:
    """Predict tactile blind spots and simultaneous contacts of a finger sliding over a surface."""
    from .mechanics import default_positions, get_subject, sweep  # heavy (numba); when the command runs
    from .mechanics.figures import save_occupancy_figure  # heavy (matplotlib); when the command runs

    try:
        if kind not in ("geometric", "mechanical"):
            raise ValueError(f"--kind must be 'geometric' or 'mechanical', got {kind!r}")
        surf = surface_from_spec(surface)
        owns = {"owns": lambda n: n.startswith("occupancy-") and n.endswith(".png"),
                "what": "folder of occupancy figures"}
        check_output_dir(out, **owns)
        finger = get_subject(subject) if finger_path is None else _finger_file(finger_path)
        positions = default_positions(surf, step=step)
        with console.status(f"solving the contact at {positions.size} finger positions..."):
            res = sweep(surf, finger, positions, load=load)
        bs = res.blind_spots(kind)
        name = f"occupancy-{surf.name}-s{subject}.png"
        png = save_occupancy_figure(res, surf, output_dir(out, **owns) / name, kind=kind)
    except (ValueError, TypeError, OSError) as exc:
        fail(str(exc))
        return
    who = f"subject {subject}" if finger_path is None else f"finger {finger.name or finger_path}"
    table = Table(title=f"Tactile blind spots: {surf.name}, {who}, {load:g} N ({kind} contact)")
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
    realism: Annotated[bool, typer.Option(
        "--realism", help="A harder study: friction drawn per trial (10 % SD), falling with load, and the "
                          "normal force wandering over +-50 mN (fingerfriction.sim.RealismParams).")] = False,
    finger: Annotated[
        list[str] | None,
        typer.Option("--finger", help="SUBJECT=FILE: that subject's finger, a finger JSON file (repeat)."),
    ] = None,
    finger_seed: Annotated[
        int | None,
        typer.Option("--finger-seed", help="Draw the other subjects' fingers around the calibrated ones "
                     "(radius, modulus, flat length +-25 %) with this seed."),
    ] = None,
    verbose: bool = VERBOSE,
    quiet: bool = QUIET,
) -> None:
    """Simulate recordings (video + force sensor) of the paper's study with known ground truth."""
    from .sim import (  # heavy (video encoder, mechanics); when the command runs
        RealismParams,
        SimOptions,
        simulate_study,
    )

    kw: dict = {"reps": reps, "seed": seed, "video_format": video_format,
                "contact_model": contact_model, "realism": RealismParams() if realism else None}
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
    if finger:
        kw["fingers"] = _finger_file(items=finger)
    if finger_seed is not None:
        kw["finger_seed"] = finger_seed
    try:
        opts = SimOptions(**kw)
    except ValueError as exc:
        fail(str(exc))
    verbosity = _verbosity(verbose, quiet)
    t0 = time.perf_counter()
    with Progress(
        TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
        TextColumn("{task.fields[label]}"), console=err_console, transient=False,
        disable=not _show_progress(verbosity),
    ) as prog, console_log(verbosity, _echo) as log:
        tasks: dict = {}

        def report(stage: str, done: int, total: int, label: str) -> None:
            if stage not in tasks:
                name = "contact tables" if stage == "tables" else "trials"
                tasks[stage] = prog.add_task(name, total=total, label="")
            prog.update(tasks[stage], completed=done, label=label)

        try:
            study = simulate_study(out, opts, workers=workers or None, progress=report)
        except (ValueError, OSError) as exc:
            prog.stop()
            fail(str(exc))
    _summary(summary_line("simulate", [_n(len(study.trials), "trial") + " written",
                                       f"ground truth in {out}/truth/"],
                          elapsed_s=time.perf_counter() - t0, output=f"{out}/manifest.json", log=log))


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
    from .study.params import video_options  # heavy (video stage); imported when the command runs
    from .study.trial import TrialInput  # heavy (both stages); imported when the command runs
    from .video.overlay import write_overlay  # heavy (OpenCV, PyAV); imported when the command runs

    try:
        tr = TrialInput.from_study(study, trial)
        opts = video_options({"level": level}, tr.record.video.calibration_frame)  # as `analyze`
        info = write_overlay(
            tr.path(tr.record.video.path, "video.path"), tr.height_mm, out or f"{trial}-overlay.mp4",
            surface=tr.surface, options=opts, start=start, stop=stop, step=step, fps=fps, scale=scale,
        )
    except KeyError as exc:
        fail(str(exc.args[0]) if exc.args else str(exc))
    except (ValueError, OSError) as exc:
        fail(str(exc))
    console.print(f"[green]wrote[/] {info.path}: {info.n_frames} frames ({info.n_flagged} flagged)")



# ---------------------------------------------------------------------------------------
# forces (force processing, fingerfriction.forces)
# ---------------------------------------------------------------------------------------


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
    estimate_highpass: bool = typer.Option(
        False, "--estimate-highpass", help="fit the sensor cut-off on the rests (--highpass-hz: the prior)"
    ),
) -> None:
    """Process the forces of one trial: F_T(x) on a 0.01 mm grid over the 26 mm window.

    With --from-video, x(t) and the contact regions come from the video stage run exactly as
    `analyze` runs it (the same options)."""
    from .forces import ForceProcessingParams  # heavy (scipy); imported when the command runs
    from .study.trial import TrialInput, finger_positions, process_trial_forces  # heavy: both stages

    try:
        tr = TrialInput.from_study(study, trial)
        x, regions = finger_positions(tr, positions=positions, from_truth=from_truth, from_video=from_video)
        params = ForceProcessingParams(
            sensor_highpass_hz=highpass_hz or None, notch_q=notch_q, estimate_highpass=estimate_highpass
        )
        prof = process_trial_forces(tr, x, params=params, regions=regions, on_error="flag")
        if out is not None:
            prof.write_csv(output_file(out))
    except KeyError as exc:
        fail(str(exc.args[0]) if exc.args else str(exc))
        return
    except (ValueError, OSError) as exc:
        fail(str(exc).strip("'\""))
        return
    for f in prof.flags:
        colour = "red" if f.severity == "error" else "yellow"
        tag = escape(f"[{f.code}]")
        console.print(f"[{colour}]{f.severity}[/] {tag} {escape(f.message)}", highlight=False)
    if not prof.success:
        fail(prof.message)
    ok = ~np.isnan(prof.f_t)
    console.print(
        f"trial {trial}: F_T(x) on {prof.x.size} positions "
        f"[{prof.window_mm[0]:g}, {prof.window_mm[1]:g}] mm, "
        f"flat segment [{prof.flat_segment_mm[0]:.2f}, {prof.flat_segment_mm[1]:.2f}] mm; "
        f"F_T from {np.min(prof.f_t[ok]) * 1e3:.1f} to {np.max(prof.f_t[ok]) * 1e3:.1f} mN "
        f"(peak at x = {prof.x[np.argmax(prof.f_t)]:.2f} mm)",
        highlight=False,
    )
    console.print("steps: " + ", ".join(h["step"] for h in prof.history), highlight=False)
    est = next((h for h in prof.history if h["step"] == "estimate_highpass"), None)
    if est is not None and est["success"]:
        console.print(
            f"sensor cut-off estimated on the rests: {est['cutoff_hz']:.4f} +- {est['se_hz']:.4f} Hz "
            f"(prior {est['prior_hz']:g} Hz)",
            highlight=False,
        )
    if out is not None:
        console.print(f"wrote {out}", highlight=False)


# ---------------------------------------------------------------------------------------
# analyze / fit / report (study pipeline, fingerfriction.study and .report)
# ---------------------------------------------------------------------------------------


@app.command("analyze")
def analyze_cmd(
    study: str = typer.Argument(..., help="Study folder (with manifest.json)."),
    out: str = typer.Option(..., "--out", "-o", help="Results folder (created; resumed if it exists)."),
    scheduler: str = typer.Option(None, "--scheduler", help="Address of a running Dask scheduler, "
                                  "e.g. tcp://10.0.0.5:8786 (default: a local cluster on all cores)."),
    workers: int = typer.Option(None, "--workers", "-j", min=1, help="Local workers (default: all cores)."),
    force: bool = typer.Option(False, "--force", help="Recompute trials that are already finished."),
    window_mm: float = typer.Option(None, "--window-mm", help="Force position window in mm, centred on the "
                                    "feature (default: the paper's 26 mm)."),
    position: str = typer.Option("hybrid", "--position", help="x(t) estimator: hybrid (chord midpoint, "
                                 "else an outline edge; default) or cf-centroid (the paper's C_f centroid) "
                                 "or chord."),
    simulated: bool = typer.Option(False, "--simulated", help="Options for studies of the virtual "
                                   "experiment (only matter with --position cf-centroid: narrower window, "
                                   "x(t) extended; see README)."),
    dry_run: bool = typer.Option(False, "--dry-run", help="List the trials that would be computed and why "
                                 "(new, input changed, manifest entry changed, parameters changed); run "
                                 "and write nothing."),
    verbose: bool = VERBOSE,
    quiet: bool = QUIET,
) -> None:
    """Every trial through video analysis and force processing, in parallel (resumable).

    The study is checked first (as `fingerfriction check`): mistakes in the manifest stop
    the run; a trial whose recordings do not match its entry fails, the others go on. A
    finished trial is computed again when its input files, its manifest entry or the
    analysis parameters changed."""
    from .study.analyze import StudyCheckError, analyze, plan_analysis  # heavy (Dask, both stages)
    from .study.params import POSITIONS, AnalysisParams, sim_params  # heavy (both stages), as above

    try:
        if position not in POSITIONS:
            raise ValueError(f"--position must be one of {', '.join(POSITIONS)}, got {position!r}")
        opts = sim_params(position) if simulated else {"video": {"position": position}, "forces": {}}
        if window_mm is not None:
            opts["forces"]["window_mm"] = window_mm
        params = AnalysisParams(**opts)
        verbosity = _verbosity(verbose, quiet)
        if dry_run:
            plan = plan_analysis(study, out, params=params, force=force)
        else:
            with console_log(verbosity, _echo) as log:
                res = analyze(study, out, scheduler=scheduler, n_workers=workers, force=force,
                              progress=_show_progress(verbosity), params=params)
    except StudyCheckError as exc:
        _print_problems(exc.problems)
        fail(f"{len(exc.problems)} problem(s) in the manifest; nothing was run")
    except (ValueError, OSError) as exc:
        fail(str(exc))
    if dry_run:
        for p in plan.trials:
            console.print(f"{p.trial_id}: {p.action} ({p.reason})", highlight=False, soft_wrap=True)
        console.print(f"would compute {len(plan.todo)} and skip {len(plan.skipped)} of {len(plan.trials)} "
                      "trials; nothing was run or written", highlight=False)
        return
    _grouped_failures(res.failures, "analysis", verbosity)
    _summary(summary_line(
        "analyze", [f"{res.n_computed} computed", f"{res.n_skipped} already done",
                    f"{res.n_failed} failed of {_n(res.n_trials, 'trial')}",
                    f"{res.scheduler} scheduler, {res.n_workers} workers"],
        elapsed_s=res.elapsed_s, output=str(res.results), log=log))


def _print_problems(problems) -> None:
    for p in problems:
        err_console.print(escape(str(p)), highlight=False, soft_wrap=True)


@app.command("check")
def check_cmd(
    study: str = typer.Argument(..., help="Study folder (with manifest.json), or the manifest."),
) -> None:
    """Validate a study and list every problem at once: each manifest field of each trial,
    and each recording against its entry (present, readable, frame count and rate, image
    size, force channels, sample count and rate). Exit status 2 if there is any."""
    from .study.check import check_study  # heavy (video and force readers); imported when run

    res = check_study(study)
    _print_problems(res.problems)
    n_ok = len(res.study.trials) if res.study is not None else 0
    if res.problems:
        whole = "" if res.study is not None else "; the manifest as a whole cannot be read"
        fail(f"{len(res.problems)} problem(s): {n_ok} of {res.n_entries} trials are fine, "
             f"{len(res.by_trial())} have problems{whole}")
    console.print(f"{res.manifest}: {n_ok} trials, no problem found", highlight=False)


@app.command("fit")
def fit_cmd(
    results: str = typer.Argument(..., help="Results folder written by `fingerfriction analyze`."),
    model: str = typer.Option("load", help="Default model, load (load-consistent Eq. 4) or paper (as "
                                           "printed); both are fitted, this one is used downstream."),
    method: str = typer.Option("lstsq", help="Paper model's p0, p1 fit: lstsq or nelder-mead (the paper's)."),
    mu_min: float = typer.Option(0.30, help="Smallest mu of the paper model's grid."),
    mu_max: float = typer.Option(0.90, help="Largest mu of the paper model's grid."),
    mu_step: float = typer.Option(0.01, help="Step of the paper model's mu grid."),
    median: int = typer.Option(11, help="Median filter window on the models, samples (odd; 1 = off)."),
    seed: int = typer.Option(0, help="Seed of the bootstrap confidence intervals."),
    verbose: bool = VERBOSE,
    quiet: bool = QUIET,
) -> None:
    """Both model variants: mu per subject, per-trial parameters, Table 1 with CIs, flags."""
    from .study.fitting import fit  # heavy (scipy, the forward model); imported when the command runs
    from .study.store import ResultsStore  # heavy (pandas, scipy); imported when the command runs

    verbosity = _verbosity(verbose, quiet)
    t0 = time.perf_counter()
    try:
        with console_log(verbosity, _echo) as log:
            res = fit(results, model=model, mu_grid=(mu_min, mu_max, mu_step), method=method,
                      median_kernel=median, progress=_show_progress(verbosity), seed=seed)
    except (ValueError, OSError) as exc:
        fail(str(exc))
    store = ResultsStore(results)
    _fit_warnings(res, store, verbosity)
    _summary(summary_line("fit", _fit_facts(res), elapsed_s=time.perf_counter() - t0,
                          output=str(store.fit_dir), log=log))


def _fit_facts(res) -> list[str]:
    """The fit's summary: trials, models, mu per subject with its CI, flags, validation."""
    n_err = sum(f.level == "error" for f in res.flags)
    mu = ", ".join(("not measured" if m != m else f"{m:.3f}")
                   + (f" [{res.mu_ci[s][0]:.3f}, {res.mu_ci[s][1]:.3f}]"
                      if s in res.mu_ci and all(v == v for v in res.mu_ci[s]) else "")
                   + f" (subject {s})" for s, m in res.mu.items())
    val = ("validated (leave one surface out)" if res.loso is not None
           else f"not validated: {res.loso_message}")
    return [_n(res.n_trials, "trial"), f"both models, {res.model} the default", f"mu {mu}",
            f"{res.n_failed} failed", f"{n_err} error flags, {len(res.flags) - n_err} warnings", val]


def _fit_warnings(res, store, verbosity: int) -> None:
    """One warning line per subject: its flags of both models grouped by kind, each with a
    count and one example (with --verbose: each subject's and model's summary line and every
    flag); trials that could not be prepared for the fit, one line."""
    if verbosity < 0:
        return
    unread = [(t, r) for t, r in res.failures if not any(f.trial == t for f in res.flags)]
    if verbosity > 0:
        for line in res.lines:
            _echo(line)
        for f in res.flags:
            where = f.trial or (f"subject {f.subject}" if f.subject else "study")
            _warn(f"{f.level} {f.code} ({f.model} model) {where}: {one_line(f.message, 300)}")
        for tid, reason in unread:
            _warn(f"not fitted: {tid}: {one_line(reason, 300)}")
        return
    if unread:
        _warn(f"{_n(len(unread), 'trial')} could not be prepared for the fit (e.g. {unread[0][0]}: "
              f"{one_line(unread[0][1], 100)})")
    by_subject: dict = {}
    for f in res.flags:
        if f.level in ("error", "warning"):
            by_subject.setdefault(f.subject or "", {}).setdefault((f.model, f.code), []).append(f)
    for subj, groups in by_subject.items():
        parts = []
        for (model, code), fs in groups.items():
            n_tr = len({f.trial for f in fs if f.trial})
            first = fs[0]
            where = f"{first.trial}: " if first.trial else ""
            parts.append(f"{model} model {code}" + (f" in {_n(n_tr, 'trial')}" if n_tr else "")
                         + f" (e.g. {where}{one_line(first.message, 90)})")
        _warn((f"subject {subj}: " if subj else "") + "; ".join(parts))


def _print_tables(rep) -> None:
    from .report.tables import format_p, table1_display  # heavy (matplotlib); when a table is printed

    if rep.table1 is not None:
        wide = table1_display(rep.table1)
        t = Table(title="Table 1: Pearson rho, measured vs model (* p < 0.01)")
        for c in wide.columns:
            t.add_column(str(c))
        for row in wide.itertuples(index=False):
            t.add_row(*[str(v) for v in row])
        console.print(t)
    if getattr(rep, "loso", None) is not None:
        t = Table(title="Out of sample (leave one surface out): rho per held-out surface")
        for c in ("subject", "held-out surface", "trials", "rho in sample", "rho out of sample", "p out"):
            t.add_column(c)
        for r in rep.loso.itertuples(index=False):
            t.add_row(str(r.subject), str(r.surface), str(r.n_trials), f"{r.rho_in_sample:.2f}",
                      f"{r.rho_out_of_sample:.2f}", format_p(r.p_out_of_sample))
        console.print(t)
    t = Table(title="Tactile blind spots (all trials pooled)")
    for c in ("surface", "trials", "start (mm)", "end (mm)", "width (mm)"):
        t.add_column(c)
    for r in rep.blindspots.itertuples(index=False):
        none = r.start_mm != r.start_mm  # NaN: a surface without blind spots
        t.add_row(str(r.surface), str(r.n_trials), "-" if none else f"{r.start_mm:.2f}",
                  "-" if none else f"{r.end_mm:.2f}", "none" if none else f"{r.width_mm:.2f}")
    console.print(t)
    for key, df in rep.truth.items():
        t = Table(title=f"Recovered vs ground truth: {key}")
        for c in df.columns:
            t.add_column(str(c))
        for row in df.itertuples(index=False):
            t.add_row(*[f"{v:.3f}" if isinstance(v, float) else str(v) for v in row])
        console.print(t)


@app.command("report")
def report_cmd(
    results: str = typer.Argument(..., help="Results folder (after analyze; fit for Fig. 6/S3, Table 1)."),
    sample: int = typer.Option(6, "--sample", min=0,
                               help="Trial pages for every flagged trial and this many of the others."),
    all_trials: bool = typer.Option(False, "--all-trials", help="A page for every trial."),
    animations: bool = typer.Option(True, "--animations/--no-animations",
                                    help="Overlay animation on each trial page (needs the study's videos)."),
    verbose: bool = VERBOSE,
    quiet: bool = QUIET,
) -> None:
    """Figures (PNG, SVG), Table 1, blind-spot table, a self-contained HTML report and a page
    per flagged (and sampled) trial."""
    from .report import make_report  # heavy (matplotlib, jinja2); imported when the command runs

    verbosity = _verbosity(verbose, quiet)
    t0 = time.perf_counter()
    try:
        with console_log(verbosity, _echo) as log:
            rep = make_report(results, progress=_show_progress(verbosity),
                              sample=None if all_trials else sample, animations=animations)
    except (ValueError, OSError) as exc:
        fail(str(exc))
    if verbosity >= 0:
        _print_tables(rep)
        for note in rep.notices:  # e.g. not fitted: said before the path, as at the top of the page
            console.print(f"[bold yellow]note:[/] {escape(note)}", highlight=False, soft_wrap=True)
    kinds: dict = {}
    for f in rep.flags:
        if f["level"] != "info":
            kinds.setdefault(f["code"], []).append(f)
    flagged = " ".join(f"{c} x{len(v)}" for c, v in kinds.items())
    _summary(summary_line(
        "report", [_n(rep.n_trials + rep.n_failed, "trial"), "not fitted" if not rep.fitted else "",
                   _n(len(rep.pages), "trial page"), f"flags: {flagged}" if flagged else "nothing flagged",
                   f"{len(rep.files)} files"],
        elapsed_s=time.perf_counter() - t0, output=str(rep.html), log=log))


# ---------------------------------------------------------------------------------------
# predict / render (prediction and haptic rendering)
# ---------------------------------------------------------------------------------------


def _predict_inputs(params):
    """--params: None or a JSON path (parameters, a fit's fit.json or its RESULTS folder)."""
    return None if params is None else str(params)


#: The files ``predict`` writes in its folder (``Prediction.write``).
PREDICTION_FILES = {"forces.csv", "regions.csv", "occupancy.csv", "blind_spots.csv", "prediction.json",
                    "forces.png", "occupancy.png"}


@app.command("predict")
def predict_cmd(
    surface: str = typer.Option(..., "--surface", help="Name (bump-4mm), spec (bump:W=3,H=0.5) or CSV."),
    subject: int = typer.Option(..., "--subject", help="Subject 1 or 2 (calibrated forward-model finger)."),
    params: str = typer.Option(None, "--params", help="JSON parameters, or a fit's RESULTS folder."),
    model: str = typer.Option(None, "--model", help="load or paper (default: the fit's, else load)."),
    out: str = typer.Option("prediction", "--out", help="Output folder for CSV, JSON and PNG files "
                            "(created if missing)."),
    load: float = typer.Option(0.3, "--load", help="Normal force in N."),
    step: float = typer.Option(0.01, "--step", help="Finger step in mm."),
    contact: str = typer.Option("geometric", "--contact", help="geometric (70 um) or mechanical."),
    figures: bool = typer.Option(True, "--figures/--no-figures", help="Write PNG figures."),
    finger_path: str = typer.Option(
        None, "--finger", help="Finger JSON file (calibrate-finger) instead of the subject's default."
    ),
) -> None:
    """Predict F_T(x), F_int, F_def, contact occupancy and blind spots on any relief."""
    from .predict import predict  # heavy (the forward model); imported when the command runs

    finger = None if finger_path is None else _finger_file(finger_path)
    try:
        owns = {"owns": PREDICTION_FILES, "what": "prediction folder"}
        check_output_dir(out, **owns)
        pred = predict(surface, subject, _predict_inputs(params), load=load, step=step, contact=contact,
                       model=model, finger=finger)
        paths = pred.write(output_dir(out, **owns), figures=figures)
    except (ValueError, OSError, RuntimeError) as exc:
        fail(str(exc))
    t = Table(title=f"prediction: {pred.surface.name}, subject {pred.subject} ({pred.contact} contact)")
    t.add_column("quantity")
    t.add_column("value", justify="right")
    t.add_row("parameters", pred.params_text)
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
    params: str = typer.Option(None, "--params", help="JSON parameters, or a fit's RESULTS folder."),
    model: str = typer.Option(None, "--model", help="load or paper (default: the fit's, else load)."),
    speed: float = typer.Option(80.0, "--speed", help="Sliding speed in mm/s."),
    rate: float = typer.Option(2000.0, "--rate", help="Display update rate in Hz."),
    normal_force: float = typer.Option(None, "--normal-force", help="Display normal force in N."),
    load: float = typer.Option(0.3, "--load", help="Normal force in N of the prediction."),
    mu_min: float = typer.Option(0.0, "--mu-min", help="Lowest mu the display can produce."),
    mu_max: float = typer.Option(5.0, "--mu-max", help="Highest mu the display can produce."),
    table: str = typer.Option(None, "--table", help="Also write the table CSV (x_mm, F_T_N, mu_cmd)."),
    step: float = typer.Option(0.01, "--step", help="Finger step in mm of the prediction."),
    finger_path: str = typer.Option(
        None, "--finger", help="Finger JSON file (calibrate-finger) instead of the subject's default."
    ),
) -> None:
    """Friction command for a flat friction-modulating display, as a signal in time."""
    from .render import HapticRenderer  # heavy (the forward model); imported when the command runs

    finger = None if finger_path is None else _finger_file(finger_path)
    try:
        output_file(out, create=False), table and output_file(table, option="--table", create=False)
        r = HapticRenderer.for_surface(surface, subject, _predict_inputs(params), load=load,
                                       normal_force=normal_force, step=step, mu_range=(mu_min, mu_max),
                                       model=model, finger=finger)
        files = r.write_command(output_file(out), speed, rate)
        if table:
            files["table"] = r.write_table(output_file(table, option="--table"))
    except (ValueError, OSError, RuntimeError) as exc:
        fail(str(exc))
    d = r.display
    console.print(
        f"{r.prediction.surface.name}, subject {r.prediction.subject}: "
        f"mu_cmd {r.mu_cmd.min():.3f}..{r.mu_cmd.max():.3f}"
        f" (lateral force = mu_cmd x {d.effective_normal_force:.3f} N; "
        f"{r.n_clipped} table entries clipped to [{d.mu_min:g}, {d.mu_max:g}])",
        highlight=False,
    )
    for kind, path in files.items():
        console.print(f"  {kind:8s} {path}", highlight=False)


@app.command("validate")
def validate_cmd(
    results: str = typer.Argument(..., help="Results folder of 'fingerfriction analyze' (and 'fit')."),
    out: str = typer.Option(None, "--out", help="CSV path (default RESULTS/fit/loso.csv)."),
    step: float = typer.Option(0.01, "--step", help="Finger step in mm of the forward sweeps."),
    finger: Annotated[
        list[str] | None,
        typer.Option("--finger", help="SUBJECT=FILE: that subject's finger JSON (calibrate-finger); repeat."),
    ] = None,
    calibrated: bool = typer.Option(False, "--calibrated-fingers", help="Also predict each held-out surface "
                                    "with each subject's finger calibrated on the other surfaces (slow)."),
) -> None:
    """Leave-one-surface-out validation: fit on the other surfaces, predict each one from
    its geometry alone (no video), rho next to the in-sample Table 1."""
    from .predict import validate_results  # heavy (the forward model); imported when the command runs
    from .study.finger_calibration import calibrate_held_out  # heavy (numba); likewise

    fingers = _finger_file(items=finger)
    try:
        held = None
        if calibrated:
            with console.status("calibrating the fingers without each surface...") as st:
                held = calibrate_held_out(results, progress=lambda k, n, what: st.update(
                    f"calibrated {k} of {n} fingers ({what})"))
            for (surf, subj), why in held.errors.items():
                console.print(f"[yellow]no calibrated finger[/] for subject {subj} without {surf}: {why}",
                              highlight=False, soft_wrap=True)
        res = validate_results(results, out=None if out is None else output_file(out), forward_step=step,
                               fingers=fingers, calibrated_fingers=held and held.fingers())
    except (ValueError, OSError, RuntimeError) as exc:
        fail(str(exc))
    t = Table(title="out-of-sample validation (leave one surface out)")
    cal = "rho_out_of_sample_calibrated_finger" in res.table.columns
    for col in ("model", "subject", "surface", "trials", "rho in sample", "rho held-out params, video",
                "rho out of sample", *(["rho out of sample, calibrated finger"] if cal else [])):
        t.add_column(col, justify="right" if col.startswith(("rho", "trials")) else "left")
    for r in res.table.itertuples():
        t.add_row(r.model, str(r.subject), r.surface, str(r.n_trials), f"{r.rho_in_sample:.2f}",
                  f"{r.rho_heldout_params_video:.2f}", f"{r.rho_out_of_sample:.2f}",
                  *([f"{r.rho_out_of_sample_calibrated_finger:.2f}"] if cal else []))
    console.print(t)

@app.command("init")
def init_cmd(
    study: Annotated[str, typer.Argument(metavar="STUDY", help="Folder of the recordings; manifest.json is "
                                         "written there, with paths relative to it.")],
    video: Annotated[list[str], typer.Option(
        "--video", metavar="PATTERN", help="File-name pattern of the videos, relative to STUDY, e.g. "
        "'raw/S{subject}_{surface}_{speed}mms_{repetition}.cine'; {subject}, {surface}, {speed} (mm/s) are "
        "needed, {repetition} and other {fields} are optional, * matches anything. Repeat for several.")],
    forces: Annotated[list[str], typer.Option(
        "--forces", metavar="PATTERN", help="File-name pattern of the force files, with the same fields "
                                            "(repeat for several).")],
    surface: Annotated[list[str] | None, typer.Option(
        "--surface", metavar="TOKEN=SURFACE", help="The surface a file-name token stands for: a built-in "
        "name (bump-2mm), a spec (bump:W=3,H=0.5) or an x,h CSV (repeat). Default: the token itself.")
    ] = None,
    channels: Annotated[list[str] | None, typer.Option(
        "--channels", metavar="[FORMAT:]F1,F2", help="Names (or CSV column indices) of the two piezo "
        "channels, e.g. 'Piezo/ai0,Piezo/ai1' or 'csv:1,2'. Default F1,F2.")] = None,
    time: Annotated[list[str] | None, typer.Option(
        "--time", metavar="[FORMAT:]COLUMN", help="A time column in s (name or CSV index): its rate is "
        "checked against --fs-hz or gives it, its first value places sample 0.")] = None,
    units: Annotated[list[str] | None, typer.Option(
        "--units", metavar="[FORMAT:]N|V|mV", help="Units of the channels in the files (default N).")] = None,
    sensitivity: Annotated[list[str] | None, typer.Option(
        "--sensitivity", metavar="[FORMAT:]N_PER_V[,N_PER_V]", help="Channels in volts: the charge "
        "amplifiers' sensitivity in N/V, one for both or F1,F2.")] = None,
    gain: Annotated[list[str] | None, typer.Option(
        "--gain", metavar="[FORMAT:]V_PER_N[,V_PER_N]", help="Channels in volts: the gain in V/N "
        "(instead of --sensitivity).")] = None,
    fs_hz: Annotated[list[str] | None, typer.Option(
        "--fs-hz", metavar="[FORMAT:]HZ", help="Force sampling rate in Hz for files that do not state it "
        "(checked against those that do).")] = None,
    force_t0_s: Annotated[list[str] | None, typer.Option(
        "--force-t0-s", metavar="[FORMAT:]SECONDS", help="Clock offset: time in s of force sample 0 "
        "(default 0).")] = None,
    fps: Annotated[float | None, typer.Option(
        "--fps", metavar="HZ", help="Video frame rate in Hz for files that do not state it (TIFF); checked "
                                    "against those that do.")] = None,
    video_t0_s: Annotated[float, typer.Option(
        "--video-t0-s", metavar="SECONDS", help="Clock offset: time in s of video frame 0 (default 0).")
    ] = 0.0,
    calibration_frame: Annotated[int, typer.Option(
        "--calibration-frame", metavar="INDEX", min=0, help="The finger-free frame used for calibration.")
    ] = 0,
    surface_height_mm: Annotated[list[str] | None, typer.Option(
        "--surface-height-mm", metavar="[SURFACE=]MM", help="Feature height H in mm that calibrates the "
        "image scale (default: the surface's own).")] = None,
    description: Annotated[str, typer.Option("--description", metavar="TEXT",
                                             help="Free text for the manifest.")] = "",
    dry_run: Annotated[bool, typer.Option("--dry-run", help="Print what was found; write nothing.")] = False,
    overwrite: Annotated[bool, typer.Option("--overwrite", help="Replace an existing manifest.json.")
                         ] = False,
    skip_bad: Annotated[bool, typer.Option("--skip-bad", help="Write the trials without problems when "
                                                                "some have problems.")] = False,
) -> None:
    """Build STUDY/manifest.json from a folder of recordings named after a pattern.

    Frame counts, frame rates, image sizes, sample counts and sampling rates are read from
    the files. The table of the trials found, and the files that were not used, are printed
    before anything is written."""
    from .study.init import InitOptions, build_manifest, write_init  # reads the files; when the command runs

    try:
        opts = InitOptions.from_command_line(
            video=video, forces=forces, surface=surface, channels=channels, time=time, units=units,
            sensitivity=sensitivity, gain=gain, fs_hz=fs_hz, force_t0_s=force_t0_s, fps=fps,
            video_t0_s=video_t0_s, calibration_frame=calibration_frame, surface_height_mm=surface_height_mm,
            description=description)
        res = build_manifest(study, opts, created_by=f"fingerfriction {__version__} init")
    except (ValueError, OSError) as exc:
        fail(str(exc))
    _print_init_table(res)
    if res.unmatched:
        console.print(f"{len(res.unmatched)} file(s) not used:", highlight=False)
        for u in res.unmatched[:40]:
            console.print(f"  {escape(u.path)}: {escape(u.reason)}", highlight=False)
        if len(res.unmatched) > 40:
            console.print(f"  ... and {len(res.unmatched) - 40} more", highlight=False)
    _print_problems(res.problems)
    try:
        path = write_init(res, study, dry_run=dry_run, overwrite=overwrite, skip_bad=skip_bad)
    except (ValueError, OSError) as exc:
        fail(str(exc))
    n_bad = len(res.trials) - res.n_ok
    left = f" ({n_bad} with problems left out)" if n_bad else ""
    if dry_run:
        console.print(f"dry run: {path} would hold {res.n_ok} trials{left}; nothing was written",
                      highlight=False)
    else:
        console.print(f"[green]wrote[/] {path}: {res.n_ok} trials{left}", highlight=False)


def _print_init_table(res) -> None:
    t = Table(title=f"{len(res.trials)} trials found ({res.n_ok} without problems)")
    for c in ("trial", "surface", "video", "frames @ fps", "force file", "samples @ Hz"):
        t.add_column(c, overflow="fold")
    for r in res.trials:
        frames = "" if r.n_frames is None else f"{r.n_frames} @ {r.fps:g}"
        samples = "" if r.n_samples is None else f"{r.n_samples} @ {r.fs_hz:g}"
        t.add_row(r.id, r.surface, os.path.basename(r.video), frames, os.path.basename(r.force), samples,
                  style="red" if r.problem else None)
    console.print(t)


@app.command("calibrate-finger")
def calibrate_finger_cmd(
    results: str = typer.Argument(..., help="Results folder of 'fingerfriction analyze'."),
    subject: str = typer.Option(..., "--subject", help="Subject label as in the study's manifest."),
    out: str = typer.Option(None, "--out", help="Finger JSON to write (default finger-s<SUBJECT>.json)."),
    initial: str = typer.Option(None, "--initial", help="Starting finger JSON (default: the subject's "
                                "default finger, or subject 1's)."),
    load: float = typer.Option(None, "--load", help="Assume this constant normal force in N (studies "
                               "without an absolute F_N; the modulus is then relative to it)."),
    surfaces: str = typer.Option(None, "--surfaces", help="Calibrate on these surfaces only (comma list)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the bootstrap uncertainties."),
) -> None:
    """Fit the subject's finger (radius, modulus, flat length) to its measured contact regions
    and write it as a finger JSON that predict, predict-contact, validate and render accept."""
    from .mechanics.calibrate import CalibrationOptions  # heavy (numba); when the command runs
    from .study.finger_calibration import calibrate_results  # heavy (the forward model); likewise

    start = None if initial is None else _finger_file(initial)
    target = out or f"finger-s{subject}.json"
    try:
        output_file(target, create=False)  # a folder given as the file fails before the work
        opts = CalibrationOptions(seed=seed)
        t0 = time.process_time()
        with console.status(f"calibrating the finger of subject {subject}..."):
            res = calibrate_results(results, subject, initial=start, options=opts, load=load,
                                    surfaces=_csv(surfaces))
        cpu = time.process_time() - t0
    except (ValueError, OSError) as exc:
        fail(str(exc))
    console.print(escape(res.summary()), highlight=False)
    console.print(f"CPU {cpu:.1f} s ({res.n_solves} contact solves)", highlight=False)
    if not res.success:
        fail(f"the calibration of subject {subject} did not succeed: {res.message}; no finger written")
    from .mechanics.finger_file import write_finger_file  # small; only once there is a finger

    try:
        path = write_finger_file(output_file(target), res.finger, calibration={
            "results": os.path.abspath(results), "subject": subject, **res.to_dict()})
    except OSError as exc:
        fail(f"cannot write {target}: {exc}")
    console.print(f"[green]wrote[/] {path}", highlight=False)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``fingerfriction`` console script."""
    try:
        app(args=argv, standalone_mode=True)
    except SystemExit as exc:  # typer exits through SystemExit
        return int(exc.code or 0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
