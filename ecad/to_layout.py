"""An imported board as a layout: the same TOML a hand-written unit has, around one board or into a unit.

:func:`import_board` takes a :class:`~imutherm.ecad.board.BoardDesign` and the user's powers, heights and
sites, decides each footprint's fate (:mod:`imutherm.ecad.classify`) and writes a complete single-board
unit: the board (its bounding rectangle; the true outline kept for drawings; its conductivity from the
stack-up, :mod:`imutherm.geometry.board_material`), every modelled part as a component (body, die, exposed
pad and via field), standoffs under the mounting holes, a housing around it with stated clearances, the
three cooling schemes, and the sensor sites. :func:`replace_board` puts the imported board in place of one
board of an existing layout instead. Both check the result as any layout is checked (``parse_layout`` and
every scheme's ``build_geometry``) before anything is written.

The unit around a single board (every number overridable, :class:`HousingOptions`): the housing and its
mounting are the reference unit's (2.5 mm anodised aluminium walls, 3 mm base, 2.5 mm lid, the base bolted to
a fixture at the ambient through 500 W/m^2 K; ``layouts/imu_reference.toml`` gives the sources); 1 mm
clearance from the board's edges to the walls and above the tallest part to the lid; the board on standoffs
(nylon, as the reference unit's) under its mounting holes (or at its corners when it has none), as tall as
the tallest bottom-side part plus 1 mm, 2 mm at least.
"""

from __future__ import annotations

import hashlib
import re
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from imutherm import InputError
from imutherm.ecad.board import BoardDesign, Rect
from imutherm.ecad.classify import MERGED_UNKNOWN_HEIGHT_MM, Decision, decide, merged_heat, off_axis
from imutherm.ecad.grease_parts import dissipators, grease_parts
from imutherm.ecad.heights import estimated_parts, is_estimated, strict_refusal
from imutherm.ecad.kicad_copper import with_coverage
from imutherm.ecad.panel import pick_board, unique_references
from imutherm.ecad.part_bodies import (DIE_FRACTION, MIN_VIAS, SNAP_MM, die_and_pad, overlaps, round_centre, round_mm,
                                      round_size, snap_soft_parts)
from imutherm.ecad.placement import place_parts
from imutherm.ecad.standoffs import standoff_rects, standoff_parts
from imutherm.ecad.toml_writer import NOTE, Inline, Note, dumps
from imutherm.ecad.via_fields import via_field_entry
from imutherm.geometry.board_material import DEFAULT_COVERAGE, board_material
from imutherm.geometry.layout import parse_layout
from imutherm.geometry.materials import get_material
from imutherm.geometry.outline import board_loops, outline_area
from imutherm.site_table import ACCEL_SITES, GYRO_SITES, SITES

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

#: what ``--site REF=KIND`` accepts: the sensor sites it gives (a probe is a plain temperature output)
SITE_KINDS = {"imu": SITES, "gyro": GYRO_SITES, "accel": ACCEL_SITES, **{s: (s,) for s in SITES}, "probe": ()}
#: bond gap limit of the grease scheme [mm], as the reference unit's (the paper's "millimetre-order gap")
MAX_BOND_GAP_MM = 2.0
#: least power [W] of a chip that gets a die of its own (sites and regulators always do): below it the power is
#: spread through the package; a 10 mW die 100 K/W above its board is 1 K warmer, less than the mesh resolves
DIE_MIN_W = 0.01


@dataclass(frozen=True)
class HousingOptions:
    """The unit around a single imported board (see the module docstring); lengths [mm]."""

    clearance_mm: float = 1.0
    wall_mm: float = 2.5
    base_mm: float = 3.0
    lid_mm: float = 2.5
    min_standoff_mm: float = 2.0
    material: str = "aluminium_6061_anodised"
    standoff_material: str = "nylon_66"
    mounting: str = "fixture"
    mounting_face: str = "bottom"
    contact_conductance_W_m2K: float = 500.0
    ambient_C: float = 70.0


