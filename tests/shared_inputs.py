"""Expensive test inputs built once per test run, shared by the pytest-xdist workers."""

from __future__ import annotations

import fcntl
import os
import pickle
import shutil

#: The small demo's design (the session fixture ``small_demo``): 1 subject, 2 surfaces,
#: 1 speed, 1 repetition (2 simulated trials with videos), on 2 workers.
SMALL_DEMO = ("--subjects", "1", "--surfaces", "bump-2mm,step-up-4mm", "--speeds", "120", "--reps", "1",
              "--workers", "2")


def once_per_run(tmp_path_factory, name: str, build):
    """``(folder, value)``: ``build(folder)`` run once per test run, whatever the number of
    pytest-xdist workers that ask for it. The first to ask builds into a folder under the
    run's temporary root that the workers share (``value`` is pickled); the others wait
    for it and get the same folder. For the expensive inputs of a session fixture (a study
    simulated, analysed or fitted): without it each worker would build its own. Read-only
    to the tests: one that writes into it works on a copy."""
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # the run's root; the worker's basetemp is root/popen-gwN
    folder, done = root / f"once-{name}", root / f"once-{name}.pickle"
    with open(root / f"once-{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)  # a worker building it holds the others here
        if not done.is_file():
            shutil.rmtree(folder, ignore_errors=True)  # what a failed build left
            folder.mkdir()
            value = build(folder)
            done.write_bytes(pickle.dumps(value))
    return folder, pickle.loads(done.read_bytes())
