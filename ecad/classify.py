"""What becomes of each footprint of an imported board: modelled, merged into the board, or skipped.

Rules, in order (each decision carries its reason, printed by ``imutherm import``):

* **skipped**: not on the board modelled (outside its outline, on another board or the frame of a panel:
  :mod:`imutherm.ecad.panel`); marked do-not-populate (KiCad's ``dnp`` attribute, a ``DNP`` field, or a
  value such as ``DNP``, ``DNF``, ``DNI``, ``NP``, ``NF``, ``no-pop``, ``do not fit``); a mounting hole (a standoff goes
  under it), by its name or by what it is: a hole of :data:`MOUNTING_MIN_DRILL_MM` or more and no body; bare
  holes (tooling holes, mouse bites of a panel); a fiducial; a test point; a net tie or solder jumper (copper
  only); a footprint without pads (a logo, silkscreen-only art, a panel tab); a footprint of one pad and no
  body outline (a wire or test pad); a KiCad 5 ``virtual`` footprint without pads.
* **modelled**: a part that dissipates power, carries a sensor site, is named by the electrical design, or
  that the user keeps (``--keep``); and every part larger than the merge limits.
* **merged**: the rest: an unpowered part whose body is at most :data:`MERGE_AREA_MM2` and
  :data:`MERGE_HEIGHT_MM` (passives, small discretes). Its mass and heat capacity are smeared into the board
  material (:mod:`imutherm.geometry.board_material`); its pads' copper is within the board's assumed coverage.

The body is the footprint's fab-layer outline (the package's own drawing; a fab drawing of less than a quarter
of the pads' extent is only a marker); without one, the courtyard less the
IPC-7351 nominal courtyard excess (0.25 mm a side) but at least the pads; without either, the pads. A
package class with ``body = "fab+pads"`` (SOT-223, DPAK: the tab carries the die) takes the outline and the
pads together. A footprint rotated by a multiple of 90 degrees keeps its body exactly; at any other angle the
model's axis-aligned box keeps the body's area and aspect, turned to the nearest multiple of 90 degrees (the
true rotated outline is kept in the drawing's labels, the area in the model).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from imutherm import InputError
from imutherm.ecad.board import BoardDesign, Footprint, Rect
from imutherm.ecad.heights import resolve_height
from imutherm.ecad.packages import PackageClass, package_class
from imutherm.ecad.power_fields import power_from_fields

#: largest body area [mm^2] of an unpowered part merged into the board: a 1210 chip is 8 mm^2, a SOT-23
#: 4.4 mm^2, an 8-pin SOIC 24 mm^2 (modelled); parts this small sit below the mesh's 2 mm cells anyway
MERGE_AREA_MM2 = 10.0
#: tallest unpowered part [mm] merged into the board (a 1210 MLCC is 2.7 mm at most)
MERGE_HEIGHT_MM = 3.0
#: smallest hole [mm] of a mounting hole: an M2 screw's close fit is 2.2 mm (ISO 273), KiCad's smallest
#: MountingHole footprint 2.1 mm; a single wire pad drills less (a 14 AWG wire is 1.63 mm across)
MOUNTING_MIN_DRILL_MM = 2.0
#: a fab drawing smaller than this share of its pads' extent is a marker (a pin-1 dot), not the body outline
FAB_MIN_COVER = 0.25
#: IPC-7351B nominal courtyard excess [mm] a side, removed from a courtyard to estimate a body without fab outline
COURTYARD_EXCESS_MM = 0.25
#: height [mm] assumed for a merged part of no known class: it only sets the mass smeared into the board
MERGED_UNKNOWN_HEIGHT_MM = 1.0
#: densities [kg/m^3] and specific heats [J/kg K] of merged bodies by kind, for the smeared heat capacity:
#: ceramic chips as alumina (Incropera Table A.2: 3970, 765), plastic packages as mould compound
#: (epoxy + silica filler: 1900, 880, the library's ``mould_compound``)
_CHIP = (3970.0, 765.0)
_PLASTIC = (1900.0, 880.0)

#: values and fields that mark a part not fitted: do not populate / fit / install / mount / place, not
#: populated / fitted, no-pop (whole words, any case, ``_``, ``-`` or a space between the words)
_DNP = re.compile(r"(?<![A-Za-z0-9])(DNP|DNF|DNI|DNM|DNS|NOPOP|NO[ _-]?POP(ULATE)?|NO[ _-]?FIT|NOT[ _-]?(FITTED|"
                  r"POPULATED|MOUNTED|PLACED|INSTALLED)|DO[ _-]?NOT[ _-]?(POPULATE|FIT|INSTALL|MOUNT|PLACE|STUFF)|"
                  r"UNPOPULATED|UNFITTED)(?![A-Za-z0-9])", re.I)
#: a whole value that marks a part not fitted
_DNP_VALUES = {"np", "nf", "n/p", "n/f", "nofit", "-"}
#: fields whose "no" / "false" / "0" marks a part not fitted
_FITTED_FIELDS = {"populate", "populated", "fitted", "fit", "mount", "mounted", "place", "stuff", "assemble"}

_SKIP = (
    (re.compile(r"MountingHole", re.I), "mounting hole (a standoff is placed under it)"),
    (re.compile(r"Fiducial", re.I), "fiducial mark (copper only)"),
    (re.compile(r"TestPoint", re.I), "test point (a bare pad)"),
    (re.compile(r"NetTie|SolderJumper|Jumper:SolderJ", re.I), "net tie / solder jumper (copper only)"),
    (re.compile(r"(^|:)(Logo|Symbol)|OSHW|KiCad-Logo", re.I), "logo or symbol (silkscreen only)"),
)


@dataclass(frozen=True)
class Decision:
    """The fate of one footprint.

    fate : ``modelled``, ``merged`` or ``skipped``
    reason : str, why (one phrase)
    package : PackageClass or None
    body : Rect or None, the body in board coordinates [mm] (axis-aligned; see the module docstring)
    height_mm : float or None [mm], and height_source : str
    power_W : float [W], and power_source : str
    note : str, what was left out of the footprint's fields (a power rating, a field that holds no number)
    """

    footprint: Footprint
    fate: str
    reason: str
    package: PackageClass | None = None
    body: Rect | None = None
    height_mm: float | None = None
    height_source: str = ""
    power_W: float = 0.0
    power_source: str = ""
    note: str = ""


def not_fitted(fp: Footprint) -> str | None:
    """Why ``fp`` is marked do-not-populate, or None (see the module docstring)."""
    if "dnp" in fp.attributes:
        return "marked do-not-populate (the file's DNP attribute)"
    if _DNP.search(fp.value) or fp.value.strip().lower() in _DNP_VALUES:
        return f"marked do-not-populate (value {fp.value!r})"
    for name, text in fp.fields.items():
        key, value = name.strip().lower(), str(text).strip().lower()
        if (key in ("dnp", "dnf", "dni") and value in ("1", "yes", "true", "y", "x", "dnp", "dnf", "dni")) or \
                (key in _FITTED_FIELDS and value in ("no", "false", "0", "n")) or (_DNP.fullmatch(str(text).strip())
                                                                                 and key not in ("reference",)):
            return f"marked do-not-populate (field {name} = {str(text)!r})"
    return None


def hole_only(fp: Footprint) -> str | None:
    """Why ``fp`` is a hole and no part (a mounting hole, tooling holes, mouse bites), or None: it has no body
    outline, a hole, and copper (if any) of one pad name only: a plated ring, its vias, its other side."""
    holes = [p.drill_mm for p in fp.pads if p.drill_mm]
    if fp.fab is not None or not holes or fp.height_mm is not None or len({p.name for p in fp.copper_pads}) > 1:
        return None
    if max(holes) >= MOUNTING_MIN_DRILL_MM:
        return (f"mounting hole (a {max(holes):g} mm hole without a body: a standoff is placed under it)")
    if not fp.copper_pads:
        return f"bare hole{'s' if len(holes) > 1 else ''} ({max(holes):g} mm: a tooling hole or mouse bites), no part"
    return None


def skip_reason(fp: Footprint) -> str | None:
    """Why ``fp`` is not a physical part to model, or None."""
    if fp.off_board:
        return fp.off_board
    dnp = not_fitted(fp)
    if dnp:
        return dnp
    if "unplaced" in fp.attributes:
        return "unplaced in the IDF file"
    for pattern, reason in _SKIP:
        if pattern.search(fp.library):
            return reason
    hole = hole_only(fp)
    if hole:
        return hole
    if not fp.pads and fp.fab is None:
        return "no pads: a logo, silkscreen-only art or a panel tab" if "virtual" not in fp.attributes else \
            "KiCad 5 virtual footprint without pads (no physical part)"
    if len({p.name for p in fp.copper_pads}) == 1 and fp.fab is None and fp.height_mm is None:
        return "one pad and no body outline: a wire or test pad"
    return None


def body_local(fp: Footprint, package: PackageClass | None) -> Rect:
    """The body outline in the footprint frame [mm] (see the module docstring)."""
    pads = Rect.around(p for pad in fp.copper_pads for p in ((pad.rect.x0, pad.rect.y0), (pad.rect.x1, pad.rect.y1)))
    if fp.fab is not None and (pads is None or fp.fab.area >= FAB_MIN_COVER * pads.area):
        body = fp.fab
        if package is not None and package.body == "fab+pads" and pads is not None:
            body = Rect(min(body.x0, pads.x0), min(body.y0, pads.y0), max(body.x1, pads.x1), max(body.y1, pads.y1))
        return body
    if fp.courtyard is not None and fp.courtyard.width > 2 * COURTYARD_EXCESS_MM:
        e = COURTYARD_EXCESS_MM
        c = Rect(fp.courtyard.x0 + e, fp.courtyard.y0 + e, fp.courtyard.x1 - e, fp.courtyard.y1 - e)
        if pads is None:
            return c
        return Rect(min(c.x0, pads.x0), min(c.y0, pads.y0), max(c.x1, pads.x1), max(c.y1, pads.y1))
    if pads is not None and pads.area > 0:
        return pads
    raise InputError(f"footprint {fp.ref} ({fp.library}) has no fab outline, courtyard or pads to give its body")


def body_on_board(fp: Footprint, local: Rect) -> Rect:
    """The body's axis-aligned box in board coordinates [mm] (exact at multiples of 90 degrees)."""
    cx, cy = fp.to_board(*local.centre)
    quarter = round(fp.rotation_deg / 90.0)
    w, h = (local.width, local.height) if quarter % 2 == 0 else (local.height, local.width)
    return Rect(cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2)


