"""The power-on transient on a reduced model that checks itself against the full model.

The full adaptive TR-BDF2 transient of a unit costs ~75 preconditioned CG solves of the full model;
its steady field (solved anyway) and a handful of solves give a reduced model that reproduces it:

1. **Basis**: the steady rise x = T_ss - T_amb, the uniform field (so the projection conserves heat),
   and the block Krylov space of the secant operator A about the steady field
   (:func:`imutherm.thermal.reduced.linearised`; with ``cavity_law 's2s'`` its exchange secant is the
   low-rank term): A^-1 M x, (A^-1 M)^2 x, ... (moment matching at s = 0: what a step response needs),
   M-orthonormalised.
2. **Reduced transient**: the *nonlinear* model projected on the basis, M_r y' = V^T (F - L T - N(T)),
   T = T_amb + V y: the nonlinear laws (natural convection, radiation, the cavity exchange) are
   evaluated exactly on their own nodes, so the only error is the basis's. Integrated by an implicit
   stiff integrator (scipy BDF, exact reduced Jacobian) at tight tolerance; the steady field is in the
   basis and Galerkin-exact, so the reduced curves end on the full steady state.
3. **Check** (a posteriori, against the full model): at a few times t_k (spread over the transient, and
   each site's t95) the full nonlinear residual of the reduced solution, r = F - M T' - L T - N(T)
   (orthogonal to the basis), gives the error estimate e_k = (A + M / t_k)^-1 r_k (the error's modes
   answer a residual held since t = 0 by (1 - e^{-lambda t}) / lambda <= 1 / (lambda + 1 / t) up to a
   factor ~1.6). The curves are accepted when every site's estimated error is within ``tol_K`` and every
   t95's (error over the curve's slope there) within ``t95_rel``; otherwise the error fields join the basis
   and the reduced transient is run again (at most ``max_rounds`` times), and if it still fails the caller
   falls back to the full adaptive FEM. The estimate's effectivity against the true error is measured in
   ``tests/test_reduced_transient.py``. Each error solve starts from the Galerkin solution on the earlier error
   fields (:meth:`_Solver.warm_start`) and stops at the same residual relative to r_k as from zero. CG is
   scipy's step for step (:func:`pcg`) but takes a start's residual and returns its own, so neither a start's
   residual nor a warm-start field's product with A is formed again, and A + s M is formed in one reused buffer
   (:meth:`_Solver.shifted`).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.integrate import solve_ivp

from imutherm import InputError
from imutherm.thermal.metrics import T95_FRACTION, settle_time
from imutherm.thermal.reduced import linearised, secant_slopes, sparse_part
from imutherm.thermal.linear import amg_like, amg_preconditioner
from imutherm.workers import one_blas_thread
from imutherm.thermal.probes import probe_matrix
from imutherm.thermal.results import TransientResult
from imutherm.thermal.transient import SETTLE_FRACTION

#: site error the check accepts [K] (the study's accuracy target: every site curve within 0.05 K of the full adaptive FEM)
CHECK_TOL_K = 0.05
#: relative t95 error the check accepts [-] (the study's t95 target: 1 %)
CHECK_T95_REL = 0.01
#: Krylov vectors A^-1 M ... of the first basis. A basis shared across schemes was measured and not taken (reference
#: unit, default mesh, 2026-12-07): air and potted have the same mesh (193,550 nodes; grease 204,610), but potted's
#: reduced transient on air's 8 basis vectors (and its own steady field) took 3 rounds, 28 full solves and 275 CG
#: iterations where its own basis takes 1 round, 17 and 243 (air's on potted's: 30 and 276): the filled cavity
#: changes the slow modes
KRYLOV_ORDER = 3
#: time scales [s] of the shifted solves (A + M / tau)^-1 b that join the basis for the first seconds. 0.1 s joined
#: (0.3 s was the first) when the grease scheme's first basis failed its check at the earliest check time (0.22 s:
#: 0.052 K against 0.05 K) and took a second round of 9 more full solves; with it every scheme's first-round estimate
#: is lower at the default mesh (air 0.034 -> 0.030 K, grease 0.052 -> 0.025 K, potted 0.016 -> 0.009 K) for one
#: solve of ~25 CG iterations
EARLY_S = (0.1, 0.3, 2.0, 10.0, 50.0)
#: shift [1/s] of the second AMG hierarchy, sparse(A) + s M (the time scale 0.3 s), and
#: the shift from which a solve (A + s M) x = b uses it instead of A's own (its time scale 1 / s <= 10 s): where
#: the heat capacity term outweighs conduction in the boards and the air, A's hierarchy preconditions it poorly.
#: Measured on the reference unit (air scheme, default mesh, CG to 1e-4), iterations with A's hierarchy / with
#: this one: s = 0.1: 29 / 35, 0.5: 36 / 18, 1.5: 53 / 16, 3.3: 74 / 15, 4.6: 84 / 17, 10: 121 / 24 (setup ~0.4 s,
#: about 20 iterations). Again with the steady solve's hierarchy as A's and this one on its aggregates
#: (:func:`~imutherm.thermal.linear.amg_like`; from zero, the power load): s = 0.02: 31 / 58, 0.1: 42 / 33, 0.5:
#: 74 / 24, 3.3: 166 / 22, 10: 271 / 35; so from 0.1 (was 0.3): whole reduced transients air 271 -> 260, grease
#: 271 -> 260, potted 284 -> 269 iterations, the same solves and estimates within 0.002 K
SHIFTED_PC_S = 1.0 / 0.3
SHIFTED_PC_FROM = 0.1
#: relative CG tolerance of the basis solves and of the error-estimate solves. A basis vector only has to span
#: (the Galerkin projection picks the combination, the check measures the result): 1e-3 instead of 1e-4 took 11 %
#: fewer CG iterations on the reference unit (default mesh; air 305 -> 271, grease 315 -> 271, potted 316 -> 283),
#: the check's estimate no larger (air 0.029 -> 0.026 K, grease 0.031 -> 0.016 K, potted 0.0090 -> 0.0088 K) and
#: the curves within 0.02 K of the 1e-4 basis's; 1e-2 brought air's estimate to 0.045 K of the 0.05 K accepted
BASIS_RTOL = 1e-3
CHECK_RTOL = 1e-2
#: check times: this many spread geometrically over the transient (from its end / 3000), and the earliest and
#: latest t95. Fewer full check solves with a calibrated cheap indicator at the others was measured and not taken
#: (reference unit, default mesh, the 9-10 check times of each scheme): the ratio of the indicator to the check's
#: site estimate spread 0.05-1.10 for one V-cycle of the solve's preconditioner, 0.22-1.12 for 2 CG iterations,
#: 0.004-0.71 for a Jacobi step and 0.3 to over 40 for t |r| (unscaled); a bound from any of them needs a safety
#: factor of ~20, i.e. a full solve wherever the estimate exceeds ~2.5 mK (most check times). The late times'
#: solves cost 1-7 iterations with the Galerkin start (:meth:`_Solver.warm_start`)
CHECK_TIMES = 8
#: the reduced integrator's relative tolerance (its absolute one: this times the largest steady rise)
ODE_RTOL = 1e-7


@dataclass(frozen=True)
class ReducedCheck:
    """The reduced transient's check against the full model.

    accepted : bool, the curves passed (else the caller ran the full FEM)
    reason : str, why not (empty when accepted)
    basis_size : int, rounds : int (1: the first basis passed)
    full_solves : int, CG solves of the full model (basis and check); cg_iterations : int
    check_times_s : tuple [s]; site_error_K : (len(check_times), m) estimated site errors [K]
    max_site_error_K : float [K], max_t95_error_rel : float [-] (estimated)
    tol_K : float [K], t95_rel : float [-], cavity_law : str
    timings_s : dict, {"basis", "integrate", "check"} [s]
    """

    accepted: bool
    reason: str
    basis_size: int
    rounds: int
    full_solves: int
    cg_iterations: int
    check_times_s: tuple
    site_error_K: np.ndarray
    max_site_error_K: float
    max_t95_error_rel: float
    tol_K: float
    t95_rel: float
    timings_s: dict

    def summary(self) -> dict:
        """JSON-ready figures (the ``transient_check`` entry of ``result.json``)."""
        return {"accepted": self.accepted, "reason": self.reason, "basis_size": self.basis_size,
                "rounds": self.rounds, "full_solves": self.full_solves, "cg_iterations": self.cg_iterations,
                "check_times_s": [float(t) for t in self.check_times_s],
                "max_site_error_K": float(self.max_site_error_K), "max_t95_error_rel": float(self.max_t95_error_rel),
                "tol_K": self.tol_K, "t95_rel": self.t95_rel,
                "timings_s": {k: float(v) for k, v in self.timings_s.items()}}


class _Solver:
    """CG on the full model (counts solves): one AMG hierarchy of the secant operator's sparse part, and for
    the large shifts (A + s M, s >= :data:`SHIFTED_PC_FROM`) one of sparse(A) + :data:`SHIFTED_PC_S` M, built
    at its first use on the first one's aggregates (:func:`~imutherm.thermal.linear.amg_like`: its coarse
    matrices only, a third of a setup)."""

    def __init__(self, A, M=None, pc=None):
        self.A, self.M = A, M
        self.pc = pc if pc is not None else amg_preconditioner(sparse_part(A))
        self.pc_shifted = None
        self.solves = self.its = 0
        self.X = []                      # the recycled solutions (the check's error fields, kept by the caller anyway)
        self.XAX = np.zeros((0, 0))      # X^T A X and X^T M X [W/K], [J/K]: the Galerkin system of any shift
        self.XMX = np.zeros((0, 0))
        self._same_pattern = self._buffer = None   # :meth:`shifted`

    def _preconditioner(self, Op):
        s = getattr(Op, "s", 0.0)
        if self.M is None or s < SHIFTED_PC_FROM:
            return self.pc
        if self.pc_shifted is None:   # the unshifted hierarchy's aggregates, coarse matrices of A + s M (amg_like)
            S = _Shifted(self.A, self.M, SHIFTED_PC_S, np.float32).sparse   # single precision, as the V-cycle runs
            if S is None:
                S = (sparse_part(self.A) + SHIFTED_PC_S * self.M).tocsr()
            like = amg_like(S, self.pc)
            self.pc_shifted = like if like is not None else amg_preconditioner(S)
        return self.pc_shifted

    def _remember(self, x, Ox, s):
        """Add ``x`` to the warm starts' space given ``Ox`` = (A + s M) x (the solve's own b - r: no product with A),
        one product with M (their Gram rows kept, not them)."""
        Mx = self.M @ x if self.M is not None else x
        Ax = Ox - s * Mx if s else Ox
        k = len(self.X)
        XAX, XMX = np.zeros((k + 1, k + 1)), np.zeros((k + 1, k + 1))
        XAX[:k, :k], XMX[:k, :k] = self.XAX, self.XMX
        for G, y in ((XAX, Ax), (XMX, Mx)):
            row = np.array([float(v @ y) for v in self.X] + [float(x @ y)])
            G[k, :], G[:, k] = row, row
        self.X.append(x)
        self.XAX, self.XMX = XAX, XMX

    def warm_start(self, Op, b):
        """The Galerkin solution of ``Op x = b`` on the span of every earlier solution (Op = A + s M: its k x k
        system from the kept Gram matrices, k dot products with b), or None when there is none or it does not
        beat zero. Op's A-norm error is the least over that span, so it never starts worse than x = 0."""
        return self._warm_start(Op, b)[0]

    def _warm_start(self, Op, b):
        """(x0, b - Op x0) of :meth:`warm_start`, or (None, None)."""
        if not self.X:
            return None, None
        s = getattr(Op, "s", 0.0)
        G = self.XAX + s * self.XMX
        c = np.array([float(v @ b) for v in self.X])
        d = 1.0 / np.sqrt(np.maximum(np.diag(G), 1e-300))
        w, Q = np.linalg.eigh(d[:, None] * G * d[None, :])
        keep = w > 1e-10 * w.max()
        z = d * (Q[:, keep] @ ((Q[:, keep].T @ (d * c)) / w[keep]))
        x0 = np.column_stack(self.X) @ z
        r0 = b - Op @ x0
        return (x0, r0) if np.linalg.norm(r0) < np.linalg.norm(b) else (None, None)

    def shifted(self, s):
        """A + s M (:class:`_Shifted`), its sparse part's values in one buffer that every call reuses (the solves
        run one at a time: no nnz-sized allocation a solve) and the shared pattern tested once."""
        if self._same_pattern is None:
            self._same_pattern = _Shifted.same_pattern(sparse_part(self.A), self.M)
        if self._same_pattern and self._buffer is None:
            self._buffer = np.empty(self.M.nnz)
        return _Shifted(self.A, self.M, s, out=self._buffer if self._same_pattern else None,
                        same=self._same_pattern)

    def release(self):
        """Free the shifted operators' value buffer (:meth:`shifted` makes it again when next asked; each call fills
        it whole): not kept while the basis is orthonormalised and projected (the transient's peak)."""
        self._buffer = None

    def solve(self, Op, b, rtol, guess=None, recycle=False):
        """x with |b - Op x| <= rtol |b| (CG); the stopping test is relative to |b| as from zero, so a start changes
        the cost, not the accuracy. The start: with ``recycle``, :meth:`warm_start` (the Galerkin solution on the
        span of the earlier recycled solutions, the check's error fields) and x joins that span; else the best
        multiple of ``guess`` (the previous Krylov vector or shifted solve: on the reference unit's air scheme
        18 % fewer iterations, 439 -> 360, the same estimate to 1e-4 K). The basis solves take the latter: a
        Galerkin start from the span of the earlier basis vectors resolves the part of the new vector outside
        that span (what a basis vector adds) only to the tolerance relative to the whole vector, and it raised
        the check's estimate (air 0.028 -> 0.042 K, grease 0.016 -> 0.043 K of the 0.05 K accepted)."""
        x0 = r0 = None
        if recycle:
            x0, r0 = self._warm_start(Op, b)
        elif guess is not None:   # the best multiple of a nearby solution, if it beats zero (one product)
            w = Op @ guess
            ww = float(w @ w)
            alpha = float(w @ b) / ww if ww > 0 else 0.0
            if alpha != 0.0:
                r0 = b - alpha * w
                if np.linalg.norm(r0) < np.linalg.norm(b):
                    x0 = alpha * guess
                else:
                    r0 = None
        x, r, its, info = pcg(Op, b, x0, r0, self._preconditioner(Op), rtol, maxiter=3000)
        self.solves += 1
        self.its += its
        if info:
            raise InputError(f"reduced transient: CG did not converge (info {info})")
        if recycle:
            self._remember(x, b - r, getattr(Op, "s", 0.0))
        return x


