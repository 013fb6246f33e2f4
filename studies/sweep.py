"""Parameter sweeps of one cooling scheme: design, sampling, running (local or Dask), resume, sensitivity.

A sweep varies numeric inputs named by dotted keys:

- ``<table>.<field>`` and ``<array>.<name>.<field>[.<index>]`` of the layout file, e.g.
  ``environment.ambient_C``, ``mounting.contact_conductance_W_m2K``, ``components.reg_5v.power_W``,
  ``boards.main.min_mm.2`` (an element of a vector);
- ``materials.<material>.<property>`` of a material the scheme uses (``k`` or ``k_in_plane`` /
  ``k_through``, ``density``, ``specific_heat``, ``emissivity``): a changed copy of the library entry is
  handed to the model (``ModelOptions.materials``), the library is not touched;
- ``options.<field>`` of the numeric :class:`~imutherm.thermal.model.ModelOptions`, e.g. ``options.emissivity``.

:func:`plan_sweep` checks every key and every case before anything runs (each case's values are
applied to the layout file's dict, which is re-parsed and built, so the layout's own checks run);
:func:`run_sweep` runs the missing cases and appends one row per case to ``results.csv`` as each
finishes (flushed and fsynced), so a killed sweep loses only the cases in flight and ``resume``
runs exactly the missing case ids. Designs (grid, Latin hypercube, Morris) and the Morris
measures come from SALib; for grid and LHS the influence measure is the standardised regression
coefficient (SRC) of a linear least-squares fit, reported with its R^2.
"""

from __future__ import annotations

import copy
import csv
import difflib
import hashlib
import io
import itertools
import json
import math
import os
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import asdict, dataclass, fields
from pathlib import Path

import numpy as np

from imutherm import InputError
from imutherm.geometry.build import build_geometry
from imutherm.geometry.layout import default_layout_path, parse_layout
from imutherm.geometry.materials import PROPERTY_UNITS, get_material, settable_properties, with_properties
from imutherm.geometry.mesh import DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS, grid_shape
from imutherm.thermal.model import ModelOptions

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
#: a case with the 1200 s power-on transient costs about this many steady cases (README thermal benchmark,
#: grease: the transient adds 25.1 s to a ~7 s steady case; measured with the θ-scheme steps, the adaptive
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
#: optional numeric fields a layout table may leave out (their defaults apply) but a sweep may set
_OPTIONAL_FIELDS = {"components": ("power_W", "die_base_mm"), "parts": ("power_W",),
                    "mounting": ("temperature_C",), "schemes": ("max_bond_gap_mm",)}
RESULTS_CSV = "results.csv"
SWEEP_JSON = "sweep.json"


# ---------------------------------------------------------------- design
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


@dataclass(frozen=True)
class SweepResult:
    """The outcome of :func:`run_sweep`.

    out_dir : Path
    plan : SweepPlan
    rows : list of dict, every recorded case sorted by id (values as in ``results.csv``: floats, None when empty)
    ran : int, cases run by this call; skipped : int, cases already recorded (resume)
    failed : int, rows with status ``failed``; lost : tuple of case ids not run (a worker died)
    sensitivity : dict, see :func:`sensitivity`
    wall_s : float [s] of this call
    """

    out_dir: Path
    plan: SweepPlan
    rows: list
    ran: int
    skipped: int
    failed: int
    lost: tuple
    sensitivity: dict
    wall_s: float
    #: the reduced-model sweep's check against the full FEM (:func:`~imutherm.studies.sweep_surrogate.verification_summary`)
    verification: dict | None = None
    #: timings of the reduced-model sweep [s]: build, evaluation, verification
    timings: dict | None = None


