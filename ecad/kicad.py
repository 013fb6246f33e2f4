"""Read a KiCad board (``.kicad_pcb``, KiCad 4/5 ``(module`` and KiCad 6-9 ``(footprint``) into a BoardDesign.

What is read: the outline (``Edge.Cuts`` lines, arcs, circles, rectangles and polygons, on the board or in a
footprint), the thickness and copper layers (the ``(stackup)`` section where there is one, else
``(general (thickness))`` and the layer table), every footprint (reference, library name, value, side,
position, rotation, fab and courtyard outlines, pads, user fields such as ``Height_mm`` / ``Power_W``,
attributes) and the vias. Copper layers are identified by their type in the layer table (``signal``,
``power``, ``mixed``, ``jumper``) or, where a file gives none, by number (< 32 in KiCad 4-8), never by name:
KiCad 4/5 let a designer rename them. The front copper layer is number 0; the back is 31 (KiCad 4-8) or 2
(KiCad 9, which numbers copper layers 0, 2, 4, ...).

KiCad's y axis points down the screen; the BoardDesign's points up (seen from the top), origin at the lower
left of the outline's bounding rectangle. A footprint's local points, bottom-side ones included (KiCad stores
them already mirrored), map to the board as ``origin + R(rotation) . local``; pad angles in the file are
absolute (the footprint's rotation included).
"""

from __future__ import annotations

import math
from pathlib import Path

from imutherm import InputError
from imutherm.ecad.board import BoardDesign, Footprint, Pad, Rect, Via
from imutherm.ecad.sexpr import child, children, parse_sexpr
from imutherm.textio import quote, read_text

#: largest board file read [bytes]: 64 MiB (the 4-layer shared board is 0.9 MB; boards of a few hundred
#: footprints with filled zones reach 10-30 MB)
MAX_BOARD_BYTES = 64 * 2**20
#: copper layer types of KiCad's layer table
COPPER_TYPES = ("signal", "power", "mixed", "jumper")
#: copper thickness when the file has no stack-up [um]: 1 oz/ft^2 (35 um), the usual default of board
#: houses and KiCad's own stack-up default
DEFAULT_COPPER_UM = 35.0
#: the board file versions of each KiCad release (the file's ``(version N)``), newest first
KICAD_VERSIONS = ((20241229, "KiCad 9"), (20240108, "KiCad 8"), (20221018, "KiCad 7"), (20211014, "KiCad 6"),
                  (20171130, "KiCad 5"), (0, "KiCad 4"))
#: a stack-up's plausible total [mm]: thinner than 0.1 mm or thicker than 10 mm is not a rigid board
THICKNESS_RANGE_MM = (0.1, 10.0)
#: the stack-up's sum may differ from the stated board thickness by this fraction (mask and rounding)
THICKNESS_TOLERANCE = 0.1
#: segments per full circle when an arc of the outline is drawn as a polyline
ARC_SEGMENTS = 72

_GRAPHICS = ("line", "rect", "poly", "circle", "arc", "curve")


def kicad_release(version: float) -> str:
    """The KiCad release that writes board files of ``version`` (``KiCad 7``)."""
    return next(name for v, name in KICAD_VERSIONS if version >= v)