@dataclass(frozen=True)
class ImportOptions:
    """What the user adds to the board file.

    powers : ref -> power [W] (``--powers FILE``, ``--power REF=W``); heights : ref -> height [mm]
    sites : ref -> kind (:data:`SITE_KINDS`); keep : refs modelled whatever their size
    grades : "*" or ref -> sensor grade (``--grade``); grade_rule : the chip -> grade rule (the CLI passes
    :func:`imutherm.imu.site_grades.site_grades`; None: the sites name no grade)
    electrical : dict or None, an ``[electrical]`` table and its ``[[rails]]`` (``--electrical FILE``)
    grease : tuple of refs or None, the parts the grease scheme bonds to the base, top-side ones moved to the back
        (None: ``grease_rule``'s choice, or without one :func:`imutherm.ecad.grease_parts.dissipators`)
    grease_rule : callable (air-only LayoutSpec, names, sites) -> ({ref: why}, notes) or None; ``imutherm import``
        passes :func:`imutherm.unit.grease_choice.choose`: the parts that set the hot spot and the sensor temperatures
    grease_why : ref -> why the rule chose it (set by :func:`import_board`)
    board_name, layout_name : str; prefix : str, put before every component name (``--into``)
    exact : bool, keep every part's exact outline (no snapping of the parts without a die)
    strict_heights : bool, refuse a part whose height is only estimated (:mod:`imutherm.ecad.heights`)
    """

    powers: dict = field(default_factory=dict)
    powers_source: str = "--powers"
    heights: dict = field(default_factory=dict)
    heights_source: str = "--height"
    sites: dict = field(default_factory=dict)
    grades: dict = field(default_factory=dict)  # --grade: "*" or ref -> sensor grade (imutherm.imu.site_grades)
    #: the sensor-grade rule, (sites, footprints, grades) -> (ref -> grade, lines): the import's is
    #: imutherm.imu.site_grades.site_grades (a chip's grade from its value or footprint), passed in by the
    #: caller because the ecad layer imports nothing of imu; None: the sites name no grade (the study's default)
    grade_rule: Callable | None = None
    keep: frozenset = frozenset()
    electrical: dict | None = None
    electrical_source: str = ""
    grease: tuple | None = None
    grease_rule: object = None
    grease_why: dict = field(default_factory=dict)
    board_name: str = "main"
    layout_name: str | None = None
    prefix: str = ""
    housing: HousingOptions = HousingOptions()
    merge_area_mm2: float | None = None
    exact: bool = False
    strict_heights: bool = False


@dataclass(frozen=True)
class ImportResult:
    """An import: the layout text and its checked spec, each footprint's fate, and notes for the user.

    decisions : tuple of Decision, one per footprint; notes : tuple of str (what was assumed or left out)
    names : dict, footprint ref -> component name in the layout
    """

    board: BoardDesign
    decisions: tuple
    text: str
    spec: object
    notes: tuple
    names: dict

    def count(self, fate: str) -> int:
        return sum(d.fate == fate for d in self.decisions)


def component_name(ref: str, prefix: str = "") -> str:
    """A layout name for reference designator ``ref``: letters, digits, ``_`` and ``-`` kept, others ``_``."""
    return prefix + (re.sub(r"[^A-Za-z0-9_-]", "_", ref) or "part")


def _check_refs(board: BoardDesign, opts: ImportOptions) -> None:
    on_board = [fp.ref for fp in board.footprints if not fp.off_board]
    named = set(opts.sites) | set(opts.powers) | set(opts.heights) | set(opts.keep) | set(opts.grease or ())
    dup = sorted({ref for ref in named if on_board.count(ref) > 1}, key=natural_order)
    if dup:
        where = "; ".join(f"({fp.x:.2f}, {fp.y:.2f}) mm" for fp in board.footprints
                          if fp.ref == dup[0] and not fp.off_board)
        raise InputError(f"{board.source}: {dup[0]} is a duplicate reference: {on_board.count(dup[0])} footprints "
                         f"carry it (at {where}); give each part a unique reference in KiCad (Annotate) before "
                         f"naming it in --site / --power / --height / --keep / --grease")
    refs = {fp.ref for fp in board.footprints}
    for what, given in (("--site", opts.sites), ("--power/--powers", opts.powers), ("--height/--heights", opts.heights),
                        ("--keep", opts.keep), ("--grease", opts.grease or ())):
        unknown = sorted(set(given) - refs)
        if unknown:
            listed = ", ".join(sorted(refs, key=natural_order)[:40])
            raise InputError(f"{board.source}: {what}: no footprint {', '.join(unknown[:5])} on the board; its "
                             f"references: {listed}{' ...' if len(refs) > 40 else ''}")
        elsewhere = sorted(ref for ref in given if ref not in on_board)
        if elsewhere and what == "--site":
            fp = next(fp for fp in board.footprints if fp.ref == elsewhere[0])
            raise InputError(f"{board.source}: {what} {elsewhere[0]}: not on the board modelled ({fp.off_board}); a "
                             f"layout models one board: import each with --site on one of its parts")
    for ref, kind in opts.sites.items():
        if kind not in SITE_KINDS:
            raise InputError(f"--site {ref}={kind}: unknown kind; valid: {', '.join(SITE_KINDS)}")


def natural_order(ref: str):
    """A sort key putting references in their natural order (``R2`` before ``R10``)."""
    return [int(t) if t.isdigit() else t for t in re.split(r"(\d+)", ref)]


def _electrical_refs(electrical: dict | None) -> set:
    if not electrical:
        return set()
    refs = set()
    for rail in electrical.get("rails", []) or []:
        if isinstance(rail, dict):
            if isinstance(rail.get("regulator"), str):
                refs.add(rail["regulator"])
            if isinstance(rail.get("loads_A"), dict):
                refs |= set(rail["loads_A"])
    return refs


def likely_dissipators(board: BoardDesign, limit: int = 6) -> str:
    """The parts a user most likely has to give powers for: ICs and power packages, largest first."""
    icish = [fp for fp in board.footprints if re.match(r"(U|IC|VR|Q)\d", fp.ref, re.I)
             or re.search(r"SOT-223|TO-252|TO-263|LDO|regulat", f"{fp.library} {fp.value}", re.I)]
    icish.sort(key=lambda fp: -(fp.fab.area if fp.fab else 0.0))
    return "; ".join(f"{fp.ref} {fp.value or '?'} ({fp.library.split(':')[-1]})" for fp in icish[:limit]) or "none found"


