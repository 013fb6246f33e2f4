"""Steady and transient solves of a :class:`~imutherm.thermal.problem.ThermalProblem`.

Discretisation: Q1 (trilinear) finite elements on the tensor grid
(:mod:`imutherm.thermal.assembly`). Linear boundary laws (Convection,
Contact) use the consistent face mass; the nonlinear laws (NaturalConvection,
Radiation) use nodal (lumped) face quadrature, so their Jacobian is diagonal.

Steady: Newton's method on ``(K + H) T + N(T) = F`` with a backtracking line
search; the natural-convection slope is floored at ΔT → 0 (see
:meth:`~imutherm.thermal.problem.NaturalConvection.flux_out`). A linear
problem takes one solve. Non-convergence raises :class:`ConvergenceError`.

Transient: θ-scheme (θ = 1 backward Euler, θ = 0.5 Crank–Nicolson) in
increment form, from a uniform start (``ambient_C``: power-on). Nonlinear laws
are *linearised once per step* about the start-of-step temperature,
``N(T1) ≈ N(T0) + N'(T0) (T1 − T0)`` (no inner iterations); the energy
bookkeeping uses the same linearised flux, so the balance closes to solver
precision. Matrices are assembled once; the direct factorisation or the AMG
hierarchy is built once and reused as a preconditioner across steps (rebuilt
only when the step size changes a lot or CG slows down).

Linear solves: sparse LU below ``DIRECT_LIMIT`` unknowns, else CG
preconditioned by pyamg smoothed-aggregation AMG (``rtol`` 1e-10 for a linear
steady problem; 1e-4 per Newton step, an inexact Newton method whose outer
loop drives the error to ``tol``: the field agrees with 1e-10 inner solves to
~1e-11 K on the reference unit at ~25 % fewer CG iterations than 1e-6 and ~50 % fewer than 1e-10; 1e-6 per
transient step).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from imutherm import InputError
from imutherm.thermal.assembly import Assembly, assemble
from imutherm.thermal.problem import ThermalProblem

#: Below this many unknowns ``solver='auto'`` factorises (SuperLU), above it uses AMG-CG.
DIRECT_LIMIT = 20_000
#: Relative residual of the CG solve of a linear steady problem (one solve).
CG_RTOL = 1e-10
#: Relative residual of the CG solve of each Newton step (inexact Newton: the
#: right-hand side is the current residual, so the outer loop tightens it).
NEWTON_CG_RTOL = 1e-4
#: Relative residual of the per-step CG solves of a transient.
TRANSIENT_CG_RTOL = 1e-6


class ConvergenceError(InputError):
    """A solve did not converge (Newton iterations or the linear solver); no result is returned."""


# --------------------------------------------------------------------------- results

@dataclass(frozen=True)
class SteadyResult:
    """Steady temperature field.

    Attributes
    ----------
    problem : ThermalProblem
    T_C : ndarray (n_nodes,) [°C]
        Node temperatures (grid node order).
    probe_names : tuple of str
    probe_C : ndarray (n_probes,) [°C]
        Trilinear interpolation of the field at the probe points.
    iterations : int
        Newton iterations (1 for a linear problem).
    linear_iterations : int
        Total inner CG iterations (direct solves count 1).
    residual : float [-]
        Final relative residual ``‖r‖ / (‖F‖ + ‖N(T)‖ + ‖L T‖)`` over free nodes.
    energy_balance_rel_error : float [-]
        ``|P_in − Q_out| / max(P_in, ½ Σ|Q_face|)``, Q_out from the boundary laws
        at the solution (fixed-temperature faces: consistent nodal reactions).
    power_in_W : float [W]
        Volumetric power plus HeatFlux input.
    heat_out_W : dict [W]
        Heat leaving per face name (``xmin`` .. ``zmax``).
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
    iterations: int
    linear_iterations: int
    residual: float
    energy_balance_rel_error: float
    power_in_W: float
    heat_out_W: dict
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