def pcg(Op, b, x0, r0, pc, rtol, maxiter):
    """Preconditioned CG, scipy's ``cg`` step for step (its iterates and its stopping test |r| < rtol |b| on the
    updated residual r), from ``x0`` with its residual ``r0`` = b - Op x0 given (a start's residual, known to the
    caller, is not formed again; both None: from zero). Returns (x, r, iterations, info: 0 converged, else
    ``maxiter``); r is the updated residual, b - Op x to rounding (the warm starts' Gram rows use b - r as Op x)."""
    x = np.zeros_like(b) if x0 is None else np.array(x0, float)
    r = b.copy() if r0 is None else np.array(r0, float)
    tol = rtol * float(np.linalg.norm(b))
    rho_prev, p = None, None
    for it in range(maxiter):
        if np.linalg.norm(r) < tol or tol == 0.0:
            return x, r, it, 0
        z = pc @ r
        rho = float(np.dot(r, z))
        if p is None:
            p = np.array(z, float)
        else:
            p *= rho / rho_prev
            p += z
        q = Op @ p
        alpha = rho / float(np.dot(p, q))
        x += alpha * p
        r -= alpha * q
        rho_prev = rho
    return x, r, maxiter, maxiter


class _Shifted(spla.LinearOperator):
    """A + s M (A may be sparse plus low rank): its sparse part sparse(A) + s M formed once where both share one
    pattern (the assembly's: one sparse product an iteration instead of two), else applied term by term."""

    def __init__(self, A, M, s, dtype=float, out=None, same=None):
        super().__init__(float, A.shape)
        self.A, self.M, self.s = A, M, s
        S = sparse_part(A)
        self.sparse = None
        if same if same is not None else self.same_pattern(S, M):
            data = np.multiply(M.data, s, dtype=dtype, out=out)
            data += S.data
            self.sparse = sp.csr_matrix((data, S.indices, S.indptr), shape=S.shape, copy=False)

    @staticmethod
    def same_pattern(S, M) -> bool:
        """Whether the CSR matrices ``S`` and ``M`` share one sparsity pattern (then A + s M is one CSR matrix)."""
        return bool(sp.isspmatrix_csr(S) and sp.isspmatrix_csr(M) and S.nnz == M.nnz and (S.indices is M.indices or (
            np.array_equal(S.indptr, M.indptr) and np.array_equal(S.indices, M.indices))))

    def _matvec(self, x):
        x = np.ravel(x)
        if self.sparse is None:
            return self.A @ x + self.s * (self.M @ x)
        out = self.sparse @ x
        if self.A is not sparse_part(self.A):
            out += self.A.low_rank(x)
        return out


