"""The steady solve: Newton's method with a backtracking line search, and the steady energy balance.

Discretisation: Q1 (trilinear) finite elements on the tensor grid
(:mod:`imutherm.thermal.assembly`). Linear boundary laws (Convection,
Contact) use the consistent face mass; the nonlinear laws (NaturalConvection,
Radiation) use nodal (lumped) face quadrature, so their Jacobian is diagonal.

:func:`solve_steady` runs Newton's method on ``(K + H) T + N(T) = F`` with a
backtracking line search; the natural-convection slope is floored at ΔT → 0 (see
:meth:`~imutherm.thermal.problem.NaturalConvection.flux_out`). A surface-to-surface cavity
exchange enters each Newton step with its dense coupling (a low-rank product inside CG, see
:mod:`imutherm.thermal.cavity_radiation`), not only its diagonal slope. A linear
problem takes one solve. Non-convergence raises :class:`ConvergenceError`.

Linear solves (:mod:`imutherm.thermal.linear`): sparse LU below ``DIRECT_LIMIT`` unknowns, else CG
preconditioned by pyamg smoothed-aggregation AMG (``rtol`` 1e-10 for a linear
steady problem; for a nonlinear one an inexact Newton method whose outer
loop drives the error to ``tol``: each step's CG forced by the outer contraction,
1e-2 for the first step and down to 1e-4 (Eisenstat & Walker 1996; the field agrees
with 1e-10 inner solves to ~1e-11 K on the reference unit; the forcing takes 25-29 %
fewer CG iterations than 1e-4 at every step, which took ~25 % fewer than 1e-6). Newton stops on the error
left, estimated from the last two steps' contraction (:func:`remaining_error`), not on the last step's size:
on the reference unit grease 3 Newton steps instead of 5 (47 CG iterations instead of 87), potted 3 instead
of 4 (48 instead of 67), air unchanged (5, 77); fields within 1.2e-6 K of the classic test's.
"""

from __future__ import annotations

import math
import time

import numpy as np
import scipy.sparse.linalg as spla

from imutherm import ConvergenceError, InputError
from imutherm.thermal.assembly import Assembly, assemble
from imutherm.thermal.cavity_radiation import CavityExchange
from imutherm.thermal.guards import DIVERGED_RISE_K  # a steady rise beyond it is divergence, not physics
from imutherm.thermal.linear import CG_RTOL, check_rtol, choose_solver, Dirichlet, initial_field, LinSolver
from imutherm.thermal.probes import named_probes
from imutherm.workers import one_blas_thread
from imutherm.thermal.problem import ThermalProblem
from imutherm.thermal.results import SteadyResult

#: Relative residual of the CG solve of each Newton step (inexact Newton: the
#: right-hand side is the current residual, so the outer loop tightens it).
NEWTON_CG_RTOL = 1e-4
#: Forcing of the Newton steps' CG solves (inexact Newton; S. C. Eisenstat, H. F. Walker, "Choosing the forcing
#: terms in an inexact Newton method", SIAM J. Sci. Comput. 17(1), 16-32, 1996, their choice 2 with alpha = 1
#: since this Newton matrix is approximate and the outer rate linear; the constants chosen on the reference unit,
#: 1e-1 first took more Newton steps on potted): the first step to
#: FORCING_MAX, each next one to FORCING_GAMMA times the residual's last contraction, never tighter than
#: NEWTON_CG_RTOL (the solve then also keeps the preconditioner's rebuild check).
FORCING_MAX = 1e-2
FORCING_GAMMA = 0.5


def _check_heat_exit(asm: Assembly, n_dirichlet: int, what: str):
    has_exit = n_dirichlet > 0 or bool(asm.nonlinear) or any(bc.law.coefficient > 0 for bc in asm.linear)
    if not has_exit:
        raise InputError(f"{what}: no boundary law removes heat (no FixedTemperature, Convection, Contact, "
                         f"NaturalConvection or Radiation on any face): the steady state is undefined")


def _dirichlet_heat_by_face(asm: Assembly, nodes, S_out: np.ndarray, heat: dict):
    """Add the heat leaving through fixed-temperature nodes (per node, W) to ``heat`` by face."""
    if not len(nodes):
        return
    owner = {}
    for d in asm.dirichlet:
        for n_ in d.nodes.tolist():
            owner[n_] = d.face
    for n_, s in zip(nodes.tolist(), S_out.tolist()):
        heat[owner[n_]] = heat.get(owner[n_], 0.0) + s




