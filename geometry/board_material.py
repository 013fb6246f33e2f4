"""A multilayer board's effective orthotropic properties from its stack-up: the rule of mixtures.

A board of thickness t with copper layers of thicknesses t_i, layer i covering a fraction c_i of the board
(one ``coverage`` for all, or each layer's as measured from the board file), holds a copper volume fraction
f = sum(c_i t_i) / t. Heat along the board runs through the
copper and the laminate side by side (parallel), across it through them in turn (series)::

    k_in_plane = f k_Cu + (1 - f) k_FR4          k_through = 1 / (f / k_Cu + (1 - f) / k_FR4)

the first-order rule of electronics-cooling texts (Lemczyk, Mack, Culham & Yovanovich, "PCB trace thermal
analysis and effective conductivity", J. Electronic Packaging 114 (1992) 413; within the 10-40 / 0.3-0.7 W/m K
measured by Azar & Graebner, IEEE SEMI-THERM 1996). It gives the library's ``pcb_fr4_4layer`` (four 35 um
layers in 1.6 mm at 50 % coverage: 17.7 / 0.31 W/m K). Density and specific heat mix by volume and by mass.
The copper of small parts merged into the board (their pads) is within the coverage assumed; their mass is
added to the board's mass and heat capacity (``merged_mass_kg``, ``merged_heat_capacity_J_K``).
"""

from __future__ import annotations

import math

from imutherm import InputError
from imutherm.geometry.materials import Material

#: FR-4 laminate: k 0.3 W/m K (through-thickness, the laminate's own: Azar & Graebner 1996 measured 0.29-0.34),
#: rho 1850 kg/m^3, c 1100 J/kg K (typical glass-epoxy laminate, e.g. Isola FR406 / IPC-4101 class data)
FR4 = {"k": 0.3, "density": 1850.0, "specific_heat": 1100.0}
#: copper: k 398 W/m K, rho 8933 kg/m^3, c 385 J/kg K (Incropera & DeWitt, 6th ed., Table A.1, pure copper 300 K)
COPPER = {"k": 398.0, "density": 8933.0, "specific_heat": 385.0}
#: copper coverage of each layer [-] when the design's is not measured: 50 %, the library board's assumption
#: (signal layers 20-40 %, planes 80-95 %; a 4-layer board with two planes averages about half)
DEFAULT_COVERAGE = 0.5
#: solder-mask emissivity [-] (assumed, as the library board: green mask ~0.9)
MASK_EMISSIVITY = 0.9


def board_material(name: str, thickness_mm: float, copper_um, *, coverage: float = DEFAULT_COVERAGE,
                   merged_mass_kg: float = 0.0, merged_heat_capacity_J_K: float = 0.0,
                   area_mm2: float | None = None, note: str = "") -> Material:
    """The effective material of a board (see the module docstring).

    Parameters
    ----------
    name : str, the material's name
    thickness_mm : float [mm], the board thickness
    copper_um : sequence of float [um], each copper layer's thickness
    coverage : float [-], the copper coverage of every layer, or a sequence of each layer's [-] (measured)
    merged_mass_kg, merged_heat_capacity_J_K : float [kg], [J/K], of the parts merged into the board
    area_mm2 : float [mm^2], the board's area (needed with merged parts)
    note : str, appended to the source (what was merged)
    """
    copper = [float(t) for t in copper_um]
    measured = not isinstance(coverage, (int, float))
    cover = [float(c) for c in coverage] if measured else [float(coverage)] * len(copper)
    if (not copper or not thickness_mm > 0 or len(cover) != len(copper)
            or not all(0 <= c <= 1 for c in cover) or not sum(cover) > 0):
        raise InputError(f"board material {name!r}: needs a thickness > 0, copper layers and a coverage of each "
                         f"(0..1, not all 0)")
    f = sum(c * t for c, t in zip(cover, copper)) * 1e-3 / thickness_mm
    if not 0 < f < 1:
        raise InputError(f"board material {name!r}: {len(copper)} copper layers of {sum(copper):g} um in all do not "
                         f"fit a {thickness_mm:g} mm board")
    k_in = f * COPPER["k"] + (1 - f) * FR4["k"]
    k_th = 1.0 / (f / COPPER["k"] + (1 - f) / FR4["k"])
    mass_cu, mass_fr4 = f * COPPER["density"], (1 - f) * FR4["density"]
    rho = mass_cu + mass_fr4
    c = (mass_cu * COPPER["specific_heat"] + mass_fr4 * FR4["specific_heat"]) / rho
    source = (f"{len(copper)} copper layers ({', '.join(f'{t:g}' for t in copper)} um) in a {thickness_mm:g} mm FR-4 "
              f"board at {_coverage_text(cover, measured)}: copper volume fraction {f:.4f}; rule of mixtures "
              f"(in-plane parallel, "
              f"through series; Lemczyk et al. 1992) with FR-4 k 0.3, rho 1850, c 1100 and Cu k 398, rho 8933, c 385; "
              f"solder-mask emissivity 0.9 (assumed)")
    if merged_mass_kg or merged_heat_capacity_J_K:
        if not area_mm2 or area_mm2 <= 0:
            raise InputError(f"board material {name!r}: merged parts need the board area")
        volume = area_mm2 * thickness_mm * 1e-9
        rho_c = rho * c + merged_heat_capacity_J_K / volume
        rho += merged_mass_kg / volume
        c = rho_c / rho
        source += (f"; merged parts' mass {merged_mass_kg * 1e3:.3g} g and heat capacity "
                   f"{merged_heat_capacity_J_K:.3g} J/K smeared over the board")
    if note:
        source += f"; {note}"
    return Material(name, round(k_in, 4), round(k_th, 4), round(rho, 2), round(c, 2), MASK_EMISSIVITY, source)