@dataclass(frozen=True)
class TransientResult:
    """Transient temperature history.

    Attributes
    ----------
    problem : ThermalProblem
    times : ndarray (n_steps + 1,) [s]
        Step times, starting at 0.
    T_C : ndarray (n_nodes,) [°C]
        Field at ``t_end``.
    T0_C : ndarray (n_nodes,) [°C]
        Field at t = 0 (after applying fixed temperatures).
    probe_names : tuple of str
    probe_C : ndarray (n_steps + 1, n_probes) [°C]
        Probe temperatures at every step.
    saved_times : ndarray (n_saved,) [s]
    saved_C : ndarray (n_saved, n_nodes) [°C]
        Fields at ``saved_times`` (linear in time between steps).
    iterations : int
        Total inner linear-solver iterations over all steps (direct solves count 1).
    residual : float [-]
        Largest relative linear residual of any step.
    energy_balance_rel_error : float [-]
        ``|E_in − (E_stored + E_out)| / max(|E_in|, |E_stored| + |E_out|)``; E_out
        integrated with the same θ-weighting as the scheme.
    energy_in_J, energy_stored_J, energy_out_J : float [J]
    unknowns : int
    steps : int
    theta : float
    assembly_s, solve_s : float [s]
    solver : str
    lagged_nonlinear : bool
        True when nonlinear laws were linearised per step (no inner iteration).
    """

    problem: ThermalProblem
    times: np.ndarray
    T_C: np.ndarray
    T0_C: np.ndarray
    probe_names: tuple
    probe_C: np.ndarray
    saved_times: np.ndarray
    saved_C: np.ndarray
    iterations: int
    residual: float
    energy_balance_rel_error: float
    energy_in_J: float
    energy_stored_J: float
    energy_out_J: float
    unknowns: int
    steps: int
    theta: float
    assembly_s: float
    solve_s: float
    solver: str
    lagged_nonlinear: bool

    @property
    def grid(self):
        return self.problem.grid

    @property
    def ambient_C(self) -> float:
        return self.problem.ambient_C


# --------------------------------------------------------------------------- probes

def probe_matrix(grid, points) -> sp.csr_matrix:
    """Trilinear interpolation operator (n_points, n_nodes) for points [m] inside the grid."""
    pts = np.atleast_2d(np.asarray(points, dtype=float))
    if pts.size == 0:
        return sp.csr_matrix((0, grid.n_nodes))
    if pts.shape[1] != 3 or not np.all(np.isfinite(pts)):
        raise InputError(f"probe points must be finite (x, y, z) [m], got shape {pts.shape}")
    axes = (grid.xs, grid.ys, grid.zs)
    Nx, Ny, Nz = (len(a) for a in axes)
    idx, xi = [], []
    for d, a in enumerate(axes):
        p = pts[:, d]
        tol = 1e-9 * (a[-1] - a[0])
        out = (p < a[0] - tol) | (p > a[-1] + tol)
        if out.any():
            bad = pts[np.flatnonzero(out)[0]].tolist()
            raise InputError(f"probe point {bad} [m] lies outside the grid "
                             f"({'xyz'[d]} in [{a[0]:.6g}, {a[-1]:.6g}] m)")
        i = np.clip(np.searchsorted(a, p, side="right") - 1, 0, len(a) - 2)
        idx.append(i)
        xi.append(np.clip((p - a[i]) / (a[i + 1] - a[i]), 0.0, 1.0))
    rows, cols, vals = [], [], []
    for da in (0, 1):
        for db in (0, 1):
            for dc in (0, 1):
                w = (xi[0] if da else 1 - xi[0]) * (xi[1] if db else 1 - xi[1]) * (xi[2] if dc else 1 - xi[2])
                node = ((idx[0] + da) * Ny + (idx[1] + db)) * Nz + (idx[2] + dc)
                rows.append(np.arange(len(pts)))
                cols.append(node)
                vals.append(w)
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(len(pts), grid.n_nodes))


def _probes(grid, probes):
    if probes is None:
        return (), sp.csr_matrix((0, grid.n_nodes))
    items = list(probes.items()) if isinstance(probes, dict) else list(probes)
    names = tuple(str(n) for n, _ in items)
    if len(set(names)) != len(names):
        raise InputError(f"probe names must be unique, got {names}")
    pts = np.array([np.asarray(p, dtype=float).reshape(3) for _, p in items]) if items else np.zeros((0, 3))
    return names, probe_matrix(grid, pts)


# --------------------------------------------------------------------------- linear algebra

