"""The IMU side of the end-to-end study: one (scheme, seed) from die temperatures to calibration,
compensation and attitude error (:func:`imu_case`), the seeds reduced to mean and spread, and a sweep
case's lean IMU side.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import replace

import numpy as np

from imutherm import InputError
from imutherm.studies.end_to_end.config import PHASES, StudyConfig
from imutherm.studies.end_to_end.thermal import self_heating_table, site_curves


def _seed_rngs(seed: int):
    """Independent generators for unit, calibration rig and each motion run, the same in every scheme."""
    ss = np.random.SeedSequence(int(seed))
    unit_ss, cal_ss, run_ss = ss.spawn(3)
    return np.random.default_rng(unit_ss), cal_ss, run_ss


def _draw(grade: str, seed: int):
    from imutherm.imu.sensor_model import draw_unit

    rng_unit, cal_ss, run_ss = _seed_rngs(seed)
    return draw_unit(grade, rng_unit), cal_ss, run_ss


def bare_calibration(grade: str, seed: int):
    """Calibration of seed ``seed``'s sensors on their own, over -40..70 °C die temperature."""
    from imutherm.imu.calibration import calibrate_unit

    unit, cal_ss, _ = _draw(grade, seed)
    return calibrate_unit(unit, np.random.default_rng(cal_ss))


@functools.lru_cache(maxsize=16)
def _profile_motion(profile: str, rate: float) -> tuple:
    """(trajectory, gate) of motion ``profile`` at ``rate`` [Hz]: the same in every scheme and seed, so made once
    per process (:func:`imu_case`); the trajectory's arrays read-only (shared). The tuned settings are not cached
    here: they are read from their file at every case, so an edit of the file (or a test's) takes effect."""
    from imutherm.imu import motion
    from imutherm.imu.filters.run import GateConfig
    from imutherm.studies.attitude.attitude_study import leveling_window_s

    traj = motion.make_profile(profile, None, rate, lever_arm=motion.DEFAULT_LEVER_ARM[profile])
    for f in dataclasses.fields(traj):
        value = getattr(traj, f.name)
        if isinstance(value, np.ndarray):
            value.flags.writeable = False
    return traj, replace(GateConfig(), init_s=leveling_window_s(traj, GateConfig()))