def m_orthonormal(cols, M) -> np.ndarray:
    """An M-orthonormal basis V (V^T M V = I) of the span of ``cols`` (near-dependent columns dropped)."""
    X = np.column_stack([c / (np.linalg.norm(c) or 1.0) for c in cols])
    U, s, _ = np.linalg.svd(X, full_matrices=False)
    del X   # (n, k): not kept beside U's products
    U = U[:, s > 1e-10 * s[0]]
    R = sla.cholesky(U.T @ (M @ U))          # U^T M U = R^T R
    return sla.solve_triangular(R, U.T, trans="T").T   # U R^-1


class _Conduction:
    """L = K + H [W/K] (conduction and the linear laws) as S - diag(D) from the secant operator's sparse part S and
    its secant slopes D (:func:`~imutherm.thermal.reduced.secant_slopes`): ``L @ x`` for a vector or an (n, r) block
    without a matrix of its own (one nnz-sized array less: 38 MB on the reference unit's default mesh)."""

    def __init__(self, S, D):
        self.S, self.D = S, D
        self.shape = S.shape

    def __matmul__(self, x):
        out = self.S @ x
        if x.ndim == 1:
            out -= self.D * x
        else:   # a column at a time: no second (n, r) temporary beside the product (the same values)
            for j in range(x.shape[1]):
                out[:, j] -= self.D * x[:, j]
        return out


