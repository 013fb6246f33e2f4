"""Read a KiCad board (``.kicad_pcb``, KiCad 4/5 ``(module`` and KiCad 6-9 ``(footprint``) into a BoardDesign.

What is read: the outline (``Edge.Cuts`` lines, arcs, circles, rectangles and polygons, on the board or in a
footprint), the thickness and copper layers (the ``(stackup)`` section where there is one, else
``(general (thickness))`` and the layer table), every footprint (reference, library name, value, side,
position, rotation, fab and courtyard outlines, pads, user fields such as ``Height_mm`` / ``Power_W``,
attributes), the vias and each copper layer's zones, tracks and pads (:mod:`imutherm.ecad.kicad_copper`).
Copper layers are identified by their type in the layer table (``signal``, ``power``, ``mixed``, ``jumper``) or,
where a file gives none, by number (< 32 in KiCad 4-8), never by name: KiCad 4/5 let a designer rename them
(``C1F`` / ``C4B``), and their files then name the layer so on every pad, while KiCad 6-9 write the canonical
name and keep the user's as a fourth word of the table. The front copper layer is number 0; the back is 31
(KiCad 4-8) or 2 (KiCad 9, which numbers copper layers 0, 2, 4, ...). The
stack-up (sublayers included) is read by :mod:`imutherm.ecad.stackup`.

A damaged file is refused in one line naming the item: a number that is not finite or lies outside KiCad's
coordinate range (+-2147 mm, its 32-bit nanometres), a position of one number, an arc of more than a turn,
a file version that is not a date, a control character in a reference.

KiCad's y axis points down the screen; the BoardDesign's points up (seen from the top), origin at the lower
left of the outline's bounding rectangle. A footprint's local points, bottom-side ones included (KiCad stores
them already mirrored), map to the board as ``origin + R(rotation) . local``; pad angles in the file are
absolute (the footprint's rotation included).
"""

from __future__ import annotations

import math
import re
from dataclasses import replace
from pathlib import Path

from imutherm import InputError
from imutherm.ecad.board import BoardDesign, Footprint, Pad, Rect, Via
from imutherm.ecad.kicad_copper import read_copper
from imutherm.ecad.models3d import footprint_model_height
from imutherm.ecad.outline_loops import simplified_outline
from imutherm.ecad.sexpr import child, children, parse_sexpr
from imutherm.ecad.stackup import read_stackup
from imutherm.textio import quote, read_text

#: largest board file read [bytes]: 64 MiB (the 4-layer shared board is 0.9 MB; boards of a few hundred
#: footprints with filled zones reach 10-30 MB)
MAX_BOARD_BYTES = 64 * 2**20
#: copper layer types of KiCad's layer table
COPPER_TYPES = ("signal", "power", "mixed", "jumper")
#: the board file versions of each KiCad release (the file's ``(version N)``, a date), newest first
KICAD_VERSIONS = ((20241229, "KiCad 9"), (20240108, "KiCad 8"), (20221018, "KiCad 7"), (20211014, "KiCad 6"),
                  (20171130, "KiCad 5"), (0, "KiCad 4"))
