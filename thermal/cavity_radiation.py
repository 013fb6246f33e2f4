"""Surface-to-surface radiation inside the cavity: patches, view factors, radiosity.

The faces that bound each air region (connected air cells) are grouped into
*patches*: per air region, bounding part, face orientation and face plane, cut
into tiles of ``patch_mm`` along the two in-plane axes. View factors between the
patches come from seeded Monte-Carlo ray casting: from every patch, rays leave
with stratified, cosine-weighted (diffuse) directions from stratified points on
its face cells and are marched cell by cell through the grid's air cells (an
exact 3-D DDA on the non-uniform tensor grid, compiled: :mod:`imutherm.thermal.ray_march`)
until they hit a solid face, so occlusion by every part inside the region is exact. The estimate is then made
reciprocal (A_i F_ij = A_j F_ji) and closed (sum_j F_ij = 1) by a symmetric
scaling; both residuals are reported before and after (:class:`ViewFactors`).

Radiosity of a grey, diffuse enclosure (Incropera & DeWitt, 6th ed., §13.3, the
radiosity equations of an N-surface enclosure): with ``E = diag(eps)``, the net heat leaving the patches is

    Q = X Eb,   X = diag(A) (I - F) (I - (I - E) F)^-1 E,   Eb = sigma T^4,

X symmetric with zero row sums (an isothermal enclosure exchanges nothing).
In the finite-element model the patch temperature is the area average of its
face-cell nodal temperatures, ``T_p = P T``, and the patch heat goes back to the
same nodes, ``N(T) = P^T X sigma (P T)^4`` (conservative: sum N = 0).

How it enters the solver: as a nonlinear law (:class:`CavityExchange`) on the
nodes of the cavity surfaces, evaluated exactly (σT⁴, no linearisation error at
the steady state). Its exact Jacobian ``P^T X diag(4 sigma T_p^3) P`` couples
every patch with every other and does not fit the solver's 27-point sparse
pattern, so the law hands the solver a diagonal (Jacobi) slope instead:
``D_n = 1/2 sum_p P_pn sum_q |X_pq| 4 sigma T_q^3``, half the Gershgorin bound
of the exact one. With D that large, ``L + 2D - B`` is positive semi-definite
(``B`` the exact Jacobian at a uniform temperature: X is a weighted graph Laplacian,
so ``X <= 2 diag(X) <= diag(sum_q |X_pq|)``, and ``(P v)_p^2 <= sum_n P_pn v_n^2``
as P averages, hence ``B <= 2D``; ``L`` conduction and boundary, positive definite), so the fixed-point iteration
with that slope converges for the linearised exchange (iteration matrix
``(L + D)^-1 (D - B)``, eigenvalues in (-1, 1)), but only linearly: 13 Newton iterations on the
reference unit's air scheme. The steady Newton step therefore solves with the exchange's coupling
itself, in its symmetric form ``P^T diag(s) X diag(s) P`` with ``s^2 = 4 sigma T_p^3``
(:meth:`CavityExchange.symmetric_jacobian`), applied as a low-rank product inside CG and
preconditioned by the AMG hierarchy of the matrix with the diagonal slope: 5 Newton iterations and
~40 % of the CG iterations there, the same converged field (the residual is the exact σT⁴ in both).
The transient linearises the law once per step
about the start-of-step field like the other nonlinear laws: the diagonal part
is implicit, the exchange between patches lags one step, which is
unconditionally stable for the same reason and first order in the step.
"""

from __future__ import annotations

import copy

import time
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
from scipy import ndimage

from imutherm import InputError
from imutherm.geometry.grid import TensorGrid
from imutherm.thermal.problem import SIGMA, ZERO_C_K
from imutherm.thermal.ray_march import march, place_rays

