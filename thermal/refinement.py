"""The discretisation error of a steady answer, by uniform refinement (Richardson extrapolation).

A Q1 field on a grid of spacing h converges as T(h) = T* - C h^p + ... at a point, with p = 2 where the field is
smooth and less near the re-entrant corners of thin solids in air (a board edge, a package corner), where the
field is singular. Solving again on the grid with every interval split in ``r`` parts
(:func:`imutherm.geometry.mesh.refine_grid`) gives the coarse answer's error

    E = T* - T(h) ~ (T(h/r) - T(h)) r^p / (r^p - 1),

the extrapolated value T(h) + E and, from three grids, the observed order p (:func:`observed_order`).

**The answer a study gives** is not the coarse value but the refined one corrected (:func:`bracket`): where the
error falls monotonically at an order of at least p, the converged value lies between the refined value T(h/r)
and the extrapolation at order p, T(h/r) + (T(h/r) - T(h)) / (r^p - 1); the answer is that interval's midpoint
and its error bound the half-width, (T(h/r) - T(h)) / (2 (r^p - 1)): a quarter of the coarse value's estimated
error at r = 2, p = 1. At the reference unit's default mesh that is <= 0.06 K at every sensor die, and the
three-grid extrapolation lies inside the bound at every die and hot spot of the three schemes
(``benchmarks/bench_mesh_convergence.py``).

:data:`MESH_ERROR_ORDER` is the order the two-grid estimate of a study assumes: the lowest observed at the
reference unit's sensor dies by the refinement study of ``imutherm verify`` (``refinement_reference_unit``:
1x, 2x, 3x of a 6 mm / 1-cell mesh, linear laws; 2026-12-04: air 1.22-1.52, grease 1.02-1.21 at the dies,
1.3-1.45 at the hot spot), rounded down to 1; at the default mesh with the study's laws the orders at the dies are
1.10-2.17 and the estimate bounds the three-grid error at every die (``benchmarks/bench_mesh_convergence.py``,
2026-12-05: air, grease, potted). An order this low is the mark of the singular corners; where the
field converges faster the estimate errs on the large side (a smooth field at p = 2: 1.5x the error; the
board-in-cavity case of the verification suite: 1.2-1.3x).

:func:`refined_steady` solves the refined problem from the coarse field (prolonged, exact on the nested grid):
one Newton step (a second only where the nonlinear laws need it), since the start is within the discretisation
error of the answer, by CG with a two-level preconditioner whose coarse level is the coarse grid itself (:func:`_two_level`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

from imutherm import InputError
from imutherm.workers import one_blas_thread

#: the order of convergence [-] a two-grid estimate assumes (module docstring)
MESH_ERROR_ORDER = 1.0
#: refinement ratio [-] of the study's estimate: every interval split in two (8x the cells)
REFINEMENT_RATIO = 2


def richardson(coarse, fine, ratio: float = REFINEMENT_RATIO, order: float = MESH_ERROR_ORDER) -> tuple:
    """(error of the coarse values [K], extrapolated values): ``E = (fine - coarse) r^p / (r^p - 1)``,
    ``coarse + E``. ``coarse``, ``fine`` [°C or K], arrays of the same shape; ``ratio`` r > 1, ``order`` p > 0."""
    if not (np.all(np.asarray(ratio) > 1) and np.all(np.asarray(order) > 0)):
        raise InputError(f"richardson: need ratio > 1 and order > 0, got {ratio!r}, {order!r}")
    c, f = np.asarray(coarse, float), np.asarray(fine, float)
    g = ratio**order
    err = (f - c) * g / (g - 1.0)
    return err, c + err


def bracket(coarse, fine, ratio: float = REFINEMENT_RATIO, order: float = MESH_ERROR_ORDER) -> tuple:
    """(answer, its error bound [K]): the midpoint of the interval from ``fine`` to the extrapolation at ``order``,
    ``fine + (fine - coarse) / (r^p - 1)``, and half its width. The converged value lies in that interval where the
    error falls monotonically at an order >= p (module docstring). ``coarse``, ``fine`` [°C or K]."""
    err, _ = richardson(coarse, fine, ratio, order)
    f = np.asarray(fine, float)
    half = 0.5 * (err - (f - np.asarray(coarse, float)))   # (fine - coarse) / (2 (r^p - 1))
    return f + half, np.abs(half)


def observed_order(values, ratios) -> np.ndarray:
    """Observed order p [-] of convergence from three grids with spacing h / ratios[k] (e.g. (1, 2, 3)):
    the p with (v3 - v2) / (v2 - v1) = (r2^-p - r3^-p) / (r1^-p - r2^-p), per column of ``values`` (3, m);
    NaN where the differences change sign (not monotone: no order) or p is outside (0.05, 8)."""
    v = np.atleast_2d(np.asarray(values, float))
    if v.shape[0] != 3 or len(ratios) != 3:
        raise InputError("observed_order: needs values on three grids")
    r1, r2, r3 = (float(r) for r in ratios)
    out = np.full(v.shape[1], np.nan)
    for j in range(v.shape[1]):
        d1, d2 = v[1, j] - v[0, j], v[2, j] - v[1, j]
        if d1 == 0 or d2 / d1 <= 0:
            continue
        q = d2 / d1

        def f(p):
            return (r2**-p - r3**-p) / (r1**-p - r2**-p) - q
        try:
            out[j] = brentq(f, 0.05, 8.0)
        except ValueError:
            pass
    return out


@dataclass(frozen=True)
class RefinementEstimate:
    """The discretisation error of a steady answer by one uniform refinement.

    names : tuple of str, the sites (and ``hot spot``: the field's maximum); coarse_C, fine_C : (m,) [°C]
    error_K : (m,) [K] estimated error of the coarse (the answer's) values, E = T* - T_coarse
    extrapolated_C : (m,) [°C] coarse + error
    answer_C : (m,) [°C] the corrected answer, answer_error_K : (m,) [K] its error bound (:func:`bracket`)
    ratio : int, order : float (assumed, :data:`MESH_ERROR_ORDER`)
    coarse_nodes, fine_nodes : int; seconds : float [s] (wall) and cpu_s : float [s] of the refined solve
    solver : str, 'assembled' (:func:`refined_steady`) or 'matrix-free'
    (:func:`imutherm.thermal.mesh_estimate.refined_steady_matrix_free`); cg_steps : int, its CG steps (0: not counted)
    fallback : str, why the assembled solve was used after the matrix-free one ('' none)
    """

    names: tuple
    coarse_C: np.ndarray
    fine_C: np.ndarray
    error_K: np.ndarray
    extrapolated_C: np.ndarray
    answer_C: np.ndarray
    answer_error_K: np.ndarray
    ratio: int
    order: float
    coarse_nodes: int
    fine_nodes: int
    seconds: float
    cpu_s: float
    solver: str = "assembled"
    cg_steps: int = 0
    fallback: str = ""

    def max_error(self, names, of: str = "error_K") -> tuple:
        """(the error [K] of largest magnitude over ``names`` (those present), its site); ``of``: 'error_K' (the
        default mesh's values) or 'answer_error_K' (the corrected answer's bound)."""
        values = getattr(self, of)
        idx = [self.names.index(n) for n in names if n in self.names]
        if not idx:
            return float("nan"), None
        k = max(idx, key=lambda i: abs(values[i]))
        return float(values[k]), self.names[k]

    def summary(self) -> dict:
        """JSON-ready figures (the ``discretisation_error`` entry of ``summary.json`` / ``result.json``)."""
        return {"method": f"Richardson: the steady solve again on the mesh with every interval split in "
                          f"{self.ratio} ({self.fine_nodes:,} nodes), order p = {self.order:g} assumed "
                          "(imutherm.thermal.refinement.MESH_ERROR_ORDER)",
                "refined_solver": getattr(self, "solver", "assembled"), "cg_steps": getattr(self, "cg_steps", 0),
                "fallback": getattr(self, "fallback", ""),
                "ratio": self.ratio, "order": self.order, "coarse_nodes": self.coarse_nodes,
                "fine_nodes": self.fine_nodes, "timings_s": {"wall": self.seconds, "cpu": self.cpu_s},
                "answer": "answer_C, the midpoint between refined_C and the extrapolation at the order p, within "
                          "answer_error_K of the converged value where the error falls at an order >= p; the "
                          "study's site values and curves and its hot spot are scaled to it (fields, maps and part "
                          "maxima stay the default mesh's)",
                "sites": {n: {"default_C": float(c), "refined_C": float(f), "error_K": float(e),
                              "extrapolated_C": float(x), "answer_C": float(a), "answer_error_K": float(b)}
                          for n, c, f, e, x, a, b in zip(self.names, self.coarse_C, self.fine_C, self.error_K,
                                                         self.extrapolated_C, self.answer_C, self.answer_error_K)}}


HOT_SPOT = "hot spot"
#: residual of the refined solve's CG relative to the prolonged field's: the corrections it measures are 0.01-1 K
#: against 10-40 K rises, so 1e-3 leaves them within ~1e-3 K (reference unit, air, linear laws: the same site
#: differences to 0.001 K as a solve to 1e-10)
REFINED_CG_RTOL = 1e-3
#: the refined Newton stops when a step changes no node by more than this [K]: the first step carries the
#: discretisation's correction (0.1-1 K at the reference unit's sites), the second the nonlinear laws' change
#: over it (~1e-3 K), a third nothing the estimate can see
REFINED_STEP_K = 5e-3


def _two_level(A, prolong, coarse_pc):
    """A symmetric two-level preconditioner of the refined matrix ``A`` (sparse): one Gauss-Seidel sweep
    forward, the coarse grid's correction through ``prolong`` with ``coarse_pc`` (the coarse matrix's AMG
    V-cycle), one sweep backward. The coarse space is the refined one's own (nested Q1 spaces), so no hierarchy
    of the 8x larger matrix is built (its AMG setup took longer and ~2x the memory of the solve). The sweeps run
    on ``A`` itself, in double precision: a single-precision copy made them ~25 % faster but was the solve's
    third-largest array (152 MiB on the reference unit's refined mesh)."""
    import scipy.sparse.linalg as spla
    from pyamg.relaxation.relaxation import gauss_seidel

    R = prolong.T   # a CSC view: no copy

    def apply(b):
        b = np.ravel(np.asarray(b, float))
        x = np.zeros_like(b)
        gauss_seidel(A, x, b, iterations=1, sweep="forward")
        x += prolong @ (coarse_pc @ (R @ (b - A @ x)))
        gauss_seidel(A, x, b, iterations=1, sweep="backward")
        return x

    return spla.LinearOperator(A.shape, matvec=apply, dtype=float)


def newton_matrix(asm, D, T):
    """The sparse Newton matrix at ``T`` [°C]: conduction and linear laws, the nonlinear laws' diagonal slopes (each
    s2s exchange's too, its coupling is applied beside it), fixed nodes eliminated. ``asm``: an assembly with its
    own ``H_data`` (not ``merge_linear``)."""
    data = D.eliminate(asm.K_data + asm.H_data)
    if asm.nonlinear:
        _, J = asm.nonlinear_flux(T)
        data[D.free_diag] += J[~D.mask]
    return asm.pattern.csr(data)


@one_blas_thread
def refined_steady(fine_problem, coarse_problem, coarse_T_C, prolong, probes: dict, coarse_probe_C,
                   coarse_max_C: float, *, ratio: int = REFINEMENT_RATIO, order: float = MESH_ERROR_ORDER,
                   max_newton: int = 4, coarse_pc=None) -> RefinementEstimate:
    """The estimate of the coarse answer's error from the steady solve of ``fine_problem`` (``coarse_problem`` on
    its refined grid), started from ``prolong @ coarse_T_C`` (exact on the nested grid: the Newton steps only
    carry the discretisation's correction, so one does on the reference unit).

    Each Newton step is solved by CG to :data:`REFINED_CG_RTOL` times the prolonged field's residual (an absolute
    tolerance), preconditioned by :func:`_two_level` with the coarse Newton matrix's AMG hierarchy; each s2s exchange
    enters with its coupling, as in the steady solve. A next step is taken only where the laws' change over the
    step leaves a residual above that tolerance (reference unit, default mesh: none; the second step it took
    with a relative tolerance moved no site by more than 3e-4 K).
    probes : dict name -> (x, y, z) [m]; coarse_probe_C : (m,) [°C] their coarse values; coarse_max_C : [°C] the
    coarse field's maximum (the hot spot). coarse_pc : the coarse solve's own preconditioner
    (``solve_steady(..., keep=)``: a Newton matrix of the same problem), used for the coarse level instead of
    assembling the coarse problem again and building a hierarchy of its Newton matrix at ``coarse_T_C``.
    """
    import scipy.sparse.linalg as spla

    from imutherm import ConvergenceError
    from imutherm.thermal.assembly import assemble
    from imutherm.thermal.cavity_radiation import CavityExchange
    from imutherm.thermal.linear import Dirichlet, amg_preconditioner
    from imutherm.thermal.probes import named_probes
    from imutherm.thermal.steady import with_exchanges

    t0, c0 = time.perf_counter(), time.process_time()
    Tc = np.asarray(coarse_T_C, float)
    if coarse_pc is None:
        asm_c = assemble(coarse_problem, mass=False)
        Dc = Dirichlet(asm_c, asm_c.dirichlet_values(None)[0])
        coarse_pc = amg_preconditioner(newton_matrix(asm_c, Dc, Tc))
        del asm_c
    asm = assemble(fine_problem, mass=False, cache_pattern=False, merge_linear=True)   # K_data: K + H
    dnodes, dvals = asm.dirichlet_values(None)
    D = Dirichlet(asm, dnodes)
    L = asm.pattern.csr(asm.K_data)
    # the Newton matrix's data: L's own array where no node is fixed (its diagonal slopes added for the solve and
    # taken off again: the refined matrices are the run's largest arrays), else the eliminated copy
    A = asm.pattern.csr(D.eliminate(L.data))
    F = asm.F_q + asm.F_bc
    exchanges = [bc.law for bc in asm.nonlinear if isinstance(bc.law, CavityExchange)]
    T = prolong @ Tc
    T[dnodes] = dvals
    atol, count = None, [0]
    for _ in range(max_newton):
        N, J = asm.nonlinear_flux(T) if asm.nonlinear else (0.0, None)
        r = F - L @ T - N
        r[dnodes] = 0.0
        r_norm = float(np.linalg.norm(r))
        if atol is None:   # the tolerance of every step: relative to the prolonged field's residual
            atol = REFINED_CG_RTOL * r_norm
        elif r_norm <= atol:   # the laws' change over the first step is below what its CG left
            break
        diag = A.data[D.free_diag]
        if J is not None:
            A.data[D.free_diag] += J[~D.mask]
        op = with_exchanges(A, exchanges, T, D.mask) if exchanges else A
        dT, info = spla.cg(op, r, rtol=0.0, atol=atol, M=_two_level(A, prolong, coarse_pc), maxiter=500,
                           callback=lambda _x: count.__setitem__(0, count[0] + 1))
        A.data[D.free_diag] = diag
        if info != 0:
            raise ConvergenceError(f"refined steady solve: CG did not reach rtol {REFINED_CG_RTOL:g} (info {info})")
        T += dT
        if not asm.nonlinear or np.abs(dT).max() <= REFINED_STEP_K:
            break
    names, Pm = named_probes(fine_problem.grid, probes)
    names = tuple(names) + (HOT_SPOT,)
    coarse = np.append(np.asarray(coarse_probe_C, float), coarse_max_C)
    fine = np.append(Pm @ T, float(np.max(T)))
    err, extra = richardson(coarse, fine, ratio, order)
    answer, bound = bracket(coarse, fine, ratio, order)
    return RefinementEstimate(names, coarse, fine, err, extra, answer, bound, int(ratio), float(order), int(len(Tc)),
                              int(fine_problem.grid.n_nodes), time.perf_counter() - t0, time.process_time() - c0,
                              cg_steps=count[0])


def fmt_error(est: RefinementEstimate, sites) -> str:
    """One line: the corrected answer's error bound at ``sites`` and at the hot spot, and the default mesh's own
    estimated error there [K]."""
    b, at_b = est.max_error(sites, "answer_error_K")
    e, at_e = est.max_error(sites)
    hot = est.names.index(HOT_SPOT)
    if not math.isfinite(b):
        line = (f"mesh (Richardson, {est.ratio}x refined, p >= {est.order:g}): answer corrected, hot spot within "
                f"{est.answer_error_K[hot]:.3f} K (default mesh {est.error_K[hot]:+.2f} K)")
    else:
        line = error_line(est.ratio, est.order, b, at_b, est.answer_error_K[hot], e, at_e, est.error_K[hot])
    return line + solver_note(est)


def solver_note(est: RefinementEstimate) -> str:
    """'' for the matrix-free refined solve (the default); else how the refined solve was made and why."""
    if getattr(est, "fallback", ""):
        return f"; bound: refined solve assembled, because {est.fallback}"
    return ""


def error_line(ratio: int, order: float, bound_K: float, bound_at: str, hot_bound_K: float, error_K: float,
               error_at: str, hot_error_K: float) -> str:
    """The printed sentence of a mesh-error estimate: the corrected answer's error bound, largest at the sensor
    die ``bound_at`` and at the hot spot, then the default mesh's own estimated errors there [K] (the command's
    line and the report's, from a :class:`RefinementEstimate` or from ``summary.json``)."""
    return (f"mesh (Richardson, {ratio}x refined, p >= {order:g}): answer corrected to within {bound_K:.3f} K at "
            f"the sensor dies ({bound_at}), {hot_bound_K:.3f} K at the hot spot (the default mesh's values: "
            f"{error_K:+.2f} K at most ({error_at}), hot spot {hot_error_K:+.2f} K)")