"""IDF 3.0 boards: read a ``.emn`` board file with its ``.emp`` library, write one from a layout's board.

IDF (Intermediate Data Format, version 3.0, 1996) is the neutral ECAD/MCAD exchange that Altium, OrCAD,
Allegro, PADS and KiCad export and that Flotherm and Icepak read. The board file holds the outline (its
first line the thickness), holes and the placement of every component (package name, part number,
reference, x, y, mounting offset, rotation counter-clockwise [deg], side, status); the library holds each
package's outline and **height**, and optional properties (``PROP POWER_OPR`` is the operating power [W]).
Units are ``MM`` or ``THOU`` (0.0254 mm). An outline point with a non-zero angle closes an arc of that sweep
[deg, counter-clockwise positive] from the previous point; 360 draws a circle about the previous point.
A bottom-side package's outline is mirrored about its own y axis before it is rotated.

IDF carries no stack-up: the copper layers are assumed (``copper_layers``, ``copper_um``) and said so.
:func:`write_idf` writes a layout's board (its modelled and merged parts, heights and powers) so an import
can be checked by a round trip.
"""

from __future__ import annotations

import math
import re
import shlex
from pathlib import Path

from imutherm import InputError
from imutherm.ecad.board import BoardDesign, Footprint, Rect
from imutherm.ecad.outline_loops import simplified_outline
from imutherm.textio import quote, read_text

MM_PER_THOU = 0.0254
_CONTROL = re.compile(r"[\x00-\x1f\x7f-\x9f]")
#: IDF carries no stack-up: copper layers assumed when reading one (the reference unit's 4-layer board)
DEFAULT_COPPER_LAYERS = 4
DEFAULT_COPPER_UM = 35.0
MAX_IDF_BYTES = 64 * 2**20
#: most outline records read (ten times the points a layout's outline holds after simplification; a real
#: board edge has hundreds to a few thousand)
MAX_OUTLINE_RECORDS = 200_000
ARC_SEGMENTS = 72


def _sections(text: str, where: str) -> list:
    """[(name, [record tokens ...]), ...] of the file's ``.NAME`` ... ``.END_NAME`` sections."""
    out, current, rows = [], None, []
    for number, line in enumerate(text.splitlines(), 1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        if s.startswith("."):
            key = s.split()[0].upper()
            if current is None:
                current, rows = key[1:], []
                out.append((current, rows, number))
            elif key == f".END_{current}":
                current = None
            else:
                raise InputError(f"{where}: line {number}: {quote(s, 40)} inside section .{current} (missing "
                                 f".END_{current}?)")
            continue
        if current is None:
            raise InputError(f"{where}: line {number}: {quote(s, 60)} outside any section; not an IDF file?")
        if '"' not in s and "'" not in s and "\\" not in s:
            rows.append((number, s.split()))  # most records (outline points): 20x faster than shlex
            continue
        try:
            rows.append((number, shlex.split(s, posix=True)))
        except ValueError:
            raise InputError(f"{where}: line {number}: unbalanced quotes in {quote(s, 60)}") from None
    if current is not None:
        raise InputError(f"{where}: the file ends inside section .{current}: truncated?")
    return out


def _float(tok: str, where: str, number: int, what: str) -> float:
    try:
        v = float(tok)
    except (TypeError, ValueError):
        v = math.nan
    if not math.isfinite(v):
        raise InputError(f"{where}: line {number}: {what}: expected a number, got {quote(tok, 30)}")
    return v


def _number_or_nan(tok: str) -> float:
    try:
        return float(tok)
    except ValueError:
        return math.nan


def _outline_records(text: str) -> int:
    """The points of the file's outline sections (their records less the thickness line), counted at C speed
    before they are read."""
    count, start = 0, 0
    while True:
        a = min((i for i in (text.find(".BOARD_OUTLINE", start), text.find(".PANEL_OUTLINE", start)) if i >= 0),
                default=-1)
        if a < 0:
            return count
        head_end = text.find("\n", a)
        b = text.find(".END_", a + 1)
        b = len(text) if b < 0 else b
        count += max(text.count("\n", head_end + 1, b) - 1, 0) if head_end >= 0 else 0
        start = b


def _loop_points(rows, where: str, scale: float) -> list:
    """The polylines of outline records ``label x y angle`` (arcs sampled), in file units x ``scale``."""
    loops, current, label = [], [], None
    for number, tok in rows:
        if len(tok) < 4:
            raise InputError(f"{where}: line {number}: an outline point needs 'loop x y angle', got {' '.join(tok)}")
        lab = tok[0]
        try:
            x, y, ang = float(tok[1]) * scale, float(tok[2]) * scale, float(tok[3])
        except ValueError:
            x = y = ang = math.nan
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(ang)):
            bad = next(t for t in tok[1:4] if not math.isfinite(_number_or_nan(t)))
            raise InputError(f"{where}: line {number}: outline point: expected a number, got {quote(bad, 30)}")
        if label is not None and lab != label and current:
            loops.append(current)
            current = []
        label = lab
        if abs(ang) > 360.0 + 1e-6:
            raise InputError(f"{where}: line {number}: an arc of {ang:g} degrees; an arc turns at most 360 degrees")
        if ang == 0 or not current:
            current.append((x, y))
            continue
        px, py = current[-1]
        if abs(abs(ang) - 360.0) < 1e-9:  # a circle about the previous point through this one
            r = math.hypot(x - px, y - py)
            current[-1:] = [(px + r * math.cos(2 * math.pi * i / ARC_SEGMENTS), py + r * math.sin(2 * math.pi * i / ARC_SEGMENTS))
                            for i in range(ARC_SEGMENTS + 1)]
            continue
        chord = math.hypot(x - px, y - py)
        theta = math.radians(ang)
        r = chord / (2 * math.sin(abs(theta) / 2)) if chord > 0 else 0.0
        mx, my = (px + x) / 2, (py + y) / 2
        h = math.sqrt(max(r * r - (chord / 2) ** 2, 0.0)) * (1 if abs(theta) < math.pi else -1)
        nx, ny = (-(y - py) / chord, (x - px) / chord) if chord > 0 else (0.0, 0.0)
        sign = 1.0 if theta > 0 else -1.0
        cx, cy = mx + sign * h * nx, my + sign * h * ny
        a0 = math.atan2(py - cy, px - cx)
        n = max(2, int(abs(ang) / 360 * ARC_SEGMENTS) + 1)
        current += [(cx + r * math.cos(a0 + theta * i / (n - 1)), cy + r * math.sin(a0 + theta * i / (n - 1)))
                    for i in range(1, n)]
    if current:
        loops.append(current)
    return loops