def _coverage_text(cover: list, measured: bool) -> str:
    if not measured:
        return f"{cover[0]:.0%} coverage"
    return f"measured coverage {', '.join(f'{c:.1%}' for c in cover)} (front to back)"


#: hole-wall copper of a plated via [um]: 25 um, IPC-6012 class 3's least average (class 1-2: 20 um), the figure
#: TI's PowerPAD note SLMA002 and the library's ``pcb_via_field`` take (recalled, not checked against the text)
PLATING_UM = 25.0


def via_field_material(name: str, board: Material, drills_mm, area_mm2: float,
                       plating_um: float = PLATING_UM) -> Material:
    """The board under an exposed pad with vias: the board's material with the vias' copper barrels in parallel
    through it.

    Each via of finished hole d (KiCad's drill) has a plated barrel of wall t outside it, a copper ring of area
    a = pi t (d + t); N vias in a pad of area A are a copper area fraction phi = sum(a) / A, and (unfilled
    barrels, air inside; the barrels run straight through the board)::

        k_through = phi k_Cu + (1 - phi) k_board_through        k_in_plane = k_board_in_plane

    with rho and c mixed by volume and mass as :func:`board_material` does. Lengths [mm], t [um]."""
    drills = [float(d) for d in drills_mm]
    if not drills or not area_mm2 > 0 or not all(d > 0 for d in drills) or not plating_um > 0:
        raise InputError(f"via field {name!r}: needs vias of drill > 0, a pad area > 0 and a plating > 0")
    t = plating_um * 1e-3
    phi = sum(math.pi * t * (d + t) for d in drills) / area_mm2
    if not 0 < phi < 1:
        raise InputError(f"via field {name!r}: {len(drills)} vias' barrels ({phi:.0%}) do not fit a "
                         f"{area_mm2:g} mm^2 pad")
    k_th = phi * COPPER["k"] + (1 - phi) * board.k_through
    mass_cu, mass_b = phi * COPPER["density"], (1 - phi) * board.density
    rho = mass_cu + mass_b
    c = (mass_cu * COPPER["specific_heat"] + mass_b * board.specific_heat) / rho
    sizes = sorted(set(round(d, 3) for d in drills))
    source = (f"{len(drills)} vias of {', '.join(f'{d:g}' for d in sizes)} mm drill under a {area_mm2:.3g} mm^2 pad, "
              f"{plating_um:g} um barrels (IPC-6012 class 3 average, recalled): copper area fraction {phi:.4f} = "
              f"sum(pi t (d + t)) / A; through-plane parallel {phi:.4f} x 398 + {1 - phi:.4f} x "
              f"{board.k_through:g} W/m K; in-plane, rho, c: the board's ({board.name}) with the barrels' copper")
    return Material(name, board.k_in_plane, round(k_th, 4), round(rho, 2), round(c, 2), board.emissivity, source)
