"""How the package starts its worker processes: the simulator's process pool
(:func:`~fingerfriction.sim.simulate_study`) and the analysis' Dask local cluster
(:func:`~fingerfriction.pipeline.analyze.analyze`).

Both start them from a ``forkserver`` where the platform has one (not on Windows): one
server per calling process, which imports the workers' code once (:data:`PRELOAD`); each
worker is then a fork of it, instead of a new interpreter importing SciPy, pandas, OpenCV,
Dask and this package again, which can take longer than the work of a small run. The
server lives as long as the calling process, so later runs in it (a notebook, a script
over several studies, the test suite) start their workers at once. As with ``spawn``, each
worker still imports the calling script as ``__mp_main__`` (see ``_mainguard``) and starts
in the caller's current working directory with its ``sys.path``.

The environment is the server's, from when it started: the caller's later changes do not
reach a forked worker by themselves. The package's own variables (``FINGERFRICTION_*``,
which choose the FE finger's mesh and cache) are therefore handed to each worker at its
start (:func:`package_environ`), so that a study simulated after ``os.environ[...] = ...``
in a notebook uses what was set. Other libraries' variables read at import (thread counts)
keep the server's values: set them before the first run.
"""

from __future__ import annotations

import atexit
import multiprocessing as mp
import os

#: Imported by the forkserver before its first worker (an import that fails is skipped by
#: multiprocessing, and the worker imports what it needs itself).
PRELOAD = ("distributed", "fingerfriction.pipeline.analyze", "fingerfriction.sim.writer")


def forkserver_context():
    """The ``forkserver`` multiprocessing context with :data:`PRELOAD`, or None where the
    platform has no forkserver.

    The preload takes effect when the server starts (at the first worker of the process);
    set again later, it changes nothing.
    """
    if "forkserver" not in mp.get_all_start_methods():
        return None
    ctx = mp.get_context("forkserver")
    ctx.set_forkserver_preload(list(PRELOAD))
    atexit.unregister(_stop_server)  # registered once, however many runs ask for the context
    atexit.register(_stop_server)
    return ctx


def _stop_server() -> None:
    """At the caller's exit, stop its forkserver and wait for it.

    The server reaps the workers it forked; waited for by the caller, its CPU time and
    theirs count in the caller's (``resource.RUSAGE_CHILDREN`` of whoever runs the
    command: the benchmarks' CPU figures), as spawned workers' did. Left alone, the server
    outlives the caller for a moment and is reaped by init, its workers' CPU time with it.
    ``ForkServer._stop`` is the standard library's own way to stop it (used by CPython's
    tests); where a Python lacks it, nothing is done.
    """
    from multiprocessing import forkserver  # at exit only; the module is loaded when a forkserver ran

    stop = getattr(forkserver._forkserver, "_stop", None)
    if stop is not None:
        try:
            stop()
        except OSError:  # already gone, or not this process's child
            pass


#: The package's environment variables that its workers read (``mechanics.fe.provider``);
#: an empty value reads as unset.
PACKAGE_ENV = ("FINGERFRICTION_FE_MESH", "FINGERFRICTION_CACHE")


def package_environ() -> dict[str, str]:
    """The caller's package variables for a worker to take at its start: every
    ``FINGERFRICTION_*`` set, and an empty value for each of :data:`PACKAGE_ENV` that is not
    (a worker forked from a server started while it was set then reads it as unset)."""
    env = {k: v for k, v in os.environ.items() if k.startswith("FINGERFRICTION_")}
    return {**dict.fromkeys(PACKAGE_ENV, ""), **env}