#: default patch edge [mm]: the convergence study in docs/benchmarks/cavity_radiation.md (air scheme tp1 within 0.1 K of 2 mm patches)
DEFAULT_PATCH_MM = 5.0
#: default rays per patch (stratified); the view-factor noise is ~sqrt(F/rays) per pair before
#: reciprocity averaging, and the unit's rises change by < 0.05 K from 256 to 1024 rays (docs/benchmarks/cavity_radiation.md)
DEFAULT_RAYS = 400
#: emissivity of an interior surface whose material gives none [-]. Assumed: nylon standoffs, solder mask
#: over via fields and silicone grease are non-metallic surfaces, 0.85-0.95 (Incropera & DeWitt, 6th ed.,
#: Table A.11: paints, plastics, rubber ~0.9); the bare copper edges of exposed pads are < 1 % of the area.
DEFAULT_INTERIOR_EMISSIVITY = 0.9
#: fraction of the Gershgorin bound of the exchange's Jacobian handed to the solver as its diagonal slope
#: (>= 1/2 keeps the iteration convergent, see the module docstring; docs/benchmarks/cavity_radiation.md gives the measured rates)
JACOBI_FRACTION = 0.5


@dataclass(frozen=True)
class Patches:
    """The radiating patches of the air regions of a grid.

    region : (n,) int, air region of each patch (0-based)
    part : (n,) int, index of the bounding solid part (``grid.part_names``)
    axis : (n,) int, normal axis; sign : (n,) int, +1/-1 the normal pointing into the air
    area : (n,) [m^2]; centre : (n, 3) [m] area-weighted centre
    P : sparse (n, n_nodes), patch average of the nodal temperatures [-] (rows sum to 1)
    n_regions : int; region_cells : (n_regions,) air cells per region
    face_patch : tuple of three int arrays, patch of each grid face normal to x, y, z
        (shapes (nx+1, ny, nz), (nx, ny+1, nz), (nx, ny, nz+1); -1: no patch); None where no rays are traced
        (a chunk of patches, :func:`refined_patches`)
    fc_patch, fc_axis, fc_plane, fc_u, fc_v : per face cell: patch, normal axis, node-plane index and
        the (u, v) cell indices on the two other axes in increasing axis order
    """

    region: np.ndarray
    part: np.ndarray
    axis: np.ndarray
    sign: np.ndarray
    area: np.ndarray
    centre: np.ndarray
    P: sp.csr_matrix
    n_regions: int
    region_cells: np.ndarray
    face_patch: tuple
    fc_patch: np.ndarray
    fc_axis: np.ndarray
    fc_plane: np.ndarray
    fc_u: np.ndarray
    fc_v: np.ndarray

    @property
    def n(self) -> int:
        return len(self.area)


