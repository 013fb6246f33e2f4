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


def transient_steps(time_kwargs: dict) -> int:
    """Time steps [-] of a transient given ``run_scheme``'s time arguments (``t_end``, ``time_scheme``,
    ``dt``, ``dt_max``): given steps are counted; for the error-controlled TR-BDF2 steps the count is
    its lower bound ``t_end / dt_max`` (steps never exceed ``dt_max``, default 300 s)."""
    from imutherm.studies.thermal_study import THETA_DT, THETA_DT_MAX
    from imutherm.thermal.transient import DEFAULT_DT_MAX

    t_end, dt, dt_max = time_kwargs["t_end"], time_kwargs.get("dt"), time_kwargs.get("dt_max")
    if time_kwargs.get("time_scheme") == "theta" and dt is None:
        dt, dt_max = THETA_DT, THETA_DT_MAX if dt_max is None else dt_max
    if dt is not None:
        return count_time_steps(t_end, dt, dt_max)
    return int(math.ceil(t_end / (dt_max or DEFAULT_DT_MAX) - 1e-9))


def usable_workers(jobs: int, tasks: int) -> int:
    """Worker processes [-] a run of ``tasks`` independent tasks can use with ``--jobs jobs``: no more than the
    tasks (a worker without a task would only hold memory), at least 1. The cost estimates count these, and
    the runs start no more (``sweep --jobs 10000`` of 2 cases runs, and is estimated, on 2 workers)."""
    return max(1, min(int(jobs), int(tasks)))


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
    jobs = min(2, cpus) if jobs is None else int(jobs)
    if jobs < 1:
        raise InputError(f"--jobs: {jobs} is invalid; valid: an integer >= 1")
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