def amg_preconditioner(A) -> spla.LinearOperator:
    """One smoothed-aggregation V-cycle (pyamg) as an SPD preconditioner for CG.

    Prolongation smoothing uses the local (Gershgorin) spectral-radius
    estimate: the default Arnoldi estimate costs ~10x more setup time and can
    break down (NaN) on the consistent-mass transient matrices, whose
    off-diagonals are partly positive. The hierarchy is built and cycled in
    single precision (the V-cycle is memory-bound: ~35 % faster, the same CG
    iteration count; CG itself and its residuals stay in double precision, so
    the accuracy of the solve is unchanged). The V-cycle is called directly
    (pyamg's ``aspreconditioner`` adds two residual evaluations per
    application); the public route is the fallback.
    """
    import pyamg

    def build(dtype):
        return pyamg.smoothed_aggregation_solver(A.astype(dtype), symmetry="hermitian", max_coarse=500,
                                                 smooth=("jacobi", {"omega": 4.0 / 3.0, "weighting": "local"}))

    ml = build(np.float32)
    cycle = getattr(ml, "_MultilevelSolver__solve", None)
    if cycle is None or len(ml.levels) < 2:  # small problem (one level: a dense solve) or another pyamg
        return build(np.float64).aspreconditioner(cycle="V")

    def matvec(b):
        b = np.ravel(np.asarray(b, dtype=np.float32))
        x = np.zeros_like(b)
        cycle(0, x, b, "V", 1)
        return x.astype(float)

    return spla.LinearOperator(A.shape, matvec=matvec, dtype=float)


class _LinSolver:
    """Solves A x = b for a sequence of SPD matrices near the one the preconditioner was built on."""

    def __init__(self, method: str, rtol: float = CG_RTOL, maxiter: int = 5000):
        self.method = method
        self.rtol = rtol
        self.maxiter = maxiter
        self.A_pc = None
        self.pc = None
        self.lu = None
        self.base_its = None
        self.setups = 0

    def prepare(self, A):
        self.A_pc = A
        self.setups += 1
        if self.method == "direct":
            self.lu = spla.splu(A.tocsc())
            self.pc = spla.LinearOperator(A.shape, matvec=self.lu.solve, dtype=float)
        else:
            self.pc = amg_preconditioner(A)
        self.base_its = None

    def _cg(self, A, b, x0):
        its = [0]

        def cb(_):
            its[0] += 1

        # preconditioned by the factorisation of a nearby matrix, CG needs only a few iterations:
        # the direct path always solves tightly
        rtol = min(self.rtol, CG_RTOL) if self.method == "direct" else self.rtol
        x, info = spla.cg(A, b, x0=x0, rtol=rtol, atol=0.0, maxiter=self.maxiter, M=self.pc, callback=cb)
        return x, info, its[0]

    def solve(self, A, b, x0=None):
        """Return (x, iterations, relative residual)."""
        bn = np.linalg.norm(b)
        if bn == 0.0:
            return np.zeros_like(b), 0, 0.0
        if self.pc is None:
            self.prepare(A)
        if x0 is not None:
            # best multiple of the predictor (one matvec), dropped if it does not beat zero
            w = A @ x0
            ww = float(np.dot(w, w))
            alpha = float(np.dot(w, b)) / ww if ww > 0 else 0.0
            if alpha <= 0 or np.linalg.norm(b - alpha * w) >= bn:
                x0 = None
            else:
                x0 = alpha * x0
        if self.method == "direct" and A is self.A_pc:
            x = self.lu.solve(b)
            its = 1
        else:
            x, info, its = self._cg(A, b, x0)
            slow = self.base_its is not None and its > 2 * self.base_its + 10
            if self.method == "direct" and its > 10:
                slow = True
            if info != 0 or slow:
                self.prepare(A)
                if self.method == "direct":
                    x, its = self.lu.solve(b), its + 1
                else:
                    x, info, its2 = self._cg(A, b, x0)
                    its += its2
                    if info != 0:
                        raise ConvergenceError(f"AMG-preconditioned CG did not reach rtol={self.rtol:g} "
                                               f"in {self.maxiter} iterations (info={info})")
                    self.base_its = its2
            elif self.base_its is None:
                self.base_its = its
        rel = float(np.linalg.norm(b - A @ x) / bn)
        if not np.isfinite(rel) or rel > max(1e-6, 10 * self.rtol):
            raise ConvergenceError(f"linear solve failed: relative residual {rel:.3g}")
        return x, its, rel


