"""The plan of a sweep: its factors, design (grid, SALib LHS / Morris / Sobol'), cases and cost.

:func:`plan_sweep` checks every key and every case before anything runs (each case's values are
applied to the layout file's dict, which is re-parsed and built, so the layout's own checks run) and
returns a frozen :class:`SweepPlan`; :func:`estimate_cost` estimates its CPU time from the mesh size
(the constants below say what they were measured on).
"""

from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from imutherm import InputError
from imutherm.geometry.build import build_geometry
from imutherm.geometry.layout import default_layout_path, parse_layout
from imutherm.geometry.materials import get_material, with_properties
from imutherm.geometry.mesh import DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS, grid_shape
from imutherm.studies.sweep.case import attitude_columns
from imutherm.studies.sweep.keys import split_set, tidy_value, unknown_key_error, parse_values, valid_keys
from imutherm.unit.model import ModelOptions

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

METHODS = ("grid", "lhs", "morris", "sobol")
#: Morris grid levels (SALib's default; Morris & Campolongo recommend an even p, 4 is usual)
MORRIS_LEVELS = 4
#: CPU time per mesh unknown of one steady case [s]: benchmarks/bench_sweep.py on the 2-core development
#: machine, 50 cases of the reference unit at the default mesh: 7.4 s per case for 185 724 unknowns
STEADY_S_PER_UNKNOWN = 4.0e-5
#: a case with the 1200 s power-on transient costs about this many steady cases (the thermal benchmark,
#: benchmarks/bench_thermal_core.py, grease: the transient adds 25.1 s to a ~7 s steady case; measured with the θ-scheme steps, the adaptive
#: TR-BDF2 default was not re-measured for this estimate)
TRANSIENT_FACTOR = 4.5
#: most cases of one sweep: 1e5 cases at the default mesh are ~9 days of one core (7.4 s each); more is a
#: typing error (1,000 x 1,000 values) rather than a study. Counted before the design is expanded.
MAX_CASES = 100_000
#: default most estimated CPU time of a sweep's cases [h] (``--max-cpu-hours``): a week of one core
MAX_CPU_HOURS = 168.0
#: reduced-model sweep (benchmarks/bench_sweep_sobol.py, 2026-12-01, shared machine, CPU time): build time per
#: mesh unknown of a 6-knob model [s] (~125 CPU-s at 185 724 unknowns: the nominal steady solve, the knobs'
#: additivity test, 25 basis solves, the knob interpolation)
REDUCED_BUILD_S_PER_UNKNOWN = 6.5e-4
#: one case on the reduced model [s] (an r x r solve, r ~ 100), and with the transient's modal response
REDUCED_CASE_S, REDUCED_TRANSIENT_FACTOR = 5e-4, 5.0


@dataclass(frozen=True)
class Factor:
    """One swept input.

    key : str, dotted path (see the module docstring)
    values : tuple of float or None, the levels of a grid design
    bounds : (lo, hi) or None, the range of an LHS / Morris design
    unit : str, e.g. ``W``, ``degC``, ``W/m^2 K`` (for labels)
    """

    key: str
    values: tuple | None
    bounds: tuple | None
    unit: str


@dataclass(frozen=True)
class CaseSettings:
    """What every case shares: scheme, mesh and run switches (sent to the workers once per case)."""

    scheme: str
    mesh_size_mm: float
    min_cells: int
    transient: bool
    t_end: float
    sites: tuple
    attitude: bool
    attitude_seeds: int = 1


@dataclass(frozen=True)
class Case:
    """One case: its id, input values (in factor order), the checked layout and model options."""

    case_id: int
    values: tuple
    layout: object
    options: ModelOptions


@dataclass(frozen=True)
class SweepPlan:
    """A checked sweep, ready to run.

    design : dict, everything that determines the rows (recorded in ``sweep.json``; a resume must match it)
    factors : tuple of Factor
    X : ndarray (cases, factors), the input values of every case
    cases : tuple of Case
    settings : CaseSettings
    outputs : tuple of str, output columns of ``results.csv``
    unknowns : ndarray (cases,), mesh unknowns of every case
    """

    design: dict
    factors: tuple
    X: np.ndarray
    cases: tuple
    settings: CaseSettings
    outputs: tuple
    unknowns: np.ndarray
    #: the layout file's dict and path, and the base model options: what a case's model is built from
    raw: dict | None = None
    path: str | None = None
    base_options: ModelOptions | None = None

    @property
    def surrogate(self) -> str:
        """``reduced`` (cases on the reduced model, a few verified on the full FEM) or ``none``."""
        return self.design.get("surrogate", "none")

    @property
    def keys(self) -> tuple:
        return tuple(f.key for f in self.factors)

    @property
    def columns(self) -> tuple:
        """Header of ``results.csv``."""
        return ("case",) + self.keys + self.outputs + ("status", "message", "seconds")


