"""One behaviour for every command: --out folders, file modes under the umask, --version,
readable option types in --help."""

from __future__ import annotations

import json
import os
import stat
import sys
from pathlib import Path

import numpy as np
import pytest
import typer
from typer.testing import CliRunner

from fingerfriction import __version__
from fingerfriction.cli import app

runner = CliRunner()


def _run(*args):
    r = runner.invoke(app, [str(a) for a in args])
    return r.exit_code, " ".join(r.output.split())


def test_version():
    code, out = _run("--version")
    assert code == 0 and out == f"fingerfriction {__version__}"


@pytest.mark.slow
def test_help_shows_readable_types():
    group = typer.main.get_command(app)
    assert len(group.commands) >= 12
    for name in ["", *group.commands]:
        code, out = _run(*([name] if name else []), "--help")
        assert code == 0, (name, out)
        for raw in ("<str>", "<bool>", "<int", "<float", "<list"):
            assert raw not in out, (name, raw)
    code, out = _run("analyze", "--help")
    assert "TEXT" in out and "INTEGER" in out and "FLOAT" in out


def _cluttered(tmp_path):
    d = tmp_path / "busy"
    d.mkdir()
    (d / "notes.txt").write_text("mine")
    return d


@pytest.mark.parametrize("command", [
    ["predict", "--surface", "bump-2mm", "--subject", "1", "--step", "0.1"],
    ["predict-contact", "--surface", "bump-2mm", "--subject", "1", "--step", "0.1"],
    ["demo", "--reps", "1"],
])
def test_a_folder_holding_something_else_is_refused(tmp_path, command):
    busy = _cluttered(tmp_path)
    code, out = _run(*command, "--out", busy)
    assert code == 2
    assert f"--out '{busy}' is not empty" in out and "it holds notes.txt; give a new or empty folder" in out
    assert sorted(os.listdir(busy)) == ["notes.txt"]


def test_analyze_refuses_a_folder_that_is_not_a_results_folder_and_creates_a_new_one(tmp_path):
    study = tmp_path / "study"
    (study / "raw").mkdir(parents=True)
    np.savez(study / "raw" / "f.npz", F1=np.zeros(10), F2=np.zeros(10))
    (study / "manifest.json").write_text(json.dumps({
        "format": "fingerfriction-study", "schema_version": 1,
        "trials": [{"id": "t1", "subject": "1", "surface": "bump-2mm", "speed_mm_s": 40,
                    "video": {"path": "raw/missing.cine"}, "force": {"path": "raw/f.npz", "fs_hz": 1e4}}]}))
    busy = _cluttered(tmp_path)
    for extra in ([], ["--dry-run"]):
        code, out = _run("analyze", study, "--out", busy, *extra)
        assert code == 2 and f"'{busy}' is not empty and is not a results folder" in out, out
    code, out = _run("analyze", study, "--out", tmp_path / "new" / "results")
    assert code == 1 and "0 computed, 0 already done, 1 failed" in out, out  # every trial failed: 1
    assert (tmp_path / "new" / "results" / "run.json").is_file()
    code, out = _run("analyze", study, "--out", tmp_path / "new" / "results")  # its own folder: resumed
    assert code == 1 and "1 failed" in out, out


@pytest.mark.slow
def test_outputs_are_created_where_missing(tmp_path):
    code, out = _run("predict", "--surface", "bump:W=3,H=0.5", "--subject", 1, "--step", 0.1, "--no-figures",
                     "--out", tmp_path / "a" / "pred")
    assert code == 0 and (tmp_path / "a" / "pred" / "forces.csv").is_file(), out
    code, out = _run("predict", "--surface", "bump:W=3,H=0.5", "--subject", 1, "--step", 0.1, "--no-figures",
                     "--out", tmp_path / "a" / "pred")  # the same command again: its own files
    assert code == 0, out
    code, out = _run("predict-contact", "--surface", "bump-2mm", "--subject", 1, "--step", 0.1,
                     "--out", tmp_path / "b" / "figs")
    assert code == 0 and (tmp_path / "b" / "figs" / "occupancy-bump-2mm-s1.png").is_file(), out
    code, out = _run("render", "--surface", "bump-2mm", "--subject", 1, "--step", 0.1,
                     "--out", tmp_path / "c" / "cmd.wav", "--table", tmp_path / "d" / "table.csv")
    assert code == 0 and (tmp_path / "c" / "cmd.wav").is_file() and (tmp_path / "d" / "table.csv").is_file()
    code, out = _run("render", "--surface", "bump-2mm", "--subject", 1, "--out", tmp_path / "c")
    assert code == 2 and "is a folder; give a file name" in out


@pytest.mark.slow
def test_every_output_follows_the_umask(tmp_path):
    """Under umask 027 every file the commands write is 0640 (tables, loso.*, predictions,
    render commands, figures, the report), as a colleague in the group can read them. In this
    process, its umask set for the commands and restored after them."""
    sys.path.insert(0, str(Path(__file__).parents[1] / "report"))
    from report_synthetic import write_synthetic_results

    out = str(tmp_path)
    old = os.umask(0o027)
    try:
        write_synthetic_results(out + "/results", subjects={"1": 0.55})  # one subject: the same files
        for args in (["fit", out + "/results"], ["report", out + "/results"],
                     ["predict", "--surface", "bump-2mm", "--subject", "1", "--step", "0.1",
                      "--out", out + "/p"],
                     ["predict-contact", "--surface", "bump-2mm", "--subject", "1", "--step", "0.1",
                      "--out", out + "/pc"],
                     ["render", "--surface", "bump-2mm", "--subject", "1", "--step", "0.1",
                      "--out", out + "/r/cmd.wav", "--table", out + "/r/table.csv"]):
            res = runner.invoke(app, args)
            assert res.exit_code == 0, (args, res.output)
    finally:
        os.umask(old)
    modes = {}
    for p in tmp_path.rglob("*"):
        if p.is_file():
            modes[str(p.relative_to(tmp_path))] = stat.S_IMODE(p.stat().st_mode)
    written = [k for k in modes if not k.startswith("results/trials/") and k != "results/run.json"]
    assert any(k.startswith("results/fit/") for k in written) and any(k.startswith("results/report/")
                                                                       for k in written)
    assert {"p/forces.csv", "pc/occupancy-bump-2mm-s1.png", "r/cmd.wav", "r/cmd.wav.json",
            "r/table.csv"} <= set(written)
    bad = {k: oct(m) for k, m in modes.items() if k in written and m != 0o640}
    assert not bad, bad


def test_options_defaulting_to_none_show_their_dataclass_default():
    # an option whose default is None leaves the value to the stage's dataclass (or function);
    # its help shows that default, looked up where it is defined: every lookup resolves
    from fingerfriction.cli._common import FieldDefault

    group = typer.main.get_command(app)
    shown = {}
    for name, cmd in group.commands.items():
        for p in cmd.params:
            if isinstance(p.show_default, FieldDefault):
                assert p.default is None, (name, p.opts)
                shown[f"{name} {p.opts[0]}"] = str(p.show_default)
    assert len(shown) >= 30
    assert shown["fit --median"] == "11" and shown["fit --mu-min"] == "0.3"
    assert shown["forces --notch-q"] == "10" and shown["simulate --world"] == "load-sharing"
    code, out = _run("fit", "--help")
    assert code == 0 and "[default: 11]" in out and "(11)" not in out
