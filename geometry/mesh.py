"""Mesh a :class:`Geometry` into a conforming :class:`TensorGrid`.

Grid lines are placed on every face of every part, so each cell lies in
exactly one part. Between two lines, the interval is split evenly so that no
cell is longer than ``max_cell_mm`` and every part (or housing wall) is at
least ``min_cells`` cells thick along each axis. A 0.1 mm bond line is thus
resolved by its own cells without refining the rest of the unit.

Boards, their via fields and the plain parts that carry them (standoffs) get
``BOARD_CELLS_FACTOR * min_cells`` cells across: they carry the hottest die's
heat to the housing, and the mesh-convergence study
(``benchmarks/bench_reference.py --convergence``) found the maximum rise most
sensitive to them (grease scheme: 4 instead of 2 cells through the boards
moves it by 1.2 %; air scheme: 4 instead of 2 across the standoffs by 0.9 %;
every other part kind by <= 0.6 %). Tied to ``min_cells``, halving the mesh
refines them too.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from imutherm import InputError
from imutherm.geometry.build import MM, Geometry
from imutherm.geometry.grid import FACE_NAMES, TensorGrid
from imutherm.geometry.layout import AXES
from imutherm.geometry.outline import board_loops, cuts_board, edge_lines, outside_cells

DEFAULT_MAX_CELL_MM = 2.0  # [mm] default largest cell edge; the mesh convergence study: docs/benchmarks/reference.md
DEFAULT_MIN_CELLS = 2      # cells across the thinnest dimension of every part
BOARD_CELLS_FACTOR = 2     # boards, via fields, standoffs: this many times min_cells across
_FACTOR_KINDS = ("board", "vias", "box")
#: [mm] part faces closer than this share one grid line (20 um: no layer of a unit is that thin, the thinnest
#: cells are 50 um; faces a CAD export puts a rounding error apart, or a board's parts placed a few um out of
#: line, make no sliver cells: cube-main's four stepper drivers 6 um apart made a 6 um row of cells across the
#: unit and tripled its steady solve's CG iterations)
LINE_TOL_MM = 0.02

#: [mm] an outline edge's grid line is left out when another line lies closer than this (the cells follow the
#: edge by their centres instead, at most this far off): a sliver of 5 um across the whole unit took a board's
#: steady solve from 75 to 274 CG iterations
EDGE_GAP_MM = 0.25

#: names of the outer faces of the housing, by grid face
HOUSING_FACE_NAMES = {"xmin": "side_xmin", "xmax": "side_xmax", "ymin": "side_ymin", "ymax": "side_ymax",
                      "zmin": "bottom", "zmax": "top"}


@dataclass(frozen=True)
class MeshInfo:
    """Summary of a mesh for reports and ``geometry.json``.

    n_cells, n_nodes : int
    min_cell_mm, max_cell_mm : float [mm] smallest and largest cell edge
    cells_across : dict  part name -> fewest cells across the part along any axis
    thinnest_gap_mm : float or None [mm] the thinnest gap of the fill between two solids, along any axis
        (None: no fill); thinnest_gap_cells : int, the cells across it; thinnest_gap_axis : str (x, y, z);
        thinnest_gap_at_mm : tuple [mm] the centre of one of its cells
    fewest_gap_cells : int or None, the fewest cells across any gap of the fill (``min_cells`` or more)
    """

    n_cells: int
    n_nodes: int
    min_cell_mm: float
    max_cell_mm: float
    cells_across: dict
    thinnest_gap_mm: float | None = None
    thinnest_gap_cells: int | None = None
    thinnest_gap_axis: str | None = None
    thinnest_gap_at_mm: tuple | None = None
    fewest_gap_cells: int | None = None

    def gap_line(self) -> str:
        """The thinnest gap in words, for the mesh summary lines of the commands."""
        if self.thinnest_gap_mm is None:
            return "no fill gaps"
        at = ", ".join(f"{v:.1f}" for v in self.thinnest_gap_at_mm)
        return (f"thinnest gap {self.thinnest_gap_mm:.3g} mm along {self.thinnest_gap_axis} at ({at}) mm, "
                f"{self.thinnest_gap_cells} cells across; every gap >= {self.fewest_gap_cells} cells")


def _spans(part, geometry: Geometry, axis: int) -> list:
    """The solid extents of a part along one axis (the housing: its two walls)."""
    if part.kind == "fill":
        return []
    if part.kind == "housing":
        lo, hi = geometry.outer[0][axis], part.hi[axis]
        cav = geometry.cavity
        spans = [(lo, cav[0][axis])]
        if axis < 2:
            spans.append((cav[1][axis], hi))
        return spans
    return [(part.lo[axis], part.hi[axis])]


def _face_lines(geometry: Geometry, axis: int) -> np.ndarray:
    """The grid lines of every part face along one axis [m]: faces closer than :data:`LINE_TOL_MM` share the
    line of the lowest of them (a sliver between nearly coincident faces is no cell of its own)."""
    pts = [geometry.outer[0][axis], geometry.outer[1][axis], geometry.cavity[0][axis], geometry.cavity[1][axis]]
    for p in geometry.parts:
        pts += [p.lo[axis], p.hi[axis]]
    v = np.unique(np.asarray(pts, float))
    keep = np.concatenate([[True], np.diff(v) >= LINE_TOL_MM * MM])
    v = v[keep]
    for board, loops in _cut_boards(geometry):   # a cut-out's or slot's long straight edges
        n = AXES.index(board.normal)
        if axis != n:
            k = [a for a in range(3) if a != n].index(axis)
            for c in edge_lines(loops, k):   # one near another line would make a sliver of cells across the unit
                c = (board.min_mm[axis] + c) * MM
                if np.min(np.abs(v - c)) >= EDGE_GAP_MM * MM:
                    v = np.insert(v, np.searchsorted(v, c), c)
    return v


def _line_index(lines: np.ndarray, values) -> np.ndarray:
    """Index of the grid line each face coordinate [m] lies on (within :data:`LINE_TOL_MM`, see :func:`_face_lines`)."""
    return np.searchsorted(lines, np.asarray(values, float) + 0.5 * LINE_TOL_MM * MM, side="right") - 1


def _paint(geometry: Geometry, lines: tuple) -> np.ndarray:
    """Part index of every cell of the grid with lines ``lines`` (x, y, z) [m]: housing, fill, lid, then the inner
    parts in layout order (packages before their dies and pads), each later part over the earlier ones."""
    parts = geometry.parts
    cell_part = np.empty(tuple(len(v) - 1 for v in lines), dtype=np.int32)
    first = ("housing", "fill", "lid")
    order = sorted(range(len(parts)), key=lambda i: first.index(parts[i].kind) if parts[i].kind in first else 3)
    for i in order:
        p = parts[i]
        idx = tuple(slice(*_line_index(v, [p.lo[a], p.hi[a]])) for a, v in enumerate(lines))
        cell_part[idx] = i
    fill = next((i for i, p in enumerate(parts) if p.kind == "fill"), None)
    index = {p.name: i for i, p in enumerate(parts)}
    for board, loops in _cut_boards(geometry) if fill is not None else ():
        i = index[board.name]
        p = parts[i]
        idx = tuple(slice(*_line_index(v, [p.lo[a], p.hi[a]])) for a, v in enumerate(lines))
        n = AXES.index(board.normal)
        a0, a1 = (a for a in range(3) if a != n)
        centres = [0.5 * (lines[a][idx[a]] + lines[a][idx[a].start + 1:idx[a].stop + 1]) / MM - board.min_mm[a]
                   for a in (a0, a1)]
        out = np.expand_dims(outside_cells(loops, *centres), n)   # (u, v) -> the board's (x, y, z) order
        block = cell_part[idx]
        block[(block == i) & out] = fill
    return cell_part


def _cut_boards(geometry: Geometry) -> list:
    """(board spec, closed loops [mm]) of the boards whose true outline takes cells off their rectangle."""
    out = []
    for b in geometry.layout.boards:
        loops = board_loops(b.outline_mm)
        n = AXES.index(b.normal)
        a0, a1 = (a for a in range(3) if a != n)
        if loops and cuts_board(loops, b.size_mm[a0], b.size_mm[a1]):
            out.append((b, loops))
    return out


def _fill_runs(solid: np.ndarray, widths: np.ndarray, axis: int) -> tuple:
    """Runs of fill cells (``solid`` False) along ``axis`` between solid cells (``widths`` [m]: the cell widths
    along it, 1-D): for each cell, the length [m] of the run through it (0 in solids) and the run's number of
    cells, both shaped like ``solid``."""
    m = np.moveaxis(~solid, axis, -1)
    n = m.shape[-1]
    rows = m.reshape(-1, n)
    start = rows & ~np.concatenate([np.zeros((rows.shape[0], 1), bool), rows[:, :-1]], axis=1)
    run = np.cumsum(start.ravel()).reshape(rows.shape) * rows      # run id, 0 in solids
    ids = run[rows]
    length = np.bincount(ids, weights=np.broadcast_to(np.asarray(widths, float), rows.shape)[rows])
    count = np.bincount(ids)
    out_len = np.zeros(rows.shape)
    out_cnt = np.zeros(rows.shape, dtype=np.int64)
    out_len[rows] = length[ids]
    out_cnt[rows] = count[ids]
    back = lambda a: np.moveaxis(a.reshape(m.shape), -1, axis)  # noqa: E731
    return back(out_len), back(out_cnt)


def _axis_counts(geometry: Geometry, axis: int, max_cell: float, min_cells: int, skeleton=None) -> tuple:
    """The part-face lines along one axis and the cells [-] (float, uncapped) between each two of them.

    Every interval gets cells no longer than ``max_cell`` [m]; every solid part ``min_cells`` across its
    extent (boards, via fields, standoffs ``BOARD_CELLS_FACTOR`` times as many); every gap of the fill
    between two solids (a run of fill along the axis, on the grid of the face lines) ``min_cells`` across.
    ``skeleton``: (lines (x, y, z), cell part index) of that face-line grid, if already painted.
    """
    if skeleton is None:
        skeleton = _skeleton(geometry)
    lines3, cp = skeleton
    lines = lines3[axis]
    widths = np.diff(lines)
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        n = np.maximum(np.ceil(widths / max_cell - 1e-9), 1.0)
        for p in geometry.parts:
            cells = min_cells * (BOARD_CELLS_FACTOR if p.kind in _FACTOR_KINDS else 1)
            for lo, hi in _spans(p, geometry, axis):
                i0, i1 = _line_index(lines, [lo, hi])
                need = np.ceil(cells * widths[i0:i1] / (lines[i1] - lines[i0]) - 1e-9)
                n[i0:i1] = np.maximum(n[i0:i1], need)
        fill = [i for i, p in enumerate(geometry.parts) if p.kind == "fill"]
        if fill:   # a run of fill between two solids along the axis is a gap: min_cells across it, like a part
            gap, _ = _fill_runs(cp != fill[0], widths, axis)
            inside = gap > 0
            need = np.where(inside, np.ceil(min_cells * _along(widths, axis) / np.where(inside, gap, 1.0) - 1e-9), 0)
            n = np.maximum(n, np.moveaxis(need, axis, 0).reshape(len(widths), -1).max(axis=1, initial=0))
    return lines, n


def _along(v: np.ndarray, axis: int) -> np.ndarray:
    """A 1-D array along ``axis`` shaped to broadcast over a 3-D cell array."""
    shape = [1, 1, 1]
    shape[axis] = len(v)
    return np.reshape(v, shape)


def _skeleton(geometry: Geometry) -> tuple:
    """The grid of the part-face lines alone (one cell per interval) and its cell part index."""
    lines = tuple(_face_lines(geometry, a) for a in range(3))
    return lines, _paint(geometry, lines)


def _axis_lines(geometry: Geometry, axis: int, max_cell: float, min_cells: int, skeleton=None) -> np.ndarray:
    lines, n = _axis_counts(geometry, axis, max_cell, min_cells, skeleton)
    pieces = [np.linspace(a, b, k + 1)[:-1] for a, b, k in zip(lines[:-1], lines[1:], n.astype(int))]
    return np.concatenate(pieces + [lines[-1:]])


def grid_shape(geometry: Geometry, max_cell_mm: float = DEFAULT_MAX_CELL_MM,
               min_cells: int = DEFAULT_MIN_CELLS) -> tuple:
    """(nx, ny, nz) cells [-] that :func:`build_mesh` would make, from the 1-D line counts only (cheap:
    nothing of the mesh's size is allocated, so an unaffordable mesh can be refused before it is built).
    Counts beyond 1e15 per axis are capped there."""
    _check_mesh_arguments(max_cell_mm, min_cells)
    sk = _skeleton(geometry)
    return tuple(int(min(float(np.sum(_axis_counts(geometry, a, max_cell_mm * MM, int(min_cells), sk)[1])), 1e15))
                 for a in range(3))


def _check_mesh_arguments(max_cell_mm, min_cells) -> None:
    if not np.isfinite(max_cell_mm) or max_cell_mm <= 0:
        raise InputError(f"--mesh-size must be a finite number > 0 [mm], got {max_cell_mm!r}")
    if int(min_cells) != min_cells or min_cells < 1:
        raise InputError(f"--min-cells must be an integer >= 1, got {min_cells!r}")


def build_mesh(geometry: Geometry, max_cell_mm: float = DEFAULT_MAX_CELL_MM,
               min_cells: int = DEFAULT_MIN_CELLS) -> TensorGrid:
    """The conforming tensor-product mesh of ``geometry``.

    Parameters
    ----------
    max_cell_mm : float [mm] largest cell edge
    min_cells : int, fewest cells across every part along each axis (boards, via fields and
        standoffs: ``BOARD_CELLS_FACTOR`` times as many)

    Examples
    --------
    A coarse mesh (6 mm cells, one cell across the thinnest part; the default is 2 mm and two cells):

    >>> from imutherm.geometry.build import build_geometry
    >>> from imutherm.geometry.mesh import build_mesh, mesh_info
    >>> grid = build_mesh(build_geometry("imu_reference", "grease"), max_cell_mm=6, min_cells=1)
    >>> grid.shape, grid.n_nodes                 # cells along x, y, z; nodes
    ((53, 51, 23), 67392)
    >>> grid.part_names[:3]                      # one subdomain per part, named as in the layout
    ('housing', 'lid', 'main')
    >>> mesh_info(grid).cells_across["main"]     # cells through the main board's thickness
    2
    """
    _check_mesh_arguments(max_cell_mm, min_cells)
    sk = _skeleton(geometry)
    lines = tuple(_axis_lines(geometry, a, max_cell_mm * MM, int(min_cells), sk) for a in range(3))
    cell_part = _paint(geometry, lines)
    empty = [p.name for i, p in enumerate(geometry.parts) if not (cell_part == i).any()]
    if empty:
        raise InputError(f"{geometry.layout.path}: part(s) {', '.join(empty)} get no cell: thinner than the mesh's "
                         f"line tolerance of {LINE_TOL_MM * 1e3:g} um, or covered by other parts")
    return TensorGrid(*lines, cell_part, tuple(p.name for p in geometry.parts), dict(HOUSING_FACE_NAMES))


def refine_grid(grid: TensorGrid, factor: int = 2) -> TensorGrid:
    """``grid`` with every interval split into ``factor`` equal parts (each cell into ``factor**3`` cells of the
    same part): the uniform refinement of a mesh-convergence study. Its Q1 space contains the coarse one
    (nested), so the coarse field is exactly representable on it (:func:`prolongation`)."""
    if int(factor) != factor or factor < 1:
        raise InputError(f"refinement factor must be an integer >= 1, got {factor!r}")
    factor = int(factor)
    t = np.arange(factor) / factor

    def split(x):
        return np.concatenate([(x[:-1, None] + np.diff(x)[:, None] * t[None, :]).ravel(), x[-1:]])

    cp = grid.cell_part
    for a in range(3):
        cp = np.repeat(cp, factor, axis=a)
    return TensorGrid(split(grid.xs), split(grid.ys), split(grid.zs), cp, grid.part_names, dict(grid.face_names))


def prolongation(coarse: TensorGrid, fine: TensorGrid) -> "Prolongation":
    """The (fine nodes, coarse nodes) trilinear interpolation of a nodal field from ``coarse`` to ``fine`` (exact
    for a refinement of ``coarse``: :func:`refine_grid`), as a :class:`Prolongation` operator."""
    import scipy.sparse as sp

    def interp(xc, xf):
        i = np.clip(np.searchsorted(xc, xf, side="right") - 1, 0, len(xc) - 2)
        w = np.clip((xf - xc[i]) / (xc[i + 1] - xc[i]), 0.0, 1.0)
        rows = np.arange(len(xf))
        P = sp.csr_matrix((np.r_[1 - w, w], (np.r_[rows, rows], np.r_[i, i + 1])), shape=(len(xf), len(xc)))
        P.eliminate_zeros()   # a fine node on a coarse one takes that node alone
        return P

    return Prolongation((interp(coarse.xs, fine.xs), interp(coarse.ys, fine.ys), interp(coarse.zs, fine.zs)))


class Prolongation:
    """The trilinear interpolation between two tensor grids' nodal fields: the Kronecker product of its three 1-D
    interpolations ``factors`` (sparse (fine lines, coarse lines) along x, y, z), applied one axis at a time.
    ``P @ x`` interpolates a coarse field (n_coarse,) to the fine nodes, ``P.T @ y`` is the transpose (the
    restriction of a fine residual). No (fine, coarse) matrix is formed: on the reference unit's 2x refined mesh
    it held 61 MB beside the refined solve, the study's peak."""

    def __init__(self, factors: tuple, transpose: bool = False):
        self.factors, self.transpose = tuple(factors), transpose
        fine, coarse = (int(np.prod([f.shape[k] for f in self.factors])) for k in (0, 1))
        self.shape = (coarse, fine) if transpose else (fine, coarse)

    @property
    def T(self) -> "Prolongation":
        return Prolongation(self.factors, not self.transpose)

    def __matmul__(self, x):
        x = np.asarray(x, float)
        if x.ndim != 1 or x.shape[0] != self.shape[1]:
            raise ValueError(f"prolongation: a vector of {self.shape[1]} values needed, got shape {x.shape}")
        mats = [f.T if self.transpose else f for f in self.factors]
        X = x.reshape([m.shape[1] for m in mats])
        for axis, m in enumerate(mats):   # one 1-D interpolation along each axis
            X = np.moveaxis(X, axis, 0)
            rest = X.shape[1:]
            X = np.moveaxis((m @ X.reshape(X.shape[0], -1)).reshape((m.shape[0],) + rest), 0, axis)
        return np.ascontiguousarray(X).reshape(-1)


def mesh_info(grid: TensorGrid) -> MeshInfo:
    """Cell and node counts, cell-size range and the cells across each part."""
    widths = np.concatenate(grid.cell_sizes())
    across = {}
    for idx, name in enumerate(grid.part_names):
        mask = grid.cell_part == idx
        if not mask.any():
            across[name] = 0
            continue
        # fewest cells the part spans along any axis, over the grid lines through it
        counts = [int(mask.sum(axis=a).max()) for a in range(3)]
        across[name] = min(counts)
    gaps = grid_gaps(grid)
    return MeshInfo(grid.n_cells, grid.n_nodes, float(widths.min() / MM), float(widths.max() / MM), across, **gaps)


def grid_gaps(grid: TensorGrid) -> dict:
    """The thinnest gap of the fill between solids and the fewest cells across any gap (:class:`MeshInfo`)."""
    if "fill" not in grid.part_names or not (grid.cell_part == grid.part_names.index("fill")).any():
        return {}
    solid = grid.cell_part != grid.part_names.index("fill")
    best, fewest = None, None
    for axis, w in enumerate(grid.cell_sizes()):
        length, count = _fill_runs(solid, w, axis)
        inside = length > 0
        c = int(count[inside].min())
        fewest = c if fewest is None else min(fewest, c)
        i = np.unravel_index(np.argmin(np.where(inside, length, np.inf)), length.shape)
        if best is None or length[i] < best[0]:
            best = (float(length[i]), int(count[i]), axis, i)
    width, cells, axis, i = best
    centre = tuple(float(c[j] / MM) for c, j in zip(grid.cell_centres(), i))
    return {"thinnest_gap_mm": width / MM, "thinnest_gap_cells": cells, "thinnest_gap_axis": "xyz"[axis],
            "thinnest_gap_at_mm": centre, "fewest_gap_cells": fewest}


def to_skfem(grid: TensorGrid):
    """The grid as a ``skfem.MeshHex`` with named subdomains (parts) and boundaries (outer faces)."""
    import skfem

    nx, ny, nz = grid.shape
    nid = np.arange(grid.n_nodes).reshape(nx + 1, ny + 1, nz + 1)
    c = lambda di, dj, dk: nid[di:di + nx, dj:dj + ny, dk:dk + nz].ravel()  # noqa: E731
    # scikit-fem's local hexahedron order: 000, 010, 100, 001, 110, 011, 101, 111
    t = np.vstack([c(0, 0, 0), c(0, 1, 0), c(1, 0, 0), c(0, 0, 1), c(1, 1, 0), c(0, 1, 1), c(1, 0, 1), c(1, 1, 1)])
    mesh = skfem.MeshHex(grid.node_coordinates().T, t)
    flat = grid.cell_part.ravel()
    subdomains = {name: np.flatnonzero(flat == i) for i, name in enumerate(grid.part_names)}
    bounds = (grid.xs[[0, -1]], grid.ys[[0, -1]], grid.zs[[0, -1]])
    boundaries = {}
    for f, face in enumerate(FACE_NAMES):
        axis, end = divmod(f, 2)
        value = bounds[axis][end]
        boundaries[grid.face_names.get(face, face)] = mesh.facets_satisfying(
            lambda x, a=axis, v=value: np.isclose(x[a], v))
    return mesh.with_subdomains(subdomains).with_boundaries(boundaries)
