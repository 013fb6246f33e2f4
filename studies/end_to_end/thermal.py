"""The thermal side of the end-to-end study: one scheme's steady field, power-on transient and self-heating in
the calibration oven (:func:`thermal_case`), kept in the disk cache under the key of its content
(:func:`thermal_key`, :func:`stored_thermal_case`), and the order the schemes go to the workers.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from imutherm import InputError
from imutherm.geometry.layout import LayoutSpec
from imutherm.unit.model import ModelOptions, build_problem
from imutherm.thermal.steady import solve_steady
from imutherm.studies.thermal.thermal_study import longest_first, with_mesh_error  # noqa: F401  (the package's names)


def self_heating_table(res, chamber_C, *, model: str = "full", solves: list | None = None,
                       preconditioner=None, assembly=None) -> tuple[np.ndarray, np.ndarray]:
    """Sensor-die rise over the chamber [K], (k, 6) in SITES order, at oven temperatures ``chamber_C`` [°C].

    The scheme's model is solved steady with the chamber as ambient and fixture
    temperature (same mesh and options as ``res``); a chamber equal to the
    layout's ambient reuses ``res.steady``. ``model`` 'full': the full Newton solve; 'reduced': on a basis of
    ``res``'s steady rise that checks itself against the full model, every sensor die within 0.01 K
    (:func:`imutherm.thermal.reduced_steady.reduced_steady`), the full solve when the check fails.
    ``solves``: a list that gets one JSON-ready dict per solved chamber temperature (how it was solved).
    ``preconditioner``: the scheme's steady solve's (``solve_steady(..., keep=)``: the same conduction), for the
    reduced model's check instead of a new AMG hierarchy. ``assembly``: the scheme's own (the same grid and
    materials): its conduction, heat capacity and volume load are taken, only the oven's boundary is assembled
    (:func:`imutherm.thermal.assembly.assemble` ``like=``).
    """
    from imutherm.imu.sensor_model import SITES
    from imutherm.thermal.assembly import assemble, volume_part
    from imutherm.thermal.reduced_steady import reduced_steady

    geo = res.geometry
    lay = geo.layout
    missing = [s for s in SITES if s not in geo.sites]
    if missing:
        raise InputError(f"{lay.path}: the study needs a site per sensor die; missing: {', '.join(missing)}")
    probes = {s: geo.sites[s] for s in SITES}
    chamber = np.asarray(sorted(float(c) for c in chamber_C))
    rise = np.empty((chamber.size, 6))
    # the scheme's conduction, capacity and load without its boundary matrix (not kept beside the oven's own)
    like, assembly = (None if assembly is None else volume_part(assembly)), None
    for k, Tc in enumerate(chamber):
        if Tc == lay.ambient_C and lay.mounting.temperature_C == lay.ambient_C:
            st = res.steady
            idx = [st.probe_names.index(s) for s in SITES]
            rise[k] = np.asarray(st.probe_C)[idx] - Tc
            continue
        lay_c = replace(lay, ambient_C=Tc, mounting=replace(lay.mounting, temperature_C=Tc))
        problem = build_problem(replace(geo, layout=lay_c), res.grid, res.options)
        asm = assemble(problem, like=like)
        known = np.asarray(res.steady.T_C) - lay.ambient_C
        st, how = None, {"chamber_C": float(Tc), "model": "full"}
        if model == "reduced":
            try:
                st, chk = reduced_steady(problem, asm, known, probes, preconditioner=preconditioner)
                how["check"] = chk.summary()
            except InputError as e:   # e.g. a fixed-temperature face: the full solve
                how["check"] = {"accepted": False, "reason": str(e)}
            if st is not None:
                how["model"] = "reduced"
        if st is None:
            st = solve_steady(problem, probes=probes, initial_C=known + Tc, assembly=asm)
        if solves is not None:
            solves.append(how)
        rise[k] = np.asarray(st.probe_C) - Tc
        st = asm = problem = None   # not kept beside the next temperature's
    return chamber, rise


def site_curves(res) -> tuple[np.ndarray, np.ndarray]:
    """Die temperatures of the six sensor sites over the power-on transient: t (M,) [s], T (M, 6) [°C]."""
    from imutherm.imu.sensor_model import SITES

    tr = res.transient
    idx = [tr.probe_names.index(s) for s in SITES]
    return np.asarray(tr.times, float), np.asarray(tr.probe_C, float)[:, idx]


def thermal_case(layout: LayoutSpec, scheme: str, options: ModelOptions, chamber_C, progress: bool = False,
                 **thermal_kwargs):
    """The thermal side of one scheme: (SchemeResult, chamber (k,) [°C], rise (k, 6) [K], oven solves).

    Steady field, power-on transient (always run) and the oven self-heating table; a pure function of its
    arguments, so schemes can run in separate processes. With ``estimate_mesh_error``, the sites' values and
    curves and the oven's rises are the estimate's corrected answer
    (:func:`~imutherm.studies.thermal.thermal_study.mesh_corrected`). The oven solves are reduced and checked when the
    transient is (``transient_model`` 'reduced'), else full. Returns (SchemeResult, chamber, rise, oven solves
    (list of dicts, :func:`self_heating_table`)).
    """
    from imutherm.budget import release_freed_memory
    from imutherm.imu.sensor_model import SITES
    from imutherm.studies.thermal.thermal_study import mesh_factors, run_scheme

    estimate = thermal_kwargs.pop("estimate_mesh_error", False)
    kept = {}   # the steady solve's preconditioner: the oven's check and the estimate's coarse level use it too
    res = run_scheme(layout, scheme, options=options, progress=progress, transient=True, keep=kept, **thermal_kwargs)
    solves = []
    chamber, rise = self_heating_table(res, chamber_C, model=thermal_kwargs.get("transient_model", "full"),
                                       solves=solves, preconditioner=kept.get("preconditioner"),
                                       assembly=kept.pop("assembly", None))   # not kept through the refined solve
    if estimate:
        res = with_mesh_error(res, kept.pop("preconditioner", None))
        factors = mesh_factors(res)   # the oven's rises too: the same mesh, the same conduction
        rise = rise * np.array([factors.get(s, 1.0) for s in SITES])
    release_freed_memory()
    return res, chamber, rise, solves


#: the study's own source a thermal case depends on, beside the models' (:data:`imutherm.cache.CODE_VERSION`:
#: thermal, unit, geometry, layouts, the constants); files read, not imported
CASE_SOURCES = (("studies", "thermal/thermal_study.py"), ("studies", "end_to_end/thermal.py"),
                ("imutherm", "site_table.py"))


def thermal_key(layout: LayoutSpec, scheme: str, options: ModelOptions, chamber_C, **thermal_kwargs) -> str:
    """The disk-cache key (hex SHA-256, :func:`imutherm.cache.key_of`) of :func:`thermal_case`'s value: the
    layout's content (:func:`layout_content`: not its file's path, name or time), the scheme, the model options
    (materials, laws), the oven temperatures, the mesh, time and estimate settings, the sensor-die names and the
    source of the code that computes it. The IMU side (grade, seeds, profiles, filters) is not in it: a sweep over those re-uses it."""
    from imutherm.cache import key_of, source_version
    from imutherm.site_table import SITES

    kw = {k: v for k, v in thermal_kwargs.items() if k != "progress"}
    chamber = tuple(sorted(float(c) for c in chamber_C))
    return key_of("thermal_case", layout_content(layout), str(scheme), options, chamber, kw, SITES,
                  source_version(CASE_SOURCES))


def layout_content(layout: LayoutSpec) -> LayoutSpec:
    """``layout`` as the disk cache's keys see it: what the unit is, not where its file is. Without the file's
    path, the name (a file without a ``name`` field is named after the file) and the reference data (the paths
    of the figures beside the layout, or of the package's own digest: another checkout's are other paths; no
    thermal solve reads them). A cached value read back gets these three of the layout asked for
    (:func:`_as_read`). The materials library and the model code are in every key by their source
    (:data:`imutherm.cache.CODE_VERSION`); the layout's own materials are in its content."""
    return replace(layout, path="", name="", reference_data=None)


