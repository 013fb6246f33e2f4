"""The transient solve: :func:`solve_transient` from a uniform start, and its step sizes.

Two schemes (:mod:`imutherm.thermal.stepping`): the θ-scheme (θ = 1 backward Euler, θ = 0.5
Crank–Nicolson) with given steps, and TR-BDF2 with given or error-controlled steps (the default of every
study: :func:`imutherm.studies.thermal.thermal_study.run_scheme`). Both work in increment form from a uniform start
(``ambient_C``: power-on); the θ-scheme linearises the nonlinear laws once per step about the
start-of-step temperature, ``N(T1) ≈ N(T0) + N'(T0) (T1 − T0)`` (no inner iterations); the energy
bookkeeping uses the same fluxes the scheme used, so the balance closes to solver precision. Matrices are
assembled once; the direct factorisation or the AMG hierarchy is built once and reused as a
preconditioner across steps (rebuilt only when the step size changes a lot or CG slows down). Each
accepted step is handed to the observers (:mod:`imutherm.thermal.observers`) and checked by
:func:`imutherm.thermal.guards.check_step`. :func:`time_steps` makes geometrically growing given steps.
"""

from __future__ import annotations

import math
import time

import numpy as np

from imutherm import InputError
from imutherm.thermal.assembly import Assembly, assemble
from imutherm.thermal.guards import MAX_STEPS, check_step
from imutherm.thermal.linear import check_rtol
from imutherm.workers import one_blas_thread
from imutherm.thermal.observers import EnergyAccount, ProbeHistory, SavedFields, SettleWatch
from imutherm.thermal.probes import named_probes
from imutherm.thermal.problem import ThermalProblem
from imutherm.thermal.results import TransientResult
from imutherm.thermal.stepping import StepContext, theta_steps, trbdf2_steps

#: Relative residual of the per-step CG solves of a transient (relative to the step's right-hand side, i.e.
#: to the temperature increment). 1e-5 would save ~15 % of the iterations at the same t95, but the energy
#: balance with a time-dependent fixed temperature then degrades 100x (7e-7 -> 9e-5).
TRANSIENT_CG_RTOL = 1e-6


def time_steps(t_end: float, dt_first: float, dt_max: float, growth: float = 1.2) -> np.ndarray:
    """Geometrically growing step sizes [s] that sum to ``t_end`` [s].

    Steps start at ``dt_first`` [s], grow by ``growth`` per step up to
    ``dt_max`` [s]; the last step is shortened to land on ``t_end``. Pass the
    result as ``dt`` to :func:`solve_transient`.
    """
    if not (t_end > 0 and dt_first > 0 and dt_max >= dt_first and growth >= 1.0):
        raise InputError(f"time_steps: need t_end > 0, 0 < dt_first <= dt_max [s], growth >= 1; got "
                         f"t_end={t_end}, dt_first={dt_first}, dt_max={dt_max}, growth={growth}")
    steps, t, h = [], 0.0, float(dt_first)
    while t < t_end * (1 - 1e-12):
        h = min(h, t_end - t)
        steps.append(h)
        t += h
        h = min(h * growth, dt_max)
    if len(steps) > 1 and steps[-1] < 1e-6 * steps[-2]:
        steps[-2] += steps.pop()
    return np.array(steps)


def _t_end(t_end) -> float:
    """``t_end`` [s] as a float; InputError unless it is a finite number > 0 (given or adaptive steps alike)."""
    try:
        t_end = float(t_end)
    except (TypeError, ValueError):
        raise InputError(f"t_end must be a number [s], got {t_end!r}") from None
    if not (math.isfinite(t_end) and t_end > 0):
        raise InputError(f"t_end must be > 0 [s], got {t_end!r}")
    return t_end