def _no_power(board: BoardDesign, decisions: list) -> InputError:
    lost = [d for d in decisions if d.power_W > 0 and d.fate != "modelled"]
    if lost:
        d = lost[0]
        return InputError(f"{board.source}: no power on the board modelled: {d.footprint.ref} ({d.power_W:g} W) is "
                          f"{d.fate}: {d.reason}"
                          + (f" (and {len(lost) - 1} more powered parts)" if len(lost) > 1 else ""))
    return InputError(f"{board.source}: no power anywhere on the board (no dissipation field such as Power_W, no "
                      f"--powers or --electrical): give the dissipated powers, e.g. --power REF=W; likely dissipators: "
                      f"{likely_dissipators(board)}")


def _component(board: BoardDesign, d: Decision, name: str, board_name: str, body: Rect, die: bool,
               power_from_rails: bool, snapped: str = "", materials: dict | None = None) -> dict:
    """The ``[[components]]`` table of one modelled part (with its provenance as the comment above it); a via
    field's material is added to ``materials`` (the layout's, holding the board's as ``materials["board"]``)."""
    fp = d.footprint
    h = d.height_mm
    entry = {NOTE: (f"{fp.ref} {fp.value} ({fp.library}) at ({fp.x:.3f}, {fp.y:.3f}) mm, {fp.rotation_deg:g} deg, "
                    f"{fp.side}; {d.reason}\nheight {h:g} mm"
                    + (" ESTIMATED (no height found)" if is_estimated(d.height_source) else "") + f": {d.height_source}"
                    + (f"\n{snapped}" if snapped else "")),
             "name": name, "board": board_name, "side": fp.side,
             "center_mm": [round_centre(body.centre[0]), round_centre(body.centre[1])],
             "size_mm": Note([round_size(body.width), round_size(body.height), round_mm(h)],
                             "body from the " + ("fab outline" if fp.fab is not None else "courtyard / pads")
                             + (" and pads" if d.package is not None and d.package.body == "fab+pads" else "")
                             + (f"; rotated {fp.rotation_deg:g} deg: the same area, aligned to the nearest axis"
                                if off_axis(fp) else "") + ("; edges snapped (see above)" if snapped else "")),
             "material": d.package.material if d.package is not None else "mould_compound",
             "footprint": fp.library, "height_source": d.height_source}
    if die:
        (du, dv, dt), db, pad, vias = die_and_pad(board, d, body)
        if pad is not None:
            entry["exposed_pad"] = Note(True, f"largest pad {pad[0]:.3g} x {pad[1]:.3g} mm under the body")
            entry["pad_mm"] = [round_mm(pad[0]), round_mm(pad[1])]
            if vias >= MIN_VIAS:
                entry["vias"] = Note(True, f"{vias} vias inside the exposed pad")
                if materials is not None:   # the field's material from the file's vias (ecad/via_fields.py)
                    mat, table = via_field_entry(board, d, entry["pad_mm"], materials["board"], name)
                    entry["vias_material"], materials[mat] = mat, table
        entry["die_mm"] = Note([round_mm(du), round_mm(dv), round_mm(dt)], f"assumed: {DIE_FRACTION:g} of the body, as the reference "
                                                          f"unit's dies")
        entry["die_base_mm"] = round_mm(db)
    if not power_from_rails:
        entry["power_W"] = Note(float(d.power_W), d.power_source or "unpowered")
    return entry


def _has_die(d: Decision, site_refs: set, regulators: set) -> bool:
    """A die for a chip dissipating at least :data:`DIE_MIN_W` (its power in the die, not spread through the
    package), a sensor site or a regulator; a passive, inductor or connector, or a chip of less power,
    dissipates through its whole body."""
    ref = d.footprint.ref
    chip = d.package.kind in ("ic", "discrete") if d.package is not None else bool(re.match(r"(U|IC|Q)\d", ref, re.I))
    return ref in site_refs or ref in regulators or (d.power_W >= DIE_MIN_W and chip)


def _sites(opts: ImportOptions, names: dict, board: BoardDesign, notes: list) -> dict:
    """The ``[sites]`` of the --site parts, each sensor site with its chip's grade (one note line per part)."""
    grades, lines = ({}, []) if opts.grade_rule is None else \
        opts.grade_rule(opts.sites, {fp.ref: fp for fp in board.footprints}, opts.grades)
    notes.extend(lines)
    sites = {}
    for ref, kind in opts.sites.items():
        targets = SITE_KINDS[kind] or (names[ref],)
        for s in targets:
            if s in sites:
                raise InputError(f"--site: {s} is given twice ({sites[s]['part'][:-4]} and {names[ref]})")
            sites[s] = Inline({"part": names[ref] + "_die", **({"grade": grades[ref]} if ref in grades else {})})
    return sites


