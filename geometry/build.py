"""Build the parts of one cooling scheme from a layout: boxes in metres, checked.

``build_geometry(layout, scheme)`` places the housing, lid, boards, plain parts,
component packages with their dies and pads, the scheme's bond lines and the
cavity fill, then checks them: no overlapping solids (a die and pad may sit
inside their package; the fill takes the free space), every part inside the
cavity, every component on its board. A board is its rectangle here; a board
whose true outline (``outline_mm``) has cut-outs, slots or a shaped edge has its
volume from that outline, and the mesh takes the cells outside it out of the
board (:mod:`imutherm.geometry.outline`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from imutherm import InputError
from imutherm.geometry.layout import AXES, LayoutSpec, SchemeSpec, load_layout
from imutherm.geometry.materials import Material, get_material
from imutherm.geometry.outline import board_loops, cuts_board, outline_area

MM = 1e-3  # [m per mm]
VIA_FIELD_MATERIAL = "pcb_via_field"  # board material under an exposed pad with thermal vias (a layout's default)
_TOL = 1e-9  # [m] geometric tolerance for touching faces


@dataclass(frozen=True)
class Part:
    """One solid of the unit, an axis-aligned box (or the housing shell / the fill).

    Attributes
    ----------
    name : str
        Unique; the mesh subdomain and result label.
    kind : str
        ``housing`` (box minus the cavity), ``lid``, ``board``, ``vias``
        (a thermal-via field inside a board), ``box``, ``component`` (package
        body), ``die``, ``pad``, ``bond`` or ``fill``.
    material : str
    lo, hi : tuple [m]
        Lower and upper corners of the box (for ``housing``: the outer box
        below the lid; for ``fill``: the cavity).
    power_W : float [W]
    normal : str or None
        Board normal axis (orients the orthotropic conductivity of boards and via fields).
    parent : str or None
        The package a die or pad sits in, the board a via field sits in, the
        component a bond belongs to.
    hole : tuple or None
        (lo, hi) [m] of the box removed from a ``housing`` part (the cavity).
    board_contact_W_m2K : float or None [W/m^2 K]
        For a ``box``: its contact conductance to the boards it touches (None:
        the model's default, ``ModelOptions.standoff_contact_W_m2K``).
    """

    name: str
    kind: str
    material: str
    lo: tuple
    hi: tuple
    power_W: float = 0.0
    normal: str | None = None
    parent: str | None = None
    hole: tuple | None = None
    board_contact_W_m2K: float | None = None

    @property
    def size(self) -> np.ndarray:
        """Box size [m] along x, y, z."""
        return np.subtract(self.hi, self.lo)

    @property
    def box_volume(self) -> float:
        """Volume of the bounding box [m^3] (minus the hole for the housing)."""
        v = float(np.prod(self.size))
        if self.hole is not None:
            v -= float(np.prod(np.subtract(self.hole[1], self.hole[0])))
        return v

    @property
    def centroid(self) -> np.ndarray:
        """Centre of the box [m]."""
        return 0.5 * (np.asarray(self.lo) + np.asarray(self.hi))


@dataclass(frozen=True)
class Geometry:
    """The parts of one scheme of a layout, with derived quantities.

    Attributes
    ----------
    layout : LayoutSpec
    scheme : SchemeSpec
    parts : tuple of Part
        Housing, lid, boards, plain parts, packages, pads, dies, bonds, and the
        fill last.
    sites : dict
        Site name -> position [m] (x, y, z).
    outer : tuple
        (lo, hi) of the outer box [m].
    cavity : tuple
        (lo, hi) of the cavity [m].
    volumes : dict
        Part name -> volume [m^3] (the fill: cavity minus the parts in it).
    """

    layout: LayoutSpec
    scheme: SchemeSpec
    parts: tuple
    sites: dict
    outer: tuple
    cavity: tuple
    volumes: dict = field(repr=False)

    def part(self, name: str) -> Part:
        for p in self.parts:
            if p.name == name:
                return p
        raise InputError(f"unknown part {name!r}; valid: {', '.join(p.name for p in self.parts)}")

    def material(self, part_name: str) -> Material:
        return get_material(self.part(part_name).material)

    @property
    def total_power_W(self) -> float:
        """Sum of all part powers [W]."""
        return float(sum(p.power_W for p in self.parts))

    @property
    def mass_kg(self) -> float:
        """Mass of the unit [kg] (fill included: air is negligible, potting is not)."""
        return float(sum(self.volumes[p.name] * get_material(p.material).density for p in self.parts))


def _fail(layout: LayoutSpec, where: str, msg: str):
    raise InputError(f"{layout.path}: {where}: {msg}")


def _in_plane(normal: str) -> tuple:
    n = AXES.index(normal)
    return tuple(a for a in range(3) if a != n)


def _component_parts(layout: LayoutSpec, comp, board, side: str) -> list:
    """Package, pad and die boxes of one component on its board side."""
    n = AXES.index(board.normal)
    a0, a1 = _in_plane(board.normal)
    bmin = np.asarray(board.min_mm) * MM
    bmax = bmin + np.asarray(board.size_mm) * MM
    centre = {a0: bmin[a0] + comp.center_mm[0] * MM, a1: bmin[a1] + comp.center_mm[1] * MM}
    for ax, c, half, span in ((a0, comp.center_mm[0], comp.size_mm[0] / 2, board.size_mm[a0]),
                              (a1, comp.center_mm[1], comp.size_mm[1] / 2, board.size_mm[a1])):
        if c - half < -1e-9 or c + half > span + 1e-9:
            _fail(layout, f"component {comp.name!r}", f"field 'center_mm': footprint {c - half:g}..{c + half:g} mm "
                  f"along {AXES[ax]} leaves board {board.name!r} (0..{span:g} mm)")
    face, sign = (bmax[n], 1.0) if side == "top" else (bmin[n], -1.0)

    def box(u, v, z0, z1):  # footprint u x v [mm] centred, from z0 to z1 [mm] off the board face
        lo, hi = np.zeros(3), np.zeros(3)
        lo[a0], hi[a0] = centre[a0] - u * MM / 2, centre[a0] + u * MM / 2
        lo[a1], hi[a1] = centre[a1] - v * MM / 2, centre[a1] + v * MM / 2
        ends = sorted((face + sign * z0 * MM, face + sign * z1 * MM))
        lo[n], hi[n] = ends
        return tuple(lo), tuple(hi)

    u, v, h = comp.size_mm
    out = [Part(comp.name, "component", comp.material, *box(u, v, 0.0, h),
                power_W=0.0 if comp.die_mm else comp.power_W)]
    if comp.die_mm:
        du, dv, dt = comp.die_mm
        if comp.exposed_pad:
            pu, pv = comp.pad_mm
            out.append(Part(comp.name + "_pad", "pad", "copper", *box(pu, pv, 0.0, comp.die_base_mm),
                            parent=comp.name))
            if comp.vias:
                thick = board.size_mm[n]
                out.append(Part(comp.name + "_vias", "vias", comp.vias_material, *box(pu, pv, -thick, 0.0),
                                normal=board.normal, parent=board.name))
        out.append(Part(comp.name + "_die", "die", "silicon",
                        *box(du, dv, comp.die_base_mm, comp.die_base_mm + dt), power_W=comp.power_W,
                        parent=comp.name))
    return out


def _bond(layout: LayoutSpec, scheme: SchemeSpec, package: Part, board, side: str, cavity) -> Part:
    """The bond line (grease) between a package's outer face and the nearest wall."""
    n = AXES.index(board.normal)
    lo, hi = list(package.lo), list(package.hi)
    if side == "top":
        gap = cavity[1][n] - package.hi[n]
        lo[n], hi[n] = package.hi[n], cavity[1][n]
    else:
        gap = package.lo[n] - cavity[0][n]
        lo[n], hi[n] = cavity[0][n], package.lo[n]
    if gap <= _TOL or gap > scheme.max_bond_gap_mm * MM + _TOL:
        _fail(layout, f"scheme {scheme.name!r}", f"component {package.name!r} is {gap / MM:.3g} mm from the wall; "
              f"a bond bridges 0 < gap <= max_bond_gap_mm = {scheme.max_bond_gap_mm:g} mm")
    return Part(package.name + "_bond", "bond", scheme.bond_material, tuple(lo), tuple(hi), parent=package.name)


def _faces_touch(a: Part, b: Part) -> bool:
    """True if two boxes share a face patch of non-zero area."""
    gaps = [max(a.lo[i], b.lo[i]) - min(a.hi[i], b.hi[i]) for i in range(3)]  # > 0 apart, < 0 overlapping
    return sum(abs(g) <= _TOL for g in gaps) == 1 and all(g <= _TOL for g in gaps)


def _check(layout: LayoutSpec, scheme: SchemeSpec, parts: list, cavity) -> None:
    inner = [p for p in parts if p.kind not in ("housing", "lid", "fill")]
    for p in inner:
        if any(p.lo[i] < cavity[0][i] - _TOL or p.hi[i] > cavity[1][i] + _TOL for i in range(3)):
            _fail(layout, f"scheme {scheme.name!r}: part {p.name!r}",
                  f"lies outside the cavity: part {np.round(np.asarray(p.lo) / MM, 3).tolist()}.."
                  f"{np.round(np.asarray(p.hi) / MM, 3).tolist()} mm, cavity "
                  f"{np.round(np.asarray(cavity[0]) / MM, 3).tolist()}..{np.round(np.asarray(cavity[1]) / MM, 3).tolist()} mm")
    los = np.array([p.lo for p in inner])
    his = np.array([p.hi for p in inner])
    ov = np.minimum(his[:, None, :], his[None, :, :]) - np.maximum(los[:, None, :], los[None, :, :])
    clash = np.all(ov > _TOL, axis=2)
    for i, j in zip(*np.nonzero(np.triu(clash, 1))):
        a, b = inner[i], inner[j]
        if a.name == b.parent or b.name == a.parent:   # a die or pad in its package, a via field in its board
            continue
        _fail(layout, f"scheme {scheme.name!r}: part {a.name!r}", f"overlaps part {b.name!r}")
    boards = [p for p in parts if p.kind == "board"]
    for p in parts:
        if p.board_contact_W_m2K is not None and not any(_faces_touch(p, b) for b in boards):
            _fail(layout, f"part {p.name!r}", "field 'board_contact_W_m2K' is set but the part touches no board "
                  f"(boards: {', '.join(b.name for b in boards)}); move it against a board or remove the field")


def build_geometry(layout: LayoutSpec | str | None = None, scheme: str | None = None) -> Geometry:
    """Place and check every part of ``scheme`` (default: the layout's default scheme).

    Parameters
    ----------
    layout : LayoutSpec, path, or None (the built-in reference unit)
    scheme : str, one of the layout's schemes (``air``, ``grease``, ``potted``)

    Examples
    --------
    >>> from imutherm.geometry.build import build_geometry
    >>> geometry = build_geometry("imu_reference", "grease")
    >>> len(geometry.parts), round(sum(p.power_W for p in geometry.parts), 3)   # parts, power [W]
    (44, 1.962)
    >>> [p.name for p in geometry.parts if p.kind == "bond"]   # the grease lines of the scheme
    ['processor_bond', 'reg_5v_bond', 'reg_3v3_bond', 'reg_1v8_bond']
    >>> [round(1e3 * float(v), 2) for v in geometry.sites["gyro_x"]]   # a sensor site [mm]
    [58.65, 14.0, 14.3]
    """
    if not isinstance(layout, LayoutSpec):
        layout = load_layout(layout)
    sch = layout.scheme(scheme)
    hs = layout.housing
    outer_hi = np.asarray(hs.outer_mm) * MM
    cav_lo = np.array([hs.wall_mm, hs.wall_mm, hs.base_mm]) * MM
    cav_hi = outer_hi - np.array([hs.wall_mm, hs.wall_mm, hs.lid_mm]) * MM
    cavity = (tuple(cav_lo), tuple(cav_hi))
    lid_z = cav_hi[2]
    parts = [Part("housing", "housing", hs.material, (0.0, 0.0, 0.0), (outer_hi[0], outer_hi[1], lid_z),
                  hole=cavity),
             Part("lid", "lid", hs.material, (0.0, 0.0, lid_z), tuple(outer_hi))]
    boards = {b.name: b for b in layout.boards}
    for b in layout.boards:
        lo = np.asarray(b.min_mm) * MM
        parts.append(Part(b.name, "board", b.material, tuple(lo), tuple(lo + np.asarray(b.size_mm) * MM),
                          normal=b.normal))
    for p in layout.parts:
        lo = np.asarray(p.min_mm) * MM
        parts.append(Part(p.name, "box", p.material, tuple(lo), tuple(lo + np.asarray(p.size_mm) * MM),
                          power_W=p.power_W, board_contact_W_m2K=p.board_contact_W_m2K))
    for c in layout.components:
        side = c.side
        if c.name in sch.move_to_back:
            side = "bottom" if side == "top" else "top"
        comp_parts = _component_parts(layout, c, boards[c.board], side)
        parts += comp_parts
        if (c.name in sch.move_to_back or c.name in sch.bond_in_place) and sch.bond_material:
            parts.append(_bond(layout, sch, comp_parts[0], boards[c.board], side, cavity))
    _check(layout, sch, parts, cavity)

    volumes = {p.name: p.box_volume for p in parts}
    for b in layout.boards:   # a board cut by its true outline: the outline's area (imutherm.geometry.outline)
        loops = board_loops(b.outline_mm)
        a0, a1 = _in_plane(b.normal)
        if loops and cuts_board(loops, b.size_mm[a0], b.size_mm[a1]):
            volumes[b.name] = outline_area(loops) * b.size_mm[AXES.index(b.normal)] * MM**3
    for p in parts:  # dies and pads are carved out of their package, via fields out of their board
        if p.parent and p.kind in ("die", "pad", "vias"):
            volumes[p.parent] -= volumes[p.name]
    inner = sum(volumes[p.name] for p in parts if p.kind not in ("housing", "lid"))
    fill = Part("fill", "fill", sch.fill, *cavity)
    volumes["fill"] = fill.box_volume - inner
    parts.append(fill)

    sites = {}
    for s in layout.sites:
        if s.part:
            sites[s.name] = next(p for p in parts if p.name == s.part).centroid
        else:
            b = boards[s.board]
            n = AXES.index(b.normal)
            a0, a1 = _in_plane(b.normal)
            if not (0 <= s.at_mm[0] <= b.size_mm[a0] and 0 <= s.at_mm[1] <= b.size_mm[a1]):
                _fail(layout, f"site {s.name!r}", f"field 'at_mm' {list(s.at_mm)} lies outside board {b.name!r} "
                      f"(0..{b.size_mm[a0]:g}, 0..{b.size_mm[a1]:g} mm)")
            pos = np.asarray(b.min_mm, float) * MM
            pos[a0] += s.at_mm[0] * MM
            pos[a1] += s.at_mm[1] * MM
            if s.side == "top":
                pos[n] += b.size_mm[n] * MM
            sites[s.name] = pos
    return Geometry(layout, sch, tuple(parts), sites, ((0.0, 0.0, 0.0), tuple(outer_hi)), cavity, volumes)