def _header(sections, where: str, kind: str) -> tuple:
    """(units scale [mm per unit], board name) of an IDF header."""
    if not sections or sections[0][0] != "HEADER":
        raise InputError(f"{where}: not an IDF file: it must start with a .HEADER section")
    rows = sections[0][1]
    if not rows or len(rows[0][1]) < 2 or rows[0][1][0].upper() != kind or not rows[0][1][1].startswith("3"):
        raise InputError(f"{where}: not an IDF 3.0 {kind}: the header's first record must be '{kind} 3.0 ...'")
    units = rows[1][1][-1].upper() if kind == "BOARD_FILE" and len(rows) > 1 and rows[1][1] else "MM"
    if units not in ("MM", "THOU"):
        raise InputError(f"{where}: units {units!r}; valid: MM or THOU")
    return (1.0 if units == "MM" else MM_PER_THOU), (rows[1][1][0] if kind == "BOARD_FILE" and len(rows) > 1 else "")


def read_library(path: str | Path) -> dict:
    """``{(package, part number): (outline Rect [mm] in the package frame, height [mm], properties)}`` of a .emp."""
    where = str(path)
    sections = _sections(read_text(path, "IDF library file", MAX_IDF_BYTES), where)
    _header(sections, where, "LIBRARY_FILE")
    out = {}
    for name, rows, start in sections[1:]:
        if name not in ("ELECTRICAL", "MECHANICAL"):
            continue
        if not rows or len(rows[0][1]) < 4:
            raise InputError(f"{where}: line {start}: .{name} needs 'package part_number units height'")
        number, head = rows[0]
        units = head[2].upper()
        if units not in ("MM", "THOU"):
            raise InputError(f"{where}: line {number}: units {head[2]!r}; valid: MM or THOU")
        scale = 1.0 if units == "MM" else MM_PER_THOU
        height = _float(head[3], where, number, "height") * scale
        if not 0 < height <= 100:
            raise InputError(f"{where}: line {number}: package {head[0]} height {height:g} mm; valid: 0..100 mm")
        props = {}
        points = []
        for n, tok in rows[1:]:
            if tok and tok[0].upper() == "PROP":
                if len(tok) < 3:
                    raise InputError(f"{where}: line {n}: PROP needs a name and a value")
                props[tok[1].upper()] = tok[2]
            else:
                points.append((n, tok))
        loops = _loop_points(points, where, scale)
        box = Rect.around(p for loop in loops for p in loop)
        if box is None or box.area <= 0:
            raise InputError(f"{where}: line {number}: package {head[0]} has no outline")
        out[(head[0], head[1])] = (box, height, props)
    return out


