"""Assembly checks of the Q1 tensor-grid matrices: row sums, mass, loads, patch test, scikit-fem agreement."""

import numpy as np
import pytest
import scipy.sparse as sp

from imutherm.thermal import Contact, Convection, HeatFlux, Radiation, ThermalProblem, assemble
from imutherm.thermal.assembly import KX_REF, M_REF
from imutherm.thermal.verification import box_grid


def _random_grid(rng, shape=(5, 4, 3), parts=2):
    axes = [np.concatenate([[0.0], np.cumsum(rng.uniform(0.5e-3, 3e-3, n))]) for n in shape]
    cp = rng.integers(0, parts, shape)
    return box_grid(*axes, parts=cp, names=tuple(f"p{i}" for i in range(parts)))


@pytest.fixture
def hetero():
    rng = np.random.default_rng(7)
    g = _random_grid(rng)
    k = rng.uniform(0.2, 200, (g.n_cells, 3))
    rc = rng.uniform(1e3, 3e6, g.n_cells)
    q = rng.uniform(0, 1e6, g.n_cells)
    pr = ThermalProblem(g, k, rc, q, 20.0, {"xmin": Convection(25.0, 10.0), "zmax": Radiation(0.5),
                                            "ymin": HeatFlux(300.0), "zmin": Contact(800.0, 30.0)})
    return pr, assemble(pr)


def test_reference_matrices():
    # unit cube: a constant is in the kernel, mass sums to the volume
    assert np.allclose(KX_REF.sum(axis=1), 0)
    assert M_REF.sum() == pytest.approx(1.0)


def test_stiffness_rows_sum_to_zero_and_symmetric(hetero):
    pr, asm = hetero
    K = asm.K
    scale = np.abs(K).sum(axis=1).max()
    assert np.abs(np.asarray(K.sum(axis=1))).max() < 1e-13 * scale
    assert abs(K - K.T).max() == 0.0
    assert np.all(K.diagonal() > 0)


def test_mass_sums_to_total_heat_capacity(hetero):
    pr, asm = hetero
    total = float(np.dot(pr.rho_c, pr.grid.cell_volumes().ravel()))
    assert asm.M.sum() == pytest.approx(total, rel=1e-13)
    lumped = assemble(pr, lumped_mass=True).M
    assert lumped.sum() == pytest.approx(total, rel=1e-13)
    assert abs(lumped - sp.diags(lumped.diagonal())).max() == 0     # diagonal only


def test_loads_sum_to_power_and_boundary_terms(hetero):
    pr, asm = hetero
    assert asm.F_q.sum() == pytest.approx(pr.power_W, rel=1e-13)
    g = pr.grid
    area_x = (g.ys[-1] - g.ys[0]) * (g.zs[-1] - g.zs[0])
    area_y = (g.xs[-1] - g.xs[0]) * (g.zs[-1] - g.zs[0])
    area_z = (g.xs[-1] - g.xs[0]) * (g.ys[-1] - g.ys[0])
    # H sums to (h A) over the convection and contact faces
    assert asm.H.sum() == pytest.approx(25.0 * area_x + 800.0 * area_z, rel=1e-13)
    # F_bc: h T_ref A + q A
    assert asm.F_bc.sum() == pytest.approx(25.0 * 10.0 * area_x + 800.0 * 30.0 * area_z + 300.0 * area_y,
                                           rel=1e-13)
    # nonlinear law: lumped nodal areas sum to the face area
    assert asm.nonlinear[0].weights.sum() == pytest.approx(area_z, rel=1e-13)


def test_patch_test_linear_field_is_reproduced():
    """A linear field with uniform anisotropic k solves the interior equations exactly."""
    rng = np.random.default_rng(3)
    g = _random_grid(rng, (6, 5, 4), parts=1)
    pr = ThermalProblem(g, (3.0, 0.5, 40.0), 1.0, 0.0, 0.0, {})
    K = assemble(pr).K
    X = g.node_coordinates()
    T = 2.0 + 300 * X[:, 0] - 100 * X[:, 1] + 50 * X[:, 2]
    r = K @ T
    nx, ny, nz = g.shape
    ids = np.arange(g.n_nodes).reshape(nx + 1, ny + 1, nz + 1)
    inner = ids[1:-1, 1:-1, 1:-1].ravel()
    assert np.abs(r[inner]).max() < 1e-12 * np.abs(K).max() * np.abs(T).max()


def test_patch_test_through_the_solver():
    """Fixed temperatures on two opposite faces of a non-uniform grid: the linear field is exact everywhere."""
    from imutherm.thermal import FixedTemperature, solve_steady

    rng = np.random.default_rng(5)
    g = _random_grid(rng, (6, 5, 4), parts=1)
    pr = ThermalProblem(g, (3.0, 0.5, 40.0), 1.0, 0.0, 0.0,
                        {"xmin": FixedTemperature(10.0), "xmax": FixedTemperature(70.0)})
    r = solve_steady(pr)
    x = g.node_coordinates()[:, 0]
    assert np.abs(r.T_C - (10 + 60 * x / x.max())).max() < 1e-10


