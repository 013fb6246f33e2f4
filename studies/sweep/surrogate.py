"""Sweep cases on the reduced model of :mod:`imutherm.thermal.reduced`, proven against the full FEM.

A sweep whose every key only changes a coefficient of the model on the same mesh (a power, a
conductivity, a contact or mounting conductance, a convection factor, an emissivity) is a
parametric family of one operator: the reduced model of the scheme carries each key as a knob
(its Chebyshev interpolation over the key's range; powers enter the load exactly), so a case costs
one r x r solve (r ~ 100) instead of a nonlinear FEM solve of ~2e5 unknowns. Keys that move the
mesh, the ambient or a fixture temperature (the reduced model is linearised about the ambient),
or the heat capacity (the reduced mass matrix is fixed) are not knobs: such a sweep runs on the
full FEM (:func:`~imutherm.studies.sweep.keys.surrogate_keys` says why).

What the reduced model gives per case: the steady rise of every site, the largest rise (over the
sites and the hottest node of each powered part in the nominal field: the field's maximum lies
where the heat is released, and moves within a part only to second order), and with the transient
the hottest site's t95 from the closed-form modal response. Knobs that change the same
conductances (a contact's series resistance includes the half-cell of the material beside it) do
not add: every pair of swept knobs is tested for additivity on the assembled operators, and a
non-additive pair is interpolated jointly on the tensor grid of its nodes.

:func:`verify` re-runs randomly chosen cases on the full FEM; their largest site error is the
sweep's proof, and a sweep whose error exceeds the tolerance is reported as failed (exit 3).
"""

from __future__ import annotations

import itertools
import time
from dataclasses import dataclass

import numpy as np

from imutherm import InputError
from imutherm.thermal.reduced import Knob, SparsePlusLowRank, build_reduced, linearised, sparse_part
from imutherm.studies.sweep.keys import key_kind

#: largest relative t95 error of a verified case with the transient (the study's t95 target, 1 %)
VERIFY_T95_REL = 0.01
#: relative size of a non-additive part of two knobs' operator changes that makes them a coupled pair
ADDITIVE_RTOL = 1e-8
#: Chebyshev nodes per kind of key: laws linear in the parameter (2 would do; 3 guards a law that is
#: not), conductances in series with a half-cell (log coordinate, as the correlation's contacts),
#: material conductivities (linear in the cells, in series at contacts), cavity emissivities (the
#: radiosity exchange is nearly linear, see knobs.S2S_EMISSIVITY_NODES)
NODES_LINEAR, NODES_CONTACT, NODES_K, NODES_CAVITY = 3, 6, 5, 4
#: time grid of the reduced transient [s] (times t_end x this): dense enough that t95's log interpolation
#: between points is exact to < 1e-4 of t95 for the unit's time constants
_T_GRID = np.concatenate([[0.0], np.geomspace(1e-4, 1.0, 600)])


def knob_of(factor, geometry) -> Knob:
    """The reduced model's :class:`Knob` of a sweep factor, over the factor's range; a power's knob value is
    the change from the layout's power [W] (:func:`knob_values`)."""
    from imutherm.unit.effects import power_part

    kind = key_kind(factor.key)
    lo, hi = (float(v) for v in factor.bounds)
    if lo == hi:  # a one-value factor: any small interval holds it
        lo, hi = lo * 0.999 - 1e-12, hi * 1.001 + 1e-12
    if kind == "power":
        part = factor.key.split(".")[1]
        p0 = power_part(geometry, part).power_W
        return Knob(factor.key, "W", lo - p0, hi - p0, part=part)
    if kind in ("contact", "k"):
        return Knob(factor.key, factor.unit, lo, hi, log=True, nodes=NODES_CONTACT if kind == "contact" else NODES_K)
    return Knob(factor.key, factor.unit, lo, hi, nodes=NODES_CAVITY if kind == "cavity" else NODES_LINEAR)