def read_kicad(path: str | Path) -> BoardDesign:
    """Read a ``.kicad_pcb`` file (see the module docstring); InputError naming the file on any problem."""
    path = Path(path)
    where = str(path)
    text = read_text(path, "KiCad board file", MAX_BOARD_BYTES)
    if not text.lstrip().startswith("(kicad_pcb"):
        start = text.lstrip()[:30]
        raise InputError(f"{where}: not a KiCad board: a .kicad_pcb file starts with '(kicad_pcb', this one with "
                         f"{quote(start, 40)}")
    tree = parse_sexpr(text, where)
    version_node = child(tree, "version")
    version = float(version_node[1]) if version_node and isinstance(version_node[1], float) else 0.0
    generator = child(tree, "generator_version")  # KiCad 8+ names its release
    release = f"KiCad {generator[1]}" if generator and len(generator) > 1 else kicad_release(version)
    layers = _layer_table(tree, where)
    copper = [n for n, (_, kind) in layers.items() if kind in COPPER_TYPES] or [n for n in layers if n < 32]
    names = {name: n for n, (name, _) in layers.items()}
    front = 0
    back = 31 if 31 in copper else (2 if 2 in copper and version >= KICAD_VERSIONS[0][0] else max(copper, default=31))
    thickness, copper_um, stack_source = _stackup(tree, where, len(copper))
    outline = _outline(tree)
    if not outline:
        raise InputError(f"{where}: the board has no outline: nothing is drawn on the Edge.Cuts layer "
                         f"(draw the board edge in KiCad's Edge.Cuts layer)")
    box = Rect.around(p for line in outline for p in line)
    if box.width <= 0 or box.height <= 0:
        raise InputError(f"{where}: the Edge.Cuts outline encloses no area ({box.width:g} x {box.height:g} mm)")

    def flip(x, y):  # KiCad (y down) -> board (y up, origin at the outline's lower left), to 1 nm
        return (round(x - box.x0, 6), round(box.y1 - y, 6))

    outline = tuple(tuple(flip(x, y) for x, y in line) for line in outline)
    footprints = tuple(_footprint(fp, where, names, front, back, flip)
                       for fp in children(tree, "footprint") + children(tree, "module"))
    vias = []
    for v in children(tree, "via"):
        at, drill = child(v, "at"), child(v, "drill")
        if at and len(at) >= 3:
            x, y = flip(_num(at[1], where, "via"), _num(at[2], where, "via"))
            vias.append(Via(x, y, _num(drill[1], where, "via drill") if drill else 0.3))
    return BoardDesign(where, f"{release} ({int(version)})", box.width, box.height, outline, thickness,
                       len(copper), copper_um, stack_source, footprints, tuple(vias))


def _num(value, where: str, what: str) -> float:
    if isinstance(value, float) and math.isfinite(value):
        return value
    if isinstance(value, str):
        try:
            v = float(value)
        except ValueError:
            v = math.nan
        if math.isfinite(v):
            return v
    raise InputError(f"{where}: {what}: expected a number, got {quote(value, 40)}")


def _layer_table(tree, where: str) -> dict:
    """``{number: (canonical name, type)}`` of the ``(layers ...)`` section."""
    node = child(tree, "layers")
    if node is None:
        raise InputError(f"{where}: the board has no (layers ...) section: not a complete KiCad board (truncated?)")
    out = {}
    for entry in node[1:]:
        if isinstance(entry, list) and len(entry) >= 3 and isinstance(entry[0], float):
            out[int(entry[0])] = (str(entry[1]), str(entry[2]))
    if not out:
        raise InputError(f"{where}: the (layers ...) section lists no layer")
    return out


def _stackup(tree, where: str, n_copper: int) -> tuple:
    """(thickness [mm], copper thicknesses [um], source) from the stack-up, else the stated thickness."""
    general = child(tree, "general")
    stated = child(general, "thickness") if general else None
    stated_mm = _num(stated[1], where, "general thickness") if stated else None
    stack = child(child(tree, "setup") or [], "stackup")
    copper_um, total = [], 0.0
    if stack is not None:
        for layer in children(stack, "layer"):
            kind = child(layer, "type")
            t = child(layer, "thickness")
            t_mm = _num(t[1], where, f"stack-up layer {quote(layer[1], 40)} thickness") if t else 0.0
            if t_mm < 0:
                raise InputError(f"{where}: stack-up layer {quote(layer[1], 40)} has a negative thickness {t_mm:g} mm")
            total += t_mm
            if kind and str(kind[1]).lower() == "copper":
                copper_um.append(t_mm * 1e3 if t else DEFAULT_COPPER_UM)
    lo, hi = THICKNESS_RANGE_MM
    if copper_um:
        if not lo <= total <= hi:
            raise InputError(f"{where}: the stack-up's layers sum to {total:.4g} mm, an impossible board thickness "
                             f"(valid {lo:g}..{hi:g} mm); correct the layer thicknesses in KiCad's Board Setup")
        if stated_mm and abs(total - stated_mm) > THICKNESS_TOLERANCE * stated_mm:
            raise InputError(f"{where}: the stack-up's layers sum to {total:.4g} mm but the board states "
                             f"{stated_mm:g} mm thickness; correct the stack-up in KiCad's Board Setup")
        for um in copper_um:
            if not 5.0 <= um <= 500.0:
                raise InputError(f"{where}: a stack-up copper layer is {um:g} um thick; valid 5..500 um")
        return total, tuple(copper_um), f"the file's stack-up: {len(copper_um)} copper layers, {total:.3f} mm"
    if stated_mm is None:
        raise InputError(f"{where}: the board states no thickness ((general (thickness ...)) and no stack-up)")
    if not lo <= stated_mm <= hi:
        raise InputError(f"{where}: the board's thickness is {stated_mm:g} mm, impossible (valid {lo:g}..{hi:g} mm)")
    return (stated_mm, (DEFAULT_COPPER_UM,) * n_copper,
            f"the file's thickness {stated_mm:g} mm and {n_copper} copper layers of {DEFAULT_COPPER_UM:g} um "
            f"(1 oz, assumed: the file has no stack-up)")


