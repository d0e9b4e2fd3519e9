"""The console's truth table: mu precise enough to compare with its CI, the error in %."""

from collections import namedtuple

from fingerfriction.cli.study import _truth_cell

Row = namedtuple("Row", "model subject mu_true mu_fitted error")


def test_mu_to_five_decimals_and_its_error_relative_to_the_truth():
    row = Row("load", "1", 0.55, 0.55021, 0.00021)
    assert _truth_cell("mu", "mu_fitted", row.mu_fitted, row) == "0.55021"
    assert _truth_cell("mu", "error", row.error, row) == "+0.04"
    assert _truth_cell("mu", "subject", row.subject, row) == "1"
    assert _truth_cell("blindspots", "error_mm", 0.0214, row) == "0.021"
    nan_row = Row("load", "1", float("nan"), 0.5, float("nan"))
    assert _truth_cell("mu", "error", nan_row.error, nan_row) == "nan"