def _check_diverging(problem, T, amb: float, it: int) -> None:
    """ConvergenceError naming the likely cause if a Newton iterate is non-finite or has exploded."""
    rise = float(np.abs(T - amb).max()) if np.all(np.isfinite(T)) else math.inf
    if rise > DIVERGED_RISE_K:
        raise ConvergenceError(f"solve_steady: diverging at Newton iteration {it} (max |T - ambient| = {rise:.3g} K, "
                               f"beyond {DIVERGED_RISE_K:g} K); likely cause: a power far beyond physical sense "
                               f"(total {problem.power_W:.3g} W) or boundary coefficients that remove no heat")


@one_blas_thread
def solve_steady(problem: ThermalProblem, *, tol: float = 1e-8, max_iter: int = 50, solver: str = "auto",
                 probes=None, initial_C=None, assembly: Assembly | None = None,
                 rtol: float | None = None, keep: dict | None = None) -> SteadyResult:
    """Steady temperature field of ``problem``.

    Parameters
    ----------
    problem : ThermalProblem
    tol : float [-]
        Newton stops when the error left, estimated from the last two steps' max|ΔT| (:func:`remaining_error`),
        is <= tol * max(1 K, max|T − ambient|).
    max_iter : int
        Newton iteration limit; exceeding it raises :class:`ConvergenceError`.
    solver : {'auto', 'direct', 'amg'}
        Linear solver; ``'auto'``: SuperLU below 20 000 unknowns, else AMG-CG.
    probes : dict or sequence of (name, (x, y, z)), optional [m]
    initial_C : float or ndarray (n_nodes,), optional [°C]
        Newton start (default ``ambient_C``).
    assembly : Assembly, optional
        Reuse an assembly of the same problem.
    rtol : float, optional [-]
        Relative residual of the inner CG solves (AMG path); default 1e-10 for a
        linear problem (one solve); for a nonlinear one the tightest the Newton steps'
        forcing goes (default 1e-4; the first step at 1e-2, :data:`FORCING_MAX`).
    keep : dict, optional
        Given, it gets ``"preconditioner"``: the linear solves' preconditioner (the AMG V-cycle, or the LU, of
        a Newton matrix of this solve), for the solves of nearby matrices that follow (the reduced transient's
        basis, the oven's reduced steady check, the mesh-error estimate's coarse level) instead of a new setup.

    Returns
    -------
    SteadyResult

    Raises
    ------
    ConvergenceError
        Newton did not converge in ``max_iter`` steps or diverged (:class:`imutherm.ConvergenceError`).
    InputError
        Bad arguments, or a problem from which no heat can leave.

    Examples
    --------
    A 10 mm slab (k = 1 W/m K) with 1 MW/m^3 of heat, both faces held at 20 °C: the centre rises by
    q L^2 / (8 k) = 12.5 K, which linear elements give exactly at the nodes.

    >>> import numpy as np
    >>> from imutherm.geometry.grid import TensorGrid
    >>> from imutherm.thermal import FixedTemperature, ThermalProblem, solve_steady
    >>> L = 0.01                                                        # [m]
    >>> grid = TensorGrid(np.linspace(0.0, L, 11), np.array([0.0, 1e-3]), np.array([0.0, 1e-3]),
    ...                   np.zeros((10, 1, 1), np.int32), ("slab",), {})
    >>> held = (FixedTemperature(20.0),)
    >>> problem = ThermalProblem(grid, k=1.0, rho_c=1.6e6, q=1e6, ambient_C=20.0,
    ...                          boundary={"xmin": held, "xmax": held})
    >>> steady = solve_steady(problem, probes={"centre": (L / 2, 5e-4, 5e-4)})
    >>> round(float(steady.probe_C[0]) - 20.0, 6)                       # [K]
    12.5
    >>> bool(steady.energy_balance_rel_error < 1e-9)
    True

    A layout's problem: :func:`imutherm.unit.model.build_problem`; the sites as probes:
    ``solve_steady(problem, probes=geometry.sites)``.
    """
    if not (isinstance(max_iter, (int, np.integer)) and max_iter >= 1):
        raise InputError(f"max_iter must be an integer >= 1, got {max_iter!r}")
    if not (np.isfinite(tol) and tol > 0):
        raise InputError(f"tol must be > 0, got {tol!r}")
    t0 = time.perf_counter()
    asm = assembly if assembly is not None else assemble(problem, mass=False)   # a steady solve needs no M
    assembly_s = time.perf_counter() - t0 if assembly is None else 0.0
    t1 = time.perf_counter()
    names, P = named_probes(problem.grid, probes)
    n = asm.n
    dnodes, dvals = asm.dirichlet_values(None)
    _check_heat_exit(asm, len(dnodes), "solve_steady")
    D = Dirichlet(asm, dnodes)
    free = ~D.mask
    method = choose_solver(solver, int(free.sum()))
    nonlinear = bool(asm.nonlinear)
    if rtol is None:
        rtol = NEWTON_CG_RTOL if nonlinear else CG_RTOL
    lin = LinSolver(method, rtol=check_rtol(rtol))
    L = asm.pattern.csr(asm.K_data + asm.H_data)
    F = asm.F_q + asm.F_bc
    T = initial_field(problem, initial_C, n)
    T[dnodes] = dvals

    def residual(T):
        N, J = asm.nonlinear_flux(T) if nonlinear else (0.0, None)
        r = L @ T + N - F
        r[dnodes] = 0.0
        return r, N, J

    T, it, lin_its = _newton(problem, asm, D, L, lin, residual, T, tol, max_iter)
    if keep is not None:
        keep["preconditioner"] = lin.pc
    r, N, _ = residual(T)
    LT = L @ T
    scale = np.linalg.norm(F[free]) + np.linalg.norm(np.asarray(N + 0 * T)[free]) + np.linalg.norm(LT[free])
    res = float(np.linalg.norm(r[free]) / scale) if scale > 0 else 0.0
    P_in, heat_bnd, ebal = steady_balance(asm, T, dnodes, F, LT, N)
    probe_C = P @ T
    T.setflags(write=False)
    probe_C.setflags(write=False)
    return SteadyResult(problem=problem, T_C=T, probe_names=names, probe_C=probe_C, newton_iterations=it,
                        linear_iterations=lin_its, residual=res, energy_balance_rel_error=float(ebal),
                        power_in_W=P_in, heat_out_W=heat_bnd, unknowns=int(free.sum()),
                        assembly_s=assembly_s, solve_s=time.perf_counter() - t1, solver=method)