def _point(node, key):
    n = child(node, key)
    if n is None or len(n) < 3 or not all(isinstance(v, float) for v in n[1:3]):
        return None
    return (n[1], n[2])


def _arc_points(centre, start, sweep_deg) -> list:
    """Points of an arc from ``start`` about ``centre`` through ``sweep_deg`` (KiCad's screen sense)."""
    r = math.hypot(start[0] - centre[0], start[1] - centre[1])
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    n = max(2, int(abs(sweep_deg) / 360 * ARC_SEGMENTS) + 1)
    return [(centre[0] + r * math.cos(a0 + math.radians(sweep_deg) * i / (n - 1)),
             centre[1] + r * math.sin(a0 + math.radians(sweep_deg) * i / (n - 1))) for i in range(n)]


def _circle_through(a, b, c):
    """Centre of the circle through three points, None if they are collinear."""
    d = 2 * (a[0] * (b[1] - c[1]) + b[0] * (c[1] - a[1]) + c[0] * (a[1] - b[1]))
    if abs(d) < 1e-12:
        return None
    ux = ((a[0]**2 + a[1]**2) * (b[1] - c[1]) + (b[0]**2 + b[1]**2) * (c[1] - a[1]) + (c[0]**2 + c[1]**2) * (a[1] - b[1])) / d
    uy = ((a[0]**2 + a[1]**2) * (c[0] - b[0]) + (b[0]**2 + b[1]**2) * (a[0] - c[0]) + (c[0]**2 + c[1]**2) * (b[0] - a[0])) / d
    return (ux, uy)


def _shape_points(node, kind: str) -> list:
    """The points of one graphic item (``line``, ``rect``, ``poly``, ``circle``, ``arc``, ``curve``) as a
    polyline, in the item's own frame; [] when the item is unreadable."""
    if kind == "line":
        a, b = _point(node, "start"), _point(node, "end")
        return [a, b] if a and b else []
    if kind == "rect":
        a, b = _point(node, "start"), _point(node, "end")
        return [a, (b[0], a[1]), b, (a[0], b[1]), a] if a and b else []
    if kind in ("poly", "curve"):
        pts = child(node, "pts")
        return [(p[1], p[2]) for p in children(pts, "xy") if len(p) >= 3] if pts else []
    if kind == "circle":
        c, e = _point(node, "center"), _point(node, "end")
        return _arc_points(c, e, 360.0) if c and e else []
    if kind == "arc":
        mid = _point(node, "mid")
        a, b = _point(node, "start"), _point(node, "end")
        if mid and a and b:  # KiCad 6+: start, mid, end
            c = _circle_through(a, mid, b)
            if c is None:
                return [a, b]
            angle = lambda p: math.atan2(p[1] - c[1], p[0] - c[0])  # noqa: E731
            sweep = (angle(b) - angle(a)) % (2 * math.pi)
            if (angle(mid) - angle(a)) % (2 * math.pi) > sweep:  # the arc runs the other way round
                sweep -= 2 * math.pi
            return _arc_points(c, a, math.degrees(sweep))
        ang = child(node, "angle")
        if a and b and ang:  # KiCad 4/5: start = centre, end = the arc's start point, angle = its sweep
            return _arc_points(a, b, float(ang[1]))
    return []


def _atom_text(value) -> str:
    """An atom as the file wrote it: KiCad 5's unquoted pad name ``1`` is read as 1.0 and written back as ``1``."""
    if isinstance(value, float):
        return str(int(value)) if value.is_integer() else repr(value)
    return "" if isinstance(value, list) else str(value)


def _layer_of(node) -> str:
    layer = child(node, "layer")
    return str(layer[1]) if layer and len(layer) > 1 else ""


