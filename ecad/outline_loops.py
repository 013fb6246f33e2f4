"""A board outline's polylines: joined into closed loops, simplified, and tested for what lies inside.

Readers return the outline as drawn: separate lines and arcs (KiCad's ``Edge.Cuts``), loops (IDF). These
functions join them end to end into closed loops (:func:`chain`), drop points that change the shape by less
than a tolerance (:func:`simplify`, Douglas-Peucker, so a million-point outline costs seconds, not minutes, and
the layout stays small) and fill them by the even-odd rule (:func:`inside`): a loop inside a loop is a
cut-out, as KiCad and every fab read an outline. Lengths [mm].
"""

from __future__ import annotations

import math

import numpy as np

from imutherm import InputError
from imutherm.geometry.layout import MAX_OUTLINE_POINTS

#: ends of two outline pieces closer than this join [mm] (KiCad snaps ends to 1 nm; hand-drawn outlines
#: leave gaps of a few um)
JOIN_MM = 0.01
#: a simplified outline stays within this of the drawn one [mm] (far below a mesh cell)
SIMPLIFY_MM = 0.005
#: most outline points kept after simplification: what a layout holds (a board edge of more is not an outline
#: to model)
MAX_POINTS = MAX_OUTLINE_POINTS


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


def simplify(line, tol: float = SIMPLIFY_MM) -> list:
    """``line`` with the points dropped that lie within ``tol`` of the segment of their kept neighbours
    (Douglas-Peucker, iterative); the first and last points are kept."""
    pts = np.asarray(line, float)
    n = len(pts)
    if n <= 3:
        return [tuple(p) for p in pts]
    keep = np.zeros(n, bool)
    keep[0] = keep[-1] = True
    if np.allclose(pts[0], pts[-1]):  # a closed loop: split at the point farthest from its start
        far = int(np.argmax(np.hypot(*(pts - pts[0]).T)))
        keep[far] = True
        stack = [(0, far), (far, n - 1)]
    else:
        stack = [(0, n - 1)]
    while stack:
        a, b = stack.pop()
        if b - a < 2:
            continue
        seg = pts[b] - pts[a]
        rel = pts[a + 1:b] - pts[a]
        length = math.hypot(*seg)
        d = np.abs(seg[0] * rel[:, 1] - seg[1] * rel[:, 0]) / length if length > 0 else np.hypot(*rel.T)
        k = int(np.argmax(d))
        if d[k] > tol:
            m = a + 1 + k
            keep[m] = True
            stack += [(a, m), (m, b)]
    return [tuple(p) for p in pts[keep]]


def simplified_outline(polylines, where: str, tol: float = SIMPLIFY_MM) -> list:
    """Every polyline simplified (:func:`simplify`); InputError if more than :data:`MAX_POINTS` points remain."""
    out = [simplify(line, tol) for line in polylines]
    total = sum(len(line) for line in out)
    if total > MAX_POINTS:
        raw = sum(len(line) for line in polylines)
        raise InputError(f"{where}: the board outline has {raw:,} points, {total:,} after dropping those within "
                         f"{tol * 1e3:g} um of a straight line; at most {MAX_POINTS:,}: not an outline to model "
                         f"(simplify the board edge in the ECAD tool)")
    return out


def inside(loops, x, y) -> np.ndarray:
    """Which points (arrays ``x``, ``y`` [mm]) lie inside the closed ``loops`` by the even-odd rule."""
    from matplotlib.path import Path as MplPath

    x, y = np.asarray(x, float), np.asarray(y, float)
    pts = np.column_stack([x.ravel(), y.ravel()])
    result = np.zeros(len(pts), bool)
    for loop in loops:
        result ^= MplPath(np.asarray(loop, float)).contains_points(pts)
    return result.reshape(x.shape)


def loop_area(loop) -> float:
    """The area a closed loop encloses [mm^2] (shoelace; positive whatever its direction)."""
    p = np.asarray(loop, float)
    return 0.5 * abs(float(np.dot(p[:-1, 0], p[1:, 1]) - np.dot(p[1:, 0], p[:-1, 1])))
