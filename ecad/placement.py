"""The modelled parts on their board: what overhangs the edge, and what overlaps by design.

Real boards put parts where a box model would not: an edge connector or a horizontal header hangs over the
board edge, a part sits over a notch of the outline, a reverse-mount LED shines through its key switch, a
part sits under a module or a shield, two fab outlines drawn generously cross. :func:`place_parts` keeps
each of them and says what it did (each note gives the part's position, as the board file has it):

* a body **over the edge** is cut at the board's rectangle: the model's body is the part over the board (its
  power, if any, dissipated there), the overhang's mass and surface left out; a part over a notch or cut-out
  of the true outline is kept whole and noted. A part with less than :data:`MIN_ON_BOARD_MM` of its body on
  the board is not on it: skipped (a ``--site`` there is refused);
* two bodies on one side that **overlap** by half the smaller one or more are a design's (one inside the
  other): the one that neither dissipates, carries a site nor is kept is merged into the board (its mass
  smeared, as a small part's), the smaller when both are such; two that both matter are refused;
* a **partial overlap** (crossing fab outlines) is trimmed: the body of the part that matters less (then the
  one losing the smaller share) gives way to the other along the axis that costs it least.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from imutherm import InputError
from imutherm.ecad.board import BoardDesign, Rect
from imutherm.ecad.outline_loops import chain, inside
from imutherm.ecad.part_bodies import DIGITS, clip, overlaps, quantised

#: least body extent [mm] on the board for a part to count as on it
MIN_ON_BOARD_MM = 0.25
#: share of the smaller body two bodies must share to count as one inside the other
INSIDE_FRACTION = 0.5
#: share of a body over a cut-out or notch of the true outline worth a note
OVER_CUTOUT_FRACTION = 0.02


def _intersection(a: Rect, b: Rect) -> Rect:
    return Rect(max(a.x0, b.x0), max(a.y0, b.y0), min(a.x1, b.x1), min(a.y1, b.y1))


def _trimmed(body: Rect, other: Rect) -> Rect | None:
    """``body`` shrunk along one axis to meet ``other``, the option that keeps the most area; None if none."""
    options = []
    if other.x0 <= body.x0 < other.x1 < body.x1:
        options.append(Rect(other.x1, body.y0, body.x1, body.y1))
    if body.x0 < other.x0 < body.x1 <= other.x1:
        options.append(Rect(body.x0, body.y0, other.x0, body.y1))
    if other.y0 <= body.y0 < other.y1 < body.y1:
        options.append(Rect(body.x0, other.y1, body.x1, body.y1))
    if body.y0 < other.y0 < body.y1 <= other.y1:
        options.append(Rect(body.x0, body.y0, body.x1, other.y0))
    return max(options, key=lambda r: r.area, default=None)


def _kept_share(bodies: dict, victim: str, other: str) -> float:
    """The share of ``victim``'s body left after trimming it to meet ``other``'s (0 if it cannot be)."""
    cut = _trimmed(bodies[victim], bodies[other])
    return cut.area / bodies[victim].area if cut is not None else 0.0


def _where(fp) -> str:
    return f"{fp.ref} at ({fp.x:.2f}, {fp.y:.2f}) mm"


def _edges(board: BoardDesign, body: Rect) -> str:
    sides = [name for name, over in (("left", -body.x0), ("bottom", -body.y0), ("right", body.x1 - board.width_mm),
                                     ("top", body.y1 - board.height_mm)) if over > 10.0**-DIGITS]
    return " and ".join(sides)


def place_parts(board: BoardDesign, decisions: list, keep: set, sites: set, notes: list) -> tuple:
    """(decisions, {ref: body Rect on the board}) of the modelled parts (see the module docstring).

    keep : refs that matter whatever their power (sites, the electrical design's parts, ``--keep``)
    sites : the ``--site`` refs (refused if off the board); notes : gets a line for everything done."""
    loops, _ = chain(board.outline)
    out, bodies = list(decisions), {}
    for k, d in enumerate(out):
        if d.fate != "modelled":
            continue
        fp, b = d.footprint, d.body
        c = clip(b, board)
        if c.width < min(MIN_ON_BOARD_MM, b.width) or c.height < min(MIN_ON_BOARD_MM, b.height):
            if fp.ref in sites:
                raise InputError(f"{board.source}: --site {fp.ref}: {_where(fp)} lies outside the board outline "
                                 f"(0..{board.width_mm:.2f} x 0..{board.height_mm:.2f} mm)")
            out[k] = replace(d, fate="skipped", reason="outside the board outline (less than "
                             f"{MIN_ON_BOARD_MM:g} mm of its body on the board)")
            notes.append(f"{_where(fp)}: its body lies outside the board outline: skipped"
                         + (f" (its {d.power_W:g} W left out)" if d.power_W > 0 else ""))
            continue
        if b.area - c.area > 10.0**-DIGITS * max(b.width, b.height):
            notes.append(f"{_where(fp)}: its body overhangs the board's {_edges(board, b)} edge by "
                         f"{max(-b.x0, -b.y0, b.x1 - board.width_mm, b.y1 - board.height_mm):.2f} mm "
                         f"({100 * (1 - c.area / b.area):.0f} % of its area): kept, cut at the edge (the model's body "
                         f"is the part over the board{', its power dissipated there' if d.power_W > 0 else ''})")
        elif loops:
            gx, gy = np.meshgrid(np.linspace(c.x0, c.x1, 12)[1:-1], np.linspace(c.y0, c.y1, 12)[1:-1])
            off = 1.0 - float(np.mean(inside(loops, gx, gy)))
            if off > OVER_CUTOUT_FRACTION:
                notes.append(f"{_where(fp)}: {100 * off:.0f} % of its body lies over a notch or cut-out of the "
                             f"board outline (an edge part): kept whole")
        bodies[fp.ref] = quantised(c)
    _resolve_overlaps(board, out, bodies, keep, notes)
    return out, bodies


def _resolve_overlaps(board: BoardDesign, out: list, bodies: dict, keep: set, notes: list) -> None:
    """Merge what lies inside another part and trim crossing outlines (see the module docstring), in place."""
    index = {d.footprint.ref: k for k, d in enumerate(out) if d.fate == "modelled"}

    def matters(ref):
        return out[index[ref]].power_W > 0 or ref in keep

    changed = True
    while changed:
        changed = False
        refs = [r for r in bodies if out[index[r]].fate == "modelled"]
        for i, a in enumerate(refs):
            for b in refs[i + 1:]:
                da, db = out[index[a]], out[index[b]]
                if da.footprint.side != db.footprint.side or not overlaps(bodies[a], bodies[b]):
                    continue
                small, big = sorted((a, b), key=lambda r: (bodies[r].area, r))
                shared = _intersection(bodies[small], bodies[big]).area
                side = da.footprint.side
                victim, other = min(((a, b), (b, a)), key=lambda vo: (matters(vo[0]), -_kept_share(bodies, *vo)))
                cut = _trimmed(bodies[victim], bodies[other])
                if shared < INSIDE_FRACTION * bodies[small].area and cut is not None and \
                        min(cut.width, cut.height) >= MIN_ON_BOARD_MM:
                    notes.append(f"{_where(out[index[victim]].footprint)}: its body and {other}'s overlap on the "
                                 f"{side} side by {shared:.2f} mm^2 (crossing fab outlines): {victim}'s trimmed by "
                                 f"{max(bodies[victim].width - cut.width, bodies[victim].height - cut.height):.2f} "
                                 f"mm to meet {other}'s")
                    bodies[victim] = quantised(cut)
                else:
                    gone = small if not matters(small) else big if not matters(big) else None
                    if gone is None:
                        ra, rb = bodies[a], bodies[b]
                        raise InputError(
                            f"{board.source}: parts {a} and {b} overlap on the {side} side and both dissipate or "
                            f"carry a site ({a}: {ra.x0:.2f}..{ra.x1:.2f} x {ra.y0:.2f}..{ra.y1:.2f} mm; {b}: "
                            f"{rb.x0:.2f}..{rb.x1:.2f} x {rb.y0:.2f}..{rb.y1:.2f} mm); correct their fab outlines or "
                            f"placement in KiCad")
                    other = big if gone == small else small
                    how = "inside" if gone == small else "around"
                    d = out[index[gone]]
                    out[index[gone]] = replace(d, fate="merged", reason=f"{how} {other}'s body (a part placed in or "
                                               f"under another by design): merged into the board")
                    notes.append(f"{_where(d.footprint)} lies {how} {other}'s body on the {side} side "
                                 f"({100 * shared / bodies[small].area:.0f} % of {small}'s area), as placed by design: "
                                 f"{gone} merged into the board (its mass smeared), {other} modelled")
                    del bodies[gone]
                changed = True
                break
            if changed:
                break
