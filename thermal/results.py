"""The results of the thermal solves: one frozen dataclass per kind of solve.

:class:`ThermalResult` holds what every solve returns (field, probe temperatures, iteration counts,
energy balance, timings); :class:`SteadyResult` adds the power in and the heat out per face,
:class:`TransientResult` the history (step times, saved fields, energy account, step statistics).
Reading a field renamed since (``iterations``) raises an :class:`AttributeError` that names its new
name (the rename shim, ``_RENAMED``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from imutherm.thermal.problem import ThermalProblem

#: result fields renamed in an earlier version: the old name -> what to read instead
_RENAMED = {"iterations": "newton_iterations (Newton iterations; 0 for a transient, whose nonlinear laws are "
                          "linearised once per step) or linear_iterations (inner linear-solver iterations)"}


@dataclass(frozen=True)
class ThermalResult:
    """What every thermal solve returns (base of :class:`SteadyResult` and :class:`TransientResult`).

    Attributes
    ----------
    problem : ThermalProblem
    T_C : ndarray (n_nodes,) [°C]
        Node temperatures (grid node order); for a transient the field at ``t_end``.
    probe_names : tuple of str
    probe_C : ndarray [°C]
        Trilinear interpolation of the field at the probe points: (n_probes,) for a steady
        solve, (n_steps + 1, n_probes) for a transient (one row per step time).
    newton_iterations : int
        Newton iterations of a steady solve (1 for a linear problem); 0 for a transient
        (nonlinear laws are linearised once per step, no inner iteration).
    linear_iterations : int
        Total inner linear-solver (CG) iterations over all solves (a direct solve counts 1).
    residual : float [-]
        Steady: final relative nonlinear residual; transient: largest relative linear
        residual of any step.
    energy_balance_rel_error : float [-]
    unknowns : int
        Number of free nodes.
    assembly_s, solve_s : float [s]
        Wall-clock times.
    solver : str
        ``'direct'`` or ``'amg'``.
    """

    problem: ThermalProblem
    T_C: np.ndarray
    probe_names: tuple
    probe_C: np.ndarray
    newton_iterations: int
    linear_iterations: int
    residual: float
    energy_balance_rel_error: float
    unknowns: int
    assembly_s: float
    solve_s: float
    solver: str

    @property
    def grid(self):
        return self.problem.grid

    @property
    def ambient_C(self) -> float:
        return self.problem.ambient_C

    def __getattr__(self, name):   # only reached when normal lookup fails: name the renamed fields
        if name in _RENAMED:
            raise AttributeError(f"{type(self).__name__}.{name} was renamed: use {_RENAMED[name]}")
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")


@dataclass(frozen=True)
class SteadyResult(ThermalResult):
    """Steady temperature field (fields of :class:`ThermalResult`, and:)

    Attributes
    ----------
    residual : float [-]
        Final relative residual ``‖r‖ / (‖F‖ + ‖N(T)‖ + ‖L T‖)`` over free nodes.
    energy_balance_rel_error : float [-]
        ``|P_in − Q_out| / max(P_in, ½ Σ|Q_face|)``, Q_out from the boundary laws
        at the solution (fixed-temperature faces: consistent nodal reactions).
    power_in_W : float [W]
        Volumetric power plus HeatFlux input.
    heat_out_W : dict [W]
        Heat leaving per face name (``xmin`` .. ``zmax``).
    """

    power_in_W: float
    heat_out_W: dict


@dataclass(frozen=True)
class TransientResult(ThermalResult):
    """Transient temperature history (fields of :class:`ThermalResult`, and:)

    Attributes
    ----------
    times : ndarray (n_steps + 1,) [s]
        Step times, starting at 0.
    T0_C : ndarray (n_nodes,) [°C]
        Field at t = 0 (after applying fixed temperatures).
    saved_times : ndarray (n_saved,) [s]
    saved_C : ndarray (n_saved, n_nodes) [°C]
        Fields at ``saved_times`` (linear in time between steps).
    energy_balance_rel_error : float [-]
        ``|E_in − (E_stored + E_out)| / max(|E_in|, |E_stored| + |E_out|)``; E_out
        integrated with the same weights as the scheme (θ, or TR-BDF2's b).
    energy_in_J, energy_stored_J, energy_out_J : float [J]
    steps : int
    theta : float
    lagged_nonlinear : bool
        True when nonlinear laws were linearised per step (no inner iteration).
    scheme : str
        ``'theta'`` or ``'trbdf2'`` (``theta`` is NaN for TR-BDF2).
    linear_solves : int
        Linear solves, including rejected steps and error estimates.
    rejected_steps : int
        Adaptive steps redone with a smaller step.
    tol_K : float or None [K]
        Local error tolerance of an adaptive run (None: given steps).
    settled : bool
        True when the run stopped early because every probe had settled (``settle_C``).
    """

    times: np.ndarray
    T0_C: np.ndarray
    saved_times: np.ndarray
    saved_C: np.ndarray
    energy_in_J: float
    energy_stored_J: float
    energy_out_J: float
    steps: int
    theta: float
    lagged_nonlinear: bool
    scheme: str = "theta"
    linear_solves: int = 0
    rejected_steps: int = 0
    tol_K: float | None = None
    settled: bool = False