@dataclass(frozen=True)
class CostEstimate:
    """cases : int; unknowns : int (mean per case); case_s : float [s] per case; total_s : float [s] on ``jobs``."""

    cases: int
    unknowns: int
    case_s: float
    total_s: float
    jobs: int


def count_cases(factors, method: str, samples: int | None) -> int:
    """Cases [-] of the design of ``factors``, in O(factors): the product of the value counts (grid),
    ``samples`` (lhs) or ``samples`` x (factors + 1) (morris); 0 if ``samples`` is missing (refused later)."""
    if method == "grid":
        return math.prod(len(f.values) for f in factors)
    if samples is None or samples < 1:
        return 0
    return int(samples) * (len(factors) + 1 if method == "morris" else 1)


def _count_words(factors, method: str, samples) -> str:
    if method == "grid":
        return " x ".join(f"{len(f.values):,}" for f in factors) + " values"
    return f"--samples {samples:,}" + (f" x {len(factors) + 1} (inputs + 1)" if method == "morris" else "")


def _design_matrix(factors, method: str, samples: int | None, seed: int | None) -> np.ndarray:
    if method == "grid":
        return np.array(list(itertools.product(*(f.values for f in factors))), float)
    if samples is None or samples < 1:
        raise InputError(f"--method {method} needs --samples N >= 1, got {samples!r}")
    if seed is None:
        raise InputError(f"--method {method} needs --seed N (the design is reproducible from it)")
    problem = {"num_vars": len(factors), "names": [f.key for f in factors], "bounds": [list(f.bounds) for f in factors]}
    rng = np.random.default_rng(seed)
    if method == "lhs":
        from SALib.sample import latin
        X = latin.sample(problem, samples, seed=rng)
    elif method == "sobol":
        if samples & (samples - 1):
            raise InputError(f"--method sobol needs --samples a power of 2 (the Sobol' sequence's balance), got "
                             f"{samples}; e.g. {1 << (samples.bit_length() - 1)} or {1 << samples.bit_length()} "
                             f"(cases = samples x (inputs + 2))")
        from SALib.sample import sobol
        X = sobol.sample(problem, samples, calc_second_order=False, scramble=True, seed=seed)
    else:
        from SALib.sample import morris
        X = morris.sample(problem, samples, num_levels=MORRIS_LEVELS, seed=rng)
    return np.vectorize(tidy_value)(np.asarray(X, float)).reshape(-1, len(factors))


def _assign(data: dict, key: str, value: float) -> None:
    """Set the numeric leaf ``key`` of a layout dict (the key was checked against :func:`valid_keys`)."""
    parts = key.split(".")
    node = data[parts[0]]
    rest = parts[1:]
    if isinstance(node, list):  # array of tables, selected by name
        node = next(t for t in node if t.get("name") == rest[0])
        rest = rest[1:]
    while len(rest) > 1 and not rest[1].isdigit():
        node = node[rest[0]]
        rest = rest[1:]
    if len(rest) == 2:  # vector element
        node[rest[0]][int(rest[1])] = value
    else:
        node[rest[0]] = value


def case_model(raw: dict, path: str, scheme: str, base: ModelOptions, values: dict, fitted=None) -> tuple:
    """(layout, geometry, options) of one case: ``values`` (key -> value) written into a copy of the layout
    file's dict ``raw`` (re-parsed and built, so the layout's checks run; with the fitted model's powers if
    ``fitted``), ``options.*`` and ``materials.*`` keys applied to the base options ``base``. Raises InputError
    from the layout, geometry or materials."""
    data = copy.deepcopy(raw)
    opts, mats = {}, {}
    for key, v in values.items():
        head = key.split(".")
        if head[0] == "options":
            opts[head[1]] = v
        elif head[0] == "materials":
            mats.setdefault(head[1], {})[head[2]] = v
        else:
            _assign(data, key, v)
    layout = parse_layout(data, path)
    if fitted is not None:
        from imutherm.studies.thermal.fitted_model import fitted_layout
        layout = fitted_layout(fitted, layout)
    geometry = build_geometry(layout, scheme)
    overrides = tuple(with_properties(get_material(m), f"--set materials.{m}", **ch) for m, ch in mats.items())
    options = base.with_(**opts, materials=base.materials + overrides)
    return layout, geometry, options


