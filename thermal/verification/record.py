"""The verification suite's record of one case, the published reference values and the grids the cases share.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

import numpy as np

from imutherm.geometry.grid import TensorGrid


#: published reference values (quoted in the notes beside the exact solutions the cases compare with)
NAFEMS_T3_TARGET_C = 36.60     # NAFEMS T3, x = 0.08 m, t = 32 s [°C]
NAFEMS_T4_TARGET_C = 18.25     # NAFEMS T4, point E [°C]
NAFEMS_T4_ROUNDING_K = 0.005   # T4 is published to two decimals [K]
RADIATION_1D_PUBLISHED_K = 927.0   # 1-D conduction with a radiating end [K]


@dataclass(frozen=True)
class VerificationRecord:
    """One verification case.

    Attributes
    ----------
    case : str
    quantity : str
        What ``computed`` and ``exact`` are (with units).
    computed, exact : float
    error : float
        The compared error measure (see ``quantity``/``note``).
    tolerance : float
        Pass when ``error <= tolerance``.
    passed : bool
    note : str
        Why this tolerance; the reference used. Every figure in it is formatted from the
        run (a computed value, or an input of the case), never typed in as observed once
        (``tests/test_thermal_verification.py`` checks the source).
    seconds : float [s]
        Wall-clock time of the case.
    """

    case: str
    quantity: str
    computed: float
    exact: float
    error: float
    tolerance: float
    passed: bool
    note: str
    seconds: float = 0.0

    def as_dict(self) -> dict:
        d = asdict(self)
        d["pass"] = d.pop("passed")
        return d


def checked(case, quantity, computed, exact, error, tolerance, note, t0) -> VerificationRecord:
    """The record of one case, checked: passed if ``error`` is finite and within ``tolerance``; ``t0`` its
    :func:`time.perf_counter` start."""
    error = float(error)
    return VerificationRecord(case=case, quantity=quantity, computed=float(computed), exact=float(exact),
                              error=error, tolerance=float(tolerance),
                              passed=bool(np.isfinite(error) and error <= tolerance), note=note,
                              seconds=time.perf_counter() - t0)


def box_grid(xs, ys=(0.0, 0.01), zs=(0.0, 0.01), parts=None, names=("solid",)) -> TensorGrid:
    """A TensorGrid from node coordinates [m]; default one 10 mm cell across y and z (a 1-D bar).

    ``parts`` (cell part indices, shape (nx, ny, nz) or broadcastable flat) and
    ``names`` (part names) default to a single part ``solid``.
    """
    xs, ys, zs = (np.asarray(a, dtype=float) for a in (xs, ys, zs))
    shape = (len(xs) - 1, len(ys) - 1, len(zs) - 1)
    cp = np.zeros(shape, dtype=int) if parts is None else np.asarray(parts).reshape(shape)
    return TensorGrid(xs, ys, zs, cp, tuple(names), {})


def graded(x0: float, x1: float, n: int, ratio: float) -> np.ndarray:
    """``n`` cells from x0 to x1 [m], each ``ratio`` times longer than the previous."""
    w = ratio ** np.arange(n)
    return x0 + (x1 - x0) * np.concatenate([[0.0], np.cumsum(w) / w.sum()])