def import_board(board: BoardDesign, opts: ImportOptions = ImportOptions()) -> ImportResult:
    """A single-board unit around ``board`` (see the module docstring); InputError on any problem.

    Parameters
    ----------
    board : BoardDesign, from :func:`imutherm.ecad.read.read_board`
    opts : ImportOptions, what the board file does not say: powers [W], heights [mm], the sensor sites

    Returns
    -------
    ImportResult: ``text`` the layout TOML (write it to a file: an ordinary layout), ``spec`` its checked
    :class:`~imutherm.geometry.layout.LayoutSpec`, ``decisions`` each footprint's fate with its reason

    Examples
    --------
    The flight controller of ``examples/boards/`` (run from a clone) with its powers and heights files and the
    ICM-20689 (``U2``) as the sensor site, as ``imutherm import`` does it:

    >>> import gzip, tempfile
    >>> from pathlib import Path
    >>> from imutherm.ecad.read import read_board
    >>> from imutherm.ecad.to_layout import ImportOptions, import_board
    >>> from imutherm.ecad.user_tables import read_value_csv
    >>> pcb = Path(tempfile.mkdtemp()) / "drone-fc.kicad_pcb"
    >>> _ = pcb.write_bytes(gzip.decompress(Path("examples/boards/drone-fc.kicad_pcb.gz").read_bytes()))
    >>> options = ImportOptions(powers=read_value_csv("examples/boards/drone-fc_powers.csv", "power_W"),
    ...                         heights=read_value_csv("examples/boards/drone-fc_heights.csv", "height_mm"),
    ...                         sites={"U2": "imu"})
    >>> unit = import_board(read_board(pcb), options)
    >>> unit.count("modelled"), unit.count("merged"), unit.count("skipped")
    (15, 59, 4)
    >>> list(unit.spec.schemes), unit.spec.sites[0].name
    (['air', 'grease', 'potted'], 'gyro_x')

    ``unit.spec`` goes wherever a layout goes: ``build_geometry(unit.spec, "grease")``,
    ``run_scheme(unit.spec, "grease")``.
    """
    board, decisions, keep, regulators, notes = _prepare(board, opts)
    notes += _check_heights(board, decisions, opts)
    decisions, bodies = place_parts(board, decisions, keep, set(opts.sites), notes)
    if not any(d.power_W > 0 for d in decisions if d.fate == "modelled") and not regulators:
        raise _no_power(board, decisions)
    names = _names(decisions, opts.prefix, notes)
    if opts.grease is None and opts.grease_rule is not None:  # e.g. imutherm.unit.grease_choice.choose
        air = _single_board_layout(board, decisions, names, replace(opts, grease=()), regulators, [], bodies)[1]
        chosen, told = opts.grease_rule(air, names, opts.sites)
        notes += told
        opts = replace(opts, grease=tuple(chosen), grease_why=chosen)
    layout, spec = _single_board_layout(board, decisions, names, opts, regulators, notes, bodies)
    return ImportResult(board, tuple(decisions), layout, spec, tuple(notes), names)


def _prepare(board: BoardDesign, opts: ImportOptions) -> tuple:
    """(board, decisions, refs kept, regulators, notes): the board picked from its file (a panel's, without what
    lies outside it), the user's references checked, repeated ones told apart, each footprint's fate decided."""
    board = pick_board(board, sites=opts.sites, powered=opts.powers)
    _check_refs(board, opts)
    board, renamed = unique_references(board)
    board, coverage = with_coverage(board)
    rails_refs = _electrical_refs(opts.electrical)
    unknown_rail = sorted(rails_refs - {fp.ref for fp in board.footprints})
    if unknown_rail:
        raise InputError(f"{opts.electrical_source or '--electrical'}: no footprint {', '.join(unknown_rail[:5])} on "
                         f"the board {board.source}")
    keep = set(opts.keep) | set(opts.sites) | rails_refs
    merge = opts.merge_area_mm2 if opts.merge_area_mm2 is not None else 10.0
    decisions = decide(board, powers=opts.powers, heights=opts.heights, keep=keep, merge_area_mm2=merge)
    regulators = {r.get("regulator") for r in (opts.electrical or {}).get("rails", []) or [] if isinstance(r, dict)}
    off = {fp.ref: fp.off_board for fp in board.footprints if fp.off_board}
    off = {ref: why for ref, why in off.items() if ref not in {fp.ref for fp in board.footprints if not fp.off_board}}
    notes = list(board.notes) + [n for n in (renamed, coverage) if n] + _field_notes(decisions)
    for what, given in (("--power", opts.powers), ("--height", opts.heights), ("--keep", opts.keep)):
        notes += [f"{what} {ref}: not on the board modelled ({off[ref]}): left out"
                  for ref in sorted(given, key=natural_order) if ref in off]
    return board, decisions, keep, regulators, notes


