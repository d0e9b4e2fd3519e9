"""Settings and shared fixtures of the whole test session."""

import os
import tempfile
from pathlib import Path

import pytest
from hypothesis.configuration import set_hypothesis_home_dir

from shared_inputs import once_per_run

# The command line prints through rich, which wraps at the terminal's width (80 columns
# when the output is not a terminal). Tests look for phrases that contain paths under
# pytest's tmp folder, whose length varies (pytest-xdist adds a worker folder): a wide
# console keeps such a phrase on one line. Set before any test module imports the CLI.
os.environ.setdefault("COLUMNS", "200")

# Nothing is written into the source tree: hypothesis keeps its example database and caches
# in ./.hypothesis by default; they go to the folder FINGERFRICTION_HYPOTHESIS_DIR names, or
# to one under the system's temporary folder (shared by the runs, as ./.hypothesis was).
set_hypothesis_home_dir(os.environ.get("FINGERFRICTION_HYPOTHESIS_DIR")
                        or Path(tempfile.gettempdir()) / "fingerfriction-hypothesis")


def _synthetic_fit(tmp_path_factory, name: str, **kw) -> tuple:
    """``(results, exit status, output)`` of `fingerfriction fit` on the synthetic results
    of ``write_synthetic_results(**kw)`` (tests/report/report_synthetic.py), once per run."""

    def build(folder):
        import sys

        from typer.testing import CliRunner

        sys.path.insert(0, str(Path(__file__).parent / "report"))
        from report_synthetic import write_synthetic_results

        from fingerfriction.cli import app

        if "truth_dir" in kw:  # a folder beside the results
            kw["truth_dir"] = folder / kw["truth_dir"]
        write_synthetic_results(folder / "r", **kw)
        r = CliRunner().invoke(app, ["fit", str(folder / "r")])
        return r.exit_code, r.output

    folder, (exit_code, output) = once_per_run(tmp_path_factory, name, build)
    return folder / "r", exit_code, output


@pytest.fixture(scope="session")
def rejected_fit(tmp_path_factory):
    """``(results, exit status, output)`` of `fingerfriction fit` on synthetic results whose
    forces no variant explains (the forward model's contact, a force unrelated to the
    surface): every variant rejected. One fit for the command-line and the browser tests
    of a rejected model; a test that writes into the folder (the report) copies it."""
    return _synthetic_fit(tmp_path_factory, "rejected-fit", regions="forward", force_law="unrelated")


@pytest.fixture(scope="session")
def forward_fit(tmp_path_factory):
    """``(results, exit status, output)`` of `fingerfriction fit` on synthetic results with
    the forward model's contact, forces of a constant pressure with the start transient of
    real slides, and a truth folder: a study a variant explains, nothing flagged. One fit
    for the command-line and the browser tests; a test that writes into the folder copies it."""
    return _synthetic_fit(tmp_path_factory, "forward-fit", regions="forward", transient_mm=0.8,
                          truth_dir="study/truth")
