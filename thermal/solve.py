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

from imutherm import ConvergenceError, InputError  # noqa: F401  (ConvergenceError re-exported)
from imutherm.thermal.assembly import Assembly, assemble
from imutherm.thermal.guards import MAX_STEPS, check_step
from imutherm.thermal.problem import ThermalProblem

#: Below this many unknowns ``solver='auto'`` factorises (SuperLU), above it uses AMG-CG.
DIRECT_LIMIT = 20_000
#: Relative residual of the CG solve of a linear steady problem (one solve).
CG_RTOL = 1e-10
#: Relative residual of the CG solve of each Newton step (inexact Newton: the
#: right-hand side is the current residual, so the outer loop tightens it).
NEWTON_CG_RTOL = 1e-4
#: Relative residual of the per-step CG solves of a transient (relative to the step's right-hand side, i.e.
#: to the temperature increment). 1e-5 would save ~15 % of the iterations at the same t95, but the energy
#: balance with a time-dependent fixed temperature then degrades 100x (7e-7 -> 9e-5).
TRANSIENT_CG_RTOL = 1e-6


# --------------------------------------------------------------------------- results

#: result fields renamed by issue 13: the old name -> what to read instead
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

def _private_vcycle(ml):
    """pyamg's own V-cycle ``(x, b) -> None`` (x updated in place), or None where this pyamg lacks it.

    The one use of a pyamg private: ``MultilevelSolver.__solve(lvl, x, b, cycle, cycles)``
    (name-mangled ``_MultilevelSolver__solve``, pyamg 4-5). It is what ``solve`` and
    ``aspreconditioner`` call inside; called directly it saves their two residual evaluations
    per application. :func:`amg_preconditioner` falls back to the public route without it.
    """
    cycle = getattr(ml, "_MultilevelSolver__solve", None)
    if cycle is None:
        return None

    def vcycle(x, b):
        cycle(0, x, b, "V", 1)

    return vcycle