#: a file version beyond this is not a date (KiCad 4 wrote small integers, 5-9 dates yyyymmdd)
MAX_VERSION = 99991231
#: KiCad's coordinate range [mm]: 32-bit integer nanometres
MAX_COORD_MM = 2147.483647
#: segments per full circle when an arc of the outline is drawn as a polyline
ARC_SEGMENTS = 72
#: pad layer names that mean every copper layer / both outer ones
COPPER_WILDCARDS = ("*.Cu", "F&B.Cu")
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")

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
    version = _version(tree, where)
    generator = child(tree, "generator_version")  # KiCad 8+ names its release
    release = f"KiCad {generator[1]}" if generator and len(generator) > 1 else kicad_release(version)
    layers = _layer_table(tree, where)
    copper = [n for n, (_, kind, _) in layers.items() if kind in COPPER_TYPES] or [n for n in layers if n < 32]
    if not copper:
        raise InputError(f"{where}: the layer table lists no copper layer (type signal, power, mixed or jumper)")
    names = {}
    for n, (name, _, user) in layers.items():
        names.setdefault(name, n)
        if user:
            names.setdefault(user, n)
    front = 0 if 0 in copper else min(copper)
    back = 31 if 31 in copper else (2 if 2 in copper and version >= KICAD_VERSIONS[0][0] else max(copper))
    order = [front] + sorted(n for n in copper if n not in (front, back)) + ([back] if back != front else [])
    general = child(tree, "general")
    stated = child(general, "thickness") if general else None
    stated_mm = _num(stated[1] if len(stated) > 1 else None, where, "general thickness") if stated else None
    kicad9 = version >= KICAD_VERSIONS[0][0]
    canonical = {front: "F.Cu", back: "B.Cu"}
    names_of = [(layers[n][0], canonical.get(n, f"In{(n - 2) // 2 if kicad9 else n}.Cu")) for n in order]
    thickness, copper_um, stack_source, notes = read_stackup(tree, where, names_of, stated_mm)
    outline = _outline(tree, where)
    if not outline:
        raise InputError(f"{where}: the board has no outline: nothing is drawn on the Edge.Cuts layer "
                         f"(draw the board edge in KiCad's Edge.Cuts layer)")
    box = Rect.around(p for line in outline for p in line)
    if box.width <= 0 or box.height <= 0:
        raise InputError(f"{where}: the Edge.Cuts outline encloses no area ({box.width:g} x {box.height:g} mm)")

    def flip(x, y):  # KiCad (y down) -> board (y up, origin at the outline's lower left), to 1 nm
        return (round(x - box.x0, 6), round(box.y1 - y, 6))

    outline = tuple(tuple(flip(x, y) for x, y in line) for line in simplified_outline(outline, where))
    copper_set = set(copper)
    nodes = children(tree, "footprint") + children(tree, "module")
    footprints = tuple(_footprint(fp, where, names, copper_set, front, back, flip) for fp in nodes)
    footprints = tuple(_with_model_height(f, node, path.parent) for f, node in zip(footprints, nodes))
    vias = []
    for v in children(tree, "via"):
        x, y = _xy(v, "at", where, "a via")
        drill = child(v, "drill")
        d = _num(drill[1] if len(drill) > 1 else None, where, "a via's drill") if drill else 0.3
        vias.append(Via(*flip(x, y), d))
    art = read_copper(tree, where, order, names, [c for _, c in names_of], flip)
    return BoardDesign(where, f"{release} ({int(version)})", box.width, box.height, outline, thickness,
                       len(copper), copper_um, stack_source, footprints, tuple(vias), notes, art)


def _with_model_height(fp: Footprint, node, board_dir: Path) -> Footprint:
    """The footprint with the height of its 3D model where the model file is on the disk (models3d.py)."""
    h, source = footprint_model_height(node, board_dir)
    return fp if h is None else replace(fp, height_mm=h, height_source=source)


def _version(tree, where: str) -> float:
    node = child(tree, "version")
    if node is None:
        return 0.0
    v = node[1] if len(node) > 1 else None
    if not (isinstance(v, float) and math.isfinite(v) and 0 <= v <= MAX_VERSION):
        raise InputError(f"{where}: (version {quote(v, 30)}): not a KiCad file version (a date such as 20241229)")
    return v


def _num(value, where: str, what: str) -> float:
    """A finite number of the file; InputError naming ``what`` otherwise."""
    if isinstance(value, float) and math.isfinite(value):
        return value
    raise InputError(f"{where}: {what}: expected a number, got {quote(value, 40)}")


def _coord(value, where: str, what: str) -> float:
    v = _num(value, where, what)
    if abs(v) > MAX_COORD_MM:
        raise InputError(f"{where}: {what}: {v:g} mm is outside KiCad's coordinate range (+-{MAX_COORD_MM:g} mm)")
    return v


def _xy(node, key: str, where: str, what: str, required: bool = True):
    """``(x, y)`` [mm] of ``(key x y ...)`` in ``node``; None when absent and not ``required``."""
    n = child(node, key)
    if n is None:
        if required:
            raise InputError(f"{where}: {what} has no ({key} x y)")
        return None
    if len(n) < 3:
        raise InputError(f"{where}: {what}: ({key} {' '.join(quote(v, 20) for v in n[1:])}) needs x and y [mm]")
    return (_coord(n[1], where, f"{what}: {key} x"), _coord(n[2], where, f"{what}: {key} y"))


def _layer_table(tree, where: str) -> dict:
    """``{number: (canonical name, type, user name or "")}`` of the ``(layers ...)`` section."""
    node = child(tree, "layers")
    if node is None:
        raise InputError(f"{where}: the board has no (layers ...) section: not a complete KiCad board (truncated?)")
    out = {}
    for entry in node[1:]:
        if isinstance(entry, list) and len(entry) >= 3 and isinstance(entry[0], float):
            if not (entry[0].is_integer() and 0 <= entry[0] < 1000):
                raise InputError(f"{where}: the layer table numbers a layer {quote(entry[0], 30)}; valid 0..999")
            user = str(entry[3]) if len(entry) > 3 and isinstance(entry[3], str) else ""
            out[int(entry[0])] = (str(entry[1]), str(entry[2]), user)
    if not out:
        raise InputError(f"{where}: the (layers ...) section lists no layer")
    return out


