"""The end-to-end study of every scheme (:func:`run_study`): thermal cases in worker processes (or from the disk
cache, keyed by their content), each scheme's IMU cases queued as soon as its thermal result is in.
"""

from __future__ import annotations

import time
from concurrent.futures import as_completed
from itertools import chain

import numpy as np

from imutherm import InputError
from imutherm.geometry.layout import LayoutSpec, load_layout
from imutherm.unit.model import ModelOptions
from imutherm.studies.end_to_end.config import SchemeStudy, StudyConfig, StudyResult
from imutherm.studies.end_to_end.imu import bare_calibration, imu_case, reduce_cases
from imutherm.studies.end_to_end.thermal import (cached_thermal_case, full_case, longest_first, site_curves,
                                                 stored_thermal_case, thermal_key)
from imutherm.workers import check_jobs, process_pool, usable_workers


def _imu_jobs(pool, config: StudyConfig, seeds, bare, args):
    if pool is None:
        return [imu_case(config.grade, s, *args, config, bare[s]) for s in seeds]
    return [pool.submit(imu_case, config.grade, s, *args, config, bare[s]) for s in seeds]


def run_study(layout=None, schemes=("air", "grease", "potted"), *, config: StudyConfig = StudyConfig(),
              options: ModelOptions | None = None, jobs: int | None = None, progress: bool = False,
              use_cache: bool = True, while_imu=None, **thermal_kwargs) -> StudyResult:
    """The end-to-end study of every scheme (module docstring).

    Parameters
    ----------
    layout : LayoutSpec, path, built-in name or None (the reference unit)
    schemes : scheme names of the layout
    config : StudyConfig (IMU side)
    options : ModelOptions (thermal laws; default :class:`ModelOptions`)
    jobs : int, worker processes (default: min(2, CPUs)); 1 runs everything in this process. With
        ``jobs`` > 1 the schemes' thermal solves run side by side in the workers, the longest first
        (:func:`longest_first`), and each scheme's IMU cases (one per seed) are queued as soon as its thermal
        result is in, whichever finishes first.
    progress : bool, print one line per stage
    use_cache : bool, read each scheme's thermal case from the disk cache (:mod:`imutherm.cache`) when one of the
        same content is there (:func:`~imutherm.studies.end_to_end.thermal.thermal_key`: layout, scheme,
        options, mesh, time and estimate settings, oven temperatures, code; not the IMU side) and keep the
        computed ones there; a hit prints ``<scheme>: thermal: cached (key ...)`` (whatever ``progress``) and
        solves nothing. ``$IMUTHERM_CACHE=off`` turns it off too
    while_imu : callable of no arguments or None: with ``jobs`` > 1, called in this process once every scheme's
        thermal case is in, while the workers run the IMU cases (this process only waits for them then): the
        command imports its report's modules there, off the serial end of the run (issue 59)
    **thermal_kwargs : passed to :func:`imutherm.studies.thermal.thermal_study.run_scheme` (mesh_size_mm, min_cells,
        transient time settings); the transient is always run. ``estimate_mesh_error=True``: each scheme's
        steady answer also gets its discretisation error (:func:`~imutherm.studies.thermal.thermal_study.mesh_error`,
        one refined solve at a time over the workers)
    """
    from imutherm.studies.thermal.thermal_study import result_summary

    start = time.perf_counter()
    layout, schemes, options, jobs, seeds = _study_inputs(layout, schemes, options, jobs, config)
    thermal_kwargs.pop("transient", None)
    pool = process_pool(jobs, shared_lock=True)   # one BLAS thread each, the refined solves one at a time
    try:
        pending, thermal = _thermal_then_imu(pool, jobs, layout, schemes, options, config, seeds, progress,
                                             thermal_kwargs, use_cache)
        if pool is not None and while_imu is not None:
            while_imu()
        out = {}
        for sch in schemes:
            cases = [c if isinstance(c, dict) else c.result() for c in pending[sch]]
            res, chamber, rise, oven = thermal[sch]
            out[sch] = SchemeStudy(scheme=sch, thermal=res, summary=result_summary(res), chamber_C=chamber,
                                   rise_K=rise, imu=reduce_cases(cases), series=cases[0]["series"],
                                   oven_solves=tuple(oven))
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
    return StudyResult(layout=layout, config=config, options=options, schemes=out,
                       wall_s=time.perf_counter() - start)