def knob_values(knobs, row, base_power) -> dict:
    """Knob values of one case (``row``: factor values in order); powers as changes from ``base_power`` [W]."""
    return {k.name: (float(v) - base_power[k.name] if k.part is not None else float(v)) for k, v in zip(knobs, row)}


# ------------------------------------------------------------------ build
@dataclass(frozen=True)
class SweepSurrogate:
    """The reduced model of a sweep and what it needs to evaluate a case.

    rom : ReducedModel (probes: the layout's sites, then ``hot@<part>`` points)
    knobs : tuple of Knob, in factor order; base_power : dict key -> layout power [W] (power keys)
    sites : tuple of the layout's site names; pairs : tuple of jointly interpolated key pairs
    build_s : float [s] (nominal steady solve, additivity test, reduced-model build)
    """

    rom: object
    knobs: tuple
    base_power: dict
    sites: tuple
    pairs: tuple
    build_s: float


def _powered_nodes(grid, geometry, knobs=()) -> np.ndarray:
    """Every node of the powered parts (and of the parts a power knob heats) [-]: where the largest steady
    rise is (the field has no maximum where there is no source, so it lies in the closure of the parts
    that dissipate)."""
    from imutherm.unit.effects import power_part
    conn = grid.hex_connectivity()
    cells = np.asarray(grid.cell_part).ravel()
    names = {p.name for p in geometry.parts if p.power_W} | {power_part(geometry, k.part).name for k in knobs
                                                             if k.part is not None}
    ids = [grid.part_names.index(n) for n in sorted(names) if n in grid.part_names]
    return np.unique(conn[np.isin(cells, ids)])


def _hot_spots(grid, geometry, T_C) -> dict:
    """``hot@<part>`` -> the coordinates [m] of the hottest node of each powered part in the field ``T_C``."""
    conn = grid.hex_connectivity()
    xyz = grid.node_coordinates()
    cells = np.asarray(grid.cell_part).ravel()
    out = {}
    for p in geometry.parts:
        if not p.power_W or p.name not in grid.part_names:
            continue
        nodes = np.unique(conn[cells == grid.part_names.index(p.name)])
        if nodes.size:
            out[f"hot@{p.name}"] = tuple(float(c) for c in xyz[nodes[np.argmax(T_C[nodes])]])
    return out


def _coupled_pairs(variant_fn, grid, T_C, knobs) -> tuple:
    """Pairs of (non-load) knobs whose operator changes do not add, found on the assembled operators."""
    from imutherm.thermal.assembly import assemble
    from imutherm.unit.effects import effect_problem

    def op(values):
        A, _ = linearised(assemble(effect_problem(variant_fn(values), grid), mass=False), T_C)
        return sparse_part(A).data, (A.G if isinstance(A, SparsePlusLowRank) else np.zeros((0, 0)))

    moving = [k for k in knobs if not k.is_load]
    if len(moving) < 2:
        return ()
    # two points inside each range (not a node, not the nominal value by accident)
    val = {k.name: float(k.from_u(0.37)) for k in moving}
    s0, g0 = op({})
    single = {k.name: op({k.name: val[k.name]}) for k in moving}
    pairs = []
    for a, b in itertools.combinations([k.name for k in moving], 2):
        sab, gab = op({a: val[a], b: val[b]})
        (sa, ga), (sb, gb) = single[a], single[b]
        ds = sab - sa - sb + s0
        scale = max(np.abs(sa - s0).max(initial=0), np.abs(sb - s0).max(initial=0), 1e-300)
        dg = gab - ga - gb + g0 if gab.size else np.zeros(0)
        gscale = max(np.abs(ga - g0).max(initial=0), np.abs(gb - g0).max(initial=0), 1e-300) if gab.size else 1.0
        if np.abs(ds).max(initial=0) > ADDITIVE_RTOL * scale or np.abs(dg).max(initial=0) > ADDITIVE_RTOL * gscale:
            pairs.append((a, b))
    return tuple(pairs)