def _arc_points(centre, start, sweep_deg) -> list:
    """Points of an arc from ``start`` about ``centre`` through ``sweep_deg`` (KiCad's screen sense)."""
    r = math.hypot(start[0] - centre[0], start[1] - centre[1])
    a0 = math.atan2(start[1] - centre[1], start[0] - centre[0])
    n = max(2, int(abs(sweep_deg) / 360 * ARC_SEGMENTS) + 1)
    return [(centre[0] + r * math.cos(a0 + math.radians(sweep_deg) * i / (n - 1)),
             centre[1] + r * math.sin(a0 + math.radians(sweep_deg) * i / (n - 1))) for i in range(n)]


def _circle_through(a, b, c):
    """Centre of the circle through three points, None if they are (nearly) collinear."""
    d = 2 * (a[0] * (b[1] - c[1]) + b[0] * (c[1] - a[1]) + c[0] * (a[1] - b[1]))
    if abs(d) < 1e-12:
        return None
    ux = ((a[0]**2 + a[1]**2) * (b[1] - c[1]) + (b[0]**2 + b[1]**2) * (c[1] - a[1]) + (c[0]**2 + c[1]**2) * (a[1] - b[1])) / d
    uy = ((a[0]**2 + a[1]**2) * (c[0] - b[0]) + (b[0]**2 + b[1]**2) * (a[0] - c[0]) + (c[0]**2 + c[1]**2) * (b[0] - a[0])) / d
    if math.hypot(ux - a[0], uy - a[1]) > 2 * MAX_COORD_MM:  # three points on a line to within rounding
        return None
    return (ux, uy)


def _shape_points(node, kind: str, where: str, what: str) -> list:
    """The points of one graphic item (``line``, ``rect``, ``poly``, ``circle``, ``arc``, ``curve``) as a
    polyline, in the item's own frame; [] when the item lacks what its kind needs."""
    what = f"{what}: {kind}"
    if kind in ("line", "rect"):
        a, b = _xy(node, "start", where, what, False), _xy(node, "end", where, what, False)
        if not (a and b):
            return []
        return [a, b] if kind == "line" else [a, (b[0], a[1]), b, (a[0], b[1]), a]
    if kind in ("poly", "curve"):
        pts = child(node, "pts")
        out = []
        for p in children(pts, "xy") if pts else ():
            if len(p) < 3:
                raise InputError(f"{where}: {what}: (xy {' '.join(quote(v, 20) for v in p[1:])}) needs x and y [mm]")
            out.append((_coord(p[1], where, f"{what} point"), _coord(p[2], where, f"{what} point")))
        return out
    if kind == "circle":
        c, e = _xy(node, "center", where, what, False), _xy(node, "end", where, what, False)
        return _arc_points(c, e, 360.0) if c and e else []
    if kind == "arc":
        mid = _xy(node, "mid", where, what, False)
        a, b = _xy(node, "start", where, what, False), _xy(node, "end", where, what, False)
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
            sweep = _num(ang[1] if len(ang) > 1 else None, where, f"{what} angle")
            if abs(sweep) > 360.0 + 1e-6:
                raise InputError(f"{where}: {what}: an arc of {sweep:g} degrees; an arc turns at most 360 degrees")
            return _arc_points(a, b, sweep)
    return []


def _atom_text(value) -> str:
    """An atom as the file wrote it: KiCad 5's unquoted pad name ``1`` is read as 1.0 and written back as ``1``."""
    if isinstance(value, float):
        return str(int(value)) if value.is_integer() and abs(value) < 1e15 else repr(value)
    return "" if isinstance(value, list) else str(value)


def _layer_of(node) -> str:
    layer = child(node, "layer")
    return str(layer[1]) if layer and len(layer) > 1 else ""


def _fp_at(fp, where: str, what: str) -> tuple:
    """(x, y [mm], rotation [deg]) of a footprint's ``(at x y [angle])``."""
    x, y = _xy(fp, "at", where, what)
    at = child(fp, "at")
    rotation = _num(at[3], where, f"{what}: rotation") if len(at) > 3 and not isinstance(at[3], str) else 0.0
    return x, y, rotation