def _check_rtol(rtol) -> float:
    try:
        r = float(rtol)
    except (TypeError, ValueError):
        raise InputError(f"rtol must be a number in (0, 1e-2], got {rtol!r}") from None
    if not 0 < r <= 1e-2:
        raise InputError(f"rtol must be in (0, 1e-2], got {rtol!r}")
    return r


def _choose(solver: str, n_free: int) -> str:
    if solver not in ("auto", "direct", "amg"):
        raise InputError(f"solver must be 'auto', 'direct' or 'amg', got {solver!r}")
    if solver == "auto":
        return "direct" if n_free < DIRECT_LIMIT else "amg"
    return solver


class _Dirichlet:
    """Symmetric elimination of fixed-temperature nodes on the shared CSR pattern."""

    def __init__(self, asm: Assembly, nodes: np.ndarray):
        self.nodes = nodes
        pat = asm.pattern
        self.mask = np.zeros(asm.n, dtype=bool)
        self.mask[nodes] = True
        self.kill = self.mask[pat.rows] | self.mask[pat.indices] if len(nodes) else None
        self.diag = pat.diag_pos[nodes]
        self.free_diag = pat.diag_pos[~self.mask]

    def eliminate(self, data: np.ndarray) -> np.ndarray:
        if self.kill is None:
            return data
        d = data.copy()
        d[self.kill] = 0.0
        d[self.diag] = 1.0
        return d


def _check_heat_exit(asm: Assembly, n_dirichlet: int, what: str):
    has_exit = n_dirichlet > 0 or bool(asm.nonlinear) or any(bc.law.coefficient > 0 for bc in asm.linear)
    if not has_exit:
        raise InputError(f"{what}: no boundary law removes heat (no FixedTemperature, Convection, Contact, "
                         f"NaturalConvection or Radiation on any face): the steady state is undefined")


def _initial_field(problem: ThermalProblem, initial_C, n: int) -> np.ndarray:
    if initial_C is None:
        return np.full(n, problem.ambient_C)
    T = np.array(initial_C, dtype=float)
    if T.ndim == 0:
        return np.full(n, float(T))
    if T.shape != (n,) or not np.all(np.isfinite(T)):
        raise InputError(f"initial_C must be a number or a finite array of shape ({n},) [°C], got {T.shape}")
    return T.copy()


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


# --------------------------------------------------------------------------- steady

#: a steady rise beyond this [K] is divergence, not physics (every material here has melted long before)
DIVERGED_RISE_K = 1e4


def _check_diverging(problem, T, amb: float, it: int) -> None:
    """ConvergenceError naming the likely cause if a Newton iterate is non-finite or has exploded."""
    rise = float(np.abs(T - amb).max()) if np.all(np.isfinite(T)) else math.inf
    if rise > DIVERGED_RISE_K:
        raise ConvergenceError(f"solve_steady: diverging at Newton iteration {it} (max |T - ambient| = {rise:.3g} K, "
                               f"beyond {DIVERGED_RISE_K:g} K); likely cause: a power far beyond physical sense "
                               f"(total {problem.power_W:.3g} W) or boundary coefficients that remove no heat")


