"""Write small KiCad boards for the tests, in the dialects of KiCad 5, 7, 8 and 9.

A part is a dict: ``ref``, ``lib`` (library name), ``value``, ``at`` (x, y, rotation) in KiCad's coordinates
(mm, y down), ``side`` (``top``/``bottom``), ``fab`` ((x0, y0, x1, y1) in the footprint's local frame, y down,
as the part sits on the top side; a bottom part is written mirrored, as KiCad stores it), ``pads``
(list of (name, kind, x, y, w, h[, drill]) in the same frame), ``fields`` (dict), ``attr`` (list).

Copper layers renamed (``copper_names``) are written as each KiCad writes them: KiCad 5 names the layer so in
its table and on every pad and footprint; KiCad 6-9 keep the canonical name everywhere and add the user's as a
fourth word of the table.
"""

from __future__ import annotations

DIALECTS = ("kicad5", "kicad7", "kicad8", "kicad9")


def _layers(dialect: str, copper: int, names: tuple | None) -> tuple:
    """(the layers section, front copper name, back copper name, a layer-name function)."""
    if dialect == "kicad9":
        nums = [0] + [4 + 2 * i for i in range(copper - 2)] + [2]
    else:
        nums = [0] + list(range(1, copper - 1)) + [31]
    canonical = ("F.Cu",) + tuple(f"In{i}.Cu" for i in range(1, copper - 1)) + ("B.Cu",)
    q = (lambda s: s) if dialect == "kicad5" else (lambda s: f'"{s}"')
    if names and dialect != "kicad5":   # KiCad 6+: canonical names in use, the user's in the table
        rows = [f"    ({n} {q(name)} signal {q(user)})" for n, name, user in zip(nums, canonical, names)]
        cu = canonical
    else:
        cu = names or canonical
        rows = [f"    ({n} {q(name)} signal)" for n, name in zip(nums, cu)]
    other = (("F.SilkS", 37, 5), ("B.SilkS", 36, 7), ("Edge.Cuts", 44, 25), ("F.CrtYd", 47, 31),
             ("B.CrtYd", 46, 29), ("F.Fab", 49, 35), ("B.Fab", 48, 33))
    rows += [f"    ({n9 if dialect == 'kicad9' else n} {q(name)} user)" for name, n, n9 in other]
    return "  (layers\n" + "\n".join(rows) + "\n  )", cu[0], cu[-1], q


def kicad_board(parts, *, dialect: str = "kicad7", outline=(100.0, 100.0, 140.0, 130.0), thickness: float = 1.6,
                copper: int = 4, stackup=None, copper_names: tuple | None = None, vias=(), extra: str = "") -> str:
    """The text of a ``.kicad_pcb`` holding ``parts`` (see the module docstring) inside the rectangle
    ``outline`` (x0, y0, x1, y1) [mm] (None: no outline; draw one in ``extra``); ``stackup``: list of (name,
    type, thickness [mm], or a list of sublayer thicknesses [mm]) or None."""
    version = {"kicad5": 20171130, "kicad7": 20221018, "kicad8": 20240108, "kicad9": 20241229}[dialect]
    layers, front, back, q = _layers(dialect, copper, copper_names)
    lines = [f"(kicad_pcb (version {version}) (generator pcbnew)", f"  (general (thickness {thickness}))", layers]
    if stackup:
        def thick(th):
            return " addsublayer ".join(f"(thickness {t}) (material \"FR4\")" for t in th) \
                if isinstance(th, (list, tuple)) else f"(thickness {th})"
        rows = "\n".join(f'      (layer "{n}" (type "{t}") {thick(th)})' for n, t, th in stackup)
        lines.append(f"  (setup\n    (stackup\n{rows}\n    )\n  )")
    edge = q("Edge.Cuts")
    if outline is not None:
        x0, y0, x1, y1 = outline
        for a, b in (((x0, y0), (x1, y0)), ((x1, y0), (x1, y1)), ((x1, y1), (x0, y1)), ((x0, y1), (x0, y0))):
            lines.append(f"  (gr_line (start {a[0]} {a[1]}) (end {b[0]} {b[1]}) (layer {edge}) (width 0.05))")
    for x, y, drill in vias:
        lines.append(f"  (via (at {x} {y}) (size 0.6) (drill {drill}) (layers {q(front)} {q(back)}) (net 0))")
    for p in parts:
        lines.append(_footprint(p, dialect, front, back, q))
    lines.append(extra)
    lines.append(")")
    return "\n".join(lines) + "\n"


