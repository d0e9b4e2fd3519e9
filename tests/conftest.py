"""Settings for the whole test session."""

import os
import tempfile
from pathlib import Path

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
