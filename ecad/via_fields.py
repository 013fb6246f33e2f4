"""The via field under an exposed pad from the board file's own vias: their count and drills, their material.

A part with an exposed pad and :data:`~imutherm.ecad.part_bodies.MIN_VIAS` or more vias inside it (the board's
vias and the footprint's own plated holes, as KiCad's ``ThermalVias`` footprints draw them) gets a via field:
the board under the pad, through its thickness, of a material made from those vias
(:func:`imutherm.geometry.board_material.via_field_material`: their copper barrels in parallel with the board),
instead of the library's ``pcb_via_field`` (an assumed 0.3 mm at 1.2 mm pitch).
"""

from __future__ import annotations

import hashlib
import re

from imutherm.ecad.board import BoardDesign, Rect
from imutherm.ecad.classify import Decision
from imutherm.ecad.part_bodies import exposed_pad
from imutherm.ecad.toml_writer import NOTE
from imutherm.geometry.board_material import via_field_material
from imutherm.geometry.materials import Material


def drills_under(board: BoardDesign, d: Decision, pad_rect: Rect) -> list:
    """The drill diameters [mm] of the vias whose centres lie in ``pad_rect`` (board coordinates): the board's
    vias and the part's own plated through-holes."""
    def within(x, y):
        return pad_rect.x0 <= x <= pad_rect.x1 and pad_rect.y0 <= y <= pad_rect.y1

    out = [v.drill_mm for v in board.vias if within(v.x, v.y)]
    fp = d.footprint
    for p in fp.pads:
        if p.kind == "thru_hole" and p.drill_mm and within(*fp.to_board(*p.rect.centre)):
            out.append(p.drill_mm)
    return out


def via_field_entry(board: BoardDesign, d: Decision, pad_mm: tuple, board_material: tuple, name: str) -> tuple:
    """(material name, ``[materials]`` table) of the via field under part ``d``'s exposed pad of (u, v) size
    ``pad_mm`` [mm] on a board of material ``board_material`` (its name and layout table)."""
    board_name, board_table = board_material
    _, pad_rect = exposed_pad(d)
    drills = drills_under(board, d, pad_rect)
    base = Material(board_name, board_table["k_in_plane"], board_table["k_through"], board_table["density"],
                    board_table["specific_heat"], board_table.get("emissivity"), board_table.get("source", ""))
    m = via_field_material("vias", base, drills, pad_mm[0] * pad_mm[1])
    digest = hashlib.sha1(repr((m.k_in_plane, m.k_through, m.density, m.specific_heat)).encode()).hexdigest()[:6]
    mat = f"vias_{re.sub(r'[^A-Za-z0-9_]', '_', name)}_{digest}"
    table = {NOTE: f"via field under {d.footprint.ref}'s exposed pad: {m.source}", "k_in_plane": m.k_in_plane,
             "k_through": m.k_through, "density": m.density, "specific_heat": m.specific_heat,
             "emissivity": m.emissivity, "source": m.source}
    return mat, table
