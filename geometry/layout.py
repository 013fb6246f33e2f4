"""Read and check a layout file (TOML) into a frozen :class:`LayoutSpec`.

Every problem found raises :class:`imutherm.InputError` with a one-line message
naming the file, the part and the field, and what would be valid. Geometric
checks that need the built parts (overlaps, parts outside the cavity) are in
:mod:`imutherm.geometry.build`.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from pathlib import Path

from imutherm import InputError
from imutherm.geometry.electrical import ElectricalSpec, parse_electrical, rail_losses
from imutherm.geometry.layout_files import builtin_layouts, default_layout_path, resolve_layout  # noqa: F401
from imutherm.geometry.materials import load_library, material_from_table, register_materials
from imutherm.geometry.outline import MAX_OUTLINE_POINTS, coverage_from_table, outline_from_table  # noqa: F401
from imutherm.reference_data import parse_reference
from imutherm.textio import quote, read_text

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

AXES = ("x", "y", "z")
SCHEME_NAMES = ("air", "grease", "potted")

# Physical-sense bounds of every layout value, checked before any meshing (each with its reason).
#: ambient and fixture temperatures [degC]: the material data are near-room-temperature handbook values;
#: FR-4 boards soften at their glass transition (Tg 130-180 degC, IPC-4101) and the usual military
#: operating range is -55..125 degC, so anything outside -60..150 degC is outside the model's validity.
TEMPERATURE_RANGE_C = (-60.0, 150.0)
#: largest power of one part or component die [W]: a small IMU dissipates ~1-3 W in all; 100 W in one
#: part would take it far outside TEMPERATURE_RANGE_C (and 1e30 W would overflow the solver).
MAX_POWER_W = 100.0
#: largest length or coordinate [mm] of a "small" unit (the reference housing is 70 mm long)
MAX_LENGTH_MM = 1000.0
#: thinnest part dimension [mm] (1 um): thinner than any bond line modelled here (grease ~25-100 um);
#: the mesh places grid lines on every face (coordinates rounded to 1e-12 m), so thinner parts vanish.
MIN_SIZE_MM = 1e-3
#: largest contact conductance [W/m^2 K]: soldered and brazed joints reach ~1e5 (Incropera Table 3.2)
MAX_CONDUCTANCE_W_M2K = 1e6
#: largest layout file read [bytes]: 1 MiB, ~80 times the 12 kB reference layout; parsing that much TOML
#: takes ~1 s here, so no layout, however hostile, keeps a run busy before it is refused
MAX_LAYOUT_BYTES = 2**20
#: unknown keys quoted in one message at most
MAX_LISTED = 10


@dataclass(frozen=True)
class HousingSpec:
    """Aluminium box: outer size and wall, base and lid thickness [mm]."""

    outer_mm: tuple
    wall_mm: float
    base_mm: float
    lid_mm: float
    material: str


@dataclass(frozen=True)
class MountingSpec:
    """How the housing is held: ``fixture`` (a face bolted to a plate) or ``free``.

    contact_conductance_W_m2K : float [W/m^2 K] (fixture only)
    temperature_C : float [degC] temperature of the fixture plate
    """

    kind: str
    face: str
    contact_conductance_W_m2K: float
    temperature_C: float


@dataclass(frozen=True)
class BoardSpec:
    """A PCB: global lower corner and size [mm]; ``normal`` is its thin axis.

    The board is the rectangle, less what its true outline leaves out; an imported board also keeps:
    outline_mm : tuple of polylines or None, the true outline, each a tuple of (u, v) board-local points [mm];
        where they close into loops, the mesh's board is what the loops fill (cut-outs and slots are the
        cavity's fill, :mod:`imutherm.geometry.outline`)
    source : str or None, the file the board was imported from (and its format)
    copper_coverage : tuple of float [-], each copper layer's coverage measured from the file, front to back
    """

    name: str
    normal: str
    min_mm: tuple
    size_mm: tuple
    material: str
    outline_mm: tuple | None = None
    source: str | None = None
    merged_parts: tuple = ()
    copper_coverage: tuple = ()


@dataclass(frozen=True)
class MergedPartSpec:
    """A small unpowered part of an imported board, merged into the board material (drawings and IDF export):
    board-local centre (u, v) and size (u, v, height) [mm], side, footprint library name."""

    name: str
    side: str
    center_mm: tuple
    size_mm: tuple
    footprint: str | None = None


@dataclass(frozen=True)
class BoxSpec:
    """A plain box part (standoffs, brackets, card guides): global lower corner and size [mm].

    power_W : float [W]
    board_contact_W_m2K : float or None [W/m^2 K], contact conductance where this part
        touches a board (None: the model's ``standoff_contact_W_m2K``)
    """

    name: str
    min_mm: tuple
    size_mm: tuple
    material: str
    power_W: float
    board_contact_W_m2K: float | None = None


@dataclass(frozen=True)
class ComponentSpec:
    """A component on a board: package body, die and optional exposed pad.

    center_mm : (u, v) board-local centre [mm]
    size_mm : (u, v, height) footprint and height [mm]
    die_mm : (u, v, thickness) of the die, centred, ``die_base_mm`` above the board face [mm]
    exposed_pad : the die sits on a copper pad / tab soldered to the board
    pad_mm : (u, v) footprint of that pad [mm] (default: the die's)
    vias : a thermal-via field through the board under the pad; vias_material : its material (default the
        library's ``pcb_via_field``; an import computes one from the file's vias)
    power_W : float [W] dissipated in the die
    power_source : str, where ``power_W`` comes from (``layout power_W``, or the electrical design's
        formula for a rail's regulator without an explicit ``power_W``)
    footprint : str or None, the ECAD footprint it was imported from (information only)
    height_source : str or None, the height's source (``estimated: ...``: :mod:`imutherm.ecad.heights`)
    """

    name: str
    board: str
    side: str
    center_mm: tuple
    size_mm: tuple
    material: str
    die_mm: tuple | None
    die_base_mm: float
    exposed_pad: bool
    pad_mm: tuple | None
    vias: bool
    power_W: float
    axis: str | None
    power_source: str = "layout power_W"
    footprint: str | None = None
    vias_material: str = "pcb_via_field"
    height_source: str | None = None


@dataclass(frozen=True)
class SiteSpec:
    """A named temperature output: a part's centroid, or a point on a board face."""

    name: str
    part: str | None = None
    board: str | None = None
    side: str | None = None
    at_mm: tuple | None = None
    grade: str | None = None  # sensor grade of the site's chip (imutherm.imu.site_grades), None: not named


@dataclass(frozen=True)
class SchemeSpec:
    """A cooling scheme as a variant of the layout.

    fill : material of the free cavity space (air, potting compound)
    move_to_back : components moved to the other face of their board
    bond_material : material bridging moved components (and ``bond_in_place``) to the nearest wall (or None)
    max_bond_gap_mm : largest gap a bond may bridge [mm]
    bond_in_place : components bonded where they are, to the wall their outer face faces (a bottom-side part to
        the base)
    """

    name: str
    description: str
    fill: str
    move_to_back: tuple
    bond_material: str | None
    max_bond_gap_mm: float
    bond_in_place: tuple = ()


@dataclass(frozen=True)
class LayoutSpec:
    """Everything a layout file says, checked; lengths in mm as in the file."""

    name: str
    path: str
    description: str
    default_scheme: str
    ambient_C: float
    housing: HousingSpec
    mounting: MountingSpec
    boards: tuple
    parts: tuple
    components: tuple
    sites: tuple
    schemes: dict
    #: the supply and rails the regulators' powers follow from (None: every power is given explicitly)
    electrical: ElectricalSpec | None = None
    #: the layout's own materials (``[materials.<name>]``), beside the library's
    materials: tuple = ()
    #: the figures the model is set beside (imutherm.reference_data; None: none, no paper's figures either)
    reference_data: object = None

    def __post_init__(self):
        register_materials(self.materials, self.path)

    def __setstate__(self, state):  # unpickled in a worker process: its own materials known there too
        self.__dict__.update(state)
        register_materials(self.materials, self.path)

    def scheme(self, name: str | None) -> SchemeSpec:
        """The scheme ``name`` (default: the layout's default scheme)."""
        name = name or self.default_scheme
        if name not in self.schemes:
            raise InputError(f"{self.path}: unknown scheme {name!r}; valid: {', '.join(self.schemes)}")
        return self.schemes[name]


# ---------------------------------------------------------------- field checks
SIZE_BOUNDS = (MIN_SIZE_MM, MAX_LENGTH_MM, "mm")
TEMPERATURE_BOUNDS = (*TEMPERATURE_RANGE_C, "degC")
POWER_BOUNDS = (0.0, MAX_POWER_W, "W")


class _Table:
    """Reads fields of one TOML table, with the file and the part in every message."""

    def __init__(self, path: str, where: str, table, allowed: dict):
        self.path, self.where = path, where
        if not isinstance(table, dict):
            self.fail(None, f"must be a table, got {type(table).__name__}")
        unknown = sorted(set(table) - set(allowed))
        if unknown:
            listed = ", ".join(quote(k, 60) for k in unknown[:MAX_LISTED])
            more = f" and {len(unknown) - MAX_LISTED} more" if len(unknown) > MAX_LISTED else ""
            self.fail(None, f"unknown key(s) {listed}{more}; valid: {', '.join(allowed)}")
        self.table, self.allowed = table, allowed

    def fail(self, field, msg):
        loc = f"{self.path}: {self.where}" + (f": field {quote(field, 60)}" if field else "")
        msg = str(msg)
        if len(msg) > 600:  # a huge value quoted in full would make a megabyte "line"
            msg = f"{msg[:600]}... ({len(msg) - 600} more characters)"
        raise InputError(f"{loc}: {msg}")

    def bounded(self, field, value, lo, hi, unit):
        """``value`` unless outside [lo, hi] (then InputError naming the field and the valid range)."""
        if value is not None and not lo <= value <= hi:
            self.fail(field, f"{value!r} {unit} is outside the valid range {lo:g}..{hi:g} {unit}")
        return value

    def get(self, field, default=...):
        if field not in self.table:
            if default is ...:
                self.fail(field, "is required")
            return default
        return self.table[field]

    def number(self, field, default=..., *, positive=False, nonneg=False, bounds=None):
        """A finite number; ``bounds`` = (lo, hi, unit) of physical sense."""
        value = self.get(field, default)
        if value is None:
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            self.fail(field, f"must be a finite number, got {quote(value)}")
        if positive and value <= 0:
            self.fail(field, f"must be > 0, got {value!r}")
        if nonneg and value < 0:
            self.fail(field, f"must be >= 0, got {value!r}")
        if bounds is not None:
            self.bounded(field, value, *bounds)
        return float(value)

    def vector(self, field, n, default=..., *, positive=False):
        """A list of ``n`` finite numbers [mm]: coordinates within +-MAX_LENGTH_MM; ``positive``: sizes
        within MIN_SIZE_MM..MAX_LENGTH_MM."""
        value = self.get(field, default)
        if value is None:
            return None
        if not isinstance(value, list) or len(value) != n:
            self.fail(field, f"must be a list of {n} numbers, got {quote(value)}")
        for v in value:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                self.fail(field, f"must hold finite numbers, got {quote(v)}")
            if positive and v <= 0:
                self.fail(field, f"sizes must be > 0, got {value!r}")
            if positive:
                self.bounded(field, v, *SIZE_BOUNDS)
            else:
                self.bounded(field, v, -MAX_LENGTH_MM, MAX_LENGTH_MM, "mm")
        return tuple(float(v) for v in value)

    def string(self, field, default=..., *, choices=None):
        value = self.get(field, default)
        if value is None:
            return None
        if not isinstance(value, str) or not value:
            self.fail(field, f"must be a non-empty string, got {quote(value)}")
        if choices is not None and value not in choices:
            self.fail(field, f"unknown value {quote(value)}; valid: {', '.join(choices)}")
        return value

    def material(self, field, materials, default=...):
        name = self.string(field, default)
        if name is not None and name not in materials:
            self.fail(field, f"unknown material {quote(name)}; valid: {', '.join(sorted(materials))}")
        return name


_TOP = {"name": "layout name", "description": "text", "default_scheme": "scheme name",
        "environment": "table", "housing": "table", "mounting": "table", "boards": "array of tables",
        "parts": "array of tables", "components": "array of tables", "sites": "table",
        "schemes": "table", "electrical": "table", "rails": "array of tables", "materials": "table",
        "reference_data": "table"}


def _table_array(top: _Table, key: str) -> list:
    """The ``[[key]]`` entries of the layout (none if absent); anything but an array is an error."""
    value = top.get(key, [])
    if not isinstance(value, list):
        top.fail(key, f"must be an array of tables ([[{key}]] entries), got {type(value).__name__} {value!r}")
    return value


def _named_tables(top: _Table, key: str, form: str) -> dict:
    """The ``[key]`` table of named entries (empty if absent); anything but a table is an error."""
    value = top.get(key, {})
    if not isinstance(value, dict):
        top.fail(key, f"must be a table of named {key} ({form}), got {type(value).__name__} {value!r}")
    return value


def load_layout(path: str | Path | None = None) -> LayoutSpec:
    """Read and check a layout TOML file (default: the built-in reference unit).

    ``path`` is a file, or the name of a built-in layout (``imu_cardguide``; see
    :func:`builtin_layouts`). Raises InputError naming the file, the part and the
    field on any problem.

    Examples
    --------
    >>> from imutherm.geometry.layout import load_layout
    >>> layout = load_layout("imu_reference")          # or a path to your own TOML file
    >>> layout.name, layout.ambient_C, list(layout.schemes)
    ('imu_reference', 70.0, ['air', 'grease', 'potted'])
    >>> [site.name for site in layout.sites]
    ['gyro_x', 'gyro_y', 'gyro_z', 'accel_x', 'accel_y', 'accel_z', 'tp1', 'tp2', 'tp3']
    >>> load_layout("no_such_unit.toml")
    Traceback (most recent call last):
    ...
    imutherm.InputError: no_such_unit.toml: layout file not found; built-in layouts: imu_cardguide, imu_reference
    """
    path = resolve_layout(path)
    spath = str(path)
    if not path.exists():
        raise InputError(f"{spath}: layout file not found; built-in layouts: {', '.join(builtin_layouts())}")
    text = read_text(path, "layout file", MAX_LAYOUT_BYTES)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{spath}: not valid TOML: {exc}") from None
    except RecursionError:
        raise InputError(f"{spath}: not valid TOML: arrays or tables nested too deep for the parser") from None
    return parse_layout(data, spath)


def parse_layout(data: dict, path: str = "<layout>") -> LayoutSpec:
    """Check a layout already read into a dict (see :func:`load_layout`); one parser per table, in file order."""
    top = _Table(path, "layout", data, _TOP)
    own = _parse_materials(path, top)
    mats = {**load_library(), **{m.name: m for m in own}}
    ambient = _parse_environment(path, top)
    housing = _parse_housing(path, top, mats)
    mounting = _parse_mounting(path, top, ambient)
    names = _Names(path)
    boards = _parse_boards(path, top, mats, names)
    parts = _parse_parts(path, top, mats, names)
    components = _parse_components(path, top, mats, names, boards)
    electrical = parse_electrical(path, top, _Table, {c.name: c for c in components})
    components = _component_powers(path, components, electrical)
    sites = _parse_sites(path, top, names, boards)
    schemes = _parse_schemes(path, top, mats, components)
    default = top.string("default_scheme", next(iter(schemes)))
    if default not in schemes:
        top.fail("default_scheme", f"unknown scheme {default!r}; valid: {', '.join(schemes)}")
    return LayoutSpec(top.string("name", Path(path).stem), path, top.string("description", ""), default,
                      ambient, housing, mounting, tuple(boards), tuple(parts), tuple(components),
                      tuple(sites), schemes, electrical, own, parse_reference(path, data.get("reference_data")))


def _parse_materials(path, top) -> tuple:
    """``[materials.<name>]``: the layout's own materials (the library's fields, a ``source`` required)."""
    lib = load_library()
    out = []
    for name, table in _named_tables(top, "materials", "[materials.<name>] tables").items():
        if name in lib:
            top.fail("materials", f"{name!r} is a library material; give yours another name")
        if not isinstance(table, dict):
            top.fail("materials", f"[materials.{name}] must be a table, got {type(table).__name__}")
        out.append(material_from_table(name, table, f"{path}: [materials.{name}]"))
    return tuple(out)


def _component_powers(path, components, electrical) -> list:
    """Each rail regulator without an explicit ``power_W`` gets its loss from the electrical design at the
    nominal supply; an explicit ``power_W`` wins (a sweep or a measurement sets it). Every other
    component must state its ``power_W``."""
    losses = rail_losses(electrical, path=path) if electrical is not None else {}
    out = []
    for c in components:
        if c.power_W is None:
            if c.name not in losses:
                raise InputError(f"{path}: component {c.name!r}: field 'power_W' is required (or make the part "
                                 f"a rail's regulator in [[rails]], whose loss then follows from the supply)")
            loss = losses[c.name]
            c = replace(c, power_W=float(loss.loss_W), power_source=f"electrical: rail {loss.rail!r}, {loss.formula}")
        elif c.name in losses:
            c = replace(c, power_source=f"layout power_W (the electrical design gives {losses[c.name].loss_W:.4g} W)")
        out.append(c)
    return out


class _Names:
    """The one namespace of boards, parts and components (and their derived ``_die``/``_pad``/``_vias``)."""

    def __init__(self, path: str):
        self.path = path
        self.where = {r: "the housing (reserved name)" for r in ("housing", "lid", "fill")}

    def claim(self, name, where):
        if name in self.where:
            raise InputError(f"{self.path}: {where}: duplicate name {name!r} (also used by {self.where[name]})")
        self.where[name] = where

    def __contains__(self, name):
        return name in self.where

    def __iter__(self):
        return iter(self.where)


def _parse_environment(path, top) -> float:
    """``[environment]``: the ambient temperature [°C]."""
    env = _Table(path, "[environment]", top.get("environment"), {"ambient_C": "degC"})
    return env.number("ambient_C", bounds=TEMPERATURE_BOUNDS)


def _parse_housing(path, top, mats) -> HousingSpec:
    """``[housing]``: outer size, wall/base/lid thicknesses [mm] and material; they must leave a cavity."""
    h = _Table(path, "[housing]", top.get("housing"),
               {"outer_mm": "3 lengths", "wall_mm": "mm", "base_mm": "mm", "lid_mm": "mm", "material": "name"})
    housing = HousingSpec(h.vector("outer_mm", 3, positive=True), h.number("wall_mm", positive=True, bounds=SIZE_BOUNDS),
                          h.number("base_mm", positive=True, bounds=SIZE_BOUNDS),
                          h.number("lid_mm", positive=True, bounds=SIZE_BOUNDS),
                          h.material("material", mats))
    ox, oy, oz = housing.outer_mm
    if 2 * housing.wall_mm >= min(ox, oy) or housing.base_mm + housing.lid_mm >= oz:
        h.fail("wall_mm", "walls, base and lid leave no cavity inside outer_mm")
    return housing


def _parse_mounting(path, top, ambient) -> MountingSpec:
    """``[mounting]``: fixture (contact conductance, temperature; default the ambient) or free."""
    m = _Table(path, "[mounting]", top.get("mounting"),
               {"kind": "fixture|free", "face": "bottom|top", "contact_conductance_W_m2K": "W/m^2 K",
                "temperature_C": "degC"})
    kind = m.string("kind", choices=("fixture", "free"))
    return MountingSpec(kind, m.string("face", "bottom", choices=("bottom", "top")),
                        m.number("contact_conductance_W_m2K", 0.0 if kind == "free" else ...,
                                 positive=kind == "fixture", nonneg=True,
                                 bounds=(0.0, MAX_CONDUCTANCE_W_M2K, "W/m^2 K")),
                        m.number("temperature_C", ambient, bounds=TEMPERATURE_BOUNDS))


def _parse_boards(path, top, mats, names: _Names) -> list:
    """``[[boards]]``: name, normal axis, corner and size [mm] (thinnest along the normal), material."""
    boards = []
    for i, t in enumerate(_table_array(top, "boards")):
        b = _Table(path, f"boards[{i}]", t, {"name": "str", "normal": "x|y|z", "min_mm": "3 numbers",
                                              "size_mm": "3 sizes", "material": "name",
                                              "outline_mm": "polylines of (u, v)", "source": "text",
                                              "copper_coverage": "fractions, front to back",
                                              "merged_parts": "[{ name, side, center_mm, size_mm, footprint }]"})
        b.where = f"board {quote(b.string('name'), 60)}"
        spec = BoardSpec(b.string("name"), b.string("normal", choices=AXES), b.vector("min_mm", 3),
                         b.vector("size_mm", 3, positive=True), b.material("material", mats))
        b.where = f"board {quote(spec.name, 60)}"
        if spec.size_mm[AXES.index(spec.normal)] != min(spec.size_mm):
            b.fail("size_mm", f"the size along the normal {spec.normal!r} must be the board thickness (smallest size)")
        spec = replace(spec, outline_mm=_outline(b, spec), source=b.string("source", None),
                       copper_coverage=coverage_from_table(b.get("copper_coverage", None), b.fail),
                       merged_parts=_merged_parts(path, b, spec))
        names.claim(spec.name, b.where)
        boards.append(spec)
    return boards


def _outline(b: _Table, board: BoardSpec):
    """``outline_mm`` checked (:func:`imutherm.geometry.outline.outline_from_table`)."""
    a0, a1 = (a for a in range(3) if a != AXES.index(board.normal))
    return outline_from_table(b.get("outline_mm", None), (board.size_mm[a0], board.size_mm[a1]), b.fail)


def _merged_parts(path, b: _Table, board: BoardSpec) -> tuple:
    """``merged_parts``: the imported parts merged into the board (drawings and export only)."""
    value = b.get("merged_parts", [])
    if not isinstance(value, list):
        b.fail("merged_parts", "must be a list of { name, side, center_mm, size_mm, footprint } tables")
    out = []
    for i, t in enumerate(value):
        m = _Table(path, f"board {quote(board.name, 60)}: merged_parts[{i}]", t,
                   {"name": "str", "side": "top|bottom", "center_mm": "(u, v)", "size_mm": "(u, v, height)",
                    "footprint": "text"})
        out.append(MergedPartSpec(m.string("name"), m.string("side", choices=("top", "bottom")),
                                  m.vector("center_mm", 2), m.vector("size_mm", 3, positive=True),
                                  m.string("footprint", None)))
    return tuple(out)


def _parse_parts(path, top, mats, names: _Names) -> list:
    """``[[parts]]``: free boxes (name, corner and size [mm], material, power [W], optional board contact)."""
    parts = []
    for i, t in enumerate(_table_array(top, "parts")):
        p = _Table(path, f"parts[{i}]", t, {"name": "str", "min_mm": "3 numbers", "size_mm": "3 sizes",
                                             "material": "name", "power_W": "W", "board_contact_W_m2K": "W/m^2 K"})
        p.where = f"part {quote(p.string('name'), 60)}"
        spec = BoxSpec(p.string("name"), p.vector("min_mm", 3), p.vector("size_mm", 3, positive=True),
                       p.material("material", mats), p.number("power_W", 0.0, nonneg=True, bounds=POWER_BOUNDS),
                       p.number("board_contact_W_m2K", None, positive=True))
        names.claim(spec.name, f"part {quote(spec.name, 60)}")
        parts.append(spec)
    return parts


def _parse_components(path, top, mats, names: _Names, boards) -> list:
    """``[[components]]``: packages on a board side, with optional die, exposed pad and via field."""
    board_by_name = {b.name: b for b in boards}
    components = []
    for i, t in enumerate(_table_array(top, "components")):
        c = _Table(path, f"components[{i}]", t,
                   {"name": "str", "board": "board name", "side": "top|bottom", "center_mm": "(u, v)",
                    "size_mm": "(u, v, height)", "material": "name", "die_mm": "(u, v, thickness)",
                    "die_base_mm": "mm", "exposed_pad": "bool", "pad_mm": "(u, v)", "vias": "bool",
                    "vias_material": "name", "power_W": "W", "axis": "x|y|z", "footprint": "text",
                    "height_source": "text"})
        name = c.string("name")
        c.where = f"component {quote(name, 60)}"
        board = c.string("board")
        if board not in board_by_name:
            c.fail("board", f"unknown board {board!r}; valid: {', '.join(board_by_name) or '(none defined)'}")
        size = c.vector("size_mm", 3, positive=True)
        die = c.vector("die_mm", 3, None, positive=True)
        die_base = c.number("die_base_mm", 0.2, nonneg=True, bounds=(0.0, MAX_LENGTH_MM, "mm"))
        if die is not None and (die[0] > size[0] or die[1] > size[1] or die_base + die[2] > size[2]):
            c.fail("die_mm", f"die {die} with base {die_base} mm does not fit inside the package {size}")
        pad = c.get("exposed_pad", False)
        if not isinstance(pad, bool):
            c.fail("exposed_pad", f"must be true or false, got {pad!r}")
        if pad and (die is None or die_base <= 0):
            c.fail("exposed_pad", "an exposed pad needs a die and die_base_mm > 0 (the pad thickness)")
        pad_mm = c.vector("pad_mm", 2, None, positive=True)
        if pad_mm is not None and not pad:
            c.fail("pad_mm", "needs exposed_pad = true")
        if pad_mm is not None and (pad_mm[0] < die[0] or pad_mm[1] < die[1] or pad_mm[0] > size[0] or pad_mm[1] > size[1]):
            c.fail("pad_mm", f"pad {pad_mm} must hold the die {die[:2]} and fit the footprint {size[:2]}")
        vias = c.get("vias", False)
        if not isinstance(vias, bool):
            c.fail("vias", f"must be true or false, got {vias!r}")
        if vias and not pad:
            c.fail("vias", "a via field sits under an exposed pad: set exposed_pad = true")
        if "vias_material" in t and not vias:
            c.fail("vias_material", "needs vias = true")
        spec = ComponentSpec(name, board, c.string("side", choices=("top", "bottom")), c.vector("center_mm", 2),
                             size, c.material("material", mats), die, die_base, pad,
                             (pad_mm or (die[:2] if pad else None)), vias,
                             c.number("power_W", None, nonneg=True, bounds=POWER_BOUNDS),
                             c.string("axis", None, choices=AXES), footprint=c.string("footprint", None),
                             vias_material=c.material("vias_material", mats, "pcb_via_field"),
                             height_source=c.string("height_source", None))
        names.claim(name, c.where)
        for sub in ("_die", "_pad", "_vias"):
            names.claim(name + sub, c.where)
        components.append(spec)
    return components


def _parse_sites(path, top, names: _Names, boards) -> list:
    """``[sites]``: each a part's centroid (``part``) or a point on a board face (``board``, ``side``, ``at_mm``)."""
    board_by_name = {b.name: b for b in boards}
    sites = []
    for name, t in _named_tables(top, "sites", "[sites] with name = { ... } lines").items():
        s = _Table(path, f"site {quote(name, 60)}", t, {"part": "part name", "board": "board name",
                                                "side": "top|bottom", "at_mm": "(u, v)", "grade": "sensor grade"})
        grade = None
        if "grade" in t:  # the chip's grade (imutherm import writes it); its name is checked against the sensor
            grade = s.string("grade").strip().lower()  # library where the study takes it (imu.site_grades)
            if not re.fullmatch(r"[a-z0-9_]+(\+[a-z0-9_]+)?", grade):
                s.fail("grade", f"{grade!r} is not a grade name (a sensor-library key, or GYRO+ACCEL)")
        if "part" in t:
            extra = [k for k in ("board", "side", "at_mm") if k in t]
            if extra:
                s.fail(extra[0], "a site is either a part's centroid (part) or a point on a board face "
                                 f"(board, side, at_mm), not both: remove {' and '.join(map(repr, extra))} or 'part'")
            part = s.string("part")
            if part not in names or part == "fill":
                s.fail("part", f"unknown part {part!r}; valid: {', '.join(sorted(names))}")
            sites.append(SiteSpec(name, part=part, grade=grade))
        else:
            if "board" not in t:
                s.fail(None, "needs 'part' (a part's centroid) or 'board' with 'at_mm' (a point on a board face)")
            board = s.string("board")
            if board not in board_by_name:
                s.fail("board", f"unknown board {board!r}; valid: {', '.join(board_by_name)}")
            sites.append(SiteSpec(name, board=board, side=s.string("side", "top", choices=("top", "bottom")),
                                  at_mm=s.vector("at_mm", 2), grade=grade))
    return sites


def _parse_schemes(path, top, mats, components) -> dict:
    """``[schemes.<name>]``: fill material, components moved to the back, bond material and gap; at least one."""
    comp_by_name = {c.name: c for c in components}
    schemes = {}
    for name, t in _named_tables(top, "schemes", "[schemes.<name>] tables").items():
        s = _Table(path, f"scheme {quote(name, 60)}", t, {"description": "text", "fill": "material",
                                                  "move_to_back": "component names", "bond_in_place": "component names",
                                                  "bond_material": "material", "max_bond_gap_mm": "mm"})
        if name not in SCHEME_NAMES:
            s.fail(None, f"unknown scheme; valid: {', '.join(SCHEME_NAMES)}")
        lists = {key: s.get(key, []) for key in ("move_to_back", "bond_in_place")}
        for key, moved in lists.items():
            if not isinstance(moved, list):
                s.fail(key, f"must be a list of component names, got {moved!r}")
            for comp in moved:
                if not isinstance(comp, str):
                    s.fail(key, f"must be a list of component names (strings), got {comp!r} in {moved!r}")
                if comp not in comp_by_name:
                    s.fail(key, f"unknown component {comp!r}; valid: {', '.join(comp_by_name)}")
        schemes[name] = SchemeSpec(name, s.string("description", name), s.material("fill", mats),
                                   tuple(lists["move_to_back"]), s.material("bond_material", mats, None),
                                   s.number("max_bond_gap_mm", 2.0, positive=True, bounds=SIZE_BOUNDS),
                                   tuple(lists["bond_in_place"]))
    if not schemes:
        top.fail("schemes", f"at least one scheme is required; valid names: {', '.join(SCHEME_NAMES)}")
    return schemes
