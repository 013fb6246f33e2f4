"""A KiCad board's thickness and copper from its ``(stackup)`` section, and what is unusual about it.

KiCad 6-9 write the physical stack-up top to bottom: mask, copper and dielectric layers, each with its
``(thickness ...)``; a dielectric of several sublayers (core + prepreg, KiCad's *add sublayer*) carries one
``(thickness ...)`` per sublayer after the word ``addsublayer``, and all of them count. Files without a
stack-up (KiCad 4/5, or never opened in the Board Setup) state a thickness in ``(general (thickness ...))``;
their copper is then assumed 35 um a layer and said so.

What is taken, and said (each note printed by ``imutherm import``):

* the copper layers are those of the layer table (where the copper is); their thicknesses are the stack-up's
  of the same name (35 um for a table layer the stack-up leaves out); a stack-up that lists another number of
  copper layers than the table is noted;
* the thickness is the stack-up's sum; a board that states another thickness (more than 10 % off) is noted;
* a stack-up that repeats KiCad's 2-layer default dielectric (1.51 mm, 1.53 mm without masks: 1.6 mm less two
  35 um coppers and two 10 um masks) on more than one dielectric was never set: it sums to several
  millimetres (4.69 mm on four layers); the board is modelled at the thickness it states, or KiCad's default
  1.6 mm when it states the same sum, and said so;
* a board thicker than :data:`USUAL_MAX_MM` (3.2 mm, the thickest of the usual 0.4-3.2 mm fab offers) is noted.

A total outside 0.1..10 mm, a negative layer or a copper layer outside 5..500 um is refused: no rigid board.
"""

from __future__ import annotations

import math

from imutherm import InputError
from imutherm.ecad.sexpr import child, children
from imutherm.textio import quote

#: copper thickness when the file has no stack-up [um]: 1 oz/ft^2 (35 um), the usual default of board
#: houses and KiCad's own stack-up default
DEFAULT_COPPER_UM = 35.0
#: a stack-up's plausible total [mm]: thinner than 0.1 mm or thicker than 10 mm is not a rigid board
THICKNESS_RANGE_MM = (0.1, 10.0)
#: the stack-up's sum may differ from the stated board thickness by this fraction (mask and rounding)
THICKNESS_TOLERANCE = 0.1
#: thickest usual board [mm]: board houses offer 0.4-3.2 mm as standard (e.g. JLCPCB, PCBWay, Eurocircuits)
USUAL_MAX_MM = 3.2
#: KiCad's default dielectric [mm] of a 2-layer 1.6 mm board (BOARD_STACKUP::BuildDefaultStackupList:
#: 1.6 - 2 x 0.035 copper - 2 x 0.01 mask = 1.51; 1.53 without masks), and KiCad's default board thickness
KICAD_DEFAULT_DIELECTRICS_MM = (1.51, 1.53)
KICAD_DEFAULT_BOARD_MM = 1.6


def _thickness_mm(node, where: str, layer_name: str) -> list:
    """Every ``(thickness v [locked])`` of a stack-up layer (one per sublayer) [mm]."""
    out = []
    for t in children(node, "thickness"):
        v = t[1] if len(t) > 1 else None
        if not (isinstance(v, float) and math.isfinite(v)):
            raise InputError(f"{where}: stack-up layer {quote(layer_name, 40)}: thickness {quote(v, 30)} is not a "
                             f"number [mm]")
        if v < 0:
            raise InputError(f"{where}: stack-up layer {quote(layer_name, 40)} has a negative thickness {v:g} mm")
        out.append(v)
    return out