def test_matches_scikit_fem():
    """Stiffness and mass agree with scikit-fem's ElementHex1 on the same non-uniform grid."""
    skfem = pytest.importorskip("skfem")
    from skfem.helpers import dot, grad

    rng = np.random.default_rng(11)
    g = _random_grid(rng, (4, 3, 3), parts=1)
    asm = assemble(ThermalProblem(g, 1.0, 1.0, 0.0, 0.0, {}))
    mesh = skfem.MeshHex.init_tensor(g.xs, g.ys, g.zs)
    basis = skfem.Basis(mesh, skfem.ElementHex1())
    Ks = skfem.BilinearForm(lambda u, v, w: dot(grad(u), grad(v))).assemble(basis)
    Ms = skfem.BilinearForm(lambda u, v, w: u * v).assemble(basis)
    P, X = mesh.p.T, g.node_coordinates()
    key = lambda A: np.lexsort((A[:, 2], A[:, 1], A[:, 0]))  # noqa: E731
    perm = np.empty(len(P), dtype=int)
    perm[key(X)] = key(P)
    assert abs(Ks[perm][:, perm] - asm.K).max() < 1e-12 * abs(Ks).max()
    assert abs(Ms[perm][:, perm] - asm.M).max() < 1e-12 * abs(Ms).max()


def test_all_matrices_share_one_pattern(hetero):
    pr, asm = hetero
    K, M, H = asm.K, asm.M, asm.H
    assert np.array_equal(K.indptr, M.indptr) and np.array_equal(K.indices, H.indices)
    assert K.has_sorted_indices


def test_merged_linear_laws_are_k_plus_h(hetero):
    """``merge_linear`` (the refined mesh-error solve's assembly) gives K + H in one array, the rest unchanged; the
    rows of the pattern, built at first use, are each entry's row."""
    pr, asm = hetero
    merged = assemble(pr, mass=False, cache_pattern=False, merge_linear=True)
    assert merged.H_data.size == 0 and merged.M_data is None
    assert np.allclose(merged.K_data, asm.K_data + asm.H_data, rtol=1e-13, atol=0.0)
    assert np.array_equal(merged.F_q, asm.F_q) and np.array_equal(merged.F_bc, asm.F_bc)
    assert [bc.face for bc in merged.nonlinear] == [bc.face for bc in asm.nonlinear]
    coo = asm.K.tocoo()
    assert np.array_equal(merged.pattern.rows, coo.row)


@pytest.mark.parametrize("block_bytes", [None, 27 * 8 * 20])
def test_data_made_slab_by_slab_is_the_stencil_s(hetero, monkeypatch, block_bytes):
    """The CSR data made in slabs of node planes (no (27, Nx, Ny, Nz) array; here also one plane of nodes a slab)
    is the whole stencil's, bit for bit, and each entry's position is its (row, offset)."""
    from imutherm.thermal import assembly
    from imutherm.thermal.assembly import mass_stencil, stiffness_stencil

    pr, asm = hetero
    if block_bytes is not None:
        monkeypatch.setattr(assembly, "STENCIL_BLOCK_BYTES", block_bytes)
        asm = assemble(pr)
    assert np.array_equal(asm.K_data, asm.pattern.data(stiffness_stencil(pr)))
    assert np.array_equal(asm.M_data, asm.pattern.data(mass_stencil(pr)))
    pat = asm.pattern
    rows = np.arange(pat.n)
    for o in (0, 4, 13, 26):
        has = pat.valid()[:, o]
        pos = pat.positions(rows[has], o)
        assert np.array_equal(pat.rows[pos], rows[has]) and np.all(np.diff(pos) > 0)


def test_the_pattern_made_in_row_blocks_is_the_whole_one(monkeypatch):
    """The column indices made a block of rows at a time are those of every row at once (sorted, row + offset)."""
    from imutherm.thermal import assembly

    whole = assembly.Pattern((5, 4, 3))
    monkeypatch.setattr(assembly, "_ROW_BLOCK", 7)
    blocks = assembly.Pattern((5, 4, 3))
    assert np.array_equal(whole.indices, blocks.indices) and np.array_equal(whole.indptr, blocks.indptr)
    A = sp.csr_matrix((np.ones(blocks.nnz), blocks.indices, blocks.indptr), shape=(blocks.n, blocks.n))
    assert A.has_sorted_indices and (A - A.T).nnz == 0 and A.diagonal().all()


@pytest.mark.parametrize("shape", [(1, 1, 1), (2, 1, 3), (5, 4, 3), (1, 6, 2), (3, 3, 3), (4, 2, 1)])
def test_the_row_counts_from_the_axes_are_the_masks(shape):
    """The row starts and diagonal positions, made from each axis's in-grid offsets, are those the neighbour mask
    gives (rows' in-grid neighbours counted; the diagonal where the row's own column is stored)."""
    from imutherm.thermal import assembly

    pat = assembly.Pattern(shape)
    v = pat.valid()
    assert np.array_equal(np.diff(pat.indptr), v.sum(axis=1))
    assert np.array_equal(pat.diag_pos - pat.indptr[:-1], v[:, :13].sum(axis=1))
    assert np.array_equal(pat.indices[pat.diag_pos], np.arange(pat.n))
