"""A part's body on its board: edges on a lattice, die, exposed pad and via field, snapping, placement checks.

The in-plane geometry :mod:`imutherm.ecad.to_layout` writes for each modelled part. Every length is rounded
to :data:`DIGITS` decimals, bodies lie on the 0.001 mm lattice and dies / pads on 0.002 mm (centred boxes), so
the edges a tensor mesh sees coincide to the last bit and make no sliver cells.
"""

from __future__ import annotations

from imutherm.ecad.board import BoardDesign, Rect
from imutherm.ecad.classify import Decision, body_local

#: the die of a powered or sensing package: its footprint this fraction of the body's, as the reference unit's
#: assumed dies (0.3-0.45 of the body: LQFP-100 6/14, SOT-223 2.5/6.5, LCC 2/5); thickness and base as there
DIE_FRACTION = 0.4
DIE_THICKNESS_MM = 0.3
DIE_BASE_MM = 0.2
#: an exposed pad: the largest copper pad inside a package of 3+ pads covering at least this body fraction
EP_MIN_FRACTION = 0.15
#: vias inside an exposed pad (board vias and the footprint's own through-holes) that make a via field
MIN_VIAS = 2
#: lengths in the layout to this precision [mm] (10 um: far below any cell; keeps the file readable)
DIGITS = 3
#: a part without a die has its in-plane edges moved to a neighbour's line this close [mm] (half the default
#: largest cell), else to this lattice [mm] (see snap_soft_parts; ``imutherm import --exact`` keeps every edge)
SNAP_MM = 1.0
SNAP_LATTICE_MM = 0.5


def round_mm(v: float) -> float:
    """A length [mm] as the layout writes it, to :data:`DIGITS` decimals."""
    return round(float(v), DIGITS)


def round_size(v: float) -> float:
    """A body's in-plane size [mm] to 0.0001 mm (a snapped edge may sit on a die's edge, a 0.0005 mm multiple)."""
    return round(float(v), DIGITS + 1)


def round_centre(v: float) -> float:
    """A centre [mm] to 0.0001 mm: the midpoint of two edges on the 0.001 mm lattice, exactly."""
    return round(float(v), DIGITS + 2)


def lattice(v: float, step: float) -> float:
    """``v`` on the lattice of ``step`` [mm] (a decimal with no more digits than ``step`` has)."""
    return round(round(float(v) / step) * step, 6)


def quantised(body: Rect) -> Rect:
    """A body's edges on the 0.001 mm lattice: every written size is then exact, every centre a multiple of
    0.0005 mm, and the edges the mesh sees from them coincide to the last bit with the snapping's (no sliver
    cells of a rounding's width)."""
    return Rect(*(lattice(v, 10.0**-DIGITS) for v in (body.x0, body.y0, body.x1, body.y1)))


def exposed_pad(d: Decision):
    """(pad (u, v) size [mm] in board orientation, pad rect in board coordinates) of an exposed pad, or None."""
    fp = d.footprint
    if len(fp.copper_pads) < 3:
        return None
    body = body_local(fp, d.package)
    inside = [p for p in fp.copper_pads if p.rect.x0 >= body.x0 - 0.05 and p.rect.x1 <= body.x1 + 0.05
              and p.rect.y0 >= body.y0 - 0.05 and p.rect.y1 <= body.y1 + 0.05]
    if not inside:
        return None
    pad = max(inside, key=lambda p: p.rect.area)
    if pad.rect.area < EP_MIN_FRACTION * body.area:
        return None
    w, h = (pad.rect.width, pad.rect.height) if round(fp.rotation_deg / 90.0) % 2 == 0 else (pad.rect.height, pad.rect.width)
    cx, cy = fp.to_board(*pad.rect.centre)
    return (w, h), Rect(cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2)


def vias_under(board: BoardDesign, d: Decision, pad_rect: Rect) -> int:
    n = sum(pad_rect.x0 <= v.x <= pad_rect.x1 and pad_rect.y0 <= v.y <= pad_rect.y1 for v in board.vias)
    fp = d.footprint
    for p in fp.pads:
        if p.kind == "thru_hole":
            x, y = fp.to_board(*p.rect.centre)
            n += pad_rect.x0 <= x <= pad_rect.x1 and pad_rect.y0 <= y <= pad_rect.y1
    return n


def clip(body: Rect, board: BoardDesign) -> Rect:
    w, h = round_mm(board.width_mm), round_mm(board.height_mm)   # the board as written
    return Rect(max(body.x0, 0.0), max(body.y0, 0.0), min(body.x1, w), min(body.y1, h))


