"""The forward model's commands: predict-contact, predict, render, validate and
calibrate-finger (``fingerfriction.mechanics``, ``fingerfriction.predict``,
``fingerfriction.predict.render``)."""

from __future__ import annotations

import os
import time
from typing import Annotated

import typer
from rich.markup import escape
from rich.table import Table

from .._check import check_option
from .._outputs import check_output_dir, output_dir, output_file
from ..surfaces import surface_from_spec
from ._common import (
    LOAD_N,
    SEED,
    STEP_MM,
    SUBJECT,
    WORKERS,
    bounded,
    console,
    csv_list,
    dataclass_option,
    fail,
    finish,
    given,
    or_default,
    read_fingers,
)

_SWEEP_LOAD = "fingerfriction.mechanics.sweep:sweep.load"
_SWEEP_STEP = "fingerfriction.mechanics.sweep:default_positions.step"
_SWEEP_KIND = "fingerfriction.mechanics.sweep:SweepResult.blind_spots.kind"
_PREDICT = "fingerfriction.predict.prediction:predict"
_DISPLAY = "fingerfriction.predict.render:DisplayModel"
_VALIDATE_STEP = "fingerfriction.pipeline.validation:validate_results.forward_step"
_SUBJECT = "fingerfriction.mechanics.finger:get_subject.subject"
_COMMAND = "fingerfriction.predict.render:HapticRenderer.write_command"
_FINGER_MODEL = "fingerfriction.pipeline.finger_calibration:calibrate_results.model"
_HELD_OUT_MODEL = "fingerfriction.pipeline.finger_calibration:calibrate_held_out.model"
_FE_WORKERS = "fingerfriction.mechanics.fe.calibration:FECalibrationOptions.workers"
_FE_OFFSET = "fingerfriction.mechanics.fe.calibration:FECalibrationOptions.position_offset"
_FIT_HELP = ("The finger's fields to fit (comma list; default: halfspace radius,modulus,flat_length; fe "
             "tissue_modulus,skin_modulus,skin_thickness,radius,semi_height, of those and pulp_thickness: "
             "each FE field adds two nodes to the grid of FE tables).")
_OFFSET_HELP = ("FE finger: also fit one offset (mm) between the tracked finger position and the model "
                "finger's reference point (a finger leaning under friction is tracked behind it; "
                "docs/mechanics-fe.md).")


def predict_contact(
    surface: str = typer.Option(
        ..., "--surface", help="Paper surface name (bump-4mm ...), spec 'bump:W=3,H=0.5' or x,h CSV (mm)."
    ),
    subject: int = dataclass_option(_SUBJECT, "--subject", help="Calibrated finger of subject 1 or 2.",
                                    callback=SUBJECT),
    load: float = dataclass_option(_SWEEP_LOAD, "--load", help="Normal force in N.", callback=LOAD_N),
    step: float = dataclass_option(_SWEEP_STEP, "--step", callback=STEP_MM,
                                   help="Finger position step in mm over the 26 mm window."),
    kind: str = dataclass_option(_SWEEP_KIND, "--kind",
                                 help="Contact definition: geometric (gap <= 70 um) or mechanical."),
    out: str = typer.Option(
        "predict-contact", "--out", help="Folder for the occupancy figure (PNG); created if missing."
    ),
    finger_path: str = typer.Option(
        None, "--finger", help="Finger JSON file (calibrate-finger) instead of the subject's default."
    ),
) -> None:
    """Predict tactile blind spots and simultaneous contacts of a finger sliding over a surface."""
    from ..mechanics import default_positions, get_subject, sweep  # heavy (numba); when the command runs
    from ..mechanics.figures import save_occupancy_figure  # heavy (matplotlib); when the command runs

    try:
        load, step = or_default(load, _SWEEP_LOAD), or_default(step, _SWEEP_STEP)
        subject = or_default(subject, _SUBJECT)
        kind = check_option("--kind", or_default(kind, _SWEEP_KIND), ("geometric", "mechanical"))
        surf = surface_from_spec(surface)
        owns = {"owns": lambda n: n.startswith("occupancy-") and n.endswith(".png"),
                "what": "folder of occupancy figures"}
        check_output_dir(out, **owns)
        finger = get_subject(subject) if finger_path is None else read_fingers(finger_path)
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


def _predict_inputs(params):
    """--params: None or a JSON path (parameters, a fit's fit.json or its RESULTS folder)."""
    return None if params is None else str(params)