def _step_sizes(t_end, dt) -> np.ndarray:
    """The given steps ``dt`` (one size, the last step shortened to land on ``t_end``, or an array that sums
    to ``t_end``) as an array [s]; InputError on a bad ``t_end`` or ``dt``."""
    t_end = _t_end(t_end)
    arr = np.atleast_1d(np.asarray(dt, dtype=float))
    if arr.size == 0 or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise InputError(f"dt must be > 0 [s] (a number or an array of step sizes), got {dt!r}")
    if arr.size == 1:
        h = float(arr[0])
        if h > t_end * (1 + 1e-12):
            raise InputError(f"dt = {h} s is longer than t_end = {t_end} s")
        n = max(1, int(math.ceil(t_end / h - 1e-9)))
        steps = np.full(n, h)
        steps[-1] = t_end - h * (n - 1)
        if n > 1 and steps[-1] < 1e-6 * h:
            steps = steps[:-1]
            steps[-1] += t_end - steps.sum()
        return steps
    if abs(arr.sum() - t_end) > 1e-9 * t_end:
        raise InputError(f"the step sizes dt sum to {arr.sum()} s, not t_end = {t_end} s")
    return arr


#: default local error tolerance of the adaptive TR-BDF2 run [K] (max over nodes per step); see solve_transient
DEFAULT_TOL_K = 0.01
#: default first step of an adaptive run [s]; the controller shrinks it if the power-on jump needs it. The
#: chip dies' power-on jump limits the first steps to ~0.07 s at 0.01 K on the reference unit: a 0.25 s start
#: was rejected 4-5 times (15 wasted solves), 0.05 s is accepted and then grows 2x per step.
DEFAULT_DT_FIRST = 0.05
#: default largest step of an adaptive run [s]
DEFAULT_DT_MAX = 300.0
#: settle stop: every probe within this fraction of its final rise (and past its t95)
SETTLE_FRACTION = 0.005
SCHEMES = ("theta", "trbdf2")


def _settle_targets(settle_C, names):
    if settle_C is None:
        return None
    if isinstance(settle_C, dict):
        unknown = [k for k in settle_C if k not in names]
        missing = [k for k in names if k not in settle_C]
        if unknown or missing:
            raise InputError(f"settle_C must give a final temperature for every probe {list(names)}; "
                             f"unknown {unknown}, missing {missing}")
        vals = np.array([float(settle_C[k]) for k in names])
    else:
        vals = np.atleast_1d(np.asarray(settle_C, dtype=float))
        if vals.shape != (len(names),):
            raise InputError(f"settle_C must have one value per probe ({len(names)}), got shape {vals.shape}")
    if not len(names):
        raise InputError("settle_C needs probes (the stop watches the probe temperatures)")
    if not np.all(np.isfinite(vals)):
        raise InputError(f"settle_C must be finite [°C], got {vals.tolist()}")
    return vals


def _positive(name, v, allow_none=True):
    if v is None and allow_none:
        return None
    try:
        f = float(v)
    except (TypeError, ValueError):
        raise InputError(f"{name} must be a number > 0, got {v!r}") from None
    if not (math.isfinite(f) and f > 0):
        raise InputError(f"{name} must be a finite number > 0, got {v!r}")
    return f