def _check_heights(board: BoardDesign, decisions: list, opts: ImportOptions) -> list:
    """The note naming the parts whose height is estimated; with ``--strict-heights`` their refusal instead
    (every such part named: :mod:`imutherm.ecad.heights`)."""
    estimated = estimated_parts(decisions)
    if opts.strict_heights and estimated:
        raise strict_refusal(board.source, estimated)
    if not estimated:
        return []
    parts = ", ".join(f"{d.footprint.ref} {d.height_mm:g} mm" + (" (merged)" if d.fate == "merged" else "")
                      for d in sorted(estimated, key=lambda d: natural_order(d.footprint.ref)))
    return [f"ESTIMATED heights of {len(estimated)} part{'s' if len(estimated) > 1 else ''} (no height in the "
            f"footprint, its name or the package tables; each part's height_source gives the rule): {parts}; "
            f"--heights-template FILE writes them to fill in, --strict-heights refuses them"]


def _field_notes(decisions: list) -> list:
    """One note per kind of field left out (a power rating, a field without a number), naming its parts."""
    by_note: dict = {}
    for d in decisions:
        if d.note and d.fate != "skipped":
            by_note.setdefault(d.note, []).append(d.footprint.ref)
    out = []
    for note, refs in by_note.items():
        more = f" (+{len(refs) - 12} more)" if len(refs) > 12 else ""
        out.append(f"{', '.join(sorted(refs, key=natural_order)[:12])}{more}: {note}")
    return out


def _names(decisions: list, prefix: str, notes: list) -> dict:
    names, used = {}, set()
    for d in decisions:
        if d.fate != "modelled":
            continue
        name = component_name(d.footprint.ref, prefix)
        base, k = name, 2
        while name in used or name.lower() in ("housing", "lid", "fill", "main") or name.startswith("standoff_"):
            name, k = f"{base}_{k}", k + 1
        if name != component_name(d.footprint.ref, prefix):
            notes.append(f"{d.footprint.ref}: named {name!r} in the layout (its reference is taken)")
        used.add(name)
        names[d.footprint.ref] = name
    return names


def _board_material_entry(board: BoardDesign, decisions: list, board_name: str) -> tuple:
    merged = [d for d in decisions if d.fate == "merged"]
    mass = sum(merged_heat(d)[0] for d in merged)
    heat = sum(merged_heat(d)[1] for d in merged)
    loops = board_loops(board.outline)   # the mesh's board is the outline's (imutherm.geometry.outline)
    area = outline_area(loops) if loops else board.width_mm * board.height_mm
    m = board_material("board", board.thickness_mm, board.copper_um, coverage=board.coverage or DEFAULT_COVERAGE,
                       merged_mass_kg=mass, merged_heat_capacity_J_K=heat, area_mm2=area,
                       note=f"stack-up: {board.stackup_source}; {len(merged)} parts merged")
    # named by its values, so two boards of the same name but other stack-ups never share a name in a process
    digest = hashlib.sha1(repr((m.k_in_plane, m.k_through, m.density, m.specific_heat)).encode()).hexdigest()[:6]
    name = f"pcb_{re.sub(r'[^A-Za-z0-9_]', '_', board_name)}_{board.copper_layers}l_{digest}"
    table = {NOTE: f"board {board_name}: {m.source}", "k_in_plane": m.k_in_plane, "k_through": m.k_through,
             "density": m.density, "specific_heat": m.specific_heat, "emissivity": m.emissivity,
             "source": m.source}
    return name, table


