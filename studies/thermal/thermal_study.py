"""The thermal chain for one scheme: layout -> geometry -> mesh -> problem -> solve -> metrics.

``run_scheme`` is what ``imutherm solve`` and the three-scheme comparison call;
``result_summary`` turns its result into the ``result.json`` content.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import asdict, dataclass, replace

import numpy as np

from imutherm import InputError
from imutherm.geometry.build import MM, Geometry, build_geometry
from imutherm.geometry.grid import TensorGrid
from imutherm.geometry.layout import AXES, LayoutSpec, load_layout
from imutherm.geometry.mesh import DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS, build_mesh
from imutherm.thermal.metrics import ThermalMetrics, thermal_metrics
from imutherm.unit.model import ModelOptions, build_problem
from imutherm.thermal.assembly import assemble
from imutherm.site_table import ACCEL_SITES, GYRO_SITES
from imutherm.unit.effects import (EFFECTS, apply_model_effects, apply_signal_effects, effect_problem,
                                    moves_ambient)
from imutherm.thermal.reduced import lag_field, linearised
from imutherm.thermal.probes import probe_matrix
from imutherm.thermal.steady import solve_steady
from imutherm.thermal.transient import solve_transient, time_steps



@dataclass(frozen=True)
class SchemeResult:
    """Everything one scheme's thermal run produced.

    geometry, grid : the unit and its mesh
    steady : SteadyResult (the final state; always computed)
    transient : TransientResult or None (power-on from ambient)
    metrics : ThermalMetrics of the transient (t63/t95 against the steady rises) or of the steady result
    options : ModelOptions used
    wall_s : float [s] wall time of the whole run
    transient_check : ReducedCheck or None, the check of a reduced transient
        (:mod:`imutherm.thermal.reduced_transient`; ``accepted`` False: the transient is the full FEM's)
    mesh_error : RefinementEstimate or None, the steady answer's discretisation error (:func:`mesh_error`)
    mesh_corrected : bool, the site values and curves and the hot spot are the estimate's corrected answer
        (:func:`mesh_corrected`), not the default mesh's own
    """

    geometry: Geometry
    grid: TensorGrid
    steady: object
    transient: object | None
    metrics: ThermalMetrics
    options: ModelOptions
    wall_s: float
    transient_check: object | None = None
    mesh_error: object | None = None
    mesh_corrected: bool = False


#: growth factor of the transient step from ``dt`` to ``dt_max`` (first steps resolve the power-on jump)
DT_GROWTH = 1.2
#: given-step defaults of the θ-scheme (the pre-TR-BDF2 default): 2 s growing by 1.2 up to 60 s
THETA_DT, THETA_DT_MAX = 2.0, 60.0
TIME_SCHEMES = ("trbdf2", "theta")
#: how the power-on transient is computed: the full adaptive FEM, or a reduced model checked against it
TRANSIENT_MODELS = ("full", "reduced")


def check_time_arguments(t_end: float, dt: float | None = None, dt_max: float | None = None,
                         tol_K: float | None = None, time_scheme: str = "trbdf2") -> None:
    """InputError unless the transient's time arguments are valid.

    ``t_end``, ``dt``, ``dt_max`` [s] and ``tol_K`` [K] finite and > 0 where given,
    ``dt <= dt_max``, ``dt <= t_end``; ``time_scheme`` 'trbdf2' or 'theta'.
    """
    if time_scheme not in TIME_SCHEMES:
        raise InputError(f"time scheme must be one of {', '.join(TIME_SCHEMES)}, got {time_scheme!r}")
    for name, v in (("t_end", t_end), ("dt", dt), ("dt_max", dt_max), ("time_tol", tol_K)):
        if name == "t_end" or v is not None:
            if v is None or not math.isfinite(v) or v <= 0:
                unit = "[K]" if name == "time_tol" else "[s]"
                raise InputError(f"{name} must be a finite number > 0 {unit}, got {v!r}")
    if dt is not None and dt > t_end:
        raise InputError(f"dt = {dt} s must not exceed t_end = {t_end} s")
    if dt is not None and dt_max is not None and dt_max < dt:
        raise InputError(f"dt_max = {dt_max} s must not be smaller than dt = {dt} s")


def step_sizes(t_end: float, dt: float, dt_max: float | None) -> np.ndarray | float:
    """Steps [s]: constant ``dt`` if ``dt_max`` is None, else growing by 1.2 from ``dt`` up to ``dt_max``."""
    check_time_arguments(t_end, dt, dt_max)
    return dt if dt_max is None or dt_max == dt else time_steps(t_end, dt, dt_max, DT_GROWTH)


#: Relative CG residual of the transient's per-stage solves in a unit study (the library default is 1e-6).
#: On the reference unit (air scheme, default mesh, adaptive TR-BDF2 at 0.01 K) 1e-5 gives the same steps
#: and every site's t95 to 0.1 s of the 1e-6 run, an energy balance of 4e-11 (6e-11 at 1e-6), and 18 % fewer
#: stage CG iterations (986 instead of 1204; transient 43 s instead of 49 s). Not the library default: with a time-dependent fixed temperature
#: the energy balance follows the CG tolerance more closely (tests/test_thermal_solve.py).
STUDY_CG_RTOL = 1e-5


def run_scheme(layout: LayoutSpec | str | None = None, scheme: str | None = None, *,
               mesh_size_mm: float = DEFAULT_MAX_CELL_MM, min_cells: int = DEFAULT_MIN_CELLS,
               options: ModelOptions | None = None, transient: bool = False, t_end: float = 1200.0,
               time_scheme: str = "trbdf2", tol_K: float | None = None, dt: float | None = None,
               dt_max: float | None = None, theta: float = 1.0, until_settled: bool = False, save_times=None,
               progress: bool = False, effects=(), transient_model: str = "full",
               estimate_mesh_error: bool = False, keep: dict | None = None) -> SchemeResult:
    """Solve one cooling scheme of a layout.

    Parameters
    ----------
    layout : LayoutSpec, path or None (the reference unit)
    scheme : str (air, grease, potted; default: the layout's)
    mesh_size_mm : float [mm] largest cell edge
    transient : bool, also run the power-on transient from ambient
    t_end : float [s] transient end time (the latest end with ``until_settled``)
    time_scheme : 'trbdf2' (default: second order, L-stable; error-controlled unless ``dt`` is given)
        or 'theta' (θ-scheme with given steps; 1 backward Euler, 0.5 Crank-Nicolson)
    tol_K : float [K] local error tolerance of the adaptive TR-BDF2 steps on the sites
        (default 0.01 K, see :func:`imutherm.thermal.transient.solve_transient`)
    dt, dt_max : float [s] given steps: first step ``dt`` growing by 1.2 up to ``dt_max``
        (``dt_max`` None: constant ``dt``); the θ-scheme defaults to 2 s up to 60 s. Without ``dt``
        (TR-BDF2), ``dt_max`` is the largest adaptive step (default 300 s).
    theta : float, θ of the θ-scheme
    until_settled : bool, stop the transient once every site is within 0.5 % of its steady rise
        (and past its t95): the steady solution is computed first
    save_times : sequence [s], times at which the transient keeps the whole field
    effects : sequence of :class:`~imutherm.unit.effects.EffectSetting`, candidate effects switched
        on (model effects change the problem; signal effects, probe lag and ambient drift, change the
        sites' curves of the transient, and its metrics; an ambient drift needs ``transient``)
    transient_model : 'full' (the adaptive FEM) or 'reduced': the transient on a reduced model of the
        steady field that checks itself against the full model, the full FEM when the check fails
        (:func:`imutherm.thermal.reduced_transient.reduced_power_on`; adaptive TR-BDF2 settings only:
        given steps or the θ-scheme always run the full FEM)
    estimate_mesh_error : bool, also estimate the steady answer's discretisation error (:func:`mesh_error`: one
        steady solve on the mesh refined 2x in every direction, 8x the cells) and correct the sites' values and
        curves and the hot spot by it (:func:`mesh_corrected`)
    keep : dict, optional: gets the steady solve's ``"preconditioner"`` (``solve_steady(..., keep=)``), which the
        reduced transient and the mesh-error estimate here use too, and the ``"assembly"``, for the caller's later
        solves of the same unit (the oven's, :func:`imutherm.studies.end_to_end.thermal.thermal_case`)

    Returns
    -------
    SchemeResult (geometry, mesh, steady and transient results, :class:`~imutherm.thermal.metrics.ThermalMetrics`)

    Examples
    --------
    What ``imutherm solve --scheme potted --mesh-size 6 --min-cells 1`` computes, in one call (a coarse mesh:
    one cell across the thinnest part):

    >>> from imutherm.studies.thermal.thermal_study import run_scheme
    >>> run = run_scheme("imu_reference", "potted", mesh_size_mm=6, min_cells=1)
    >>> print(f"max rise {run.metrics.max_rise_K:.1f} K in {run.metrics.max_part}")
    max rise 15.4 K in reg_5v_die
    >>> print(f"gyro_x +{run.metrics.probe_rise_K['gyro_x']:.1f} K")
    gyro_x +2.1 K

    With ``transient=True`` it adds the power-on transient from the ambient, and ``run.metrics`` each site's
    t63 and t95 [s].
    """
    if transient_model not in TRANSIENT_MODELS:
        raise InputError(f"transient model must be one of {', '.join(TRANSIENT_MODELS)}, got {transient_model!r}")
    effects = tuple(effects)
    if not transient and moves_ambient(effects):
        moving = next(e.base for e in effects if moves_ambient((e,)))
        raise InputError(f"effect {moving} needs a transient run (a drifting ambient has no steady state)")
    start = time.perf_counter()
    if transient:
        if time_scheme == "theta" and dt is None:
            dt, dt_max = THETA_DT, THETA_DT_MAX if dt_max is None else dt_max
        check_time_arguments(t_end, dt, dt_max, tol_K, time_scheme)
        if dt is not None and tol_K is not None:
            raise InputError("time_tol applies to error-controlled steps: give either dt or time_tol")
        if time_scheme == "theta" and tol_K is not None:
            raise InputError("time_tol needs the trbdf2 time scheme (the theta scheme takes given steps)")
        steps = step_sizes(t_end, dt, dt_max) if dt is not None else None
    if not isinstance(layout, LayoutSpec):
        layout = load_layout(layout)
    options = options or ModelOptions()
    geometry = build_geometry(layout, scheme)
    grid = build_mesh(geometry, mesh_size_mm, min_cells)
    if effects:
        variant = apply_model_effects(geometry, options, effects)
        geometry, options = variant.geometry, variant.options
        problem = effect_problem(variant, grid)
    else:
        problem = build_problem(geometry, grid, options)
    probes = dict(geometry.sites)
    asm = assemble(problem)  # shared by the steady and the transient solve
    kept = {} if keep is None else keep   # one preconditioner for every solve of this unit's matrix
    steady = solve_steady(problem, probes=probes, assembly=asm, keep=kept)
    pc = kept.get("preconditioner")
    if keep is not None:
        keep["assembly"] = asm
    tr = check = None
    if transient:
        final_C = dict(zip(steady.probe_names, (float(v) for v in steady.probe_C)))
        if transient_model == "reduced" and steps is None and time_scheme == "trbdf2":
            tr, check = _reduced_transient(problem, asm, steady, probes, t_end, until_settled, save_times, progress,
                                           pc)
    if transient and tr is None:
        kw = dict(scheme=time_scheme, save_times=save_times, probes=probes, progress=progress, assembly=asm,
                  settle_C=final_C if until_settled else None, rtol=STUDY_CG_RTOL)
        if time_scheme == "theta":
            kw["theta"] = theta
        if steps is None:
            kw.update(tol_K=tol_K, dt_max=dt_max, error_control="probes")
        tr = solve_transient(problem, t_end, steps, **kw)
    if transient:
        if any(EFFECTS[e.base].kind == "signal" for e in effects):
            tr = _with_signal_effects(tr, steady, asm, effects, probes)
        final = {n: v - problem.ambient_C for n, v in final_C.items()}
        metrics = thermal_metrics(tr, final_rise_K=final)
    else:
        metrics = thermal_metrics(steady)
    res = SchemeResult(geometry=geometry, grid=grid, steady=steady, transient=tr, metrics=metrics, options=options,
                       wall_s=time.perf_counter() - start, transient_check=check)
    if estimate_mesh_error:
        if progress:
            print("  mesh error: the steady solve on the mesh refined 2x ...", flush=True)
        res = mesh_corrected(replace(res, mesh_error=mesh_error(res, coarse_pc=pc), wall_s=time.perf_counter() - start))
    return res


def _reduced_transient(problem, asm, steady, probes, t_end, settle, save_times, progress, pc=None):
    """(TransientResult or None, ReducedCheck or None): the checked reduced transient; None: run the full FEM
    (the check failed, or the model is one the reduced model does not cover: the reason is printed)."""
    from imutherm.thermal.reduced_transient import reduced_power_on
    try:
        tr, check = reduced_power_on(problem, asm, steady, probes, t_end, settle=settle, save_times=save_times,
                                     preconditioner=pc)
    except InputError as e:   # e.g. a fixed-temperature face, a fixture away from ambient
        if progress:
            print(f"  reduced transient not applicable ({e}): full FEM", flush=True)
        return None, None
    if progress:
        print(f"  reduced transient: basis {check.basis_size}, {check.full_solves} full solves, estimated error "
              f"{check.max_site_error_K:.2g} K: " + ("accepted" if check.accepted else f"{check.reason}: full FEM"),
              flush=True)
    return tr, check


def refined_problem(res: SchemeResult, ratio: int = 2) -> tuple:
    """(refined problem, prolongation, probes {site: (x, y, z) [m]}, the sites' default-mesh values [°C], the
    default mesh's maximum [°C]) of the mesh-error estimate (:func:`mesh_error`)."""
    from imutherm.geometry.mesh import prolongation, refine_grid
    from imutherm.unit.model import cavity_exchange_law

    st = res.steady
    fine = refine_grid(res.grid, ratio)
    exchange = None
    if st.problem.exchanges:
        exchange = cavity_exchange_law(res.geometry, res.grid, res.options).refined(fine, ratio)
    fine_problem = replace(build_problem(res.geometry, fine, res.options, exchange=exchange),
                           boundary=st.problem.boundary)
    probes = {n: res.geometry.sites[n] for n in st.probe_names if n in res.geometry.sites}
    coarse = [float(v) for n, v in zip(st.probe_names, st.probe_C) if n in probes]
    return fine_problem, prolongation(res.grid, fine), probes, coarse, float(np.max(st.T_C))


def mesh_error(res: SchemeResult, ratio: int = 2, coarse_pc=None, *, matrix_free: bool = True, max_cg: int | None = None):
    """The discretisation error of ``res``'s steady answer at its sites and hot spot
    (:class:`~imutherm.thermal.refinement.RefinementEstimate`): the same problem on ``res.grid`` with every
    interval split in ``ratio`` parts (:func:`~imutherm.geometry.mesh.refine_grid`), solved from the prolonged
    steady field, Richardson's extrapolation of the two. The refined problem has the same parts, laws and
    boundary (model effects included) and the same s2s exchange (patches and view factors of the coarse grid,
    :meth:`~imutherm.thermal.cavity_radiation.CavityExchange.refined`): the difference is the conduction's
    discretisation alone. ``coarse_pc``: the steady solve's preconditioner
    (:func:`~imutherm.thermal.refinement.refined_steady`), else the coarse level is set up again.

    ``matrix_free`` (default) with a ``coarse_pc``: the refined solve without its matrix
    (:func:`~imutherm.thermal.mesh_estimate.refined_steady_matrix_free`, ~0.3 GB less on the reference unit, the
    same values to its CG tolerance); where its CG does not converge (in ``max_cg`` steps, default
    :data:`~imutherm.thermal.mesh_estimate.MAX_CG_STEPS`), the assembled solve, the reason in the estimate's
    ``fallback``. ``$IMUTHERM_REFINED_SOLVE`` ``assembled``: the assembled solve always (a paired benchmark's
    "before"; the values agree to the CG tolerance, so the thermal cache does not tell the two apart)."""
    from imutherm import ConvergenceError
    from imutherm.thermal.mesh_estimate import MAX_CG_STEPS, refined_steady_matrix_free
    from imutherm.thermal.refinement import refined_steady

    st = res.steady
    fine_problem, prolong, probes, coarse, coarse_max = refined_problem(res, ratio)
    why = ""
    if os.environ.get("IMUTHERM_REFINED_SOLVE", "").strip().lower() == "assembled":
        matrix_free = False
    if matrix_free and coarse_pc is not None:
        try:
            return refined_steady_matrix_free(fine_problem, st.T_C, prolong, coarse_pc, probes, coarse, coarse_max,
                                              ratio=ratio, max_cg=MAX_CG_STEPS if max_cg is None else max_cg)
        except ConvergenceError as e:
            why = str(e)
    est = refined_steady(fine_problem, st.problem, st.T_C, prolong, probes, coarse, coarse_max, ratio=ratio,
                         coarse_pc=coarse_pc)
    return replace(est, fallback=why) if why else est


def mesh_factors(res: SchemeResult) -> dict:
    """Site (and ``hot spot``) -> the factor [-] that takes its default-mesh rise to the mesh-error estimate's
    corrected answer (:attr:`~imutherm.thermal.refinement.RefinementEstimate.answer_C`); 1 where the rise is below
    1 mK (no factor to take)."""
    est, amb = res.mesh_error, res.steady.problem.ambient_C
    out = {}
    for n, c, a in zip(est.names, est.coarse_C, est.answer_C):
        out[n] = float((a - amb) / (c - amb)) if abs(c - amb) >= 1e-3 else 1.0
    return out


def mesh_corrected(res: SchemeResult) -> SchemeResult:
    """``res`` with its answer corrected for the discretisation error (``res.mesh_error``, :func:`mesh_error`):
    each site's steady value and power-on curve has its rise scaled by :func:`mesh_factors`, the hot spot's rise
    by the hot spot's factor. That takes the steady error out; during the warm-up the error has a shape of its own
    that one factor does not follow (``benchmarks/bench_corrected_curves.py``: against the 2x mesh's own reduced
    transient, air, the scaled curves are off by up to 0.073 K at a sensor die, mid-warm-up; the unscaled by up
    to 0.108 K, at the end). The fields, maps and part maxima stay the default mesh's. Without an estimate, or
    corrected already: ``res`` itself."""
    if res.mesh_error is None or res.mesh_corrected:
        return res
    from imutherm.thermal.refinement import HOT_SPOT

    amb = res.steady.problem.ambient_C
    factors = mesh_factors(res)

    def scaled(result):
        f = np.array([factors.get(n, 1.0) for n in result.probe_names])
        T = amb + (np.asarray(result.probe_C) - amb) * f
        T.setflags(write=False)
        return replace(result, probe_C=T)
    fh, m = factors[HOT_SPOT], res.metrics
    metrics = replace(m, probe_rise_K={n: v * factors.get(n, 1.0) for n, v in m.probe_rise_K.items()},
                      max_rise_K=m.max_rise_K * fh, max_C=amb + m.max_rise_K * fh)
    return replace(res, steady=scaled(res.steady), transient=None if res.transient is None else scaled(res.transient),
                   metrics=metrics, mesh_corrected=True)


def with_mesh_error(res, coarse_pc=None):
    """``res`` with its mesh-error estimate and the answer corrected by it (:func:`mesh_error`,
    :func:`mesh_corrected`), the refined solve one at a time in a pool's workers
    (:func:`imutherm.workers.one_at_a_time`: on the reference unit it adds ~0.35 GB matrix-free, ~0.6 GB
    assembled, to the ~0.57 GB of a scheme's steady solve, ``docs/benchmarks/mesh_estimate.md``); ``wall_s``
    includes it.
    ``coarse_pc``: the steady solve's preconditioner (:func:`mesh_error`)."""
    import time

    from imutherm.budget import release_freed_memory
    from imutherm.workers import one_at_a_time

    t0 = time.perf_counter()
    release_freed_memory()   # the solves' freed arrays, before the refined solve's (the study's peak)
    with one_at_a_time():
        res = mesh_corrected(replace(res, mesh_error=mesh_error(res, coarse_pc=coarse_pc)))
    return replace(res, wall_s=res.wall_s + time.perf_counter() - t0)


def longest_first(layout: LayoutSpec, schemes, options: ModelOptions) -> tuple:
    """``schemes`` in the order their thermal cases go to the workers: the longest first (so the shortest one
    runs last, beside the first schemes' IMU cases). A scheme whose cavity is air under the s2s law adds the
    view factors and the dense exchange to every solve, and goes first (reference unit, default mesh: air
    18.6, grease 17.7, potted 10.2 CPU-s); ties keep the given order."""
    from imutherm.unit.cavity_laws import cavity_law_of

    def s2s(sch):
        fill = layout.schemes[sch].fill
        return cavity_law_of(options).patches and options.material(fill).name == "air"
    return tuple(sorted(schemes, key=lambda sch: not s2s(sch)))


def _with_signal_effects(tr, steady, asm, effects, sites: dict):
    """The transient with its site curves as read under the signal effects (probe lag, ambient drift)."""
    lag = None
    if moves_ambient(effects):  # a moving ambient: the sites' lag behind a ramp of the surroundings
        A, _ = linearised(asm, steady.T_C)
        P = probe_matrix(tr.grid, np.array([sites[n] for n in tr.probe_names]))
        lag = P @ lag_field(A, asm.M)
    amb = tr.problem.ambient_C
    rise = apply_signal_effects(tr.times, np.asarray(tr.probe_C) - amb, effects, lag)
    return replace(tr, probe_C=rise + amb)


def _spread(rises: dict, names) -> float:
    vals = [rises[n] for n in names if n in rises]
    return float(max(vals) - min(vals)) if vals else float("nan")


def _num(v):
    return None if v is None or (isinstance(v, float) and not math.isfinite(v)) else float(v)


def result_summary(res: SchemeResult) -> dict:
    """The ``result.json`` content of a scheme run (SI units named in the keys; NaN -> null)."""
    g, st, tr = res.geometry, res.steady, res.transient
    steady_m = thermal_metrics(st)
    if res.mesh_corrected:   # the hot spot's corrected rise (the field itself is the default mesh's)
        from imutherm.thermal.refinement import HOT_SPOT

        steady_m = replace(steady_m, max_rise_K=steady_m.max_rise_K * mesh_factors(res)[HOT_SPOT])
    last = tr if tr is not None else st
    final_m = res.metrics
    sites = {}
    for name in st.probe_names:
        entry = {"rise_K": final_m.probe_rise_K[name], "temperature_C": final_m.probe_rise_K[name] + g.layout.ambient_C,
                 "steady_rise_K": steady_m.probe_rise_K[name]}
        if tr is not None:
            entry["t63_s"] = _num(final_m.t63_s[name])
            entry["t95_s"] = _num(final_m.t95_s[name])
        sites[name] = entry
    out = {
        "layout": g.layout.name, "scheme": g.scheme.name, "scheme_description": g.scheme.description,
        "mode": "transient" if tr is not None else "steady", "ambient_C": g.layout.ambient_C,
        "power_W": g.total_power_W,
        "max_rise_K": final_m.max_rise_K, "max_temperature_C": final_m.max_C, "hottest_part": final_m.max_part,
        "max_at_mm": [v / MM for v in final_m.max_at_m],
        "steady_max_rise_K": steady_m.max_rise_K,
        "sites": sites,
        "gyro_spread_K": _spread(final_m.probe_rise_K, GYRO_SITES),
        "accel_spread_K": _spread(final_m.probe_rise_K, ACCEL_SITES),
        "part_max_rise_K": final_m.part_max_rise_K,
        "energy_balance_rel_error": last.energy_balance_rel_error,
        "steady_energy_balance_rel_error": st.energy_balance_rel_error,
        "heat_out_W": {k: float(v) for k, v in st.heat_out_W.items()},
        "unknowns": st.unknowns,
        "steady_newton_iterations": st.newton_iterations, "steady_linear_iterations": st.linear_iterations,
        "steady_residual": st.residual,
        "solver": st.solver,
        "timings_s": {"steady_assembly": st.assembly_s, "steady_solve": st.solve_s, "wall": res.wall_s},
        "mesh": _mesh_summary(res.grid),
        "model_options": options_dict(res.options),
    }
    if tr is not None:
        # transient_residual [-]: largest relative linear residual of any step (TransientResult.residual)
        out.update({"t_end_s": float(tr.times[-1]), "steps": tr.steps, "time_scheme": tr.scheme,
                    "theta": tr.theta if tr.scheme == "theta" else None, "time_tol_K": tr.tol_K,
                    "rejected_steps": tr.rejected_steps, "linear_solves": tr.linear_solves,
                    "settled": tr.settled,
                    "transient_newton_iterations": tr.newton_iterations,
                    "transient_linear_iterations": tr.linear_iterations, "transient_residual": tr.residual})
        out["timings_s"].update({"transient_assembly": tr.assembly_s, "transient_solve": tr.solve_s})
        out["transient_model"] = "reduced" if tr.scheme == "reduced" else "full"
        if res.transient_check is not None:
            out["transient_check"] = res.transient_check.summary()
    if res.mesh_error is not None:
        out["discretisation_error"] = res.mesh_error.summary()
    return out


def _mesh_summary(grid: TensorGrid) -> dict:
    """Cells, nodes and the thinnest gap of the fill with its cells across
    (:func:`~imutherm.geometry.mesh.mesh_info`)."""
    from imutherm.geometry.mesh import grid_gaps

    gaps = grid_gaps(grid)
    out = {"cells": grid.n_cells, "nodes": grid.n_nodes}
    if gaps:
        out.update({"thinnest_gap_mm": gaps["thinnest_gap_mm"], "thinnest_gap_cells": gaps["thinnest_gap_cells"],
                    "thinnest_gap_axis": gaps["thinnest_gap_axis"], "fewest_gap_cells": gaps["fewest_gap_cells"]})
    return out


def options_dict(options: ModelOptions) -> dict:
    d = asdict(options)
    d["interfaces"] = [dict(i) for i in d["interfaces"]]
    return d


def board_plane_map(res: SchemeResult, board: str = "main") -> dict:
    """Steady temperature [degC] on the grid plane nearest a board's mid-plane, with its axes [mm]."""
    part = res.geometry.part(board)
    n = AXES.index(part.normal)
    g = res.grid
    lines = (g.xs, g.ys, g.zs)
    mid = 0.5 * (part.lo[n] + part.hi[n])
    k = int(np.argmin(np.abs(lines[n] - mid)))
    T = np.asarray(res.steady.T_C).reshape(len(g.xs), len(g.ys), len(g.zs))
    plane = np.take(T, k, axis=n)
    a0, a1 = (a for a in range(3) if a != n)
    return {"T_C": plane, "u_mm": lines[a0] / MM, "v_mm": lines[a1] / MM, "axes": "xyz"[a0] + "xyz"[a1],
            "normal": "xyz"[n], "at_mm": lines[n][k] / MM}


def probe_table(res: SchemeResult) -> tuple:
    """(header, rows) of ``probes.csv``: time [s] then one column per site [degC].

    A steady run gives one row at time ``inf``.
    """
    if res.transient is not None:
        t = np.asarray(res.transient.times)
        data = np.asarray(res.transient.probe_C)
        names = res.transient.probe_names
    else:
        t = np.array([np.inf])
        data = np.asarray(res.steady.probe_C)[None, :]
        names = res.steady.probe_names
    return ["time_s"] + list(names), np.column_stack([t, data])


def model_curves(runs: dict) -> dict:
    """scheme -> (site names, times [s], temperatures [degC]) of each run's sites (its power-on transient, or
    one steady row at ``inf``), as :func:`imutherm.studies.paper.bench_comparison` takes them."""
    out = {}
    for s, res in runs.items():
        header, rows = probe_table(res)
        out[s] = (header[1:], rows[:, 0], rows[:, 1:])
    return out
