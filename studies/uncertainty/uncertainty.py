"""What the model does not know, carried to the study's answer: ``imutherm compare --uncertainty``.

Every uncertain input of the thermal model is a knob of the scheme's reduced model
(:mod:`imutherm.thermal.reduced`) with its range, its source and its nominal value (:func:`inputs`): the
model's own uncertain inputs as :func:`imutherm.unit.knobs.uncertain_inputs` states them (the re-tune
knobs of :data:`~imutherm.unit.knobs.RETUNE`: powers' scale, mount, convection, housing emissivity,
board conductivity; and the supply voltage, from the layout's electrical design: its ``supply_range_V``
and the loss slope of the linear regulator it feeds, :func:`supply_input`; a layout without an electrical
design has no supply input, and the result's ``notes`` say so), the cavity pair emissivity, the cavity
radiation law's form (under the s2s law: ``cavity_law_blend`` w 0..1 towards the effective law) and the grease
bond lines' contact.

:func:`propagate` draws SALib's Saltelli design over the inputs (uniform in each knob's coordinate:
uniform over a linear range, log-uniform over a conductance's), evaluates a model on every row and
returns, per output, the mean, the 5 / 50 / 95 % quantiles, and first-order and total Sobol'
indices with their 95 % confidence (every row of the design is a draw from the inputs' joint
distribution, so the quantiles use them all). :func:`run_uncertainty` does it per scheme on the
reduced model (the same draws in every scheme, so the difference between two schemes is computed
draw by draw), for each sensor die's steady rise, the largest die rise, the hottest die's t95 and
their differences between schemes, and checks the reduced model against the full FEM at a few
drawn points (steady at every check point, the power-on transient at the first).

With the nominal end-to-end study (``study``), a few of the draws also run through the full IMU chain
to the residual sensor errors and the attitude error (:mod:`imutherm.studies.uncertainty.uncertainty_imu`).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from imutherm import InputError
from imutherm.workers import check_jobs
from imutherm.unit.cavity_laws import LAW_BLEND, cavity_law_of

#: time grid of the reduced transient, x t_end [s]
_T_GRID = np.concatenate([[0.0], np.geomspace(1e-4, 1.0, 600)])
QUANTILES = (0.05, 0.5, 0.95)
DEFAULT_SAMPLES = 256
DEFAULT_CHECKS = 2


@dataclass(frozen=True)
class UncertainInput:
    """One uncertain input: ``name`` (a knob of :func:`imutherm.unit.knobs.variant`, or ``supply_V``),
    ``unit``, range ``lo``..``hi`` [unit], ``log`` (log-uniform), ``source`` (where the range comes from),
    ``nominal`` [unit] (the model's value) or None (the layout's).

    ``knob`` / ``per_unit``: an input that is not itself a model knob sets the knob ``knob`` to
    ``(value - nominal) x per_unit`` [knob unit] (the supply voltage [V]: the extra loss [W] of the linear
    regulator it feeds, ``per_unit`` its input current [A] = W/V); None for a model knob.
    """

    name: str
    unit: str
    lo: float
    hi: float
    log: bool
    source: str
    nominal: float | None = None
    knob: str | None = None
    per_unit: float | None = None


def supply_input(geometry) -> tuple:
    """(UncertainInput or None, note): the supply voltage [V] as an uncertain input, read from the layout's
    electrical design (``[electrical]`` ``supply_V``, ``supply_range_V`` and the regulator it feeds:
    :func:`imutherm.unit.knobs.supply_power_knob`, the one place the range and the loss slope come from).
    None, with the reason in ``note``, if the layout has no electrical design, states its supply exactly,
    or its supply's voltage moves no single linear regulator's loss."""
    from imutherm.unit import knobs

    lay = geometry.layout
    spec = lay.electrical
    if spec is None:
        return None, (f"no supply-voltage input: layout {lay.name!r} states no electrical design ([electrical] and "
                      f"[[rails]]), so its regulators' powers are given, not derived from a supply voltage")
    v_lo, v_hi = spec.supply_range_V
    if v_hi <= v_lo:
        return None, (f"no supply-voltage input: layout {lay.name!r} states its supply exactly ({spec.supply_V:g} V, "
                      f"no supply_range_V)")
    try:
        knob, source = knobs.supply_power_knob(geometry)
    except InputError as e:
        return None, f"no supply-voltage input: {e}"
    slope = (knob.hi - knob.lo) / (v_hi - v_lo)  # the regulator's input current [A] = its loss per volt [W/V]
    reg = knob.part
    return (UncertainInput("supply_V", "V", v_lo, v_hi, False,
                           f"{source}; sets {reg}'s loss by {slope * 1e3:.4g} mA per volt "
                           f"({knob.lo:+.3f} .. {knob.hi:+.3f} W around its nominal)", spec.supply_V,
                           knob=knob.name, per_unit=slope),
            f"supply_V {v_lo:g}..{v_hi:g} V (nominal {spec.supply_V:g} V) moves {reg}'s loss {knob.lo:+.3f} .. "
            f"{knob.hi:+.3f} W (the layout's electrical design)")


def inputs(geometry, options=None) -> tuple:
    """The uncertain inputs of ``geometry``'s unit with their ranges, sources and nominal values: the model's
    own (:func:`imutherm.unit.knobs.uncertain_inputs`: the re-tune knobs of
    :data:`~imutherm.unit.knobs.RETUNE` and the supply voltage from the layout's electrical design,
    :func:`supply_input`), the cavity pair emissivity, under the s2s cavity law its form (``cavity_law_blend``,
    uniform 0..1 towards the effective law) and the grease bond lines' contact."""
    from imutherm.unit import knobs
    from imutherm.unit.model import GREASE_WETTED_JOINT_W_M2K, ModelOptions

    options = options or ModelOptions()
    nominal = knobs.nominal_values(geometry, options)
    sup, _ = supply_input(geometry)
    out = []
    for k, src in knobs.uncertain_inputs(geometry):
        if k.name in nominal:
            out.append(UncertainInput(k.name, k.unit, k.lo, k.hi, k.log, src, nominal[k.name]))
        elif sup is not None and k.name == sup.knob:
            out.append(sup)
    out.append(UncertainInput("cavity_emissivity", "-", 0.63, 0.86, False,
                              "pair emissivity of facing board / housing surfaces: boards 0.80-0.95 (solder "
                              "mask, assumed), anodised inner walls 0.75-0.90 (Incropera Table A.11, widened) "
                              "-> 1/(1/e1 + 1/e2 - 1) = 0.63-0.86 (model default 0.77)", options.cavity_emissivity))
    if cavity_law_of(options).blendable:
        out.append(UncertainInput(LAW_BLEND, "-", 0.0, 1.0, False,
                                  "the cavity radiation law's form: weight w of the effective-conductivity law in a "
                                  "blend with the s2s exchange (0 s2s, the model's law; 1 effective). The two "
                                  "verified laws differ by 40 % of the air rise, an independent finite-volume model "
                                  "of the unit lies between them and which is closer to the real unit is not known: "
                                  "uniform over the span, competing model forms weighted alike (alternate "
                                  "hypotheses, Zio & Apostolakis 1996)", options.cavity_law_blend))
    out.append(UncertainInput("contact@bond", "W/m^2 K", 3.6e3, 2.0e4, True,
                              "each face of a grease bond line: from an unwetted (air-filled) Al joint, "
                              "R'' = 2.75e-4 m^2 K/W (Incropera & DeWitt Table 3.1b), up to the contact effect's "
                              "physical bound 2e4 (the model's default, the silicone-oil-filled joint, is 1.9e4)",
                              GREASE_WETTED_JOINT_W_M2K))
    return tuple(out)


