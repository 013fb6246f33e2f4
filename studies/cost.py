"""What a study will cost, estimated from its configuration before it runs (the study side of the budget).

:func:`transient_steps` counts the time steps of ``run_scheme``'s time arguments, :func:`study_imu_work` and
:func:`check_study_cost` the IMU side of the end-to-end study. The limits of memory, cells and steps, and
the s2s exchange's cost, are in :mod:`imutherm.budget` (the base package, which knows no study).
"""

from __future__ import annotations

import math
import os

from imutherm import InputError
from imutherm.budget import BASE_BYTES, available_memory_bytes, count_time_steps, fmt_bytes
from imutherm.workers import check_jobs, usable_workers


def transient_steps(time_kwargs: dict) -> int:
    """Time steps [-] of a transient given ``run_scheme``'s time arguments (``t_end``, ``time_scheme``,
    ``dt``, ``dt_max``): given steps are counted; for the error-controlled TR-BDF2 steps the count is
    its lower bound ``t_end / dt_max`` (steps never exceed ``dt_max``, default 300 s)."""
    from imutherm.studies.thermal.thermal_study import THETA_DT, THETA_DT_MAX
    from imutherm.thermal.transient import DEFAULT_DT_MAX

    t_end, dt, dt_max = time_kwargs["t_end"], time_kwargs.get("dt"), time_kwargs.get("dt_max")
    if time_kwargs.get("time_scheme") == "theta" and dt is None:
        dt, dt_max = THETA_DT, THETA_DT_MAX if dt_max is None else dt_max
    if dt is not None:
        return count_time_steps(t_end, dt, dt_max)
    return int(math.ceil(t_end / (dt_max or DEFAULT_DT_MAX) - 1e-9))


# ------------------------------------------------------------------ a full-FEM transient's time
#: CPU time of one time step of the full FEM per unknown [s]: TR-BDF2, two stage solves by CG (~21 iterations each
#: at the study's 1e-5) with the step's AMG hierarchy and the s2s exchange lagged. Measured 2026-12-04 on the
#: reference unit (grease, default mesh, 204,610 unknowns, ``imutherm solve --transient --t-end 50 --dt 5``): 10
#: steps in 67 s of wall time on this 2-core machine at load ~10, ~3.3 s of CPU a step; an adaptive step adds one
#: loose error-estimate solve (+~25 %)
SECONDS_PER_STEP_UNKNOWN = 1.6e-5
#: adaptive TR-BDF2 steps (accepted + rejected) of a power-on transient to settled at the default 0.01 K: the
#: reference unit takes 20-30 (``benchmarks/bench_transient_accuracy.py``); the estimate assumes this many
ADAPTIVE_STEPS = 40
#: an estimate beyond this [s] is printed with a warning and the cheaper ways to the same answer
WARN_TRANSIENT_S = 600.0
#: an estimate beyond this [s] is refused (the limit of :data:`imutherm.budget.MAX_TIME_STEPS`, ~6 h)
MAX_TRANSIENT_S = 6 * 3600.0


def transient_cost(time_kwargs: dict, unknowns: int) -> dict:
    """The full-FEM transient of ``run_scheme``'s time arguments on ``unknowns`` nodes: ``steps`` [-] (given
    steps counted, error-controlled ones :data:`ADAPTIVE_STEPS`), ``given`` (bool) and ``seconds`` [s] of CPU."""
    given = time_kwargs.get("dt") is not None or time_kwargs.get("time_scheme") == "theta"
    steps = transient_steps(time_kwargs) if given else ADAPTIVE_STEPS
    factor = 1.0 if given else 1.25
    return {"steps": int(steps), "given": bool(given),
            "seconds": float(steps * factor * SECONDS_PER_STEP_UNKNOWN * unknowns)}


