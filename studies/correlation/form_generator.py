"""The correlation campaign's hardest model-form path: contacts as thin solid layers, another grid, every law off.

The ``layered`` path of :func:`imutherm.studies.correlation.hidden_effect.model_form_options` generates the "measured"
data with a model that differs from the inversion's in form in several ways at once, as a real bench's unit does:

- **contacts as thin solid layers** (:func:`refine_contact_layers`): every contact conductance (bond lines,
  standoffs, the lid joint, the boards' joints, a hidden contact effect) is a resolved layer of
  :data:`LAYER_MM` in the part it belongs to, its conductivity the series value in every direction
  (``ModelOptions.contact_layers``), where the inversion lumps it into the touching cell's normal conductivity;
- **a coarser or a finer grid** than the inversion's (:data:`GRID_FACTORS`, alternating by case), so the
  discretisation error has either sign;
- the s2s cavity's patches cut on the generator's own grid (not the ``discretisation`` path's finer patches and
  rays: their view factors cost ~10 minutes a case on the shared 2-core machine);
- **±10 % nuisance on every conductivity and law** (:func:`nuisance_options`): every material's
  conductivities, the contact conductances, the cavity's and the housing's emissivities, the convection
  correlation, the mount and the board (the last three as the other paths have them);
- per-probe offsets and noise as every path (:func:`imutherm.studies.correlation.hidden_effect.make_case`).

A hidden library effect is drawn on top of all this, so model-form error and a strong effect come together in
one case.

:func:`form_pair` serves a campaign at a *set* form error (``benchmarks/bench_correlation_forms.py --generator
fem``): the full FEM's site rises of one truth twice, on the inversion's own form (its laws and mesh) and on one
other form of :data:`FEM_FORMS` alone, so the form's error can be scaled to a chosen fraction of the rise.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from imutherm.geometry.grid import TensorGrid
from imutherm.geometry.materials import settable_properties, with_properties
from imutherm.unit.model import ModelOptions, unit_interfaces

#: thickness of a resolved contact layer [mm]: a bond line's or joint's interstitial layer is 10-100 um thick;
#: 0.1 mm keeps the layer's cells within the tensor grid's aspect ratios (the grid's thinnest parts are
#: 0.05-0.1 mm: dies and bond lines)
LAYER_MM = 0.1
#: the generator's cell size as a factor of the inversion's, by case (alternating): coarser, finer (0.75, not 0.5:
#: a 3 mm generator case took ~30 min on the shared machine under load, a 9 mm one 16 min)
GRID_FACTORS = (1.5, 0.75)

#: the single forms :func:`form_pair` generates with: contacts as thin layers, the other cavity-radiation law, a
#: finer grid (:data:`GRID_FORM`), ±10 % nuisance on every conductivity, contact and emissivity
FEM_FORMS = ("layered", "cavity_law", "grid", "nuisance")
#: the ``grid`` form's generator mesh: cell size this factor of the inversion's, and this many cells across the
#: thinnest part (the inversion's campaigns use 4 mm and 1: the generator 2 mm and 2, 2x finer both ways; a
#: coarser cell size barely changes the unit's tensor grid, whose lines follow the parts: 4 mm and 8 mm gave
#: the same site rises within 0.04 K, 2026-12-07)
GRID_FORM = (0.5, 2)


def generator_mesh_mm(inversion_mm: float, case: int) -> float:
    """The ``layered`` path's generator mesh [mm] for case number ``case``: :data:`GRID_FACTORS` in turn."""
    return float(inversion_mm * GRID_FACTORS[case % len(GRID_FACTORS)])


def refine_contact_layers(grid: TensorGrid, geometry, options: ModelOptions, layer_mm: float = LAYER_MM) -> TensorGrid:
    """``grid`` with a grid plane at ``layer_mm`` inside part b of every contact (a, b) of the unit
    (:func:`~imutherm.unit.model.unit_interfaces`), on each face where b touches a, where the touching cell is
    wider than twice the layer: the touching cells become a thin layer that ``contact_layers`` makes the
    contact's solid layer. A plane of a tensor grid runs through the whole unit; cells keep their parts."""
    d = layer_mm * 1e-3
    lines = [np.asarray(grid.xs, float), np.asarray(grid.ys, float), np.asarray(grid.zs, float)]
    cp = grid.cell_part
    names = grid.part_names
    new = [set(), set(), set()]
    for itf in unit_interfaces(geometry, options):
        if itf.part_a not in names or itf.part_b not in names:
            continue
        a, b = names.index(itf.part_a), names.index(itf.part_b)
        for axis in range(3):
            w = np.diff(lines[axis])
            for shift in (1, -1):
                nb = np.roll(cp, shift, axis=axis)
                edge = [slice(None)] * 3
                edge[axis] = 0 if shift == 1 else -1
                nb[tuple(edge)] = -1
                cells = (cp == b) & (nb == a)
                if not cells.any():
                    continue
                idx = np.unique(np.nonzero(cells)[axis])
                for i in idx:
                    if w[i] <= 2 * d:
                        continue
                    # shift 1: the neighbour a lies at i - 1, so b's face is line i; shift -1: line i + 1
                    new[axis].add(float(lines[axis][i] + d) if shift == 1 else float(lines[axis][i + 1] - d))
    out = []
    for axis in range(3):
        old = lines[axis]
        fresh = np.array(sorted(x for x in new[axis] if np.min(np.abs(old - x)) > 1e-9))
        out.append(np.union1d(old, fresh) if len(fresh) else old)
    parts = cp
    for axis in range(3):
        centres = 0.5 * (out[axis][1:] + out[axis][:-1])
        src = np.clip(np.searchsorted(lines[axis], centres) - 1, 0, len(lines[axis]) - 2)
        parts = np.take(parts, src, axis=axis)
    return TensorGrid(out[0], out[1], out[2], np.ascontiguousarray(parts, dtype=np.int32), grid.part_names,
                      dict(grid.face_names))