def nominal_row(ins) -> np.ndarray:
    """The inputs' nominal values (D,) [units], in design order."""
    return np.array([i.nominal for i in ins], float)


# ------------------------------------------------------------------ generic propagation
def _problem(ins) -> dict:
    return {"num_vars": len(ins), "names": [i.name for i in ins], "bounds": [[-1.0, 1.0]] * len(ins)}


def to_values(ins, U: np.ndarray) -> np.ndarray:
    """Physical input values (n, D) [units] of design rows ``U`` in each input's coordinate [-1, 1]
    (linear, or in log p for a log-uniform input)."""
    U = np.asarray(U, float)
    out = np.empty_like(U)
    for j, i in enumerate(ins):
        f, g = (np.log, np.exp) if i.log else ((lambda x: x), (lambda x: x))
        out[:, j] = g(f(i.lo) + (U[:, j] + 1) / 2 * (f(i.hi) - f(i.lo)))
    return out


def design(ins, samples: int, seed: int) -> np.ndarray:
    """SALib's Saltelli design (first and total order), ``samples`` (a power of 2) x (D + 2) rows, in [-1, 1]."""
    if samples < 2 or samples & (samples - 1):
        raise InputError(f"--uncertainty-samples must be a power of 2 >= 2 (the Sobol' sequence's balance), "
                         f"got {samples}")
    from SALib.sample import sobol

    return sobol.sample(_problem(ins), samples, calc_second_order=False, scramble=True, seed=seed)