def _minutes(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else (f"{seconds / 60:.0f} min" if seconds < 7200
                                                      else f"{seconds / 3600:.1f} h")


def check_transient_cost(what: str, time_kwargs: dict, unknowns: int) -> dict:
    """Print the full-FEM transient's estimated cost before it starts; past :data:`WARN_TRANSIENT_S` with how to
    make it cheaper, past :data:`MAX_TRANSIENT_S` refused (InputError). Returns :func:`transient_cost`."""
    c = transient_cost(time_kwargs, unknowns)
    how = (f"{c['steps']:,} given steps" if c["given"] else
           f"~{c['steps']} error-controlled steps (power-on to settled)")
    line = (f"{what}: transient on the full FEM, {how} on {unknowns:,} unknowns: estimated ~{_minutes(c['seconds'])} "
            "of CPU")
    cheaper = []
    if c["given"]:
        adaptive = transient_cost({k: v for k, v in time_kwargs.items() if k not in ("dt", "dt_max")}
                                  | {"time_scheme": "trbdf2"}, unknowns)["seconds"]
        cheaper.append(f"drop --dt/--theta: the error-controlled TR-BDF2 steps reach the same curves to 0.01 K in "
                       f"~{ADAPTIVE_STEPS} steps (~{_minutes(adaptive)})")
        cheaper.append("a larger --dt (or --dt-max with a growing step)")
    cheaper.append("--until-settled (stop once settled)" if not time_kwargs.get("until_settled") else None)
    cheaper.append("a larger --mesh-size or a smaller --min-cells")
    hint = "; ".join(h for h in cheaper if h)
    if c["seconds"] > MAX_TRANSIENT_S:
        raise InputError(f"{line}, more than the limit of {MAX_TRANSIENT_S / 3600:g} h; cheaper: {hint}")
    if c["seconds"] > WARN_TRANSIENT_S:
        line += f" (more than {WARN_TRANSIENT_S / 60:g} min; cheaper: {hint})"
    print(line, flush=True)
    return c


def check_schemes_side_by_side(solve_bytes, refined_bytes, jobs: int | None, max_memory: int | None) -> float:
    """Memory [bytes] of ``compare``'s thermal solves side by side, InputError beyond ``max_memory`` (default: the
    memory available now).

    The schemes run in min(``jobs``, schemes) workers (``jobs`` default min(2, CPUs)), and the mesh-error
    estimates' refined solves one at a time: the largest refined solve (``refined_bytes``, one per scheme, empty
    without the estimate) beside the largest other schemes' solves (``solve_bytes``, one per scheme, each
    :func:`imutherm.budget.thermal_cost`), plus the command's interpreter. One worker: the schemes' own checks
    cover it (returns the largest of them)."""
    solve_bytes, refined_bytes = sorted(map(float, solve_bytes), reverse=True), [float(b) for b in refined_bytes]
    jobs = check_jobs(jobs)
    k = usable_workers(jobs, len(solve_bytes))
    if k <= 1:
        return max(solve_bytes + refined_bytes, default=0.0)
    if refined_bytes:
        memory = BASE_BYTES + max(refined_bytes) + sum(solve_bytes[:k - 1])
    else:
        memory = BASE_BYTES + sum(solve_bytes[:k])
    limit = available_memory_bytes() if max_memory is None else int(max_memory)
    if memory > limit:
        src = "--max-memory" if max_memory is not None else "the memory available now (--max-memory)"
        what = "a refined solve (the mesh-error estimate) beside " if refined_bytes else ""
        raise InputError(f"compare: {k} schemes solved side by side (--jobs {jobs}), {what}{k - 1 if refined_bytes else k} "
                         f"scheme solve(s), estimated ~{fmt_bytes(memory)} of memory, more than {src} "
                         f"{fmt_bytes(limit)}; use --jobs 1 (one scheme at a time)"
                         + (" or --no-mesh-error" if refined_bytes else ""))
    return memory


# ------------------------------------------------------------------ the IMU side of `imutherm compare`
#: wall time of one attitude filter over one motion sample in the end-to-end study's IMU side [s] (truth
#: model and compensation included) and the fixed part of one (scheme, seed) case [s] (the in-unit
#: calibration): fitted to ``benchmarks/bench_study_imu.py`` runs of 60,000 / 460,000 / 1.84e6
#: filter-samples (2.7 / 5.9 / 15.8 s: 7.2 us each + 2.6 s) on this machine under load, rounded up
SECONDS_PER_FILTER_SAMPLE = 10e-6
SECONDS_PER_CASE = 3.0
#: peak memory of one (scheme, seed) IMU case above the interpreter per sample of its longest profile
#: [bytes]: measured 1.0-1.3 kB (flight, 40,000 samples: 38-48 MiB) by the same benchmark, rounded up
BYTES_PER_SAMPLE_STUDY = 2000
#: most estimated wall time of the IMU side of one study [s]: 6 h, as :data:`imutherm.budget.MAX_TIME_STEPS` for a transient
MAX_STUDY_IMU_S = 6 * 3600.0


def _profile_samples(profile: str, rate_hz: float) -> int:
    """Samples [-] of ``profile`` at its default duration (what the study runs) at ``rate_hz`` [Hz]."""
    import inspect

    from imutherm.imu import motion

    duration = inspect.signature(getattr(motion, f"{profile}_profile")).parameters["duration"].default
    return int(round(duration * rate_hz))


def study_imu_work(config, schemes: int) -> dict:
    """What the IMU side of :func:`imutherm.studies.end_to_end.run_study` computes, counted from ``config``
    (a ``StudyConfig``) alone: ``samples`` per profile [-], ``longest_samples`` [-], ``sets`` (compensated
    sample sets per run: uncompensated + calibrations x compensations), ``cases`` (schemes x seeds) and
    ``filter_samples`` [-] (cases x profiles' samples x phases x sets x filters)."""
    from imutherm.imu.sensor_model import load_grade
    from imutherm.studies.end_to_end import PHASES

    rate = load_grade(config.grade).sample_rate_hz
    samples = {p: _profile_samples(p, rate) for p in config.profiles}
    comps = [c for c in config.compensations if c != "none"]
    sets = int("none" in config.compensations) + len(config.calibrations) * len(comps)
    cases = int(schemes) * int(config.seeds)
    per_case = sum(samples.values()) * len(PHASES) * sets * len(config.filters)
    return {"samples": samples, "longest_samples": max(samples.values()), "sets": sets, "cases": cases,
            "filter_samples": cases * per_case}


def check_study_cost(config, schemes: int, jobs: int | None, max_memory: int | None) -> dict:
    """InputError stating the estimate and the limit if the IMU side of the end-to-end study is beyond them.

    Wall time: ``filter_samples`` x :data:`SECONDS_PER_FILTER_SAMPLE` + ``cases`` x
    :data:`SECONDS_PER_CASE`, over the worker processes that run in
    parallel (``jobs - 1`` beside the thermal solves, at most the CPUs; ``jobs=1``: this process), limit
    :data:`MAX_STUDY_IMU_S`. Memory: each worker holds the interpreter and one case at a time
    (:data:`BYTES_PER_SAMPLE_STUDY` per sample of the longest profile), limit ``max_memory`` (default the
    memory available now). Returns :func:`study_imu_work` with ``seconds`` and ``memory_bytes`` added.
    """
    work = study_imu_work(config, schemes)
    cpus = os.cpu_count() or 1
    jobs = check_jobs(jobs)
    jobs = usable_workers(jobs, work["cases"])   # the study starts no more (run_study)
    workers = max(1, jobs - 1)
    seconds = (work["filter_samples"] * SECONDS_PER_FILTER_SAMPLE + work["cases"] * SECONDS_PER_CASE) / min(workers, cpus)
    case_bytes = BYTES_PER_SAMPLE_STUDY * work["longest_samples"]
    memory = BASE_BYTES + (workers if jobs > 1 else 0) * BASE_BYTES + workers * case_bytes
    work.update(seconds=seconds, memory_bytes=float(memory))
    what = (f"compare: the IMU side is {work['cases']:,} cases (schemes x --seeds) of "
            f"{work['filter_samples'] // max(work['cases'], 1):,} filter-samples (profiles' samples x 2 phases x "
            f"{work['sets']} compensated sets x {len(config.filters)} filters)")
    if seconds > MAX_STUDY_IMU_S:
        raise InputError(f"{what}, estimated ~{seconds / 3600:.3g} h on {min(workers, cpus)} worker(s), more than "
                         f"the limit of {MAX_STUDY_IMU_S / 3600:g} h; use fewer --seeds, --profiles or --filters")
    limit = available_memory_bytes() if max_memory is None else int(max_memory)
    if memory > limit:
        src = "--max-memory" if max_memory is not None else "the memory available now (--max-memory)"
        raise InputError(f"{what}, estimated ~{fmt_bytes(memory)} of memory on {workers} worker process(es) "
                         f"(--jobs {jobs}), more than {src} {fmt_bytes(limit)}; use a smaller --jobs")
    return work


#: the expected (not bounding) peak of one steady solve, for the import's estimate: the process with its libraries
#: [bytes], per unknown of the mesh [bytes] and per pair of s2s cavity patches [bytes]. Measured with
#: /usr/bin/time (peak RSS) of ``imutherm solve --scheme air`` on examples/boards/openuav (2026-12-07, load 8 on 2
#: cores): 124.8 MiB at 22,800 unknowns without cavity radiation (2.29 kB per unknown above 75 MiB, budget.py's
#: interpreter and libraries), 229 MiB at the default 66,300 unknowns with 602 patches (2.2 kB), 137.6 MiB with
#: 564 patches at 22,800 unknowns (+12.8 MiB: 42 bytes per pair). Held out: 1,527 patches (2.5 mm) at 22,800
#: unknowns, 193 MiB measured, 218 MiB by these (+13 %). The budget's own constants (imutherm.budget:
#: 100 MiB + 3 kB per unknown + 64 MiB + 56 bytes per pair) bound the run and refuse it; these say what it takes
PEAK_BASE_BYTES = 75 * 2**20
PEAK_BYTES_PER_UNKNOWN = 2300.0
PEAK_BYTES_PER_PATCH_PAIR = 42.0


def solve_memory(layout, scheme: str, mesh_size_mm: float | None = None, min_cells: int | None = None,
                 options=None) -> dict:
    """Expected peak memory [bytes] of one steady solve of ``scheme``: the mesh's and the s2s cavity exchange's
    (its dense patch-pair arrays, beside the mesh's), by the measured constants above. ``{"cells", "unknowns",
    "patches", "mesh_bytes", "exchange_bytes", "bytes"}``; the default mesh and model unless given. Builds the
    mesh to count the cavity's patches (no n^2 array exists yet)."""
    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.mesh import DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS, grid_shape
    from imutherm.unit.model import ModelOptions, s2s_patches

    mesh_size_mm = DEFAULT_MAX_CELL_MM if mesh_size_mm is None else mesh_size_mm
    min_cells = DEFAULT_MIN_CELLS if min_cells is None else min_cells
    geometry = build_geometry(layout, scheme)
    options = options or ModelOptions()
    nx, ny, nz = grid_shape(geometry, mesh_size_mm, min_cells)
    unknowns = (nx + 1) * (ny + 1) * (nz + 1)
    n = s2s_patches(geometry, options, mesh_size_mm, min_cells)
    mesh = PEAK_BASE_BYTES + PEAK_BYTES_PER_UNKNOWN * unknowns
    exchange = PEAK_BYTES_PER_PATCH_PAIR * float(n) ** 2
    return {"cells": nx * ny * nz, "unknowns": unknowns, "patches": n, "mesh_bytes": mesh, "exchange_bytes": exchange,
            "bytes": mesh + exchange}
