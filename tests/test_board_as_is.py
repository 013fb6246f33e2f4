"""The board as it is (issue 55 item 4): its true outline in the mesh, its copper measured, its vias, its
parts' heights from their 3D models. Boards written by the test (``tests/kicad_writer.py``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imutherm.ecad.read import read_board
from imutherm.ecad.to_layout import ImportOptions, import_board
from imutherm.geometry.build import build_geometry
from imutherm.geometry.mesh import build_mesh
from imutherm.geometry.outline import board_loops, outline_area

from kicad_writer import kicad_board, part

SOIC = "Package_SO:SOIC-8_3.9x4.9mm"
POWER = ImportOptions(powers={"U1": (0.1, "test")})


def _import(tmp_path, parts=None, **kw):
    path = tmp_path / "b.kicad_pcb"
    path.write_text(kicad_board(parts or [part("U1", SOIC, (110, 105, 0))], **kw))
    return import_board(read_board(path), POWER)


def _board_cells(grid, name="main"):
    """(board-cell volume [mm^3], cell part array, in-plane cell centres [mm])."""
    dx, dy, dz = grid.cell_sizes()
    cells = grid.cell_part == grid.part_names.index(name)
    vol = float(np.einsum("i,j,k->ijk", dx, dy, dz)[cells].sum()) / 1e-9
    return vol, cells


# ------------------------------------------------------------------ 1: the true outline in the mesh
def test_a_slot_is_not_board_and_the_board_cells_fill_the_outline_exactly(tmp_path):
    """A 40 x 30 mm board with a 20 x 2 mm slot: the board's cells hold 40 x 30 - 20 x 2 = 1160 mm^2 of board
    (grid lines on the slot's edges make it exact), the slot's cells are the cavity's fill, and the board's
    volume (mass) is the outline's."""
    slot = '  (gr_rect (start 110 112) (end 130 114) (layer "Edge.Cuts") (width 0.05))'
    r = _import(tmp_path, extra=slot)
    g = build_geometry(r.spec, "air")
    grid = build_mesh(g)
    vol, cells = _board_cells(grid)
    t = r.board.thickness_mm
    assert vol == pytest.approx((40 * 30 - 20 * 2) * t, rel=1e-9)
    assert g.volumes["main"] / 1e-9 == pytest.approx((40 * 30 - 20 * 2) * t, rel=1e-9)
    xc, yc, zc = (c / 1e-3 for c in grid.cell_centres())
    x0, y0, z0 = r.spec.boards[0].min_mm
    # the slot: board-local u 10..30, v 16..18 (KiCad y 112..114 flipped on a board of y 100..130)
    i = np.flatnonzero((xc > x0 + 10) & (xc < x0 + 30))
    j = np.flatnonzero((yc > y0 + 16) & (yc < y0 + 18))
    k = np.flatnonzero((zc > z0) & (zc < z0 + t))
    block = grid.cell_part[np.ix_(i, j, k)]
    assert len(i) and len(j) and len(k) and (block == grid.part_names.index("fill")).all()
    # beside the slot, still board
    j_near = np.flatnonzero((yc > y0 + 19) & (yc < y0 + 20))
    assert cells[np.ix_(i, j_near, k)].all()


def test_a_round_cut_out_follows_the_outline_within_a_cell(tmp_path):
    """A 10 mm round hole in the board: the board cells' area is the outline's (40 x 30 - 25 pi mm^2) to within
    the staircase of cells along the circle (one cell row round its 31.4 mm circumference)."""
    hole = '  (gr_circle (center 120 115) (end 125 115) (layer "Edge.Cuts") (width 0.05))'
    r = _import(tmp_path, extra=hole)
    g = build_geometry(r.spec, "air")
    grid = build_mesh(g)
    vol, _ = _board_cells(grid)
    t = r.board.thickness_mm
    exact = (40 * 30 - 25 * math.pi) * t
    assert g.volumes["main"] / 1e-9 == pytest.approx(exact, rel=2e-3)   # the 72-gon of the drawn circle
    cell = max(float(np.max(np.diff(grid.xs))), float(np.max(np.diff(grid.ys)))) / 1e-3
    assert abs(vol - exact) < 0.5 * cell * 10 * math.pi * t
    assert vol < 40 * 30 * t - 0.5 * 25 * math.pi * t   # the hole is there, not the rectangle


def test_a_rectangular_outline_leaves_the_mesh_as_it_was(tmp_path):
    """An outline that is the board's rectangle cuts nothing: no board cell becomes fill, the volume is the
    box's."""
    r = _import(tmp_path)
    b = r.spec.boards[0]
    loops = board_loops(b.outline_mm)
    assert outline_area(loops) == pytest.approx(40 * 30)
    g = build_geometry(r.spec, "air")
    vol, _ = _board_cells(build_mesh(g))
    assert vol == pytest.approx(40 * 30 * r.board.thickness_mm, rel=1e-9)


def test_a_notched_board_edge_is_fill(tmp_path):
    """An L-shaped board (a 15 x 10 mm notch out of a 40 x 30 mm rectangle's corner): the notch is fill."""
    pts = [(100, 100), (140, 100), (140, 120), (125, 120), (125, 130), (100, 130), (100, 100)]
    edge = "\n".join(f'  (gr_line (start {a[0]} {a[1]}) (end {b[0]} {b[1]}) (layer "Edge.Cuts") (width 0.05))'
                     for a, b in zip(pts[:-1], pts[1:]))
    r = _import(tmp_path, outline=None, extra=edge)
    g = build_geometry(r.spec, "air")
    vol, _ = _board_cells(build_mesh(g))
    assert vol == pytest.approx((40 * 30 - 15 * 10) * r.board.thickness_mm, rel=1e-9)