def overlaps(a: Rect, b: Rect, tol: float = 1e-3) -> bool:
    return min(a.x1, b.x1) - max(a.x0, b.x0) > tol and min(a.y1, b.y1) - max(a.y0, b.y0) > tol


def die_and_pad(board: BoardDesign, d: Decision, body: Rect) -> tuple:
    """((die u, v, thickness), die base, (pad u, v) or None, vias under the pad) [mm] of a part with a die."""
    h = d.height_mm
    even = lambda v: lattice(v, 2 * 10.0**-DIGITS)  # noqa: E731 - centred boxes: half sizes on the 0.001 lattice
    dt, db = round_mm(min(DIE_THICKNESS_MM, 0.35 * h)), round_mm(min(DIE_BASE_MM, 0.25 * h))
    du, dv = even(DIE_FRACTION * body.width), even(DIE_FRACTION * body.height)
    ep = exposed_pad(d)
    if ep is None:
        return (du, dv, dt), db, None, 0
    (pu, pv), pad_rect = ep
    pu, pv = even(min(pu, body.width)), even(min(pv, body.height))
    return (min(du, pu), min(dv, pv), dt), db, (pu, pv), vias_under(board, d, pad_rect)


def snap_soft_parts(board: BoardDesign, modelled: list, bodies: dict, hard: set, anchors_extra, exact: bool) -> tuple:
    """Bodies of the parts without a die, their in-plane edges moved to the nearest line of the hard parts
    (those with a die), the board, the standoffs or an already snapped edge within :data:`SNAP_MM`, else to the
    :data:`SNAP_LATTICE_MM` lattice: they then add few grid lines (a tensor mesh carries every part's faces
    across the unit). A part whose snapped body would overlap a neighbour, or lose more than half its width,
    keeps its exact body. Returns (bodies, {ref: note})."""
    if exact:
        return bodies, {}
    anchors = [{0.0, board.width_mm}, {0.0, board.height_mm}]
    for d in modelled:
        ref = d.footprint.ref
        if ref not in hard:
            continue
        b = bodies[ref]
        anchors[0] |= {b.x0, b.x1}
        anchors[1] |= {b.y0, b.y1}
        (du, dv, _), _, pad, _ = die_and_pad(board, d, b)
        cx, cy = b.centre
        anchors[0] |= {cx - du / 2, cx + du / 2} | ({cx - pad[0] / 2, cx + pad[0] / 2} if pad else set())
        anchors[1] |= {cy - dv / 2, cy + dv / 2} | ({cy - pad[1] / 2, cy + pad[1] / 2} if pad else set())
    for r in anchors_extra:
        anchors[0] |= {r.x0, r.x1}
        anchors[1] |= {r.y0, r.y1}

    anchors = [{round(a, 6) for a in axis} for axis in anchors]

    def snap(v, axis):
        near = min(anchors[axis], key=lambda a: abs(a - v))
        return near if abs(near - v) <= SNAP_MM else round(v / SNAP_LATTICE_MM) * SNAP_LATTICE_MM

    out, notes = dict(bodies), {}
    soft = sorted((d for d in modelled if d.footprint.ref not in hard), key=lambda d: -bodies[d.footprint.ref].area)
    for d in soft:
        ref, b = d.footprint.ref, bodies[d.footprint.ref]
        s = clip(Rect(snap(b.x0, 0), snap(b.y0, 1), snap(b.x1, 0), snap(b.y1, 1)), board)
        if s.width < 0.5 * b.width or s.height < 0.5 * b.height or s.width <= 0 or s.height <= 0:
            continue
        if any(o is not d and o.footprint.side == d.footprint.side and overlaps(s, out[o.footprint.ref])
               for o in modelled) or (d.footprint.side == "bottom" and any(overlaps(s, r) for r in anchors_extra)):
            continue
        if s != b:
            out[ref] = s
            anchors[0] |= {s.x0, s.x1}
            anchors[1] |= {s.y0, s.y1}
            move = max(abs(s.x0 - b.x0), abs(s.x1 - b.x1), abs(s.y0 - b.y0), abs(s.y1 - b.y1))
            notes[ref] = (f"in-plane edges snapped by up to {move:.2f} mm to its neighbours' lines (a part without "
                          f"a die: its exact outline would only add mesh lines); exact body {b.x0:.3f}..{b.x1:.3f} x "
                          f"{b.y0:.3f}..{b.y1:.3f} mm")
    return out, notes
