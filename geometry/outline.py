"""A board's true outline in the mesh: closed loops, what lies inside them, their area, their straight edges.

A layout board's ``outline_mm`` (polylines of board-local (u, v) points [mm], as ``imutherm import`` writes the
board file's ``Edge.Cuts``) is joined end to end into closed loops (:func:`chain`) and filled by the even-odd
rule (:func:`inside`): a loop inside a loop is a cut-out or a slot, as KiCad and every fab read an outline. The
mesh takes the board's cells whose centres lie outside the filled loops out of the board (they are the cavity's
fill: air, or potting where the scheme pots), and puts grid lines on the outline's long axis-aligned edges, so a
rectangular cut-out or slot is exact; a curved edge is followed cell by cell (a staircase of cell centres). An
outline that does not close into a loop leaves the board its rectangle. Lengths [mm].
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np

from imutherm.textio import quote

#: ends of two outline pieces closer than this join [mm] (KiCad snaps ends to 1 nm; hand-drawn outlines
#: leave gaps of a few um)
JOIN_MM = 0.01
#: an axis-aligned outline edge at least this long [mm] gets a grid line of its own (shorter ones, and the
#: short chords of an arc, are followed by the cells)
EDGE_LINE_MM = 1.0
#: most points of a board outline (a real outline with its arcs drawn as polylines has a few hundred)
MAX_OUTLINE_POINTS = 20000
#: most grid lines an outline adds along each axis (the longest edges first): a castellated or panel edge of
#: hundreds of short straight pieces must not multiply the mesh
MAX_EDGE_LINES = 48


def chain(polylines, tol: float = JOIN_MM) -> tuple:
    """(closed loops, open polylines): the polylines joined end to end where their ends meet within ``tol``.

    A closed loop ends on its first point. Pieces are matched through a grid of their ends (linear in the
    number of pieces)."""
    pending = {i: [tuple(p) for p in line] for i, line in enumerate(polylines) if len(line) >= 2}
    cell = max(tol, 1e-9)
    ends: dict = {}

    def key(p):
        return (math.floor(p[0] / cell), math.floor(p[1] / cell))

    def add(i):
        for p in (pending[i][0], pending[i][-1]):
            ends.setdefault(key(p), set()).add(i)

    def remove(i):
        for p in (pending[i][0], pending[i][-1]):
            ends.get(key(p), set()).discard(i)

    def partner(p, me):
        kx, ky = key(p)
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for j in ends.get((kx + dx, ky + dy), ()):
                    if j != me and (math.dist(pending[j][0], p) <= tol or math.dist(pending[j][-1], p) <= tol):
                        return j
        return None

    for i in pending:
        add(i)
    loops, open_lines = [], []
    while pending:
        i = next(iter(pending))
        remove(i)
        line = pending.pop(i)
        for _ in range(2):  # grow forwards, then backwards
            while math.dist(line[0], line[-1]) > tol:
                j = partner(line[-1], i)
                if j is None:
                    break
                remove(j)
                other = pending.pop(j)
                line += other[1:] if math.dist(other[0], line[-1]) <= tol else other[-2::-1]
            line.reverse()
        if len(line) >= 4 and math.dist(line[0], line[-1]) <= tol:
            line[-1] = line[0]
            loops.append(line)
        else:
            open_lines.append(line)
    return loops, open_lines


def inside(loops, x, y) -> np.ndarray:
    """Which points (arrays ``x``, ``y`` [mm]) lie inside the closed ``loops`` by the even-odd rule: a ray from each
    point towards +x crosses the loops' edges an odd number of times (edge by edge, every point at once)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    px, py = x.ravel(), y.ravel()
    result = np.zeros(px.shape, bool)
    for loop in loops:
        pts = np.asarray(loop, float)
        if len(pts) and not np.array_equal(pts[0], pts[-1]):
            pts = np.vstack([pts, pts[:1]])   # a loop given open is closed, as a fab reads it
        for (x0, y0), (x1, y1) in zip(pts[:-1], pts[1:]):
            if y0 == y1:
                continue
            spans = (y0 > py) != (y1 > py)
            result[spans] ^= px[spans] < x0 + (py[spans] - y0) * (x1 - x0) / (y1 - y0)
    return result.reshape(x.shape)


def loop_area(loop) -> float:
    """The area a closed loop encloses [mm^2] (shoelace; positive whatever its direction)."""
    p = np.asarray(loop, float)
    return 0.5 * abs(float(np.dot(p[:-1, 0], p[1:, 1]) - np.dot(p[1:, 0], p[:-1, 1])))