def _study_inputs(layout, schemes, options, jobs, config: StudyConfig) -> tuple:
    """(layout, schemes, options, workers, seeds) of a study, checked (unknown schemes, ``jobs`` < 1 refused);
    the workers no more than the tasks that can run at once."""
    layout = layout if isinstance(layout, LayoutSpec) else load_layout(layout)
    schemes = tuple(schemes)
    unknown = [s for s in schemes if s not in layout.schemes]
    if unknown or not schemes:
        raise InputError(f"{layout.path}: unknown scheme(s) {unknown or '(none given)'}; "
                         f"valid: {', '.join(layout.schemes)}")
    options = options or ModelOptions()
    jobs = check_jobs(jobs)
    seeds = tuple(range(config.seed0, config.seed0 + config.seeds))
    jobs = usable_workers(jobs, len(schemes) * len(seeds))   # the most tasks that can run at once
    return layout, schemes, options, jobs, seeds


def _cache_lookup(layout, schemes, options, config: StudyConfig, thermal_kwargs: dict, use_cache: bool) -> tuple:
    """(scheme -> cache key or None, scheme -> thermal case found in the disk cache); one line printed per hit
    and per entry that could not be read (recomputed)."""
    from imutherm.cache import enabled

    on = use_cache and enabled()
    keys = {sch: thermal_key(layout, sch, options, config.chamber_C, **thermal_kwargs) if on else None
            for sch in schemes}
    found = {}
    for sch in schemes:
        value, status = cached_thermal_case(keys[sch], layout)
        if status == "hit":
            found[sch] = value
            print(f"{sch}: thermal: cached (key {keys[sch][:12]})", flush=True)
        elif status == "unreadable":
            print(f"{sch}: thermal: the cache entry {keys[sch][:12]} could not be read: recomputed", flush=True)
    return keys, found


def _thermal_then_imu(pool, jobs: int, layout, schemes, options, config: StudyConfig, seeds, progress: bool,
                      thermal_kwargs: dict, use_cache: bool = True) -> tuple:
    """(scheme -> its IMU cases (results, or futures on ``pool``), scheme -> (SchemeResult, chamber, rise, oven
    solves)): each scheme's thermal case (from the disk cache, or solved and stored there), in order of
    completion, its IMU cases queued as soon as it is in."""
    from imutherm.imu.sensor_model import SITES

    keys, found = _cache_lookup(layout, schemes, options, config, thermal_kwargs, use_cache)
    todo = [sch for sch in schemes if sch not in found]
    need_bare = "bare" in config.calibrations
    if pool is None:
        thermal_futs = None
        bare = {s: bare_calibration(config.grade, s) if need_bare else None for s in seeds}
    else:
        if progress and todo:
            print(f"thermal (steady, power-on transient, oven self-heating) of {', '.join(todo)} "
                  f"in {jobs} processes ...", flush=True)
        # lean: the heavy thermal problem stays in the worker's cache entry while the other solves run (issue 59)
        thermal_futs = {pool.submit(stored_thermal_case, keys[sch], layout, sch, options, config.chamber_C,
                                    lean=keys[sch] is not None, **thermal_kwargs): sch
                        for sch in longest_first(layout, todo, options)}
        bare_futs = {s: pool.submit(bare_calibration, config.grade, s) if need_bare else None for s in seeds}
        bare = None   # the bare-sensor calibrations' results, collected with the first scheme's thermal case
    pending, thermal = {}, {}
    # in order of completion: each scheme's IMU cases are queued as soon as its thermal result is in (the
    # cached ones first)
    order = chain([sch for sch in schemes if sch in found], todo if pool is None else as_completed(thermal_futs))
    for item in order:
        if isinstance(item, str) and item in found:
            sch = item
            res, chamber, rise, oven = found[sch]
        elif thermal_futs is None:
            sch = item
            if progress:
                print(f"scheme {sch}: thermal (steady, power-on transient, oven self-heating) ...", flush=True)
            res, chamber, rise, oven = stored_thermal_case(keys[sch], layout, sch, options, config.chamber_C,
                                                           progress=progress, **thermal_kwargs)
        else:
            sch = thermal_futs[item]
            res, chamber, rise, oven = item.result()
        if bare is None:
            bare = {s: f.result() if f is not None else None for s, f in bare_futs.items()}
        t, T = site_curves(res)
        idx = [res.steady.probe_names.index(s) for s in SITES]
        steady_T = np.asarray(res.steady.probe_C)[idx]
        if progress:
            done = "from the cache" if sch in found else f"done ({res.wall_s:.0f} s)"
            print(f"scheme {sch}: thermal {done}; IMU and attitude, {len(seeds)} seeds ...", flush=True)
        pending[sch] = _imu_jobs(pool, config, seeds, bare, (t, T, steady_T, chamber, rise))
        thermal[sch] = (res, chamber, rise, oven)
    # every solve done: the full values of the lean ones (read back from the cache) for the report and files
    thermal = {sch: full_case(v, keys[sch], layout, sch, options, config.chamber_C, **thermal_kwargs)
               for sch, v in thermal.items()}
    return pending, thermal