def key_unit(key: str) -> str:
    """Unit of a sweep key or output column from its name (``_W_m2K`` -> ``W/m^2 K``, ``_mm`` -> ``mm`` ...)."""
    parts = key.split(".")
    if parts[0] == "materials" and len(parts) == 3:
        return PROPERTY_UNITS.get(parts[2], "-")
    name = parts[-2] if parts[-1].isdigit() and len(parts) > 1 else parts[-1]
    for suffix, unit in (("_W_m2K", "W/m^2 K"), ("_mm", "mm"), ("_C", "degC"), ("_W", "W"), ("_K", "K"),
                         ("_s", "s"), ("_deg", "deg"), ("_V", "V"), ("_A", "A")):
        if name.endswith(suffix):
            return unit
    return "-"


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _layout_keys(raw: dict, scheme: str) -> dict:
    """Settable numeric leaves of a layout dict: dotted key -> unit."""
    keys = {}

    def leaf(prefix, name, value):
        if _is_number(value):
            keys[f"{prefix}.{name}"] = key_unit(name)
        elif isinstance(value, list) and value and all(_is_number(v) for v in value):
            for i in range(len(value)):
                keys[f"{prefix}.{name}.{i}"] = key_unit(name)

    def table(prefix, t, kind):
        for name, value in t.items():
            leaf(prefix, name, value)
        for name in _OPTIONAL_FIELDS.get(kind, ()):
            keys.setdefault(f"{prefix}.{name}", key_unit(name))

    for top, value in raw.items():
        if top == "schemes" and isinstance(value, dict):
            if isinstance(value.get(scheme), dict):
                table(f"schemes.{scheme}", value[scheme], "schemes")
        elif isinstance(value, dict):
            if all(isinstance(v, dict) for v in value.values()) and value:  # [sites]: named inline tables
                for name, t in value.items():
                    table(f"{top}.{name}", t, top)
            else:
                table(top, value, top)
        elif isinstance(value, list) and value and all(isinstance(t, dict) for t in value):
            for t in value:
                if isinstance(t.get("name"), str):
                    table(f"{top}.{t['name']}", t, top)
    return keys


def _options_keys() -> dict:
    """Numeric ModelOptions fields: ``options.<field>`` -> unit."""
    out = {}
    for f in fields(ModelOptions):
        if "float" in str(f.type):
            out[f"options.{f.name}"] = "-" if "emissivity" in f.name else key_unit(f.name)
    return out


def _material_keys(geometry) -> dict:
    out = {}
    for name in sorted({p.material for p in geometry.parts}):
        for prop in settable_properties(get_material(name)):
            out[f"materials.{name}.{prop}"] = PROPERTY_UNITS[prop]
    return out


def valid_keys(raw: dict, layout, scheme: str) -> dict:
    """Every key a sweep of ``scheme`` of this layout may set: dotted key -> unit."""
    keys = _layout_keys(raw, scheme)
    keys.update(_material_keys(build_geometry(layout, scheme)))
    keys.update(_options_keys())
    return keys


def _unknown_key(key: str, valid) -> InputError:
    near = difflib.get_close_matches(key, list(valid), n=5, cutoff=0.5)
    if not near:  # nearest by the last component (a right field in the wrong table, or vice versa)
        last = key.rsplit(".", 1)[-1]
        near = [k for k in valid if k.rsplit(".", 1)[-1] == last][:5]
    hint = f"nearest valid: {', '.join(near)}" if near else f"valid keys start with: {', '.join(sorted({k.split('.')[0] for k in valid}))}"
    return InputError(f"--set: unknown key {key!r}; {hint}")


def _number(text: str, key: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"--set {key}: {text.strip()!r} is not a number") from None
    if not math.isfinite(v):
        raise InputError(f"--set {key}: values must be finite numbers, got {text.strip()!r}")
    return v


def _tidy(v: float) -> float:
    """12 significant digits: linspace's 0.6000000000000001 becomes 0.6; every case uses the tidied value."""
    return float(f"{v:.12g}")


def parse_values(key: str, text: str, method: str) -> tuple:
    """(values, bounds) of one ``--set KEY=VALUES``.

    grid: a list ``0.5,1,2`` or ``lo:hi:n`` (n >= 2 evenly spaced values); lhs / morris: ``lo:hi`` with lo < hi.
    """
    text = text.strip()
    if not text:
        raise InputError(f"--set {key}=: no values; give a list 0.5,1,2 or a range lo:hi:n")
    if ":" in text:
        parts = text.split(":")
        if len(parts) not in (2, 3):
            raise InputError(f"--set {key}={text}: a range is lo:hi:n (grid) or lo:hi (lhs, morris)")
        lo, hi = _number(parts[0], key), _number(parts[1], key)
        if not lo < hi:
            raise InputError(f"--set {key}={text}: a range needs lo < hi")
        if method == "grid":
            if len(parts) != 3:
                raise InputError(f"--set {key}={text}: a grid range needs a count: lo:hi:n")
            try:
                n = int(parts[2])
            except ValueError:
                raise InputError(f"--set {key}={text}: n must be an integer >= 2, got {parts[2]!r}") from None
            if n < 2:
                raise InputError(f"--set {key}={text}: n must be an integer >= 2, got {n}")
            return tuple(_tidy(v) for v in np.linspace(lo, hi, n)), (lo, hi)
        if len(parts) == 3:
            raise InputError(f"--set {key}={text}: with --method {method} give the range as lo:hi "
                             "(the number of cases comes from --samples)")
        return None, (lo, hi)
    if method != "grid":
        raise InputError(f"--set {key}={text}: --method {method} samples a range: give lo:hi, not a list")
    values = tuple(_number(v, key) for v in text.split(","))
    if len(set(values)) != len(values):
        raise InputError(f"--set {key}={text}: repeated value (each case would run twice)")
    return values, (min(values), max(values))