def find_patches(grid: TensorGrid, air: np.ndarray, patch_mm: float = DEFAULT_PATCH_MM) -> Patches:
    """Air regions of ``air`` (cell mask, 6-connected) and their bounding faces grouped into patches.

    A region touching the outer boundary of the grid is not an enclosure: InputError.
    """
    if not (np.isfinite(patch_mm) and patch_mm > 0):
        raise InputError(f"cavity patch size must be a finite number > 0 [mm], got {patch_mm!r}")
    air = np.asarray(air, bool)
    if air.shape != grid.shape:
        raise InputError(f"cavity radiation: air mask shape {air.shape} differs from the grid's {grid.shape}")
    labels, n_reg = ndimage.label(air)  # default structure: face (6-) connectivity
    if n_reg == 0:
        raise InputError("cavity radiation: the grid has no air cells")
    for ax in range(3):
        for end in (0, -1):
            if np.take(air, end, axis=ax).any():
                raise InputError("cavity radiation: an air region reaches the outer boundary of the grid; "
                                 "surface-to-surface exchange needs air enclosed by solid faces")
    lines = (grid.xs, grid.ys, grid.zs)
    patch_m = patch_mm * 1e-3
    cp = grid.cell_part
    recs = []  # per face cell: axis, plane, u, v, region, part, sign, area, centre(3)
    for ax in range(3):
        u_ax, v_ax = [a for a in range(3) if a != ax]
        for sign in (1, -1):
            # sign +1: solid at lower index, air at upper (normal +ax into the air)
            lo_air = np.moveaxis(air, ax, 0)
            a_air = lo_air[1:] if sign == 1 else lo_air[:-1]
            a_sol = ~lo_air[:-1] if sign == 1 else ~lo_air[1:]
            idx = np.nonzero(a_air & a_sol)
            i0 = idx[0]  # index along ax of the lower cell
            plane = i0 + 1
            air_i = i0 + 1 if sign == 1 else i0
            sol_i = i0 if sign == 1 else i0 + 1

            def full(i):
                out = [None] * 3
                out[ax], out[u_ax], out[v_ax] = i, idx[1], idx[2]
                return tuple(out)
            region = labels[full(air_i)] - 1
            part = cp[full(sol_i)]
            hu, hv = np.diff(lines[u_ax])[idx[1]], np.diff(lines[v_ax])[idx[2]]
            cu = 0.5 * (lines[u_ax][idx[1]] + lines[u_ax][idx[1] + 1])
            cv = 0.5 * (lines[v_ax][idx[2]] + lines[v_ax][idx[2] + 1])
            c = np.zeros((len(i0), 3))
            c[:, ax], c[:, u_ax], c[:, v_ax] = lines[ax][plane], cu, cv
            recs.append(dict(axis=np.full(len(i0), ax), plane=plane, u=idx[1], v=idx[2], region=region,
                             part=part, sign=np.full(len(i0), sign), area=hu * hv, centre=c,
                             tu=np.floor((cu - lines[u_ax][0]) / patch_m).astype(np.int64),
                             tv=np.floor((cv - lines[v_ax][0]) / patch_m).astype(np.int64)))
    fc = {k: np.concatenate([r[k] for r in recs]) for k in recs[0]}
    key = np.column_stack([fc["region"], fc["part"], fc["axis"], fc["sign"], fc["plane"], fc["tu"], fc["tv"]])
    _, patch_of_fc = np.unique(key, axis=0, return_inverse=True)
    patch_of_fc = patch_of_fc.ravel()
    n = int(patch_of_fc.max()) + 1
    area = np.bincount(patch_of_fc, weights=fc["area"], minlength=n)
    centre = np.column_stack([np.bincount(patch_of_fc, weights=fc["area"] * fc["centre"][:, d], minlength=n)
                              for d in range(3)]) / area[:, None]
    first = np.zeros(n, dtype=np.int64)
    first[patch_of_fc[::-1]] = np.arange(len(patch_of_fc))[::-1]
    # patch averaging: each face cell gives area/4 to each of its four corner nodes
    Nn = tuple(s + 1 for s in grid.shape)
    rows, cols, vals = [], [], []
    for a in (0, 1):
        for b in (0, 1):
            ijk = np.zeros((len(patch_of_fc), 3), dtype=np.int64)
            for ax in range(3):
                m = fc["axis"] == ax
                u_ax, v_ax = [d for d in range(3) if d != ax]
                ijk[m, ax] = fc["plane"][m]
                ijk[m, u_ax] = fc["u"][m] + a
                ijk[m, v_ax] = fc["v"][m] + b
            rows.append(patch_of_fc)
            cols.append((ijk[:, 0] * Nn[1] + ijk[:, 1]) * Nn[2] + ijk[:, 2])
            vals.append(fc["area"] / 4.0 / area[patch_of_fc])
    P = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                      shape=(n, grid.n_nodes))
    face_patch = []
    nx, ny, nz = grid.shape
    for ax in range(3):
        shp = [nx, ny, nz]
        shp[ax] += 1
        fp = np.full(shp, -1, dtype=np.int64)
        m = fc["axis"] == ax
        u_ax, v_ax = [d for d in range(3) if d != ax]
        ind = [None] * 3
        ind[ax], ind[u_ax], ind[v_ax] = fc["plane"][m], fc["u"][m], fc["v"][m]
        fp[tuple(ind)] = patch_of_fc[m]
        face_patch.append(fp)
    return Patches(region=fc["region"][first], part=fc["part"][first], axis=fc["axis"][first],
                   sign=fc["sign"][first], area=area, centre=centre, P=P, n_regions=int(n_reg),
                   region_cells=np.bincount(labels.ravel())[1:], face_patch=tuple(face_patch),
                   fc_patch=patch_of_fc, fc_axis=fc["axis"], fc_plane=fc["plane"], fc_u=fc["u"], fc_v=fc["v"])


#: the patch-edge rule (:func:`choose_patch_mm`, the CLI's default): most patches the s2s law exchanges between
#: before its patch edge grows. The dense exchange costs ~n^2 memory and n^2..n^3 time (:mod:`imutherm.budget`);
#: this keeps it near the reference unit's (1,262 patches of 5 mm at the default mesh), so a larger housing's
#: exchange costs about what the reference's does instead of 5.4^2 times more (cube-main, 150 x 120 mm board)
AUTO_MAX_PATCHES = 1600
#: the coarsest patch edge the rule chooses [mm]: the convergence study's coarsest (docs/benchmarks/cavity_radiation.md,
#: reference unit, air scheme: tp1 24.067 K at 10 mm, 24.075 K at 5 mm, 24.073 K at 2.5 mm patches); beyond it the
#: patch count is left above the target and the cost limits of :func:`imutherm.budget.check_s2s_cost` apply
AUTO_MAX_PATCH_MM = 10.0