def solve_steady(problem: ThermalProblem, *, tol: float = 1e-8, max_iter: int = 50, solver: str = "auto",
                 probes=None, initial_C=None, assembly: Assembly | None = None,
                 rtol: float | None = None) -> SteadyResult:
    """Steady temperature field of ``problem``.

    Parameters
    ----------
    problem : ThermalProblem
    tol : float [-]
        Newton stops when max|ΔT| <= tol * max(1 K, max|T − ambient|).
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
        linear problem (one solve), 1e-4 per Newton step of a nonlinear one.

    Returns
    -------
    SteadyResult
    """
    if not (isinstance(max_iter, (int, np.integer)) and max_iter >= 1):
        raise InputError(f"max_iter must be an integer >= 1, got {max_iter!r}")
    if not (np.isfinite(tol) and tol > 0):
        raise InputError(f"tol must be > 0, got {tol!r}")
    t0 = time.perf_counter()
    asm = assembly if assembly is not None else assemble(problem)
    assembly_s = time.perf_counter() - t0 if assembly is None else 0.0
    t1 = time.perf_counter()
    names, P = _probes(problem.grid, probes)
    n = asm.n
    dnodes, dvals = asm.dirichlet_values(None)
    _check_heat_exit(asm, len(dnodes), "solve_steady")
    D = _Dirichlet(asm, dnodes)
    free = ~D.mask
    method = _choose(solver, int(free.sum()))
    nonlinear = bool(asm.nonlinear)
    if rtol is None:
        rtol = NEWTON_CG_RTOL if nonlinear else CG_RTOL
    lin = _LinSolver(method, rtol=_check_rtol(rtol))
    L = asm.pattern.csr(asm.K_data + asm.H_data)
    F = asm.F_q + asm.F_bc
    base = D.eliminate(L.data)
    T = _initial_field(problem, initial_C, n)
    T[dnodes] = dvals
    amb = problem.ambient_C

    def residual(T):
        N, J = asm.nonlinear_flux(T) if nonlinear else (0.0, None)
        r = L @ T + N - F
        r[dnodes] = 0.0
        return r, N, J

    r, N, J = residual(T)
    A = asm.pattern.csr(base)
    lin_its = 0
    converged = False
    it = 0
    for it in range(1, max_iter + 1):
        if nonlinear:
            data = base.copy()
            data[D.free_diag] += J[free]
            A = asm.pattern.csr(data)
        dT, its, _ = lin.solve(A, -r)
        lin_its += its
        if not nonlinear:
            T += dT
            _check_diverging(problem, T, amb, it)
            converged = True
            break
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
        T, r, N, J = T_new, r_new, N_new, J_new
        _check_diverging(problem, T, amb, it)
        change = step * np.abs(dT).max()
        if change <= tol * max(1.0, float(np.abs(T - amb).max())):
            converged = True
            break
    if not converged:
        raise ConvergenceError(f"solve_steady: Newton did not converge in {max_iter} iterations "
                               f"(last max|ΔT| = {change:.3g} K, residual norm {np.linalg.norm(r):.3g} W); "
                               f"raise max_iter or check the boundary laws")
    r, N, _ = residual(T)
    LT = L @ T
    scale = np.linalg.norm(F[free]) + np.linalg.norm(np.asarray(N + 0 * T)[free]) + np.linalg.norm(LT[free])
    res = float(np.linalg.norm(r[free]) / scale) if scale > 0 else 0.0
    # energy balance
    heat = asm.face_heat_out(T)
    if len(dnodes):
        Nd = (N if nonlinear else np.zeros(n))[dnodes]
        S_out = F[dnodes] - LT[dnodes] - Nd      # heat leaving through the fixed-T nodes
        _dirichlet_heat_by_face(asm, dnodes, S_out, heat)
    P_in = float(asm.F_q.sum()) + asm.flux_in_W
    heat_bnd = {k: v for k, v in heat.items()}
    flux_by_face = {}
    for bc in asm.fluxes:
        flux_by_face[bc.face] = flux_by_face.get(bc.face, 0.0) + bc.law.q * bc.weights.sum()
    Q_out = sum(heat_bnd.values()) + sum(flux_by_face.values())   # heat_out counts HeatFlux as negative
    denom = max(abs(P_in), 0.5 * sum(abs(v) for v in heat_bnd.values()), 1e-300)
    ebal = abs(P_in - Q_out) / denom
    probe_C = P @ T
    T.setflags(write=False)
    probe_C.setflags(write=False)
    return SteadyResult(problem=problem, T_C=T, probe_names=names, probe_C=probe_C, iterations=it,
                        linear_iterations=lin_its, residual=res, energy_balance_rel_error=float(ebal),
                        power_in_W=P_in, heat_out_W=heat_bnd, unknowns=int(free.sum()),
                        assembly_s=assembly_s, solve_s=time.perf_counter() - t1, solver=method)


# --------------------------------------------------------------------------- transient

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


def _step_sizes(t_end, dt) -> np.ndarray:
    try:
        t_end = float(t_end)
    except (TypeError, ValueError):
        raise InputError(f"t_end must be a number [s], got {t_end!r}") from None
    if not (math.isfinite(t_end) and t_end > 0):
        raise InputError(f"t_end must be > 0 [s], got {t_end!r}")
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


