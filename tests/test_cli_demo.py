"""The `demo` command: synthetic trials -> fit -> Table 1 and blind spots, --out writes tables."""

import pandas as pd
import pytest
from typer.testing import CliRunner

from fingerfriction.cli import app


@pytest.mark.slow
def test_demo_writes_tables(tmp_path):
    r = CliRunner().invoke(app, ["demo", "--reps", "1", "--out", str(tmp_path / "out")])
    assert r.exit_code == 0, r.output
    assert "Table 1" in r.output and "blind spots" in r.output and "mu fitted" in r.output
    t1 = pd.read_csv(tmp_path / "out" / "table1.csv")
    assert len(t1) == 18  # (2 subjects + both) x 2 scales x 3 shapes
    assert {"table1.md", "table1.tex", "blindspots.csv", "blindspots.md", "blindspots.tex"} <= {
        p.name for p in (tmp_path / "out").iterdir()
    }


def test_demo_bad_method_is_one_line_error():
    r = CliRunner().invoke(app, ["demo", "--method", "bfgs"])
    assert r.exit_code == 2
    assert "--method must be 'lstsq' or 'nelder-mead', got 'bfgs'" in r.output
    assert "Traceback" not in r.output