def build_surrogate(plan, progress=None) -> SweepSurrogate:
    """The :class:`SweepSurrogate` of a sweep plan (its base layout, scheme, mesh and model options).

    Raises InputError when a knob is coupled to two others (the reduced model interpolates pairs only).
    """
    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.mesh import build_mesh
    from imutherm.thermal.assembly import assemble
    from imutherm.unit.effects import ModelVariant, effect_problem, power_part
    from imutherm.thermal.steady import solve_steady
    from imutherm.studies.sweep.plan import case_model

    t0 = time.perf_counter()
    say = progress or (lambda s: None)
    s = plan.settings
    layout, geometry, options = case_model(plan.raw, plan.path, s.scheme, plan.base_options, {})
    grid = build_mesh(geometry, s.mesh_size_mm, s.min_cells)

    def variant_fn(values):
        if not values:
            return ModelVariant(geometry, options)
        _, geo, opts = case_model(plan.raw, plan.path, s.scheme, plan.base_options, values)
        return ModelVariant(geo, opts)

    knobs = tuple(knob_of(f, geometry) for f in plan.factors)
    base_power = {k.name: power_part(geometry, k.part).power_W for k in knobs if k.part is not None}
    say(f"reduced model: nominal steady solve ({grid.n_nodes} unknowns)")
    pb = effect_problem(variant_fn({}), grid)
    st = solve_steady(pb, probes=dict(geometry.sites), assembly=assemble(pb))
    T_C = np.asarray(st.T_C)
    hot = _hot_spots(grid, geometry, T_C)
    say("reduced model: additivity of the knobs' operator changes")
    pairs = _coupled_pairs(variant_fn, grid, T_C, knobs)
    seen = [n for p in pairs for n in p]
    multi = sorted({n for n in seen if seen.count(n) > 1})
    if multi:
        raise InputError(f"--surrogate reduced: {', '.join(multi)} change(s) the same conductances as two other "
                         f"keys ({pairs}); the reduced model interpolates pairs only: use --surrogate none")
    say(f"reduced model: building ({len(knobs)} knobs{', pairs ' + str(pairs) if pairs else ''})")
    probes = dict(geometry.sites)
    probes.update(hot)
    rom = build_reduced(variant_fn, grid, knobs, probes, pairs=pairs, load_directions=True,
                        max_nodes=_powered_nodes(grid, geometry, knobs))
    return SweepSurrogate(rom, knobs, base_power, tuple(geometry.sites), pairs, time.perf_counter() - t0)


# ------------------------------------------------------------------ evaluate
def evaluate(sur: SweepSurrogate, row, transient: bool = False, t_end: float = 1200.0) -> dict:
    """Outputs of one case on the reduced model, named as :func:`imutherm.studies.sweep.case.case_outputs` names
    them: ``max_rise_K``, ``rise_<site>_K`` [K], with ``transient`` ``t95_s`` [s] of the hottest site (None
    if not settled by ``t_end``)."""
    from imutherm.thermal.metrics import T95_FRACTION, settle_time

    rom = sur.rom
    vals = knob_values(sur.knobs, row, sur.base_power)
    A, _, b = rom.operators(vals)
    x = np.linalg.solve(A, b)
    rise = rom.P @ x
    m = len(sur.sites)
    out = {"max_rise_K": rom.max_rise(x)}
    if transient:
        j = int(np.argmax(rise[:m]))
        t = _T_GRID * t_end
        curve = rom.rise(vals, t)[:, j]
        t95 = settle_time(t, curve, T95_FRACTION, float(rise[j]))
        out["t95_s"] = None if not np.isfinite(t95) else float(t95)
    out.update({f"rise_{n}_K": float(v) for n, v in zip(sur.sites, rise[:m])})
    return out


def evaluate_all(sur: SweepSurrogate, X, transient: bool = False, t_end: float = 1200.0) -> list:
    """One row dict per case of the design ``X`` (cases, factors): outputs, ``status``, ``seconds``."""
    rows = []
    for i, row in enumerate(np.asarray(X, float)):
        t0 = time.perf_counter()
        try:
            r = {"case": i, **evaluate(sur, row, transient, t_end), "status": "ok", "message": ""}
        except (np.linalg.LinAlgError, InputError, ValueError) as exc:
            r = {"case": i, "status": "failed", "message": f"reduced model: {type(exc).__name__}: {exc}"}
        r["seconds"] = time.perf_counter() - t0
        rows.append(r)
    return rows


