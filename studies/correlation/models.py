"""The reduced models a correlation runs on (built once per scheme and ambient, kept in the disk cache), the
checks of the measured files before they are built, and the re-run of the corrected model on the full FEM.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from imutherm import InputError
from imutherm.geometry.build import build_geometry
from imutherm.geometry.layout import LayoutSpec, load_layout
from imutherm.geometry.mesh import DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS, build_mesh
from imutherm.measured import MeasuredRun
from imutherm.unit import knobs
from imutherm.unit.effects import effect_of, is_signal, setting
from imutherm.unit.model import ModelOptions
from imutherm.thermal.reduced import build_reduced


@dataclass(frozen=True)
class Models:
    """The reduced models a correlation runs on: ``roms`` (scheme, ambient_C) -> ReducedModel,
    ``geometries`` scheme -> Geometry, ``build_s`` [s] to build them all."""

    roms: dict
    geometries: dict
    build_s: float
    keyed_geometries: dict = field(default_factory=dict)
    mesh_size_mm: float = DEFAULT_MAX_CELL_MM
    min_cells: int = DEFAULT_MIN_CELLS
    options: ModelOptions | None = None


def worker_pool(jobs: int, n: int):
    """A process pool of min(jobs, n) workers with one BLAS thread each, or None for one job."""
    from imutherm.workers import process_pool

    return process_pool(min(jobs, n))


def map_jobs(fn, args, jobs: int) -> list:
    """``[fn(*a) for a in args]``, on min(``jobs``, len(args)) worker processes (:func:`worker_pool`)."""
    pool = worker_pool(jobs, len(args))
    if pool is None:
        return [fn(*a) for a in args]
    try:
        return [f.result() for f in [pool.submit(fn, *a) for a in args]]
    finally:
        pool.shutdown(cancel_futures=True)


def _build_one(layout: LayoutSpec, scheme: str, amb: float, mesh_size_mm: float, min_cells: int,
               options: ModelOptions, use_cache: bool = True):
    """(geometry, reduced model, from the cache: bool) of one (scheme, ambient [degC]); a pure function, run in
    a worker. The model is kept in the disk cache (:mod:`imutherm.cache`) under the key of everything it
    depends on: the layout's content, the scheme, the ambient, the mesh, the model options, the knob set and
    the sites (and the code version of the model)."""
    from dataclasses import replace

    from imutherm.cache import cached
    lay = replace(layout, ambient_C=amb, mounting=replace(layout.mounting, temperature_C=amb))
    geo = build_geometry(lay, scheme)
    ks = [k for k, _ in knobs.RETUNE] + [knobs.effect_knob(n, options) for n in knobs.model_effect_names()
                                     if knobs.applicable(n, geo, options)]
    names = {k.name for k in ks}
    pairs = knobs.coupled_pairs(names)

    def build():
        grid = build_mesh(geo, mesh_size_mm, min_cells)
        return build_reduced(lambda v: knobs.variant(geo, options, v), grid, ks, dict(geo.sites), pairs=pairs)
    parts = (replace(lay, path=""), scheme, float(amb), float(mesh_size_mm), int(min_cells), options, ks, pairs,
             dict(geo.sites))
    rom, hit = cached("reduced_model", parts, build, use_cache=use_cache)
    return geo, rom, hit


#: a file is refused before the reduced models are built if it ends before this fraction of its sites'
#: slowest t63 in the pre-check's knobless reduced model (its basis is the nominal Krylov space alone, a
#: few % off the full model's t63; the exact check after the build stays)
PRECHECK_T63_FRACTION = 0.9


#: the pre-check's mesh [mm] (at least; min cells 1): the reference unit's t63 there are within 2 % of the
#: 2 mm mesh's (gyro_x 94 / 96 s, tp1 27 / 27 s, accel_z 104 / 106 s) at a third of the CPU (12 / 33 s)
PRECHECK_MESH_MM = 6.0


def model_t63_s(layout: LayoutSpec, scheme: str, amb: float, sites, mesh_size_mm: float, min_cells: int,
                options: ModelOptions, use_cache: bool = True) -> dict:
    """Nominal t63 [s] of ``sites`` of one (scheme, ambient [degC]): a reduced model without knobs (one
    nonlinear steady solve and the nominal Krylov basis: a small part of a full build), rise to 2e4 s.
    Kept in the disk cache (:mod:`imutherm.cache`) under the key of everything it depends on."""
    from dataclasses import replace

    from imutherm.cache import cached
    lay = replace(layout, ambient_C=amb, mounting=replace(layout.mounting, temperature_C=amb))
    geo = build_geometry(lay, scheme)
    probes = {s: geo.sites[s] for s in sites}

    def build():
        grid = build_mesh(geo, mesh_size_mm, min_cells)
        rom = build_reduced(lambda v: knobs.variant(geo, options, v), grid, [], probes)
        fine = np.geomspace(1.0, 2.0e4, 400)
        curves = rom.rise({}, fine)
        out = {}
        for j, s in enumerate(rom.site_names):
            fin = curves[-1, j]
            out[s] = float(np.interp(0.632 * fin, curves[:, j], fine)) if fin > 0 else math.nan
        return out
    parts = (replace(lay, path=""), scheme, float(amb), float(mesh_size_mm), int(min_cells), options, probes)
    return cached("model_t63", parts, build, use_cache=use_cache)[0]


def check_inputs(runs, layout: LayoutSpec, holdout: str | None, *, mesh_size_mm: float, min_cells: int,
                 options: ModelOptions, say=None, use_cache: bool = True) -> None:
    """Everything about the measured files that can be refused before the reduced models are built:
    a ``holdout`` naming no file, and a file without a steady row that ends before
    :data:`PRECHECK_T63_FRACTION` of its slowest site's t63 (:func:`model_t63_s` on a mesh of at least
    :data:`PRECHECK_MESH_MM`, once per (scheme, ambient)). ``mesh_size_mm``, ``min_cells``: the run's mesh."""
    if holdout not in (None, "auto") and not any(r.path == holdout or r.name == holdout for r in runs):
        raise InputError(f"--holdout {holdout!r}: not one of the measured files ({', '.join(r.path for r in runs)})")
    t63 = {}
    for run in runs:
        if np.isinf(run.times_s).any():
            continue
        key = (run.scheme, run.ambient_C)
        if key not in t63:
            if say:
                say(f"time constants of {run.scheme} at {run.ambient_C:g} C (a reduced model without knobs)")
            sites = sorted({s for r in runs if (r.scheme, r.ambient_C) == key for s in r.sites})
            t63[key] = model_t63_s(layout, run.scheme, run.ambient_C, sites, max(mesh_size_mm, PRECHECK_MESH_MM),
                                   1, options, use_cache=use_cache)
        slowest = max(t63[key][s] for s in run.sites)
        last = float(run.times_s.max())
        if last < PRECHECK_T63_FRACTION * slowest:
            raise InputError(f"{run.path}:{run.lines[-1]}: the file ends at {last:g} s, before the model's time "
                             f"constant (~{slowest:.0f} s, t63 of its slowest site): nothing to correlate the "
                             f"plateau with; add later readings or a steady row (time_s = inf)")


