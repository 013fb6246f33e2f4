"""The reduced transient's cost (issue 59): the shifted AMG hierarchy built on the unshifted one's aggregates
(:func:`imutherm.thermal.linear.amg_like`) preconditions as well as a hierarchy of its own, and the reduced model's
s2s exchange term, precomputed as (Q^T X), is the same right-hand side and Jacobian as the product it replaces."""

import numpy as np
import pytest
import scipy.sparse.linalg as spla

from imutherm.studies.thermal.thermal_study import run_scheme
from imutherm.thermal import linear, reduced_transient
from imutherm.thermal.reduced import linearised, sparse_part

COARSE = dict(mesh_size_mm=6.0, min_cells=1)


@pytest.fixture(scope="module")
def air():
    """The reference unit's air scheme (s2s cavity law) on the coarse mesh: its assembly, secant operator, heat
    capacity and the steady solve's own preconditioner."""
    kept = {}
    res = run_scheme(None, "air", keep=kept, **COARSE)
    asm = kept["assembly"]
    A, _ = linearised(asm, np.asarray(res.steady.T_C))
    return res, asm, A, asm.M, kept["preconditioner"]


def _its(op, b, pc) -> int:
    n = [0]
    _, info = spla.cg(op, b, rtol=1e-4, M=pc, maxiter=2000, callback=lambda _: n.__setitem__(0, n[0] + 1))
    assert info == 0
    return n[0]


def test_amg_like_preconditions_the_shifted_operator_as_its_own_hierarchy(air):
    _, asm, A, M, pc = air
    assert getattr(pc, "hierarchy", None) is not None
    S = (sparse_part(A) + reduced_transient.SHIFTED_PC_S * M).tocsr()
    like, own = linear.amg_like(S, pc), linear.amg_preconditioner(S)
    assert like is not None and len(like.hierarchy.levels) == len(pc.hierarchy.levels)
    for s in (10.0, 1.0 / 0.3, 0.5):
        op = reduced_transient._Shifted(A, M, s)
        n_like, n_own, n_plain = _its(op, asm.F_q, like), _its(op, asm.F_q, own), _its(op, asm.F_q, pc)
        # the same iterations to within a few, and far fewer than the unshifted hierarchy needs at the large shifts
        assert n_like <= n_own + 3, (s, n_like, n_own)
        if s > 1.0:
            assert 2 * n_like < n_plain, (s, n_like, n_plain)


def test_amg_like_needs_a_hierarchy_of_the_same_size(air):
    _, asm, A, M, pc = air
    S = sparse_part(A).tocsr()
    plain = spla.LinearOperator(S.shape, matvec=lambda x: x, dtype=float)
    assert linear.amg_like(S, plain) is None
    assert linear.amg_like(S[:100, :100].tocsr(), pc) is None


def test_the_exchange_term_is_the_product_it_replaces(air):
    from imutherm.thermal.problem import SIGMA, ZERO_C_K
    res, asm, _, M, _ = air
    x = np.asarray(res.steady.T_C) - res.steady.problem.ambient_C
    V = reduced_transient.m_orthonormal([x, np.ones(asm.n), M @ x], M)
    red = reduced_transient.ProjectedModel(asm, V, res.steady.problem.ambient_C)
    ex = [law for law in red.laws if law[0] == "exchange"]
    assert len(ex) == 1
    _, bc, Q, _ = ex[0]
    y = V.T @ (M @ x) * 0.7
    Tk = red.amb + ZERO_C_K + Q @ y
    f_ex = Q.T @ (bc.law.X @ (SIGMA * Tk**4))
    J_ex = Q.T @ (bc.law.X @ (4 * SIGMA * Tk[:, None]**3 * Q))
    saved = red.laws
    red.laws = [law for law in saved if law[0] != "exchange"]
    f_rest, J_rest = red.rhs(0.0, y), red.jac(0.0, y)
    red.laws = saved
    f, J = red.rhs(0.0, y), red.jac(0.0, y)
    assert np.abs(f - (f_rest - f_ex)).max() <= 1e-10 * np.abs(f_ex).max()
    assert np.abs(J - (J_rest - J_ex)).max() <= 1e-10 * np.abs(J_ex).max()


def test_the_conduction_operator_is_k_plus_h_without_its_matrix(air):
    """L = K + H as the secant operator's sparse part less its secant slopes (no nnz-sized array of its own)."""
    from imutherm.thermal.reduced import secant_slopes
    res, asm, A, _, _ = air
    L = reduced_transient._Conduction(sparse_part(A), secant_slopes(asm, np.asarray(res.steady.T_C)))
    ref = asm.pattern.csr(asm.K_data + asm.H_data)
    rng = np.random.default_rng(5)
    x, X = rng.standard_normal(asm.n), rng.standard_normal((asm.n, 3))
    for got, want in ((L @ x, ref @ x), (L @ X, ref @ X)):
        assert got.shape == want.shape
        assert np.abs(got - want).max() <= 1e-12 * np.abs(ref.data).max() * np.abs(x).max() * 27


def test_the_shifted_operators_share_the_pattern(air):
    """A + s M formed on the assembly's pattern: no copy of its indices, and in single precision for the shifted
    hierarchy (the V-cycle's precision)."""
    _, asm, A, M, _ = air
    S = sparse_part(A)
    op = reduced_transient._Shifted(A, M, 2.0)
    single = reduced_transient._Shifted(A, M, 2.0, np.float32)
    for o in (op, single):
        assert np.shares_memory(o.sparse.indices, S.indices) and np.shares_memory(o.sparse.indptr, S.indptr)
    assert op.sparse.dtype == np.float64 and single.sparse.dtype == np.float32
    assert np.abs(single.sparse.data - op.sparse.data).max() <= 1e-6 * np.abs(op.sparse.data).max()