@one_blas_thread
def solve_transient(problem: ThermalProblem, t_end: float, dt=None, *, scheme: str = "theta", theta: float = 1.0,
                    tol_K: float | None = None, error_control: str = "nodes", dt_first: float | None = None, dt_max: float | None = None,
                    settle_C=None, settle_fraction: float = SETTLE_FRACTION, save_times=None,
                    probes=None, progress: bool = False, solver: str = "auto", lumped_mass: bool = False,
                    initial_C=None, power_profile=None, assembly: Assembly | None = None,
                    rtol: float = TRANSIENT_CG_RTOL) -> TransientResult:
    """Transient temperature history of ``problem`` from a uniform start.

    Two schemes:

    * ``'theta'``: θ-scheme with given steps (θ = 1 backward Euler, first order;
      θ = 0.5 Crank–Nicolson), one solve per step.
    * ``'trbdf2'``: TR-BDF2 (Bank et al. 1985; Hosea & Shampine 1996) with
      γ = 2 − √2: second order, L-stable (the power-on jump does not ring as
      with Crank–Nicolson), one-step, and both stages use the same matrix
      M + (γ/2) h L, so one AMG hierarchy serves a step size and is reused while
      the step changes by less than 2x. Written as an ESDIRK with weights
      b = (√2/4, √2/4, 1 − √2/2); the heat leaving is integrated with the same
      weights, so the energy balance closes to the CG tolerance. With ``dt``
      given the steps are fixed (two solves per step); with ``dt=None`` the
      step is error-controlled: the embedded third-order weights of Hosea &
      Shampine give an O(h^3) local error estimate, filtered by one loose
      (1e-1) solve with the same matrix so that stiff components (the chip dies
      at power-on) do not spoil it; a step whose max nodal estimate exceeds
      ``tol_K`` is redone with a smaller step, and the next step is
      h·min(2, max(0.2, 0.9 (tol/err)^(1/3))), capped at ``dt_max``. This
      controls accuracy where the curves bend and takes long steps where they
      flatten, which fixed steps cannot do: the power-on to settle transient of
      the reference unit takes ~20-30 steps for a t95 within 2 % (see
      ``benchmarks/bench_transient_accuracy.py``), against 54 growing
      backward-Euler steps that overestimate t95 by 11-14 %.

    Nonlinear laws (natural convection, radiation) are linearised about the
    start of the step (θ-scheme), or, for TR-BDF2, about the start of the step in
    stage 1 and re-evaluated exactly at the stage value T(t + γh) for stage 2
    (the Jacobian, hence the matrix, stays that of the step start). The energy
    bookkeeping uses exactly the fluxes the scheme used.

    Parameters
    ----------
    problem : ThermalProblem
    t_end : float [s]
        End time (> 0); with ``settle_C`` the latest end.
    dt : float or array_like or None [s]
        Step size (> 0; the last step is shortened to land on ``t_end``), or the
        sequence of step sizes (summing to ``t_end``; see :func:`time_steps`).
        ``None`` (``scheme='trbdf2'`` only): error-controlled steps.
    scheme : {'theta', 'trbdf2'}
        Default ``'theta'``, the historical default kept so that a call with given steps
        means the same scheme it always did: the verification cases call it so
        (``theta=0.5``, Crank–Nicolson) and switching the default would change their
        stored figures. Every study passes ``'trbdf2'``
        (:func:`imutherm.studies.thermal.thermal_study.run_scheme`, the reduced models' checks,
        the correlation's re-runs) and so does the CLI; adaptive steps (``dt=None``)
        need ``'trbdf2'``.
    theta : float [-]
        θ-scheme weight: 1.0 backward Euler (default), 0.5 Crank–Nicolson.
    tol_K : float, optional [K]
        Local error tolerance per adaptive step, default 0.01 K (~1/1000 of the
        5-20 K rises of the reference unit's sites): there it gives every site's t95
        within ~1 % of a step-converged run (see the benchmark).
    error_control : {'nodes', 'probes'}
        Where the local error estimate is measured (max norm): every free node
        (default), or only the probes. ``run_scheme`` controls the sites (probes):
        the study reports their curves, and with node control the sub-second
        power-on transients of the small, hot chip dies (which TR-BDF2 damps,
        L-stable, and whose heat the scheme conserves exactly) would hold the
        step small for many extra steps (air scheme, 6 mm mesh, 0.01 K: 38 steps
        to reach 200 s with node control, 21 with site control).
    dt_first, dt_max : float, optional [s]
        First and largest adaptive step (default 0.05 s and 300 s).
    settle_C : dict or array_like, optional [°C]
        Final (steady) temperature of every probe: the run stops at the first
        step where every probe has passed 95 % of its rise from its t = 0 value
        and is within ``settle_fraction`` of that rise from the final value
        (``t_end`` is then only an upper bound).
    settle_fraction : float [-]
        Default 0.005.
    save_times : sequence of float, optional [s]
        Times in [0, t_end] at which to keep the whole field (linear in time between
        steps); times after a settle stop are dropped.
    probes : dict or sequence of (name, (x, y, z)), optional [m]
        Points whose temperature is recorded at every step (trilinear interpolation).
    progress : bool
        Show a tqdm progress bar.
    solver : {'auto', 'direct', 'amg'}
    lumped_mass : bool
        Lumped (row-sum) heat capacity; default consistent. Ignored when ``assembly`` is given.
    initial_C : float or ndarray (n_nodes,), optional [°C]
        Start field (default ``ambient_C``: power-on from ambient).
    power_profile : callable, optional
        ``s(t [s]) -> [-]`` multiplying the volumetric power (default 1: power on at t = 0).
    assembly : Assembly, optional
    rtol : float [-]
        Relative residual of the per-step (per-stage) CG solves (AMG path), default 1e-6
        (relative to the step's right-hand side, i.e. to the temperature
        increment): the algebraic error stays far below the time-discretisation
        error and the energy balance still closes to ~1e-7.

    Returns
    -------
    TransientResult

    Raises
    ------
    ConvergenceError
        The iterates diverged, a linear solve failed, or the steps hit their limit
        (:class:`imutherm.ConvergenceError`).
    InputError
        Bad arguments.

    Examples
    --------
    A 10 mm aluminium cube with 0.06 W inside and h = 10 W/m^2 K on its six faces, switched on at 20 °C. Its
    Biot number h a / k is 5e-4, so it heats as one lump: a rise of P/(hA) = 10 K with τ = ρc V/(hA) = 400 s,
    10 (1 − 1/e) = 6.32 K at t = τ; the adaptive steps hold the error near their 0.01 K tolerance.

    >>> import numpy as np
    >>> from imutherm.geometry.grid import TensorGrid
    >>> from imutherm.thermal import Convection, ThermalProblem, solve_transient
    >>> a = 0.01                                                        # [m]
    >>> lines = np.linspace(0.0, a, 3)
    >>> cube = TensorGrid(lines, lines, lines, np.zeros((2, 2, 2), np.int32), ("block",), {})
    >>> air = (Convection(10.0),)
    >>> problem = ThermalProblem(cube, k=200.0, rho_c=2.4e6, q=0.06 / a**3, ambient_C=20.0,
    ...                          boundary={face: air for face in ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")})
    >>> result = solve_transient(problem, 400.0, scheme="trbdf2", probes={"centre": (a / 2, a / 2, a / 2)})
    >>> print(f"{result.probe_C[-1, 0] - 20.0:.2f} K after {result.times[-1]:.0f} s in {result.steps} steps")
    6.33 K after 400 s in 14 steps

    A layout's problem and its sensor sites: :func:`imutherm.studies.thermal.thermal_study.run_scheme`, or
    ``solve_transient(problem, 1500.0, scheme="trbdf2", probes=geometry.sites, settle_C=...)`` as in the
    gallery's API example.
    """
    if scheme not in SCHEMES:
        raise InputError(f"scheme must be one of {', '.join(SCHEMES)}, got {scheme!r}")
    adaptive = dt is None
    if adaptive and scheme != "trbdf2":
        raise InputError("dt is required for the theta scheme (error-controlled steps need scheme='trbdf2')")
    if not adaptive and (tol_K is not None or dt_first is not None or dt_max is not None):
        raise InputError("tol_K, dt_first and dt_max apply to adaptive steps (dt=None) only")
    if error_control not in ("nodes", "probes"):
        raise InputError(f"error_control must be 'nodes' or 'probes', got {error_control!r}")
    if adaptive:
        t_end = _t_end(t_end)
        tol_K = _positive("tol_K [K]", DEFAULT_TOL_K if tol_K is None else tol_K, False)
        dt_first = min(_positive("dt_first [s]", DEFAULT_DT_FIRST if dt_first is None else dt_first, False), t_end)
        dt_max = _positive("dt_max [s]", DEFAULT_DT_MAX if dt_max is None else dt_max, False)
        if dt_max < dt_first:
            raise InputError(f"dt_max = {dt_max} s must not be smaller than dt_first = {dt_first} s")
        steps = None
    else:
        steps = _step_sizes(t_end, dt)
        t_end = float(steps.sum())
    try:
        theta = float(theta)
    except (TypeError, ValueError):
        raise InputError(f"theta must be a number in [0.5, 1], got {theta!r}") from None
    if not 0.5 <= theta <= 1.0:
        raise InputError(f"theta must be in [0.5, 1] (1 backward Euler, 0.5 Crank–Nicolson), got {theta}")
    if not (0 < float(settle_fraction) < 0.05):
        raise InputError(f"settle_fraction must be in (0, 0.05), got {settle_fraction!r}")
    if power_profile is not None and not callable(power_profile):
        raise InputError("power_profile must be a callable s(t [s]) -> [-]")
    sv = np.sort(np.atleast_1d(np.asarray([] if save_times is None else save_times, dtype=float)))
    if sv.size and (not np.all(np.isfinite(sv)) or sv[0] < 0 or sv[-1] > t_end * (1 + 1e-12)):
        raise InputError(f"save_times must lie in [0, t_end = {t_end}] s, got {sv.tolist()}")
    names, P = named_probes(problem.grid, probes)
    settle = _settle_targets(settle_C, names)
    if adaptive and error_control == "probes" and not names:
        raise InputError("error_control='probes' needs probes")
    t0 = time.perf_counter()
    asm = assembly if assembly is not None else assemble(problem, lumped_mass=lumped_mass)
    assembly_s = time.perf_counter() - t0 if assembly is None else 0.0
    t1 = time.perf_counter()
    ctx = StepContext.start(problem, asm, P, solver, check_rtol(rtol), initial_C, power_profile, t_end)
    if scheme == "theta":
        stepper = theta_steps(ctx, steps, theta)
    else:
        stepper = trbdf2_steps(ctx, steps, tol_K, dt_first, dt_max, error_control)
    history = ProbeHistory(P, ctx.T0)
    saved = SavedFields(sv, ctx.T0)
    energy = EnergyAccount(asm)
    watch = SettleWatch(settle, float(settle_fraction), history) if settle is not None else None
    T, settled = _run(ctx, stepper, (saved, history, energy), watch, MAX_STEPS if adaptive else None, progress)
    E_stored, ebal = energy.close(ctx.T0, T)
    times, probe_hist = history.arrays()
    saved_C = saved.array(asm.n)
    T_start = ctx.T0
    sv_out = sv[:len(saved_C)]
    for arr in (T, T_start, probe_hist, saved_C, times, sv_out):
        arr.setflags(write=False)
    return TransientResult(problem=problem, times=times, T_C=T, T0_C=T_start, probe_names=names,
                           probe_C=probe_hist, saved_times=sv_out, saved_C=saved_C, newton_iterations=0,
                           linear_iterations=ctx.its, residual=ctx.res_max, energy_balance_rel_error=float(ebal),
                           energy_in_J=energy.E_in, energy_stored_J=E_stored, energy_out_J=energy.E_out,
                           unknowns=int(ctx.free.sum()), steps=len(times) - 1,
                           theta=theta if scheme == "theta" else float("nan"),
                           assembly_s=assembly_s, solve_s=time.perf_counter() - t1, solver=ctx.method,
                           lagged_nonlinear=bool(asm.nonlinear), scheme=scheme, linear_solves=ctx.solves,
                           rejected_steps=ctx.rejected, tol_K=tol_K if adaptive else None, settled=settled)


def _run(ctx: StepContext, stepper, observers, watch, max_steps, progress):
    """Drive ``stepper``, hand each step to the observers, check it (guards) and stop on settle.

    Returns the final field and whether the settle stop ended the run.
    """
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=round(ctx.t_end, 6), desc="transient", unit="s")
    T, settled = ctx.T0.copy(), False
    try:
        for st in stepper:
            for obs in observers:
                obs.observe(st)
            T = st.T
            check_step(T, st.tb, st.k, start_C=ctx.T0, t_end=ctx.t_end, power_W=ctx.power_W,
                       rejected=ctx.rejected, h=st.h, max_steps=max_steps)
            if bar is not None:
                bar.update(round(st.h, 6))
            if watch is not None and watch.observe(st):
                settled = True
                break
    finally:
        if bar is not None:
            bar.close()
    return T, settled