def build_models(keys, layout: LayoutSpec | str | None = None, *, mesh_size_mm: float = DEFAULT_MAX_CELL_MM,
                 min_cells: int = DEFAULT_MIN_CELLS, options: ModelOptions | None = None, jobs: int = 1,
                 progress=None, use_cache: bool = True) -> Models:
    """The reduced model of each (scheme, ambient [degC]) in ``keys``, with every re-tune knob and every
    model effect that applies to the scheme (:func:`imutherm.thermal.reduced.build_reduced`).

    ``use_cache``: read and keep the models in the disk cache (:mod:`imutherm.cache`); a model found there
    costs a file read instead of its build.

    Each costs one nonlinear steady solve, ~35 preconditioned CG solves and ~60 assemblies of the full
    model: about a minute at the default 2 mm mesh on one core; ``jobs`` builds that many at once.
    """
    t0 = time.perf_counter()
    say = progress or (lambda s: None)
    if not isinstance(layout, LayoutSpec):
        layout = load_layout(layout)
    options = options or ModelOptions()
    keys = list(keys)
    for scheme, _ in keys:
        if scheme not in layout.schemes:
            raise InputError(f"correlate: scheme {scheme!r} is not in layout {layout.name!r}; "
                             f"valid: {', '.join(layout.schemes)}")
    n_nodes = build_mesh(build_geometry(layout, keys[0][0]), mesh_size_mm, min_cells).n_nodes if keys else 0
    # measured at the default mesh (1.75e5 unknowns, 16-17 knobs, two coupled pairs; effective cavity law):
    # three builds on two workers of the idle 2-core machine 112 s, i.e. ~56 s each; 1.0 GB peak per worker
    # (benchmarks/bench_correlation_speed.py, 2026-12-01)
    each, gb = n_nodes / 175e3 * 60.0, n_nodes / 175e3 * 1.1
    say(f"{len(keys)} reduced model(s), ~{n_nodes} unknowns each: about {each:.0f} s and {gb:.1f} GB each on one "
        f"core, {len(keys)} on {max(1, min(jobs, len(keys)))} worker(s)")
    pool = worker_pool(jobs, len(keys))
    try:
        if pool is None:
            built = []
            for scheme, amb in keys:
                say(f"reduced model of {scheme} at {amb:g} C")
                built.append(_build_one(layout, scheme, amb, mesh_size_mm, min_cells, options, use_cache))
        else:
            futs = [pool.submit(_build_one, layout, sc, amb, mesh_size_mm, min_cells, options, use_cache)
                    for sc, amb in keys]
            built = []
            for (scheme, amb), f in zip(keys, futs):
                built.append(f.result())
                say(f"reduced model of {scheme} at {amb:g} C: " + ("from the cache" if built[-1][2] else "done"))
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
    roms, geometries, keyed = {}, {}, {}
    for (scheme, amb), (geo, rom, _) in zip(keys, built):
        geometries.setdefault(scheme, geo)
        keyed[(scheme, amb)] = geo
        roms[(scheme, amb)] = rom
    return Models(roms, geometries, time.perf_counter() - t0, keyed, mesh_size_mm, min_cells, options)