def _split_set(item: str) -> tuple:
    if "=" not in item:
        raise InputError(f"--set {item!r}: expected KEY=VALUES, e.g. components.reg_5v.power_W=0.4,0.8,1.2")
    key, text = item.split("=", 1)
    key = key.strip()
    if not key:
        raise InputError(f"--set {item!r}: missing KEY before '='")
    return key, text


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
    return np.vectorize(_tidy)(np.asarray(X, float)).reshape(-1, len(factors))


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
        from imutherm.studies.fitted_model import fitted_layout
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
    fitted : FittedModel or None, the correlated model (:mod:`imutherm.studies.fitted_model`): its powers
        act on every case's layout (after the case's own values); its other values must already be in
        ``options`` (``imutherm.cli._options.run_inputs``)
    surrogate : ``reduced`` (cases on the scheme's reduced model, :mod:`imutherm.studies.sweep_surrogate`:
        every key must be one of its knobs), ``none`` (every case on the full FEM) or ``auto`` (reduced when
        every key is a knob and no attitude columns are asked for, else none)
    verify : int, cases re-run on the full FEM to prove a reduced-model sweep (default 5)
    verify_tol_K : float [K], the largest site or max-rise error a verified case may show (default 0.1 K)

    Raises InputError on more than :data:`MAX_CASES` cases or ``max_cpu_hours``, an unknown key (naming the nearest valid ones), a bad value or range,
    or a case the layout, the geometry or the model refuses.
    """
    if method not in METHODS:
        raise InputError(f"--method: unknown {method!r}; valid: {', '.join(METHODS)}")
    from imutherm.studies import sweep_surrogate as SS

    if surrogate not in SS.SURROGATES:
        raise InputError(f"--surrogate: unknown {surrogate!r}; valid: {', '.join(SS.SURROGATES)}")
    verify = SS.VERIFY_DEFAULT if verify is None else verify
    verify_tol_K = SS.VERIFY_TOL_K if verify_tol_K is None else verify_tol_K
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
        key, text = _split_set(item)
        if key not in valid:
            raise _unknown_key(key, valid)
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
        from imutherm.studies.fitted_model import fitted_effects
        if fitted_effects(fitted):
            raise InputError(f"--model {fitted.path}: effect(s) {', '.join(e.text() for e in fitted_effects(fitted))} "
                             f"add a boundary law a sweep case cannot carry; use imutherm solve/compare --model")
        if surrogate == "reduced":
            raise InputError(f"--model {fitted.path}: the reduced-model sweep does not carry a fitted model's powers "
                             "yet; use --surrogate none")
        surrogate = "none"
    if surrogate != "none":
        fits, why = SS.surrogate_keys(factors, build_geometry(base_layout, scheme))
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


# ---------------------------------------------------------------- one case
def case_outputs(result, sites) -> dict:
    """Outputs of one :class:`~imutherm.studies.thermal_study.SchemeResult`.

    max_rise_K [K] largest steady rise anywhere; rise_<site>_K [K] steady rise of each site;
    t95_s [s] (transient only) time to 95 % of its final rise of the site with the largest rise
    (None if it has not settled by t_end).
    """
    from imutherm.thermal.metrics import thermal_metrics

    steady = thermal_metrics(result.steady)
    out = {"max_rise_K": float(steady.max_rise_K)}
    if result.transient is not None:
        hottest = max(sites, key=lambda s: steady.probe_rise_K[s])
        t95 = result.metrics.t95_s[hottest]
        out["t95_s"] = None if t95 is None or not math.isfinite(t95) else float(t95)
    out.update({f"rise_{s}_K": float(steady.probe_rise_K[s]) for s in sites})
    return out


def attitude_columns(transient: bool) -> tuple:
    """The attitude columns of a sweep with ``--attitude``: roll and pitch RMS error [deg] of the lean
    IMU configuration :data:`~imutherm.studies.end_to_end.SWEEP_CONFIG` (improved compensation, unit
    calibrated in the oven with this case's self-heating, gated and kf filters, flight profile), per
    phase (``warmup`` needs ``transient``; ``steady``), then ``extrapolated_fraction`` [-] (share of
    compensated samples beyond the calibrated range).
    """
    from imutherm.studies.end_to_end import PHASES, SWEEP_CONFIG as C

    phases = PHASES if transient else ("steady",)
    return tuple(f"{ph}_{comp}_{f}_{prof}_{m}" for ph in phases for comp in C.compensations for f in C.filters
                 for prof in C.profiles for m in ("roll_rms_deg", "pitch_rms_deg")) + ("extrapolated_fraction",)


def run_case(case: Case, settings: CaseSettings) -> dict:
    """Run one case; any exception is recorded in the row (status ``failed``), never raised."""
    from imutherm.studies.thermal_study import run_scheme

    start = time.perf_counter()
    row = {"case": case.case_id}
    try:
        res = run_scheme(case.layout, settings.scheme, mesh_size_mm=settings.mesh_size_mm,
                         min_cells=settings.min_cells, options=case.options, transient=settings.transient,
                         t_end=settings.t_end)
        row.update(case_outputs(res, settings.sites))
        if settings.attitude:
            from imutherm.studies.end_to_end import scheme_attitude_metrics

            metrics = scheme_attitude_metrics(res, seeds=settings.attitude_seeds, seed0=0)
            cols = attitude_columns(settings.transient)
            missing = [c for c in cols if c not in metrics]
            if missing:
                raise RuntimeError(f"scheme_attitude_metrics gave no {', '.join(missing)}")
            row.update({c: float(metrics[c]) for c in cols})
        row.update(status="ok", message="")
    except Exception as exc:  # noqa: BLE001 - a failing case is recorded and the sweep goes on
        row.update(status="failed", message=f"{type(exc).__name__}: {' '.join(str(exc).split())}")
    row["seconds"] = time.perf_counter() - start
    return row


def _pool_case(case: Case, settings: CaseSettings) -> dict:
    """``run_case`` in a local worker; a worker whose sweep was killed stops instead of running queued cases."""
    from imutherm.studies import _worker

    if _worker.parent_gone():
        raise SystemExit(0)
    return run_case(case, settings)


# ---------------------------------------------------------------- results.csv
def _fmt(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if not math.isfinite(v) else repr(v)
    return str(v)


def _row_line(plan: SweepPlan, row: dict) -> str:
    values = dict(zip(plan.keys, plan.cases[row["case"]].values))
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(
        [_fmt(row.get(c, values.get(c))) for c in plan.columns])
    return buf.getvalue()


def _parse_cell(column: str, text: str):
    if column in ("status", "message"):
        return text
    if column == "case":
        return int(text)
    return float(text) if text != "" else None


def _damaged(path: Path, lineno: int, what: str) -> InputError:
    return InputError(f"{path}:{lineno}: {what}; the file is damaged: delete that line to run its case again "
                      "with --resume (or start a new --out)")


def read_results(path: Path, columns, cases=None, keys=()) -> list:
    """Rows of a ``results.csv``, checked line by line; a damaged line is refused naming it.

    A partial last line (no newline: a kill mid-write cut it) is the one repair made, as it is provably
    safe: it is dropped from the file and its case runs again. Every other line must decode as UTF-8, have
    the header's fields, an integer case id of the design (``cases``: the plan's cases, None: not checked),
    numbers in the numeric columns, status ok or failed, and inputs (``keys``: the plan's input columns) equal
    to its case's in the design.
    """
    data = path.read_bytes()
    if data and not data.endswith(b"\n"):
        cut = data.rfind(b"\n") + 1
        with open(path, "r+b") as fh:
            fh.truncate(cut)
        data = data[:cut]
    lines = data.split(b"\n")[:-1] if data else []
    if not lines:
        return []
    texts = []
    for i, raw in enumerate(lines, start=1):
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise _damaged(path, i, f"not UTF-8 text (byte {exc.start + 1})") from None
        if "\0" in text:
            raise _damaged(path, i, "a NUL byte")
        texts.append(text)
    try:
        parsed = [next(csv.reader([t])) if t else [] for t in texts]
    except csv.Error as exc:
        raise InputError(f"{path}: not a valid CSV: {exc}") from None
    header = parsed[0]
    if tuple(header) != tuple(columns):
        raise _damaged(path, 1, f"its columns {header} are not this sweep's {list(columns)}")
    rows, seen = [], set()
    for i, line in enumerate(parsed[1:], start=2):
        if len(line) != len(columns):
            raise _damaged(path, i, f"{len(line)} fields, the header has {len(columns)}")
        row = {}
        for c, t in zip(columns, line):
            try:
                row[c] = _parse_cell(c, t)
            except ValueError:
                what = "an integer case id" if c == "case" else "a number"
                raise _damaged(path, i, f"column {c!r} holds {t[:40]!r}, not {what}") from None
        if row["status"] not in ("ok", "failed"):
            raise _damaged(path, i, f"status {row['status'][:40]!r} is neither ok nor failed")
        if row["case"] in seen:
            raise _damaged(path, i, f"case {row['case']} is recorded twice")
        if cases is not None:
            if not 0 <= row["case"] < len(cases):
                raise _damaged(path, i, f"case id {row['case']} is not in this design (0..{len(cases) - 1})")
            design = dict(zip(keys, cases[row["case"]].values))
            off = [k for k, v in design.items() if k in row and row[k] != v]
            if off:
                raise _damaged(path, i, f"case {row['case']}'s {off[0]} = {row[off[0]]!r} is not the design's "
                                        f"{design[off[0]]!r}")
        seen.add(row["case"])
        rows.append(row)
    return rows


class _RowWriter:
    """Appends one complete line per call, flushed and fsynced."""

    def __init__(self, path: Path, plan: SweepPlan):
        self.plan = plan
        new = not path.exists() or path.stat().st_size == 0
        self.fh = open(path, "a", newline="")
        if new:
            self._write(",".join(plan.columns) + "\n")

    def _write(self, text: str) -> None:
        self.fh.write(text)
        self.fh.flush()
        os.fsync(self.fh.fileno())

    def append(self, row: dict) -> None:
        self._write(_row_line(self.plan, row))

    def close(self) -> None:
        self.fh.close()


def _atomic_write(path: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
    try:
        with os.fdopen(fd, "w", newline="") as fh:
            fh.write(text)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _json_text(data) -> str:
    def default(obj):
        if isinstance(obj, np.generic):
            return obj.item()
        if isinstance(obj, np.ndarray):
            return obj.tolist()
        if isinstance(obj, Path):
            return str(obj)
        raise TypeError(f"not JSON serialisable: {type(obj).__name__}")

    return json.dumps(data, indent=2, default=default) + "\n"


def _design_mismatch(old: dict, new: dict) -> list:
    return [k for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)]


# ---------------------------------------------------------------- sensitivity
def sensitivity(plan: SweepPlan, rows: list) -> dict:
    """Influence of each input on each output.

    morris: SALib ``analyze.morris`` (mu*, sigma, mu* confidence) when every case is ok;
    sobol: SALib ``analyze.sobol`` first-order S1 and total ST indices with their 95 % confidence half-widths
    (bootstrap, seeded) when every case is ok; otherwise (and for grid / lhs): standardised regression coefficients (SRC) of a linear
    least-squares fit of the standardised output on the standardised inputs over the ok cases,
    with the fit's R^2 (SRC ranks inputs well only where R^2 is near 1).

    Returns {"measure", "note", "outputs": {output: {"by_key": {key: {...}}, "r2"?}},
    "ranking": [keys, most influential on max_rise_K first]}.
    """
    ok = [r for r in rows if r["status"] == "ok"]
    keys = plan.keys
    out = {"measure": None, "note": "", "outputs": {}, "ranking": []}
    method = plan.design["method"]
    complete = len(ok) == len(plan.cases)
    use_morris = method == "morris" and complete
    if method in ("morris", "sobol") and not complete:
        what = "Morris measures" if method == "morris" else "Sobol' indices"
        out["note"] = (f"{what} need every case of the design; {len(plan.cases) - len(ok)} of "
                       f"{len(plan.cases)} failed or missing, so SRC over the ok cases is given instead")
    if method == "sobol" and complete:
        from SALib.analyze import sobol

        out["measure"] = "sobol"
        problem = {"num_vars": len(keys), "names": list(keys), "bounds": [list(f.bounds) for f in plan.factors]}
        by_id = {r["case"]: r for r in ok}
        for name in plan.outputs:
            Y = np.array([np.nan if by_id[c.case_id][name] is None else by_id[c.case_id][name]
                          for c in plan.cases], float)
            if not np.all(np.isfinite(Y)) or Y.std() == 0:
                continue
            res = sobol.analyze(problem, Y, calc_second_order=False, conf_level=0.95,
                                seed=plan.design["seed"])
            out["outputs"][name] = {"by_key": {k: {m: float(res[m][i]) for m in ("S1", "S1_conf", "ST", "ST_conf")}
                                               for i, k in enumerate(keys)}}
        metric = "ST"
    elif use_morris:
        from SALib.analyze import morris

        out["measure"] = "morris_mu_star"
        problem = {"num_vars": len(keys), "names": list(keys), "bounds": [list(f.bounds) for f in plan.factors]}
        by_id = {r["case"]: r for r in ok}
        for name in plan.outputs:
            Y = np.array([by_id[c.case_id][name] if by_id[c.case_id][name] is not None else np.nan
                          for c in plan.cases], float)
            if not np.all(np.isfinite(Y)):
                continue
            res = morris.analyze(problem, plan.X, Y, num_levels=MORRIS_LEVELS,
                                 seed=np.random.default_rng(plan.design["seed"]))
            out["outputs"][name] = {"by_key": {k: {"mu_star": float(res["mu_star"][i]), "sigma": float(res["sigma"][i]),
                                                   "mu_star_conf": float(res["mu_star_conf"][i])}
                                               for i, k in enumerate(keys)}}
        metric = "mu_star"
    else:
        out["measure"] = "src"
        X = np.array([[r[k] for k in keys] for r in ok], float).reshape(len(ok), len(keys))
        sx = X.std(axis=0) if len(ok) else np.zeros(len(keys))
        live = [i for i in range(len(keys)) if sx[i] > 0]
        for name in plan.outputs:
            y = np.array([np.nan if r[name] is None else r[name] for r in ok], float)
            good = np.isfinite(y)
            if good.sum() < len(live) + 2 or not live:
                continue
            Xs = (X[good][:, live] - X[good][:, live].mean(0)) / X[good][:, live].std(0)
            if np.any(~np.isfinite(Xs)) or y[good].std() == 0:
                continue
            ys = (y[good] - y[good].mean()) / y[good].std()
            A = np.column_stack([Xs, np.ones(len(ys))])
            coef, *_ = np.linalg.lstsq(A, ys, rcond=None)
            r2 = float(1.0 - np.sum((ys - A @ coef) ** 2) / np.sum(ys ** 2))
            out["outputs"][name] = {"r2": r2, "by_key": {keys[i]: {"src": float(coef[j])} for j, i in enumerate(live)}}
        metric = "src"
    primary = out["outputs"].get("max_rise_K")
    if primary:
        out["ranking"] = sorted(primary["by_key"], key=lambda k: -abs(primary["by_key"][k][metric]))
    return out


# ---------------------------------------------------------------- running
def _progress(total: int, initial: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, unit="case", desc="sweep", disable=not enabled, dynamic_ncols=True)


def _run_local(pending, settings, jobs, record, lost):
    if jobs == 1:
        for case in pending:
            record(run_case(case, settings))
        return
    import multiprocessing
    from concurrent.futures.process import BrokenProcessPool

    from imutherm.studies._worker import init_worker

    threads = max(1, (os.cpu_count() or 1) // jobs)
    # spawn: workers start without the parent's numpy, and init_worker (a module without numpy) sets the
    # thread limits before the first task imports it, so they apply when BLAS loads
    pool = ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn"), initializer=init_worker,
                               initargs=(threads, os.getpid()))
    try:
        futures = {pool.submit(_pool_case, c, settings): c.case_id for c in pending}
        for fut in as_completed(futures):
            try:
                record(fut.result())
            except BrokenProcessPool:
                lost.append(futures[fut])
    except BaseException:  # Ctrl-C: drop the queued cases instead of waiting for them
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()


def _dask_client(address: str):
    try:
        from distributed import Client
    except ImportError:  # pragma: no cover - a declared dependency
        raise InputError("--dask needs the 'distributed' package: pip install 'dask[distributed]'") from None
    try:
        return Client(address, timeout="10s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError(f"--dask: cannot connect to a Dask scheduler at {address!r}: {exc}") from None


def _run_dask(pending, settings, client, record, lost):
    from distributed import as_completed as dask_completed

    tag = time.time_ns()  # unique task keys: a resumed sweep on the same cluster never reuses old results
    futures = [client.submit(run_case, c, settings, pure=False, key=f"imutherm-sweep-{tag}-case-{c.case_id}")
               for c in pending]
    ids = {f.key: c.case_id for f, c in zip(futures, pending)}
    for fut in dask_completed(futures):
        try:
            record(fut.result())
        except Exception:  # noqa: BLE001 - a lost worker: the case is not recorded, a resume reruns it
            lost.append(ids[fut.key])


def run_sweep(plan: SweepPlan, out_dir, *, jobs: int = 1, dask_address: str | None = None,
              resume: bool = False, progress: bool = True) -> SweepResult:
    """Run the cases of ``plan`` not yet in ``out_dir/results.csv``; write ``sweep.json``.

    jobs : int, local worker processes (1: in this process); dask_address : ``tcp://host:port`` of a
    Dask scheduler (instead of ``jobs``); resume : continue a sweep in ``out_dir`` (its recorded
    design must equal ``plan``'s); progress : tqdm bar on stderr.

    Raises InputError if ``out_dir`` already holds a sweep and ``resume`` is False, or if ``resume``
    finds a different design or no sweep.
    """
    start = time.perf_counter()
    if not isinstance(jobs, int) or jobs < 1:
        raise InputError(f"--jobs must be an integer >= 1, got {jobs!r}")
    out = Path(out_dir)
    csv_path, json_path = out / RESULTS_CSV, out / SWEEP_JSON
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out} exists and is not a directory")
    rows: list = []
    client = _dask_client(dask_address) if dask_address else None  # before anything is written
    try:
        return _run(plan, out, csv_path, json_path, rows, jobs, dask_address, client, resume, progress, start)
    finally:
        if client is not None:
            client.close()


def _run(plan, out, csv_path, json_path, rows, jobs, dask_address, client, resume, progress, start):
    if resume:
        if not json_path.is_file():
            raise InputError(f"--resume: {json_path} not found; start the sweep without --resume")
        try:
            old = json.loads(json_path.read_bytes().decode("utf-8"))["design"]
            if not isinstance(old, dict):
                raise TypeError("its design is not a table")
        except UnicodeDecodeError as exc:
            raise InputError(f"--resume: {json_path} is damaged (not UTF-8 text at byte {exc.start + 1}); "
                             "start the sweep in a new --out") from None
        except (ValueError, KeyError, TypeError) as exc:
            raise InputError(f"--resume: {json_path} is not a sweep record ({type(exc).__name__}: {exc}); "
                             "start the sweep in a new --out") from None
        diff = _design_mismatch(old, plan.design)
        if diff:
            raise InputError(f"--resume: this sweep's design differs from the one recorded in {json_path} "
                             f"in {', '.join(diff)}; give the same --set, --method, --samples, --seed, layout, "
                             "scheme, mesh and model options, or a new --out")
        if csv_path.exists():
            rows = read_results(csv_path, plan.columns, plan.cases, plan.keys)
    else:
        if csv_path.exists() or json_path.exists():
            raise InputError(f"--out {out} already holds a sweep ({RESULTS_CSV}/{SWEEP_JSON}); "
                             "add --resume to continue it or give a new directory")
        out.mkdir(parents=True, exist_ok=True)
        _atomic_write(json_path, _json_text({"design": plan.design, "status": "running"}))
    if plan.surrogate == "reduced":
        return _run_reduced(plan, out, csv_path, json_path, jobs, dask_address, client, progress, start)
    done = {r["case"] for r in rows}
    pending = [c for c in plan.cases if c.case_id not in done]
    writer = _RowWriter(csv_path, plan)
    lost: list = []
    ran = 0
    bar = _progress(len(plan.cases), len(done), progress)

    def record(row):
        nonlocal ran
        writer.append(row)
        rows.append(dict(zip(plan.columns, _defaults(plan, row))))  # as a resume would read it back
        ran += 1
        bar.update(1)

    try:
        if client is not None:
            _run_dask(pending, plan.settings, client, record, lost)
        else:
            _run_local(pending, plan.settings, jobs, record, lost)
    finally:
        bar.close()
        writer.close()
    rows.sort(key=lambda r: r["case"])
    # tidy: the appended file rewritten in case order (atomic replace: a kill now loses nothing)
    _atomic_write(csv_path, ",".join(plan.columns) + "\n" + "".join(_row_line(plan, r) for r in rows))
    sens = sensitivity(plan, rows)
    failed = sum(r["status"] == "failed" for r in rows)
    wall = time.perf_counter() - start
    ok_s = [r["seconds"] for r in rows if r["status"] == "ok" and r["seconds"] is not None]
    record_json = {
        "design": plan.design,
        "status": "complete" if len(rows) == len(plan.cases) else "incomplete",
        "counts": {"cases": len(plan.cases), "recorded": len(rows), "ok": len(rows) - failed, "failed": failed,
                   "ran_this_call": ran, "lost": len(lost)},
        "sensitivity": sens,
        "timing": {"wall_s_this_call": wall, "runner": f"dask {dask_address}" if dask_address else f"{jobs} local process(es)",
                   "case_s_mean": float(np.mean(ok_s)) if ok_s else None,
                   "case_s_max": float(np.max(ok_s)) if ok_s else None},
    }
    _atomic_write(json_path, _json_text(record_json))
    return SweepResult(out, plan, rows, ran, len(done), failed, tuple(sorted(lost)), sens, wall)


def _run_reduced(plan, out, csv_path, json_path, jobs, dask_address, client, progress, start):
    """Every case on the reduced model, ``verify`` random cases re-run on the full FEM (local or Dask).

    The rows are written at once (a run of thousands of cases takes seconds; a resume recomputes them all).
    """
    from imutherm.studies import sweep_surrogate as SS

    say = (lambda m: print(m, flush=True)) if progress else (lambda m: None)
    s = plan.settings
    sur = SS.build_surrogate(plan, progress=say)
    t1 = time.perf_counter()
    rows = SS.evaluate_all(sur, plan.X, s.transient, s.t_end)
    t_eval = time.perf_counter() - t1
    say(f"reduced model: {len(rows)} cases in {t_eval:.1f} s (basis {sur.rom.basis_size}, built in {sur.build_s:.0f} s)")
    rows = [dict(zip(plan.columns, _defaults(plan, r))) for r in rows]
    _atomic_write(csv_path, ",".join(plan.columns) + "\n" + "".join(_row_line(plan, r) for r in rows))
    ids = SS.pick_cases(len(plan.cases), plan.design["verify"], plan.design["seed"])
    full_rows, lost = [], []
    t2 = time.perf_counter()
    if ids:
        say(f"verifying {len(ids)} case(s) on the full FEM: {ids}")
        pending = [full_case(plan, i) for i in ids]
        bar = _progress(len(ids), 0, progress)

        def record(row):
            full_rows.append(row)
            bar.update(1)
        try:
            if client is not None:
                _run_dask(pending, s, client, record, lost)
            else:
                _run_local(pending, s, jobs, record, lost)
        finally:
            bar.close()
    t_verify = time.perf_counter() - t2
    by_id = {r["case"]: r for r in rows}
    checks = [SS.compare_rows(by_id[f["case"]], f, s.sites) for f in sorted(full_rows, key=lambda r: r["case"])]
    checks += [{"case": i, "status": "failed", "message": "worker lost"} for i in lost]
    ver = SS.verification_summary(checks, plan.design["verify_tol_K"], SS.VERIFY_T95_REL, s.transient)
    sens = sensitivity(plan, rows)
    failed = sum(r["status"] == "failed" for r in rows)
    wall = time.perf_counter() - start
    timings = {"build_s": sur.build_s, "evaluate_s": t_eval, "verify_s": t_verify, "wall_s": wall}
    ok_s = [r["seconds"] for r in rows if r["status"] == "ok"]
    record_json = {
        "design": plan.design,
        "status": "complete",
        "counts": {"cases": len(plan.cases), "recorded": len(rows), "ok": len(rows) - failed, "failed": failed,
                   "ran_this_call": len(rows), "lost": len(lost)},
        "sensitivity": sens,
        "surrogate": {"kind": "reduced", "basis_size": sur.rom.basis_size, "unknowns": sur.rom.unknowns,
                      "full_solves": sur.rom.solves, "coupled_pairs": [list(p) for p in sur.pairs],
                      "knobs": [{"key": k.name, "lo": k.lo, "hi": k.hi, "log": k.log, "nodes": k.nodes,
                                 "load": k.is_load} for k in sur.knobs],
                      "hot_spots": [n for n in sur.rom.site_names if n.startswith("hot@")]},
        "verification": ver,
        "timing": {"wall_s_this_call": wall, "runner": f"dask {dask_address}" if dask_address else f"{jobs} local process(es)",
                   "case_s_mean": float(np.mean(ok_s)) if ok_s else None,
                   "case_s_max": float(np.max(ok_s)) if ok_s else None, **timings},
    }
    _atomic_write(json_path, _json_text(record_json))
    return SweepResult(out, plan, rows, len(rows), 0, failed, (), sens, wall, ver, timings)


def _defaults(plan: SweepPlan, row: dict) -> list:
    """The row's value for each column, inputs filled from the design (as read back from the CSV)."""
    values = dict(zip(plan.keys, plan.cases[row["case"]].values))
    return [_parse_cell(c, _fmt(row.get(c, values.get(c)))) for c in plan.columns]