def test_the_recycled_warm_start_is_the_galerkin_solution_on_the_earlier_fields(air):
    """The check's solves start from the Galerkin solution of (A + s M) x = b on the span of the earlier error
    fields: exact when the solution lies in that span, never worse than zero in A + s M's energy norm, and the
    solve still meets |b - Op x| <= rtol |b| (the start changes the cost, not the accuracy)."""
    _, asm, A, M, pc = air
    lin = reduced_transient._Solver(A, M, pc)
    rng = np.random.default_rng(3)
    b1, b2 = asm.F_q, M @ rng.standard_normal(asm.n)
    x1 = lin.solve(reduced_transient._Shifted(A, M, 0.5), b1, 1e-8, recycle=True)
    x2 = lin.solve(reduced_transient._Shifted(A, M, 0.05), b2, 1e-8, recycle=True)
    assert lin.XAX.shape == (2, 2) and np.allclose(lin.XAX, lin.XAX.T)
    op = reduced_transient._Shifted(A, M, 0.2)
    target = 2.0 * x1 - 0.5 * x2
    x0 = lin.warm_start(op, op @ target)
    assert np.linalg.norm(x0 - target) <= 1e-6 * np.linalg.norm(target)
    b = asm.F_q + 0.1 * b2   # a right-hand side whose solution is not in the span: the start beats zero
    x0 = lin.warm_start(op, b)
    assert x0 is not None and np.linalg.norm(b - op @ x0) < 0.5 * np.linalg.norm(b)
    its0 = lin.its
    x = lin.solve(op, b, 1e-2, recycle=True)
    assert np.linalg.norm(b - op @ x) <= 1e-2 * np.linalg.norm(b)
    n = [0]
    spla.cg(op, b, rtol=1e-2, atol=0.0, M=lin._preconditioner(op), callback=lambda _: n.__setitem__(0, n[0] + 1))
    assert lin.its - its0 < n[0], ("the Galerkin start should save iterations here", lin.its - its0, n[0])


def test_pcg_is_scipys_cg_step_for_step(air):
    """The solver's own CG (issue 59: a start's residual passed in, the updated residual returned) takes scipy's
    iterates and stopping test: the same iteration count and solution to rounding, from zero and from a start."""
    _, asm, A, M, pc = air
    op = reduced_transient._Shifted(A, M, 0.5)
    b = asm.F_q
    x0 = 0.5 * reduced_transient.pcg(op, b, None, None, pc, 1e-3, 500)[0]
    for start in (None, x0):
        n = [0]
        ref, info = spla.cg(op, b, x0=None if start is None else start.copy(), rtol=1e-6, atol=0.0, M=pc,
                            maxiter=500, callback=lambda _: n.__setitem__(0, n[0] + 1))
        assert info == 0
        r0 = None if start is None else b - op @ start
        x, r, its, info = reduced_transient.pcg(op, b, start, r0, pc, 1e-6, 500)
        assert info == 0 and its == n[0] > 3
        assert np.abs(x - ref).max() <= 1e-10 * np.abs(ref).max()
        # the updated residual is the true one to rounding, and meets the test
        assert np.linalg.norm(r - (b - op @ x)) <= 1e-9 * np.linalg.norm(b)
        assert np.linalg.norm(r) < 1e-6 * np.linalg.norm(b)
    # not converged within maxiter: info is maxiter, as scipy's
    assert reduced_transient.pcg(op, b, None, None, pc, 1e-12, 2)[2:] == (2, 2)


def test_the_shifted_operators_share_one_buffer_and_the_gram_rows_are_exact(air):
    """:meth:`_Solver.shifted` forms A + s M in one reused nnz-sized buffer (the same operator as a fresh one), and
    the warm starts' Gram rows, taken from the solve's own residual (Op x = b - r), equal X^T A X and X^T M X."""
    _, asm, A, M, pc = air
    lin = reduced_transient._Solver(A, M, pc)
    x = np.random.default_rng(5).standard_normal(asm.n)
    op1 = lin.shifted(0.3)
    y1 = op1 @ x
    assert np.abs(y1 - reduced_transient._Shifted(A, M, 0.3) @ x).max() <= 1e-12 * np.abs(y1).max()
    op2 = lin.shifted(2.0)
    assert np.shares_memory(op1.sparse.data, op2.sparse.data)
    y2 = op2 @ x
    assert np.abs(y2 - reduced_transient._Shifted(A, M, 2.0) @ x).max() <= 1e-12 * np.abs(y2).max()
    b1, b2 = asm.F_q, M @ x
    x1 = lin.solve(lin.shifted(0.5), b1, 1e-6, recycle=True)
    x2 = lin.solve(lin.shifted(0.05), b2, 1e-6, recycle=True)
    X = np.column_stack([x1, x2])
    XAX, XMX = X.T @ (A @ X), X.T @ (M @ X)
    assert np.abs(lin.XAX - XAX).max() <= 1e-6 * np.abs(XAX).max()
    assert np.abs(lin.XMX - XMX).max() <= 1e-12 * np.abs(XMX).max()
