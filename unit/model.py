"""From a layout's geometry and mesh to a :class:`ThermalProblem`: the unit's physics, switchable.

``build_problem(geometry, grid, options)`` sets, per cell, the conductivity
(boards orthotropic along their normal), the volumetric heat capacity and the
die powers, and, per outer face, the boundary laws: natural convection and
radiation to the ambient, or contact with the mounting fixture. Every law is a
named, parameterised switch in :class:`ModelOptions`, so a correlation
workflow can add or refit an effect by name.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from imutherm import InputError
from imutherm.geometry.build import Geometry
from imutherm.geometry.grid import FACE_NAMES, TensorGrid
from imutherm.geometry.layout import AXES
from imutherm.geometry.materials import Material, get_material
from imutherm.thermal.cavity_radiation import DEFAULT_PATCH_MM, DEFAULT_RAYS
from imutherm.unit.cavity_laws import (CAVITY_LAWS as LAWS, DEFAULT_CAVITY_LAW, CavitySetting, CavityTerms, cavity_law,
                                       cavity_law_of)
from imutherm.thermal.problem import (SIGMA, ZERO_C_K, Contact, Convection, NaturalConvection, Radiation,
                                      ThermalProblem, natural_convection_h)

#: Al/Al interface with air, 10 um roughness, 1e5 N/m^2: R'' = 2.75e-4 m^2 K/W
#: (Incropera & DeWitt, 6th ed., Table 3.1b) -> h = 3636 W/m^2 K. Used for the lid joint.
AL_AL_AIR_JOINT_W_M2K = 1.0 / 2.75e-4
#: Al/Al interface filled with silicone oil, same roughness and pressure: R'' = 0.525e-4 m^2 K/W
#: (Incropera & DeWitt, 6th ed., Table 3.1b) -> h = 19 048 W/m^2 K. Used on each face of a grease
#: bond line (the grease wets the surface like the oil; its bulk is the bond part itself).
GREASE_WETTED_JOINT_W_M2K = 1.0 / 0.525e-4

_FACE_ORIENTATION = {"xmin": "vertical", "xmax": "vertical", "ymin": "vertical", "ymax": "vertical",
                     "zmin": "down", "zmax": "up"}
_MOUNT_FACE = {"bottom": "zmin", "top": "zmax"}


@dataclass(frozen=True)
class Interface:
    """A contact conductance between two touching parts [W/m^2 K].

    Applied to the cell layer of ``part_b`` that touches ``part_a``: along the
    normal of the shared face its conductivity becomes ``w / (w/k + 1/h)``
    (w: cell width), the exact series value for heat crossing the interface.
    """

    part_a: str
    part_b: str
    conductance_W_m2K: float
    source: str = ""


@dataclass(frozen=True)
class ModelOptions:
    """The physical laws of the unit model, each switchable and parameterised.

    exterior : ``natural`` (face-orientation correlations, h depends on the
        surface rise), ``fixed`` (h = ``h_fixed_W_m2K`` on every free face) or ``none``
    h_fixed_W_m2K : float [W/m^2 K]
    convection_scale : float [-], factor on the natural-convection coefficient C of every
        exterior face (1: the handbook correlation; a correlation's scatter is ~±25 %)
    radiation : bool, exterior radiation eps sigma (T^4 - T_amb^4)
    emissivity : float or None [-], override of the housing material's emissivity
    mounting_conductance_W_m2K : float or None [W/m^2 K], override of the layout's
    cavity_radiation : bool, radiation inside the cavity air (False: none, whatever ``cavity_law``)
    cavity_law : ``s2s`` (default: surface-to-surface exchange between the faces that bound each air
        region, view factors and radiosity: :mod:`imutherm.thermal.cavity_radiation`), ``effective`` (an
        effective conductivity of the air across its gaps, see :func:`cavity_radiation_conductivity`; known
        bias: it conducts along thin slots as well as across them, so it runs the reference unit's air
        scheme cool, tp1 16.9 K against 24.1 K with s2s and the paper's measured > 20 K) or ``none``
    cavity_emissivity : float [-], effective pair emissivity of facing surfaces (``effective`` law)
    cavity_law_blend : float [-] in [0, 1], weight w of the ``effective`` law in a blend with the ``s2s`` law
        (``cavity_law 's2s'`` only): the exchange times (1 - w) plus w times the air's effective radiative
        conductivity. 0 (default): the s2s law alone; 1: the effective law alone. A model-form device, not a
        law of its own: the cavity's radiation is known only to lie near or between the two verified laws
        (the correlation re-tunes w where the model's own form does not explain the data)
    cavity_surface_emissivity : float or None [-], emissivity of every interior surface (``s2s`` law);
        None: each bounding part's material emissivity (``DEFAULT_INTERIOR_EMISSIVITY`` where it has none)
    cavity_wall_emissivity : float or None [-], emissivity of the housing's and the lid's inner faces
        (``s2s`` law; wins over ``cavity_surface_emissivity`` there); None: as the other surfaces
    cavity_patch_mm : float [mm], patch edge of the ``s2s`` law
    cavity_max_patches : int or None, with the ``s2s`` law: the patch edge grows from ``cavity_patch_mm`` (up to
        10 mm) until the cavity has at most this many patches (:func:`~imutherm.thermal.cavity_radiation.
        choose_patch_mm`; the CLI's default unless ``--cavity-patch-mm`` is given); None: ``cavity_patch_mm`` exactly
    cavity_rays : int, rays per patch of the ``s2s`` view factors (seeded, reproducible)
    interfaces : tuple of Interface, contact conductances between named parts
    bond_contact_W_m2K : float or None [W/m^2 K], contact conductance on both faces
        of every grease bond line (package/bond and bond/wall); None: none
    standoff_contact_W_m2K : float or None [W/m^2 K], contact conductance where a
        plain part (standoff, bracket) touches the housing, the lid or a board; None: none
        (a part's own ``board_contact_W_m2K`` in the layout overrides it towards boards)
    materials : tuple of Material, property sets used instead of the library entries of
        the same name (a sweep varies a material this way without touching the library)
    contact_layers : bool, a contact conductance as a thin solid layer (default False: the touching cell
        layer's conductivity *along the normal* takes the series resistance, :class:`Interface`): True sets every
        component of the touching cells to the series value, the form of a resolved solid layer when the grid
        has a thin cell layer there (:func:`imutherm.studies.correlation.form_generator.refine_contact_layers`); a
        model-form device of the correlation campaign's generator, not a law of the default model
    """

    exterior: str = "natural"
    h_fixed_W_m2K: float = 10.0
    convection_scale: float = 1.0
    radiation: bool = True
    emissivity: float | None = None
    mounting_conductance_W_m2K: float | None = None
    cavity_radiation: bool = True
    # boards and packages ~0.9, anodised housing 0.84: 1/(1/0.9 + 1/0.84 - 1) = 0.77
    cavity_emissivity: float = 0.77
    # s2s: the effective law is optimistic (reference unit, air, tp1: 16.9 K effective, 24.1 K s2s, paper
    # measured > 20 K; the effective conductivity carries heat along thin slots as well as across them)
    cavity_law: str = DEFAULT_CAVITY_LAW
    cavity_law_blend: float = 0.0
    cavity_surface_emissivity: float | None = None
    cavity_wall_emissivity: float | None = None
    cavity_patch_mm: float = DEFAULT_PATCH_MM
    cavity_max_patches: int | None = None
    cavity_rays: int = DEFAULT_RAYS
    interfaces: tuple = field(default_factory=lambda: (
        Interface("housing", "lid", AL_AL_AIR_JOINT_W_M2K, "screwed lid, Al/Al with air: Incropera Table 3.1b"),))
    bond_contact_W_m2K: float | None = GREASE_WETTED_JOINT_W_M2K
    # assumed: a dry screwed joint like the lid's; the nylon's own resistance (2.7 mm / 0.25 W/m K)
    # is ~40x larger, so this value hardly matters
    standoff_contact_W_m2K: float | None = AL_AL_AIR_JOINT_W_M2K
    materials: tuple = ()
    contact_layers: bool = False

    def __post_init__(self):
        if self.exterior not in ("natural", "fixed", "none"):
            raise InputError(f"model option 'exterior': unknown value {self.exterior!r}; valid: natural, fixed, none")
        if not (np.isfinite(self.convection_scale) and self.convection_scale > 0):
            raise InputError(f"model option 'convection_scale' must be a finite number > 0, got {self.convection_scale!r}")
        for name in ("h_fixed_W_m2K", "mounting_conductance_W_m2K"):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v >= 0):
                raise InputError(f"model option {name!r} must be a finite number >= 0, got {v!r}")
        for name in ("bond_contact_W_m2K", "standoff_contact_W_m2K"):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise InputError(f"model option {name!r} must be a finite number > 0 or None (off), got {v!r}")
        if self.cavity_law not in LAWS:
            raise InputError(f"model option 'cavity_law': unknown value {self.cavity_law!r}; "
                             f"valid: {', '.join(LAWS)}")
        if not (isinstance(self.cavity_law_blend, (int, float, np.floating)) and 0.0 <= self.cavity_law_blend <= 1.0):
            raise InputError(f"model option 'cavity_law_blend' must be a number in [0, 1] (0: s2s, 1: effective), "
                             f"got {self.cavity_law_blend!r}")
        if self.cavity_law_blend and not cavity_law(self.cavity_law).blendable:
            blendable = " or ".join(repr(n) for n, law in LAWS.items() if law.blendable)
            raise InputError(f"model option 'cavity_law_blend' = {self.cavity_law_blend:g} blends the effective law "
                             f"into the s2s law; it needs cavity_law {blendable}, not {self.cavity_law!r}")
        if not (np.isfinite(self.cavity_patch_mm) and self.cavity_patch_mm > 0):
            raise InputError(f"model option 'cavity_patch_mm' must be a finite number > 0 [mm], "
                             f"got {self.cavity_patch_mm!r}")
        if self.cavity_max_patches is not None and not (
                isinstance(self.cavity_max_patches, (int, np.integer)) and self.cavity_max_patches >= 1):
            raise InputError(f"model option 'cavity_max_patches' must be an integer >= 1 or None (the patch edge "
                             f"exactly), got {self.cavity_max_patches!r}")
        if not (isinstance(self.cavity_rays, (int, np.integer)) and self.cavity_rays >= 16):
            raise InputError(f"model option 'cavity_rays' must be an integer >= 16, got {self.cavity_rays!r}")
        for name in ("emissivity", "cavity_emissivity", "cavity_surface_emissivity", "cavity_wall_emissivity"):
            v = getattr(self, name)
            if v is not None and not (0.0 <= v <= 1.0):
                raise InputError(f"model option {name!r}: emissivity must be in [0, 1], got {v!r}")
        for m in self.materials:
            if not isinstance(m, Material):
                raise InputError(f"model option 'materials' must hold Material entries, got {m!r}")
            get_material(m.name)  # an override replaces a library entry: the name must exist

    def material(self, name: str) -> Material:
        """The material ``name``: its override in ``materials`` if given, else the library's."""
        for m in self.materials:
            if m.name == name:
                return m
        return get_material(name)

    def with_(self, **changes) -> "ModelOptions":
        """A copy with some options changed."""
        return replace(self, **changes)


def cavity_radiation_conductivity(run_length, mean_T_C: float, emissivity: float):
    """Effective conductivity of radiation across an enclosed gap [W/m K].

    Two facing grey plates a distance ``run_length`` [m] apart exchange
    q = sigma (T1^4 - T2^4) / (1/e1 + 1/e2 - 1) (Incropera, eq. 13.24);
    linearised about ``mean_T_C`` this is h_r dT with h_r = 4 sigma e T^3, i.e.
    a conductivity h_r * run_length across the gap. Side walls' view factors
    are neglected (exact for wide gaps between parallel plates).
    """
    T = mean_T_C + ZERO_C_K
    return 4.0 * SIGMA * emissivity * T**3 * np.asarray(run_length, float)


def _run_lengths(mask: np.ndarray, widths: np.ndarray, axis: int) -> np.ndarray:
    """For each True cell, the length [m] of the contiguous True run through it along ``axis``."""
    m = np.moveaxis(mask, axis, -1)
    w = np.broadcast_to(widths, m.shape)
    out = np.zeros(m.shape)
    n = m.shape[-1]
    run_id = np.cumsum(np.concatenate([m[..., :1], m[..., 1:] & ~m[..., :-1]], axis=-1), axis=-1) * m
    flat_rows = run_id.reshape(-1, n)
    wflat = w.reshape(-1, n)
    keys = (np.arange(flat_rows.shape[0])[:, None] * (n + 1) + flat_rows)[flat_rows > 0]
    sums = np.bincount(keys, weights=wflat[flat_rows > 0])
    res = out.reshape(-1, n)
    res[flat_rows > 0] = sums[keys]
    return np.moveaxis(res.reshape(m.shape), -1, axis)


def _touch(a, b, tol: float = 1e-9) -> bool:
    """True if part ``a`` and part ``b`` share a face patch of non-zero area.

    ``b`` may be the housing, a box with a hole (the cavity): then ``a``, inside
    the hole, touches it where one of its faces lies on the hole's boundary.
    """
    if b.hole is not None:
        lo, hi = b.hole
        return any(abs(a.lo[i] - lo[i]) <= tol or abs(a.hi[i] - hi[i]) <= tol for i in range(3))
    gaps = [max(a.lo[i], b.lo[i]) - min(a.hi[i], b.hi[i]) for i in range(3)]  # > 0 apart, < 0 overlapping
    return sum(abs(g) <= tol for g in gaps) == 1 and all(g <= tol for g in gaps)


def unit_interfaces(geometry: Geometry, options: ModelOptions) -> tuple:
    """Every contact conductance of the unit: ``options.interfaces`` plus those derived from the parts.

    Each grease bond line gets ``bond_contact_W_m2K`` towards its package and towards
    the wall it bridges to; each plain part (standoff, card guide) gets ``standoff_contact_W_m2K``
    towards the housing, the lid and the boards it touches, except that a part whose
    layout entry sets ``board_contact_W_m2K`` gets that value towards the boards (a
    board edge in a card-guide slot is not a screwed joint).
    """
    out = list(options.interfaces)
    walls = [p for p in geometry.parts if p.kind in ("housing", "lid")]
    boards = [p for p in geometry.parts if p.kind == "board"]
    for p in geometry.parts:
        if p.kind == "bond" and options.bond_contact_W_m2K:
            for other in [geometry.part(p.parent)] + walls:
                if _touch(p, other):
                    out.append(Interface(other.name, p.name, options.bond_contact_W_m2K,
                                         "grease-wetted Al joint: Incropera Table 3.1b"))
        elif p.kind == "box":
            for other in walls + boards:
                own = other.kind == "board" and p.board_contact_W_m2K is not None
                h = p.board_contact_W_m2K if own else options.standoff_contact_W_m2K
                if h and _touch(p, other):
                    out.append(Interface(other.name, p.name, h, "layout: the part's board_contact_W_m2K" if own
                                         else "dry screwed joint (assumed, as the lid's)"))
    return tuple(out)


def _apply_interface(k: np.ndarray, grid: TensorGrid, itf: Interface, layer: bool = False) -> None:
    """The interface's series resistance in the cells of ``part_b`` that touch ``part_a``: along the normal
    (default), or in every direction (``layer``: the cells are a thin solid layer, see ``contact_layers``)."""
    names = grid.part_names
    for p in (itf.part_a, itf.part_b):
        if p not in names:
            raise InputError(f"interface {itf.part_a!r}/{itf.part_b!r}: unknown part {p!r}; valid: {', '.join(names)}")
    if not itf.conductance_W_m2K > 0:
        raise InputError(f"interface {itf.part_a!r}/{itf.part_b!r}: conductance must be > 0 [W/m^2 K]")
    a, b = names.index(itf.part_a), names.index(itf.part_b)
    cp = grid.cell_part
    widths = grid.cell_sizes()
    touched = 0
    done = np.zeros(cp.shape, bool)  # a layer's cell takes the series value once (at a corner it touches twice)
    for axis in range(3):
        for shift in (1, -1):
            nb = np.roll(cp, shift, axis=axis)
            edge = [slice(None)] * 3
            edge[axis] = 0 if shift == 1 else -1
            nb[tuple(edge)] = -1  # no wrap-around
            cells = (cp == b) & (nb == a)
            if not cells.any():
                continue
            if layer:
                cells &= ~done
                done |= cells
            touched += int(cells.sum())
            w = np.broadcast_to(np.expand_dims(widths[axis], [i for i in range(3) if i != axis]), cp.shape)[cells]
            for ax in ((0, 1, 2) if layer else (axis,)):
                kk = k[..., ax][cells]
                k[..., ax][cells] = w / (w / kk + 1.0 / itf.conductance_W_m2K)
    if not touched:
        raise InputError(f"interface {itf.part_a!r}/{itf.part_b!r}: the parts do not touch")


def build_problem(geometry: Geometry, grid: TensorGrid, options: ModelOptions | None = None, *,
                  exchange=None) -> ThermalProblem:
    """The thermal problem of one scheme of the unit on ``grid``, with the laws of ``options``.

    ``exchange``: the ``s2s`` cavity law to use instead of :func:`cavity_exchange_law`'s (e.g. a coarse grid's
    law on its refinement, :meth:`~imutherm.thermal.cavity_radiation.CavityExchange.refined`); unscaled (the
    ``cavity_law_blend`` scale is applied here).

    Parameters
    ----------
    geometry : Geometry, the scheme's parts (:func:`imutherm.geometry.build.build_geometry`)
    grid : TensorGrid, its mesh (:func:`imutherm.geometry.mesh.build_mesh`)
    options : ModelOptions or None (the defaults: natural convection and radiation outside, the ``s2s``
        cavity law inside)

    Returns
    -------
    ThermalProblem, ready for :func:`~imutherm.thermal.steady.solve_steady` and
    :func:`~imutherm.thermal.transient.solve_transient`

    Examples
    --------
    >>> from imutherm.geometry.build import build_geometry
    >>> from imutherm.geometry.mesh import build_mesh
    >>> from imutherm.unit.model import ModelOptions, build_problem
    >>> geometry = build_geometry("imu_reference", "potted")
    >>> grid = build_mesh(geometry, max_cell_mm=6, min_cells=1)
    >>> problem = build_problem(geometry, grid)
    >>> round(float(problem.q @ grid.cell_volumes().ravel()), 3)   # the power [W]
    1.962
    >>> [type(law).__name__ for law in problem.boundary["zmax"]]   # the lid's laws
    ['NaturalConvection', 'Radiation']
    >>> [type(law).__name__ for law in problem.boundary["zmin"]]   # the base, bolted to the fixture
    ['Contact']
    >>> calm = build_problem(geometry, grid, ModelOptions(exterior="fixed", h_fixed_W_m2K=5.0))
    >>> [type(law).__name__ for law in calm.boundary["zmax"]]
    ['Convection', 'Radiation']
    """
    options = options or ModelOptions()
    parts = geometry.parts
    if tuple(p.name for p in parts) != tuple(grid.part_names):
        raise InputError("build_problem: the grid was not meshed from this geometry")
    lay = geometry.layout
    ambient = lay.ambient_C
    nparts = len(parts)
    k_part = np.zeros((nparts, 3))
    rc_part = np.zeros(nparts)
    for i, p in enumerate(parts):
        m = options.material(p.material)
        k_part[i] = m.k_in_plane
        if p.normal:
            k_part[i, AXES.index(p.normal)] = m.k_through
        rc_part[i] = m.rho_c
    vol = geometry.volumes
    q_part = np.array([p.power_W / vol[p.name] if p.power_W else 0.0 for p in parts])
    cp = grid.cell_part
    k = k_part[cp]  # (nx, ny, nz, 3)

    fill = grid.part_names.index("fill")
    law = cavity_law_of(options)
    terms = CavityTerms()
    if options.material(parts[fill].material).name == "air":   # the law's build hook: what it adds
        blend = float(options.cavity_law_blend) if law.blendable else 0.0
        ex = (lambda: exchange) if exchange is not None else (lambda: cavity_exchange_law(geometry, grid, options))
        terms = law.terms(CavitySetting(geometry, grid, options, blend, ex))
    exchanges = tuple(terms.exchanges)
    weight = terms.conductivity_share  # the effective law's share of the cavity radiation
    if weight > 0:
        air = cp == fill
        mean_T = ambient + 10.0  # linearisation point [degC]: hot parts run ~0-30 K above ambient
        for axis, w in enumerate(grid.cell_sizes()):
            runs = _run_lengths(air, w, axis)
            k[..., axis][air] += weight * cavity_radiation_conductivity(runs[air], mean_T, options.cavity_emissivity)
    for itf in unit_interfaces(geometry, options):
        _apply_interface(k, grid, itf, options.contact_layers)

    housing = options.material(parts[grid.part_names.index("housing")].material)
    eps = options.emissivity if options.emissivity is not None else (housing.emissivity or 0.0)
    (x0, y0, z0), (x1, y1, z1) = geometry.outer
    lengths = {"vertical": z1 - z0, "up": (x1 - x0) * (y1 - y0) / (2 * ((x1 - x0) + (y1 - y0)))}
    lengths["down"] = lengths["up"]
    mount = lay.mounting
    mount_face = _MOUNT_FACE[mount.face] if mount.kind == "fixture" else None
    h_mount = options.mounting_conductance_W_m2K
    h_mount = mount.contact_conductance_W_m2K if h_mount is None else h_mount
    boundary = {}
    for face in FACE_NAMES:
        if face == mount_face:
            boundary[face] = (Contact(h_mount, mount.temperature_C),) if h_mount > 0 else ()
            continue
        laws = []
        if options.exterior == "natural":
            orient = _FACE_ORIENTATION[face]
            # a scaled correlation: C of the heated face (the housing runs above ambient)
            C = (None if options.convection_scale == 1.0 else
                 options.convection_scale * float(natural_convection_h(1.0, 1.0, orient)))
            laws.append(NaturalConvection(orient, lengths[orient], ambient, C=C))
        elif options.exterior == "fixed":
            laws.append(Convection(options.h_fixed_W_m2K, ambient))
        if options.radiation and eps > 0:
            laws.append(Radiation(eps, ambient))
        boundary[face] = tuple(laws)
    return ThermalProblem(grid, k.reshape(-1, 3), rc_part[cp].ravel(), q_part[cp].ravel(), ambient, boundary,
                          exchanges)


def s2s_patch_choice(geometry: Geometry, options: ModelOptions, mesh_size_mm: float, min_cells: int):
    """The patches (:class:`~imutherm.thermal.cavity_radiation.PatchChoice`: edge, count, the cavity's area) the
    ``s2s`` cavity law of ``options`` would exchange between on this mesh (None: no s2s law, or the cavity is
    not air), from the mesh and the faces bounding the air before any view factor or dense array exists
    (builds the mesh: call it after its own cost was checked)."""
    from imutherm.geometry.mesh import build_mesh

    if not cavity_law_of(options).patches:
        return None
    fill = next((p for p in geometry.parts if p.name == "fill"), None)
    if fill is None or options.material(fill.material).name != "air":
        return None
    grid = build_mesh(geometry, mesh_size_mm, min_cells)
    air = grid.cell_part == grid.part_names.index("fill")
    return _patch_choice(grid, air, options) if air.any() else None


def s2s_patches(geometry: Geometry, options: ModelOptions, mesh_size_mm: float, min_cells: int) -> int:
    """Patches [-] the ``s2s`` cavity law of ``options`` would exchange between on this mesh (0: none);
    :func:`s2s_patch_choice`'s count."""
    choice = s2s_patch_choice(geometry, options, mesh_size_mm, min_cells)
    return 0 if choice is None else int(choice.patches.n)


_CHOICE_CACHE: dict = {}


def _grid_key(grid: TensorGrid, air) -> str:
    import hashlib

    h = hashlib.sha1()
    for a in (grid.xs, grid.ys, grid.zs, grid.cell_part, air):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def _patch_choice(grid: TensorGrid, air, options: ModelOptions, key: str | None = None):
    """:func:`~imutherm.thermal.cavity_radiation.choose_patch_mm` of ``options``, the last few kept."""
    from imutherm.thermal.cavity_radiation import choose_patch_mm

    ckey = (key or _grid_key(grid, air), float(options.cavity_patch_mm), options.cavity_max_patches)
    if ckey not in _CHOICE_CACHE:
        if len(_CHOICE_CACHE) >= 4:
            _CHOICE_CACHE.pop(next(iter(_CHOICE_CACHE)))
        _CHOICE_CACHE[ckey] = choose_patch_mm(grid, air, options.cavity_patch_mm, options.cavity_max_patches)
    return _CHOICE_CACHE[ckey]


_VIEW_CACHE: dict = {}
#: the last few exchange laws (X costs a dense radiosity solve of the patches, ~1e9 flops at the default mesh,
#: and a correlation's reduced model assembles ~80 variants that share the emissivities)
_LAW_CACHE: dict = {}


def cavity_exchange_law(geometry: Geometry, grid: TensorGrid, options: ModelOptions):
    """The ``s2s`` cavity law of the unit: :class:`~imutherm.thermal.cavity_radiation.CavityExchange`.

    Emissivities from the bounding parts' materials (or ``cavity_surface_emissivity``; the housing's and
    lid's ``cavity_wall_emissivity`` if given); rays seeded with 0.
    View factors depend only on the mesh, the air and the patch size and rays, so the last few are kept
    (a correlation re-solves the same mesh with other emissivities or conductances), and so are the last
    few laws (the same view factors and emissivities: the same exchange matrix; laws are not changed after).
    """
    from imutherm.thermal.cavity_radiation import DEFAULT_INTERIOR_EMISSIVITY, cavity_exchange

    air = grid.cell_part == grid.part_names.index("fill")
    if options.cavity_surface_emissivity is not None:
        eps = [options.cavity_surface_emissivity] * len(geometry.parts)
    else:
        eps = [options.material(p.material).emissivity for p in geometry.parts]
        eps = [DEFAULT_INTERIOR_EMISSIVITY if e is None else e for e in eps]
    if options.cavity_wall_emissivity is not None:
        eps = [options.cavity_wall_emissivity if p.kind in ("housing", "lid") else e
               for p, e in zip(geometry.parts, eps)]
    gkey = _grid_key(grid, air)
    choice = _patch_choice(grid, air, options, gkey)
    key = (gkey, float(choice.patch_mm), int(options.cavity_rays))
    law_key = key + (tuple(float(e) for e in eps),)
    if law_key in _LAW_CACHE:  # the same enclosure and emissivities: the same radiosity solve (read-only law)
        return _LAW_CACHE[law_key]
    law = cavity_exchange(grid, air, eps, patch_mm=choice.patch_mm, rays=options.cavity_rays,
                          rng=np.random.default_rng(0), view=_VIEW_CACHE.get(key), patches=choice.patches)
    law.choice = choice   # the patch edge and why (the printout's "cavity patches of N mm" line)
    if len(_LAW_CACHE) >= 8:
        _LAW_CACHE.pop(next(iter(_LAW_CACHE)))
    _LAW_CACHE[law_key] = law
    if key not in _VIEW_CACHE:
        if len(_VIEW_CACHE) >= 4:
            _VIEW_CACHE.pop(next(iter(_VIEW_CACHE)))
        _VIEW_CACHE[key] = law.view
    return law
