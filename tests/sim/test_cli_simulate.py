"""The ``fingerfriction simulate`` command: thin, one-line errors, writes a study."""

from __future__ import annotations

import pytest
import typer.main
from typer.testing import CliRunner

from fingerfriction.cli import app
from fingerfriction.study import load_manifest


def _invoke(args):
    # with a single registered command typer runs it directly (no sub-command name)
    cmd = typer.main.get_command(app)
    prefix = ["simulate"] if hasattr(cmd, "commands") else []
    return CliRunner().invoke(app, prefix + args)


@pytest.mark.slow
def test_option_mistakes_are_one_line_errors(tmp_path):
    out = tmp_path / "o"
    for args, msg in [
        (["--surfaces", "bumpy"], "unknown surface 'bumpy'"),
        (["--speeds", "40,-3"], "--speeds must be in [1, 1000] mm/s, got -3"),
        (["--speeds", "fast"], "not a number"),
        (["--subjects", "7"], "unknown subject"),
        (["--reps", "0"], "reps must be"),
        (["--workers", "-1"], "--workers"),
    ]:
        r = _invoke(["--out", str(out), *args])
        assert r.exit_code == 2, (args, r.output)
        assert msg in r.output, (args, r.output)
        assert "Traceback" not in r.output
    assert not out.exists()


@pytest.mark.slow
def test_simulate_writes_a_study(tmp_path):
    out = tmp_path / "s"
    r = _invoke(["--out", str(out), "--reps", "1", "--subjects", "1", "--surfaces", "bump-2mm",
                 "--speeds", "120", "--workers", "1", "--contact-model", "bridged-foundation"])
    assert r.exit_code == 0, r.output
    st = load_manifest(out)
    assert [t.id for t in st.trials] == ["s1-bump-2mm-v120-r1"]
    # a different study into the same folder: refused with one line
    r = _invoke(["--out", str(out), "--reps", "1", "--subjects", "1", "--surfaces", "bump-2mm",
                 "--speeds", "80", "--workers", "1", "--contact-model", "bridged-foundation"])
    assert r.exit_code == 2 and "different study" in r.output
