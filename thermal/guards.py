"""Guards of a transient time loop: divergence and a step-count cap, checked once per accepted step.

A transient whose iterates turn non-finite or explode (a power far beyond
physical sense, a ``power_profile`` returning nonsense, a radiation law fed an
overflowing temperature) would otherwise step on to ``t_end`` carrying NaN (the
adaptive TR-BDF2 controller accepts a NaN error estimate: ``nan > 1`` is False),
and an error-controlled run whose step stays small (a tolerance far tighter
than the run's length calls for, or a power switching faster than any step can
follow) would take unbounded time. :func:`check_step` stops both with a
:class:`~imutherm.ConvergenceError` that names the likely cause.

The time loops of :mod:`imutherm.thermal.transient` call it once per accepted
step with the new field; it costs a subtraction and two reductions over the
field (measured 6.7 ms at 2e5 nodes, best of 5, on this machine at load 12,
against the ~0.2 s a step of that size takes).
"""

from __future__ import annotations

import numpy as np

from imutherm import ConvergenceError
from imutherm.budget import MAX_TIME_STEPS
from imutherm.constants import ZERO_C_K

#: a change from the start field beyond this [K] is divergence, not physics: every material of the
#: package (FR-4 ~400 °C, aluminium ~660 °C, silicon ~1400 °C) has decomposed or melted long before
DIVERGED_RISE_K = 1e4
#: absolute zero [°C]: an iterate below it has left physics (the radiation laws take T in kelvin)
ABSOLUTE_ZERO_C = -ZERO_C_K
#: most steps (accepted + rejected) of one transient: the CLI's cost limit (:data:`imutherm.budget.MAX_TIME_STEPS`),
#: ~6 h at the ~0.2 s a step of a 2e5-unknown mesh takes here; the reference unit settles in ~20-30 adaptive steps
MAX_STEPS = MAX_TIME_STEPS


def check_step(T_C: np.ndarray, t: float, steps: int, *, start_C, t_end: float, power_W: float,
               rejected: int = 0, h: float | None = None, max_steps: int | None = MAX_STEPS) -> None:
    """Raise :class:`~imutherm.ConvergenceError` if the transient has diverged or run out of steps.

    Parameters
    ----------
    T_C : ndarray (n,) [°C]
        The field at the end of the step just accepted.
    t : float [s]
        Its time.
    steps : int [-]
        Steps accepted so far (this one included).
    start_C : float or ndarray (n,) [°C]
        The field at t = 0 (divergence is measured from it).
    t_end : float [s]
        The run's end time (for the message).
    power_W : float [W]
        Total power put in at full scale (volumetric plus boundary heat flux; for the message).
    rejected : int [-]
        Steps rejected so far by the error control (counted against ``max_steps``).
    h : float, optional [s]
        The step just taken (for the message).
    max_steps : int or None [-]
        Most steps, accepted plus rejected (default :data:`MAX_STEPS`); None: no cap (fixed steps given by
        the caller, whose number is known before the run).

    Raises
    ------
    ConvergenceError
        * a non-finite temperature, a change from ``start_C`` beyond :data:`DIVERGED_RISE_K`, or a
          temperature below absolute zero (diverged);
        * ``steps + rejected > max_steps`` before ``t_end`` (the error-controlled step stayed too small).
    """
    T = np.asarray(T_C)
    change = float(np.max(np.abs(T - start_C))) if T.size else 0.0  # NaN and inf propagate through max
    where = f"at t = {t:.6g} s (step {steps}{f', h = {h:.3g} s' if h is not None else ''})"
    if not change <= DIVERGED_RISE_K:
        what = ("a non-finite temperature" if not np.isfinite(change)
                else f"max |T - T(0)| = {change:.3g} K, beyond {DIVERGED_RISE_K:g} K")
        raise ConvergenceError(f"solve_transient: diverging {where}: {what}; likely cause: a power far beyond "
                               f"physical sense (total {power_W:.3g} W), a power_profile returning non-finite or "
                               f"huge values, or boundary laws that remove no heat")
    coldest = float(T.min()) if T.size else 0.0
    if coldest < ABSOLUTE_ZERO_C:
        raise ConvergenceError(f"solve_transient: diverging {where}: a temperature of {coldest:.4g} °C, below "
                               f"absolute zero; likely cause: a negative power (total {power_W:.3g} W) or "
                               f"power_profile, or boundary laws driving heat in without bound")
    if max_steps is not None and steps + rejected > max_steps and t < t_end * (1 - 1e-12):
        raise ConvergenceError(f"solve_transient: {steps} steps ({rejected} rejected) reached the limit of "
                               f"{max_steps:,} {where}, of t_end = {t_end:.6g} s; likely cause: a tolerance "
                               f"(tol_K) far tighter than a run this long needs, dt_max too small for t_end, or a "
                               f"power_profile switching faster than the steps can follow; raise tol_K or dt_max, "
                               f"or shorten t_end")
