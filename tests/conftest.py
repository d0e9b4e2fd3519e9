"""Settings and shared fixtures of the whole test session."""

import os
import tempfile
from pathlib import Path

import pytest
from hypothesis.configuration import set_hypothesis_home_dir

from shared_inputs import SMALL_DEMO, once_per_run

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


@pytest.fixture(scope="session")
def small_demo(tmp_path_factory):
    """``(folder, console output)`` of `fingerfriction demo` on the small design
    (``shared_inputs.SMALL_DEMO``), run once per test run: for the demo command's own test
    and the report opened in a browser. Read-only; a test that writes into it copies it."""

    def build(folder):
        from typer.testing import CliRunner

        from fingerfriction.cli import app

        r = CliRunner().invoke(app, ["demo", "--out", str(folder / "demo"), *SMALL_DEMO])
        assert r.exit_code == 0, r.output
        return r.output

    folder, output = once_per_run(tmp_path_factory, "small-demo", build)
    return folder / "demo", output


#: The test files that keep a worker longest (wall seconds in a whole-suite run on 2 cores,
#: measured; most first). They run first and the rest after them in the usual order, so that
#: with `--dist loadfile` (pyproject.toml: whole files to whichever worker is free) the last
#: files handed out are short ones and the workers end together. The order of the tests only:
#: a file missing here, or listed out of date, runs all the same.
LONGEST_FIRST = (
    "report/test_html_chromium.py",         # 175 s
    "pipeline/test_pipeline.py",            # 162
    "test_readme_python.py",                # 155
    "report/test_report.py",                # 98
    "pipeline/test_finger_calibration.py",  # 90
    "mechanics/test_calibrate.py",          # 71
    "fit/test_sim_worlds.py",               # 69
    "hostile/test_hostile.py",              # 66
    "predict/test_predict.py",              # 65
    "pipeline/test_lab_study.py",           # 64
    "selfcheck/test_study.py",              # 63
    "sim/test_writer.py",                   # 60
    "cli/test_conventions.py",              # 55
    "mechanics/test_fe_calibration.py",     # 53
    "fit/test_select.py",                   # 44
    "report/test_flags_pages.py",           # 42
    "report/test_console_fit.py",           # 40
    "fit/test_load.py",                     # 34
    "mechanics/test_fe.py",                 # 28
    "cli/test_study_commands.py",           # 26
    "sim/test_cli_simulate.py",             # 24
    "cli/test_demo.py",                     # 20
    "report/test_figures.py",               # 20
    "sim/test_fe_sim.py",                   # 19
    "sim/test_worlds.py",                   # 15
)


def pytest_collection_modifyitems(config, items):
    """The files of :data:`LONGEST_FIRST` first, in that order (a stable sort: the tests of a
    file keep their order)."""
    here = Path(__file__).parent
    rank = {name: k for k, name in enumerate(LONGEST_FIRST)}

    def key(item):
        try:
            return rank.get(item.path.relative_to(here).as_posix(), len(rank))
        except ValueError:  # a test outside tests/
            return len(rank)

    items.sort(key=key)
