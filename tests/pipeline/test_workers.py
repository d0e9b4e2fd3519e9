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

    return os.getcwd(), os.environ.get("FINGERFRICTION_TEST_PROBE")


def test_a_worker_starts_in_the_callers_working_directory(tmp_path, monkeypatch):
    """As with spawn, the working directory at each start is the caller's (relative paths in a
    notebook that changed directory resolve as the user expects); the environment is the
    server's (documented in fingerfriction._workers)."""
    with ProcessPoolExecutor(1, mp_context=forkserver_context()) as ex:
        ex.submit(_cwd_and_probe).result(timeout=120)  # the server runs from here on
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("FINGERFRICTION_TEST_PROBE", "set after the server started")
    with ProcessPoolExecutor(1, mp_context=forkserver_context()) as ex:
        cwd, probe = ex.submit(_cwd_and_probe).result(timeout=120)
    assert cwd == str(tmp_path)
    assert probe is None