def statistics(ins, Y: np.ndarray, seed: int) -> dict:
    """mean, std, q05 / q50 / q95 and the Sobol' indices {input: {S1, S1_conf, ST, ST_conf}} of one output
    ``Y`` over a :func:`design` (NaN rows, e.g. a t95 not reached, make the indices None)."""
    Y = np.asarray(Y, float)
    good = np.isfinite(Y)
    out = {"mean": float(np.mean(Y[good])) if good.any() else None,
           "std": float(np.std(Y[good])) if good.any() else None,
           **{f"q{int(round(100 * q)):02d}": (float(np.quantile(Y[good], q)) if good.any() else None)
              for q in QUANTILES},
           "n": int(good.sum()), "sobol": None}
    if good.all() and np.std(Y) > 0:
        from SALib.analyze import sobol

        res = sobol.analyze(_problem(ins), Y, calc_second_order=False, conf_level=0.95, seed=seed)
        out["sobol"] = {i.name: {m: float(res[m][j]) for m in ("S1", "S1_conf", "ST", "ST_conf")}
                        for j, i in enumerate(ins)}
        out["drivers"] = sorted(out["sobol"], key=lambda n: -out["sobol"][n]["ST"])
    return out


def propagate(fn, ins, samples: int = DEFAULT_SAMPLES, seed: int = 0) -> tuple:
    """(X, outputs, stats): ``fn(X) -> {name: (n,) array}`` evaluated on the design of ``ins``; ``X`` (n, D)
    the physical input values, ``stats`` {name: :func:`statistics`}."""
    U = design(ins, samples, seed)
    X = to_values(ins, U)
    Y = fn(X)
    return X, Y, {name: statistics(ins, y, seed) for name, y in Y.items()}


# ------------------------------------------------------------------ per scheme on the reduced model
@dataclass(frozen=True)
class SchemeModel:
    """The reduced model of one scheme and how an input row becomes its knob values.

    geometry, grid, options; rom : ReducedModel; inputs : the UncertainInputs in design order, applicable :
    the names of the inputs this scheme has (``contact@bond`` needs bond lines); sites : sensor sites;
    build_s [s]
    """

    scheme: str
    geometry: object
    grid: object
    options: object
    rom: object
    inputs: tuple
    applicable: tuple
    sites: tuple
    build_s: float


def knob_values(sm: SchemeModel, row) -> dict:
    """Knob values (name -> value) of one input row; an input with a ``knob`` (the supply voltage [V]) sets it to
    ``(value - nominal) x per_unit`` (its regulator's extra loss [W])."""
    vals = {}
    for i, v in zip(sm.inputs, row):
        if i.name not in sm.applicable:
            continue
        if i.knob is not None:
            vals[i.knob] = (float(v) - i.nominal) * i.per_unit
        else:
            vals[i.name] = float(v)
    return vals