def cached_thermal_case(key: str | None, layout: LayoutSpec):
    """(value of :func:`thermal_case` or None, status): the entry under ``key`` in the disk cache
    (status ``hit``), ``absent``, ``unreadable`` (deleted: to be recomputed) or ``off`` (``key`` None). A hit's
    geometry carries ``layout`` (the same content, perhaps read from another path)."""
    from imutherm.cache import load_status

    if key is None:
        return None, "off"
    value, status = load_status(key)
    if status != "hit":
        return None, status
    return (_as_read(value[0], layout),) + tuple(value[1:]), status


def stored_thermal_case(key: str | None, layout: LayoutSpec, scheme: str, options: ModelOptions, chamber_C,
                        progress: bool = False, lean: bool = False, **thermal_kwargs):
    """:func:`thermal_case`, its value written to the disk cache under ``key`` (:func:`thermal_key`; None: not
    written). Run in a worker: the write happens there, beside the other schemes' solves. ``lean``: once the
    entry is written, the value returned is :func:`lean_case`'s (the full one is read back from the cache when
    needed, :func:`full_case`); not written (no key, or the folder cannot be written): the full value."""
    from imutherm.cache import store

    out = thermal_case(layout, scheme, options, chamber_C, progress=progress, **thermal_kwargs)
    if key is not None and store(key, out) is not None and lean:
        return lean_case(out)
    return out


