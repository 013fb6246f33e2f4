"""The copper of each layer of a KiCad board, and its coverage measured within the board's outline.

:func:`read_copper` collects, per copper layer (found by the layer table's type, whatever the layer's name, as
:mod:`imutherm.ecad.kicad` does), the shapes that carry copper: the zones' filled polygons (a zone the file holds
unfilled counts by its outline, an upper bound, and the note says so; keep-out and rule areas are not copper),
the tracks (``segment``, and ``arc`` as two chords) as lines of their width with round ends, the vias as discs
of their size on every layer they span, the pads (rectangles, rounded rectangles, trapezoids and custom pads
as their rotated rectangle; round and oval pads as discs and stadiums; a through-hole pad on every layer it
names) and filled copper polygons drawn on a copper layer (``gr_poly``, ``gr_rect``). Drill holes are not
subtracted (a via's hole is 0.1 % of a board), nor are a zone's thermal-relief spokes added beyond what its
fill holds.

:func:`measure_coverage` fills them on a :data:`CELL_MM` raster (:mod:`imutherm.geometry.raster`) clipped to
the board's true outline (its closed loops by the even-odd rule; the rectangle when it does not close) and
returns each layer's copper area over the board's area: what the rule of mixtures of
:mod:`imutherm.geometry.board_material` takes instead of its assumed 50 %.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from imutherm import InputError
from imutherm.ecad.sexpr import child, children
from imutherm.geometry.outline import chain
from imutherm.geometry.raster import Raster, rotated_rect
from imutherm.textio import quote

#: the raster cell of the coverage measurement [mm] (a 0.1 mm track is one cell wide; boards longer than
#: 400 mm are measured on a coarser raster of 4000 cells along their longer side)
CELL_MM = 0.1
#: pad shapes taken as discs / stadiums; every other shape (rect, roundrect, trapezoid, custom) is its rectangle
_ROUND = ("circle",)
_OVAL = ("oval",)


@dataclass(frozen=True)
class CopperLayer:
    """The copper shapes of one layer in board coordinates [mm] (see the module docstring).

    name : str, the layer's canonical name (``F.Cu``, ``In1.Cu``, ``B.Cu``)
    polygons : tuple of polygons (tuples of (x, y)): zone fills, rectangular pads, copper polygons
    capsules : tuple of (x0, y0, x1, y1, r): tracks (r half their width), round and oval pads, vias
    unfilled_zones : int, zones counted by their outline because the file holds no fill for them
    """

    name: str
    polygons: tuple = ()
    capsules: tuple = ()
    unfilled_zones: int = 0

    def shifted(self, dx: float, dy: float) -> "CopperLayer":
        """The same shapes moved by (dx, dy) [mm] (a panel's board cut out of its file)."""
        return CopperLayer(self.name, tuple(tuple((x + dx, y + dy) for x, y in p) for p in self.polygons),
                           tuple((x0 + dx, y0 + dy, x1 + dx, y1 + dy, r) for x0, y0, x1, y1, r in self.capsules),
                           self.unfilled_zones)


def _number(value, where: str, what: str) -> float:
    if isinstance(value, float) and math.isfinite(value) and abs(value) <= 2147.483647:
        return value
    raise InputError(f"{where}: {what}: expected a number within KiCad's range (+-2147 mm), got {quote(value, 40)}")


def _pair(node, key: str, where: str, what: str):
    """(x, y) [mm] of ``(key x y ...)`` in ``node``; None when absent."""
    n = child(node, key)
    if n is None:
        return None
    if len(n) < 3:
        raise InputError(f"{where}: {what}: ({key} ...) needs x and y [mm]")
    return (_number(n[1], where, f"{what} {key}"), _number(n[2], where, f"{what} {key}"))


def _value(node, key: str, where: str, what: str, default=None):
    n = child(node, key)
    if n is None or len(n) < 2:
        return default
    return _number(n[1], where, f"{what} {key}")


def _points(node, where: str, what: str) -> list:
    pts = child(node, "pts")
    out = []
    for p in children(pts, "xy") if pts else ():
        if len(p) < 3:
            raise InputError(f"{where}: {what}: (xy ...) needs x and y [mm]")
        out.append((_number(p[1], where, f"{what} point"), _number(p[2], where, f"{what} point")))
    return out


def read_copper(tree, where: str, order: list, names: dict, canonical: list, flip) -> tuple:
    """The :class:`CopperLayer` of each copper layer of a parsed board ``tree``, front first.

    order : the copper layers' numbers, front, inner, back; names : layer name (table or user's) -> number;
    canonical : their canonical names, in ``order``; flip : KiCad (x, y) -> board (x, y) [mm]."""
    pos = {n: k for k, n in enumerate(order)}
    every = list(range(len(order)))
    polys = [[] for _ in order]
    caps = [[] for _ in order]
    unfilled = [0] * len(order)

    def layers_of(node) -> list:
        out = set()
        for key in ("layer", "layers"):
            n = child(node, key)
            for name in (str(v) for v in (n[1:] if n else ()) if not isinstance(v, list)):
                if name in ("*.Cu",):
                    out.update(every)
                elif name == "F&B.Cu":
                    out.update((0, len(order) - 1))
                elif names.get(name) in pos:
                    out.add(pos[names[name]])
        return sorted(out)

    for zone in children(tree, "zone"):
        if child(zone, "keepout") is not None:
            continue
        on = layers_of(zone)
        fills = children(zone, "filled_polygon")
        if fills:
            for f in fills:
                pts = [flip(x, y) for x, y in _points(f, where, "a zone's filled polygon")]
                for k in (layers_of(f) if child(f, "layer") is not None else on):
                    polys[k].append(tuple(pts))
        else:
            outline = child(zone, "polygon")
            pts = [flip(x, y) for x, y in _points(outline, where, "a zone's outline")] if outline else []
            for k in on if len(pts) >= 3 else ():
                polys[k].append(tuple(pts))
                unfilled[k] += 1
    for kind in ("segment", "arc"):
        for t in children(tree, kind):
            what = f"a track ({kind})"
            a, b = _pair(t, "start", where, what), _pair(t, "end", where, what)
            if a is None or b is None:
                continue
            r = 0.5 * _value(t, "width", where, what, 0.0)
            mid = _pair(t, "mid", where, what) if kind == "arc" else None
            path = [a, mid, b] if mid else [a, b]
            for k in layers_of(t):
                caps[k] += [(*flip(*p), *flip(*q), r) for p, q in zip(path[:-1], path[1:])]
    for v in children(tree, "via"):
        at = _pair(v, "at", where, "a via")
        if at is None:
            continue
        r = 0.5 * _value(v, "size", where, "a via", 2 * (_value(v, "drill", where, "a via", 0.3) or 0.3))
        span = layers_of(v)
        for k in range(span[0], span[-1] + 1) if span else every:
            caps[k].append((*flip(*at), *flip(*at), r))
    for kind in ("gr_poly", "gr_rect"):
        for g in children(tree, kind):
            on = layers_of(g)
            fill = child(g, "fill")
            if not on or not (fill and len(fill) > 1 and str(fill[1]) in ("solid", "yes")):
                continue
            if kind == "gr_poly":
                pts = _points(g, where, "a copper polygon")
            else:
                a, b = _pair(g, "start", where, "a copper rectangle"), _pair(g, "end", where, "a copper rectangle")
                pts = [a, (b[0], a[1]), b, (a[0], b[1])] if a and b else []
            for k in on if len(pts) >= 3 else ():
                polys[k].append(tuple(flip(x, y) for x, y in pts))
    for fp in children(tree, "footprint") + children(tree, "module"):
        _pads(fp, where, layers_of, flip, polys, caps)
    return tuple(CopperLayer(canonical[k], tuple(polys[k]), tuple(caps[k]), unfilled[k]) for k in range(len(order)))


def _pads(fp, where: str, layers_of, flip, polys: list, caps: list) -> None:
    """Add the copper of a footprint's pads to ``polys`` / ``caps`` (per layer)."""
    at = _pair(fp, "at", where, "a footprint")
    if at is None:
        return
    at_node = child(fp, "at")
    rot = at_node[3] if len(at_node) > 3 and isinstance(at_node[3], float) else 0.0
    c, s = math.cos(math.radians(rot)), math.sin(math.radians(rot))
    for pad in children(fp, "pad"):
        if len(pad) < 4 or str(pad[2]) == "np_thru_hole":
            continue
        what = "a pad"
        p, size = _pair(pad, "at", where, what), _pair(pad, "size", where, what)
        on = layers_of(pad)
        if p is None or size is None or not on:
            continue
        pad_at = child(pad, "at")
        angle = pad_at[3] if len(pad_at) > 3 and isinstance(pad_at[3], float) else 0.0
        x, y = flip(at[0] + p[0] * c + p[1] * s, at[1] - p[0] * s + p[1] * c)
        w, h = abs(size[0]), abs(size[1])
        shape = str(pad[3])
        if shape in _ROUND:
            shapes = [], [(x, y, x, y, 0.5 * w)]
        elif shape in _OVAL:
            half = 0.5 * abs(w - h)
            a = math.radians(angle + (0.0 if w >= h else 90.0))
            dx, dy = half * math.cos(a), half * math.sin(a)
            shapes = [], [(x - dx, y - dy, x + dx, y + dy, 0.5 * min(w, h))]
        else:
            shapes = [tuple(rotated_rect(x, y, w, h, angle))], []
        for k in on:
            polys[k] += shapes[0]
            caps[k] += shapes[1]


def measure_coverage(layers, outline, width_mm: float, height_mm: float, cell_mm: float = CELL_MM,
                     where: str = "the board") -> tuple:
    """(coverage of each layer [-], the raster cell [mm], the board's area [mm^2]): each layer's copper within
    the board (its ``outline`` polylines' closed loops, by the even-odd rule; the rectangle ``width_mm`` x
    ``height_mm`` when they do not close) over the board's area."""
    raster = Raster.over(width_mm, height_mm, cell_mm)
    board = raster.empty()
    loops, _ = chain(outline)
    if loops:
        raster.fill_polygons(board, loops, f"{where}: the outline")
    if not board.any():
        board[:] = True
    area = raster.area(board)
    out = []
    for layer in layers:
        mask = raster.empty()
        for poly in layer.polygons:   # each zone or pad filled on its own: overlapping zones add no holes
            raster.fill_polygons(mask, [poly], f"{where}: a copper shape on {layer.name}")
        raster.fill_capsules(mask, layer.capsules)
        out.append(raster.area(mask & board) / area)
    return tuple(out), raster.cell, area


def coverage_note(layers, coverage, cell_mm: float) -> str:
    """The printout's line: each layer's measured coverage and what it was measured from."""
    listed = ", ".join(f"{layer.name} {100 * c:.0f} %" for layer, c in zip(layers, coverage))
    unfilled = sum(layer.unfilled_zones for layer in layers)
    return (f"copper coverage measured from the file's zones, tracks, vias and pads within the outline ({cell_mm:g} mm "
            f"raster): {listed}; the board's conductivity takes these instead of the assumed 50 %"
            + (f" ({unfilled} zones without a fill in the file counted by their outline: refill the zones in KiCad, "
               f"B, for the true copper)" if unfilled else ""))


def with_coverage(board) -> tuple:
    """(board with its ``coverage`` measured, the printout's note); the board unchanged and "" when it carries
    no copper shapes (IDF) or its copper count differs from its shapes' layers."""
    from dataclasses import replace

    if not board.copper or len(board.copper) != board.copper_layers or board.coverage:
        return board, ""
    coverage, cell, _ = measure_coverage(board.copper, board.outline, board.width_mm, board.height_mm,
                                         where=board.source)
    return replace(board, coverage=coverage), coverage_note(board.copper, coverage, cell)