def solve_transient(problem: ThermalProblem, t_end: float, dt, *, theta: float = 1.0, save_times=None,
                    probes=None, progress: bool = False, solver: str = "auto", lumped_mass: bool = False,
                    initial_C=None, power_scale=None, assembly: Assembly | None = None,
                    rtol: float = TRANSIENT_CG_RTOL) -> TransientResult:
    """Transient temperature history of ``problem`` from a uniform start.

    Parameters
    ----------
    problem : ThermalProblem
    t_end : float [s]
        End time (> 0).
    dt : float or array_like [s]
        Step size (> 0; the last step is shortened to land on ``t_end``), or
        the sequence of step sizes (summing to ``t_end``; see :func:`time_steps`).
    theta : float [-]
        1.0 backward Euler (default, robust to the power-on jump), 0.5 Crank–Nicolson.
    save_times : sequence of float, optional [s]
        Times in [0, t_end] at which to keep the whole field (linear in time between steps).
    probes : dict or sequence of (name, (x, y, z)), optional [m]
        Points whose temperature is recorded at every step (trilinear interpolation).
    progress : bool
        Show a tqdm progress bar.
    solver : {'auto', 'direct', 'amg'}
    lumped_mass : bool
        Lumped (row-sum) heat capacity; default consistent. Ignored when ``assembly`` is given.
    initial_C : float or ndarray (n_nodes,), optional [°C]
        Start field (default ``ambient_C``: power-on from ambient).
    power_scale : callable, optional
        ``s(t [s]) -> [-]`` multiplying the volumetric power (default 1: power on at t = 0).
    assembly : Assembly, optional
    rtol : float [-]
        Relative residual of the per-step CG solves (AMG path), default 1e-6
        (relative to the step's right-hand side, i.e. to the temperature
        increment): the algebraic error stays far below the time-discretisation
        error and the energy balance still closes to ~1e-7.

    Returns
    -------
    TransientResult
    """
    steps = _step_sizes(t_end, dt)
    t_end = float(steps.sum())
    try:
        theta = float(theta)
    except (TypeError, ValueError):
        raise InputError(f"theta must be a number in [0.5, 1], got {theta!r}") from None
    if not 0.5 <= theta <= 1.0:
        raise InputError(f"theta must be in [0.5, 1] (1 backward Euler, 0.5 Crank–Nicolson), got {theta}")
    if power_scale is not None and not callable(power_scale):
        raise InputError("power_scale must be a callable s(t [s]) -> [-]")
    sv = np.sort(np.atleast_1d(np.asarray([] if save_times is None else save_times, dtype=float)))
    if sv.size and (not np.all(np.isfinite(sv)) or sv[0] < 0 or sv[-1] > t_end * (1 + 1e-12)):
        raise InputError(f"save_times must lie in [0, t_end = {t_end}] s, got {sv.tolist()}")
    t0 = time.perf_counter()
    asm = assembly if assembly is not None else assemble(problem, lumped_mass=lumped_mass)
    assembly_s = time.perf_counter() - t0 if assembly is None else 0.0
    t1 = time.perf_counter()
    names, P = _probes(problem.grid, probes)
    n = asm.n
    pat = asm.pattern
    dnodes, g0 = asm.dirichlet_values(0.0)
    D = _Dirichlet(asm, dnodes)
    free = ~D.mask
    method = _choose(solver, int(free.sum()))
    lin = _LinSolver(method, rtol=_check_rtol(rtol))
    L_data = asm.K_data + asm.H_data
    L = pat.csr(L_data)
    Fq, Fbc = asm.F_q, asm.F_bc
    sumFq = float(Fq.sum())
    flux_in = asm.flux_in_W
    scale = (lambda t: 1.0) if power_scale is None else (lambda t: float(power_scale(t)))
    nonlinear = bool(asm.nonlinear)
    cap = np.asarray(asm.pattern.csr(asm.M_data).sum(axis=1)).ravel()   # 1^T M (symmetric)

    T = _initial_field(problem, initial_C, n)
    T[dnodes] = g0
    T_start = T.copy()
    times = np.concatenate([[0.0], np.cumsum(steps)])
    times[-1] = t_end
    probe_hist = np.empty((len(times), len(names)))
    probe_hist[0] = P @ T
    saved_C = np.empty((sv.size, n))
    si = 0
    while si < sv.size and sv[si] <= 0.0:
        saved_C[si] = T
        si += 1

    cache = {}   # step size -> (A_full, A_elim) for linear problems

    def matrices(h, J):
        key = float(h)
        if not nonlinear and key in cache:
            return cache[key]
        full = asm.M_data / h + theta * L_data
        if nonlinear:
            full = full.copy()
            full[pat.diag_pos] += theta * J
        A_full = pat.csr(full)
        A = pat.csr(D.eliminate(full)) if len(dnodes) else A_full
        if not nonlinear:
            if len(cache) >= 4:
                cache.pop(next(iter(cache)))
            cache[key] = (A_full, A)
        return A_full, A

    E_in = E_out = 0.0
    its_total = 0
    res_max = 0.0
    h_pc = None
    dT_prev = h_prev = None
    iterator = range(len(steps))
    if progress:
        from tqdm import tqdm

        iterator = tqdm(iterator, desc="transient", unit="step")
    for s_i in iterator:
        h = float(steps[s_i])
        ta, tb = times[s_i], times[s_i + 1]
        if nonlinear:
            N0, J0 = asm.nonlinear_flux(T)
            J0 = np.where(D.mask, 0.0, J0)
        else:
            N0, J0 = 0.0, None
        A_full, A = matrices(h, J0)
        if h_pc is not None and method == "amg" and not (0.5 <= h / h_pc <= 2.0):
            lin.prepare(A)
            h_pc = h
        if h_pc is None:
            h_pc = h
        sa, sb = scale(ta), scale(tb)
        rhs = (theta * sb + (1 - theta) * sa) * Fq + Fbc - L @ T - N0
        if len(dnodes):
            _, gb = asm.dirichlet_values(tb)
            dd = gb - T[dnodes]
            b = rhs.copy()
            if np.any(dd != 0):
                dfull = np.zeros(n)
                dfull[dnodes] = dd
                b -= A_full @ dfull
            b[dnodes] = dd
        else:
            b = rhs
        x0 = None
        if dT_prev is not None and method == "amg":
            x0 = dT_prev * (h / h_prev)      # the last increment, rescaled: a cheap predictor
            if len(dnodes):
                x0[dnodes] = dd
        dT, its, rel = lin.solve(A, b, x0=x0)
        dT_prev, h_prev = dT, h
        its_total += its
        res_max = max(res_max, rel)
        if len(dnodes):
            dT[dnodes] = dd
        # energy bookkeeping (θ-consistent)
        E_in += h * ((theta * sb + (1 - theta) * sa) * sumFq + flux_in)
        q_out = 0.0
        for bc in asm.linear:
            ma = T[bc.corners].mean(axis=1)
            mb = ma + dT[bc.corners].mean(axis=1)
            q_out += float(np.dot(bc.hA, theta * mb + (1 - theta) * ma - bc.T_ref))
        if nonlinear:
            q_out += float(np.sum(N0 + theta * J0 * dT))
        if len(dnodes):
            q_out += float(np.sum((rhs - A_full @ dT)[dnodes]))
        E_out += h * q_out
        T_prev = T
        T = T + dT
        while si < sv.size and sv[si] <= tb * (1 + 1e-12):
            w = (sv[si] - ta) / h
            saved_C[si] = T_prev + min(max(w, 0.0), 1.0) * dT
            si += 1
        probe_hist[s_i + 1] = P @ T
    E_stored = float(cap @ (T - T_start))
    denom = max(abs(E_in), abs(E_stored) + abs(E_out), 1e-300)
    ebal = abs(E_in - E_stored - E_out) / denom
    for arr in (T, T_start, probe_hist, saved_C, times):
        arr.setflags(write=False)
    return TransientResult(problem=problem, times=times, T_C=T, T0_C=T_start, probe_names=names,
                           probe_C=probe_hist, saved_times=sv, saved_C=saved_C, iterations=its_total,
                           residual=res_max, energy_balance_rel_error=float(ebal), energy_in_J=E_in,
                           energy_stored_J=E_stored, energy_out_J=E_out, unknowns=int(free.sum()),
                           steps=len(steps), theta=theta, assembly_s=assembly_s,
                           solve_s=time.perf_counter() - t1, solver=method, lagged_nonlinear=nonlinear)
