"""The compiled ray march of the view factors against the kept numpy march: the same hits, ray for ray."""

import numpy as np
import pytest

from imutherm.geometry.grid import TensorGrid
from imutherm.thermal.cavity_radiation import _emit, find_patches, view_factors
from imutherm.thermal.ray_march import march, march_numpy, place_rays


def _cavity_with_obstacles():
    """A non-uniform grid: an air box in solid walls (part 0) with two blocks (parts 2, 3) and a thin plate
    (part 4) inside, cell edges from 0.3 to 2.5 mm."""
    rng = np.random.default_rng(11)

    def axis(n, total):
        h = rng.uniform(0.3e-3, 2.5e-3, n)
        return np.concatenate([[0.0], np.cumsum(h)]) * total / h.sum()
    xs, ys, zs = axis(22, 0.04), axis(17, 0.03), axis(11, 0.015)
    cp = np.zeros((22, 17, 11), int)
    cp[1:-1, 1:-1, 1:-1] = 1
    cp[4:9, 3:7, 1:5] = 2
    cp[12:18, 9:15, 6:10] = 3
    cp[3:19, 2:15, 5] = 4   # a plate across most of the height's middle, with gaps at its edges
    cp[10:12, 6:9, 5] = 1   # a hole in the plate
    return TensorGrid(xs, ys, zs, cp, ("wall", "air", "a", "b", "plate"), {})


def test_compiled_march_hits_the_same_patches_as_the_numpy_march():
    g = _cavity_with_obstacles()
    air = g.cell_part == 1
    pt = find_patches(g, air, 3.0)
    pos, dirs, cell, src = _emit(pt, g, 64, np.random.default_rng(4))
    ref = march_numpy(g, air, pt.face_patch, pos, dirs, cell)
    hit, crossed = march(g, air, pt.face_patch, pos, dirs, cell, counts=True)
    assert len(pos) > 10_000 and crossed > 5 * len(pos)
    assert (ref >= 0).all()                          # an enclosure: every ray hits a patch
    assert len(np.unique(ref)) > 0.9 * pt.n          # the hits spread over the patches (the test is not trivial)
    assert np.array_equal(hit, ref)


def test_compiled_march_on_ties_axis_rays_and_leaving_rays():
    """Rays through cell corners (tmax ties: the first axis wins in both), along an axis (zero components)
    and out of the grid (no hit, -1) on a uniform grid where the ties are exact."""
    xs = ys = zs = np.linspace(0.0, 8.0, 9)
    cp = np.ones((8, 8, 8), int)
    cp[0] = 0
    cp[5, 2:6, 2:6] = 2
    g = TensorGrid(xs, ys, zs, cp, ("wall", "air", "block"), {})
    air = g.cell_part == 1
    face_patch = tuple(np.arange(np.prod(s)).reshape(s) for s in ((9, 8, 8), (8, 9, 8), (8, 8, 9)))
    d = np.array([[1, 1, 1], [-1, 1, 0], [1, 0, 0], [0, 0, -1], [-1, -1, -1], [1, 1, 0], [0, 1, 0]], float)
    d /= np.linalg.norm(d, axis=1)[:, None]
    pos = np.array([[2.0, 2.0, 2.0], [3.0, 3.0, 3.5], [1.5, 3.5, 3.5], [1.5, 3.5, 3.5], [4.0, 4.0, 4.0],
                    [1.0, 1.0, 1.0], [3.5, 3.5, 3.5]])
    cell = np.array([[2, 2, 2], [2, 3, 3], [1, 3, 3], [1, 3, 3], [3, 3, 3], [1, 1, 1], [3, 3, 3]])
    ref = march_numpy(g, air, face_patch, pos, d, cell)
    hit = march(g, air, face_patch, pos, d, cell)
    assert np.array_equal(hit, ref)
    assert ref[3] == -1 and ref[6] == -1 and ref[2] >= 0   # out through the open top and side; into the block


def test_view_factors_of_the_box_unchanged_by_the_compiled_march(monkeypatch):
    """view_factors with the numpy march put back: the same F bit for bit (the same rays, the same hits)."""
    import imutherm.thermal.cavity_radiation as cr

    g = _cavity_with_obstacles()
    air = g.cell_part == 1
    pt = find_patches(g, air, 3.0)
    a = view_factors(g, air, pt, rays=32, rng=np.random.default_rng(9), chunk=5000)
    monkeypatch.setattr(cr, "march", march_numpy)
    b = view_factors(g, air, pt, rays=32, rng=np.random.default_rng(9), chunk=5000)
    assert np.array_equal(a.F, b.F) and a.lost == b.lost == 0


@pytest.mark.slow
def test_compiled_march_on_the_reference_unit_air_scheme():
    """The reference unit's air scheme at the study's mesh and patch edge: all 504,800 rays hit the same patch."""
    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.layout import load_layout
    from imutherm.geometry.mesh import DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS, build_mesh
    from imutherm.thermal.cavity_radiation import choose_patch_mm
    from imutherm.unit.model import ModelOptions

    geo = build_geometry(load_layout(None), "air")
    g = build_mesh(geo, DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS)
    air = g.cell_part == g.part_names.index("fill")
    opt = ModelOptions()
    pt = choose_patch_mm(g, air, opt.cavity_patch_mm, opt.cavity_max_patches).patches
    pos, dirs, cell, _ = _emit(pt, g, 400, np.random.default_rng(0))
    assert np.array_equal(march(g, air, pt.face_patch, pos, dirs, cell),
                          march_numpy(g, air, pt.face_patch, pos, dirs, cell))