class ProjectedModel:
    """The nonlinear model projected on V: y' = f0 - L_r y - sum over laws V_b^T w q(T_amb + V_b y).
    ``L``: the operator K + H (a matrix or :class:`_Conduction`; default assembled from ``asm``)."""

    def __init__(self, asm, V, amb, L=None):
        self.V, self.amb = V, amb
        L = asm.pattern.csr(asm.K_data + asm.H_data) if L is None else L
        F = asm.F_q + asm.F_bc
        one = np.ones(asm.n)
        self.f0 = V.T @ (F - amb * (L @ one))
        self.L_r = V.T @ (L @ V)
        self.laws = []
        for bc in asm.nonlinear:
            Vb = V[bc.nodes]
            if hasattr(bc.law, "X") and hasattr(bc.law, "Pn"):   # the cavity exchange: Q = X sigma T_p^4
                Q = np.asarray(bc.law.Pn @ Vb)
                # (Q^T X) once: a right-hand side then costs an (r, k) product instead of the dense (k, k) one
                # (k ~1,300 patches: ~1 ms of the ~1.4 ms a call took on the reference unit)
                self.laws.append(("exchange", bc, Q, Q.T @ bc.law.X))
            else:
                self.laws.append(("nodal", bc, Vb, (Vb * bc.weights[:, None]).T))

    def rhs(self, t, y):
        from imutherm.thermal.problem import SIGMA, ZERO_C_K
        f = self.f0 - self.L_r @ y
        for law in self.laws:
            if law[0] == "exchange":
                _, bc, Q, QX = law
                Tk = self.amb + ZERO_C_K + Q @ y
                f -= QX @ (SIGMA * Tk**4)
            else:
                _, bc, Vb, W = law
                q, _ = bc.law.flux_out(self.amb + Vb @ y, bc.T_ref)
                f -= W @ q
        return f

    def jac(self, t, y):
        from imutherm.thermal.problem import SIGMA, ZERO_C_K
        J = -self.L_r.copy()
        for law in self.laws:
            if law[0] == "exchange":
                _, bc, Q, QX = law
                Tk = self.amb + ZERO_C_K + Q @ y
                J -= QX @ (4 * SIGMA * Tk[:, None]**3 * Q)
            else:
                _, bc, Vb, W = law
                _, dq = bc.law.flux_out(self.amb + Vb @ y, bc.T_ref)
                J -= W @ (dq[:, None] * Vb)
        return J