@dataclass(frozen=True)
class PatchChoice:
    """The patch edge chosen for one cavity (:func:`choose_patch_mm`).

    patch_mm : [mm] the edge used; requested_mm : [mm] the edge asked for (the finest the rule uses)
    patches : the :class:`Patches` at ``patch_mm``; max_patches : the rule's target (None: no rule)
    area_m2 : [m^2] the cavity's bounding faces (all regions)
    """

    patch_mm: float
    requested_mm: float
    patches: Patches
    max_patches: int | None
    area_m2: float

    @property
    def coarsened(self) -> bool:
        return self.patch_mm > self.requested_mm

    def words(self) -> str:
        """One line: the edge, the count and the cavity's area, and why the edge is not the one asked for."""
        s = (f"cavity patches of {self.patch_mm:g} mm ({self.patches.n:,} patches) for this housing's "
             f"{self.area_m2:.3g} m2 of cavity faces")
        if self.coarsened:
            over = self.patches.n > self.max_patches
            s += (f" (coarsened from {self.requested_mm:g} mm to keep near {self.max_patches:,} patches"
                  + (f"; more than the rule's {self.max_patches:,} at its coarsest edge" if over else "")
                  + "; the reference unit's rises move < 0.01 K from 5 to 10 mm patches; --cavity-patch-mm sets the "
                  "edge exactly)")
        return s


def choose_patch_mm(grid: TensorGrid, air: np.ndarray, patch_mm: float = DEFAULT_PATCH_MM,
                    max_patches: int | None = AUTO_MAX_PATCHES) -> PatchChoice:
    """The patch edge [mm] of the cavity ``air`` of ``grid``: ``patch_mm`` if that gives at most ``max_patches``
    patches (or ``max_patches`` is None), else the finest edge on a 0.5 mm ladder above it, up to
    :data:`AUTO_MAX_PATCH_MM` (never below ``patch_mm``), that does. The count falls about as the edge squared
    (a patch never gets smaller than its mesh faces), so the first try is ``patch_mm * sqrt(n / max_patches)``."""
    if max_patches is not None and not (isinstance(max_patches, (int, np.integer)) and max_patches >= 1):
        raise InputError(f"cavity radiation: the most patches must be an integer >= 1 or None, got {max_patches!r}")
    pat = find_patches(grid, air, patch_mm)
    area = float(pat.area.sum())
    edge, top = float(patch_mm), max(float(patch_mm), AUTO_MAX_PATCH_MM)
    while max_patches is not None and pat.n > max_patches and edge < top:
        edge = min(top, max(edge + 0.5, np.ceil(2.0 * edge * np.sqrt(pat.n / max_patches)) / 2.0))
        pat = find_patches(grid, air, edge)
    return PatchChoice(patch_mm=edge, requested_mm=float(patch_mm), patches=pat, max_patches=max_patches,
                       area_m2=area)


@dataclass(frozen=True)
class ViewFactors:
    """View factors between the patches of one grid.

    F : (n, n) [-], reciprocal and closed (per region)
    rays : int, rays cast in total; lost : int, rays that hit no patch (left the air: should be 0)
    raw_reciprocity : float [-], max |A_i F_ij - A_j F_ji| / max(A_i F_ij) of the ray estimate
    raw_closure : float [-], max |1 - sum_j F_ij| of the ray estimate
    reciprocity, closure : the same after the enforcement (round-off level)
    seconds : float [s] wall time of the ray casting and enforcement
    """

    F: np.ndarray
    rays: int
    lost: int
    raw_reciprocity: float
    raw_closure: float
    reciprocity: float
    closure: float
    seconds: float


