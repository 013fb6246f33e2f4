"""The linear algebra both thermal solves share: solver choice, AMG, the CG wrapper, fixed nodes.

* :func:`amg_preconditioner`: one single-precision smoothed-aggregation V-cycle (pyamg) as the
  preconditioner of CG (``_private_vcycle``: the one use of a pyamg private, with its public fallback).
* ``LinSolver``: solves ``A x = b`` for a sequence of matrices near the one its preconditioner (LU or
  AMG) was built on, rebuilding it when CG slows down; ``choose_solver`` picks the method (sparse LU below
  ``DIRECT_LIMIT`` unknowns, else AMG-CG), ``check_rtol`` checks a tolerance.
* ``Dirichlet``: symmetric elimination of the fixed-temperature nodes on the shared CSR pattern.
* ``initial_field``: the start field of a Newton iteration or a transient.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from imutherm import ConvergenceError, InputError
from imutherm.thermal.assembly import Assembly
from imutherm.thermal.problem import ThermalProblem

#: Below this many unknowns ``solver='auto'`` factorises (SuperLU), above it uses AMG-CG.
DIRECT_LIMIT = 20_000
#: Relative residual of the CG solve of a linear steady problem (one solve).
CG_RTOL = 1e-10


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


#: strength-of-connection threshold of the AMG aggregation (pyamg's ``symmetric`` measure; its default is 0). At 0
#: every coupling is strong, so the 1e4 conductivity contrast of air against copper and the 40:1 cells of thin layers
#: aggregate across them and the coarse levels approximate those layers badly; 0.02 drops the weakest couplings
#: (air beside metal). Measured on the reference unit (air, default mesh, linear laws, CG to 1e-8, one BLAS thread,
#: benchmarks/bench_thermal_core.py --amg): 55 iterations at 66 ms (3.6 s) with theta 0 and symmetric Gauss-Seidel,
#: 41 at 36 ms (1.5 s) with 0.02 and one forward sweep before / one backward sweep after (still a symmetric
#: V-cycle, as CG needs); 0.01 and 0.03 within 10 %, 0.1 and 0.25 slower (coarse levels 2x denser)
AMG_STRENGTH_THETA = 0.02


#: pyamg's hierarchy stops coarsening at this many unknowns (its default 10; 500: a dense solve there is cheap)
AMG_MAX_COARSE = 500
#: pyamg's default cap on the levels of a hierarchy
AMG_MAX_LEVELS = 10
#: the options of pyamg's ``smoothed_aggregation_solver`` the preconditioner builds with (:func:`amg_preconditioner`)
AMG_OPTIONS = dict(symmetry="hermitian", smooth=("jacobi", {"omega": 4.0 / 3.0, "weighting": "local"}),
                   strength=("symmetric", {"theta": AMG_STRENGTH_THETA}),
                   presmoother=("gauss_seidel", {"sweep": "forward"}),
                   postsmoother=("gauss_seidel", {"sweep": "backward"}))


def _levels_on_csr(A, options: dict):
    """pyamg's smoothed-aggregation hierarchy of ``A`` (CSR), built one level at a time on CSR matrices.

    The same hierarchy as ``pyamg.smoothed_aggregation_solver(A, max_coarse=AMG_MAX_COARSE, **options)``, entry
    for entry: each call builds one level (``max_levels=2``) and hands its Galerkin matrix and near-nullspace
    candidates to the next, which improves no candidates (pyamg improves them on the finest level only). In one
    call pyamg keeps the coarse matrices as BSR with 1x1 blocks, and its Jacobi prolongation smoother takes their
    absolute value, which sums duplicates in a Python loop over the rows: 0.2-0.3 of the ~0.6 CPU-s of a
    hierarchy of the reference unit (2026-12-05), ~15 hierarchies in a study.
    """
    import pyamg
    from pyamg.multilevel import MultilevelSolver

    levels, Al, B = [], A, None
    while True:
        improve = {} if B is None else {"improve_candidates": None}
        one = pyamg.smoothed_aggregation_solver(Al, B=B, max_levels=2, max_coarse=AMG_MAX_COARSE, **options,
                                                **improve)
        levels.append(one.levels[0])
        if len(one.levels) == 1:
            break
        Al, B = one.levels[1].A.tocsr(), one.levels[1].B
        if Al.shape[0] <= AMG_MAX_COARSE or len(levels) + 1 == AMG_MAX_LEVELS:
            last = MultilevelSolver.Level()
            last.A, last.B = Al, B
            levels.append(last)
            break
    ml = MultilevelSolver(levels)
    pyamg.relaxation.smoothing.change_smoothers(ml, options["presmoother"], options["postsmoother"])
    return ml


def _bsr_to_csr(ml):
    """``ml`` with its 1x1-block BSR matrices as CSR, in place: pyamg's BSR Gauss-Seidel and products are ~25x
    slower than the CSR ones (V-cycle ~20 % faster, the same iterates to round-off)."""
    for lvl in ml.levels:
        for name in ("A", "P", "R"):
            M = getattr(lvl, name, None)
            if sp.issparse(M) and M.format == "bsr" and M.blocksize == (1, 1):
                setattr(lvl, name, M.tocsr())
    return ml


def single(A) -> sp.csr_matrix:
    """``A`` as a single-precision CSR matrix: a CSR matrix's values converted, its pattern's arrays shared (not
    copied: ``astype`` copies them, 20 MB on the reference unit's default mesh, kept with the hierarchy)."""
    if sp.isspmatrix_csr(A) or isinstance(A, sp.csr_array):
        if A.dtype == np.float32:
            return A
        return sp.csr_matrix((A.data.astype(np.float32), A.indices, A.indptr), shape=A.shape)
    return A.astype(np.float32).tocsr()


def amg_preconditioner(A) -> spla.LinearOperator:
    """One smoothed-aggregation V-cycle (pyamg) as an SPD preconditioner for CG.

    Prolongation smoothing uses the local (Gershgorin) spectral-radius
    estimate: the default Arnoldi estimate costs ~10x more setup time and can
    break down (NaN) on the consistent-mass transient matrices, whose
    off-diagonals are partly positive. Aggregation drops the couplings weaker than
    :data:`AMG_STRENGTH_THETA`; one Gauss-Seidel sweep forward before and one backward after each coarse
    correction (a symmetric V-cycle). The hierarchy is built and cycled in
    single precision (the V-cycle is memory-bound: ~35 % faster, the same CG
    iteration count; CG itself and its residuals stay in double precision, so
    the accuracy of the solve is unchanged). The V-cycle is called directly
    (:func:`_private_vcycle`; pyamg's ``aspreconditioner`` adds two residual
    evaluations per application); the public ``aspreconditioner`` of a double-precision
    hierarchy is the fallback (one-level problems, or a pyamg without the private cycle). The hierarchy is
    built a level at a time on CSR matrices (:func:`_levels_on_csr`: the same one, less setup time).
    """
    import pyamg

    def build(dtype):
        return pyamg.smoothed_aggregation_solver(A.astype(dtype), max_coarse=AMG_MAX_COARSE, **AMG_OPTIONS)

    ml = _bsr_to_csr(_levels_on_csr(single(A), AMG_OPTIONS))
    vcycle = _private_vcycle(ml)
    if vcycle is None or len(ml.levels) < 2:  # small problem (one level: a dense solve) or another pyamg
        return build(np.float64).aspreconditioner(cycle="V")

    def matvec(b):
        b = np.ravel(np.asarray(b, dtype=np.float32))
        x = np.zeros_like(b)
        vcycle(x, b)
        return x.astype(float)

    op = spla.LinearOperator(A.shape, matvec=matvec, dtype=float)
    op.hierarchy = ml   # for :func:`amg_like`
    return op


def amg_like(A, pc) -> spla.LinearOperator | None:
    """The V-cycle of :func:`amg_preconditioner` for a matrix ``A`` on the same grid as the one ``pc`` was built
    on, reusing ``pc``'s aggregates and prolongators: only the coarse matrices R A P are formed again (Galerkin)
    and the smoothers reset. None when ``pc`` carries no hierarchy (then build one). For A + s M from A's
    hierarchy (reference unit, air, default mesh, CG to 1e-4 of the power load, s = 10 / 3.3 / 0.5 / 0.1 / 0.02
    1/s): 35 / 22 / 24 / 33 / 58 iterations against 36 / 22 / 23 / 33 / 56 with a hierarchy built on A + M / 0.3 s,
    for a third of its setup time (0.40 s against 1.15 s at load 7)."""
    import pyamg
    from pyamg.multilevel import MultilevelSolver

    ml = getattr(pc, "hierarchy", None)
    if ml is None or len(ml.levels) < 2 or ml.levels[0].A.shape != A.shape:
        return None
    levels, Al = [], single(A)
    for lvl in ml.levels:
        new = MultilevelSolver.Level()
        new.A = Al
        if hasattr(lvl, "P"):
            new.P, new.R = lvl.P, lvl.R
            Al = (lvl.R @ Al @ lvl.P).tocsr()
        levels.append(new)
    out = MultilevelSolver(levels)
    pyamg.relaxation.smoothing.change_smoothers(out, AMG_OPTIONS["presmoother"], AMG_OPTIONS["postsmoother"])
    vcycle = _private_vcycle(out)
    if vcycle is None:
        return None

    def matvec(b):
        b = np.ravel(np.asarray(b, dtype=np.float32))
        x = np.zeros_like(b)
        vcycle(x, b)
        return x.astype(float)

    op = spla.LinearOperator(A.shape, matvec=matvec, dtype=float)
    op.hierarchy = out
    return op


class LinSolver:
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

    def solve(self, A, b, x0=None, rtol=None, pc_matrix=None):
        """Return (x, iterations, relative residual).

        ``rtol`` overrides the solver's tolerance for this solve only (e.g. a loose
        error-estimate solve); such solves do not set the iteration baseline that
        triggers a preconditioner rebuild. ``pc_matrix``: the sparse matrix the
        preconditioner is built from when ``A`` is an operator (a LinearOperator).
        """
        if rtol is not None:
            return self._solve_loose(A, b, rtol, pc_matrix)
        bn = np.linalg.norm(b)
        if bn == 0.0:
            return np.zeros_like(b), 0, 0.0
        P = A if pc_matrix is None else pc_matrix
        if self.pc is None:
            self.prepare(P)
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
            if self.method == "direct" and its > 10 and pc_matrix is None:
                slow = True
            if info != 0 or slow:
                self.prepare(P)
                if self.method == "direct" and pc_matrix is None:
                    x, its = self.lu.solve(b), its + 1
                else:
                    x, info, its2 = self._cg(A, b, x0)
                    its += its2
                    if info != 0:
                        raise ConvergenceError(f"preconditioned CG did not reach rtol={self.rtol:g} "
                                               f"in {self.maxiter} iterations (info={info})")
                    self.base_its = its2
            elif self.base_its is None:
                self.base_its = its
        rel = float(np.linalg.norm(b - A @ x) / bn)
        if not np.isfinite(rel) or rel > max(1e-6, 10 * self.rtol):
            raise ConvergenceError(f"linear solve failed: relative residual {rel:.3g}")
        return x, its, rel

    def _solve_loose(self, A, b, rtol, pc_matrix=None):
        bn = np.linalg.norm(b)
        if bn == 0.0:
            return np.zeros_like(b), 0, 0.0
        if self.pc is None:
            self.prepare(A if pc_matrix is None else pc_matrix)
        if self.method == "direct" and A is self.A_pc:
            x, its = self.lu.solve(b), 1
        else:
            x, info, its = self._cg(A, b, None, rtol=rtol)
            if info != 0:
                raise ConvergenceError(f"linear solve (error estimate) did not reach rtol={rtol:g} "
                                       f"in {self.maxiter} iterations (info={info})")
        return x, its, float(np.linalg.norm(b - A @ x) / bn)


def check_rtol(rtol) -> float:
    try:
        r = float(rtol)
    except (TypeError, ValueError):
        raise InputError(f"rtol must be a number in (0, 1e-2], got {rtol!r}") from None
    if not 0 < r <= 1e-2:
        raise InputError(f"rtol must be in (0, 1e-2], got {rtol!r}")
    return r


def choose_solver(solver: str, n_free: int) -> str:
    if solver not in ("auto", "direct", "amg"):
        raise InputError(f"solver must be 'auto', 'direct' or 'amg', got {solver!r}")
    if solver == "auto":
        return "direct" if n_free < DIRECT_LIMIT else "amg"
    return solver


class Dirichlet:
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


def initial_field(problem: ThermalProblem, initial_C, n: int) -> np.ndarray:
    if initial_C is None:
        return np.full(n, problem.ambient_C)
    T = np.array(initial_C, dtype=float)
    if T.ndim == 0:
        return np.full(n, float(T))
    if T.shape != (n,) or not np.all(np.isfinite(T)):
        raise InputError(f"initial_C must be a number or a finite array of shape ({n},) [°C], got {T.shape}")
    return T.copy()
