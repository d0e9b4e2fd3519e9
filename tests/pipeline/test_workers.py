"""Worker processes start from the package's forkserver (``fingerfriction._workers``), which
has imported the workers' code: a worker has it before its first task."""

import logging
import multiprocessing as mp
from concurrent.futures import ProcessPoolExecutor

import dask
import pytest

from fingerfriction._workers import PRELOAD, forkserver_context
from fingerfriction.pipeline.analyze import _local_cluster_config

pytestmark = pytest.mark.skipif("forkserver" not in mp.get_all_start_methods(),
                                reason="this platform has no forkserver (Windows): spawn is used")

#: Evaluated in a worker before it runs anything of the package (eval is pickled by name).
LOADED = f"sorted(m for m in {PRELOAD!r} if m in __import__('sys').modules)"


def test_the_simulators_pool_workers_have_the_code_already():
    with ProcessPoolExecutor(1, mp_context=forkserver_context()) as ex:
        assert ex.submit(eval, LOADED).result(timeout=120) == sorted(PRELOAD)


def test_the_analysis_cluster_workers_come_from_the_same_server():
    from distributed import Client, LocalCluster

    cfg = _local_cluster_config()
    assert cfg["distributed.worker.multiprocessing-method"] == "forkserver"
    assert cfg["distributed.scheduler.allowed-failures"] == 0
    with dask.config.set(cfg):
        with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0",
                          silence_logs=logging.ERROR) as cluster, Client(cluster) as client:
            assert client.submit(eval, LOADED, pure=False).result(timeout=120) == sorted(PRELOAD)


def test_a_users_own_start_method_is_kept():
    with dask.config.set({"distributed.worker.multiprocessing-method": "fork"}):
        assert "distributed.worker.multiprocessing-method" not in _local_cluster_config()


def _cwd_and_probe():
    import os

    return os.getcwd(), os.environ.get("FINGERFRICTION_CACHE")


def test_a_worker_has_the_callers_directory_and_package_variables(tmp_path, monkeypatch):
    """Set after the server started (a notebook that changed directory and chose a cache):
    the simulator's workers and the analysis' workers see both, as with spawn."""
    from distributed import Client, LocalCluster

    from fingerfriction._workers import package_environ
    from fingerfriction.sim.writer import _init_worker

    with ProcessPoolExecutor(1, mp_context=forkserver_context()) as ex:
        ex.submit(_cwd_and_probe).result(timeout=120)  # the server runs from here on
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("FINGERFRICTION_CACHE", str(tmp_path / "cache"))
    want = (str(tmp_path), str(tmp_path / "cache"))
    with ProcessPoolExecutor(1, mp_context=forkserver_context(), initializer=_init_worker,
                             initargs=(package_environ(),)) as ex:
        assert ex.submit(_cwd_and_probe).result(timeout=120) == want
    with dask.config.set(_local_cluster_config()):
        with LocalCluster(n_workers=1, threads_per_worker=1, processes=True, dashboard_address=":0",
                          silence_logs=logging.ERROR, env=package_environ()) as cluster, \
                Client(cluster) as client:
            assert tuple(client.submit(_cwd_and_probe, pure=False).result(timeout=120)) == want
    # unset again: the workers read it as unset, whatever the server had
    monkeypatch.delenv("FINGERFRICTION_CACHE")
    with ProcessPoolExecutor(1, mp_context=forkserver_context(), initializer=_init_worker,
                             initargs=(package_environ(),)) as ex:
        assert ex.submit(_cwd_and_probe).result(timeout=120)[1] in (None, "")


BURN = '''
import time
from concurrent.futures import ProcessPoolExecutor

from fingerfriction._workers import forkserver_context


def burn(seconds):
    t = time.process_time()
    while time.process_time() - t < seconds:
        pass
    return True


if __name__ == "__main__":
    with ProcessPoolExecutor(1, mp_context=forkserver_context()) as ex:
        assert ex.submit(burn, 1.5).result(timeout=120)
'''


def test_a_commands_workers_count_in_its_cpu_time(tmp_path):
    """A command's workers' CPU time reaches whoever ran it (``RUSAGE_CHILDREN``: what the
    benchmarks print), as with spawned workers: the command stops its server at its exit
    and waits for it, and the server has reaped its workers."""
    import resource
    import subprocess
    import sys

    script = tmp_path / "burn.py"
    script.write_text(BURN)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([sys.executable, str(script)], check=True, cwd=tmp_path, timeout=300)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    assert cpu >= 1.5, f"the command's CPU time counted {cpu:.2f} s, its worker alone burned 1.5 s"