def test_march_refuses_mismatched_arrays():
    g = _cavity_with_obstacles()
    air = g.cell_part == 1
    pt = find_patches(g, air, 3.0)
    with pytest.raises(ValueError, match=r"\(R, 3\)"):
        march(g, air, pt.face_patch, np.zeros((4, 3)), np.zeros((4, 2)), np.zeros((4, 3), int))
    with pytest.raises(ValueError, match="air mask shape"):
        march(g, air[:-1], pt.face_patch, np.zeros((4, 3)), np.ones((4, 3)), np.zeros((4, 3), int))


def test_sparse_enforcement_equals_the_dense_iteration():
    """_enforce's sparse products against the same balancing iteration with dense ones: F to 1e-12."""
    from imutherm.thermal.cavity_radiation import _enforce

    g = _cavity_with_obstacles()
    air = g.cell_part == 1
    pt = find_patches(g, air, 3.0)
    pos, dirs, cell, src = _emit(pt, g, 48, np.random.default_rng(2))
    hit = march(g, air, pt.face_patch, pos, dirs, cell)
    F_raw = np.zeros((pt.n, pt.n))
    np.add.at(F_raw, (src, hit), 1.0 / 48)
    S = pt.area[:, None] * F_raw
    S = 0.5 * (S + S.T)
    d = np.ones(pt.n)
    for _ in range(5000):
        d = np.sqrt(d * pt.area / (S @ d))
        if np.max(np.abs(d * (S @ d) / pt.area - 1.0)) < 1e-14:
            break
    dense = d[:, None] * S * d[None, :] / pt.area[:, None]
    F = _enforce(F_raw, pt.area)
    assert (F_raw != 0).mean() < 0.5          # sparse rows: the case the sparse products are for
    assert np.abs(F - dense).max() < 1e-12 and np.abs(F.sum(axis=1) - 1.0).max() < 1e-12


def test_compiled_placement_equals_the_numpy_placement(monkeypatch):
    """The rays' origins, directions and start cells from the compiled placement and from the numpy one, given
    the same random numbers: identical (and so are the hits and view factors downstream)."""
    import imutherm.thermal.cavity_radiation as cr
    from imutherm.thermal.ray_march import place_rays_numpy

    g = _cavity_with_obstacles()
    air = g.cell_part == 1
    pt = find_patches(g, air, 3.0)
    seen = {}

    def spy(*args):
        seen["args"] = args
        return place_rays(*args)
    monkeypatch.setattr(cr, "place_rays", spy)
    pos, dirs, cell, _ = _emit(pt, g, 50, np.random.default_rng(8))
    ref = place_rays_numpy(*seen["args"])
    for a, b in zip((pos, dirs, cell), ref):
        assert a.dtype == b.dtype and np.array_equal(a, b)
    assert np.allclose(np.linalg.norm(dirs, axis=1), 1.0)
    assert air[cell[:, 0], cell[:, 1], cell[:, 2]].all()   # every ray starts in an air cell


def test_exchange_matrix_equals_the_direct_radiosity_form():
    """exchange_matrix's push-through form against X = A (I - F) M^-1 E solved directly (M = I - (I - E) F), on
    the box with its obstacles, emissivities from 0 to 1: the same X to round-off."""
    from imutherm.thermal.cavity_radiation import exchange_matrix

    g = _cavity_with_obstacles()
    air = g.cell_part == 1
    pt = find_patches(g, air, 3.0)
    F = view_factors(g, air, pt, rays=64, rng=np.random.default_rng(1)).F
    eps = np.random.default_rng(5).uniform(0.0, 1.0, pt.n)
    eps[:5], eps[5:10] = 1.0, 0.0
    n = pt.n
    Minv_E = np.linalg.solve(np.eye(n) - (1.0 - eps)[:, None] * F, np.diag(eps))
    ref = pt.area[:, None] * (Minv_E - F @ Minv_E)
    ref = 0.5 * (ref + ref.T)
    ref[np.diag_indices(n)] -= ref.sum(axis=1)
    X = exchange_matrix(F, pt.area, eps)
    assert np.abs(X - ref).max() < 1e-12 * np.abs(ref).max()
    assert np.abs(X - X.T).max() == 0.0 and np.abs(X.sum(axis=1)).max() < 1e-12 * np.abs(X).max()


def test_the_refined_law_forms_no_exchange_matrix(monkeypatch):
    """CavityExchange.refined takes the coarse law's X (a scaled law's too) instead of solving for it again."""
    import imutherm.thermal.cavity_radiation as cr
    from imutherm.geometry.mesh import refine_grid

    g = _cavity_with_obstacles()
    law = cr.cavity_exchange(g, g.cell_part == 1, [0.8, 0.0, 0.9, 0.6, 0.3], patch_mm=3.0, rays=32)
    half = law.scaled(0.5)

    def refused(*args, **kwargs):
        raise AssertionError("exchange_matrix called")
    monkeypatch.setattr(cr, "exchange_matrix", refused)
    fine = refine_grid(g, 2)
    a, b = law.refined(fine, 2), half.refined(fine, 2)
    assert a.X is law.X and b.X is half.X and np.array_equal(b.X, 0.5 * law.X)
    assert a._absX is law._absX and b._absX is half._absX and a.patches.P.shape == (law.patches.n, fine.n_nodes)
    with pytest.raises(Exception, match="exchange matrix of shape"):
        cr.CavityExchange(law.patches, law.view, law.emissivity, X=law.X[:-1])