def _newton(problem, asm, D, L, lin, residual, T, tol, max_iter):
    """Newton's method with a backtracking line search on ``residual(T) -> (r, N, J)`` = 0.

    A linear problem takes one solve with the matrix ``L`` (fixed nodes eliminated). Returns the
    converged field, the Newton iterations and the total linear iterations; raises
    :class:`ConvergenceError` when ``max_iter`` iterations do not bring the error left
    (:func:`remaining_error`) below ``tol * max(1 K, max|T − ambient|)``, or when an iterate diverges.
    """
    nonlinear = bool(asm.nonlinear)
    free = ~D.mask
    amb = problem.ambient_C
    # the Newton matrices' values in one array, for every step: L's own when no node is fixed (its diagonal put back
    # after each solve, for the residuals), else the eliminated copy. A copy a step kept three nnz-sized arrays at
    # once (the preconditioner's matrix, the last step's, the new one): 121 MB on the reference unit's default mesh
    data = D.eliminate(L.data)
    diag0 = data[D.free_diag].copy() if nonlinear else None
    r, N, J = residual(T)
    A = asm.pattern.csr(data)
    exchanges = [bc.law for bc in asm.nonlinear if isinstance(bc.law, CavityExchange)]
    lin_its = 0
    it = 0
    eta = FORCING_MAX
    last_change = math.inf
    for it in range(1, max_iter + 1):
        if nonlinear:
            data[D.free_diag] = diag0 + J[free]
            A = asm.pattern.csr(data)   # a new matrix object a step (the solver tells matrices apart by identity)
        try:
            dT, its = _newton_step(lin, A, exchanges, T, D.mask, r, eta if nonlinear else None)
        finally:
            if nonlinear and data is L.data:
                data[D.free_diag] = diag0   # L's values again
        lin_its += its
        if not nonlinear:
            T += dT
            _check_diverging(problem, T, amb, it)
            return T, it, lin_its
        rn0 = np.linalg.norm(r)
        step = 1.0
        for _ in range(30):
            T_new = T + step * dT
            r_new, N_new, J_new = residual(T_new)
            if np.isfinite(r_new).all() and np.linalg.norm(r_new) <= rn0 * (1 + 1e-12) + 1e-300:
                break
            step *= 0.5
        else:  # no decrease found (residual at round-off level): take the full step
            step = 1.0
            T_new, r_new, N_new, J_new = T + dT, *residual(T + dT)
        # the next forcing term follows the outer contraction (Eisenstat & Walker 1996, choice 2 with
        # alpha = 1: the Newton matrix is approximate, so the outer rate is linear, ~1/50 per step)
        eta = min(FORCING_MAX, FORCING_GAMMA * np.linalg.norm(r_new) / max(rn0, 1e-300))
        T, r, N, J = T_new, r_new, N_new, J_new
        _check_diverging(problem, T, amb, it)
        change = step * np.abs(dT).max()
        if remaining_error(change, last_change) <= tol * max(1.0, float(np.abs(T - amb).max())):
            return T, it, lin_its
        last_change = change
    raise ConvergenceError(f"solve_steady: Newton did not converge in {max_iter} iterations "
                           f"(last max|ΔT| = {change:.3g} K, residual norm {np.linalg.norm(r):.3g} W); "
                           f"raise max_iter or check the boundary laws")