#: The files ``predict`` writes in its folder (``Prediction.write``).
PREDICTION_FILES = {"forces.csv", "regions.csv", "occupancy.csv", "blind_spots.csv", "prediction.json",
                    "forces.png", "occupancy.png"}


def predict_cmd(
    surface: str = typer.Option(..., "--surface", help="Name (bump-4mm), spec (bump:W=3,H=0.5) or CSV."),
    subject: int = typer.Option(..., "--subject", help="Subject 1 or 2 (calibrated forward-model finger).",
                                callback=SUBJECT),
    params: str = typer.Option(None, "--params", help="JSON parameters, or a fit's RESULTS folder."),
    model: str = typer.Option(None, "--model", help="load or paper (default: the fit's, else load)."),
    out: str = typer.Option("prediction", "--out", help="Output folder for CSV, JSON and PNG files "
                            "(created if missing)."),
    load: float = dataclass_option(f"{_PREDICT}.load", "--load", callback=LOAD_N, help="Normal force in N."),
    step: float = dataclass_option(f"{_PREDICT}.step", "--step", callback=STEP_MM, help="Finger step in mm."),
    contact: str = dataclass_option(f"{_PREDICT}.contact", "--contact",
                                    help="geometric (70 um) or mechanical."),
    figures: bool = typer.Option(True, "--figures/--no-figures", help="Write PNG figures."),
    finger_path: str = typer.Option(
        None, "--finger", help="Finger JSON file (calibrate-finger) instead of the subject's default; an FE "
        "finger file makes the layered FE finger the forward model (solved every 0.1 mm, cached)."
    ),
) -> None:
    """Predict F_T(x), F_int, F_def, contact occupancy and blind spots on any relief."""
    from ..predict import predict  # heavy (the forward model); imported when the command runs

    finger = None if finger_path is None else read_fingers(finger_path, model="any")
    try:
        owns = {"owns": PREDICTION_FILES, "what": "prediction folder"}
        check_output_dir(out, **owns)
        pred = predict(surface, subject, _predict_inputs(params), model=model, finger=finger,
                       **given(load=load, step=step, contact=contact))
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


def render_cmd(
    surface: str = typer.Option(..., "--surface", help="Paper surface name, spec or CSV profile."),
    subject: int = typer.Option(..., "--subject", help="Subject 1 or 2.", callback=SUBJECT),
    out: str = typer.Option(..., "--out", help="Command signal file: .wav (float32) or .csv."),
    params: str = typer.Option(None, "--params", help="JSON parameters, or a fit's RESULTS folder."),
    model: str = typer.Option(None, "--model", help="load or paper (default: the fit's, else load)."),
    speed: float = dataclass_option(f"{_COMMAND}.speed", "--speed", help="Sliding speed in mm/s.",
                                    callback=bounded(0.1, 10_000.0, "mm/s")),
    rate: float = dataclass_option(f"{_COMMAND}.rate", "--rate", help="Display update rate in Hz.",
                                   callback=bounded(1.0, 1e6, "Hz")),
    normal_force: float = typer.Option(None, "--normal-force", help="Display normal force in N.",
                                       callback=LOAD_N),
    load: float = dataclass_option(f"{_PREDICT}.load", "--load", callback=LOAD_N,
                                   help="Normal force in N of the prediction."),
    mu_min: float = dataclass_option(f"{_DISPLAY}.mu_min", "--mu-min", callback=bounded(0.0, 100.0),
                                     help="Lowest mu the display can produce."),
    mu_max: float = dataclass_option(f"{_DISPLAY}.mu_max", "--mu-max", callback=bounded(0.0, 100.0),
                                     help="Highest mu the display can produce."),
    table: str = typer.Option(None, "--table", help="Also write the table CSV (x_mm, F_T_N, mu_cmd)."),
    step: float = dataclass_option(f"{_PREDICT}.step", "--step", help="Finger step in mm of the prediction.",
                                   callback=STEP_MM),
    finger_path: str = typer.Option(
        None, "--finger", help="Finger JSON file (calibrate-finger) instead of the subject's default."
    ),
) -> None:
    """Friction command for a flat friction-modulating display, as a signal in time."""
    from ..predict.render import HapticRenderer  # heavy (the forward model); imported when the command runs

    finger = None if finger_path is None else read_fingers(finger_path)
    try:
        output_file(out, create=False), table and output_file(table, option="--table", create=False)
        r = HapticRenderer.for_surface(surface, subject, _predict_inputs(params), normal_force=normal_force,
                                       mu_range=(mu_min, mu_max), model=model, finger=finger,
                                       **given(load=load, step=step))
        files = r.write_command(output_file(out), **given(speed=speed, rate=rate))
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


