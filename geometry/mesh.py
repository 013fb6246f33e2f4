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

DEFAULT_MAX_CELL_MM = 2.0  # [mm] default largest cell edge; the mesh convergence study: docs/benchmarks/reference.md
DEFAULT_MIN_CELLS = 2      # cells across the thinnest dimension of every part
BOARD_CELLS_FACTOR = 2     # boards, via fields, standoffs: this many times min_cells across
_FACTOR_KINDS = ("board", "vias", "box")

#: names of the outer faces of the housing, by grid face
HOUSING_FACE_NAMES = {"xmin": "side_xmin", "xmax": "side_xmax", "ymin": "side_ymin", "ymax": "side_ymax",
                      "zmin": "bottom", "zmax": "top"}


@dataclass(frozen=True)
class MeshInfo:
    """Summary of a mesh for reports and ``geometry.json``.

    n_cells, n_nodes : int
    min_cell_mm, max_cell_mm : float [mm] smallest and largest cell edge
    cells_across : dict  part name -> fewest cells across the part along any axis
    """

    n_cells: int
    n_nodes: int
    min_cell_mm: float
    max_cell_mm: float
    cells_across: dict


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


def _axis_counts(geometry: Geometry, axis: int, max_cell: float, min_cells: int) -> tuple:
    """The part-face lines along one axis and the cells [-] (float, uncapped) between each two of them."""
    pts = [geometry.outer[0][axis], geometry.outer[1][axis], geometry.cavity[0][axis], geometry.cavity[1][axis]]
    for p in geometry.parts:
        pts += [p.lo[axis], p.hi[axis]]
    lines = np.unique(np.round(np.asarray(pts), 12))
    widths = np.diff(lines)
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        n = np.maximum(np.ceil(widths / max_cell - 1e-9), 1.0)
        for p in geometry.parts:
            cells = min_cells * (BOARD_CELLS_FACTOR if p.kind in _FACTOR_KINDS else 1)
            for lo, hi in _spans(p, geometry, axis):
                i0, i1 = np.searchsorted(lines, [lo - 1e-12, hi - 1e-12])
                need = np.ceil(cells * widths[i0:i1] / (hi - lo) - 1e-9)
                n[i0:i1] = np.maximum(n[i0:i1], need)
    return lines, n


def _axis_lines(geometry: Geometry, axis: int, max_cell: float, min_cells: int) -> np.ndarray:
    lines, n = _axis_counts(geometry, axis, max_cell, min_cells)
    pieces = [np.linspace(a, b, k + 1)[:-1] for a, b, k in zip(lines[:-1], lines[1:], n.astype(int))]
    return np.concatenate(pieces + [lines[-1:]])


def grid_shape(geometry: Geometry, max_cell_mm: float = DEFAULT_MAX_CELL_MM,
               min_cells: int = DEFAULT_MIN_CELLS) -> tuple:
    """(nx, ny, nz) cells [-] that :func:`build_mesh` would make, from the 1-D line counts only (cheap:
    nothing of the mesh's size is allocated, so an unaffordable mesh can be refused before it is built).
    Counts beyond 1e15 per axis are capped there."""
    _check_mesh_arguments(max_cell_mm, min_cells)
    return tuple(int(min(float(np.sum(_axis_counts(geometry, a, max_cell_mm * MM, int(min_cells))[1])), 1e15))
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
    xs, ys, zs = (_axis_lines(geometry, a, max_cell_mm * MM, int(min_cells)) for a in range(3))
    names = tuple(p.name for p in geometry.parts)
    cell_part = np.empty((len(xs) - 1, len(ys) - 1, len(zs) - 1), dtype=np.int32)

    def index(lines, lo, hi):
        return slice(*np.searchsorted(lines, [lo - 1e-12, hi - 1e-12]))

    def paint(lo, hi, value):
        cell_part[index(xs, lo[0], hi[0]), index(ys, lo[1], hi[1]), index(zs, lo[2], hi[2])] = value

    order = sorted(range(len(names)), key=lambda i: ("housing", "fill", "lid").index(geometry.parts[i].kind)
                   if geometry.parts[i].kind in ("housing", "fill", "lid") else 3)
    for i in order:  # housing, fill, lid, then the inner parts (packages before their dies and pads)
        p = geometry.parts[i]
        paint(p.lo, p.hi, i)
    face_names = dict(HOUSING_FACE_NAMES)
    return TensorGrid(xs, ys, zs, cell_part, names, face_names)


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
    return MeshInfo(grid.n_cells, grid.n_nodes, float(widths.min() / MM), float(widths.max() / MM), across)


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