def _single_board_layout(board, decisions, names, opts, regulators, notes, bodies) -> tuple:
    hs = opts.housing
    for mat in (hs.material, hs.standoff_material):
        get_material(mat)
    modelled = [d for d in decisions if d.fate == "modelled"]
    site_refs = set(opts.sites)
    standoffs_at = standoff_rects(board, decisions, notes)
    moved = grease_parts(decisions, opts, standoffs_at, notes,
                         dissipators(decisions) if opts.grease is None else opts.grease)
    placed = [d for d in decisions if d.fate in ("modelled", "merged")]
    top_h = max([d.height_mm or 0.0 for d in placed if d.footprint.side == "top"], default=0.0)
    bottom_h = max([d.height_mm or 0.0 for d in placed if d.footprint.side == "bottom"]
                   + [d.height_mm for d in moved], default=0.0)
    standoff = max(bottom_h + hs.clearance_mm, hs.min_standoff_mm)
    keep_moved = []
    for d in moved:
        gap = standoff - d.height_mm
        if gap > MAX_BOND_GAP_MM + 1e-9:
            notes.append(f"grease scheme: {d.footprint.ref} would sit {gap:.2f} mm from the base (more than "
                         f"{MAX_BOND_GAP_MM:g} mm of grease): not bonded (--grease REF,... bonds others)")
        else:
            keep_moved.append(d)
    moved = keep_moved
    t = board.thickness_mm
    c = hs.clearance_mm
    cavity = (board.width_mm + 2 * c, board.height_mm + 2 * c, standoff + t + top_h + c)
    outer = (cavity[0] + 2 * hs.wall_mm, cavity[1] + 2 * hs.wall_mm, cavity[2] + hs.base_mm + hs.lid_mm)
    x0, y0, z0 = hs.wall_mm + c, hs.wall_mm + c, hs.base_mm + standoff
    mat_name, mat_table = _board_material_entry(board, decisions, opts.board_name)

    standoffs = standoff_parts(standoffs_at, x0, y0, hs.base_mm, standoff, hs.standoff_material)
    hard = {d.footprint.ref for d in modelled if _has_die(d, site_refs, regulators)}
    fixed = hard | {d.footprint.ref for d in modelled if d.power_W > 0 or d.footprint.ref in site_refs}
    exact = dict(bodies)
    bodies, snapped = snap_soft_parts(board, modelled, bodies, fixed, [r for _, r in standoffs_at], opts.exact)
    components, mats = [], {"board": (mat_name, mat_table)}
    for d in modelled:
        ref = d.footprint.ref
        components.append(_component(board, d, names[ref], opts.board_name, bodies[ref], ref in hard,
                                     ref in regulators and ref not in opts.powers, snapped.get(ref, ""), mats))
    if snapped:
        notes.append(snap_note(exact, bodies, snapped))
    doc = {
        NOTE: _header(board, decisions, notes),
        "name": opts.layout_name or _layout_name(board),
        "description": f"single-board unit around {board.source.split('/')[-1]} ({board.format}), imported by "
                       f"imutherm import",
        "default_scheme": "grease" if moved else "air",
        "environment": {"ambient_C": Note(hs.ambient_C, "the unit's highest working temperature (the reference "
                                                        "unit's 70 degC unless given)")},
        "housing": {NOTE: "the reference unit's housing (layouts/imu_reference.toml) around the board: "
                          f"{c:g} mm clearance to the walls and above the tallest part",
                    "outer_mm": [round_mm(v) for v in outer], "wall_mm": hs.wall_mm, "base_mm": hs.base_mm,
                    "lid_mm": hs.lid_mm, "material": hs.material},
        "mounting": _mounting(hs),
        "materials": {mat_name: mat_table, **{k: v for k, v in mats.items() if k != "board"}},
        "boards": [{NOTE: f"{board.format} board {board.source}: {board.width_mm:.3f} x {board.height_mm:.3f} mm "
                          f"(the outline's bounding rectangle), {t:g} mm, {board.copper_layers} copper layers",
                    "name": opts.board_name, "normal": "z", "min_mm": [round_mm(x0), round_mm(y0), round_mm(z0)],
                    "size_mm": [round_mm(board.width_mm), round_mm(board.height_mm), round_mm(t)], "material": mat_name,
                    "source": f"{board.source} ({board.format})",
                    "outline_mm": [[[round_mm(x), round_mm(y)] for x, y in line] for line in board.outline],
                    **_coverage_entry(board), "merged_parts": _merged_entries(decisions)}],
        "parts": standoffs,
        "components": components,
    }
    if opts.electrical:
        doc.update(_renamed_electrical(opts.electrical, names))
    sites = _sites(opts, names, board, notes)
    if sites:
        doc["sites"] = sites
    else:
        notes.append("no sensor sites: `imutherm compare` needs them; import again with --site REF=imu (a 6-axis "
                     "chip) or --site REF=gyro / REF=accel")
    schemes = {"air": {"description": "every part on the board as designed; heat leaves through the air, the "
                                      "standoffs and the housing", "fill": "air"}}
    if moved:
        top = [names[d.footprint.ref] for d in moved if d.footprint.side == "top"]
        kept = [names[d.footprint.ref] for d in moved if d.footprint.side != "top"]
        why = "; ".join(f"{d.footprint.ref}: {opts.grease_why[d.footprint.ref]}" for d in moved
                        if d.footprint.ref in opts.grease_why)
        left = [n.split(": ", 1)[1] for n in notes if n.startswith("grease scheme: ") and "--grease" in n
                and "the parts chosen" not in n]
        schemes["grease"] = {"description": ("the parts that set the hot spot and the sensor temperatures bonded to "
                                             "the base with silicone grease" if opts.grease_why else
                                             "the parts given by --grease bonded to the base with silicone grease")
                                            + (f", {', '.join(top)} moved to the back" if top else "")
                                            + (f", {', '.join(kept)} where they are (bottom side)" if kept else "")
                                            + (f" ({why})" if why else "") + (f". {' '.join(left)}" if left else ""),
                             "fill": "air", **({"move_to_back": top} if top else {}),
                             **({"bond_in_place": kept} if kept else {}),
                             "bond_material": "silicone_grease",
                             "max_bond_gap_mm": Note(MAX_BOND_GAP_MM, "the reference unit's limit")}
    else:
        left = [n.split(": ", 1)[1] for n in notes if n.startswith("grease scheme: ") and "--grease" in n
                and "the parts chosen" not in n]
        notes.append("no grease scheme: no part could be bonded to the base" + (f" ({' '.join(left)})" if left else
                     "") + "; --grease REF,... names the parts to bond")
        schemes["air"]["description"] += ". No grease scheme: " + notes[-1].split(": ", 1)[1]
    schemes["potted"] = {"description": "the free interior potted", "fill": "potting_compound"}
    doc["schemes"] = schemes
    text = dumps(doc)
    spec = check_layout_text(text, board.source)
    return text, spec