@lru_cache(maxsize=64)
def board_loops(outline_mm) -> tuple:
    """The closed loops of a layout board's ``outline_mm`` (a tuple of polylines [mm]); () when none closes."""
    if not outline_mm:
        return ()
    loops, _ = chain(outline_mm)
    return tuple(tuple(loop) for loop in loops)


def outline_area(loops) -> float:
    """The area [mm^2] the ``loops`` fill by the even-odd rule (a loop nested in an odd number of others is a
    cut-out and subtracts)."""
    total = 0.0
    for i, loop in enumerate(loops):
        others = [other for j, other in enumerate(loops) if j != i]
        depth = int(sum(inside([o], [loop[0][0]], [loop[0][1]])[0] for o in others))
        total += loop_area(loop) * (-1 if depth % 2 else 1)
    return total


def cuts_board(loops, width_mm: float, height_mm: float, tol: float = 1e-6) -> bool:
    """True if the loops take anything off the ``width_mm`` x ``height_mm`` rectangle (not just its own
    edge drawn)."""
    return bool(loops) and outline_area(loops) < width_mm * height_mm * (1 - tol)


def edge_lines(loops, axis: int, min_mm: float = EDGE_LINE_MM, most: int = MAX_EDGE_LINES) -> list:
    """The coordinates [mm] along ``axis`` (0: u, 1: v) of the outline's edges that run across it (constant
    ``axis`` coordinate) and are at least ``min_mm`` long: at most ``most``, the longest first."""
    found = {}
    for loop in loops:
        p = np.asarray(loop, float)
        d = np.diff(p, axis=0)
        other = 1 - axis
        straight = (np.abs(d[:, axis]) <= 1e-6) & (np.abs(d[:, other]) >= min_mm)
        for k in np.flatnonzero(straight):
            c = round(float(p[k, axis]), 6)
            found[c] = max(found.get(c, 0.0), abs(float(d[k, other])))
    return sorted(sorted(found, key=lambda c: -found[c])[:most])


def outside_cells(loops, u_centres, v_centres) -> np.ndarray:
    """(nu, nv) bool: which cells of centres ``u_centres`` x ``v_centres`` [mm] lie outside the loops."""
    gu, gv = np.meshgrid(np.asarray(u_centres, float), np.asarray(v_centres, float), indexing="ij")
    return ~inside(loops, gu, gv)



def outline_from_table(value, span: tuple, fail):
    """A layout board's ``outline_mm`` (polylines of [u, v] board-local points [mm] within the board's ``span``
    (u, v) [mm]) as a tuple of tuples, None when absent; ``fail(field, message)`` raises on bad input."""
    if value is None:
        return None
    if not isinstance(value, list) or not value:
        fail("outline_mm", "must be a non-empty list of polylines, each a list of [u, v] points [mm]")
    lines, count = [], 0
    for line in value:
        if not isinstance(line, list) or len(line) < 2:
            fail("outline_mm", f"each polyline needs at least 2 [u, v] points, got {quote(line, 80)}")
        pts = []
        for p in line:
            if (not isinstance(p, list) or len(p) != 2 or not all(
                    isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in p)):
                fail("outline_mm", f"points must be [u, v] pairs of finite numbers [mm], got {quote(p, 80)}")
            if not all(-1e-3 <= v <= s + 1e-3 for v, s in zip(p, span)):
                fail("outline_mm", f"point {p} lies outside the board (0..{span[0]:g}, 0..{span[1]:g} mm)")
            pts.append((float(p[0]), float(p[1])))
        count += len(pts)
        if count > MAX_OUTLINE_POINTS:
            fail("outline_mm", f"more than {MAX_OUTLINE_POINTS} points")
        lines.append(tuple(pts))
    return tuple(lines)


def coverage_from_table(value, fail):
    """A layout board's ``copper_coverage`` (each copper layer's measured coverage, front to back, fractions
    0..1) as a tuple, () when absent; ``fail(field, message)`` raises on bad input."""
    if value is None:
        return ()
    if not (isinstance(value, list) and 0 < len(value) <= 64
            and all(isinstance(v, (int, float)) and not isinstance(v, bool) and 0 <= v <= 1 for v in value)):
        fail("copper_coverage", f"must be a list of fractions 0..1, one per copper layer front to back, got "
                                f"{quote(value, 80)}")
    return tuple(float(v) for v in value)
