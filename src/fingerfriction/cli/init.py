"""``fingerfriction init``: a study's manifest.json built from a folder of lab recordings
named after a pattern (:mod:`fingerfriction.study.init`)."""

from __future__ import annotations

import os
from typing import Annotated

import typer
from rich.markup import escape
from rich.table import Table

from .. import __version__
from ._common import FieldDefault, bounded, console, fail, finish, print_problems


def _init(name: str) -> FieldDefault:
    return FieldDefault(f"fingerfriction.study.init:InitOptions.{name}")


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
        "--fps", metavar="HZ", callback=bounded(0.001, 1e7, "Hz"),
        help="Video frame rate in Hz for files that do not state it (TIFF); checked against those that do.")
    ] = None,
    video_t0_s: Annotated[float, typer.Option(
        "--video-t0-s", metavar="SECONDS", callback=bounded(-1e6, 1e6, "s"),
        help="Clock offset: time in s of video frame 0.", show_default=_init("video_t0_s"))] = None,
    calibration_frame: Annotated[int, typer.Option(
        "--calibration-frame", metavar="INDEX", callback=bounded(0, 10_000_000),
        help="The finger-free frame used for calibration.", show_default=_init("calibration_frame"))] = None,
    surface_height_mm: Annotated[list[str] | None, typer.Option(
        "--surface-height-mm", metavar="[SURFACE=]MM", help="Feature height H in mm that calibrates the "
        "image scale (default: the surface's own).")] = None,
    description: Annotated[str, typer.Option("--description", metavar="TEXT",
                                             help="Free text for the manifest.", show_default=False)] = None,
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
    from ..study.init import InitOptions, build_manifest, write_init  # reads the files; when the command runs

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
    for note in res.notes:
        console.print(f"[bold yellow]note:[/] {escape(note)}", highlight=False, soft_wrap=True)
    print_problems(res.problems)
    try:
        path = write_init(res, study, dry_run=dry_run, overwrite=overwrite, skip_bad=skip_bad)
    except (ValueError, OSError) as exc:
        fail(str(exc))
    n_bad = len(res.trials) - res.n_ok
    left = f" ({n_bad} with problems left out)" if n_bad else ""
    if dry_run:
        console.print(f"dry run: {escape(str(path))} would hold {res.n_ok} trials{left}; nothing was written",
                      highlight=False)
    else:
        console.print(f"[green]wrote[/] {escape(str(path))}: {res.n_ok} trials{left}", highlight=False)
    finish(n_bad == 0)


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