def read_idf(path: str | Path, copper_layers: int = DEFAULT_COPPER_LAYERS,
             copper_um: float = DEFAULT_COPPER_UM) -> BoardDesign:
    """Read an IDF 3.0 board (``.emn``) and its library (the ``.emp`` of the same name beside it)."""
    path = Path(path)
    where = str(path)
    text = read_text(path, "IDF board file", MAX_IDF_BYTES)
    records = _outline_records(text)
    if records > MAX_OUTLINE_RECORDS:
        raise InputError(f"{where}: the board outline has {records:,} points; at most {MAX_OUTLINE_RECORDS:,}: not an "
                         f"outline to model (simplify the board edge in the ECAD tool)")
    sections = _sections(text, where)
    scale, _ = _header(sections, where, "BOARD_FILE")
    lib_path = path.with_suffix(".emp")
    if not lib_path.exists():
        lib_path = path.with_suffix(".EMP")
    if not lib_path.exists():
        raise InputError(f"{where}: its library {path.with_suffix('.emp')} (package outlines and heights) is not "
                         f"beside it; export the .emp with the .emn")
    library = read_library(lib_path)
    outline = next((rows for name, rows, _ in sections if name in ("BOARD_OUTLINE", "PANEL_OUTLINE")), None)
    if not outline:
        raise InputError(f"{where}: the board has no .BOARD_OUTLINE section (or it is empty)")
    number, first = outline[0]
    thickness = _float(first[0], where, number, "board thickness") * scale
    if not 0.1 <= thickness <= 10:
        raise InputError(f"{where}: line {number}: board thickness {thickness:g} mm is impossible (valid 0.1..10 mm)")
    loops = simplified_outline(_loop_points(outline[1:], where, scale), where)
    box = Rect.around(p for loop in loops for p in loop)
    if box is None or box.width <= 0 or box.height <= 0:
        raise InputError(f"{where}: the board outline encloses no area")
    shift = lambda x, y: (round(x - box.x0, 6), round(y - box.y0, 6))  # noqa: E731
    footprints = []
    for name, rows, _ in sections:
        if name != "PLACEMENT":
            continue
        if len(rows) % 2:
            raise InputError(f"{where}: .PLACEMENT holds records in pairs; the last one is incomplete")
        for (n1, a), (n2, b) in zip(rows[0::2], rows[1::2]):
            if len(a) < 3 or len(b) < 6:
                raise InputError(f"{where}: line {n1}: a placement is 'package part_number reference' then "
                                 f"'x y offset rotation side status'")
            package, part, ref = a[0], a[1], a[2]
            bad = _CONTROL.search(ref)
            if bad:
                raise InputError(f"{where}: line {n1}: reference {quote(ref, 40)} holds the control character "
                                 f"U+{ord(bad.group()):04X}; a reference is printable text")
            x, y, _off, rot = (_float(t, where, n2, "placement") for t in b[:4])
            side = {"TOP": "top", "BOTTOM": "bottom"}.get(b[4].upper())
            if side is None:
                raise InputError(f"{where}: line {n2}: {ref}: side {b[4]!r}; valid: TOP or BOTTOM")
            if (package, part) not in library:
                raise InputError(f"{where}: line {n1}: {ref}: package {package!r} / {part!r} is not in {lib_path}")
            body, height, props = library[(package, part)]
            if side == "bottom":  # mirrored about the package's own y axis
                body = Rect(-body.x1, body.y0, -body.x0, body.y1)
            fields = {"POWER_OPR": props["POWER_OPR"]} if "POWER_OPR" in props else {}
            attributes = ("unplaced",) if b[5].upper() == "UNPLACED" else ()
            px, py = shift(x * scale, y * scale)
            footprints.append(Footprint(ref, package, part, side, px, py, rot, body, None, (), fields,
                                        attributes, height))
    return BoardDesign(where, "IDF 3.0", box.width, box.height, tuple(tuple(shift(*p) for p in loop) for loop in loops),
                       thickness, copper_layers, (float(copper_um),) * copper_layers,
                       f"IDF carries no stack-up: {copper_layers} copper layers of {copper_um:g} um assumed",
                       tuple(footprints), ())


