"""Where an imported board stands on its housing's base: standoffs under its mounting holes, else near its corners.

A mounting hole is what :func:`imutherm.ecad.classify.skip_reason` calls one: a ``MountingHole`` footprint or
any footprint that is a hole of 2 mm or more without a body. Under each goes a round standoff of twice the
hole's diameter (no wider than its courtyard), modelled as the square of the same area; one that would
overlap a part on the back shrinks to the hole's size, and goes (with a note) if that overlaps too. A board
without mounting holes stands on four 3 mm standoffs, one near each corner of its outline rectangle, moved
along the diagonal towards the middle until it lies inside the true outline (a round or D-shaped board's
corners are not board) and clear of the parts on the back.
"""

from __future__ import annotations

import math

import numpy as np

from imutherm import InputError
from imutherm.ecad.board import BoardDesign, Rect
from imutherm.ecad.outline_loops import chain, inside
from imutherm.ecad.part_bodies import clip, overlaps, quantised, round_mm
from imutherm.ecad.toml_writer import NOTE

#: a corner standoff's side [mm] and its least distance to the outline rectangle's edges [mm]
CORNER_STANDOFF_MM = 3.0
CORNER_INSET_MM = 1.0
#: step [mm] of the search along the diagonal for a corner standoff inside the outline
CORNER_STEP_MM = 0.5


def _inside_outline(loops: list, r: Rect) -> bool:
    """True if the square ``r`` lies inside the closed ``loops`` (its corners, edge middles and centre)."""
    if not loops:
        return True
    xs, ys = np.meshgrid([r.x0, r.centre[0], r.x1], [r.y0, r.centre[1], r.y1])
    return bool(np.all(inside(loops, xs, ys)))


def standoff_rects(board: BoardDesign, decisions: list, notes: list) -> list:
    """(ref, Rect) of the standoffs in board coordinates (see the module docstring)."""
    holes = [d.footprint for d in decisions if d.fate == "skipped" and d.reason.startswith("mounting hole")]
    back = [d for d in decisions if d.fate in ("modelled", "merged") and d.footprint.side == "bottom"]
    boxes = []
    for fp in holes:
        drills = [p.drill_mm for p in fp.pads if p.drill_mm]
        d_hole = max(drills) if drills else min((min(p.rect.width, p.rect.height) for p in fp.pads), default=3.0)
        outer = 2.0 * d_hole if fp.courtyard is None else min(2.0 * d_hole, fp.courtyard.width)
        for size in (outer * math.sqrt(math.pi) / 2.0, d_hole * math.sqrt(math.pi) / 2.0):
            r = quantised(clip(Rect(fp.x - size / 2, fp.y - size / 2, fp.x + size / 2, fp.y + size / 2), board))
            clash = [d.footprint.ref for d in back if overlaps(r, d.body)]
            if not clash:
                boxes.append((fp.ref, r))
                break
        else:
            notes.append(f"no standoff under {fp.ref}: parts on the back ({', '.join(clash[:4])}) take its place")
    if not boxes and not holes:
        loops, _ = chain(board.outline)
        s, w, h = CORNER_STANDOFF_MM, board.width_mm, board.height_mm
        moved = []
        corners = ((0, 0, 1, 1), (w - s, 0, -1, 1), (0, h - s, 1, -1), (w - s, h - s, -1, -1))
        for i, (x, y, dx, dy) in enumerate(corners):
            reach = 0.5 * math.hypot(w - s, h - s)
            for step in np.arange(CORNER_INSET_MM, reach, CORNER_STEP_MM):
                a = step / math.sqrt(2.0)
                r = quantised(Rect(x + dx * a, y + dy * a, x + dx * a + s, y + dy * a + s))
                if _inside_outline(loops, r) and not any(overlaps(r, d.body) for d in back):
                    boxes.append((f"corner{i + 1}", r))
                    if step > CORNER_INSET_MM + 1e-9:
                        moved.append(f"corner{i + 1} {step - CORNER_INSET_MM:.1f} mm")
                    break
        if moved:
            notes.append(f"no mounting hole on the board: standoffs near its corners, moved along the diagonals to lie "
                         f"inside its outline and clear of the parts on the back ({', '.join(moved)})")
    if not boxes:
        raise InputError(f"{board.source}: no place for a standoff under the board (its mounting holes and corners are "
                         f"taken by parts on the back); give the board a mounting hole or place the unit by hand")
    return [(ref, r) for ref, r in boxes if r.width > 0.1 and r.height > 0.1]


def standoff_parts(rects: list, x0: float, y0: float, z0: float, height: float, material: str) -> list:
    """The ``[[parts]]`` tables of the standoffs (board rects shifted to the unit)."""
    parts = []
    for i, (ref, r) in enumerate(rects):
        parts.append({NOTE: f"standoff under {ref}" + (" (mounting hole)" if not ref.startswith("corner") else
                                                        " (no mounting hole on the board: near a corner, assumed)"),
                      "name": f"standoff_{i + 1}", "min_mm": [round_mm(x0 + r.x0), round_mm(y0 + r.y0), round_mm(z0)],
                      "size_mm": [round_mm(r.width), round_mm(r.height), round_mm(height)], "material": material})
    return parts