def build_scheme_model(layout, scheme: str, ins, *, options=None, mesh_size_mm=None, min_cells=None,
                       progress=None, use_cache: bool = True) -> SchemeModel:
    """The reduced model of ``scheme`` over the inputs ``ins`` (each knob over the input's range), kept in the disk
    cache (:mod:`imutherm.cache`) under the key of what it depends on: the layout's content (not its path), the
    scheme, the options, the mesh, the knobs and their ranges, the sites and the model code (``use_cache``
    False: built, neither read nor written)."""
    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.mesh import DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS, build_mesh
    from imutherm.site_table import ACCEL_SITES, GYRO_SITES
    from imutherm.unit import knobs
    from imutherm.unit.model import ModelOptions
    from imutherm.thermal.reduced import Knob, build_reduced

    from imutherm.geometry.layout import LayoutSpec, load_layout

    t0 = time.perf_counter()
    options = options or ModelOptions()
    layout = layout if isinstance(layout, LayoutSpec) else load_layout(layout)
    geo = build_geometry(layout, scheme)
    grid = build_mesh(geo, DEFAULT_MAX_CELL_MM if mesh_size_mm is None else mesh_size_mm,
                      DEFAULT_MIN_CELLS if min_cells is None else min_cells)
    rom_knobs, applicable = [], []
    retune = {k.name: k for k, _ in knobs.RETUNE}
    for i in ins:
        if i.knob is not None:  # the supply voltage: its regulator's extra loss [W] over the voltage range
            rom_knobs.append(Knob(i.knob, "W", (i.lo - i.nominal) * i.per_unit, (i.hi - i.nominal) * i.per_unit,
                              part=i.knob.split("@", 1)[1]))
        elif i.name in retune:
            rom_knobs.append(replace(retune[i.name], lo=i.lo, hi=i.hi))
        elif knobs.applicable(i.name, geo, options):
            rom_knobs.append(replace(knobs.effect_knob(i.name, options), lo=i.lo, hi=i.hi, log=i.log))
        else:
            continue
        applicable.append(i.name)
    names = {k.name for k in rom_knobs}
    pairs = knobs.coupled_pairs(names)
    sites = tuple(s for s in GYRO_SITES + ACCEL_SITES if s in geo.sites)
    if progress:
        progress(f"uncertainty: reduced model of {scheme} ({len(rom_knobs)} knobs, {grid.n_nodes} unknowns)")
    from imutherm.cache import cached
    from imutherm.studies.end_to_end.thermal import layout_content

    probes = {s: geo.sites[s] for s in sites}
    parts = (layout_content(layout), scheme, options, grid.shape,
             float(DEFAULT_MAX_CELL_MM if mesh_size_mm is None else mesh_size_mm),
             int(DEFAULT_MIN_CELLS if min_cells is None else min_cells), rom_knobs, pairs, probes, "load_directions")
    rom, _ = cached("uncertainty_model", parts,
                    lambda: build_reduced(lambda v: knobs.variant(geo, options, v), grid, rom_knobs, probes,
                                          pairs=pairs, load_directions=True),
                    use_cache=use_cache, progress=progress)
    return SchemeModel(scheme, geo, grid, options, rom, tuple(ins), tuple(applicable), sites,
                       time.perf_counter() - t0)


def scheme_outputs(sm: SchemeModel, X: np.ndarray, t_end: float) -> dict:
    """Per draw: ``rise_<site>_K`` [K] (steady), ``max_die_rise_K`` [K] and ``t95_s`` [s] of the hottest die."""
    from imutherm.thermal.metrics import T95_FRACTION, settle_time

    t = _T_GRID * t_end
    n = len(X)
    rise = np.empty((n, len(sm.sites)))
    t95 = np.empty(n)
    for i, row in enumerate(X):
        vals = knob_values(sm, row)
        y = sm.rom.rise(vals, np.append(t, np.inf))
        rise[i] = y[-1]
        j = int(np.argmax(y[-1]))
        t95[i] = settle_time(t, y[:-1, j], T95_FRACTION, float(y[-1, j]))
    out = {f"rise_{s}_K": rise[:, j] for j, s in enumerate(sm.sites)}
    out["max_die_rise_K"] = rise.max(axis=1)
    out["t95_s"] = t95
    return out