def _q(s: str) -> str:
    return '"' + str(s).replace('"', "'") + '"'


def _chain(polylines, tol: float = 1e-3) -> list:
    """The polylines joined end to end into closed loops where they meet (the rest left open)."""
    pending = [list(p) for p in polylines]
    loops = []
    while pending:
        loop = pending.pop(0)
        grown = True
        while grown and pending:
            grown = False
            for i, p in enumerate(pending):
                if math.dist(loop[-1], p[0]) < tol:
                    loop += p[1:]
                elif math.dist(loop[-1], p[-1]) < tol:
                    loop += p[-2::-1]
                else:
                    continue
                pending.pop(i)
                grown = True
                break
        loops.append(loop)
    return loops


def write_idf(layout, board_name: str, path: str | Path) -> tuple:
    """Write board ``board_name`` of ``layout`` (a LayoutSpec) as IDF 3.0: ``path`` (.emn) and its .emp.

    The outline is the board's true outline where its polylines close into a loop, else its rectangle; each
    modelled component and each merged part is placed at its body's centre, rotation 0, with a rectangular
    package outline, its height and ``PROP POWER_OPR`` (its power [W]). Returns (emn path, emp path)."""
    board = next((b for b in layout.boards if b.name == board_name), None)
    if board is None:
        raise InputError(f"{layout.path}: no board {board_name!r}")
    axis = "xyz".index(board.normal)
    a0, a1 = (a for a in range(3) if a != axis)
    w, h, t = board.size_mm[a0], board.size_mm[a1], board.size_mm[axis]
    loops = _chain(board.outline_mm or ())
    if not loops or any(math.dist(loop[0], loop[-1]) > 1e-3 for loop in loops):
        loops = [[(0.0, 0.0), (w, 0.0), (w, h), (0.0, h), (0.0, 0.0)]]
    emn, emp = Path(path), Path(path).with_suffix(".emp")
    parts = [(c.name, c.footprint or f"{c.name}_body", c.side, c.center_mm, c.size_mm, c.power_W)
             for c in layout.components if c.board == board_name]
    parts += [(m.name, m.footprint or f"{m.name}_body", m.side, m.center_mm, m.size_mm, 0.0)
              for m in board.merged_parts or ()]
    lines = [".HEADER", f"BOARD_FILE 3.0 {_q('imutherm')} 2026/01/01.00:00:00 1", f"{_q(layout.name)} MM", ".END_HEADER",
             ".BOARD_OUTLINE ECAD", f"{t:.6g}"]
    for i, loop in enumerate(loops):
        lines += [f"{i} {x:.6f} {y:.6f} 0" for x, y in loop]
    lines += [".END_BOARD_OUTLINE", ".PLACEMENT"]
    lib = [".HEADER", f"LIBRARY_FILE 3.0 {_q('imutherm')} 2026/01/01.00:00:00 1", ".END_HEADER"]
    for name, package, side, (u, v), (sw, sh, height), power in parts:
        geom, part = f"{package}@{name}", name
        lines += [f"{_q(geom)} {_q(part)} {_q(name)}", f"{u:.6f} {v:.6f} 0.0 0.0 {side.upper()} PLACED"]
        lib += [".ELECTRICAL", f"{_q(geom)} {_q(part)} MM {height:.6g}", f"PROP POWER_OPR {power:.9g}",
                f"0 {-sw / 2:.6f} {-sh / 2:.6f} 0", f"0 {sw / 2:.6f} {-sh / 2:.6f} 0", f"0 {sw / 2:.6f} {sh / 2:.6f} 0",
                f"0 {-sw / 2:.6f} {sh / 2:.6f} 0", f"0 {-sw / 2:.6f} {-sh / 2:.6f} 0", ".END_ELECTRICAL"]
    lines.append(".END_PLACEMENT")
    emn.write_text("\n".join(lines) + "\n", encoding="utf-8")
    emp.write_text("\n".join(lib) + "\n", encoding="utf-8")
    return emn, emp
