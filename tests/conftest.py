"""Settings and shared fixtures of the whole test session."""

import fcntl
import json
import os
import tempfile
from pathlib import Path

import pytest
from hypothesis.configuration import set_hypothesis_home_dir

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


def once_per_run(tmp_path_factory, name: str, build):
    """``(folder, value)``: ``build(folder)`` run once per test run, whatever the number of
    pytest-xdist workers that ask for it. The first to ask builds into a folder under the
    run's temporary root that the workers share (``value`` must be JSON); the others wait
    for it and get the same folder. For the expensive inputs of a session fixture (a study
    simulated, analysed or fitted): without it each worker would build its own. Read-only
    to the tests: one that writes into it works on a copy."""
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # the run's root; the worker's basetemp is root/popen-gwN
    folder, done = root / f"once-{name}", root / f"once-{name}.json"
    with open(root / f"once-{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # a worker building it holds the others here
        if not done.is_file():
            folder.mkdir(exist_ok=True)
            value = build(folder)
            done.write_text(json.dumps({"value": value}))
    return folder, json.loads(done.read_text())["value"]


@pytest.fixture(scope="session")
def rejected_fit(tmp_path_factory):
    """``(results, exit status, output)`` of `fingerfriction fit` on synthetic results whose
    forces no variant explains (the forward model's contact, a force unrelated to the
    surface): every variant rejected. One fit for the command-line and the browser tests
    of a rejected model; a test that writes into the folder (the report) copies it."""

    def build(folder):
        import sys

        from typer.testing import CliRunner

        sys.path.insert(0, str(Path(__file__).parent / "report"))
        from report_synthetic import write_synthetic_results

        from fingerfriction.cli import app

        write_synthetic_results(folder / "r", regions="forward", force_law="unrelated")
        r = CliRunner().invoke(app, ["fit", str(folder / "r")])
        return [r.exit_code, r.output]

    folder, (exit_code, output) = once_per_run(tmp_path_factory, "rejected-fit", build)
    return folder / "r", exit_code, output
