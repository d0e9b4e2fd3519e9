"""Settings for the whole test session."""

import os

# The command line prints through rich, which wraps at the terminal's width (80 columns
# when the output is not a terminal). Tests look for phrases that contain paths under
# pytest's tmp folder, whose length varies (pytest-xdist adds a worker folder): a wide
# console keeps such a phrase on one line. Set before any test module imports the CLI.
os.environ.setdefault("COLUMNS", "200")