def nuisance_options(options: ModelOptions, geometry, rng: np.random.Generator, frac: float = 0.10) -> tuple:
    """(options, record): ``options`` with every material's conductivities (but the boards', whose in-plane
    value the re-tune's ``k_board_W_mK`` nuisance sets; their through-plane one here), the contact
    conductances (bond, standoff, every interface), the cavity's pair emissivity and the housing's outside
    emissivity each off by a uniform ±``frac``; record: what -> factor [-]. Fixed draw order (reproducible)."""
    rec = {}

    def f(name):
        rec[name] = float(1.0 + rng.uniform(-frac, frac))
        return rec[name]

    mats = []
    for name in sorted({p.material for p in geometry.parts}):
        m = options.material(name)
        props = settable_properties(m)
        if "k" in props:
            mats.append(with_properties(m, "nuisance", k=m.k_in_plane * f(f"k:{name}")))
        elif "k_through" in props:
            mats.append(with_properties(m, "nuisance", k_through=m.k_through * f(f"k_through:{name}")))
    itfs = tuple(replace(i, conductance_W_m2K=i.conductance_W_m2K * f(f"contact:{i.part_a}/{i.part_b}"))
                 for i in options.interfaces)
    from imutherm.unit.effects import wall_emissivity_for_pair
    housing = options.material(geometry.part("housing").material)
    eps_ext = options.emissivity if options.emissivity is not None else (housing.emissivity or 0.0)
    out = options.with_(
        materials=tuple(mats), interfaces=itfs,
        bond_contact_W_m2K=options.bond_contact_W_m2K and options.bond_contact_W_m2K * f("contact:bond"),
        standoff_contact_W_m2K=options.standoff_contact_W_m2K and options.standoff_contact_W_m2K * f("contact:standoff"),
        cavity_emissivity=min(1.0, options.cavity_emissivity * f("cavity_emissivity")),
        cavity_wall_emissivity=wall_emissivity_for_pair(min(0.95, options.cavity_emissivity * rec["cavity_emissivity"])),
        emissivity=min(1.0, eps_ext * f("emissivity_ext")))
    return out, rec


def form_options(form: str, inversion: ModelOptions, geometry, rng: np.random.Generator) -> tuple:
    """(the generator's options, its mesh as (cell-size factor, min cells) or None for the inversion's, record)
    of one form of :data:`FEM_FORMS` given the inversion's ``inversion``; ``nuisance`` draws from ``rng``."""
    from imutherm import InputError
    from imutherm.studies.correlation.hidden_effect import model_form_options
    if form == "layered":
        return model_form_options(inversion, "layered"), None, {}
    if form == "cavity_law":
        return model_form_options(inversion, "cavity-law"), None, {}
    if form == "grid":
        return inversion, GRID_FORM, {}
    if form == "nuisance":
        opts, rec = nuisance_options(inversion, geometry, rng, 0.10)
        return opts, None, rec
    raise InputError(f"form_options: unknown form {form!r}; valid: {', '.join(FEM_FORMS)}")


def form_pair(geometry, values: dict, inversion: ModelOptions, generator: ModelOptions, mesh_mm: float,
              min_cells: int, gen_mesh, probes: dict, times, lid_load_W_m2: float | None = None) -> tuple:
    """(rises on the inversion's form, rises on the generator's) [K], each (len(times), len(probes)): the full
    FEM (:func:`imutherm.studies.thermal.forward.checked_rise`) of the unit ``geometry`` with knobs ``values``, once
    with ``inversion``'s laws on its mesh (``mesh_mm``, ``min_cells``) and once with ``generator``'s on
    ``gen_mesh`` ((factor, min cells) of :func:`form_options`, None: the same mesh; contact layers resolved
    where ``generator`` has them). ``lid_load_W_m2``: a radiant load on the lid [W/m^2] (outside the library)."""
    from imutherm.geometry.mesh import build_mesh
    from imutherm.studies.thermal.forward import checked_rise
    from imutherm.thermal.problem import HeatFlux
    from imutherm.unit import knobs
    from imutherm.unit.effects import ModelVariant
    out = []
    for opts, mesh in ((inversion, (1.0, min_cells)), (generator, gen_mesh or (1.0, min_cells))):
        variant = knobs.variant(geometry, opts, values)
        if lid_load_W_m2:
            laws = dict(variant.extra_laws)
            laws["zmax"] = laws.get("zmax", ()) + (HeatFlux(float(lid_load_W_m2)),)
            variant = ModelVariant(variant.geometry, variant.options, laws)
        grid = build_mesh(variant.geometry, mesh_mm * mesh[0], mesh[1])
        if variant.options.contact_layers:
            grid = refine_contact_layers(grid, variant.geometry, variant.options)
        out.append(checked_rise(variant, grid, probes, times)[0])
    return out[0], out[1]
