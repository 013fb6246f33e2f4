"""The refined solve of the mesh-error estimate without its 27-point matrix (matrix-free, ~half the memory).

The study's discretisation bound (:mod:`imutherm.thermal.refinement`) needs the steady answer on the default mesh
refined 2x in every direction. :func:`imutherm.thermal.refinement.refined_steady` assembles that problem's
27-point matrix: on the reference unit's refined mesh (1.5e6 nodes) ~0.5 GB of indices and data, the study's
memory peak. :func:`refined_steady_matrix_free` solves the same Newton steps from the same start (the prolonged
default-mesh field) to the same tolerance, with

* the refined Newton matrix applied matrix-free (:class:`~imutherm.thermal.fine_operator.FineOperator`: equal to
  the assembled one to rounding), its residual likewise;
* CG preconditioned by a symmetric two-level cycle: a symmetric z-line Gauss-Seidel sweep (each line of nodes
  along z solved exactly) on a 7-point matrix spectrally
  equivalent to the Newton matrix (:meth:`~imutherm.thermal.fine_operator.FineOperator.seven_point`, 7 of the 27
  entries a row; swept on its stencil by a numba kernel, no CSR matrix formed), the default mesh's own AMG
  V-cycle through the prolongation as the coarse level (the steady solve's hierarchy: nothing set up), a
  symmetric sweep on the residual.

It gives the refined values to the CG tolerance of the assembled solve (:data:`REFINED_CG_RTOL` of the prolonged
field's residual): the same Richardson estimate, answer and bound (``docs/benchmarks/mesh_estimate.md``).

What did not work (the same page): cheaper dual-weighted estimates of the sites' change, from the same residual with
the dual weight from a few damped-Jacobi two-level steps (one step is the hierarchical-basis estimate): on the
reference unit their effectivity against the refined solve's change ranged 0.1-4 per sensor die after 1-12 steps,
and settled falsely (two steps agreeing within 5 % while 2.8x off); no cheaper estimate that kept the answer
within its bound was found.
"""

from __future__ import annotations

import time

import numpy as np

from imutherm import ConvergenceError, InputError
from imutherm.thermal.fine_operator import FineOperator
from imutherm.thermal.refinement import (HOT_SPOT, MESH_ERROR_ORDER, REFINED_CG_RTOL, REFINED_STEP_K,
                                         REFINEMENT_RATIO, RefinementEstimate, bracket, richardson)
from imutherm.workers import one_blas_thread

#: CG steps at most per Newton step [-] (reference unit, default mesh: 13-20 to REFINED_CG_RTOL)
MAX_CG_STEPS = 60
#: the smoother's symmetric Gauss-Seidel sweeps on the 7-point stencil before and after the coarse correction
#: (reference unit, air, load 9: forward/backward 21 CG steps and 4.3 CPU-s; symmetric once 15 and 4.0; symmetric
#: twice 12 and 4.2)
SWEEP_ITERATIONS = 1
#: the smoother's stencil in single precision: it is only the preconditioner's smoother (the Newton matrix, the
#: residual and CG stay double); on the reference unit the same CG steps and refined values to 1e-5 K as in double
#: (w59-memory, docs/benchmarks/mesh_estimate.md), 24 MB less on its refined mesh
SMOOTHER_DTYPE = np.float32
#: the smoother sweeps z lines (each solved exactly), not points: on the reference unit 12/13/12 CG steps instead
#: of 15/16/15 (air/grease/potted) at ~1.5x a point sweep's cost; refined values within 6e-4 K of the point
#: smoother's (r59-refined, docs/benchmarks/mesh_estimate.md)
LINE_SMOOTHER = True


def _two_level(op: FineOperator, prolong, coarse_pc):
    """The symmetric two-level cycle on ``op`` at its current linearisation: symmetric (z-line, :data:`LINE_SMOOTHER`)
    Gauss-Seidel on the 7-point stencil (:meth:`~imutherm.thermal.fine_operator.FineOperator.smoother`), the coarse
    grid's V-cycle ``coarse_pc`` through ``prolong`` on the residual, symmetric Gauss-Seidel on the residual."""
    import scipy.sparse.linalg as spla

    R = prolong.T
    smooth = op.smoother(SMOOTHER_DTYPE, lines=LINE_SMOOTHER)

    def apply(b):
        b = np.ravel(np.asarray(b, float))
        x = np.zeros_like(b)
        for _ in range(SWEEP_ITERATIONS):
            smooth(x, b)
        x += prolong @ (coarse_pc @ (R @ (b - op.apply(x))))
        r = b - op.apply(x)
        e = np.zeros_like(b)
        for _ in range(SWEEP_ITERATIONS):
            smooth(e, r)
        x += e
        return x

    return spla.LinearOperator((op.n, op.n), matvec=apply, dtype=float)


