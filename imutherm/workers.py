"""Worker processes: the one home of the studies' process pools, the ``--jobs`` check and the thread limits.

:func:`process_pool` builds every pool the studies run on (the end-to-end study, ``compare``'s schemes side
by side, a sweep, the correlation's reduced models, the uncertainty's IMU draws); :func:`check_jobs` and
:func:`usable_workers` count its workers; :func:`one_at_a_time` is the section its workers enter one at a
time (the mesh-error estimate's refined solve, ~8x a scheme's memory). In one process, :func:`thread_limit` and
:func:`one_blas_thread` (the thermal solves' decorator) limit the BLAS and OpenMP threads.

This module imports nothing heavy (no numpy): a spawned worker unpickles its start-up (``_start``) before
any task, so the thread limits set there are in the environment before numpy / scipy load BLAS and OpenMP.

Examples
--------
>>> from imutherm.workers import check_jobs, process_pool, usable_workers
>>> usable_workers(check_jobs(8), tasks=3)
3
>>> process_pool(1) is None   # one job: the caller runs its tasks in its own process
True
"""

from __future__ import annotations

import contextlib
import os

from imutherm import InputError

#: the environment variables that set the threads of BLAS, OpenMP and numba in a process started afresh
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS",
                    "VECLIB_MAXIMUM_THREADS")

#: in a worker: the process id of the process that started the pool, and the pool's shared lock (or None)
_PARENT_PID: int | None = None
_LOCK = None


def check_jobs(jobs: int | None) -> int:
    """``--jobs`` [-] checked: None is the default, min(2, CPUs); below 1 an InputError."""
    jobs = min(2, os.cpu_count() or 1) if jobs is None else int(jobs)
    if jobs < 1:
        raise InputError(f"--jobs: {jobs} is invalid; valid: an integer >= 1")
    return jobs


def usable_workers(jobs: int, tasks: int) -> int:
    """Worker processes [-] a run of ``tasks`` independent tasks can use with ``--jobs jobs``: no more than the
    tasks (a worker without a task would only hold memory), at least 1. The cost estimates count these, and
    the runs start no more (``sweep --jobs 10000`` of 2 cases runs, and is estimated, on 2 workers)."""
    return max(1, min(int(jobs), int(tasks)))


def process_pool(jobs: int, *, threads: int = 1, spawn: bool = False, shared_lock: bool = False):
    """A ``ProcessPoolExecutor`` of ``jobs`` workers, or None for ``jobs`` <= 1 (the caller runs its tasks itself).

    Workers are forked where the platform can (before any solve starts: scripts need no ``__main__`` guard and
    the workers share the parent's imports), else spawned; ``spawn=True`` always spawns (the workers start
    without the parent's numpy). Each worker runs ``threads`` BLAS / OpenMP threads: the workers already use
    the cores, and OpenBLAS's own threads on top oversubscribe them (two schemes' solves side by side ran 2.4x
    slower on 2 cores). A spawned worker gets the limit in its environment before BLAS loads, a forked one
    through threadpoolctl. ``shared_lock``: the workers share one lock, held by :func:`one_at_a_time`.
    """
    if jobs <= 1:
        return None
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    method = "spawn" if spawn or "fork" not in multiprocessing.get_all_start_methods() else "fork"
    ctx = multiprocessing.get_context(method)
    return ProcessPoolExecutor(max_workers=jobs, mp_context=ctx, initializer=_start,
                               initargs=(int(threads), os.getpid(), ctx.Lock() if shared_lock else None))


def _start(threads: int, parent_pid: int, lock) -> None:
    """A worker's start-up (:func:`process_pool`): ``threads`` threads, the pool's process id and lock kept."""
    global _PARENT_PID, _LOCK
    for var in THREAD_VARIABLES:
        os.environ[var] = str(threads)
    _PARENT_PID, _LOCK = parent_pid, lock
    import sys

    if "numpy" in sys.modules:   # forked: BLAS is loaded already, the environment is read no more
        from threadpoolctl import threadpool_limits

        threadpool_limits(threads)


def one_at_a_time():
    """A context in which a pool's workers run one at a time (the pool's shared lock); outside such a pool,
    or in a pool without the lock, a context that does nothing."""
    return _LOCK if _LOCK is not None else contextlib.nullcontext()


def parent_gone() -> bool:
    """True in a worker whose pool's process has died (the worker was re-parented): it should stop."""
    return _PARENT_PID is not None and os.getppid() != _PARENT_PID


def thread_limit(threads: int = 1, user_api: str | None = None):
    """A context limiting this process to ``threads`` threads of BLAS (``user_api='blas'``), OpenMP
    (``'openmp'``) or both (None), restored on exit (threadpoolctl)."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=threads, user_api=user_api)


def one_blas_thread(func):
    """``func`` run with one BLAS thread (numpy's and scipy's OpenBLAS), restored after the call.

    The thermal solves' decorator. They are sparse: their only BLAS calls are the vector dots and norms of CG,
    which are memory-bound, so a second OpenBLAS thread does not shorten them but spins between the calls. On the
    reference unit's steady solve (air, default mesh, linear laws; ``benchmarks/bench_reference.py``) the
    whole process took 5.1-5.6 CPU-s with OpenBLAS's default 2 threads on the 2-core machine and 3.3 CPU-s
    with one, in the same wall time (3.0-3.5 s; 2026-12-05). Entering the limit costs ~0.5 ms.
    """
    from threadpoolctl import threadpool_limits

    return threadpool_limits.wrap(limits=1, user_api="blas")(func)