def check_point(sm: SchemeModel, row, t_end: float, transient: bool) -> dict:
    """The reduced model against the full FEM at one drawn point: largest site error [K], t95 error [-]."""
    from imutherm.studies.thermal.forward import full_rise
    from imutherm.studies.thermal.thermal_study import STUDY_CG_RTOL
    from imutherm.unit import knobs
    from imutherm.thermal.metrics import T95_FRACTION, settle_time

    vals = knob_values(sm, row)
    probes = {s: sm.geometry.sites[s] for s in sm.sites}
    t = np.geomspace(1.0, t_end, 300) if transient else np.zeros(0)
    times = np.concatenate([[0.0], t, [np.inf]]) if transient else np.array([np.inf])
    t0 = time.perf_counter()
    full = full_rise(knobs.variant(sm.geometry, sm.options, vals), sm.grid, probes, times, rtol=STUDY_CG_RTOL)
    red = sm.rom.rise(vals, times)
    out = {"inputs": {i.name: float(v) for i, v in zip(sm.inputs, row)},
           "site_error_K": float(np.max(np.abs(full[-1] - red[-1]))),
           "full_max_die_rise_K": float(full[-1].max()), "reduced_max_die_rise_K": float(red[-1].max()),
           "seconds": None}
    if transient:
        j = int(np.argmax(full[-1]))
        tf = settle_time(times[:-1], full[:-1, j], T95_FRACTION, float(full[-1, j]))
        tr = settle_time(times[:-1], red[:-1, j], T95_FRACTION, float(red[-1, j]))
        out.update(curve_error_K=float(np.max(np.abs(full[:-1] - red[:-1]))), full_t95_s=tf, reduced_t95_s=tr,
                   t95_rel_error=float(abs(tr - tf) / tf) if math.isfinite(tf) and tf > 0 else None)
    out["seconds"] = time.perf_counter() - t0
    return out


def _pairs(schemes) -> list:
    return [(a, b) for i, a in enumerate(schemes) for b in schemes[i + 1:]]


def answer_words(stats: dict, schemes) -> list:
    """One sentence per pair of schemes: is one's advantage larger than what the model does not know?"""
    lines = []
    for a, b in _pairs(schemes):
        for out, what, unit, fmt in (("max_die_rise_K", "hottest sensor die", "K", "{:.1f}"),
                                     ("t95_s", "settle time t95", "s", "{:.0f}")):
            s = stats.get(f"diff_{out}:{a}-{b}")
            if not s or s["q05"] is None:
                continue
            lo, mid, hi = (fmt.format(s[q]) for q in ("q05", "q50", "q95"))
            if s["q05"] > 0 or s["q95"] < 0:
                better, worse = (b, a) if s["q05"] > 0 else (a, b)
                verdict = (f"{better} is lower than {worse} across the 5-95 % interval: the advantage is larger "
                           f"than the model's uncertainty")
            else:
                verdict = "the 5-95 % interval includes zero: the difference is within the model's uncertainty"
            drv = ", ".join(s.get("drivers", [])[:2])
            lines.append(f"{what}, {a} - {b}: {mid} {unit} (5-95 %: {lo} .. {hi} {unit}); {verdict}"
                         + (f" (driven most by {drv})" if drv else "") + ".")
    return lines


def imu_draw_rows(n_draws, samples: int, n_inputs: int) -> np.ndarray:
    """Design rows of the IMU draws: the first ``n_draws`` points of the design's base Sobol' sequence (its A
    matrix: every (D + 2)-th row), which fill the input space evenly. ``n_draws`` None: the default
    (:data:`~imutherm.studies.uncertainty.uncertainty_imu.DEFAULT_IMU_DRAWS`, at most ``samples``)."""
    from imutherm.studies.uncertainty.uncertainty_imu import DEFAULT_IMU_DRAWS

    n = min(DEFAULT_IMU_DRAWS, samples) if n_draws is None else n_draws
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 0 <= n <= samples:
        raise InputError(f"--uncertainty-imu-draws must be an integer in 0..{samples} (the draws are points of the "
                         f"design's base sample of --uncertainty-samples {samples}), got {n_draws!r}")
    return np.arange(int(n)) * (n_inputs + 2)