def validate_cmd(
    results: str = typer.Argument(..., help="Results folder of 'fingerfriction analyze' (and 'fit')."),
    out: str = typer.Option(None, "--out", help="CSV path (default RESULTS/fit/loso.csv)."),
    step: float = dataclass_option(_VALIDATE_STEP, "--step", help="Finger step in mm of the forward sweeps.",
                                   callback=STEP_MM),
    finger: Annotated[
        list[str] | None,
        typer.Option("--finger", help="SUBJECT=FILE: that subject's finger JSON (calibrate-finger, or an "
                     "FE finger file: the layered FE finger as the forward model; use --step 0.1); repeat."),
    ] = None,
    calibrated: bool = typer.Option(False, "--calibrated-fingers", help="Also predict each held-out surface "
                                    "with each subject's finger calibrated on the other surfaces (slow)."),
    finger_model: str = dataclass_option(_HELD_OUT_MODEL, "--finger-model", help="The family of the "
                                         "calibrated fingers: halfspace, or fe (the layered FE finger, its "
                                         "tables cached)."),
    workers: int = dataclass_option(_FE_WORKERS, "--workers", callback=WORKERS, help="Processes solving the "
                                    "FE calibration's tables (--finger-model fe)."),
    fit_fields: str = typer.Option(None, "--fit", help=_FIT_HELP),
    position_offset: bool = dataclass_option(_FE_OFFSET, "--position-offset/--no-position-offset",
                                             help=_OFFSET_HELP),
) -> None:
    """Leave-one-surface-out validation: fit on the other surfaces, predict each one from
    its geometry alone (no video), rho next to the in-sample Table 1."""
    from ..pipeline.finger_calibration import FINGER_FAMILIES, calibrate_held_out  # heavy (numba); likewise
    from ..pipeline.validation import validate_results  # heavy (the forward model); likewise

    if (fit_fields or position_offset is not None) and not calibrated:
        fail(f"{'--fit' if fit_fields else '--position-offset'} sets the calibrated fingers: add "
             "--calibrated-fingers")
    fingers = read_fingers(items=finger, model="any")  # half-space or FE finger files
    try:
        finger_model = check_option("--finger-model", or_default(finger_model, _HELD_OUT_MODEL),
                                    FINGER_FAMILIES)
        held = None
        if calibrated:
            opts = None
            if finger_model == "fe":
                from ..mechanics.fe.calibration import FECalibrationOptions  # with the FE family only

                opts = FECalibrationOptions(verify=False, **given(workers=workers, fit=csv_list(fit_fields),
                                                                   position_offset=position_offset))
            elif position_offset is not None:
                raise ValueError("--position-offset needs --finger-model fe")
            elif fit_fields:
                from ..mechanics.calibrate import CalibrationOptions  # heavy (numba); likewise

                opts = CalibrationOptions(fit=csv_list(fit_fields))
            with console.status("calibrating the fingers without each surface...") as st:
                held = calibrate_held_out(results, options=opts, model=finger_model,
                                          progress=lambda k, n, what: st.update(
                                              f"calibrated {k} of {n} fingers ({what})"))
            for (surf, subj), why in held.errors.items():
                console.print(f"[yellow]no calibrated finger[/] for subject {subj} without {surf}: {why}",
                              highlight=False, soft_wrap=True)
        res = validate_results(results, out=None if out is None else output_file(out), fingers=fingers,
                               calibrated_fingers=held and held.fingers(), **given(forward_step=step))
        if held is not None:  # which finger predicted each held-out surface, beside the table
            from .._atomic import atomic_write_json  # small; only with calibrated fingers
            from ..study.store import ResultsStore  # likewise

            table = output_file(out) if out is not None else ResultsStore(results).loso_path
            fingers_path = os.path.splitext(os.fspath(table))[0] + "-fingers.json"
            atomic_write_json(fingers_path, held.to_dict())
            console.print(f"held-out fingers: {fingers_path}", highlight=False)
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
    # why a cell has no prediction (the others were made): status 1, as a held-out surface
    # without its calibrated finger
    notes: dict[str, list] = {}  # the line -> the variants it holds for
    for col, finger_kind in (("note", ""), ("note_calibrated_finger", ", calibrated finger")):
        if col in res.table.columns:
            for m, surf, n in zip(res.table["model"], res.table["surface"], res.table[col], strict=True):
                if isinstance(n, str) and n:
                    notes.setdefault(f"{surf}{finger_kind}: {n}", []).append(m)
    for line, models in notes.items():
        which = ", ".join(dict.fromkeys(models))
        console.print(f"[yellow]not predicted[/] ({which}) {line}", highlight=False, soft_wrap=True)
    finish(not (held and held.errors) and not notes)