def _integrate(red: ProjectedModel, t_end: float, scale_K: float):
    sol = solve_ivp(red.rhs, (0.0, t_end), np.zeros(red.V.shape[1]), method="BDF", jac=red.jac,
                    rtol=ODE_RTOL, atol=ODE_RTOL * scale_K, dense_output=True, first_step=1e-3)
    if not sol.success:
        raise InputError(f"reduced transient: the integrator failed ({sol.message})")
    return sol


def _check_times(t_stop: float, t95) -> np.ndarray:
    """Check times [s]: :data:`CHECK_TIMES` spread geometrically from ``t_stop`` / 3000 to ``t_stop``, and the
    earliest and latest t95; a time within 15 % of the one before is dropped (its estimate adds little)."""
    tk = list(np.geomspace(t_stop / 3000.0, t_stop, CHECK_TIMES))
    if len(t95):
        tk += [float(np.min(t95)), float(np.max(t95))]
    ends = {float(np.min(t95)), float(np.max(t95))} if len(t95) else set()
    keep = []
    for t in sorted(tk):
        if keep and t <= 1.15 * keep[-1]:
            if t in ends:
                keep[-1] = t   # a t95 replaces its neighbour: the t95 check reads the estimate there
            continue
        keep.append(t)
    return np.array(keep)


