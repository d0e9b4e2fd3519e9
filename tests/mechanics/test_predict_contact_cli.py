"""The predict-contact command (cli.py, predict-contact section)."""

from __future__ import annotations

import os

import pytest
from typer.testing import CliRunner

from fingerfriction.cli import app

runner = CliRunner()


def _invoke(args):
    # With a single registered command typer runs it without its name; with several it
    # needs the name. Try the multi-command form first.
    res = runner.invoke(app, ["predict-contact", *args])
    if res.exit_code == 2 and "unexpected extra argument" in res.output:
        res = runner.invoke(app, args)
    return res


@pytest.mark.slow
def test_predict_contact_prints_blind_spots_and_writes_png(tmp_path):
    res = _invoke(["--surface", "step-up-2mm", "--subject", "1", "--step", "0.05", "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    assert "blind spots" in res.output.lower()
    assert "maximum simultaneous contacts: 2" in res.output
    png = tmp_path / "occupancy-step-up-2mm-s1.png"
    assert png.exists() and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p for p in os.listdir(tmp_path) if p != png.name] == []  # no temp files left


def test_predict_contact_bad_input_is_one_line_error(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for args, msg in [
        (["--surface", "nope"], "unknown surface"),
        (["--surface", "bump-4mm", "--subject", "3"], "unknown subject 3"),
        (["--surface", "bump-4mm", "--load", "-1"], "load"),
        (["--surface", "bump-4mm", "--out", str(tmp_path / "a-file")], "is a file; give a folder"),
    ]:
        (tmp_path / "a-file").write_text("x")
        res = _invoke(args)
        assert res.exit_code == 2, res.output
        assert msg in res.output
        assert "Traceback" not in res.output
    assert not os.path.exists("predict-contact")  # the default --out is created only to write in it