def read_stackup(tree, where: str, copper_names: list, stated_mm: float | None) -> tuple:
    """(thickness [mm], copper thicknesses [um] per table copper layer, source, notes) of a parsed board.

    copper_names : the layer table's copper layers, front to back: (name in the table, canonical name) pairs
        (a KiCad 5 table names a renamed layer ``C1F``, its stack-up ``F.Cu``)
    stated_mm : the board's ``(general (thickness))`` [mm], or None
    """
    lo, hi = THICKNESS_RANGE_MM
    stack = child(child(tree, "setup") or [], "stackup")
    copper, dielectric, total = {}, [], 0.0
    for layer in children(stack, "layer") if stack is not None else ():
        name = str(layer[1]) if len(layer) > 1 else "?"
        kind = child(layer, "type")
        values = _thickness_mm(layer, where, name)
        total += sum(values)
        if kind and str(kind[1]).lower() == "copper":
            copper[name] = values[0] * 1e3 if values else DEFAULT_COPPER_UM
        elif name.lower().startswith("dielectric"):
            dielectric += values
    notes = []
    if not copper:
        if stated_mm is None:
            raise InputError(f"{where}: the board states no thickness ((general (thickness ...)) and no stack-up)")
        if not lo <= stated_mm <= hi:
            raise InputError(f"{where}: the board's thickness is {stated_mm:g} mm, impossible "
                             f"(valid {lo:g}..{hi:g} mm)")
        if stated_mm > USUAL_MAX_MM:
            notes.append(f"the board states {stated_mm:g} mm, thicker than the usual boards (up to {USUAL_MAX_MM:g} "
                         f"mm): taken as stated")
        n = len(copper_names)
        return (stated_mm, (DEFAULT_COPPER_UM,) * n,
                f"the file's thickness {stated_mm:g} mm and {n} copper layers of {DEFAULT_COPPER_UM:g} um (1 oz, "
                f"assumed: the file has no stack-up)", tuple(notes))
    if not lo <= total <= hi:
        raise InputError(f"{where}: the stack-up's layers sum to {total:.4g} mm, an impossible board thickness "
                         f"(valid {lo:g}..{hi:g} mm); correct the layer thicknesses in KiCad's Board Setup")
    for name, um in copper.items():
        if not 5.0 <= um <= 500.0:
            raise InputError(f"{where}: stack-up copper layer {quote(name, 40)} is {um:g} um thick; valid 5..500 um")
    copper_um = tuple(copper.get(name, copper.get(canon, DEFAULT_COPPER_UM)) for name, canon in copper_names)
    matched = {name if name in copper else canon for name, canon in copper_names}
    if len(copper) != len(copper_names) or matched != set(copper):
        notes.append(f"the stack-up lists {len(copper)} copper layers, the layer table {len(copper_names)} (the "
                     f"layers that carry copper): the table's {len(copper_names)} modelled, each at the stack-up's "
                     f"thickness of that name ({DEFAULT_COPPER_UM:g} um where it has none), in the stack-up's "
                     f"{total:.3f} mm")
    thickness = total
    defaults = [t for t in dielectric if any(abs(t - d) < 5e-4 for d in KICAD_DEFAULT_DIELECTRICS_MM)]
    if len(defaults) >= 2:
        stated_differs = stated_mm is not None and abs(stated_mm - total) > THICKNESS_TOLERANCE * stated_mm
        thickness = stated_mm if stated_differs and lo <= stated_mm <= hi else KICAD_DEFAULT_BOARD_MM
        notes.append(f"the stack-up repeats KiCad's default {defaults[0]:g} mm dielectric (a 2-layer board's) "
                     f"{len(defaults)} times and sums to {total:.3f} mm: a stack-up never set; modelled "
                     + (f"at the {thickness:g} mm the board states" if stated_differs else
                        f"at KiCad's default {KICAD_DEFAULT_BOARD_MM:g} mm")
                     + " (set the dielectrics in KiCad's Board Setup > Physical Stackup)")
    elif stated_mm and abs(total - stated_mm) > THICKNESS_TOLERANCE * stated_mm:
        notes.append(f"the stack-up's layers sum to {total:.3f} mm but the board states {stated_mm:g} mm: the "
                     f"stack-up's {total:.3f} mm modelled")
    if thickness > USUAL_MAX_MM:
        notes.append(f"the board is {thickness:.3f} mm thick, thicker than the usual boards (up to {USUAL_MAX_MM:g} "
                     f"mm): taken as the stack-up says")
    source = f"the file's stack-up: {len(copper_names)} copper layers, {thickness:.3f} mm"
    if thickness != total:
        source += f" (its layers sum to {total:.3f} mm)"
    return thickness, copper_um, source, tuple(notes)