def calibrate_finger_cmd(
    results: str = typer.Argument(..., help="Results folder of 'fingerfriction analyze'."),
    subject: str = typer.Option(..., "--subject", help="Subject label as in the study's manifest."),
    out: str = typer.Option(None, "--out", help="Finger JSON to write (default finger-s<SUBJECT>.json)."),
    initial: str = typer.Option(None, "--initial", help="Starting finger JSON (default: the subject's "
                                "default finger, or subject 1's)."),
    load: float = typer.Option(None, "--load",
                               callback=LOAD_N, help="Assume this constant normal force in N (studies "
                               "without an absolute F_N; the modulus is then relative to it)."),
    surfaces: str = typer.Option(None, "--surfaces", help="Calibrate on these surfaces only (comma list)."),
    seed: int = dataclass_option("fingerfriction.mechanics.calibrate:CalibrationOptions.seed", "--seed",
                                 help="Seed of the bootstrap uncertainties.", callback=SEED),
    finger_model: str = dataclass_option(_FINGER_MODEL, "--finger-model", help="halfspace (radius, "
                                         "modulus, flat length), or fe: the layered FE finger (pulp modulus "
                                         "and outline radius, through a grid of cached FE tables; "
                                         "docs/mechanics-fe.md)."),
    friction: float = typer.Option(None, "--friction", callback=bounded(0.0, 5.0),
                                   help="FE finger: the sliding friction of its contact (default: the "
                                   "study's fitted flat-ground mu)."),
    workers: int = dataclass_option(_FE_WORKERS, "--workers", callback=WORKERS,
                                    help="Processes solving the FE grid's tables (--finger-model fe)."),
    fit_fields: str = typer.Option(None, "--fit", help=_FIT_HELP),
    position_offset: bool = dataclass_option(_FE_OFFSET, "--position-offset/--no-position-offset",
                                             help=_OFFSET_HELP),
) -> None:
    """Fit the subject's finger to its measured contact regions and write it as a finger JSON
    that predict, validate and render accept (predict-contact and render: half-space only)."""
    from ..mechanics.calibrate import CalibrationOptions  # heavy (numba); when the command runs
    from ..pipeline.finger_calibration import FINGER_FAMILIES, calibrate_results  # heavy; likewise

    try:
        finger_model = check_option("--finger-model", or_default(finger_model, _FINGER_MODEL),
                                    FINGER_FAMILIES)
    except ValueError as exc:
        fail(str(exc))
    start = None if initial is None else read_fingers(initial, model=finger_model)
    target = out or f"finger-s{subject}.json"
    try:
        output_file(target, create=False)  # a folder given as the file fails before the work
        if finger_model == "fe":
            from ..mechanics.fe.calibration import FECalibrationOptions  # with the FE family only

            opts = FECalibrationOptions(**given(seed=seed, workers=workers, fit=csv_list(fit_fields),
                                                position_offset=position_offset))
        elif position_offset is not None:
            raise ValueError("--position-offset needs --finger-model fe")
        else:
            opts = CalibrationOptions(**given(seed=seed, fit=csv_list(fit_fields)))
        t0 = time.process_time()
        with console.status(f"calibrating the finger of subject {subject}..."):
            res = calibrate_results(results, subject, initial=start, options=opts, load=load,
                                    surfaces=csv_list(surfaces), model=finger_model, friction=friction)
        cpu = time.process_time() - t0
    except (ValueError, OSError) as exc:
        fail(str(exc))
    console.print(escape(res.summary()), highlight=False)
    what = "FE tables solved" if finger_model == "fe" else "contact solves"
    fe_cpu = f", FE tables {res.timings['fe_tables']:.1f} s in all processes" if finger_model == "fe" else ""
    console.print(f"CPU {cpu:.1f} s in this process ({res.n_solves} {what}{fe_cpu})", highlight=False)
    if not res.success:
        fail(f"the calibration of subject {subject} did not succeed: {res.message}; no finger written")
    from ..mechanics.finger_file import write_finger_file  # small; only once there is a finger

    try:
        path = write_finger_file(output_file(target), res.finger, calibration={
            "results": os.path.abspath(results), "subject": subject, **res.to_dict()})
    except OSError as exc:
        fail(f"cannot write {target}: {exc}")
    console.print(f"[green]wrote[/] {path}", highlight=False)