def _footprint(p: dict, dialect: str, front: str, back: str, q) -> str:
    bottom = p.get("side", "top") == "bottom"
    mirror = (lambda x: -x) if bottom else (lambda x: x)
    side = "B" if bottom else "F"
    x, y, rot = p["at"]
    head = "module" if dialect == "kicad5" else "footprint"
    lib = p["lib"] if dialect == "kicad5" else f'"{p["lib"]}"'
    out = [f"  ({head} {lib} (layer {q(back if bottom else front)})", f"    (at {x} {y} {rot})"]
    ref, value = p["ref"], p.get("value", "X")
    if dialect in ("kicad8", "kicad9"):
        out += [f'    (property "Reference" "{ref}" (at 0 0 0) (layer "{side}.SilkS"))',
                f'    (property "Value" "{value}" (at 0 0 0) (layer "{side}.Fab"))']
    else:
        out += [f"    (fp_text reference {q(ref)} (at 0 0) (layer {q(side + '.SilkS')}))",
                f"    (fp_text value {q(value)} (at 0 0) (layer {q(side + '.Fab')}))"]
    for k, v in p.get("fields", {}).items():
        out.append(f'    (property "{k}" "{v}")')
    if p.get("attr"):
        out.append(f"    (attr {' '.join(p['attr'])})")
    if p.get("fab"):
        fx0, fy0, fx1, fy1 = p["fab"]
        fx0, fx1 = sorted((mirror(fx0), mirror(fx1)))
        for a, b in (((fx0, fy0), (fx1, fy0)), ((fx1, fy0), (fx1, fy1)), ((fx1, fy1), (fx0, fy1)), ((fx0, fy1), (fx0, fy0))):
            out.append(f"    (fp_line (start {a[0]} {a[1]}) (end {b[0]} {b[1]}) (layer {q(side + '.Fab')}) (width 0.1))")
    for name, kind, px, py, w, h, *drill in p.get("pads", []):
        cu = f"{q(back if bottom else front)} {q(side + '.Paste')}" if kind == "smd" else q("*.Cu")
        hole = f" (drill {drill[0]})" if drill else ""
        out.append(f"    (pad {name if dialect == 'kicad5' else chr(34) + str(name) + chr(34)} {kind} "
                   f"{'circle' if drill else 'rect'} (at {mirror(px)} {py} {rot}) (size {w} {h}){hole} (layers {cu}))")
    out.append("  )")
    return "\n".join(out)


def part(ref, lib, at, *, side="top", fab=(-1.0, -0.5, 1.0, 0.5), pads=None, value="X", fields=None, attr=("smd",)):
    """A part dict with two pads under its fab outline unless ``pads`` is given."""
    if pads is None:
        x0, y0, x1, y1 = fab
        cy, h = (y0 + y1) / 2, (y1 - y0) * 0.8
        pads = [("1", "smd", x0 + 0.2 * (x1 - x0), cy, 0.3 * (x1 - x0), h),
                ("2", "smd", x1 - 0.2 * (x1 - x0), cy, 0.3 * (x1 - x0), h)]
    return {"ref": ref, "lib": lib, "at": at, "side": side, "fab": fab, "pads": pads, "value": value,
            "fields": dict(fields or {}), "attr": list(attr)}