def _case(case_id: int, values, factors, raw: dict, path: str, settings: CaseSettings, base: ModelOptions,
          fitted=None, mesh: bool = True) -> tuple:
    """(Case, unknowns): the case's layout re-parsed and built (with the fitted model's powers if ``fitted``),
    its options and materials checked (``mesh`` False: the mesh is not counted and unknowns is 0)."""
    what = ", ".join(f"{f.key}={v:g}" for f, v in zip(factors, values))
    try:
        layout, geometry, options = case_model(raw, path, settings.scheme, base,
                                               {f.key: v for f, v in zip(factors, values)}, fitted)
        # counted from the grid lines alone (the mesh of every case is not built at planning)
        unknowns = (int(np.prod([n + 1 for n in grid_shape(geometry, settings.mesh_size_mm, settings.min_cells)]))
                    if mesh else 0)
    except InputError as exc:
        raise InputError(f"--set: case {case_id} ({what}) is refused: {exc}") from None
    return Case(case_id, tuple(values), layout, options), unknowns


def full_case(plan: SweepPlan, case_id: int) -> Case:
    """The case ``case_id`` with its layout and options built (a reduced-model plan keeps values only)."""
    c = plan.cases[case_id]
    if c.layout is not None:
        return c
    return _case(case_id, c.values, plan.factors, plan.raw, plan.path, plan.settings, plan.base_options, mesh=False)[0]


def _canonical_hash(data) -> str:
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()


