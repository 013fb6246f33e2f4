"""Start-up of a sweep's local worker process; imports nothing heavy on purpose.

The process pool unpickles :func:`init_worker` before any task, so the thread limits set here are in
the environment before numpy / scipy load their BLAS and OpenMP runtimes in that process.
"""

from __future__ import annotations

import os

_PARENT_PID: int | None = None

THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS",
                    "VECLIB_MAXIMUM_THREADS")


def init_worker(threads: int, parent_pid: int) -> None:
    """Limit BLAS / OpenMP / numba threads to ``threads`` and remember the sweep's process id."""
    global _PARENT_PID
    for var in THREAD_VARIABLES:
        os.environ[var] = str(threads)
    _PARENT_PID = parent_pid


def parent_gone() -> bool:
    """True if the sweep process that started this worker has died (the worker was re-parented)."""
    return _PARENT_PID is not None and os.getppid() != _PARENT_PID
