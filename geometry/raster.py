"""Shapes filled on a fine square raster with numpy: polygons (even-odd), thick lines and discs, rotated rectangles.

A :class:`Raster` is a grid of square cells of side ``cell`` [mm] whose cell (i, j) has its centre at
``(x0 + (i + 0.5) cell, y0 + (j + 0.5) cell)``; a cell belongs to a shape when its centre does. Masks are bool
arrays of shape ``(nx, ny)``. What the import measures with it: the copper of each layer of a board (zones,
tracks, pads) within the board's outline, as a fraction of the board's area
(:mod:`imutherm.ecad.kicad_copper`). The error of an area is at most a cell row along the shape's edge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from imutherm import InputError

#: crossings of a polygon's edges with the raster's rows computed at once (bounding the memory to tens of MB)
_CHUNK = 2_000_000
#: most crossings of one fill (a board's whole copper layer has a few hundred thousand): beyond, not a board
MAX_CROSSINGS = 100_000_000


@dataclass(frozen=True)
class Raster:
    """A square-cell raster: lower-left corner (x0, y0) [mm], cell side [mm], cells along x and y."""

    x0: float
    y0: float
    cell: float
    nx: int
    ny: int

    @staticmethod
    def over(width_mm: float, height_mm: float, cell_mm: float, max_cells: int = 4000) -> "Raster":
        """A raster over the rectangle 0..width x 0..height [mm] of cells ``cell_mm``, coarser if the longer
        side would need more than ``max_cells``."""
        cell = max(float(cell_mm), max(width_mm, height_mm) / max_cells)
        return Raster(0.0, 0.0, cell, max(1, math.ceil(width_mm / cell)), max(1, math.ceil(height_mm / cell)))

    def empty(self) -> np.ndarray:
        return np.zeros((self.nx, self.ny), bool)

    def _cols(self, x0: float, x1: float, n: int, origin: float) -> slice:
        """The cells along one axis whose centres may lie in x0..x1 [mm]."""
        lo = max(0, math.floor((x0 - origin) / self.cell - 0.5))
        hi = min(n, math.ceil((x1 - origin) / self.cell + 0.5))
        return slice(lo, max(lo, hi))

    def centres(self, si: slice, sj: slice) -> tuple:
        """(x, y) [mm] cell centres of the index ranges ``si``, ``sj`` (1-D each)."""
        return (self.x0 + (np.arange(si.start, si.stop) + 0.5) * self.cell,
                self.y0 + (np.arange(sj.start, sj.stop) + 0.5) * self.cell)

    def fill_polygons(self, mask: np.ndarray, polygons, what: str = "a polygon") -> None:
        """Set the cells inside ``polygons`` (each a sequence of (x, y) [mm], closed or not), all of them filled
        together by the even-odd rule (a polygon inside another is a hole), on ``mask``. Each edge is crossed
        with the rows it spans only (the work is the crossings, about twice the rows per loop for a real
        shape); InputError naming ``what`` beyond :data:`MAX_CROSSINGS`."""
        polys = [np.asarray(p, float) for p in polygons if len(p) >= 3]
        if not polys:
            return
        a = np.concatenate(polys)
        b = np.concatenate([np.roll(p, -1, axis=0) for p in polys])
        keep = a[:, 1] != b[:, 1]   # horizontal edges cross no row
        a, b = a[keep], b[keep]
        if not len(a):
            return
        lo, hi = np.minimum(a[:, 1], b[:, 1]), np.maximum(a[:, 1], b[:, 1])
        # rows whose centre line y satisfies lo <= y < hi (the crossing rule (a <= y) != (b <= y))
        j0 = np.clip(np.ceil((lo - self.y0) / self.cell - 0.5), 0, self.ny).astype(np.int64)
        j1 = np.clip(np.ceil((hi - self.y0) / self.cell - 0.5), 0, self.ny).astype(np.int64)
        n = j1 - j0
        total = int(n.sum())
        if total > MAX_CROSSINGS:
            raise InputError(f"{what}: {len(a):,} edges crossing the {self.cell:g} mm raster's rows {total:,} times: "
                             f"not a board's copper (at most {MAX_CROSSINGS:,})")
        if not total:
            return
        r_min, r_max = int(j0[n > 0].min()), int(j1[n > 0].max())
        counts = np.zeros((r_max - r_min) * (self.nx + 1), np.int32)
        ends = np.cumsum(n)
        start = 0
        while start < len(a):   # edges in groups of about _CHUNK crossings
            stop = int(np.searchsorted(ends, (ends[start - 1] if start else 0) + _CHUNK, side="right"))
            stop = max(stop, start + 1)
            e = np.repeat(np.arange(start, stop), n[start:stop])
            first = np.repeat(ends[start:stop] - n[start:stop], n[start:stop])
            r = j0[e] + (np.arange(len(e)) + (ends[start - 1] if start else 0) - first)
            y = self.y0 + (r + 0.5) * self.cell
            x = a[e, 0] + (y - a[e, 1]) / (b[e, 1] - a[e, 1]) * (b[e, 0] - a[e, 0])
            col = np.clip(np.ceil((x - self.x0) / self.cell - 0.5), 0, self.nx).astype(np.int64)  # first centre >= x
            counts += np.bincount((r - r_min) * (self.nx + 1) + col, minlength=len(counts)).astype(np.int32)
            start = stop
        parity = (np.cumsum(counts.reshape(r_max - r_min, self.nx + 1)[:, :self.nx], axis=1) % 2).astype(bool)
        mask[:, r_min:r_max] |= parity.T

    def fill_capsules(self, mask: np.ndarray, capsules) -> None:
        """Set the cells within distance r of a segment, for each capsule (x0, y0, x1, y1, r) [mm] (a disc: a
        segment of no length), on ``mask``: a track of width 2 r with round ends, a round or oval pad, a via."""
        for x0, y0, x1, y1, r in capsules:
            si = self._cols(min(x0, x1) - r, max(x0, x1) + r, self.nx, self.x0)
            sj = self._cols(min(y0, y1) - r, max(y0, y1) + r, self.ny, self.y0)
            if si.stop <= si.start or sj.stop <= sj.start:
                continue
            xs, ys = self.centres(si, sj)
            px, py = xs[:, None] - x0, ys[None, :] - y0
            dx, dy = x1 - x0, y1 - y0
            length2 = dx * dx + dy * dy
            t = np.clip((px * dx + py * dy) / length2, 0.0, 1.0) if length2 > 0 else 0.0
            mask[si, sj] |= (px - t * dx) ** 2 + (py - t * dy) ** 2 <= r * r

    def area(self, mask: np.ndarray) -> float:
        """The area [mm^2] of the cells set in ``mask``."""
        return float(np.count_nonzero(mask)) * self.cell * self.cell


def rotated_rect(cx: float, cy: float, w: float, h: float, angle_deg: float) -> list:
    """The corners [mm] of a ``w`` x ``h`` rectangle centred at (cx, cy), turned ``angle_deg`` counter-clockwise."""
    a = math.radians(angle_deg)
    c, s = math.cos(a), math.sin(a)
    return [(cx + u * c - v * s, cy + u * s + v * c) for u, v in ((-w / 2, -h / 2), (w / 2, -h / 2), (w / 2, h / 2),
                                                                  (-w / 2, h / 2))]