def _block_mean(x: np.ndarray, n: int) -> np.ndarray:
    m = (x.shape[0] // n) * n
    return x[:m].reshape(-1, n, *x.shape[1:]).mean(axis=1)


def imu_case(grade: str, seed: int, curves_t, curves_T, steady_T, chamber_C, rise_K, config: StudyConfig,
             bare_cal=None) -> dict:
    """The IMU side of one scheme and one seed.

    Parameters
    ----------
    grade : str; seed : int
    curves_t : (M,) [s], curves_T : (M, 6) [°C]  die temperatures of the power-on transient (SITES order)
    steady_T : (6,) [°C]                          steady die temperatures
    chamber_C : (k,) [°C], rise_K : (k, 6) [K]    self-heating in the calibration oven
    config : StudyConfig
    bare_cal : Calibration | None                 the bare-sensor calibration of this seed (computed if None)

    Returns
    -------
    dict with ``attitude[cal][phase][comp][filter][profile] -> {metric: value [deg]}``,
    ``residuals[cal][comp] -> {metric: value}`` (flight (else the first profile) warm-up,
    ``residual_window_s`` means: accel [mg],
    gyro [°/s]), ``extrapolated[cal] -> fraction`` (sample-sensor pairs outside the calibrated range, all
    runs), ``range_C[cal] -> (lo (6,), hi (6,))`` reported-temperature ranges [°C], ``max_reported_C`` (6,)
    [°C], and ``series`` (residual and attitude-error curves of the flight warm-up).
    """
    from imutherm.imu.compensation import compensate, out_of_range_mask
    from imutherm.imu.sensor_model import simulate_imu
    from imutherm.imu.filters.run import run_filters
    from imutherm.imu.motion import DEFAULT_LEVER_ARM
    from imutherm.studies.attitude.attitude_study import error_metrics
    from imutherm.imu.filters.fusion_peer import fusion_params_of_grade

    unit, cal_ss, run_ss = _draw(grade, seed)
    cals = _calibrations(unit, cal_ss, chamber_C, rise_K, config, bare_cal)
    rate = unit.grade.sample_rate_hz
    dt = 1.0 / rate
    comps = [c for c in config.compensations if c != "none"]
    att = {c: {ph: {} for ph in PHASES} for c in cals}
    resid, series = {}, {}
    n_out = {c: 0 for c in cals}
    n_all = 0
    max_rep = np.full(6, -np.inf)
    run_seeds = run_ss.spawn(len(config.profiles) * len(PHASES))
    series_profile = "flight" if "flight" in config.profiles else config.profiles[0]  # residuals, curves
    from imutherm.studies.attitude import filter_settings  # read at every case: a file edit takes effect

    for p_i, profile in enumerate(config.profiles):
        d = DEFAULT_LEVER_ARM[profile]
        traj, gate = _profile_motion(profile, rate)
        tuned = filter_settings.load_settings().for_profile(profile, tuple(config.filters)) if config.tuned else None
        fusion = fusion_params_of_grade(grade)  # the grade's full scale, not the data's peak
        for ph_i, phase in enumerate(PHASES):
            temp = _die_temperatures(phase, traj.t, curves_t, curves_T, steady_T)
            rng = np.random.default_rng(run_seeds[p_i * len(PHASES) + ph_i])
            raw = simulate_imu(unit, traj.t, traj.omega_b, traj.f_b, temp, rng)
            max_rep = np.maximum(max_rep, raw.temp_C.max(axis=0))
            n_all += raw.temp_C.size
            first = next(iter(cals))
            sets = {(first, "none"): raw} if "none" in config.compensations else {}
            for cal in cals:
                n_out[cal] += int(out_of_range_mask(raw.temp_C, cals[cal]).sum())
                for comp in comps:
                    sets[(cal, comp)] = compensate(raw, cals[cal], comp, out_of_range=config.out_of_range)
            for (cal, comp), s in sets.items():
                est, _ = run_filters(s.gyro, s.accel, dt, d, gate, names=config.filters, settings=tuned,
                                     design={"fusion": fusion})
                m = {f: error_metrics(e.roll - traj.roll, e.pitch - traj.pitch,
                                      {"all": np.ones(traj.t.size, bool)})["all"] for f, e in est.items()}
                cal_keys = tuple(cals) if comp == "none" else (cal,)  # uncompensated: the same for all
                for ck in cal_keys:
                    for f in config.filters:
                        att[ck][phase].setdefault(comp, {}).setdefault(f, {})[profile] = m[f]
                if profile == series_profile and phase == "warmup":
                    _warmup_series(series, resid, s, traj, est, rate, config.residual_window_s, cal_keys, comp,
                                   cal == first and comp == (comps[-1] if comps else "none"))
    ranges = {c: [v.tolist() for v in cals[c].site_range_C()] for c in cals}
    return {"attitude": att, "residuals": resid, "extrapolated": {c: n_out[c] / n_all for c in cals},
            "range_C": ranges, "max_reported_C": max_rep.tolist(), "series": series}


def _calibrations(unit, cal_ss, chamber_C, rise_K, config: StudyConfig, bare_cal=None) -> dict:
    """calibration name -> Calibration of one drawn unit: ``unit`` in the oven with the scheme's self-heating
    (chamber [°C] -> rise [K], linear between the chamber temperatures, extrapolated from the end points beyond),
    ``bare`` the sensors on their own (``bare_cal`` if given)."""
    from imutherm.imu.calibration import calibrate_unit

    chamber = np.asarray(chamber_C, float)
    rise = np.asarray(rise_K, float)

    def heating(Tc):
        return np.array([np.interp(Tc, chamber, rise[:, j]) if chamber[0] <= Tc <= chamber[-1] else
                         _extrap(Tc, chamber, rise[:, j]) for j in range(6)])

    cals = {}
    if "unit" in config.calibrations:
        cals["unit"] = calibrate_unit(unit, np.random.default_rng(cal_ss), self_heating=heating)
    if "bare" in config.calibrations:
        cals["bare"] = bare_cal if bare_cal is not None else calibrate_unit(unit, np.random.default_rng(cal_ss))
    return cals


def _die_temperatures(phase: str, t, curves_t, curves_T, steady_T) -> np.ndarray:
    """(N, 6) die temperatures [°C] at the motion's times ``t`` [s]: the power-on curves in the warm-up, the
    steady values after; InputError outside the sensor model's range."""
    from imutherm.imu.sensor_model import T_MODEL_RANGE_C

    if phase == "warmup":
        temp = np.column_stack([np.interp(t, curves_t, curves_T[:, j]) for j in range(6)])
    else:
        temp = np.broadcast_to(np.asarray(steady_T, float), (t.size, 6))   # one row: its curves evaluated once
    lo, hi = T_MODEL_RANGE_C
    if temp.min() < lo or temp.max() > hi:
        raise InputError(f"die temperature {temp.max():.1f} °C is outside the sensor model's range "
                         f"{lo:g}..{hi:g} °C")
    return temp


def _warmup_series(series: dict, resid: dict, s, traj, est: dict, rate: float, window_s: float, cal_keys, comp: str,
                   attitude: bool) -> None:
    """The flight warm-up's residual sensor errors (``window_s`` means: accel [mg], gyro [°/s]) into ``resid``
    and ``series``, and with ``attitude`` each filter's roll / pitch error curve at 10 Hz [deg]."""
    from imutherm.imu.sensor_model import G0

    nb = max(1, int(round(window_s * rate)))
    ea = _block_mean((s.accel - traj.f_b) / G0 * 1e3, nb)  # [mg]
    eg = _block_mean(np.degrees(s.gyro - traj.omega_b), nb)  # [°/s]
    r = {"accel_rms_mg": float(np.sqrt(np.mean(ea**2))), "accel_max_mg": float(np.abs(ea).max()),
         "gyro_rms_dps": float(np.sqrt(np.mean(eg**2))), "gyro_max_dps": float(np.abs(eg).max())}
    for ck in cal_keys:
        resid.setdefault(ck, {})[comp] = r
        series[f"{ck}_{comp}_accel_mg"] = ea
        series[f"{ck}_{comp}_gyro_dps"] = eg
    series["residual_t_s"] = _block_mean(traj.t, nb)
    if attitude:
        k = max(1, int(round(rate / 10.0)))  # 10 Hz for the files
        series["attitude_t_s"] = traj.t[::k]
        series["attitude_compensation"] = comp
        for f, e in est.items():
            series[f"{f}_roll_err_deg"] = np.degrees(_wrap(e.roll - traj.roll))[::k]
            series[f"{f}_pitch_err_deg"] = np.degrees(_wrap(e.pitch - traj.pitch))[::k]


def _extrap(x, xs, ys):
    """Linear extrapolation from the two end points of (xs, ys)."""
    j = 1 if x < xs[0] else len(xs) - 1
    return ys[j - 1] + (x - xs[j - 1]) * (ys[j] - ys[j - 1]) / (xs[j] - xs[j - 1])


def _wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def _spread(values) -> dict:
    a = np.asarray(values, float)
    return {"mean": float(a.mean()), "std": float(a.std())}


def _reduce_tree(trees: list):
    """Leaves (floats) of equal nested dicts -> {mean, std} over the list (population std, ddof=0)."""
    first = trees[0]
    if isinstance(first, dict):
        return {k: _reduce_tree([t[k] for t in trees]) for k in first}
    if isinstance(first, (list, tuple)):
        return [_reduce_tree([t[i] for t in trees]) for i in range(len(first))]
    return _spread(trees)


def reduce_cases(cases: list) -> dict:
    """Seed results of :func:`imu_case` -> mean and std over the seeds."""
    return {"attitude": _reduce_tree([c["attitude"] for c in cases]),
            "residuals": _reduce_tree([c["residuals"] for c in cases]),
            "extrapolated_fraction": _reduce_tree([c["extrapolated"] for c in cases]),
            "range_C": {cal: {"low": _reduce_tree([c["range_C"][cal][0] for c in cases]),
                              "high": _reduce_tree([c["range_C"][cal][1] for c in cases])} for cal in cases[0]["range_C"]},
            "max_reported_C": _reduce_tree([c["max_reported_C"] for c in cases])}


def sweep_config() -> StudyConfig:
    """The lean IMU configuration of a sweep case: the paper's compensation, one seed, the flight, and the
    registry's ``sweep`` group (:func:`~imutherm.imu.filters.registry.sweep_filters`)."""
    from imutherm.imu.filters.registry import sweep_filters

    return StudyConfig(seeds=1, profiles=("flight",), compensations=("improved",), filters=sweep_filters(),
                       calibrations=("unit",))


def scheme_attitude_metrics(result, *, seeds: int = 1, seed0: int = 0, config: StudyConfig | None = None) -> dict:
    """Flat attitude metrics of one solved scheme, for a sweep row.

    Parameters
    ----------
    result : SchemeResult (:func:`imutherm.studies.thermal.thermal_study.run_scheme`; with a transient, the warm-up
        phase is included, else only the steady phase)
    seeds, seed0 : int, units / noise draws (common random numbers, as in :func:`run_study`)
    config : StudyConfig, the IMU side (default :func:`sweep_config`; its seeds are replaced)

    Returns
    -------
    dict ``<phase>_<compensation>_<filter>_<profile>_<metric>`` -> mean over the seeds [deg], calibrated in
    the unit (self-heating from ``result``'s model), plus ``extrapolated_fraction`` [-].
    """
    from imutherm.imu.sensor_model import SITES

    config = replace(config or sweep_config(), seeds=int(seeds), seed0=int(seed0))
    chamber, rise = self_heating_table(result, config.chamber_C)
    idx = [result.steady.probe_names.index(s) for s in SITES]
    steady_T = np.asarray(result.steady.probe_C)[idx]
    if result.transient is not None:
        t, T = site_curves(result)
        phases = PHASES
    else:
        t, T = np.array([0.0, 1.0]), np.tile(steady_T, (2, 1))
        phases = ("steady",)
    seeds_ = range(config.seed0, config.seed0 + config.seeds)
    cases = [imu_case(config.grade, s, t, T, steady_T, chamber, rise, config) for s in seeds_]
    red = reduce_cases(cases)
    out = {}
    for ph in phases:
        for comp, by_f in red["attitude"]["unit"][ph].items():
            if comp == "none" and "none" not in config.compensations:
                continue
            for f, by_p in by_f.items():
                for prof, m in by_p.items():
                    for k, v in m.items():
                        out[f"{ph}_{comp}_{f}_{prof}_{k}"] = v["mean"]
    out["extrapolated_fraction"] = red["extrapolated_fraction"]["unit"]["mean"]
    return out
