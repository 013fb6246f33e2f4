"""Fast trilinear (Q1 hexahedron) assembly on a tensor grid.

Every cell is a box, so its element matrices are exact closed forms
(no quadrature, no Jacobians)::

    K_e = kx hy hz / hx * KX_REF + ky hx hz / hy * KY_REF + kz hx hy / hz * KZ_REF
    M_e = rho_c hx hy hz * M_REF

with ``KX_REF = k1 ⊗ m1 ⊗ m1`` etc. built from the 1-D unit-length stiffness
``k1 = [[1, -1], [-1, 1]]`` and mass ``m1 = [[1/3, 1/6], [1/6, 1/3]]``; the
local node ``l = 4a + 2b + c`` sits at corner (a, b, c) of the cell. Boundary
faces use the 4x4 face mass ``h hu hv m1 ⊗ m1``; volumetric power gives
``q V / 8`` per cell node.

Instead of a COO list with 64 entries per cell (and a sort), the matrices are
accumulated into a 27-point nodal stencil array (shape ``(27, Nx, Ny, Nz)``)
by 64 strided numpy additions, and the CSR arrays are then written directly:
on a C-ordered structured grid the 27 neighbour offsets in lexicographic order
are the column indices in increasing order, so no sort is needed. All
matrices share one sparsity pattern (:class:`Pattern`), so linear
combinations such as ``M/dt + theta*K`` are plain operations on ``.data``.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from imutherm import InputError
from imutherm.geometry.grid import FACE_NAMES, TensorGrid
from imutherm.thermal.problem import (LINEAR_LAWS, NONLINEAR_LAWS, FixedTemperature, HeatFlux,
                                      ThermalProblem)

_K1 = np.array([[1.0, -1.0], [-1.0, 1.0]])
_M1 = np.array([[1.0 / 3.0, 1.0 / 6.0], [1.0 / 6.0, 1.0 / 3.0]])
#: 8x8 reference matrices on the unit cube, local node l = 4a + 2b + c.
KX_REF = np.kron(_K1, np.kron(_M1, _M1))
KY_REF = np.kron(_M1, np.kron(_K1, _M1))
KZ_REF = np.kron(_M1, np.kron(_M1, _K1))
M_REF = np.kron(_M1, np.kron(_M1, _M1))
#: 4x4 reference face mass on the unit square, local node 2a + b.
FACE_M_REF = np.kron(_M1, _M1)

_LOCAL3 = [(a, b, c) for a in (0, 1) for b in (0, 1) for c in (0, 1)]
_LOCAL2 = [(a, b) for a in (0, 1) for b in (0, 1)]
_CENTRE = 13
#: the ``face`` name under which an interior exchange law (cavity radiation) is listed in
#: ``Assembly.nonlinear`` and in ``heat_out_W`` (its net heat is zero: it moves heat between surfaces)
EXCHANGE_FACE = "cavity_s2s"


def _offset_index(da: int, db: int, dc: int) -> int:
    return (da + 1) * 9 + (db + 1) * 3 + (dc + 1)


#: rows of the pattern's index array made at once
_ROW_BLOCK = 1 << 18


class Pattern:
    """The 27-point sparsity pattern of a structured node grid (CSR, sorted columns)."""

    def __init__(self, node_shape: tuple):
        Nx, Ny, Nz = node_shape
        self.node_shape = (Nx, Ny, Nz)
        n = Nx * Ny * Nz
        self.n = n
        flat = np.array([(da * Ny + db) * Nz + dc for da in (-1, 0, 1) for db in (-1, 0, 1) for dc in (-1, 0, 1)])
        blocks = [(r0, min(r0 + _ROW_BLOCK, n)) for r0 in range(0, n, _ROW_BLOCK)]
        # each row's count of in-grid neighbours, and of those before its centre, from the 1-D counts per axis
        # (the neighbours of node (i, j, k) are the products of the axes' in-grid offsets)
        lo = [(np.arange(N) > 0).astype(np.int64) for N in (Nx, Ny, Nz)]        # the offset -1 lies in the grid
        cnt = [1 + lo[a] + (np.arange(N) < N - 1) for a, N in enumerate((Nx, Ny, Nz))]   # in-grid offsets, 1-3
        ci, cj, ck = cnt[0][:, None, None], cnt[1][None, :, None], cnt[2][None, None, :]
        self.indptr = np.zeros(n + 1, dtype=np.int64)
        self.indptr[1:] = (ci * cj * ck).ravel()
        # before the centre (offsets in lexicographic order): da = -1, then da = 0 and db = -1, then dc = -1
        before = lo[0][:, None, None] * cj * ck + lo[1][None, :, None] * ck + lo[2][None, None, :]
        np.cumsum(self.indptr, out=self.indptr)
        self.diag_pos = self.indptr[:-1] + before.ravel()   # the centre's position in the data array
        itype = np.int32 if n * 27 < 2 ** 31 - 1 else np.int64
        # column of each stored entry: row + offset, in the index type and in blocks of rows (a 2-D temporary of
        # every row was the largest array of an 8x refined mesh's assembly)
        self.indices = np.empty(int(self.indptr[-1]), dtype=itype)
        flat = flat.astype(itype)
        for r0, r1 in blocks:
            self.indices[self.indptr[r0]:self.indptr[r1]] = \
                (np.arange(r0, r1, dtype=itype)[:, None] + flat[None, :])[self.valid(r0, r1)]
        self.indptr = self.indptr.astype(itype)
        self.nnz = int(self.indptr[-1])

    def valid(self, r0: int = 0, r1: int | None = None, rows: np.ndarray | None = None) -> np.ndarray:
        """(rows, 27) bool: which of each row's 27 neighbour offsets (:func:`_offset_index`) lie in the grid, for
        the rows ``r0`` .. ``r1`` - 1 (default all) or the given ``rows``. Computed when asked, not kept: on the
        reference unit's 2x refined mesh the whole mask is 41 MB beside the refined solve, the study's peak."""
        Nx, Ny, Nz = self.node_shape
        r = np.arange(r0, self.n if r1 is None else r1) if rows is None else np.asarray(rows)
        i, j, k = r // (Ny * Nz), (r // Nz) % Ny, r % Nz
        inside = [((i + d >= 0) & (i + d < Nx), (j + d >= 0) & (j + d < Ny), (k + d >= 0) & (k + d < Nz))
                  for d in (-1, 0, 1)]
        out = np.empty((len(r), 27), dtype=bool)
        for da in (-1, 0, 1):
            for db in (-1, 0, 1):
                for dc in (-1, 0, 1):
                    out[:, _offset_index(da, db, dc)] = inside[da + 1][0] & inside[db + 1][1] & inside[dc + 1][2]
        return out

    @functools.cached_property
    def rows(self) -> np.ndarray:
        """The row of each stored entry (built at first use: only a fixed-temperature elimination and the
        reduced model's sparse part need it; on an 8x refined mesh it is 165 MB)."""
        rows = np.repeat(np.arange(self.n, dtype=self.indices.dtype), np.diff(self.indptr))
        rows.setflags(write=False)
        return rows

    def data(self, stencil: np.ndarray) -> np.ndarray:
        """CSR data array from a stencil array of shape (27, Nx, Ny, Nz)."""
        return stencil.reshape(27, self.n).T[self.valid()]

    def positions(self, rows: np.ndarray, o: int) -> np.ndarray:
        """Positions in the data array of the entries (row, offset ``o``) of ``rows`` (each must have it)."""
        return self.indptr[rows].astype(np.int64) + self.valid(rows=rows)[:, :o].sum(axis=1)

    def csr(self, data: np.ndarray) -> sp.csr_matrix:
        """A CSR matrix with this pattern and the given data (no copy of the pattern)."""
        return sp.csr_matrix((data, self.indices, self.indptr), shape=(self.n, self.n))


def _volume_stencil(shape: tuple, coefs: list, refs: list) -> np.ndarray:
    """The nodal stencil (27, nx + 1, ny + 1, nz + 1) of sum_r coefs[r] * refs[r] (8x8), ``coefs`` cell arrays of
    ``shape`` (nx, ny, nz)."""
    nx, ny, nz = shape
    S = np.zeros((27, nx + 1, ny + 1, nz + 1))
    for l1, (a1, b1, c1) in enumerate(_LOCAL3):
        dst = (slice(a1, a1 + nx), slice(b1, b1 + ny), slice(c1, c1 + nz))
        for l2, (a2, b2, c2) in enumerate(_LOCAL3):
            o = _offset_index(a2 - a1, b2 - b1, c2 - c1)
            terms = [(c, r[l1, l2]) for c, r in zip(coefs, refs) if r[l1, l2] != 0.0]
            if not terms:
                continue
            val = terms[0][0] * terms[0][1]
            for c, r in terms[1:]:
                val += c * r
            S[o][dst] += val
    return S


#: largest stencil block [bytes] :func:`_volume_data` makes at once
STENCIL_BLOCK_BYTES = 32 * 2**20


def _volume_data(pattern: Pattern, grid: TensorGrid, coefs: list, refs: list) -> np.ndarray:
    """The CSR data of ``pattern`` for the volume stencil sum_r coefs[r] * refs[r], made in slabs of node planes
    along x (each from its cells: the same sums in the same order as the whole stencil, bit for bit), so no
    (27, Nx, Ny, Nz) array exists: on the reference unit's 2x refined mesh 325 MB, with its copy into the data."""
    nx, ny, nz = grid.shape
    per = (ny + 1) * (nz + 1)   # nodes per plane
    slabs = max(1, -(-27 * 8 * pattern.n // STENCIL_BLOCK_BYTES))
    bounds = np.unique(np.linspace(0, nx + 1, slabs + 1).astype(int))
    coefs = [np.broadcast_to(c, grid.shape) for c in coefs]
    data = np.empty(pattern.nnz)
    for i0, i1 in zip(bounds[:-1], bounds[1:]):
        c0, c1 = max(i0 - 1, 0), min(i1, nx)   # the cells touching node planes i0 .. i1 - 1
        S = _volume_stencil((c1 - c0, ny, nz), [c[c0:c1] for c in coefs], refs)[:, i0 - c0:i1 - c0]
        r0, r1 = i0 * per, i1 * per
        data[pattern.indptr[r0]:pattern.indptr[r1]] = S.reshape(27, -1).T[pattern.valid(r0, r1)]
    return data


def cell_sizes3(grid):
    hx, hy, hz = grid.cell_sizes()
    return hx[:, None, None], hy[None, :, None], hz[None, None, :]


def _stiffness_terms(problem: ThermalProblem) -> tuple:
    g = problem.grid
    hx, hy, hz = cell_sizes3(g)
    k = problem.k.reshape(g.shape + (3,))
    cx = k[..., 0] * (hy * hz / hx)
    cy = k[..., 1] * (hx * hz / hy)
    cz = k[..., 2] * (hx * hy / hz)
    return [cx, cy, cz], [KX_REF, KY_REF, KZ_REF]


def stiffness_stencil(problem: ThermalProblem) -> np.ndarray:
    """Conduction stiffness as a stencil array (27, Nx, Ny, Nz) [W/K]."""
    return _volume_stencil(problem.grid.shape, *_stiffness_terms(problem))


def mass_stencil(problem: ThermalProblem, lumped: bool = False) -> np.ndarray:
    """Heat-capacity (mass) matrix as a stencil array [J/K]; ``lumped`` = row sums on the diagonal."""
    g = problem.grid
    cm = problem.rho_c.reshape(g.shape) * g.cell_volumes()
    if lumped:
        nx, ny, nz = g.shape
        S = np.zeros((27, nx + 1, ny + 1, nz + 1))
        for a, b, c in _LOCAL3:
            S[_CENTRE, a:a + nx, b:b + ny, c:c + nz] += cm / 8.0
        return S
    return _volume_stencil(g.shape, [cm], [M_REF])


def node_ids(grid: TensorGrid) -> np.ndarray:
    """Node index array of shape (Nx, Ny, Nz) (C order)."""
    return np.arange(grid.n_nodes).reshape(tuple(s + 1 for s in grid.shape))


def volume_load(problem: ThermalProblem) -> np.ndarray:
    """Nodal load of the volumetric power, q V / 8 per cell node [W], shape (n_nodes,)."""
    g = problem.grid
    nx, ny, nz = g.shape
    qv = problem.q.reshape(g.shape) * g.cell_volumes() / 8.0
    F = np.zeros((nx + 1, ny + 1, nz + 1))
    for a, b, c in _LOCAL3:
        F[a:a + nx, b:b + ny, c:c + nz] += qv
    return F.reshape(-1)


@dataclass
class Face:
    """Geometry of one outer face: plane nodes, face cells and their areas."""

    name: str
    axis: int                      # normal axis 0/1/2
    side: int                      # 0 = min, 1 = max
    other: tuple                   # the two tangential axes (u, v)
    plane_index: tuple             # index tuple selecting the face plane in node arrays
    nodes: np.ndarray              # (Nu, Nv) node ids
    area: np.ndarray               # (nu, nv) face-cell areas [m^2]
    centres: tuple                 # (uc (nu,), vc (nv,)) face-cell centre coordinates [m]

    def mask(self, region) -> np.ndarray:
        """Face cells (nu, nv) selected by a law's region (all when None)."""
        if region is None:
            return np.ones(self.area.shape, dtype=bool)
        (u0, u1), (v0, v1) = region
        uc, vc = self.centres
        m = ((uc >= u0) & (uc <= u1))[:, None] & ((vc >= v0) & (vc <= v1))[None, :]
        if not m.any():
            raise InputError(f"boundary face {self.name!r}: region {region} selects no face cell "
                             f"(put grid lines on the region's edges)")
        return m

    def corner_nodes(self, mask) -> np.ndarray:
        """Corner node ids (m, 4) of the selected face cells, local order 2a + b."""
        nu, nv = self.area.shape
        cols = [self.nodes[a:a + nu, b:b + nv][mask] for a, b in _LOCAL2]
        return np.column_stack(cols)

    def nodal_weights(self, coef) -> np.ndarray:
        """Lumped nodal integral of a face-cell field: sum over adjacent cells of coef*area/4, (Nu, Nv)."""
        nu, nv = self.area.shape
        w = np.zeros((nu + 1, nv + 1))
        ca = coef * self.area / 4.0
        for a, b in _LOCAL2:
            w[a:a + nu, b:b + nv] += ca
        return w


def faces(grid: TensorGrid) -> dict:
    """The six outer faces of the grid as :class:`Face` objects, keyed by name."""
    axes = (grid.xs, grid.ys, grid.zs)
    nid = node_ids(grid)
    out = {}
    for f, name in enumerate(FACE_NAMES):
        d, side = divmod(f, 2)
        u, v = [a for a in range(3) if a != d]
        p = 0 if side == 0 else nid.shape[d] - 1
        idx = [slice(None)] * 3
        idx[d] = p
        hu, hv = np.diff(axes[u]), np.diff(axes[v])
        out[name] = Face(name=name, axis=d, side=side, other=(u, v), plane_index=tuple(idx),
                         nodes=nid[tuple(idx)], area=hu[:, None] * hv[None, :],
                         centres=(0.5 * (axes[u][1:] + axes[u][:-1]), 0.5 * (axes[v][1:] + axes[v][:-1])))
    return out


def _face_data_add(pattern: Pattern, data: np.ndarray, face: Face, coef: np.ndarray) -> None:
    """Add the consistent face mass of a face-cell coefficient (nu, nv) [W/m^2 K] into the CSR ``data`` of
    ``pattern`` (no nodal stencil array: the face's own entries only)."""
    nu, nv = face.area.shape
    c = coef * face.area
    u, v = face.other
    for l1, (a1, b1) in enumerate(_LOCAL2):
        rows = face.nodes[a1:a1 + nu, b1:b1 + nv].reshape(-1)
        for l2, (a2, b2) in enumerate(_LOCAL2):
            off = [0, 0, 0]
            off[u], off[v] = a2 - a1, b2 - b1
            data[pattern.positions(rows, _offset_index(*off))] += (FACE_M_REF[l1, l2] * c).reshape(-1)


@dataclass
class LinearBC:
    face: str
    law: object
    T_ref: float                   # [°C]
    corners: np.ndarray            # (m, 4) node ids
    hA: np.ndarray                 # (m,) h * area [W/K]


@dataclass
class NodalBC:
    face: str
    law: object
    T_ref: float | None            # [°C] (None for HeatFlux)
    nodes: np.ndarray              # (m,) node ids
    weights: np.ndarray            # (m,) lumped nodal areas [m^2]


@dataclass
class DirichletBC:
    face: str
    law: FixedTemperature
    nodes: np.ndarray


@dataclass
class Assembly:
    """Matrices and loads of a :class:`ThermalProblem`, assembled once and reused.

    All matrices share ``pattern``; ``*_data`` are CSR data arrays.

    Attributes
    ----------
    K_data : conduction stiffness [W/K]
    H_data : linear boundary laws (Convection, Contact), consistent face mass [W/K]
    M_data : heat capacity [J/K] (consistent or lumped); None if assembled with ``mass=False``
    F_q : nodal load of the volumetric power [W]
    F_bc : nodal load of the linear laws (h T_ref) and of HeatFlux [W]
    """

    problem: ThermalProblem
    pattern: Pattern
    K_data: np.ndarray
    H_data: np.ndarray
    M_data: np.ndarray | None
    F_q: np.ndarray
    F_bc: np.ndarray
    linear: list = field(default_factory=list)
    nonlinear: list = field(default_factory=list)
    fluxes: list = field(default_factory=list)
    dirichlet: list = field(default_factory=list)
    lumped_mass: bool = False

    @property
    def n(self) -> int:
        return self.pattern.n

    @property
    def K(self) -> sp.csr_matrix:
        """Conduction stiffness matrix [W/K]."""
        return self.pattern.csr(self.K_data)

    @property
    def H(self) -> sp.csr_matrix:
        """Linear boundary-law matrix [W/K]."""
        return self.pattern.csr(self.H_data)

    @property
    def M(self) -> sp.csr_matrix:
        """Heat-capacity matrix [J/K]."""
        if self.M_data is None:
            raise InputError("this assembly was made without the heat capacity (assemble(..., mass=False))")
        return self.pattern.csr(self.M_data)

    def dirichlet_values(self, t: float | None) -> tuple:
        """(nodes, values [°C]) at time ``t`` [s] (``None`` for steady); later laws win on shared nodes."""
        if not self.dirichlet:
            return np.zeros(0, dtype=np.int64), np.zeros(0)
        nodes = np.concatenate([d.nodes for d in self.dirichlet])[::-1]
        vals = np.concatenate([np.full(len(d.nodes), d.law.value(t)) for d in self.dirichlet])[::-1]
        uniq, first = np.unique(nodes, return_index=True)
        return uniq, vals[first]

    def nonlinear_flux(self, T: np.ndarray):
        """Lumped nodal heat leaving through the nonlinear laws [W] and its diagonal Jacobian [W/K]."""
        N = np.zeros(self.n)
        D = np.zeros(self.n)
        for bc in self.nonlinear:
            qv, dq = bc.law.flux_out(T[bc.nodes], bc.T_ref)
            np.add.at(N, bc.nodes, bc.weights * qv)
            np.add.at(D, bc.nodes, bc.weights * dq)
        return N, D

    def face_heat_out(self, T: np.ndarray) -> dict:
        """Heat leaving per face through Convection, Contact, the nonlinear laws, minus HeatFlux [W]."""
        out = {}
        for bc in self.linear:
            out[bc.face] = out.get(bc.face, 0.0) + float(np.dot(bc.hA, T[bc.corners].mean(axis=1) - bc.T_ref))
        for bc in self.nonlinear:
            qv, _ = bc.law.flux_out(T[bc.nodes], bc.T_ref)
            out[bc.face] = out.get(bc.face, 0.0) + float(np.dot(bc.weights, qv))
        for bc in self.fluxes:
            out[bc.face] = out.get(bc.face, 0.0) - float(bc.law.q * bc.weights.sum())
        return out

    @property
    def flux_in_W(self) -> float:
        """Heat entering through HeatFlux laws [W]."""
        return float(sum(bc.law.q * bc.weights.sum() for bc in self.fluxes))


@functools.lru_cache(maxsize=4)
def pattern_of(node_shape: tuple) -> Pattern:
    """The (shared, read-only) :class:`Pattern` of a node grid: built once per shape (a correlation's reduced
    model assembles ~80 variants of one grid; building the pattern was a tenth of that)."""
    pattern = Pattern(tuple(node_shape))
    for a in (pattern.indices, pattern.indptr, pattern.diag_pos):   # (rows: read-only when built)
        a.setflags(write=False)   # shared by every assembly of the grid: an in-place change would leak
    return pattern


def assemble(problem: ThermalProblem, *, lumped_mass: bool = False, mass: bool = True,
             cache_pattern: bool = True, merge_linear: bool = False, like: Assembly | None = None) -> Assembly:
    """Assemble stiffness, heat capacity, boundary matrices and loads of ``problem``.

    Parameters
    ----------
    problem : ThermalProblem
    lumped_mass : bool
        Row-sum lumped heat capacity instead of the consistent one.
    mass : bool
        False: skip the heat capacity (a steady operator only; a third of the assembly time).
    cache_pattern : bool
        False: build the sparsity pattern for this assembly alone, not kept by :func:`pattern_of` (a one-off
        large grid, e.g. a mesh-error estimate's refined one, whose pattern would otherwise stay in memory).
    merge_linear : bool
        True: the linear laws' matrix is added into ``K_data`` (which then holds K + H) and ``H_data`` is empty:
        a steady operator of a one-off large grid with one data array instead of two (on the reference unit's 2x
        refined mesh, 1.5e6 nodes: 304 MB less).
    like : Assembly, optional
        An assembly of a problem on the same grid with the same conductivity, heat capacity and heat sources
        (checked; else ignored): its conduction, heat capacity and volume load are taken (shared, not copied)
        and only the boundary is assembled, e.g. the unit in the calibration oven at another ambient.

    Returns
    -------
    Assembly
        Reusable across steady and transient solves of the same problem.
    """
    g = problem.grid
    shape = tuple(s + 1 for s in g.shape)
    if _same_volume(like, problem, mass, lumped_mass, merge_linear):
        pattern, K_data, M_data, F_q = like.pattern, like.K_data, like.M_data if mass else None, like.F_q
        H_data = np.zeros(pattern.nnz)
        return _with_boundary(problem, pattern, K_data, H_data, M_data, F_q, lumped_mass, merge_linear)
    pattern = pattern_of(shape) if cache_pattern else Pattern(shape)
    K_data = _volume_data(pattern, g, *_stiffness_terms(problem))
    H_data = K_data if merge_linear else np.zeros(pattern.nnz)   # merged: the linear laws added into K's data
    M_data = None
    if mass:
        M_data = pattern.data(mass_stencil(problem, lumped=True)) if lumped_mass else _volume_data(
            pattern, g, [problem.rho_c.reshape(g.shape) * g.cell_volumes()], [M_REF])
    F_q = volume_load(problem)
    return _with_boundary(problem, pattern, K_data, H_data, M_data, F_q, lumped_mass, merge_linear)


def volume_part(asm: Assembly) -> Assembly | None:
    """``asm``'s volume parts alone (conduction, heat capacity, volume load; ``H_data`` and ``F_bc`` None, no boundary
    conditions), as ``like`` of :func:`assemble` for problems of the same unit under other surroundings, without
    keeping ``asm``'s boundary matrix (an nnz-sized array: 40 MB on the reference unit's default mesh) alive. None
    when ``asm``'s conduction is merged with its linear laws (``merge_linear``: no volume part of its own)."""
    if asm.H_data is asm.K_data or len(asm.H_data) != len(asm.K_data):
        return None
    return replace(asm, H_data=None, F_bc=None, linear=[], nonlinear=[], fluxes=[], dirichlet=[])


def _same_volume(like, problem: ThermalProblem, mass: bool, lumped_mass: bool, merge_linear: bool) -> bool:
    """True when ``like`` (an Assembly or None) has this problem's volume parts: the same grid, conductivity,
    heat capacity (when ``mass``) and heat sources, its conduction not merged with a boundary's."""
    if like is None or merge_linear:
        return False
    if like.H_data is not None and (like.H_data is like.K_data or len(like.H_data) != len(like.K_data)):
        return False   # merged: its K_data holds a boundary's laws too
    a, g = like.problem, problem.grid
    if mass and (like.M_data is None or like.lumped_mass != lumped_mass):
        return False
    same_grid = a.grid is g or (a.grid.shape == g.shape and all(
        np.array_equal(u, v) for u, v in zip((a.grid.xs, a.grid.ys, a.grid.zs), (g.xs, g.ys, g.zs))))
    return (same_grid and np.array_equal(a.k, problem.k) and np.array_equal(a.q, problem.q)
            and (not mass or np.array_equal(a.rho_c, problem.rho_c)))


def _with_boundary(problem, pattern, K_data, H_data, M_data, F_q, lumped_mass: bool, merge_linear: bool) -> Assembly:
    """The Assembly of ``problem`` from its volume parts: the boundary laws' matrix and load, the nonlinear,
    flux and fixed-temperature conditions and the interior exchanges added (:func:`assemble`)."""
    g = problem.grid
    F_bc = np.zeros(g.n_nodes)
    linear, nonlinear, fluxes, dirichlet = [], [], [], []
    fcs = faces(g)
    for name in FACE_NAMES:
        for law in problem.boundary.get(name, ()):
            face = fcs[name]
            mask = face.mask(law.region)
            if isinstance(law, FixedTemperature):
                nodes = np.unique(face.corner_nodes(mask))
                dirichlet.append(DirichletBC(name, law, nodes))
            elif isinstance(law, LINEAR_LAWS):
                h = law.coefficient
                coef = np.where(mask, h, 0.0)
                _face_data_add(pattern, H_data, face, coef)
                T_ref = problem.law_T_C(law)
                w = face.nodal_weights(coef)
                F_bc[face.nodes.reshape(-1)] += (w * T_ref).reshape(-1)
                linear.append(LinearBC(name, law, T_ref, face.corner_nodes(mask), h * face.area[mask]))
            elif isinstance(law, (HeatFlux,) + NONLINEAR_LAWS):
                w = face.nodal_weights(mask.astype(float)).reshape(-1)
                nodes = face.nodes.reshape(-1)
                keep = w > 0
                bc = NodalBC(name, law, None if isinstance(law, HeatFlux) else problem.law_T_C(law),
                             nodes[keep], w[keep])
                if isinstance(law, HeatFlux):
                    F_bc[bc.nodes] += law.q * bc.weights
                    fluxes.append(bc)
                else:
                    nonlinear.append(bc)
            else:  # pragma: no cover - ThermalProblem validates the laws
                raise InputError(f"face {name!r}: unsupported law {law!r}")
    if problem.exchanges and not (dirichlet or nonlinear or any(bc.law.coefficient > 0 for bc in linear)):
        raise InputError("assemble: no boundary law removes heat (an interior exchange only moves it between "
                         "surfaces): the steady state is undefined")
    for ex in problem.exchanges:  # interior surface exchange: a nonlinear law of its own nodes (net heat 0)
        nonlinear.append(NodalBC(EXCHANGE_FACE, ex, problem.ambient_C, np.asarray(ex.nodes), np.asarray(ex.weights)))
    if merge_linear:   # K + H in one array
        H_data = np.zeros(0)
    return Assembly(problem=problem, pattern=pattern, K_data=K_data, H_data=H_data, M_data=M_data,
                    F_q=F_q, F_bc=F_bc, linear=linear, nonlinear=nonlinear, fluxes=fluxes,
                    dirichlet=dirichlet, lumped_mass=lumped_mass)