def lean_case(value) -> tuple:
    """:func:`thermal_case`'s ``value`` without its thermal problem (per-cell conductivity, capacity, power and
    boundary arrays: ~55 MB of a ~60 MB reference-unit result), what a worker sends back while the other schemes'
    solves still run; the sites' values and curves, the oven table and the fields stay. Marked by the steady
    result's ``problem`` None (:func:`is_lean`)."""
    res = value[0]
    tr = res.transient
    res = replace(res, steady=replace(res.steady, problem=None),
                  transient=None if tr is None else replace(tr, problem=None))
    return (res,) + tuple(value[1:])


def is_lean(value) -> bool:
    """Whether ``value`` (of :func:`thermal_case`) is :func:`lean_case`'s."""
    return value[0].steady.problem is None


def full_case(value, key: str | None, layout: LayoutSpec, scheme: str, options: ModelOptions, chamber_C,
              **thermal_kwargs) -> tuple:
    """``value`` itself, or for a :func:`lean_case` the full value read back from the disk cache under ``key``
    (solved again here, said in one line, if the entry has gone meanwhile, e.g. evicted)."""
    if not is_lean(value):
        return value
    full, status = cached_thermal_case(key, layout)
    if status == "hit":
        return full
    print(f"{scheme}: thermal: the cache entry {str(key)[:12]} was {status} when read back: recomputed", flush=True)
    return thermal_case(layout, scheme, options, chamber_C, **thermal_kwargs)


def _as_read(res, layout: LayoutSpec):
    """``res`` (a SchemeResult) with its geometry's layout given ``layout``'s path, name and reference data (a
    cached result of the same content, :func:`layout_content`, perhaps read from another file or checkout)."""
    lay = res.geometry.layout
    if (lay.path, lay.name, lay.reference_data) == (layout.path, layout.name, layout.reference_data):
        return res
    lay = replace(lay, path=layout.path, name=layout.name, reference_data=layout.reference_data)
    return replace(res, geometry=replace(res.geometry, layout=lay))


def cached_scheme_run(layout: LayoutSpec, scheme: str, run_kwargs: dict, use_cache: bool = True):
    """One scheme of the thermal comparison (``compare --thermal-only``): :func:`run_scheme` with ``run_kwargs``
    (and the mesh-error estimate with the steady solve's preconditioner), or its SchemeResult from the disk cache
    under the key of its content (as :func:`thermal_key`; ``use_cache`` False or ``$IMUTHERM_CACHE`` off: solved,
    nothing read or written). A hit prints ``<scheme>: thermal: cached (key ...)``; an entry that cannot be read
    is recomputed, said in one line."""
    from imutherm.cache import enabled, key_of, load_status, source_version, store
    from imutherm.studies.thermal.thermal_study import run_scheme

    kw = {k: v for k, v in run_kwargs.items() if k != "progress"}
    key = None
    if use_cache and enabled():
        key = key_of("scheme_run", layout_content(layout), str(scheme), kw, source_version(CASE_SOURCES))
        value, status = load_status(key)
        if status == "hit":
            print(f"{scheme}: thermal: cached (key {key[:12]})", flush=True)
            return _as_read(value, layout)
        if status == "unreadable":
            print(f"{scheme}: thermal: the cache entry {key[:12]} could not be read: recomputed", flush=True)
    estimate = kw.pop("estimate_mesh_error", False)
    kept = {}
    res = run_scheme(layout, scheme, keep=kept, progress=run_kwargs.get("progress", False), **kw)
    if estimate:
        res = with_mesh_error(res, kept.pop("preconditioner", None))
    if key is not None:
        store(key, res)
    return res