def _settle_index(curves, final, fraction) -> int | None:
    """First row where every site has passed 95 % of its rise and is within ``fraction`` of it."""
    rise = final - curves[0]
    nz = rise != 0
    frac = np.ones_like(curves)
    frac[:, nz] = (curves[:, nz] - curves[0, nz]) / rise[nz]
    passed = np.maximum.accumulate(frac >= 0.95, axis=0) | ~nz
    ok = passed.all(axis=1) & (np.abs(final - curves) <= fraction * np.abs(rise)).all(axis=1)
    idx = np.flatnonzero(ok)
    return int(idx[0]) if idx.size else None


@one_blas_thread
def reduced_power_on(problem, asm, steady, probes: dict, t_end: float, *, settle: bool = False,
                     save_times=None, tol_K: float | None = None, t95_rel: float | None = None,
                     order: int = KRYLOV_ORDER, max_rounds: int = 2, preconditioner=None):
    """The power-on transient from the ambient on a checked reduced model (module docstring).

    problem, asm : the full model and its assembly; steady : its SteadyResult (the field the secant is
    taken about, and the end of the curves); probes : dict site -> point [m]; t_end : float [s] the
    latest end; settle : stop once every site is within 0.5 % of its steady rise (past its t95), as the
    full run's ``settle_C``; save_times : [s] times whose whole field is kept.
    tol_K : float [K], t95_rel : float [-], the check's acceptance (:class:`ReducedCheck`; default
    :data:`CHECK_TOL_K`, :data:`CHECK_T95_REL`); order : Krylov vectors of the first basis; max_rounds :
    enrichments of the basis by the error fields before giving up. preconditioner : the steady solve's
    (``solve_steady(..., keep=)``), used for the unshifted solves instead of a hierarchy of the secant operator
    (the same matrix but the nonlinear laws' slopes: one setup less, the basis the same to the solves' tolerance).

    Returns (TransientResult or None, ReducedCheck): None when the check failed (run the full FEM).
    """
    t0 = time.perf_counter()
    tol_K = CHECK_TOL_K if tol_K is None else float(tol_K)
    t95_rel = CHECK_T95_REL if t95_rel is None else float(t95_rel)
    amb = problem.ambient_C
    names = tuple(probes)
    P = probe_matrix(problem.grid, np.array([probes[n] for n in names]))
    A, _ = linearised(asm, np.asarray(steady.T_C))
    M = asm.M
    lin = _Solver(A, M, preconditioner)
    x_ss = np.asarray(steady.T_C) - amb
    # the initial slope's direction (the power over the lumped heat capacity: what the first seconds heat)
    cols = [x_ss, np.ones(asm.n), asm.F_q / np.maximum(np.asarray(M.sum(axis=1)).ravel(), 1e-300)]
    v = x_ss
    for _ in range(order):
        v = lin.solve(A, M @ v, BASIS_RTOL, guess=v)
        cols.append(v)
    prev = None
    for tau in EARLY_S:   # the first seconds: (A + M / tau)^-1 b, well conditioned, a few CG iterations each
        prev = lin.solve(lin.shifted(1.0 / tau), asm.F_q, BASIS_RTOL, guess=prev)
        cols.append(prev)
    timings = {"basis": time.perf_counter() - t0, "integrate": 0.0, "check": 0.0}
    final = P @ x_ss
    scale = max(float(np.abs(x_ss).max()), 1e-6)
    L = _Conduction(sparse_part(A), secant_slopes(asm, np.asarray(steady.T_C)))
    F = asm.F_q + asm.F_bc
    F_norm = float(np.linalg.norm(asm.F_q)) or 1.0
    for rnd in range(1, max_rounds + 2):
        t1 = time.perf_counter()
        lin.release()   # an nnz-sized array (40 MB on the reference unit) not kept through the basis and projection
        V = m_orthonormal(cols, M)
        red = ProjectedModel(asm, V, amb, L)
        sol = _integrate(red, t_end, scale)
        PV = np.asarray(P @ V)
        times = sol.t
        curves = sol.y.T @ PV.T
        t_stop = t_end
        if settle:
            k = _settle_index(curves, final, SETTLE_FRACTION)
            if k is not None:
                times, curves, t_stop = times[:k + 1], curves[:k + 1], float(times[k])
        t95 = np.array([settle_time(times, curves[:, j], T95_FRACTION, final[j]) for j in range(len(names))])
        timings["integrate"] += time.perf_counter() - t1
        t1 = time.perf_counter()
        fin = np.isfinite(t95) & (t95 > 0)   # the sites whose t95 the run reaches
        tk = _check_times(t_stop, t95[fin])
        err = np.empty((len(tk), len(names)))
        fields, res_max = [], 0.0
        for i, t in enumerate(tk):
            y = sol.sol(t)
            T = amb + V @ y
            r = F - M @ (V @ red.rhs(t, y)) - L @ T - asm.nonlinear_flux(T)[0]
            res_max = max(res_max, float(np.linalg.norm(r)) / F_norm)
            e = lin.solve(lin.shifted(1.0 / t), r, CHECK_RTOL, recycle=True)
            err[i] = P @ e
            fields.append(e)
        rel95 = 0.0   # each t95's error: the site's estimated error there over the curve's slope
        for j in np.flatnonzero(fin):
            slope = abs(float(PV[j] @ red.rhs(t95[j], sol.sol(t95[j]))))
            at95 = float(np.interp(t95[j], tk, np.abs(err[:, j])))
            rel95 = max(rel95, at95 / max(slope, 1e-30) / t95[j])
        max_err = float(np.abs(err).max())
        timings["check"] += time.perf_counter() - t1
        ok = max_err <= tol_K and rel95 <= t95_rel
        if ok or rnd == max_rounds + 1:
            break
        cols += fields
        V = red = sol = PV = None   # this round's basis and model: not kept beside the next round's
    reason = "" if ok else (f"estimated site error {max_err:.3g} K (tolerance {tol_K:g} K), t95 error "
                            f"{100 * rel95:.2g} % (tolerance {100 * t95_rel:g} %) after {rnd} round(s)")
    check = ReducedCheck(bool(ok), reason, V.shape[1], rnd, lin.solves, lin.its, tuple(float(t) for t in tk), err,
                         max_err, rel95, tol_K, t95_rel, timings)
    if not ok:
        return None, check
    return _result(problem, asm, red, sol, times, curves + amb, names, save_times, res_max, lin, t0), check