def _rerun_one(geo, values: dict, run: MeasuredRun, mesh_size_mm: float, min_cells: int, options: ModelOptions,
               use_cache: bool = True, transient: str = "reduced"):
    """(site rises [K] of the corrected model at the run's times, how its transient was computed: dict) on
    the full model: its steady solve and, ``transient`` 'reduced', the transient on the checked reduced model
    (:func:`imutherm.studies.thermal.forward.checked_rise`: the full adaptive FEM where the check fails), 'full' the
    full adaptive FEM. Kept in the disk cache under the key of the layout's content, scheme, options, values,
    sites, times, mesh and ``transient``."""
    from dataclasses import replace

    from imutherm.cache import cached
    from imutherm.studies.thermal.forward import checked_rise
    if transient not in ("reduced", "full"):
        raise InputError(f"correlate: the re-run's transient is 'reduced' or 'full', not {transient!r}")
    model_vals, signal = {}, []
    for k, v in values.items():
        if is_signal(k):
            signal.append(setting(k, **{effect_of(k).params[0].name: v}))
        elif k in knobs.RETUNE_SOURCES or knobs.applicable(k, geo):
            model_vals[k] = v
    model_vals["power_scale"] = values.get("power_scale", 1.0) * run.power_scale
    # the study's CG tolerance: the same t95 to 0.1 s as 1e-6, 18 % fewer iterations (see STUDY_CG_RTOL)
    from imutherm.studies.thermal.thermal_study import STUDY_CG_RTOL
    probes = {s: geo.sites[s] for s in run.sites}

    def build():
        variant = knobs.variant(geo, options, model_vals)
        grid = build_mesh(variant.geometry, mesh_size_mm, min_cells)
        return checked_rise(variant, grid, probes, run.times_s, signal, rtol=STUDY_CG_RTOL, full=transient == "full")
    parts = (replace(geo.layout, path=""), geo.scheme.name, options, model_vals, signal, probes,
             np.asarray(run.times_s, float), float(mesh_size_mm), int(min_cells), STUDY_CG_RTOL, transient)
    rises, info = cached("full_rerun", parts, build, use_cache=use_cache)[0]
    return rises, {"file": run.path, **info}


def rerun_full(runs, values: dict, models: Models, jobs: int = 1, progress=None, use_cache: bool = True,
               transient: str = "reduced") -> tuple:
    """The corrected model re-run on the full model: (site rises [K] of each run at its times (n, m), one
    dict per run saying how its transient was computed).

    values : knob name -> value (re-tune knobs and the named effect), as fitted; the runs' own
    ``power_scale`` multiplies the fitted one; a model effect whose target a scheme lacks is off there.
    ``jobs``: runs re-run at once; ``use_cache``: a re-run of the same corrected model on the same data
    (the next correlation of the same unit) is read from the disk cache (:mod:`imutherm.cache`).
    ``transient``: 'reduced' (default) the full steady solve and the transient on the study's checked reduced
    model, the full adaptive FEM where its check fails (:func:`imutherm.studies.thermal.forward.checked_rise`);
    'full' the full adaptive FEM (``--full``).
    """
    say = progress or (lambda s: None)
    how = ("the transient on a reduced model checked against the full one" if transient == "reduced"
           else "the full adaptive transient")
    say(f"full-model re-run of {len(runs)} file(s) (one steady solve each, {how})")
    args = [(models.keyed_geometries[(r.scheme, r.ambient_C)], values, r, models.mesh_size_mm, models.min_cells,
             models.options or ModelOptions(), use_cache, transient) for r in runs]
    out = map_jobs(_rerun_one, args, jobs)
    return [o[0] for o in out], [o[1] for o in out]


def _content_key(run: MeasuredRun) -> tuple:
    """What a measured file says, whatever its path, comments or number formatting: its experiment (scheme,
    ambient, power scale, power-on time) and its readings, by site."""
    order = np.argsort(run.sites)
    vals = np.round(run.values_C[:, order], 9)
    return (run.scheme, round(run.ambient_C, 9), round(run.power_scale, 9), round(run.t_power_on_s, 9),
            tuple(np.asarray(run.sites)[order]), np.round(run.times_s, 9).tobytes(),
            np.nan_to_num(vals, nan=-1e300).tobytes())


def refuse_duplicates(runs) -> None:
    """Refuse two measured files with the same content (the same experiment given twice counts its
    readings twice: a false confidence, and no held-out test between them), by content, not by path."""
    seen = {}
    for r in runs:
        key = _content_key(r)
        if key in seen:
            other = seen[key]
            same = "the same file" if other.path == r.path else f"the same readings as {other.path}"
            raise InputError(f"{r.path}: {same} (scheme {r.scheme}, {r.n_values} readings): a measured file given "
                             f"twice; give each experiment once")
        seen[key] = r