def plan_sweep(layout_path=None, scheme: str | None = None, sets=(), *, method: str = "grid",
               samples: int | None = None, seed: int | None = None, options: ModelOptions | None = None,
               mesh_size_mm: float = DEFAULT_MAX_CELL_MM, min_cells: int = DEFAULT_MIN_CELLS,
               transient: bool = False, t_end: float = 1200.0, attitude: bool = False,
               attitude_seeds: int = 1, max_cpu_hours: float = None, fitted=None, surrogate: str = "none",
               verify: int | None = None, verify_tol_K: float | None = None) -> SweepPlan:
    """Check a sweep and build every case; nothing runs.

    Parameters
    ----------
    layout_path : path or None (the reference unit)
    scheme : str or None (the layout's default)
    sets : sequence of ``KEY=VALUES`` strings
    method : ``grid`` (full factorial of the value lists), ``lhs`` (SALib Latin hypercube of ``samples``
        cases), ``morris`` (SALib Morris design: ``samples`` trajectories of factors + 1 cases) or ``sobol``
        (SALib Saltelli/Sobol' design for first and total order indices: ``samples`` (a power of 2) x
        (factors + 2) cases)
    samples, seed : int, design size and seed of lhs / morris
    options : ModelOptions, the base model (``options.*`` and ``materials.*`` keys change it per case)
    mesh_size_mm : float [mm]; min_cells : int
    transient : bool, also run the power-on transient (adds ``t95_s``); t_end : float [s]
    attitude : bool, add the attitude-error columns of :func:`attitude_columns` (one call of
        :func:`imutherm.studies.end_to_end.scheme_attitude_metrics` per case, the same seeds in every case)
    attitude_seeds : int, IMU units / noise draws averaged per case (seeds 0 .. n-1)
    max_cpu_hours : float [h], most estimated CPU time of all cases (default :data:`MAX_CPU_HOURS`): the
        cases are counted and the first case's mesh estimated before the design is expanded
    fitted : FittedModel or None, the correlated model (:mod:`imutherm.studies.thermal.fitted_model`): its powers
        act on every case's layout (after the case's own values); its other values must already be in
        ``options`` (``imutherm.cli._options.run_inputs``)
    surrogate : ``reduced`` (cases on the scheme's reduced model, :mod:`imutherm.studies.sweep.surrogate`:
        every key must be one of its knobs), ``none`` (every case on the full FEM) or ``auto`` (reduced when
        every key is a knob and no attitude columns are asked for, else none)
    verify : int, cases re-run on the full FEM to prove a reduced-model sweep (default 5)
    verify_tol_K : float [K], the largest site or max-rise error a verified case may show (default 0.1 K)

    Raises InputError on more than :data:`MAX_CASES` cases or ``max_cpu_hours``, an unknown key (naming the nearest valid ones), a bad value or range,
    or a case the layout, the geometry or the model refuses.
    """
    if method not in METHODS:
        raise InputError(f"--method: unknown {method!r}; valid: {', '.join(METHODS)}")
    from imutherm.studies.sweep.keys import SURROGATES, VERIFY_DEFAULT, VERIFY_TOL_K, surrogate_keys

    if surrogate not in SURROGATES:
        raise InputError(f"--surrogate: unknown {surrogate!r}; valid: {', '.join(SURROGATES)}")
    verify = VERIFY_DEFAULT if verify is None else verify
    verify_tol_K = VERIFY_TOL_K if verify_tol_K is None else verify_tol_K
    if not (isinstance(verify, int) and verify >= 0):
        raise InputError(f"--verify must be an integer >= 0 (cases re-run on the full FEM), got {verify!r}")
    if not (isinstance(verify_tol_K, (int, float)) and math.isfinite(verify_tol_K) and verify_tol_K > 0):
        raise InputError(f"--verify-tol must be a finite number > 0 [K], got {verify_tol_K!r}")
    if method == "grid" and (samples is not None or seed is not None):
        raise InputError("--samples and --seed belong to --method lhs or morris; a grid runs every combination")
    if not sets:
        raise InputError("give at least one --set KEY=VALUES")
    if not (isinstance(t_end, (int, float)) and math.isfinite(t_end) and t_end > 0):
        raise InputError(f"--t-end must be a finite number > 0 [s], got {t_end!r}")
    max_cpu_hours = MAX_CPU_HOURS if max_cpu_hours is None else max_cpu_hours
    if not (isinstance(max_cpu_hours, (int, float)) and math.isfinite(max_cpu_hours) and max_cpu_hours > 0):
        raise InputError(f"--max-cpu-hours must be a finite number > 0 [h], got {max_cpu_hours!r}")
    if not (isinstance(attitude_seeds, int) and 1 <= attitude_seeds <= 1000):
        raise InputError(f"--attitude-seeds must be an integer in 1..1000, got {attitude_seeds!r}")
    path = Path(layout_path) if layout_path else default_layout_path()
    try:
        with open(path, "rb") as fh:
            raw = tomllib.load(fh)
    except FileNotFoundError:
        raise InputError(f"{path}: layout file not found") from None
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
    base_layout = parse_layout(raw, str(path))
    scheme = base_layout.scheme(scheme).name
    base = options or ModelOptions()
    valid = valid_keys(raw, base_layout, scheme)

    factors, seen = [], set()
    for item in sets:
        key, text = split_set(item)
        if key not in valid:
            raise unknown_key_error(key, valid)
        if key in seen:
            raise InputError(f"--set {key}: given twice; give all its values in one --set")
        seen.add(key)
        values, bounds = parse_values(key, text, method)
        factors.append(Factor(key, values, bounds, valid[key]))
    factors = tuple(factors)
    n_cases = count_cases(factors, method, samples)  # before the design is expanded
    if n_cases > MAX_CASES:
        raise InputError(f"--set: {n_cases:,} cases ({_count_words(factors, method, samples)}), more than the limit "
                         f"of {MAX_CASES:,}; use fewer values per --set, fewer keys or a smaller --samples "
                         "(an lhs / morris design samples many inputs in few cases)")
    unknowns0 = int(np.prod([n + 1 for n in grid_shape(build_geometry(base_layout, scheme), mesh_size_mm, min_cells)]))
    cpu_s = n_cases * unknowns0 * STEADY_S_PER_UNKNOWN * (TRANSIENT_FACTOR if transient else 1.0)
    if cpu_s > max_cpu_hours * 3600.0:
        raise InputError(f"--set: {n_cases:,} cases of ~{unknowns0:,} unknowns, estimated {cpu_s / 3600:,.3g} h of "
                         f"one core, more than --max-cpu-hours {max_cpu_hours:g}; use fewer cases, a larger "
                         "--mesh-size, or a larger --max-cpu-hours (a Dask cluster divides it over its workers)")
    X = _design_matrix(factors, method, samples, seed)

    sites = tuple(s.name for s in base_layout.sites)
    settings = CaseSettings(scheme, float(mesh_size_mm), int(min_cells), bool(transient), float(t_end), sites,
                            bool(attitude), int(attitude_seeds))
    if fitted is not None:
        from imutherm.studies.thermal.fitted_model import fitted_effects
        if fitted_effects(fitted):
            raise InputError(f"--model {fitted.path}: effect(s) {', '.join(e.text() for e in fitted_effects(fitted))} "
                             f"add a boundary law a sweep case cannot carry; use imutherm solve/compare --model")
        if surrogate == "reduced":
            raise InputError(f"--model {fitted.path}: the reduced-model sweep does not carry a fitted model's powers "
                             "yet; use --surrogate none")
        surrogate = "none"
    if surrogate != "none":
        fits, why = surrogate_keys(factors, build_geometry(base_layout, scheme))
        if surrogate == "reduced" and attitude:
            raise InputError("--surrogate reduced gives thermal outputs only; --attitude needs --surrogate none")
        if surrogate == "reduced" and not fits:
            raise InputError(f"--surrogate reduced: {why}; use --surrogate none")
        surrogate = "reduced" if fits and not attitude else "none"
    if surrogate == "reduced":
        # every key is a coefficient on the same mesh: the layout's, geometry's and materials' checks of a
        # value are interval checks per key, so the cases holding each key's smallest and largest value check
        # every case; the mesh is built once
        ids = sorted({0} | {int(i) for j in range(len(factors)) for i in (np.argmin(X[:, j]), np.argmax(X[:, j]))})
        for i in ids:
            _case(i, tuple(float(v) for v in X[i]), factors, raw, str(path), settings, base, mesh=False)
        n0 = unknowns0  # the tensor grid's nodes (every case shares the mesh)
        cases = tuple(Case(i, tuple(float(v) for v in row), None, None) for i, row in enumerate(X))
        unknowns = np.full(len(cases), n0, int)
    else:
        built = [_case(i, tuple(float(v) for v in row), factors, raw, str(path), settings, base, fitted)
                 for i, row in enumerate(X)]
        cases = tuple(c for c, _ in built)
        unknowns = np.array([n for _, n in built], int)
    outputs = ("max_rise_K",) + (("t95_s",) if transient else ()) + tuple(f"rise_{s}_K" for s in sites)
    if attitude:
        outputs += attitude_columns(transient)
    base_opts = asdict(base)
    base_opts["materials"] = [m.name for m in base.materials]
    design = {
        "layout": str(path.resolve()), "layout_sha256": _canonical_hash(raw), "scheme": scheme,
        "method": method, "samples": samples, "seed": seed,
        "morris_levels": MORRIS_LEVELS if method == "morris" else None,
        "factors": [{"key": f.key, "unit": f.unit, "values": list(f.values) if f.values else None,
                     "bounds": list(f.bounds)} for f in factors],
        "cases": len(cases), "mesh_size_mm": float(mesh_size_mm), "min_cells": int(min_cells),
        "transient": bool(transient), "t_end_s": float(t_end) if transient else None, "attitude": bool(attitude),
        "attitude_seeds": int(attitude_seeds) if attitude else None,
        "model_options": json.loads(json.dumps(base_opts, default=str)),
        "X_sha256": _canonical_hash(X.tolist()),
        **({"model": fitted.summary()} if fitted is not None else {}),
        "surrogate": surrogate,
        "verify": int(verify) if surrogate == "reduced" else None,
        "verify_tol_K": float(verify_tol_K) if surrogate == "reduced" else None,
    }
    return SweepPlan(design, factors, X, cases, settings, outputs, unknowns, raw, str(path), base)


def estimate_cost(plan: SweepPlan, jobs: int = 1) -> CostEstimate:
    """Cases and an estimate of the wall time: mesh unknowns x :data:`STEADY_S_PER_UNKNOWN`
    (x :data:`TRANSIENT_FACTOR` with the transient), divided over ``jobs`` workers."""
    per = plan.unknowns * STEADY_S_PER_UNKNOWN * (TRANSIENT_FACTOR if plan.settings.transient else 1.0)
    n = len(plan.cases)
    if plan.surrogate == "reduced" and n:
        build = plan.unknowns[0] * REDUCED_BUILD_S_PER_UNKNOWN * (1.0 + len(plan.factors) / 6.0) / 2.0
        verify = min(plan.design["verify"], n) * float(per[0]) / max(1, min(jobs, plan.design["verify"] or 1))
        total = build + n * REDUCED_CASE_S * (REDUCED_TRANSIENT_FACTOR if plan.settings.transient else 1.0) + verify
        return CostEstimate(n, int(plan.unknowns[0]), total / n, total, jobs)
    return CostEstimate(n, int(plan.unknowns.mean()) if n else 0, float(per.mean()) if n else 0.0,
                        float(per.sum()) / max(1, min(jobs, n or 1)), jobs)
