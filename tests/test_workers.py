"""The one home of the worker processes (:mod:`imutherm.workers`): the pools' start method, their workers' thread
limits and shared lock, the ``--jobs`` check; the studies' pools are built by it."""

import os
import time

import pytest

from imutherm import InputError
from imutherm.workers import THREAD_VARIABLES, check_jobs, one_at_a_time, parent_gone, process_pool, usable_workers


def _worker_state():
    """(BLAS threads, thread variables, parent gone) as a worker sees them."""
    import numpy  # noqa: F401  (BLAS loaded, as in a task)
    from threadpoolctl import threadpool_info

    blas = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    return blas, {v: os.environ.get(v) for v in THREAD_VARIABLES}, parent_gone()


def _held(_):
    """(start, end) [s] of a 0.3 s section run one at a time."""
    with one_at_a_time():
        t0 = time.time()
        time.sleep(0.3)
        return t0, time.time()


def test_check_jobs_and_usable_workers():
    assert check_jobs(None) == min(2, os.cpu_count() or 1) and check_jobs(3) == 3
    with pytest.raises(InputError, match="--jobs: 0 is invalid"):
        check_jobs(0)
    assert usable_workers(10000, 2) == 2 and usable_workers(1, 9) == 1 and usable_workers(3, 0) == 1


def test_one_job_is_no_pool_and_one_at_a_time_outside_a_pool_does_nothing():
    assert process_pool(1) is None and process_pool(0) is None
    with one_at_a_time():
        pass


@pytest.mark.parametrize("spawn", [False, True])
def test_the_workers_run_their_threads_and_know_their_parent(spawn, monkeypatch):
    from threadpoolctl import threadpool_limits

    for var in THREAD_VARIABLES:   # the parent on two threads: the workers must not inherit them
        monkeypatch.setenv(var, "2")
    with threadpool_limits(limits=2, user_api="blas"), process_pool(2, threads=1, spawn=spawn) as pool:
        blas, env, gone = pool.submit(_worker_state).result()
        method = pool._mp_context.get_start_method()
    assert method == ("spawn" if spawn or os.name == "nt" else "fork")
    assert env == {v: "1" for v in THREAD_VARIABLES} and gone is False
    assert blas and set(blas) == {1}   # OpenBLAS on one thread in the worker, forked or spawned


def test_the_shared_lock_runs_the_section_one_at_a_time():
    with process_pool(2, shared_lock=True) as pool:
        spans = sorted(pool.map(_held, range(2)))
    assert spans[1][0] >= spans[0][1] - 1e-3   # the second started after the first ended


def test_the_studies_build_their_pools_here():
    """No module of the package but :mod:`imutherm.workers` builds a process pool or picks a start method."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    hits = [p.relative_to(root).as_posix() for layer in ("imutherm", "geometry", "ecad", "imu", "thermal", "unit",
                                                         "studies", "reports")
            for p in sorted((root / layer).rglob("*.py"))
            if any(w in p.read_text(encoding="utf-8") for w in ("ProcessPoolExecutor(", "get_context("))]
    assert hits == ["imutherm/workers.py"]


def test_the_correlations_map_gives_in_two_workers_what_it_gives_in_one():
    """The correlation's model builds run through :func:`process_pool` (min(jobs, tasks) workers), in order."""
    from imutherm.studies.correlation.models import map_jobs

    args = [(7, 2), (9, 4), (10, 3)]
    assert map_jobs(divmod, args, 2) == map_jobs(divmod, args, 1) == [(3, 1), (2, 1), (3, 1)]
