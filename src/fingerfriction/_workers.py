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
in the caller's current working directory with its ``sys.path``. Unlike ``spawn``, an
environment variable the caller sets after the server started does not reach the workers
(they keep the server's environment): set such variables (thread counts, say) before the
first run.
"""

from __future__ import annotations

import multiprocessing as mp

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
    return ctx
