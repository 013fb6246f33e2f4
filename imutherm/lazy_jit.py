"""numba's ``njit``, applied at a kernel's first call: importing a filter module does not import numba.

Importing numba takes ~53 MB of resident memory (its modules and LLVM). ``imutherm compare`` imports every
filter module before it forks its workers (the study's configuration names the filters), so with numba's
own ``njit`` the command held those pages, and its forked workers a part of them, through the thermal solves,
the study's peak included, although no filter runs until the first IMU case (at the peak, the command's 230 MB
became 173 MB and each worker's ~20 MB less). With this decorator numba is imported, and a kernel compiled (or
loaded from numba's cache), only when a kernel is first called.

A kernel called from another kernel works too: numba types a global that has a ``_numba_type_`` as that
type, here the compiled dispatcher's. Usage is numba's: ``@njit(cache=True)`` or ``njit(cache=True)(f)``.
"""

from __future__ import annotations

import functools
import importlib


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

            self._dispatcher = numba.njit(*self.signatures, **self.options)(self.func)
        return self._dispatcher

    def __call__(self, *args, **kwargs):
        return self.dispatcher(*args, **kwargs)

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