def snap_note(exact: dict, bodies: dict, snapped: dict) -> str:
    """The note naming every snapped part with how far its edges moved [mm] and its area changed [%]."""
    moves = []
    for ref in sorted(snapped, key=natural_order):
        a, b = exact[ref], bodies[ref]
        move = max(abs(a.x0 - b.x0), abs(a.x1 - b.x1), abs(a.y0 - b.y0), abs(a.y1 - b.y1))
        moves.append(f"{ref} {move:.2f} mm ({100 * (b.area / a.area - 1):+.0f} %)")
    return (f"{len(snapped)} unpowered parts without a die have their edges snapped (<= {SNAP_MM:g} mm) to their "
            f"neighbours' lines, so they add few mesh lines (powered parts and sites never are; --exact keeps every "
            f"edge): {', '.join(moves)}")


def _merged_entries(decisions: list) -> list:
    """The board's ``merged_parts`` list (drawings and IDF export): body centre and size, side, footprint."""
    out = []
    for d in decisions:
        if d.fate == "merged":
            b = d.body
            out.append(Inline({"name": d.footprint.ref, "side": d.footprint.side,
                               "center_mm": [round_mm(b.centre[0]), round_mm(b.centre[1])],
                               "size_mm": [round_mm(max(b.width, 1e-3)), round_mm(max(b.height, 1e-3)),
                                           round_mm(d.height_mm or MERGED_UNKNOWN_HEIGHT_MM)],
                               "footprint": d.footprint.library}))
    return out


def _coverage_entry(board: BoardDesign) -> dict:
    """The board's ``copper_coverage`` (measured, front to back) for the layout, {} when not measured."""
    if not board.coverage:
        return {}
    return {"copper_coverage": Note([round(c, 4) for c in board.coverage], "measured from the file's zones, tracks, "
                                    "vias and pads within the outline, front to back (ecad/kicad_copper.py)")}


def _mounting(hs: HousingOptions) -> dict:
    if hs.mounting == "free":
        return {"kind": "free", "face": hs.mounting_face}
    return {"kind": "fixture", "face": hs.mounting_face,
            "contact_conductance_W_m2K": Note(hs.contact_conductance_W_m2K, "the reference unit's assumed bolted "
                                                                             "Al-Al joint"),
            "temperature_C": hs.ambient_C}


def _layout_name(board: BoardDesign) -> str:
    stem = re.sub(r"\.(kicad_pcb|emn)$", "", board.source.replace("\\", "/").split("/")[-1], flags=re.I)
    return re.sub(r"[^A-Za-z0-9_-]", "_", stem) or "imported"


def _renamed_electrical(electrical: dict, names: dict) -> dict:
    """The ``[electrical]`` and ``[[rails]]`` tables with references turned into layout names."""
    rails = []
    for rail in electrical.get("rails", []):
        r = dict(rail)
        if "regulator" in r:
            r["regulator"] = names.get(r["regulator"], r["regulator"])
        if isinstance(r.get("loads_A"), dict):
            r["loads_A"] = Inline({names.get(k, k): v for k, v in r["loads_A"].items()})
        rails.append(r)
    return {"electrical": dict(electrical.get("electrical", {})), "rails": rails}


def _header(board: BoardDesign, decisions: list, notes: list) -> str:
    fates = {f: [d for d in decisions if d.fate == f] for f in ("modelled", "merged", "skipped")}
    lines = [f"Imported by `imutherm import` from {board.source} ({board.format}).",
             f"{len(decisions)} footprints: {len(fates['modelled'])} modelled, {len(fates['merged'])} merged into "
             f"the board, {len(fates['skipped'])} skipped.",
             "Lengths in mm, powers in W, temperatures in degC; board-local (u, v) = the board file's (x, y) with y "
             "up, origin at the outline's lower left. Edit freely: this is an ordinary layout file.",
             "merged (mass and heat capacity smeared into the board): " + ", ".join(
                 sorted((d.footprint.ref for d in fates["merged"]), key=natural_order))]
    estimated = estimated_parts(decisions)
    if estimated:
        lines.append("heights ESTIMATED (no height in the footprint, its name or the package tables; "
                     "imutherm.ecad.heights): " + ", ".join(f"{d.footprint.ref} {d.height_mm:g} mm" for d in estimated))
    for d in sorted(fates["skipped"], key=lambda d: natural_order(d.footprint.ref)):
        lines.append(f"skipped {d.footprint.ref}: {d.reason}")
    return "\n".join(lines)


def check_layout_text(text: str, where: str):
    """The layout ``text`` parsed and every scheme built (InputError with the first problem); its LayoutSpec."""
    from imutherm.geometry.build import build_geometry

    data = tomllib.loads(text)
    spec = parse_layout(data, f"{where} (imported)")
    for name in spec.schemes:
        build_geometry(spec, name)
    return spec