def amg_preconditioner(A) -> spla.LinearOperator:
    """One smoothed-aggregation V-cycle (pyamg) as an SPD preconditioner for CG.

    Prolongation smoothing uses the local (Gershgorin) spectral-radius
    estimate: the default Arnoldi estimate costs ~10x more setup time and can
    break down (NaN) on the consistent-mass transient matrices, whose
    off-diagonals are partly positive. The hierarchy is built and cycled in
    single precision (the V-cycle is memory-bound: ~35 % faster, the same CG
    iteration count; CG itself and its residuals stay in double precision, so
    the accuracy of the solve is unchanged). The V-cycle is called directly
    (:func:`_private_vcycle`; pyamg's ``aspreconditioner`` adds two residual
    evaluations per application); the public ``aspreconditioner`` of a double-precision
    hierarchy is the fallback (one-level problems, or a pyamg without the private cycle).
    """
    import pyamg

    def build(dtype):
        return pyamg.smoothed_aggregation_solver(A.astype(dtype), symmetry="hermitian", max_coarse=500,
                                                 smooth=("jacobi", {"omega": 4.0 / 3.0, "weighting": "local"}))

    ml = build(np.float32)
    for lvl in ml.levels:   # pyamg keeps the coarse levels as BSR with 1x1 blocks: its BSR Gauss-Seidel is
        for name in ("A", "P", "R"):   # ~25x slower than the CSR one there (V-cycle ~20 % faster, same iterates)
            M = getattr(lvl, name, None)
            if sp.issparse(M) and M.format == "bsr" and M.blocksize == (1, 1):
                setattr(lvl, name, M.tocsr())
    vcycle = _private_vcycle(ml)
    if vcycle is None or len(ml.levels) < 2:  # small problem (one level: a dense solve) or another pyamg
        return build(np.float64).aspreconditioner(cycle="V")

    def matvec(b):
        b = np.ravel(np.asarray(b, dtype=np.float32))
        x = np.zeros_like(b)
        vcycle(x, b)
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

    def _cg(self, A, b, x0, rtol=None):
        its = [0]

        def cb(_):
            its[0] += 1

        # preconditioned by the factorisation of a nearby matrix, CG needs only a few iterations:
        # the direct path always solves tightly
        rtol = self.rtol if rtol is None else rtol
        rtol = min(rtol, CG_RTOL) if self.method == "direct" else rtol
        x, info = spla.cg(A, b, x0=x0, rtol=rtol, atol=0.0, maxiter=self.maxiter, M=self.pc, callback=cb)
        return x, info, its[0]

    def solve(self, A, b, x0=None, rtol=None):
        """Return (x, iterations, relative residual).

        ``rtol`` overrides the solver's tolerance for this solve only (e.g. a loose
        error-estimate solve); such solves do not set the iteration baseline that
        triggers a preconditioner rebuild.
        """
        if rtol is not None:
            return self._solve_loose(A, b, rtol)
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

    def _solve_loose(self, A, b, rtol):
        bn = np.linalg.norm(b)
        if bn == 0.0:
            return np.zeros_like(b), 0, 0.0
        if self.pc is None:
            self.prepare(A)
        if self.method == "direct" and A is self.A_pc:
            x, its = self.lu.solve(b), 1
        else:
            x, info, its = self._cg(A, b, None, rtol=rtol)
            if info != 0:
                raise ConvergenceError(f"linear solve (error estimate) did not reach rtol={rtol:g} "
                                       f"in {self.maxiter} iterations (info={info})")
        return x, its, float(np.linalg.norm(b - A @ x) / bn)


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
    T = _initial_field(problem, initial_C, n)
    T[dnodes] = dvals

    def residual(T):
        N, J = asm.nonlinear_flux(T) if nonlinear else (0.0, None)
        r = L @ T + N - F
        r[dnodes] = 0.0
        return r, N, J

    T, it, lin_its = _newton(problem, asm, D, L, lin, residual, T, tol, max_iter)
    r, N, _ = residual(T)
    LT = L @ T
    scale = np.linalg.norm(F[free]) + np.linalg.norm(np.asarray(N + 0 * T)[free]) + np.linalg.norm(LT[free])
    res = float(np.linalg.norm(r[free]) / scale) if scale > 0 else 0.0
    P_in, heat_bnd, ebal = _steady_balance(asm, T, dnodes, F, LT, N)
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
    :class:`ConvergenceError` when ``max_iter`` iterations do not bring max|ΔT| below
    ``tol * max(1 K, max|T − ambient|)``, or when an iterate diverges.
    """
    nonlinear = bool(asm.nonlinear)
    free = ~D.mask
    amb = problem.ambient_C
    base = D.eliminate(L.data)
    r, N, J = residual(T)
    A = asm.pattern.csr(base)
    lin_its = 0
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
        T, r, N, J = T_new, r_new, N_new, J_new
        _check_diverging(problem, T, amb, it)
        change = step * np.abs(dT).max()
        if change <= tol * max(1.0, float(np.abs(T - amb).max())):
            return T, it, lin_its
    raise ConvergenceError(f"solve_steady: Newton did not converge in {max_iter} iterations "
                           f"(last max|ΔT| = {change:.3g} K, residual norm {np.linalg.norm(r):.3g} W); "
                           f"raise max_iter or check the boundary laws")


def _steady_balance(asm: Assembly, T, dnodes, F, LT, N):
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


# TR-BDF2 as an ESDIRK (Bank et al. 1985; Hosea & Shampine 1996, Appl. Numer. Math. 20, 21-37):
# stage 1 trapezoidal rule to t + γh, stage 2 BDF2 to t + h, both with the matrix M + d h L.
TRBDF2_GAMMA = 2.0 - math.sqrt(2.0)
_D = TRBDF2_GAMMA / 2                      # diagonal coefficient d = γ/2 = 1 − √2/2
_W = math.sqrt(2.0) / 4                    # weights b = (w, w, d), w = (1 − d)/2 = √2/4
#: b − b̂ with b̂ = ((1 − w)/3, (3w + 1)/3, d/3) the embedded third-order weights (Hosea & Shampine 1996)
_E = ((4 * _W - 1) / 3, -1.0 / 3, 2 * _D / 3)
#: default local error tolerance of the adaptive TR-BDF2 run [K] (max over nodes per step); see solve_transient
DEFAULT_TOL_K = 0.01
#: default first step of an adaptive run [s]; the controller shrinks it if the power-on jump needs it. The
#: chip dies' power-on jump limits the first steps to ~0.07 s at 0.01 K on the reference unit: a 0.25 s start
#: was rejected 4-5 times (15 wasted solves), 0.05 s is accepted and then grows 2x per step.
DEFAULT_DT_FIRST = 0.05
#: default largest step of an adaptive run [s]
DEFAULT_DT_MAX = 300.0
#: relative CG residual of the error-estimate solve: the estimate only sizes the next step, through a cube
#: root, so 10 % is ample (reference unit: the same steps and t95 as 1e-2, a third fewer iterations)
ESTIMATE_CG_RTOL = 1e-1
#: settle stop: every probe within this fraction of its final rise (and past its t95)
SETTLE_FRACTION = 0.005
#: step-size controller: safety factor, largest growth and largest cut per step
_SAFETY, _GROW_MAX, _CUT_MIN = 0.9, 2.0, 0.2
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


def solve_transient(problem: ThermalProblem, t_end: float, dt=None, *, scheme: str = "theta", theta: float = 1.0,
                    tol_K: float | None = None, error_control: str = "nodes", dt_first: float | None = None, dt_max: float | None = None,
                    settle_C=None, settle_fraction: float = SETTLE_FRACTION, save_times=None,
                    probes=None, progress: bool = False, solver: str = "auto", lumped_mass: bool = False,
                    initial_C=None, power_scale=None, assembly: Assembly | None = None,
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
        Default ``'theta'`` (this low-level function keeps its historical default;
        :func:`imutherm.studies.thermal_study.run_scheme` and the CLI default to
        adaptive TR-BDF2).
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
    power_scale : callable, optional
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
        try:
            t_end = float(t_end)
        except (TypeError, ValueError):
            raise InputError(f"t_end must be a number [s], got {t_end!r}") from None
        if not (math.isfinite(t_end) and t_end > 0):
            raise InputError(f"t_end must be > 0 [s], got {t_end!r}")
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
    if power_scale is not None and not callable(power_scale):
        raise InputError("power_scale must be a callable s(t [s]) -> [-]")
    sv = np.sort(np.atleast_1d(np.asarray([] if save_times is None else save_times, dtype=float)))
    if sv.size and (not np.all(np.isfinite(sv)) or sv[0] < 0 or sv[-1] > t_end * (1 + 1e-12)):
        raise InputError(f"save_times must lie in [0, t_end = {t_end}] s, got {sv.tolist()}")
    names, P = _probes(problem.grid, probes)
    settle = _settle_targets(settle_C, names)
    if adaptive and error_control == "probes" and not names:
        raise InputError("error_control='probes' needs probes")
    t0 = time.perf_counter()
    asm = assembly if assembly is not None else assemble(problem, lumped_mass=lumped_mass)
    assembly_s = time.perf_counter() - t0 if assembly is None else 0.0
    t1 = time.perf_counter()
    ctx = _Ctx.start(problem, asm, P, solver, _check_rtol(rtol), initial_C, power_scale, t_end)
    if scheme == "theta":
        stepper = _theta_steps(ctx, steps, theta)
    else:
        stepper = _trbdf2_steps(ctx, steps, tol_K, dt_first, dt_max, error_control)
    history = _ProbeHistory(P, ctx.T0)
    saved = _SavedFields(sv, ctx.T0)
    energy = _EnergyAccount(asm)
    watch = _SettleWatch(settle, float(settle_fraction), history) if settle is not None else None
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


# The transient is a step generator (one per scheme: :func:`_theta_steps`, :func:`_trbdf2_steps`) whose
# accepted steps (:class:`_Step`) are handed to observers (probe history, saved fields, energy account,
# settle stop), as scikit-fem's example 19 does; the schemes share the set-up (:class:`_Ctx`), the step
# matrix with its cache and preconditioner policy (:class:`_StepMatrix`), the linearisation of the
# nonlinear laws and the elimination of the fixed nodes.

@dataclass
class _Ctx:
    """What both schemes share (set up once by :func:`solve_transient`), and the solve counters."""

    asm: Assembly
    P: sp.csr_matrix
    D: _Dirichlet
    dnodes: np.ndarray
    free: np.ndarray
    method: str
    lin: _LinSolver
    T0: np.ndarray
    scale: object
    t_end: float
    L_data: np.ndarray
    L: sp.csr_matrix
    its: int = 0          # linear iterations, all solves
    solves: int = 0       # linear solves, rejected steps and error estimates included
    rejected: int = 0     # adaptive steps redone with a smaller step
    res_max: float = 0.0  # largest relative linear residual of the accepted steps

    @classmethod
    def start(cls, problem, asm, P, solver, rtol, initial_C, power_scale, t_end):
        dnodes, g0 = asm.dirichlet_values(0.0)
        D = _Dirichlet(asm, dnodes)
        free = ~D.mask
        method = _choose(solver, int(free.sum()))
        T = _initial_field(problem, initial_C, asm.n)
        T[dnodes] = g0
        L_data = asm.K_data + asm.H_data
        return cls(asm=asm, P=P, D=D, dnodes=dnodes, free=free, method=method, lin=_LinSolver(method, rtol=rtol), T0=T,
                   scale=(lambda t: 1.0) if power_scale is None else (lambda t: float(power_scale(t))),
                   t_end=t_end, L_data=L_data, L=asm.pattern.csr(L_data))

    @property
    def nonlinear(self) -> bool:
        return bool(self.asm.nonlinear)

    @property
    def power_W(self) -> float:
        """Total power at full scale [W] (volumetric plus boundary heat flux)."""
        return float(self.asm.F_q.sum()) + self.asm.flux_in_W

    def linearise(self, T):
        """``(N(T), N'(T))`` of the nonlinear laws (Jacobian zero on fixed nodes); ``(0.0, None)`` if none."""
        if not self.nonlinear:
            return 0.0, None
        N0, J0 = self.asm.nonlinear_flux(T)
        return N0, np.where(self.D.mask, 0.0, J0)

    def fixed_increment(self, t, T):
        """Increment of the fixed-node temperatures from ``T`` to their values at ``t`` [K] (None: no fixed nodes)."""
        return self.asm.dirichlet_values(t)[1] - T[self.dnodes] if len(self.dnodes) else None

    def eliminated_rhs(self, A_full, rhs, dd, x0=None):
        """Right-hand side (and predictor) of the eliminated system for increments ``dd`` on the fixed nodes."""
        if not len(self.dnodes):
            return rhs, x0
        b = rhs.copy()
        if np.any(dd != 0):
            dfull = np.zeros(len(rhs))
            dfull[self.dnodes] = dd
            b -= A_full @ dfull
        b[self.dnodes] = dd
        if x0 is not None:
            x0 = x0.copy()
            x0[self.dnodes] = dd
        return b, x0


class _StepMatrix:
    """A scheme's step matrix ``form(h) + jac(h) diag(J)`` for step size ``h`` (J: the Jacobian of the
    nonlinear laws), full and with the fixed nodes eliminated.

    Linear problems keep the last four step sizes' matrices. The preconditioner (AMG) is rebuilt when the
    step leaves [0.5, 2] x the step it was built for; otherwise the linear solver reuses it, rebuilding
    only when CG slows down (:class:`_LinSolver`).
    """

    def __init__(self, ctx: _Ctx, form, jac):
        self.ctx, self.form, self.jac = ctx, form, jac
        self.cache = {}
        self.h_pc = None

    def __call__(self, h: float, J):
        ctx = self.ctx
        key = float(h)
        if not ctx.nonlinear and key in self.cache:
            A_full, A = self.cache[key]
        else:
            pat = ctx.asm.pattern
            full = self.form(h)
            if ctx.nonlinear:
                full[pat.diag_pos] += self.jac(h) * J
            A_full = pat.csr(full)
            A = pat.csr(ctx.D.eliminate(full)) if len(ctx.dnodes) else A_full
            if not ctx.nonlinear:
                if len(self.cache) >= 4:
                    self.cache.pop(next(iter(self.cache)))
                self.cache[key] = (A_full, A)
        if self.h_pc is None:
            self.h_pc = h
        elif ctx.method == "amg" and not (0.5 <= h / self.h_pc <= 2.0):
            ctx.lin.prepare(A)
            self.h_pc = h
        return A_full, A


@dataclass(frozen=True)
class _Step:
    """One accepted step as the observers see it."""

    k: int                 # steps accepted so far, this one included
    ta: float              # [s]
    tb: float              # [s]
    h: float               # [s] the step size the scheme integrated with
    T_prev: np.ndarray     # [°C] field at ta
    T: np.ndarray          # [°C] field at tb
    power_scale: float     # [-] the scheme's weighted mean of the power scale s(t) over the step
    heat_out_W: float      # [W] the scheme's weighted mean heat leaving through the boundary laws
    #                        (θ-scheme: and through the fixed nodes)
    fixed_in_J: float | None = None   # [J] heat entering through the fixed nodes (TR-BDF2)


def _linear_heat_out(asm, T) -> float:
    """Heat leaving through the linear laws [W] (consistent face integral: mean of the face-cell corners)."""
    return sum(float(np.dot(bc.hA, T[bc.corners].mean(axis=1) - bc.T_ref)) for bc in asm.linear)


def _theta_steps(ctx: _Ctx, steps, theta):
    """θ-scheme steps in increment form, one solve each; see :func:`solve_transient`."""
    asm, lin, dnodes, L = ctx.asm, ctx.lin, ctx.dnodes, ctx.L
    Fq, Fbc = asm.F_q, asm.F_bc
    matrix = _StepMatrix(ctx, lambda h: asm.M_data / h + theta * ctx.L_data, lambda h: theta)
    times = np.concatenate([[0.0], np.cumsum(steps)])
    times[-1] = ctx.t_end
    T = ctx.T0.copy()
    dT_prev = h_prev = None
    for s_i in range(len(steps)):
        h = float(steps[s_i])
        ta, tb = times[s_i], times[s_i + 1]
        N0, J0 = ctx.linearise(T)
        A_full, A = matrix(h, J0)
        sa, sb = ctx.scale(ta), ctx.scale(tb)
        rhs = (theta * sb + (1 - theta) * sa) * Fq + Fbc - L @ T - N0
        dd = ctx.fixed_increment(tb, T)
        x0 = None
        if dT_prev is not None and ctx.method == "amg":
            x0 = dT_prev * (h / h_prev)      # the last increment, rescaled: a cheap predictor
        b, x0 = ctx.eliminated_rhs(A_full, rhs, dd, x0)
        dT, its, rel = lin.solve(A, b, x0=x0)
        dT_prev, h_prev = dT, h
        ctx.its += its
        ctx.solves += 1
        ctx.res_max = max(ctx.res_max, rel)
        if len(dnodes):
            dT[dnodes] = dd
        # heat leaving, θ-weighted on the fluxes the step used (fixed nodes: the residual of their rows)
        q_out = theta * _linear_heat_out(asm, T + dT) + (1 - theta) * _linear_heat_out(asm, T)
        if ctx.nonlinear:
            q_out += float(np.sum(N0 + theta * J0 * dT))
        if len(dnodes):
            q_out += float(np.sum((rhs - A_full @ dT)[dnodes]))
        T_prev, T = T, T + dT
        yield _Step(s_i + 1, ta, tb, h, T_prev, T, theta * sb + (1 - theta) * sa, q_out)


def _trbdf2_steps(ctx: _Ctx, steps, tol_K, dt_first, dt_max, control):
    """TR-BDF2 steps (fixed ``steps``, or adaptive when ``steps`` is None); see :func:`solve_transient`."""
    asm, lin, dnodes, free, L = ctx.asm, ctx.lin, ctx.dnodes, ctx.free, ctx.L
    M = asm.pattern.csr(asm.M_data)
    Fq, Fbc = asm.F_q, asm.F_bc
    adaptive = steps is None
    g_, d_, w_ = TRBDF2_GAMMA, _D, _W
    matrix = _StepMatrix(ctx, lambda h: asm.M_data + (d_ * h) * ctx.L_data, lambda h: d_ * h)
    T = ctx.T0.copy()
    t_end = ctx.t_end
    X2_prev = h_prev = None
    t = 0.0
    k = 0
    h = dt_first if adaptive else None
    while t < t_end * (1 - 1e-12) and (adaptive or k < len(steps)):
        if adaptive:
            h = min(h, dt_max)
            if t + h > t_end * (1 - 1e-9) or t_end - (t + h) < 0.05 * h:
                h = t_end - t                      # land on t_end without leaving a sliver
        else:
            h = float(steps[k])
        ta, tg, tb = t, t + g_ * h, (t + h if adaptive or k < len(steps) - 1 else t_end)
        h = tb - ta
        N0, J0 = ctx.linearise(T)
        A_full, A = matrix(h, J0)
        sa, sg, sb = ctx.scale(ta), ctx.scale(tg), ctx.scale(tb)
        LT = L @ T
        fn = sa * Fq + Fbc - LT - N0
        # stage 1: trapezoidal rule over [t, t + γh]
        rhs1 = (d_ * h) * (2 * fn + (sg - sa) * Fq)
        x0 = X2_prev * (g_ * h / h_prev) if X2_prev is not None and ctx.method == "amg" else None
        dd1 = ctx.fixed_increment(tg, T)
        b, x0 = ctx.eliminated_rhs(A_full, rhs1, dd1, x0)
        X1, its, rel = lin.solve(A, b, x0=x0)
        ctx.its += its
        res1 = rel
        if len(dnodes):
            X1[dnodes] = dd1
        Tg = T + X1
        Ng = asm.nonlinear_flux(Tg)[0] if ctx.nonlinear else 0.0
        fg = sg * Fq + Fbc - L @ Tg - Ng
        # stage 2: BDF2 from t, t + γh to t + h; f(t+h) ≈ g − L T1 − Ng − J0 (T1 − Tg)
        c2 = sb * Fq + Fbc - LT - Ng
        if ctx.nonlinear:
            c2 = c2 + J0 * X1
        rhs2 = h * (w_ * fn + w_ * fg + d_ * c2)
        dd2 = ctx.fixed_increment(tb, T)
        b, x0 = ctx.eliminated_rhs(A_full, rhs2, dd2, X1 / g_ if ctx.method == "amg" else None)
        X2, its, rel = lin.solve(A, b, x0=x0)
        ctx.its += its
        ctx.solves += 2
        if len(dnodes):
            X2[dnodes] = dd2
        T1 = T + X2
        f1 = c2 - (L @ X2)
        if ctx.nonlinear:
            f1 -= J0 * X2
        ratio = 0.0
        if adaptive:
            r_e = h * (_E[0] * fn + _E[1] * fg + _E[2] * f1)
            if len(dnodes):
                r_e[dnodes] = 0.0
            est, its, _ = lin.solve(A, r_e, rtol=ESTIMATE_CG_RTOL)
            ctx.its += its
            ctx.solves += 1
            e_c = ctx.P @ est if control == "probes" else est[free]
            err = float(np.abs(e_c).max()) if e_c.size else 0.0
            ratio = err / tol_K
            if ratio > 1.0 and h > 1e-9 * t_end:
                ctx.rejected += 1
                h *= max(_CUT_MIN, _SAFETY * ratio ** (-1.0 / 3.0))
                continue
        ctx.res_max = max(ctx.res_max, res1, rel)
        # heat leaving, with the scheme's weights b = (w, w, d) on the fluxes it used
        q_n = _linear_heat_out(asm, T)
        q_g = _linear_heat_out(asm, Tg)
        q_1 = _linear_heat_out(asm, T1)
        if ctx.nonlinear:
            q_n += float(np.sum(N0))
            q_g += float(np.sum(Ng))
            q_1 += float(np.sum(Ng + J0 * (X2 - X1)))
        fixed_in = None
        if len(dnodes):   # heat entering through the fixed nodes: the residual of their rows
            fixed_in = float((M @ X2 - h * (w_ * fn + w_ * fg + d_ * f1))[dnodes].sum())
        X2_prev, h_prev = X2, h
        T_prev, T = T, T1
        t = tb
        k += 1
        yield _Step(k, ta, tb, h, T_prev, T, w_ * sa + w_ * sg + d_ * sb, w_ * q_n + w_ * q_g + d_ * q_1, fixed_in)
        if adaptive:
            grow = _GROW_MAX if ratio == 0 else min(_GROW_MAX, max(_CUT_MIN, _SAFETY * ratio ** (-1.0 / 3.0)))
            h *= grow


def _run(ctx: _Ctx, stepper, observers, watch, max_steps, progress):
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


class _ProbeHistory:
    """Observer: the step times and the probe temperatures at each."""

    def __init__(self, P, T0):
        self.P = P
        self.times = [0.0]
        self.probes = [P @ T0]

    def observe(self, st: _Step):
        self.times.append(st.tb)
        self.probes.append(self.P @ st.T)

    def arrays(self):
        times = np.array(self.times)
        return times, np.array(self.probes).reshape(len(times), -1)


class _SavedFields:
    """Observer: whole fields at the requested times (linear in time within a step)."""

    def __init__(self, sv, T0):
        self.sv = sv
        self.saved = []
        while len(self.saved) < sv.size and sv[len(self.saved)] <= 0.0:
            self.saved.append(T0.copy())

    def observe(self, st: _Step):
        sv, ta, tb = self.sv, st.ta, st.tb
        while len(self.saved) < sv.size and sv[len(self.saved)] <= tb * (1 + 1e-12):
            w = min(max((sv[len(self.saved)] - ta) / (tb - ta), 0.0), 1.0)
            self.saved.append(st.T_prev + w * (st.T - st.T_prev))

    def array(self, n_nodes):
        return np.array(self.saved).reshape(len(self.saved), n_nodes)


class _EnergyAccount:
    """Observer: energy put in and let out [J], each integrated with the scheme's own weights."""

    def __init__(self, asm: Assembly):
        self.asm = asm
        self.sumFq, self.flux_in = float(asm.F_q.sum()), asm.flux_in_W
        self.E_in = self.E_out = 0.0

    def observe(self, st: _Step):
        self.E_in += st.h * (st.power_scale * self.sumFq + self.flux_in)
        self.E_out += st.h * st.heat_out_W
        if st.fixed_in_J is not None:
            self.E_out -= st.fixed_in_J

    def close(self, T_start, T):
        """(energy stored [J], relative balance error [-]) from ``T_start`` to ``T``."""
        cap = np.asarray(self.asm.pattern.csr(self.asm.M_data).sum(axis=1)).ravel()   # 1^T M (symmetric)
        E_stored = float(cap @ (T - T_start))
        denom = max(abs(self.E_in), abs(E_stored) + abs(self.E_out), 1e-300)
        return E_stored, abs(self.E_in - E_stored - self.E_out) / denom


class _SettleWatch:
    """The settle stop: True once every probe has passed 95 % of its rise and is within ``fraction`` of it."""

    def __init__(self, final, fraction, history: _ProbeHistory):
        self.final, self.fraction, self.history = final, fraction, history
        self.p0 = history.probes[0]
        self.rise = final - self.p0
        self.passed95 = self.rise == 0

    def observe(self, st: _Step) -> bool:
        p = self.history.probes[-1]
        nz = self.rise != 0
        frac = np.ones_like(self.rise)
        frac[nz] = (p[nz] - self.p0[nz]) / self.rise[nz]
        self.passed95 |= frac >= 0.95
        gap = np.abs(self.final - p)
        return bool(np.all(self.passed95) and np.all(gap <= self.fraction * np.abs(self.rise)))