def run_uncertainty(layout, schemes, *, options=None, samples: int = DEFAULT_SAMPLES, seed: int = 0,
                    checks: int = DEFAULT_CHECKS, t_end: float = 2400.0, mesh_size_mm=None, min_cells=None,
                    progress=None, study=None, imu_draws: int | None = None, jobs: int | None = 1,
                    use_cache: bool = True) -> dict:
    """Propagate :func:`inputs` through each scheme's reduced model; the result is JSON-ready.

    ``study``: the nominal end-to-end study (:class:`~imutherm.studies.end_to_end.StudyResult`) of the same
    layout, schemes and options: with it, ``imu_draws`` of the draws (:func:`imu_draw_rows`) also run through
    the full IMU chain (:mod:`imutherm.studies.uncertainty.uncertainty_imu`) in ``jobs`` processes. ``use_cache``: the
    schemes' reduced models read from and kept in the disk cache (:func:`build_scheme_model`).

    Returns {"inputs": [...], "notes": [...], "samples", "draws", "seed", "stats": {"<output>:<scheme>" or
    "diff_<output>:<a>-<b>": :func:`statistics`}, "checks": {scheme: [check_point ...]}, "max_check_error_K",
    "max_check_t95_rel_error", "imu": {...} or None, "answer": [sentences], "not_propagated": str or None,
    "timings": {...}}.
    """
    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.layout import LayoutSpec, load_layout
    from imutherm.studies.uncertainty import uncertainty_imu

    say = progress or (lambda s: None)
    t0 = time.perf_counter()
    if not isinstance(layout, LayoutSpec):
        layout = load_layout(layout)
    if checks < 0:
        raise InputError(f"--uncertainty-checks must be an integer >= 0, got {checks}")
    jobs = check_jobs(jobs)
    geo0 = build_geometry(layout, schemes[0])
    ins = inputs(geo0, options)
    notes = [supply_input(geo0)[1]]
    if not any(i.name == LAW_BLEND for i in ins):
        from imutherm.unit.model import ModelOptions
        o = options or ModelOptions()
        notes.append(f"the cavity radiation law ({o.cavity_law if o.cavity_radiation else 'none'}) "
                     "is taken as exact: only under the s2s law is its form (a blend towards the effective law, "
                     "cavity_law_blend) an uncertain input")
    U = design(ins, samples, seed)
    X = to_values(ins, U)
    rows = imu_draw_rows(imu_draws, samples, len(ins)) if study is not None else np.zeros(0, int)
    x0 = nominal_row(ins)
    chains, nominal_chains = {}, {}
    stats, per, check, timings, applicable = {}, {}, {}, {}, {}
    rng = np.random.default_rng(seed)
    for scheme in schemes:
        sm = build_scheme_model(layout, scheme, ins, options=options, mesh_size_mm=mesh_size_mm,
                                min_cells=min_cells, progress=say, use_cache=use_cache)
        applicable[scheme] = list(sm.applicable)
        t1 = time.perf_counter()
        per[scheme] = scheme_outputs(sm, X, t_end)
        timings[scheme] = {"build_s": sm.build_s, "evaluate_s": time.perf_counter() - t1}
        for name, y in per[scheme].items():
            stats[f"{name}:{scheme}"] = statistics(ins, y, seed)
        if len(rows):
            v0 = knob_values(sm, x0)
            nominal_chains[scheme] = uncertainty_imu.with_form_end(
                uncertainty_imu.nominal_chain(study.schemes[scheme]), sm, v0, say)
            chains[scheme] = [uncertainty_imu.draw_chain(nominal_chains[scheme], sm.rom, knob_values(sm, X[r]), v0,
                                                         t_end) for r in rows]
        ids = sorted(int(i) for i in rng.choice(len(X), size=min(checks, len(X)), replace=False))
        t2 = time.perf_counter()
        check[scheme] = []
        for k, i in enumerate(ids):
            say(f"uncertainty: {scheme} checked on the full FEM at draw {i}" + (" (with the transient)" if k == 0 else ""))
            c = {"draw": i, **check_point(sm, X[i], t_end, transient=(k == 0))}
            if len(rows):  # the IMU draws' oven self-heating map, against the full FEM at each chamber temperature
                c.update(uncertainty_imu.oven_check(sm, knob_values(sm, x0), nominal_chains[scheme],
                                                    knob_values(sm, X[i])))
            check[scheme].append(c)
        timings[scheme]["check_s"] = time.perf_counter() - t2
    for a, b in _pairs(list(schemes)):
        for name in ("max_die_rise_K", "t95_s"):
            stats[f"diff_{name}:{a}-{b}"] = statistics(ins, per[a][name] - per[b][name], seed)
    imu = None
    if len(rows):
        imu = _imu_section(uncertainty_imu, chains, study, list(schemes), rows, jobs, say)
    flat = [c for cs in check.values() for c in cs]
    t95e = [c["t95_rel_error"] for c in flat if c.get("t95_rel_error") is not None]
    return {
        "inputs": [{"name": i.name, "unit": i.unit, "range": [i.lo, i.hi], "nominal": i.nominal, "distribution":
                    "log-uniform" if i.log else "uniform", "source": i.source} for i in ins],
        "notes": notes,
        "method": "SALib Saltelli design (first and total order), quantiles over every draw, Sobol' indices "
                  "with 95 % bootstrap confidence; each scheme on its reduced model (the same draws in every "
                  "scheme)",
        "samples": samples, "draws": int(len(X)), "seed": seed, "t_end_s": t_end,
        "applicable": applicable,
        "stats": stats, "checks": check,
        "max_check_error_K": max((c["site_error_K"] for c in flat), default=None),
        "max_check_curve_error_K": max((c["curve_error_K"] for c in flat if "curve_error_K" in c), default=None),
        "max_check_t95_rel_error": max(t95e, default=None),
        "max_check_oven_error_K": max((c["oven_error_K"] for c in flat if "oven_error_K" in c), default=None),
        "imu": imu,
        "answer": answer_words(stats, list(schemes)) + (imu["answer"] if imu else []),
        "not_propagated": None if imu else (
            "residual sensor errors and attitude error: " + (
                "--uncertainty-imu-draws 0 runs no draw through the IMU chain" if study is not None else
                "the thermal comparison (--thermal-only / --steady-only) has no IMU chain to run the draws through")
            + "; they are the nominal study's figures"),
        "timings": {**timings, **({"imu_cpu_s": imu["cpu_s"], "imu_wall_s": imu["wall_s"]} if imu else {}),
                    "total_s": time.perf_counter() - t0},
    }