def off_axis(fp: Footprint) -> bool:
    """True if the footprint is rotated by other than a multiple of 90 degrees."""
    r = fp.rotation_deg % 90.0
    return min(r, 90.0 - r) > 1e-6


def merged_heat(decision: Decision) -> tuple:
    """(mass [kg], heat capacity [J/K]) of a merged part's body."""
    b = decision.body
    h = decision.height_mm or MERGED_UNKNOWN_HEIGHT_MM
    rho, c = _CHIP if decision.package is not None and decision.package.material == "alumina" else _PLASTIC
    mass = b.area * h * 1e-9 * rho
    return mass, mass * c


def decide(board: BoardDesign, *, powers: dict, heights: dict, keep: set, merge_area_mm2: float = MERGE_AREA_MM2,
           merge_height_mm: float = MERGE_HEIGHT_MM) -> list:
    """A :class:`Decision` per footprint of ``board``.

    powers : ref -> (power [W], source); heights : ref -> (height [mm], source) from the user (they win over
    the file's fields); keep : refs the user or the electrical design wants modelled whatever their size.
    """
    out = []
    for fp in board.footprints:
        reason = skip_reason(fp)
        if fp.off_board or (reason is not None and fp.ref not in powers and fp.ref not in keep):
            out.append(Decision(fp, "skipped", reason))
            continue
        package = package_class(fp.library)
        body = body_on_board(fp, body_local(fp, package))
        height, h_source = resolve_height(fp, package, heights, body)
        power, p_source, note = _power(fp, powers)
        if power > 0 or fp.ref in keep:
            why = f"dissipates {power:g} W" if power > 0 else "kept (a site, a rail of the electrical design, or --keep)"
            out.append(Decision(fp, "modelled", why, package, body, height, h_source, power, p_source, note))
        elif body.area <= merge_area_mm2 and (height or 0.0) <= merge_height_mm:
            out.append(Decision(fp, "merged", f"unpowered, body {body.width:.2g} x {body.height:.2g} mm "
                                f"<= {merge_area_mm2:g} mm^2", package, body, height, h_source, 0.0, "", note))
        else:
            out.append(Decision(fp, "modelled", f"unpowered but {body.width:.2g} x {body.height:.2g} x "
                                f"{height if height is not None else '?'} mm, larger than the merge limit",
                                package, body, height, h_source, 0.0, "", note))
    return out


def _power(fp: Footprint, powers: dict) -> tuple:
    """(power [W], source, note): --powers / --power, then a dissipation field (:mod:`imutherm.ecad.power_fields`;
    never a rating), else 0."""
    value, source, note = power_from_fields(fp.ref, fp.fields)
    if fp.ref in powers:
        return (*powers[fp.ref], note)
    return (value or 0.0), source, note
