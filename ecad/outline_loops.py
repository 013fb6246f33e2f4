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
from imutherm.geometry.outline import JOIN_MM, chain, inside, loop_area  # noqa: F401 (the API of this module)

#: a simplified outline stays within this of the drawn one [mm] (far below a mesh cell)
SIMPLIFY_MM = 0.005
#: most outline points kept after simplification: what a layout holds (a board edge of more is not an outline
#: to model)
MAX_POINTS = MAX_OUTLINE_POINTS


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
