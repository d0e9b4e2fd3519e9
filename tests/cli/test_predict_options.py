"""The forward model's commands leave their defaults to where they are defined: an option
the user does not give is None, and its help shows the default of the function or
dataclass that applies it."""

from __future__ import annotations

import inspect

import typer

from fingerfriction.cli import app
from fingerfriction.cli._common import FieldDefault
from fingerfriction.mechanics.finger import get_subject
from fingerfriction.predict.render import HapticRenderer


def _option(command: str, opt: str):
    cmd = typer.main.get_command(app).commands[command]
    return next(p for p in cmd.params if opt in p.opts)


def test_render_and_predict_contact_defaults_live_with_the_code_that_applies_them():
    command = inspect.signature(HapticRenderer.write_command).parameters
    for cmd, opt, default in (("render", "--speed", command["speed"].default),
                              ("render", "--rate", command["rate"].default),
                              ("predict-contact", "--subject",
                               inspect.signature(get_subject).parameters["subject"].default)):
        p = _option(cmd, opt)
        assert p.default is None and isinstance(p.show_default, FieldDefault), (cmd, opt)
        assert p.show_default.value() == default, (cmd, opt)
    assert str(_option("render", "--speed").show_default) == "80"
    assert str(_option("render", "--rate").show_default) == "2000"
    assert get_subject() is get_subject(1)


def test_the_finger_calibration_options_default_to_the_stage():
    from fingerfriction.mechanics.fe.calibration import FECalibrationOptions
    from fingerfriction.pipeline.finger_calibration import calibrate_held_out, calibrate_results

    model = {"validate": calibrate_held_out, "calibrate-finger": calibrate_results}
    for cmd in ("validate", "calibrate-finger"):
        for opt, default in (("--finger-model", inspect.signature(model[cmd]).parameters["model"].default),
                             ("--workers", FECalibrationOptions().workers)):
            p = _option(cmd, opt)
            assert p.default is None and p.show_default.value() == default, (cmd, opt)


class _Stop(Exception):
    """Raised by the stand-in calibration once it has seen its options."""


def _calibrate_finger(tmp_path, monkeypatch):
    """A runner and ``calibrate-finger``'s arguments, with a stand-in ``calibrate_results`` that
    keeps the options it was given (returned) and raises :class:`_Stop`."""
    from typer.testing import CliRunner

    import fingerfriction.pipeline.finger_calibration as fc

    seen = []

    def fake(results, subject, *, options=None, **kw):
        seen.append(options)
        raise _Stop

    monkeypatch.setattr(fc, "calibrate_results", fake)
    base = ["calibrate-finger", str(tmp_path), "--subject", "1", "--out", str(tmp_path / "f.json")]
    return CliRunner(), base, seen


def test_fit_chooses_the_calibrated_fields_and_bad_fields_are_one_line_errors(tmp_path, monkeypatch):
    runner, base, seen = _calibrate_finger(tmp_path, monkeypatch)
    for model, fields in (("fe", ("tissue_modulus", "skin_modulus")), ("halfspace", ("radius",))):
        r = runner.invoke(app, [*base, "--finger-model", model, "--fit", ",".join(fields)])
        assert isinstance(r.exception, _Stop) and seen.pop().fit == fields, r.output
    r = runner.invoke(app, [*base, "--finger-model", "fe", "--fit", "tissue_modulus,stiffness"])
    assert r.exit_code == 2 and "stiffness" in r.output and "Traceback" not in r.output
    r = runner.invoke(app, ["validate", str(tmp_path), "--fit", "radius"])
    assert r.exit_code == 2 and "--calibrated-fingers" in r.output


def test_position_offset_reaches_the_fe_calibration_and_needs_the_fe_family(tmp_path, monkeypatch):
    from fingerfriction.mechanics.fe.calibration import FECalibrationOptions

    runner, base, seen = _calibrate_finger(tmp_path, monkeypatch)
    for flag, want in (("--position-offset", True), ("--no-position-offset", False),
                       (None, FECalibrationOptions().position_offset)):
        r = runner.invoke(app, [*base, "--finger-model", "fe", *([flag] if flag else [])])
        assert isinstance(r.exception, _Stop) and seen.pop().position_offset is want, (flag, r.output)
    r = runner.invoke(app, [*base, "--finger-model", "halfspace", "--position-offset"])
    assert r.exit_code == 2 and "--finger-model fe" in r.output and "Traceback" not in r.output
    r = runner.invoke(app, ["validate", str(tmp_path), "--position-offset"])
    assert r.exit_code == 2 and "--calibrated-fingers" in r.output