def _result(problem, asm, red, sol, times, probe_C, names, save_times, res_max, lin, t0) -> TransientResult:
    """The reduced transient as a :class:`TransientResult` (its energy account on the integrator's steps)."""
    V, amb = red.V, red.amb
    one = np.ones(asm.n)
    Y = np.asarray(sol.sol(times))                     # (r, k)
    H1 = asm.pattern.csr(asm.H_data).T @ one           # heat out through the linear laws: 1^T H (T - T_ref)
    F_flux = np.zeros(asm.n)  # the HeatFlux laws' nodal loads (each law's weights are on its face's nodes)
    for bc in asm.fluxes:
        np.add.at(F_flux, bc.nodes, bc.law.q * bc.weights)
    F_lin = asm.F_bc - F_flux
    q_lin = (H1 @ V) @ Y + float(H1 @ (amb * one) - F_lin.sum())
    q_nl = np.zeros(len(times))
    for law in red.laws:
        if law[0] == "exchange":
            continue    # moves heat between the cavity surfaces only (zero net)
        _, bc, Vb, _ = law
        for j in range(len(times)):
            q, _ = bc.law.flux_out(amb + Vb @ Y[:, j], bc.T_ref)
            q_nl[j] += float(bc.weights @ q)
    power = float(asm.F_q.sum()) + asm.flux_in_W
    E_in = power * float(times[-1])
    E_out = float(np.trapezoid(q_lin + q_nl, times)) if hasattr(np, "trapezoid") else float(np.trapz(q_lin + q_nl, times))
    T_end = amb + V @ Y[:, -1]
    E_stored = float((asm.M @ one) @ (T_end - amb))
    ebal = abs(E_in - E_stored - E_out) / max(abs(E_in), abs(E_stored) + abs(E_out), 1e-30)
    sv = np.sort(np.atleast_1d(np.asarray([] if save_times is None else save_times, float)))
    sv = sv[sv <= times[-1] * (1 + 1e-12)]
    saved = np.array([amb + V @ sol.sol(t) for t in sv]) if sv.size else np.empty((0, asm.n))
    T0 = np.full(asm.n, amb)
    for arr in (T_end, T0, probe_C, saved, times, sv):
        arr.setflags(write=False)
    return TransientResult(problem=problem, times=np.asarray(times), T_C=T_end, T0_C=T0, probe_names=names,
                           probe_C=probe_C, saved_times=sv, saved_C=saved, newton_iterations=0,
                           linear_iterations=lin.its, residual=res_max, energy_balance_rel_error=float(ebal),
                           energy_in_J=E_in, energy_stored_J=E_stored, energy_out_J=E_out, unknowns=asm.n,
                           steps=len(times) - 1, theta=float("nan"), assembly_s=0.0,
                           solve_s=time.perf_counter() - t0, solver="reduced", lagged_nonlinear=False,
                           scheme="reduced", linear_solves=lin.solves, rejected_steps=0, tol_K=None,
                           settled=bool(times[-1] < sol.t[-1]))
