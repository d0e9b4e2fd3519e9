"""The virtual experiment's command: simulate (``fingerfriction.sim``)."""

from __future__ import annotations

import time
from typing import Annotated

import typer
from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

from .._console import console_log, summary_line
from ._common import (
    QUIET,
    SEED,
    VERBOSE,
    FieldDefault,
    bounded,
    echo,
    err_console,
    fail,
    given,
    plural,
    print_summary,
    read_fingers,
    show_progress,
    verbosity_of,
)


def _split_list(values: list[str] | None) -> list[str] | None:
    """Accept both ``--surfaces a b`` style repeats and comma lists ``--surfaces a,b``."""
    if not values:
        return None
    out: list[str] = []
    for v in values:
        out.extend(p.strip() for p in v.split(",") if p.strip())
    return out


def _design(surfaces, subjects, speeds) -> dict:
    """The ``SimOptions`` fields of the options that narrow the design (those given)."""
    kw: dict = {}
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
            if not 1.0 <= sp[-1] <= 1000.0:  # a slower slide lasts minutes of 1 kHz video
                fail(f"--speeds must be in [1, 1000] mm/s, got {v}")
        kw["speeds"] = tuple(sp)
    return kw


def _sim(name: str) -> FieldDefault:
    return FieldDefault(f"fingerfriction.sim.options:SimOptions.{name}")


def simulate_cmd(
    out: Annotated[str, typer.Option("--out", help="Output study folder (new, empty, or same study).")],
    reps: Annotated[int, typer.Option("--reps", help="Repetitions per condition (the paper: 5).",
                                      callback=bounded(1, 100), show_default=_sim("reps"))] = None,
    seed: Annotated[int, typer.Option("--seed", help="Study seed: same seed, byte-identical study.",
                                      callback=SEED, show_default=_sim("seed"))] = None,
    surfaces: Annotated[
        list[str] | None, typer.Option("--surfaces", help="Surfaces, e.g. bump-2mm,step-up-4mm (default: 6).")
    ] = None,
    subjects: Annotated[
        list[str] | None, typer.Option("--subjects", help="Subjects: 1, 2 (default: both).")
    ] = None,
    speeds: Annotated[
        list[str] | None, typer.Option("--speeds", help="Nominal speeds in mm/s (default 40,80,120).")
    ] = None,
    workers: Annotated[int, typer.Option("--workers", help="Worker processes (0: all cores).",
                                         callback=bounded(0, 256, "workers"))] = 0,
    video_format: Annotated[str, typer.Option("--video-format", help="ffv1-mkv or tiff.",
                                              show_default=_sim("video_format"))] = None,
    contact_model: Annotated[
        str, typer.Option("--contact-model", help="mechanics-bem or bridged-foundation (fast).",
                          show_default=_sim("contact_model"))
    ] = None,
    realism: Annotated[bool, typer.Option(
        "--realism", help="A harder study: friction drawn per trial (10 % SD), falling with load, and the "
                          "normal force wandering over +-50 mN (fingerfriction.sim.RealismParams).")] = False,
    world: Annotated[str, typer.Option(
        "--world", help="The true physics: load-sharing, constant-pressure or interlocking "
                        "(docs/worlds.md).", show_default=_sim("world"))] = None,
    chain: Annotated[str, typer.Option(
        "--chain", help="The measurement chain: ideal (the analysis inverts it exactly) or "
                        "realistic (second-order sensor of unknown cut-off, crosstalk, curved drift, a "
                        "normal force that follows the relief; docs/worlds.md).",
        show_default=_sim("chain"))] = None,
    finger: Annotated[
        list[str] | None,
        typer.Option("--finger", help="SUBJECT=FILE: that subject's finger, a finger JSON file (repeat)."),
    ] = None,
    finger_seed: Annotated[
        int | None,
        typer.Option("--finger-seed", help="Draw the other subjects' fingers around the calibrated ones "
                     "(radius, modulus, flat length +-25 %) with this seed.", callback=SEED),
    ] = None,
    finger_model: Annotated[str, typer.Option(
        "--finger-model", help="halfspace (default: the --contact-model) or fe: the layered finite-element "
                               "finger (FE finger files with --finger; tables cached on disk).",
    )] = "halfspace",
    verbose: bool = VERBOSE,
    quiet: bool = QUIET,
) -> None:
    """Simulate recordings (video + force sensor) of the paper's study with known ground truth."""
    from ..sim import (  # heavy (video encoder, mechanics); when the command runs
        RealismParams,
        SimOptions,
        simulate_study,
    )

    kw: dict = {**given(reps=reps, seed=seed, video_format=video_format, contact_model=contact_model,
                        world=world, chain=chain),
                "realism": RealismParams() if realism else None, **_design(surfaces, subjects, speeds)}
    if workers < 0:
        fail(f"--workers must be >= 0 (0: all cores), got {workers}")
    if finger_model not in ("halfspace", "fe"):  # worded as tests/sim/test_fe_sim.py expects
        fail(f"--finger-model must be halfspace or fe, got {finger_model!r}")
    if finger_model == "fe":
        if contact_model not in (None, "mechanics-bem", "fe"):
            fail(f"--finger-model fe is its own contact model; drop --contact-model {contact_model}")
        kw["contact_model"] = "fe"
    if finger:
        kw["fingers"] = read_fingers(items=finger, model="fe" if finger_model == "fe" else "halfspace")
    if finger_seed is not None:
        kw["finger_seed"] = finger_seed
    try:
        opts = SimOptions(**kw)
    except ValueError as exc:
        fail(str(exc))
    verbosity = verbosity_of(verbose, quiet)
    t0 = time.perf_counter()
    with Progress(
        TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
        TextColumn("{task.fields[label]}"), console=err_console, transient=False,
        disable=not show_progress(verbosity),
    ) as prog, console_log(verbosity, echo) as log:
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
    print_summary(summary_line("simulate", [plural(len(study.trials), "trial") + " written",
                                            f"ground truth in {out}/truth/"],
                               elapsed_s=time.perf_counter() - t0, output=f"{out}/manifest.json", log=log))