@one_blas_thread
def refined_steady_matrix_free(fine_problem, coarse_T_C, prolong, coarse_pc, probes: dict, coarse_probe_C,
                               coarse_max_C: float, *, ratio: int = REFINEMENT_RATIO,
                               order: float = MESH_ERROR_ORDER, max_newton: int = 4,
                               max_cg: int = MAX_CG_STEPS, history: list | None = None) -> RefinementEstimate:
    """:func:`imutherm.thermal.refinement.refined_steady` without the refined problem's matrix (module
    docstring): the same arguments (``coarse_pc``, the coarse steady solve's preconditioner, required), the same
    :class:`~imutherm.thermal.refinement.RefinementEstimate` (``solver`` 'matrix-free'). Raises
    :class:`~imutherm.ConvergenceError` when a Newton step's CG does not reach its tolerance in ``max_cg`` steps
    (the caller falls back to the assembled solve). ``history``: a list that gets, after each CG step of the first
    Newton step, the sites' change so far [K] (the refined value minus the prolonged one; a benchmark's record of
    how a truncated solve would estimate it)."""
    import scipy.sparse.linalg as spla

    from imutherm.thermal.probes import probe_matrix

    if coarse_pc is None:
        raise InputError("refined_steady_matrix_free: needs the coarse solve's preconditioner (solve_steady(keep=))")
    if not (isinstance(max_cg, int) and max_cg >= 1):
        raise InputError(f"refined_steady_matrix_free: max_cg must be an integer >= 1, got {max_cg!r}")
    t0, c0 = time.perf_counter(), time.process_time()
    op = FineOperator(fine_problem)
    Tc = np.asarray(coarse_T_C, float)
    T = prolong @ Tc
    T[op.fixed] = op.fixed_values[op.fixed]
    A = spla.LinearOperator((op.n, op.n), matvec=op.apply, dtype=float)
    names = tuple(str(n) for n in probes)
    Pm = probe_matrix(fine_problem.grid, np.array([np.asarray(p, float).reshape(3) for p in probes.values()])
                      if probes else np.zeros((0, 3)))
    atol, steps = None, 0
    for _ in range(max_newton):
        r = op.residual(T)
        r_norm = float(np.linalg.norm(r))
        if atol is None:   # the tolerance of every step: relative to the prolonged field's residual
            atol = REFINED_CG_RTOL * r_norm
        elif r_norm <= atol:
            break
        op.linearise(T)
        count = [0]

        def step(x, first=steps == 0):
            count[0] += 1
            if history is not None and first:
                history.append(Pm @ x)
        dT, info = spla.cg(A, r, rtol=0.0, atol=atol, M=_two_level(op, prolong, coarse_pc),
                           maxiter=max_cg, callback=step)
        steps += count[0]
        if info != 0:
            raise ConvergenceError(f"matrix-free refined solve: CG did not reach rtol {REFINED_CG_RTOL:g} in "
                                   f"{max_cg} steps")
        T += dT
        if not op.nonlinear or np.abs(dT).max() <= REFINED_STEP_K:
            break
    names = tuple(names) + (HOT_SPOT,)
    coarse = np.append(np.asarray(coarse_probe_C, float), coarse_max_C)
    fine = np.append(Pm @ T, float(np.max(T)))
    err, extra = richardson(coarse, fine, ratio, order)
    answer, bound = bracket(coarse, fine, ratio, order)
    return RefinementEstimate(names, coarse, fine, err, extra, answer, bound, int(ratio), float(order), int(len(Tc)),
                              int(fine_problem.grid.n_nodes), time.perf_counter() - t0, time.process_time() - c0,
                              solver="matrix-free", cg_steps=steps)