def replace_board(layout_path: str, board_name: str, board: BoardDesign, opts: ImportOptions) -> ImportResult:
    """The layout ``layout_path`` with its board ``board_name`` replaced by the imported one.

    The board keeps its place (lower corner and normal) in the unit; its in-plane size and thickness are the
    file's. The old board's components, their sites and their rail loads go; the imported board's modelled
    parts come in with ``<board_name>_`` before their references. The result is regenerated from the data, so
    comments of the original file are not carried over (the CLI says so).
    """
    from imutherm.geometry.layout import resolve_layout
    from imutherm.textio import read_text

    path = resolve_layout(layout_path)
    try:
        data = tomllib.loads(read_text(path, "layout file"))
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
    boards = data.get("boards", [])
    target = next((b for b in boards if isinstance(b, dict) and b.get("name") == board_name), None)
    if target is None:
        raise InputError(f"{path}: --board {board_name!r}: no such board; boards: "
                         f"{', '.join(str(b.get('name')) for b in boards if isinstance(b, dict))}")
    opts = replace(opts, board_name=board_name, prefix=opts.prefix or f"{board_name}_")
    board, decisions, keep, _, notes = _prepare(board, opts)
    notes += _check_heights(board, decisions, opts)
    notes.insert(0, f"{path}: board {board_name!r} replaced; the file is regenerated from its data, so its comments "
                    f"are not carried over")
    decisions, bodies = place_parts(board, decisions, keep, set(opts.sites), notes)
    modelled = [d for d in decisions if d.fate == "modelled"]
    names = _names(decisions, opts.prefix, notes)
    normal = target.get("normal", "z")
    axis = "xyz".index(normal)
    a0, a1 = (a for a in range(3) if a != axis)
    size = [0.0, 0.0, 0.0]
    size[a0], size[a1], size[axis] = board.width_mm, board.height_mm, board.thickness_mm
    mat_name, mat_table = _board_material_entry(board, decisions, board_name)
    target.pop("copper_coverage", None)
    target.update(size_mm=[round_mm(v) for v in size], material=mat_name, source=f"{board.source} ({board.format})",
                  outline_mm=[[[round_mm(x), round_mm(y)] for x, y in line] for line in board.outline],
                  **_coverage_entry(board), merged_parts=_merged_entries(decisions))
    data.setdefault("materials", {})[mat_name] = mat_table
    old = {c.get("name") for c in data.get("components", []) if isinstance(c, dict) and c.get("board") == board_name}
    data["components"] = [c for c in data.get("components", []) if c.get("name") not in old]
    dies = {f"{n}_die" for n in old} | old | {f"{n}_pad" for n in old}
    for s in [s for s, v in data.get("sites", {}).items()
              if isinstance(v, dict) and (v.get("part") in dies or v.get("board") == board_name)]:
        del data["sites"][s]
        notes.append(f"site {s} went with board {board_name!r}'s old parts")
    for scheme in data.get("schemes", {}).values():
        if isinstance(scheme, dict) and "move_to_back" in scheme:
            scheme["move_to_back"] = [c for c in scheme["move_to_back"] if c not in old]
    for rail in data.get("rails", []) or []:
        if isinstance(rail, dict):
            if rail.get("regulator") in old:
                raise InputError(f"{path}: rail {rail.get('name')!r} is regulated by {rail['regulator']!r}, a part of "
                                 f"board {board_name!r} that the import replaces; give the rails again with "
                                 f"--electrical FILE naming the imported parts")
            if isinstance(rail.get("loads_A"), dict):
                rail["loads_A"] = Inline({k: v for k, v in rail["loads_A"].items() if k not in old})
    regulators = {r.get("regulator") for r in (opts.electrical or {}).get("rails", []) or [] if isinstance(r, dict)}
    hard = {d.footprint.ref for d in modelled if _has_die(d, set(opts.sites), regulators)}
    fixed = hard | {d.footprint.ref for d in modelled if d.power_W > 0 or d.footprint.ref in opts.sites}
    exact = dict(bodies)
    bodies, snapped = snap_soft_parts(board, modelled, bodies, fixed, (), opts.exact)
    if snapped:
        notes.append(snap_note(exact, bodies, snapped))
    mats = {"board": (mat_name, mat_table)}
    for d in modelled:
        ref = d.footprint.ref
        data["components"].append(_component(board, d, names[ref], board_name, bodies[ref], ref in hard,
                                             ref in regulators and ref not in opts.powers, snapped.get(ref, ""), mats))
    data["materials"].update({k: v for k, v in mats.items() if k != "board"})
    if opts.electrical:
        new = _renamed_electrical(opts.electrical, names)
        data["electrical"] = new["electrical"]
        data["rails"] = list(data.get("rails", []) or []) + new["rails"]
    data["sites"] = {k: Inline(v) if isinstance(v, dict) else v for k, v in data.get("sites", {}).items()}
    data["sites"].update(_sites(opts, names, board, notes))
    data[NOTE] = (f"{path} with board {board_name!r} imported from {board.source} ({board.format}) by "
                  f"`imutherm import --into`.\n" + _header(board, decisions, notes))
    text = dumps(data)
    spec = check_layout_text(text, board.source)
    return ImportResult(board, tuple(decisions), text, spec, tuple(notes), names)
