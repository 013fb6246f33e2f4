"""The conforming mesh: a non-uniform tensor-product grid of boxes.

All parts are axis-aligned boxes, so grid lines placed on every part face make
a mesh that conforms exactly, with one part per cell.

Index conventions (used by every solver and export):

* node (i, j, k) has coordinates ``(xs[i], ys[j], zs[k])``; node arrays have
  shape ``(nx+1, ny+1, nz+1)`` and flatten in C order:
  ``node = (i * (ny+1) + j) * (nz+1) + k``;
* cell (i, j, k) spans ``[xs[i], xs[i+1]] x [ys[j], ys[j+1]] x [zs[k], zs[k+1]]``;
  cell arrays have shape ``(nx, ny, nz)`` and flatten in C order:
  ``cell = (i * ny + j) * nz + k``;
* outer faces are named ``xmin xmax ymin ymax zmin zmax``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FACE_NAMES = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")


@dataclass(frozen=True)
class TensorGrid:
    """A tensor-product hexahedral grid with a part index per cell.

    Attributes
    ----------
    xs, ys, zs : ndarray [m]
        Strictly increasing node coordinates along each axis.
    cell_part : ndarray of int, shape (nx, ny, nz)
        Index into ``part_names`` of the part each cell belongs to.
    part_names : tuple of str
        Part names; the mesh subdomains carry these names.
    face_names : dict
        Outer face (``xmin`` ... ``zmax``) -> name given by the layout
        (e.g. ``zmin`` -> ``"bottom (mounting face)"``).
    """

    xs: np.ndarray
    ys: np.ndarray
    zs: np.ndarray
    cell_part: np.ndarray
    part_names: tuple
    face_names: dict

    @property
    def shape(self) -> tuple:
        """Number of cells along x, y, z."""
        return (len(self.xs) - 1, len(self.ys) - 1, len(self.zs) - 1)

    @property
    def n_cells(self) -> int:
        nx, ny, nz = self.shape
        return nx * ny * nz

    @property
    def n_nodes(self) -> int:
        return len(self.xs) * len(self.ys) * len(self.zs)

    def cell_sizes(self) -> tuple:
        """Cell widths along x, y, z [m] (three 1-D arrays)."""
        return np.diff(self.xs), np.diff(self.ys), np.diff(self.zs)

    def cell_volumes(self) -> np.ndarray:
        """Cell volumes [m^3], shape (nx, ny, nz)."""
        dx, dy, dz = self.cell_sizes()
        return dx[:, None, None] * dy[None, :, None] * dz[None, None, :]

    def cell_centres(self) -> tuple:
        """Cell-centre coordinates along x, y, z [m] (three 1-D arrays)."""
        return (0.5 * (self.xs[1:] + self.xs[:-1]), 0.5 * (self.ys[1:] + self.ys[:-1]),
                0.5 * (self.zs[1:] + self.zs[:-1]))

    def node_coordinates(self) -> np.ndarray:
        """All node coordinates [m], shape (n_nodes, 3), C order as documented above."""
        X, Y, Z = np.meshgrid(self.xs, self.ys, self.zs, indexing="ij")
        return np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])

    def hex_connectivity(self) -> np.ndarray:
        """Cell -> 8 node indices, shape (n_cells, 8), VTK hexahedron order."""
        nx, ny, nz = self.shape
        nid = np.arange(self.n_nodes).reshape(nx + 1, ny + 1, nz + 1)
        c = lambda di, dj, dk: nid[di:di + nx, dj:dj + ny, dk:dk + nz].ravel()  # noqa: E731
        return np.column_stack([c(0, 0, 0), c(1, 0, 0), c(1, 1, 0), c(0, 1, 0),
                                c(0, 0, 1), c(1, 0, 1), c(1, 1, 1), c(0, 1, 1)])