def _newton_step(lin, A, exchanges, T, fixed, r, eta):
    """(dT, CG iterations) of one Newton step with the matrix ``A``: CG to the forcing ``eta`` first (inexact
    Newton; None: no forcing), to the solver's own tolerance when that is tighter or the loose solve fails."""
    # the exchange's coupling itself, not its diagonal slope (cavity_radiation's docstring)
    op = with_exchanges(A, exchanges, T, fixed) if exchanges else A
    pc = A if exchanges else None
    if eta is not None and eta > lin.rtol:   # inexact Newton: the step solved no tighter than it is worth
        try:
            dT, its, _ = lin.solve(op, -r, rtol=eta, pc_matrix=pc)
            return dT, its
        except ConvergenceError:      # a stale preconditioner: the full path below rebuilds it
            pass
    dT, its, _ = lin.solve(op, -r, pc_matrix=pc)
    return dT, its


def remaining_error(change: float, last_change: float) -> float:
    """The error [K] left after a Newton step that changed the field by ``change`` (max|ΔT|) after one of
    ``last_change``: with the contraction ``q = change / last_change`` of a linearly converging iteration, the
    steps still to come sum to ``change q / (1 - q)``; ``change`` itself (the classic test) while ``q > 1/2``
    or on the first step (Deuflhard, "Newton Methods for Nonlinear Problems", Springer 2004, sec. 2.1: the
    a-posteriori estimate of a contractive iteration)."""
    q = change / last_change if 0 < last_change < math.inf else math.inf
    return change * q / (1.0 - q) if q <= 0.5 else change


def with_exchanges(A, exchanges, T, fixed) -> spla.LinearOperator:
    """The Newton matrix ``A`` (sparse, each exchange's diagonal slope in it) with each surface-to-surface
    exchange's symmetric Jacobian at ``T`` [°C] in place of that slope, as an SPD operator for CG
    (fixed-temperature nodes, ``fixed`` True, keep their identity rows)."""
    terms = []
    for law in exchanges:
        s, D = law.symmetric_jacobian(T[law.nodes])
        terms.append((law, s, D))

    def matvec(v):
        v = np.ravel(v)
        out = A @ v
        w = np.where(fixed, 0.0, v)
        for law, s, D in terms:
            u = w[law.nodes]
            out[law.nodes] += law.PnT @ (s * (law.X @ (s * (law.Pn @ u)))) - D * u
        out[fixed] = v[fixed]
        return out

    return spla.LinearOperator(A.shape, matvec=matvec, dtype=float)


def steady_balance(asm: Assembly, T, dnodes, F, LT, N):
    """(power in [W], heat out per face [W], relative energy-balance error [-]) of the steady field ``T``.

    ``F`` the load, ``LT`` the linear operator applied to ``T``, ``N`` the nonlinear flux there
    (0.0 for a linear problem); fixed-temperature nodes count their consistent nodal reactions.
    """
    heat = asm.face_heat_out(T)
    if len(dnodes):
        Nd = (N if asm.nonlinear else np.zeros(asm.n))[dnodes]
        S_out = F[dnodes] - LT[dnodes] - Nd      # heat leaving through the fixed-T nodes
        _dirichlet_heat_by_face(asm, dnodes, S_out, heat)
    P_in = float(asm.F_q.sum()) + asm.flux_in_W
    heat_bnd = {k: v for k, v in heat.items()}
    flux_by_face = {}
    for bc in asm.fluxes:
        flux_by_face[bc.face] = flux_by_face.get(bc.face, 0.0) + bc.law.q * bc.weights.sum()
    Q_out = sum(heat_bnd.values()) + sum(flux_by_face.values())   # heat_out counts HeatFlux as negative
    denom = max(abs(P_in), 0.5 * sum(abs(v) for v in heat_bnd.values()), 1e-300)
    return P_in, heat_bnd, abs(P_in - Q_out) / denom