def _stratified_unit(n: int, rng: np.random.Generator) -> np.ndarray:
    """n jittered points of a k x k stratification of the unit square (k = ceil(sqrt n)), shuffled, (n, 2)."""
    k = int(np.ceil(np.sqrt(n)))
    cells = rng.permutation(k * k)[:n]
    return np.column_stack([(cells // k + rng.random(n)) / k, (cells % k + rng.random(n)) / k])


def _emit(patches: Patches, grid: TensorGrid, rays: int, rng: np.random.Generator):
    """Origins (R, 3) [m], directions (R, 3), start air cells (R, 3) and source patches (R,) of the rays."""
    lines = (grid.xs, grid.ys, grid.zs)
    n = patches.n
    order = np.argsort(patches.fc_patch, kind="stable")
    fcp = patches.fc_patch[order]
    starts = np.searchsorted(fcp, np.arange(n + 1))
    # face-cell areas in patch order
    areas = np.empty(len(order))
    for ax in range(3):
        m = patches.fc_axis[order] == ax
        u_ax, v_ax = [d for d in range(3) if d != ax]
        areas[m] = np.diff(lines[u_ax])[patches.fc_u[order][m]] * np.diff(lines[v_ax])[patches.fc_v[order][m]]
    cum = np.cumsum(areas)
    base = np.concatenate([[0.0], cum])
    src = np.repeat(np.arange(n), rays)
    # stratified choice of face cells in proportion to area: u in [0, 1) per ray, stratified per patch
    k = np.tile((np.arange(rays) + 0.0), n)
    u = (k + rng.random(n * rays)) / rays
    d_loc = np.empty((n * rays, 2))
    for p in range(n):  # stratified directions per patch (a k x k grid on the unit square)
        d_loc[p * rays:(p + 1) * rays] = _stratified_unit(rays, rng)
    w = rng.random((n * rays, 2))
    r = np.sqrt(d_loc[:, 0])
    phi = 2 * np.pi * d_loc[:, 1]
    t1, t2, nn = r * np.cos(phi), r * np.sin(phi), np.sqrt(np.maximum(0.0, 1.0 - d_loc[:, 0]))
    pos, dirs, cell = place_rays(grid, patches, order, starts, cum, base, rays, u, w, np.column_stack([t1, t2, nn]))
    return pos, dirs, cell, src


def _enforce(F: np.ndarray, area: np.ndarray, tol: float = 1e-13, max_iter: int = 5000) -> np.ndarray:
    """Reciprocal, closed view factors nearest the estimate.

    S = A F is symmetrised (reciprocity), then scaled symmetrically, S <- D S D, until its row sums are the
    areas (closure; the symmetric matrix-balancing iteration d <- sqrt(d A / (S d)), Sinkhorn-Knopp type).
    A patch that sees nothing (no ray hit anything) keeps a zero row. The products are sparse (a patch's rays
    reach ~8 % of the reference unit's patches; ~700 iterations there).
    """
    S = area[:, None] * F
    S = 0.5 * (S + S.T)
    d = np.ones(len(area))
    ok = S.sum(axis=1) > 0
    Ss = sp.csr_matrix(S)
    rs = Ss @ d
    for _ in range(max_iter):   # one product an iteration: the test's S d is the next update's
        d[ok] = np.sqrt(d[ok] * area[ok] / rs[ok])
        rs = Ss @ d
        if np.max(np.abs(d[ok] * rs[ok] / area[ok] - 1.0), initial=0.0) < tol:
            break
    S = d[:, None] * S * d[None, :]
    return S / area[:, None]


def _residuals(F, area):
    S = area[:, None] * F
    recip = float(np.abs(S - S.T).max() / max(S.max(), 1e-300))
    return recip, float(np.abs(1.0 - F.sum(axis=1)).max())


def view_factors(grid: TensorGrid, air: np.ndarray, patches: Patches, rays: int = DEFAULT_RAYS,
                 rng: np.random.Generator | None = None, chunk: int = 200_000) -> ViewFactors:
    """View factors between ``patches`` by ray casting through the ``air`` cells (see the module docstring).

    rays : int, rays per patch (>= 16); rng : numpy Generator (default: seed 0, reproducible)
    """
    if not (isinstance(rays, (int, np.integer)) and rays >= 16):
        raise InputError(f"cavity radiation: rays per patch must be an integer >= 16, got {rays!r}")
    rng = np.random.default_rng(0) if rng is None else rng
    t0 = time.perf_counter()
    n = patches.n
    counts = np.zeros((n, n))
    lost = 0
    per = max(1, chunk // rays)
    for p0 in range(0, n, per):
        sub = np.arange(p0, min(n, p0 + per))
        sel = _subset(patches, sub)
        pos, dirs, cell, src = _emit(sel, grid, rays, rng)
        hit = march(grid, air, patches.face_patch, pos, dirs, cell)
        ok = hit >= 0
        lost += int((~ok).sum())
        np.add.at(counts, (sub[src[ok]], hit[ok]), 1.0)
    F_raw = counts / rays
    rr, rc = _residuals(F_raw, patches.area)
    F = _enforce(F_raw, patches.area)
    r2, c2 = _residuals(F, patches.area)
    return ViewFactors(F=F, rays=n * rays, lost=lost, raw_reciprocity=rr, raw_closure=rc, reciprocity=r2,
                       closure=c2, seconds=time.perf_counter() - t0)


def _subset(patches: Patches, sub: np.ndarray) -> Patches:
    """The face cells of the patches ``sub``, renumbered 0..len(sub)-1 (for emitting rays in chunks)."""
    newid = np.full(patches.n, -1, dtype=np.int64)
    newid[sub] = np.arange(len(sub))
    m = newid[patches.fc_patch] >= 0
    return Patches(region=patches.region[sub], part=patches.part[sub], axis=patches.axis[sub],
                   sign=patches.sign[sub], area=patches.area[sub], centre=patches.centre[sub], P=None,
                   n_regions=patches.n_regions, region_cells=patches.region_cells, face_patch=None,
                   fc_patch=newid[patches.fc_patch[m]], fc_axis=patches.fc_axis[m], fc_plane=patches.fc_plane[m],
                   fc_u=patches.fc_u[m], fc_v=patches.fc_v[m])


def exchange_matrix(F: np.ndarray, area: np.ndarray, emissivity: np.ndarray) -> np.ndarray:
    """X [m^2] of Q = X sigma T^4: net heat leaving each patch of a grey diffuse enclosure (radiosity).

    F : (n, n) view factors, area : (n,) [m^2], emissivity : (n,) [-] in [0, 1].
    Returned symmetrised, with its row sums (zero in exact arithmetic) removed from the diagonal.

    With ``M = I - (I - E) F`` (radiosity ``J = M^-1 E Eb``), ``X = A (I - F) M^-1 E``; as ``I - F = M - E F`` and
    ``F M^-1 = (I - F (I - E))^-1 F`` (push-through), ``X = A (E - E (I - F (I - E))^-1 F E)``: one solve with n
    right-hand sides and no n x n product (~40 % less work than solving for ``M^-1 E`` and multiplying by F).
    """
    eps = np.asarray(emissivity, float)
    if np.any(~np.isfinite(eps)) or np.any(eps < 0) or np.any(eps > 1):
        raise InputError("cavity radiation: emissivities must be in [0, 1]")
    n = len(area)
    Y = np.linalg.solve(np.eye(n) - F * (1.0 - eps)[None, :], F * eps[None, :])   # (I - F (I - E))^-1 F E
    X = -(area * eps)[:, None] * Y
    X[np.diag_indices(n)] += area * eps
    X = 0.5 * (X + X.T)
    X[np.diag_indices(n)] -= X.sum(axis=1)
    return X


class CavityExchange:
    """The surface-to-surface exchange as a nonlinear law on the nodes of the cavity surfaces.

    Used by :func:`imutherm.thermal.assembly.assemble` like a boundary law: ``flux_out(T_nodes, T_ref)``
    returns the heat flux leaving each node [W/m^2] (per its lumped area ``weights`` [m^2]) and a diagonal
    slope [W/m^2 K] (see the module docstring). ``T_ref`` is unused (the exchange is between the surfaces).

    Attributes: nodes (m,), weights (m,) [m^2], Pn (n_patches, m) patch averaging on ``nodes``, X (n, n) [m^2],
    patches, view (ViewFactors), emissivity (n,) [-]
    """

    def __init__(self, patches: Patches, view: ViewFactors, emissivity: np.ndarray, X: np.ndarray | None = None):
        """``X``: the exchange matrix [m^2] when known (:meth:`refined`'s, the same patches'), else
        :func:`exchange_matrix` of the view factors and emissivities."""
        P = patches.P.tocsc()
        nodes = np.flatnonzero(np.diff(P.indptr))
        self.nodes = nodes
        self.Pn = P[:, nodes].tocsr()
        self.PnT = self.Pn.T.tocsr()
        # lumped nodal area: each patch's area spread by its averaging weights
        self.weights = np.asarray(self.PnT @ patches.area).ravel()
        self.patches = patches
        self.view = view
        self.emissivity = np.asarray(emissivity, float)
        if X is not None and X.shape != view.F.shape:
            raise InputError(f"cavity radiation: an exchange matrix of shape {X.shape} for {view.F.shape[0]} patches")
        self.X = exchange_matrix(view.F, patches.area, self.emissivity) if X is None else X
        self._absX = np.abs(self.X)

    def scaled(self, factor: float) -> "CavityExchange":
        """The same enclosure exchanging ``factor`` [-] (>= 0) times the heat: X times ``factor``, a new law (this one
        is not changed; the view factors and patches are shared)."""
        if not (np.isfinite(factor) and factor >= 0):
            raise InputError(f"cavity radiation: the exchange's scale must be a finite number >= 0, got {factor!r}")
        out = copy.copy(self)
        out.X, out._absX = self.X * float(factor), self._absX * float(factor)
        return out

    def refined(self, fine: TensorGrid, factor: int) -> "CavityExchange":
        """The same exchange (patches, view factors, emissivities: the same X) on ``fine``, this law's grid with
        every interval split into ``factor`` parts: a mesh-refinement study then sees the conduction's
        discretisation alone, not a new ray sample (:func:`refined_patches`)."""
        # the same X, not formed again (a dense radiosity solve of the patches); a scaled law keeps its scale
        out = CavityExchange(refined_patches(self.patches, fine, factor), self.view, self.emissivity, X=self.X)
        out._absX = self._absX   # shared, as X is: one copy of each n x n array in memory and in a pickle
        return out

    @property
    def region(self):  # a law's region (the whole set of nodes)
        return None

    def patch_heat(self, T_nodes) -> np.ndarray:
        """Net heat leaving each patch [W] at the nodal temperatures ``T_nodes`` [°C] (on ``nodes``)."""
        Tk = self.Pn @ np.asarray(T_nodes, float) + ZERO_C_K
        return self.X @ (SIGMA * Tk**4)

    def flux_out(self, T_nodes, T_ref=None):
        """Flux leaving each node [W/m^2] and the diagonal slope [W/m^2 K] at ``T_nodes`` [°C]."""
        Tk = self.Pn @ np.asarray(T_nodes, float) + ZERO_C_K
        Q = self.X @ (SIGMA * Tk**4)
        g = 4.0 * SIGMA * Tk**3
        D = JACOBI_FRACTION * (self.PnT @ (self._absX @ g))
        return (self.PnT @ Q) / self.weights, D / self.weights

    def symmetric_jacobian(self, T_nodes) -> tuple:
        """The exchange's Jacobian at ``T_nodes`` [°C] in a symmetric form, for the steady Newton step.

        Returns ``(s, D)``: the nodal heat changes by ``Pn^T diag(s) X diag(s) Pn v`` [W] for a change
        ``v`` [K] of the nodal temperatures, with ``s = sqrt(4 sigma T_p^3)`` per patch [W^1/2 m^-1 K^-3/2];
        ``D`` (on ``nodes``) [W/K] is the diagonal slope :meth:`flux_out` hands the solver in its place.
        The exact Jacobian is ``Pn^T X diag(s^2) Pn``; the symmetric one differs from it by the spread of
        ``T_p^3`` over the cavity (a few per cent at the unit's rises), and is positive semi-definite
        (``X`` is), so CG can solve with it.
        """
        Tk = self.Pn @ np.asarray(T_nodes, float) + ZERO_C_K
        g = 4.0 * SIGMA * Tk**3
        return np.sqrt(g), JACOBI_FRACTION * (self.PnT @ (self._absX @ g))

    def linear_term(self, T_m_C: float) -> tuple:
        """The exchange linearised about a uniform ``T_m_C`` [°C]: (nodes, Pn, G) with the nodal heat
        leaving ``N = Pn^T G Pn T[nodes]`` [W], ``G = 4 sigma T_m^3 X`` [W/K] symmetric positive
        semi-definite (a low-rank term ``K += Pn^T G Pn`` for a linear or reduced model). Its error against
        sigma T^4 is ~1.5 |T - T_m| / T_m (kelvin) of the exchanged heat: 4 % for surfaces 10 K from
        T_m = 350 K."""
        Tk = float(T_m_C) + ZERO_C_K
        return self.nodes, self.Pn, 4.0 * SIGMA * Tk**3 * self.X


def refined_patches(patches: Patches, fine: TensorGrid, factor: int) -> Patches:
    """The same patches on ``fine``, the grid of ``patches`` with every interval split into ``factor`` parts
    (:func:`imutherm.geometry.mesh.refine_grid`): each face cell's ``factor**2`` sub-faces belong to its patch,
    so the patches, their areas and the view factors between them are unchanged, and only the averaging
    ``P`` (and the per-face-cell arrays) are of the fine grid's nodes and faces. No ``face_patch`` map (rays are
    not traced on the fine grid: its view factors are the coarse ones; the map held ~35 MB on the reference
    unit's refined mesh)."""
    f = int(factor)
    a, b = np.meshgrid(np.arange(f), np.arange(f), indexing="ij")
    a, b = a.ravel(), b.ravel()
    patch = np.repeat(patches.fc_patch, f * f)
    axis = np.repeat(patches.fc_axis, f * f)
    plane = np.repeat(patches.fc_plane, f * f) * f
    u = (np.repeat(patches.fc_u, f * f) * f + np.tile(a, len(patches.fc_patch)))
    v = (np.repeat(patches.fc_v, f * f) * f + np.tile(b, len(patches.fc_patch)))
    lines = (fine.xs, fine.ys, fine.zs)
    Nn = tuple(n + 1 for n in fine.shape)
    area = np.empty(len(patch))
    cols = np.empty((4, len(patch)), dtype=np.int64)
    for ax in range(3):
        m = axis == ax
        u_ax, v_ax = [d for d in range(3) if d != ax]
        area[m] = np.diff(lines[u_ax])[u[m]] * np.diff(lines[v_ax])[v[m]]
        for k, (da, db) in enumerate(((0, 0), (0, 1), (1, 0), (1, 1))):
            ijk = [None] * 3
            ijk[ax], ijk[u_ax], ijk[v_ax] = plane[m], u[m] + da, v[m] + db
            cols[k, m] = (ijk[0] * Nn[1] + ijk[1]) * Nn[2] + ijk[2]
    vals = np.tile(area / 4.0 / patches.area[patch], 4)
    P = sp.csr_matrix((vals, (np.tile(patch, 4), cols.ravel())), shape=(patches.n, fine.n_nodes))
    return replace(patches, P=P, face_patch=None, fc_patch=patch, fc_axis=axis, fc_plane=plane,
                   fc_u=u, fc_v=v)


def cavity_exchange(grid: TensorGrid, air: np.ndarray, emissivity_by_part, *, patch_mm: float = DEFAULT_PATCH_MM,
                    rays: int = DEFAULT_RAYS, rng: np.random.Generator | None = None,
                    view: ViewFactors | None = None, patches: Patches | None = None) -> CavityExchange:
    """The exchange law of the air cells ``air`` of ``grid``.

    emissivity_by_part : sequence, emissivity [-] of each part of ``grid.part_names`` (used where it bounds air)
    patch_mm : float [mm] patch edge; rays : int rays per patch; rng : Generator for the rays (default seed 0)
    view : ViewFactors computed before for the same grid, air and patch size (they do not depend on emissivity)
    patches : Patches found before for the same grid, air and patch size (:func:`choose_patch_mm`'s)
    """
    if patches is None:
        patches = find_patches(grid, air, patch_mm)
    if view is None:
        from imutherm.budget import check_s2s_cost

        # counted before the dense n x n arrays exist: refused beyond the memory available now or the time limit
        check_s2s_cost(f"cavity law s2s at {patch_mm:g} mm patches", patches.n, rays)
        view = view_factors(grid, air, patches, rays, rng)
    elif view.F.shape != (patches.n, patches.n):
        raise InputError("cavity radiation: the given view factors do not belong to these patches")
    eps = np.asarray(emissivity_by_part, float)[patches.part]
    return CavityExchange(patches, view, eps)