# ------------------------------------------------------------------ verify
def pick_cases(n_cases: int, n: int, seed) -> list:
    """``n`` distinct case ids drawn at random (seeded: the same sweep checks the same cases)."""
    rng = np.random.default_rng(0 if seed is None else seed)
    return sorted(int(i) for i in rng.choice(n_cases, size=min(n, n_cases), replace=False))


def compare_rows(reduced: dict, full: dict, sites) -> dict:
    """Errors of one reduced case against its full-FEM row: ``site_error_K`` (largest over the sites),
    ``max_rise_error_K``, ``t95_rel_error`` (or None) [-]."""
    if full.get("status") != "ok":
        return {"case": full["case"], "status": "failed", "message": full.get("message", "")}
    site = max(abs(reduced[f"rise_{s}_K"] - full[f"rise_{s}_K"]) for s in sites)
    out = {"case": full["case"], "status": "ok", "site_error_K": float(site),
           "max_rise_error_K": float(abs(reduced["max_rise_K"] - full["max_rise_K"])),
           "full_max_rise_K": float(full["max_rise_K"]), "t95_rel_error": None}
    if "t95_s" in full and full.get("t95_s") and reduced.get("t95_s"):
        out["t95_rel_error"] = float(abs(reduced["t95_s"] - full["t95_s"]) / full["t95_s"])
    return out


def verification_summary(checks: list, tol_K: float, t95_rel: float, transient: bool) -> dict:
    """The sweep's proof: worst errors over the checked cases and whether each is within its tolerance."""
    ok = [c for c in checks if c["status"] == "ok"]
    site = max((c["site_error_K"] for c in ok), default=None)
    hot = max((c["max_rise_error_K"] for c in ok), default=None)
    t95 = max((c["t95_rel_error"] for c in ok if c["t95_rel_error"] is not None), default=None)
    problems = []
    if len(ok) < len(checks):
        problems.append(f"{len(checks) - len(ok)} checked case(s) failed on the full FEM")
    if site is not None and site > tol_K:
        problems.append(f"largest site error {site:.3g} K > {tol_K:g} K")
    if hot is not None and hot > tol_K:
        problems.append(f"largest max-rise error {hot:.3g} K > {tol_K:g} K")
    if transient and t95 is not None and t95 > t95_rel:
        problems.append(f"largest t95 error {100 * t95:.2g} % > {100 * t95_rel:g} %")
    return {"cases": [c["case"] for c in checks], "checks": checks, "tolerance_K": tol_K,
            "t95_tolerance_rel": t95_rel if transient else None, "max_site_error_K": site,
            "max_rise_error_K": hot, "max_t95_rel_error": t95, "passed": not problems, "problems": problems}


def verify_words(v: dict) -> str:
    """One line on the verification (for the CLI and the PDF)."""
    if not v["cases"]:
        return "not verified against the full FEM (--verify 0)"
    s = (f"{len(v['cases'])} random case(s) re-run on the full FEM: largest site error "
         f"{v['max_site_error_K']:.3g} K, largest max-rise error {v['max_rise_error_K']:.3g} K"
         if v["max_site_error_K"] is not None else f"{len(v['cases'])} case(s) re-run on the full FEM")
    if v["max_t95_rel_error"] is not None:
        s += f", t95 within {100 * v['max_t95_rel_error']:.2g} %"
    s += f" (tolerance {v['tolerance_K']:g} K" + (f", {100 * v['t95_tolerance_rel']:g} % on t95)" if
                                                  v["t95_tolerance_rel"] else ")")
    return s + (": PASS" if v["passed"] else ": FAIL — " + "; ".join(v["problems"]))

