"""A steady solve on a small basis that checks itself against the full model (the study's oven self-heating).

The end-to-end study solves each scheme's steady state a second time with the calibration oven's chamber as
the ambient (:func:`imutherm.studies.end_to_end.self_heating_table`): the same unit, mesh and powers; only the
temperature level of the surroundings changes, and with it the radiation laws' coefficients. Its rise field is
close to the known one's, and a full Newton solve (~5 Newton steps of ~40 CG iterations, one AMG setup) is
more than it needs:

1. **Basis**: the known steady rise x0 = T0 - T_amb0 (the solve at the layout's ambient) and the uniform
   field, M-orthonormalised.
2. **Reduced solve**: Newton's method (exact reduced Jacobian, backtracking) on the *nonlinear* model
   projected on the basis, V^T (F - L T - N(T)) = 0, T = T_amb + V y: the nonlinear laws (natural
   convection, radiation, the s2s cavity exchange) are evaluated exactly on their own nodes
   (:class:`imutherm.thermal.reduced_transient.ProjectedModel`), so the only error is the basis's.
3. **Check** (a posteriori, against the full model): the full nonlinear residual r = F - L T - N(T) of the
   reduced field and the full model's Newton step there, e = J^-1 r (J the full Jacobian at T, the s2s
   exchange's dense coupling included as in :func:`imutherm.thermal.steady.solve_steady`; CG to
   :data:`CHECK_RTOL`, preconditioned by one AMG hierarchy of its sparse part). To first order e is the
   reduced field's error (the laws' curvature over a few hundredths of a kelvin is negligible). The field is
   accepted when every probe's |e| is within ``tol_K``; otherwise e joins the basis and the reduced solve runs
   again (at most ``max_rounds`` enrichments), and if it still fails the caller runs the full Newton solve.
   The estimate against the true error is measured in ``tests/test_reduced_steady.py``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse.linalg as spla

from imutherm import InputError
from imutherm.thermal.cavity_radiation import CavityExchange
from imutherm.thermal.linear import amg_preconditioner
from imutherm.thermal.probes import named_probes
from imutherm.thermal.reduced_transient import m_orthonormal, ProjectedModel
from imutherm.thermal.results import SteadyResult
from imutherm.thermal.steady import steady_balance, with_exchanges

#: probe error the check accepts [K]: the study's oven self-heating at the sensor dies. Forty times below what
#: the self-heating table's own two-point interpolation leaves (0.4 K against a three-point table,
#: :class:`imutherm.studies.end_to_end.StudyConfig` ``chamber_C``), and a fifth of the reduced transient's 0.05 K
CHECK_TOL_K = 0.01
#: relative CG tolerance of the check's Newton-step solve (the estimate needs its first digit)
CHECK_RTOL = 1e-2
#: enrichments of the basis by the check's error field before giving up
MAX_ROUNDS = 3
#: the reduced Newton iteration stops when the largest node change is below this fraction of the largest rise
REDUCED_NEWTON_TOL = 1e-10


@dataclass(frozen=True)
class ReducedSteadyCheck:
    """The reduced steady solve's check against the full model.

    accepted : bool, the field passed (else the caller runs the full Newton solve); reason : str, why not
    basis_size : int; rounds : int (1: the first basis passed); full_solves : int, CG solves of the full model;
    cg_iterations : int; site_error_K : (m,) [K] the estimated error at each probe (last round);
    max_site_error_K : float [K]; tol_K : float [K]; timings_s : dict, {"reduced", "check"} [s]
    """

    accepted: bool
    reason: str
    basis_size: int
    rounds: int
    full_solves: int
    cg_iterations: int
    site_error_K: np.ndarray
    max_site_error_K: float
    tol_K: float
    timings_s: dict

    def summary(self) -> dict:
        """JSON-ready figures."""
        return {"accepted": self.accepted, "reason": self.reason, "basis_size": self.basis_size,
                "rounds": self.rounds, "full_solves": self.full_solves, "cg_iterations": self.cg_iterations,
                "max_site_error_K": float(self.max_site_error_K), "tol_K": self.tol_K,
                "timings_s": {k: float(v) for k, v in self.timings_s.items()}}


def _reduced_newton(red: ProjectedModel, y: np.ndarray, scale_K: float, max_iter: int = 50) -> np.ndarray:
    """Solve red.rhs(y) = 0 (the projected steady residual) by Newton's method with backtracking."""
    V = red.V
    g = red.rhs(0.0, y)
    for _ in range(max_iter):
        dy = np.linalg.solve(red.jac(0.0, y), -g)
        gn = np.linalg.norm(g)
        step = 1.0
        for _ in range(30):
            y_new = y + step * dy
            g_new = red.rhs(0.0, y_new)
            if np.isfinite(g_new).all() and np.linalg.norm(g_new) <= gn * (1 + 1e-12) + 1e-300:
                break
            step *= 0.5
        y, g = y_new, g_new
        if step * float(np.abs(V @ dy).max()) <= REDUCED_NEWTON_TOL * scale_K:
            return y
    raise InputError("reduced steady: the reduced Newton iteration did not converge")


