"""numba's ``njit``, applied at a kernel's first call: importing a filter module does not import numba.

Importing numba takes ~53 MB of resident memory (its modules and LLVM). ``imutherm compare`` imports every
filter module before it forks its workers (the study's configuration names the filters), so with numba's
own ``njit`` the command held those pages, and its forked workers a part of them, through the thermal solves,
the study's peak included, although no filter runs until the first IMU case (at the peak, the command's 230 MB
became 173 MB and each worker's ~20 MB less). With this decorator numba is imported, and a kernel compiled (or
loaded from numba's cache), only when a kernel is first called.

A kernel called from another kernel works too: numba types a global that has a ``_numba_type_`` as that
type, here the compiled dispatcher's. Usage is numba's: ``@njit(cache=True)`` or ``njit(cache=True)(f)``.

Compiled once per machine, not once per process: a kernel's first call in a process compiles it, or loads it
from numba's on-disk cache, for its arguments' types while holding a lock shared by the user's processes on the
machine (:func:`compile_lock`), and runs it after releasing the lock (held through the run, as it was until
2026-12-07, it serialised two workers' first runs of a long kernel even on a warm cache). Without the lock, on
a cold cache (after an install, or after a filter's source changed) both of ``imutherm compare``'s workers
compiled every filter kernel side by side, ~47 CPU-s each on the project's machine (2026-12-07, load ~9); with
it the second worker waits and loads what the first wrote.
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import os
import tempfile
import threading

#: environment variable naming the lock file of the kernels' first calls (default: in the temporary folder)
LOCK_ENV = "IMUTHERM_JIT_LOCK"
_LOCAL = threading.local()


def lock_path() -> str:
    """The lock file [path] the first calls of kernels hold: ``$IMUTHERM_JIT_LOCK``, else one per user in the
    temporary folder."""
    uid = os.getuid() if hasattr(os, "getuid") else 0
    return os.environ.get(LOCK_ENV) or os.path.join(tempfile.gettempdir(), f"imutherm-jit-{uid}.lock")


@contextlib.contextmanager
def compile_lock():
    """A section one process of the machine at a time runs (an exclusive ``flock`` on :func:`lock_path`),
    re-entrant in a thread; where the lock cannot be had (no ``fcntl``, the file not writable) it does nothing."""
    depth = getattr(_LOCAL, "depth", 0)
    fd = None
    if depth == 0:
        try:
            import fcntl

            fd = os.open(lock_path(), os.O_RDWR | os.O_CREAT, 0o600)
            fcntl.flock(fd, fcntl.LOCK_EX)
        except (ImportError, OSError):
            if fd is not None:
                os.close(fd)
            fd = None
    _LOCAL.depth = depth + 1
    try:
        yield
    finally:
        _LOCAL.depth = depth
        if fd is not None:
            os.close(fd)   # closing the descriptor releases the lock


class LazyKernel:
    """A function compiled by ``numba.njit(**options)`` at its first call (or when a kernel that calls it
    is compiled); called before that, it compiles first. ``dispatcher``: numba's compiled function."""

    def __init__(self, func, options: dict, signatures: tuple = ()):
        self.func, self.options, self.signatures, self._dispatcher = func, dict(options), tuple(signatures), None
        functools.update_wrapper(self, func)

    @property
    def dispatcher(self):
        if self._dispatcher is None:
            import numba

            if self.signatures:   # numba compiles the given signatures at once: one process at a time
                with compile_lock():
                    self._dispatcher = numba.njit(*self.signatures, **self.options)(self.func)
            else:
                self._dispatcher = numba.njit(**self.options)(self.func)
        return self._dispatcher

    def __call__(self, *args, **kwargs):
        d = self.dispatcher
        if d.signatures:   # compiled or loaded in this process already
            return d(*args, **kwargs)
        if kwargs:   # numba folds keyword arguments itself: the whole first call under the lock
            with compile_lock():
                return d(*args, **kwargs)
        with compile_lock():   # the first call: one process of the machine at a time compiles (or loads) ...
            d.compile(tuple(d.typeof_pyval(a) for a in args))   # ... for these arguments' types (numba's own typing)
        return d(*args)   # ... and runs outside the lock: two workers' first runs side by side

    @property
    def _numba_type_(self):
        """numba's type of this kernel when another kernel calls it: its dispatcher's."""
        import numba

        return numba.types.Dispatcher(self.dispatcher)

    def __reduce__(self):   # pickled by name, as a module-level function is
        return _module_attribute, (self.func.__module__, self.func.__qualname__)


def _module_attribute(module: str, name: str):
    return getattr(importlib.import_module(module), name)


def njit(*args, **options):
    """``numba.njit`` deferred to the first call, with numba's forms: ``@njit``, ``@njit(cache=True)``,
    ``njit(f, cache=True)``, ``njit(cache=True)(f)``; signatures (``njit("f8(f8)")``) are passed on to numba."""
    if args and callable(args[0]):
        return LazyKernel(args[0], options)
    return lambda func: LazyKernel(func, options, args)