def _outline(tree, where: str) -> list:
    """The Edge.Cuts polylines of the board and of its footprints, in KiCad coordinates."""
    lines = []
    for kind in _GRAPHICS:
        for node in children(tree, f"gr_{kind}"):
            if _layer_of(node) == "Edge.Cuts":
                pts = _shape_points(node, kind, where, "the board outline (Edge.Cuts)")
                if len(pts) >= 2:
                    lines.append(pts)
    for fp in children(tree, "footprint") + children(tree, "module"):
        edges = [(kind, node) for kind in _GRAPHICS for node in children(fp, f"fp_{kind}")
                 if _layer_of(node) == "Edge.Cuts"]
        if not edges:
            continue
        what = f"footprint {quote(_text_of(fp, 'Reference') or '?', 40)}"
        x0, y0, rot = _fp_at(fp, where, what)
        c, s = math.cos(math.radians(rot)), math.sin(math.radians(rot))
        for kind, node in edges:  # local (y down), rotated as KiCad does on screen
            pts = [(x0 + px * c + py * s, y0 - px * s + py * c)
                   for px, py in _shape_points(node, kind, where, f"{what} Edge.Cuts")]
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


def _footprint(fp, where: str, names: dict, copper: set, front: int, back: int, flip) -> Footprint:
    library = str(fp[1]) if len(fp) > 1 and isinstance(fp[1], str) and not isinstance(fp[1], list) else ""
    ref = _text_of(fp, "Reference") or "?"
    what = f"footprint {quote(ref, 40)} ({quote(library, 80)})"
    bad = _CONTROL.search(ref)
    if bad:
        raise InputError(f"{where}: {what}: its reference holds the control character U+{ord(bad.group()):04X}; "
                         f"a reference is printable text (correct it in KiCad)")
    x, y, rotation = _fp_at(fp, where, what)
    x, y = flip(x, y)
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
            if name.endswith(".Fab") or name.endswith(".CrtYd"):
                pts = [(px, -py) for px, py in _shape_points(node, kind, where, what)]  # local y down -> y up
                (fab if name.endswith(".Fab") else court).extend(pts)
    pads = tuple(p for p in (_pad(node, rotation, where, what, names, copper) for node in children(fp, "pad"))
                 if p is not None)
    fields = {}
    for node in children(fp, "property"):
        if len(node) > 2 and str(node[1]) not in _NOT_FIELDS and not str(node[1]).startswith("ki_"):
            fields[str(node[1])] = _atom_text(node[2])
    attr = child(fp, "attr")
    attributes = tuple(str(a) for a in attr[1:] if isinstance(a, str)) if attr else ()
    if children(fp, "dnp") or any(str(n[1]) == "dnp" for n in children(fp, "property") if len(n) > 1):
        attributes += ("dnp",)
    return Footprint(ref, library, _text_of(fp, "Value"), side, x, y, rotation, Rect.around(fab),
                     Rect.around(court), pads, fields, attributes)


def _drill(node, where: str, what: str) -> float | None:
    """A pad's hole diameter [mm] (``(drill d)``, ``(drill oval w h)``: the smaller side), None without one."""
    drill = child(node, "drill")
    if drill is None:
        return None
    sizes = [_num(v, where, f"{what}: drill") for v in drill[1:] if not isinstance(v, (str, list))]
    return min(sizes) if sizes and min(sizes) > 0 else None


def _pad(node, fp_rotation: float, where: str, what: str, names: dict, copper: set) -> Pad | None:
    """One pad in the footprint frame (y up); None for a paste-only aperture (no copper, no hole)."""
    if len(node) < 4:
        return None
    name, kind = _atom_text(node[1]), str(node[2])
    what = f"{what} pad {quote(name, 20)}"
    layers = child(node, "layers")
    on = [str(v) for v in layers[1:]] if layers else []
    if kind != "np_thru_hole" and not any(n in COPPER_WILDCARDS or names.get(n) in copper or n.endswith(".Cu")
                                          for n in on):
        return None
    px, py = _xy(node, "at", where, what)
    py = -py
    size = child(node, "size")
    if size is None or len(size) < 3:
        raise InputError(f"{where}: {what}: needs (size w h) [mm]")
    at = child(node, "at")
    angle = math.radians((_num(at[3], where, f"{what}: angle") if len(at) > 3 and not isinstance(at[3], str)
                          else 0.0) - fp_rotation)
    w, h = _coord(size[1], where, f"{what}: size"), _coord(size[2], where, f"{what}: size")
    c, s = abs(math.cos(angle)), abs(math.sin(angle))
    hw, hh = 0.5 * (w * c + h * s), 0.5 * (w * s + h * c)
    return Pad(name, kind, Rect(px - hw, py - hh, px + hw, py + hh), _drill(node, where, what))