def reduced_steady(problem, asm, known_rise, probes, *, tol_K: float | None = None,
                   max_rounds: int = MAX_ROUNDS, preconditioner=None):
    """The steady field of ``problem`` on a checked reduced model (module docstring).

    problem, asm : the full model and its assembly (with its heat capacity: the basis is M-orthonormal)
    known_rise : (n,) [K] a steady rise field of the same unit under other surroundings (the start of the basis)
    probes : dict name -> point [m] (the sites the check reads)
    tol_K : float [K] (default :data:`CHECK_TOL_K`); max_rounds : enrichments before giving up
    preconditioner : for the check's CG (e.g. the known field's steady solve's, ``solve_steady(..., keep=)``: the
        same conduction, other boundary slopes); default a new AMG hierarchy of the check's Newton matrix

    Returns (SteadyResult or None, ReducedSteadyCheck): None when the check failed (run the full solve).
    """
    t0 = time.perf_counter()
    tol_K = CHECK_TOL_K if tol_K is None else float(tol_K)
    if asm.dirichlet:
        raise InputError("reduced steady: fixed-temperature faces are not supported")
    amb = problem.ambient_C
    names, P = named_probes(problem.grid, probes)
    M = asm.M
    L = asm.pattern.csr(asm.K_data + asm.H_data)
    F = asm.F_q + asm.F_bc
    x0 = np.asarray(known_rise, float)
    scale = max(float(np.abs(x0).max()), 1e-6)
    exchanges = [bc.law for bc in asm.nonlinear if isinstance(bc.law, CavityExchange)]
    no_fixed = np.zeros(asm.n, bool)
    cols = [x0, np.ones(asm.n)]
    pc, solves, its = preconditioner, 0, 0
    timings = {"reduced": 0.0, "check": 0.0}
    T_start = amb + x0
    for rnd in range(1, max_rounds + 2):
        t1 = time.perf_counter()
        V = m_orthonormal(cols, M)
        red = ProjectedModel(asm, V, amb, L)
        y = _reduced_newton(red, V.T @ (M @ (T_start - amb)), scale)
        T = amb + V @ y
        timings["reduced"] += time.perf_counter() - t1
        t1 = time.perf_counter()
        N, Jd = asm.nonlinear_flux(T)
        r = F - L @ T - N
        # the Newton matrix on L's own data: the laws' slopes added to its diagonal for the solve and taken off
        # again (no second nnz-sized array: 38 MB on the reference unit's default mesh)
        diag = L.data[asm.pattern.diag_pos]
        L.data[asm.pattern.diag_pos] += Jd
        A = L
        if pc is None:
            pc = amg_preconditioner(A)
        Op = with_exchanges(A, exchanges, T, no_fixed) if exchanges else A
        n_it = [0]
        try:
            e, info = spla.cg(Op, r, rtol=CHECK_RTOL, M=pc, maxiter=3000,
                              callback=lambda _: n_it.__setitem__(0, n_it[0] + 1))
        finally:
            L.data[asm.pattern.diag_pos] = diag
        solves, its = solves + 1, its + n_it[0]
        if info:
            raise InputError(f"reduced steady: CG did not converge (info {info})")
        err = np.asarray(P @ e)
        max_err = float(np.abs(err).max()) if err.size else 0.0
        timings["check"] += time.perf_counter() - t1
        ok = max_err <= tol_K
        if ok or rnd == max_rounds + 1:
            break
        cols.append(e)
        T_start = T
    reason = "" if ok else (f"estimated site error {max_err:.3g} K (tolerance {tol_K:g} K) after {rnd} round(s)")
    check = ReducedSteadyCheck(bool(ok), reason, V.shape[1], rnd, solves, its, err, max_err, tol_K, timings)
    if not ok:
        return None, check
    LT = L @ T
    P_in, heat, ebal = steady_balance(asm, T, np.array([], int), F, LT, N)
    scale_r = np.linalg.norm(F) + np.linalg.norm(N) + np.linalg.norm(LT)
    probe_C = np.asarray(P @ T)
    for a in (T, probe_C):
        a.setflags(write=False)
    res = SteadyResult(problem=problem, T_C=T, probe_names=names, probe_C=probe_C, newton_iterations=0,
                       linear_iterations=its, residual=float(np.linalg.norm(r) / scale_r) if scale_r > 0 else 0.0,
                       energy_balance_rel_error=float(ebal), power_in_W=P_in, heat_out_W=heat, unknowns=asm.n,
                       assembly_s=0.0, solve_s=time.perf_counter() - t0, solver="reduced")
    return res, check