def _imu_section(uncertainty_imu, chains, study, schemes, rows, jobs, say) -> dict:
    """The IMU draws' part of the result (JSON-ready)."""
    cfg = study.config
    res = uncertainty_imu.run_imu_draws(chains, cfg, jobs=jobs, progress=say)
    names = uncertainty_imu.output_names(cfg)
    stats = uncertainty_imu.pair_stats(res["values"], schemes, names)
    nominal = {f"{n}:{s}": v for s in schemes for n, v in uncertainty_imu.study_figures(study.schemes[s], cfg).items()}
    comp, filters, prof = uncertainty_imu.answer_setting(cfg)
    n = len(rows)
    return {
        "method": (f"{n} of the design's draws (the first points of its base Sobol' sequence) through the full IMU "
                   f"chain (oven calibration with the draw's self-heating, {comp} compensation, filters "
                   f"{', '.join(filters)}, {prof} profile, calibrated in the unit); each draw's site curves are the "
                   f"nominal study's moved by the reduced model from the nominal inputs to the draw's; the IMU seeds "
                   f"{cfg.seed0}..{cfg.seed0 + cfg.seeds - 1} (grade {cfg.grade}) fixed in every draw and scheme, so "
                   f"the spread is the thermal model's uncertainty, not the sensor noise draw; each draw's figure "
                   f"is the mean over the seeds; "
                   + ("5-95 % intervals" if n >= uncertainty_imu.MIN_DRAWS_FOR_QUANTILES else
                      f"min .. max over the {n} draws (fewer than {uncertainty_imu.MIN_DRAWS_FOR_QUANTILES}: no "
                      "5-95 % quantiles)")),
        "n": n, "rows": [int(r) for r in rows], "seeds": list(range(cfg.seed0, cfg.seed0 + cfg.seeds)),
        "grade": cfg.grade, "compensation": comp, "filters": list(filters), "profile": prof,
        "outputs": list(names), "stats": stats, "nominal": nominal,
        "values": {k: [None if not math.isfinite(x) else float(x) for x in v] for k, v in res["values"].items()},
        "failed": res["failed"], "answer": uncertainty_imu.answer_words(stats, nominal, schemes, cfg),
        "cpu_s": res["cpu_s"], "wall_s": res["wall_s"],
    }
