"""One trial's stages on their own: the video overlay and the force processing
(``fingerfriction.video``, ``fingerfriction.forces``), each run as ``analyze`` runs it."""

from __future__ import annotations

import numpy as np
import typer
from rich.markup import escape

from .._outputs import output_file
from ._common import (
    FORCE_PARAMS,
    bounded,
    console,
    dataclass_option,
    fail,
    given,
    highpass_options,
    highpass_params,
    warn,
)

_OVERLAY = "fingerfriction.video.overlay:write_overlay"


def overlay_cmd(
    study: str = typer.Argument(..., help="Study folder (or its manifest.json)."),
    trial: str = typer.Argument(..., help="Trial id, as in the manifest."),
    out: str = typer.Option(None, "--out", help="Output .mp4 or .gif (default: <trial>-overlay.mp4)."),
    start: int = dataclass_option(f"{_OVERLAY}.start", "--start", help="First frame.",
                                  callback=bounded(0, 10_000_000, "frames")),
    stop: int = typer.Option(None, "--stop", help="Stop before this frame (default: the last).",
                             callback=bounded(1, 10_000_000, "frames")),
    step: int = dataclass_option(f"{_OVERLAY}.step", "--step", help="Draw every STEP-th frame.",
                                 callback=bounded(1, 1_000_000, "frames")),
    fps: float = dataclass_option(f"{_OVERLAY}.fps", "--fps", help="Playback frame rate of the output (Hz).",
                                  callback=bounded(0.1, 1000.0, "Hz")),
    level: float = typer.Option(None, "--level", help="Threshold gray level (default: Otsu).",
                                callback=bounded(0.0, 65535.0)),
    scale: float = dataclass_option(f"{_OVERLAY}.scale", "--scale", callback=bounded(0.05, 4.0),
                                    help="Resize factor of the 1260x360 crop."),
) -> None:
    """Write a video of a trial's frames with the traced contours and contact regions drawn."""
    from ..pipeline.params import video_options  # heavy (video stage); imported when the command runs
    from ..pipeline.trial import TrialInput  # heavy (both stages); imported when the command runs
    from ..video.overlay import write_overlay  # heavy (OpenCV, PyAV); imported when the command runs

    try:
        tr = TrialInput.from_study(study, trial)
        opts = video_options({"level": level}, tr.record.video.calibration_frame)  # as `analyze`
        info = write_overlay(
            tr.path(tr.record.video.path, "video.path"), tr.height_mm, out or f"{trial}-overlay.mp4",
            surface=tr.surface, options=opts, stop=stop,
            **given(start=start, step=step, fps=fps, scale=scale),
        )
    except KeyError as exc:
        fail(str(exc.args[0]) if exc.args else str(exc))
    except (ValueError, OSError) as exc:
        fail(str(exc))
    console.print(f"[green]wrote[/] {info.path}: {info.n_frames} frames ({info.n_flagged} flagged)")


_HP = highpass_options()


def forces_cmd(
    study: str = typer.Argument(..., help="study folder (with manifest.json)"),
    trial: str = typer.Argument(..., help="trial id"),
    out: str = typer.Option(None, "--out", help="write F_T(x) to this CSV (x_mm, F_T_N, F_N_N, n_samples)"),
    positions: str = typer.Option(None, "--positions", help="finger x (mm) per frame: .csv x_mm / .npy"),
    from_video: bool = typer.Option(False, "--from-video", help="x(t) and contact regions from the video"),
    from_truth: bool = typer.Option(False, "--from-truth", help="use the simulated study's true finger x"),
    highpass_hz: float = _HP["highpass_hz"],
    mains: str = dataclass_option(f"{FORCE_PARAMS}.mains", "--mains",
                                  help="mains interference: fit (sinusoids fitted on the rest before the "
                                       "touch), notch (the paper's notch filters) or both"),
    notch_q: float = dataclass_option(f"{FORCE_PARAMS}.notch_q", "--notch-q",
                                      help="quality factor of the notches at the mains frequencies (used by "
                                           "--mains notch or both, and by the notch that replaces the fit "
                                           "when the record has no rest before the touch)",
                                      callback=bounded(0.1, 1000.0)),
    estimate_highpass: bool = _HP["estimate_highpass"],
    highpass_model: str = _HP["highpass_model"],
) -> None:
    """Process the forces of one trial: F_T(x) on a 0.01 mm grid over the 26 mm window.

    With --from-video, x(t) and the contact regions come from the video stage run exactly as
    `analyze` runs it (the same options)."""
    from ..forces import ForceProcessingParams  # heavy (scipy); imported when the command runs
    from ..pipeline.trial import TrialInput, finger_positions, process_trial_forces  # heavy: both stages

    try:
        tr = TrialInput.from_study(study, trial)
        x, regions = finger_positions(tr, positions=positions, from_truth=from_truth, from_video=from_video)
        kw = given(mains=mains, notch_q=notch_q)
        kw.update(highpass_params(highpass_model, highpass_hz, estimate_highpass))
        params = ForceProcessingParams(**kw)
        if notch_q is not None and params.mains == "fit":
            warn("--notch-q: the fit removes the mains (--mains fit), the notches run only when the record "
                 "has no rest before the touch; give --mains notch or both to filter with them")
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