def _outline(tree) -> list:
    """The Edge.Cuts polylines of the board and of its footprints, in KiCad coordinates."""
    lines = []
    for kind in _GRAPHICS:
        for node in children(tree, f"gr_{kind}"):
            if _layer_of(node) == "Edge.Cuts":
                pts = _shape_points(node, kind)
                if len(pts) >= 2:
                    lines.append(pts)
    for fp in children(tree, "footprint") + children(tree, "module"):
        at = child(fp, "at")
        if at is None:
            continue
        x0, y0 = at[1], at[2]
        rot = math.radians(at[3]) if len(at) > 3 and isinstance(at[3], float) else 0.0
        c, s = math.cos(rot), math.sin(rot)
        for kind in _GRAPHICS:
            for node in children(fp, f"fp_{kind}"):
                if _layer_of(node) == "Edge.Cuts":  # local (y down), rotated as KiCad does on screen
                    pts = [(x0 + px * c + py * s, y0 - px * s + py * c) for px, py in _shape_points(node, kind)]
                    if len(pts) >= 2:
                        lines.append(pts)
    return lines


def _text_of(fp, key: str) -> str:
    """A footprint's reference / value: ``(fp_text reference "R1")`` (KiCad 4-7) or ``(property "Reference"
    "R1")`` (KiCad 8+)."""
    for node in children(fp, "fp_text"):
        if len(node) > 2 and node[1] == key.lower():
            return _atom_text(node[2])
    for node in children(fp, "property"):
        if len(node) > 2 and str(node[1]) == key:
            return _atom_text(node[2])
    return ""


#: properties every KiCad footprint carries that are not user fields
_NOT_FIELDS = {"Reference", "Value", "Footprint", "Datasheet", "Description", "Sheetfile", "Sheetname"}


def _footprint(fp, where: str, names: dict, front: int, back: int, flip) -> Footprint:
    library = str(fp[1]) if len(fp) > 1 and isinstance(fp[1], str) and not isinstance(fp[1], list) else ""
    ref = _text_of(fp, "Reference") or "?"
    what = f"footprint {quote(ref, 40)} ({quote(library, 80)})"
    at = child(fp, "at")
    if at is None or len(at) < 3:
        raise InputError(f"{where}: {what} has no position (at x y)")
    x, y = flip(_num(at[1], where, what), _num(at[2], where, what))
    rotation = _num(at[3], where, what) if len(at) > 3 else 0.0
    layer = _layer_of(fp)
    number = names.get(layer)
    if number == front:
        side = "top"
    elif number == back:
        side = "bottom"
    else:
        raise InputError(f"{where}: {what} sits on layer {quote(layer, 40)}, which is not the front or back copper "
                         f"layer of the board's layer table")
    fab, court = [], []
    for kind in _GRAPHICS:
        for node in children(fp, f"fp_{kind}"):
            name = _layer_of(node)
            pts = [(px, -py) for px, py in _shape_points(node, kind)]  # local y down -> y up
            if name.endswith(".Fab"):
                fab += pts
            elif name.endswith(".CrtYd"):
                court += pts
    pads = tuple(p for p in (_pad(node, rotation, where, what) for node in children(fp, "pad")) if p is not None)
    fields = {}
    for node in children(fp, "property"):
        if len(node) > 2 and str(node[1]) not in _NOT_FIELDS and not str(node[1]).startswith("ki_"):
            fields[str(node[1])] = str(node[2])
    attr = child(fp, "attr")
    attributes = tuple(str(a) for a in attr[1:] if isinstance(a, str)) if attr else ()
    if children(fp, "dnp") or any(str(n[1]) == "dnp" for n in children(fp, "property") if len(n) > 1):
        attributes += ("dnp",)
    return Footprint(ref, library, _text_of(fp, "Value"), side, x, y, rotation, Rect.around(fab),
                     Rect.around(court), pads, fields, attributes)


def _pad(node, fp_rotation: float, where: str, what: str) -> Pad | None:
    """One pad in the footprint frame (y up); None for a paste-only aperture (no copper, no hole)."""
    if len(node) < 4:
        return None
    name, kind = _atom_text(node[1]), str(node[2])
    at, size = child(node, "at"), child(node, "size")
    if at is None or size is None or len(at) < 3 or len(size) < 3:
        return None
    layers = child(node, "layers")
    names = [str(v) for v in layers[1:]] if layers else []
    if kind != "np_thru_hole" and not any(n.endswith(".Cu") or n == "*.Cu" for n in names):
        return None
    px, py = _num(at[1], where, what), -_num(at[2], where, what)
    angle = math.radians((at[3] if len(at) > 3 and isinstance(at[3], float) else 0.0) - fp_rotation)
    w, h = _num(size[1], where, what), _num(size[2], where, what)
    c, s = abs(math.cos(angle)), abs(math.sin(angle))
    hw, hh = 0.5 * (w * c + h * s), 0.5 * (w * s + h * c)
    return Pad(name, kind, Rect(px - hw, py - hh, px + hw, py + hh))

