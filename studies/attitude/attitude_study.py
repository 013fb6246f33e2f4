"""Attitude study chain: trajectory → unit → calibration → samples → compensation → filters → metrics.

:func:`run_attitude_study` runs the attitude filters of the registry (:mod:`imutherm.imu.filters.registry`:
``gated`` Liu et al. 2012, ``kf`` the horizontal-attitude KF paper, ``ungated`` complementary baseline,
``aekf`` Wang et al., and the peers) on the same compensated samples for several seeds and reduces the roll
and pitch errors to RMS and maximum per phase (``overall``, ``stable``,
``manoeuvre``). Each metric is reported as ``{"mean": ..., "std": ...}`` over
the seeds (population std, ddof=0); ``None`` where a phase has no samples.

The gate parameters (:class:`GateConfig`) and the filter runner (:func:`run_filters`) live in
:mod:`imutherm.imu.filters.run`; this module re-exports them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from imutherm import InputError
from imutherm.imu import motion
from imutherm.imu.attitude_math import wrap_angle
from imutherm.imu.filters import FusionParams, KFParams
from imutherm.imu.filters import run as filters_run
from imutherm.imu.filters.run import GateConfig
from imutherm.imu.gnss import GnssConfig, simulate_gnss
from imutherm.imu.filters.fusion_peer import fusion_params_of_grade
from imutherm.imu.motion import DEFAULT_LEVER_ARM

SEGMENTS = ("overall", "stable", "manoeuvre")
METRICS = ("roll_rms_deg", "pitch_rms_deg", "roll_max_deg", "pitch_max_deg")
COMPENSATIONS = ("none", "conventional", "improved")


@dataclass(frozen=True)
class AttitudeStudyResult:
    """Result of :func:`run_attitude_study`.

    profile, grade, compensation : str
    seeds : tuple[int]              seeds run (numpy default_rng)
    duration_s : float [s]; rate_hz : float [Hz]; lever_arm : (3,) [m]
    temperature : dict              description of the temperature input (°C)
    metrics : dict                  filters.<name>.<segment>.<metric> -> {mean, std} [deg];
                                    filters.<name>.runtime_s -> {mean, std} [s]
    gate : dict                     gate configuration and the thresholds of the first seed (SI)
    series : dict                   first seed's time series: t [s], phase, segment, truth roll/pitch [deg],
                                    per filter roll/pitch [deg] and accel_used
    gnss : dict                     the simulated receiver of aekf_gnss: rate_hz [Hz], vel_std_mps [m/s]
    fusion : dict                   the fusion peer's gyroscope_range_dps [deg/s] (the grade's full scale) and
                                    its source
    filter_settings : dict          what each filter ran with: ``tuned`` {name: {field: value}} from ``file``
                                    (studies/attitude/filter_settings.toml), ``defaults`` [names] at their defaults
    """

    profile: str
    grade: str
    compensation: str
    seeds: tuple
    duration_s: float
    rate_hz: float
    lever_arm: tuple
    temperature: dict
    metrics: dict
    gate: dict
    series: dict = field(repr=False)
    gnss: dict = field(default_factory=dict)
    fusion: dict = field(default_factory=dict)
    filter_settings: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        """JSON-ready dict (the content of attitude.json)."""
        return {
            "profile": self.profile, "grade": self.grade, "compensation": self.compensation,
            "seeds": list(self.seeds), "duration_s": self.duration_s, "rate_hz": self.rate_hz,
            "lever_arm_m": list(self.lever_arm), "temperature": self.temperature,
            "spread": "each metric is {mean, std} over the seeds (std: population, ddof=0); "
                      "angles in deg, runtime in s; null where a phase has no samples",
            "frames": "NED navigation, FRD body, ZYX Euler; errors are estimate - truth",
            "gate": self.gate, "gnss": self.gnss, "fusion": self.fusion, "filter_settings": self.filter_settings,
            "filters": self.metrics,
        }


# --------------------------------------------------------------------------- temperatures
def read_temperature_csv(path) -> tuple[np.ndarray, np.ndarray]:
    """Read a site-temperature table (:func:`imutherm.site_table.read_site_table`): ``time_s`` and one
    column per site (SITES) [°C]. Returns (time [s] (M,), temperatures [°C] (M, 6))."""
    from imutherm.site_table import read_site_table

    t, T, _ = read_site_table(path)
    return t, T


def check_temperature_span(tc, start_s: float, end_s: float, path) -> None:
    """InputError unless a multi-row temperature CSV's times ``tc`` [s] reach the run's start ``start_s`` [s]
    and overlap the run up to ``end_s`` [s]: beyond its ends a table is held constant, so a table that starts
    after the run starts, or ends before it, would be reinterpreted silently (a single row is a constant)."""
    if len(tc) < 2:
        return
    if tc[0] > start_s or tc[-1] < start_s:
        raise InputError(f"temperature: {path}: its times {tc[0]:g}..{tc[-1]:g} s do not cover the run's "
                         f"{start_s:g}..{end_s:g} s (a table is held constant beyond its ends); give time_s "
                         f"from {start_s:g} s (power-on) on, or one row for a constant temperature")


def temperature_on(t, temperature_C=None, temperature_csv=None, *, valid_C=None) -> tuple[np.ndarray, dict]:
    """True die temperatures (N, 6) [°C] on sample times ``t`` [s] and a description dict.

    Either a constant ``temperature_C`` [°C] (default 25) or a CSV interpolated
    linearly (held constant beyond its ends; a single-row CSV is a constant,
    whatever its time). Raises InputError outside ``valid_C`` (default the
    calibrated range -40..70 °C; the attitude study passes the truth model's
    range when compensation has an out-of-range policy).
    """
    from imutherm.imu.sensor_model import SITES, T_RANGE_C

    if temperature_csv is not None and temperature_C is not None:
        raise InputError("temperature: give either --temperature or --temperature-csv, not both")
    if temperature_csv is not None:
        tc, T = read_temperature_csv(temperature_csv)
        if len(t):
            check_temperature_span(tc, float(t[0]), float(t[-1]), temperature_csv)
        if len(tc) == 1:  # steady state: one row, its time (possibly inf) is irrelevant
            temp = np.tile(T[0], (len(t), 1))
        else:
            temp = np.column_stack([np.interp(t, tc, T[:, j]) for j in range(6)])
        desc = {"source": str(temperature_csv), "min_C": float(temp.min()), "max_C": float(temp.max())}
    else:
        T0 = 25.0 if temperature_C is None else float(temperature_C)
        if not math.isfinite(T0):
            raise InputError(f"temperature: {temperature_C!r} is invalid; valid: a number in °C")
        temp = np.full((len(t), 6), T0)
        desc = {"source": "constant", "value_C": T0}
    lo, hi = T_RANGE_C if valid_C is None else valid_C
    what = "the calibrated range" if valid_C is None else "the sensor model's range"
    bad = (temp < lo) | (temp > hi)
    if np.any(bad):
        n, j = np.argwhere(bad)[0]
        hint = " (or compensate beyond it with --out-of-range hold|linear)" if valid_C is None else ""
        raise InputError(f"temperature: {temp[n, j]:.2f} °C at site {SITES[j]} (t = {t[n]:.2f} s) is outside "
                         f"{what}; valid: {lo:g}..{hi:g} °C{hint}")
    return temp, desc


def leveling_window_s(traj, gate: "GateConfig") -> float:
    """The initial rest used for leveling [s]: ``gate.init_s`` or the profile's initial rest if shorter.

    Raises InputError when it is under 1 s.
    """
    rate = 1.0 / float(traj.t[1] - traj.t[0])
    first = traj.segment[0]
    first_len = float(np.sum(traj.segment == first)) / rate if traj.phase[0] == "stable" else 0.0
    init_s = min(gate.init_s, first_len)
    if init_s < 1.0:
        raise InputError(f"leveling window init_s={init_s:.2f} s (the smaller of GateConfig.init_s={gate.init_s} s "
                         f"and the initial rest of {first_len:.2f} s of profile {traj.profile!r}) is too short; "
                         "valid: at least 1 s")
    return init_s


# --------------------------------------------------------------------------- metrics
def error_metrics(roll_err, pitch_err, masks: dict) -> dict:
    """RMS and max |error| [deg] per phase; roll_err, pitch_err [rad] (N,), masks name -> (N,) bool."""
    out = {}
    r, p = np.degrees(wrap_angle(roll_err)), np.degrees(wrap_angle(pitch_err))
    for name, m in masks.items():
        if not np.any(m):
            out[name] = {k: None for k in METRICS}
            continue
        out[name] = {"roll_rms_deg": float(np.sqrt(np.mean(r[m] ** 2))),
                     "pitch_rms_deg": float(np.sqrt(np.mean(p[m] ** 2))),
                     "roll_max_deg": float(np.max(np.abs(r[m]))),
                     "pitch_max_deg": float(np.max(np.abs(p[m])))}
    return out


def _spread(values):
    vals = [v for v in values if v is not None]
    if not vals:
        return None
    a = np.asarray(vals, float)
    return {"mean": float(a.mean()), "std": float(a.std())}


def run_filters(gyro, accel, dt: float, lever_arm, gate: GateConfig = GateConfig(),
                fusion: FusionParams | None = None, kf: KFParams | None = None, design=None, **kwargs):
    """:func:`imutherm.imu.filters.run.run_filters` (where it lives), with ``fusion`` / ``kf`` taken as those
    filters' ``design`` entries, as before; returns ({name: AttitudeEstimate}, thresholds)."""
    design = {} if design is None else dict(design)
    for name, p in (("fusion", fusion), ("kf", kf)):
        if p is not None:
            design.setdefault(name, p)
    return filters_run.run_filters(gyro, accel, dt, lever_arm, gate, design=design, **kwargs)


def run_attitude_study(profile: str = "flight", *, grade: str = "adis16355", temperature_C: float | None = None,
                       temperature_csv=None, compensation: str = "improved", seeds: int = 1, seed0: int = 0,
                       duration: float | None = None, lever_arm=None, gate: GateConfig = GateConfig(),
                       names=None, out_of_range: str = "error", disturbances: bool = False,
                       gnss: GnssConfig = GnssConfig(), settings: str | None = None) -> AttitudeStudyResult:
    """Run the attitude chain for ``seeds`` seeds (seed0, seed0+1, ...) and reduce the errors.

    settings : None or 'defaults': every filter at its defaults; 'tuned': each filter at its tuned settings
    for the profile (:mod:`imutherm.studies.attitude.filter_settings`; ``imutherm attitude``'s default), those the file
    has none for (a profile or filter not tuned) at their defaults, as ``filter_settings`` in the result says.

    profile : one of motion.PROFILES; grade : sensor grade name; temperature_C [°C] constant
    (default 25) or temperature_csv (path; ``time_s`` + one column per site [°C]);
    compensation : none|conventional|improved; duration [s] (None: profile default);
    lever_arm (3,) [m] (None: per-profile default); gate : GateConfig; names : registered filters (None: every one);
    disturbances : True applies the profile's realistic disturbances (:data:`imutherm.imu.disturbances.PRESETS`,
    drawn from the generator seeded ``[seed, 7]``) and scores against the reference attitude (truth delayed by
    the sync error); ``gate["disturbances"]`` in the result describes them.
    out_of_range : error|hold|linear, the compensation's policy for reported temperatures outside the
    calibrated range (:mod:`imutherm.imu.compensation`); ``temperature["extrapolated_fraction"]`` in the
    result is the share of (sample, sensor) pairs it acted on (first seed).
    gnss : GnssConfig, the simulated receiver of ``aekf_gnss`` (fixes drawn per seed from
    ``default_rng([seed, 0x6E55])``, so the IMU noise stream is unchanged).
    Filters with a heading estimate (``aekf``, ``aekf_gnss``) also get ``filters.<name>.heading``:
    ``{"rms_deg", "max_deg"}`` each {mean, std} over the seeds, whole record.
    """
    from imutherm.imu import disturbances as dist_mod
    from imutherm.imu.calibration import calibrate_unit
    from imutherm.imu.compensation import OUT_OF_RANGE, compensate, out_of_range_mask
    from imutherm.imu.sensor_model import T_MODEL_RANGE_C, draw_unit, load_grade, simulate_imu

    if profile not in motion.PROFILES:
        raise InputError(f"--profile: {profile!r} is unknown; valid: {', '.join(motion.PROFILES)}")
    g = load_grade(grade)
    if compensation not in COMPENSATIONS:
        raise InputError(f"--compensation: {compensation!r} is unknown; valid: {', '.join(COMPENSATIONS)}")
    if not (isinstance(seeds, (int, np.integer)) and seeds >= 1):
        raise InputError(f"--seeds: {seeds!r} is invalid; valid: an integer >= 1")
    from imutherm.imu.filters.registry import REGISTRY, filter_names

    names = filter_names() if names is None else tuple(names)
    unknown = [n for n in names if n not in filter_names()]
    needs_gnss = any(REGISTRY[n].needs_gnss for n in names if n in REGISTRY)
    if unknown:
        raise InputError(f"filters: {unknown} unknown; valid: {', '.join(filter_names())}")
    d = tuple(float(v) for v in (DEFAULT_LEVER_ARM[profile] if lever_arm is None else lever_arm))
    rate = g.sample_rate_hz
    traj = motion.make_profile(profile, duration, rate, lever_arm=d)
    if out_of_range not in OUT_OF_RANGE:
        raise InputError(f"--out-of-range: {out_of_range!r} is unknown; valid: {', '.join(OUT_OF_RANGE)}")
    temp, tdesc = temperature_on(traj.t, temperature_C, temperature_csv,
                                 valid_C=None if out_of_range == "error" else T_MODEL_RANGE_C)
    init_s = leveling_window_s(traj, gate)
    gate_run = replace(gate, init_s=init_s)
    fusion = fusion_params_of_grade(g)  # the declared sensor's range, not the data's peak
    tuned, fs_json = _profile_settings(profile, names, settings)
    dt = 1.0 / rate
    masks = {"overall": np.ones(traj.t.size, bool), "stable": traj.stable, "manoeuvre": ~traj.stable}
    per = {n: [] for n in names}
    runtimes = {n: [] for n in names}
    heading = {}
    series = None
    th0 = None
    seed_list = tuple(range(seed0, seed0 + int(seeds)))
    for s in seed_list:
        rng = np.random.default_rng(s)
        unit = draw_unit(g, rng)
        cal = calibrate_unit(unit, rng) if compensation != "none" else None
        dr = dist_mod.apply(traj, dist_mod.PRESETS[profile] if disturbances else None,
                            np.random.default_rng([s, 7]))
        raw = simulate_imu(unit, traj.t, dr.omega_in, dr.f_in, temp, rng)
        samp = compensate(raw, cal, compensation, out_of_range=out_of_range)
        if cal is not None and s == seed0:
            tdesc["extrapolated_fraction"] = float(out_of_range_mask(raw.temp_C, cal).mean())
        fixes = simulate_gnss(traj, np.random.default_rng([s, 0x6E55]), gnss) if needs_gnss else None
        est, th = filters_run.run_filters(samp.gyro, samp.accel, dt, d, gate_run, names=names, gnss=fixes,
                                          design={"fusion": fusion}, settings=tuned)
        for n, e in est.items():
            per[n].append(error_metrics(e.roll - dr.ref_roll, e.pitch - dr.ref_pitch, masks))
            runtimes[n].append(e.runtime_s)
            if e.yaw is not None:
                hd = np.degrees(wrap_angle(e.yaw - traj.yaw))
                heading.setdefault(n, []).append((float(np.sqrt(np.mean(hd**2))), float(np.max(np.abs(hd)))))
        if series is None:
            th0 = th
            series = {"t": traj.t, "phase": traj.phase, "segment": traj.segment,
                      "truth_roll_deg": np.degrees(dr.ref_roll), "truth_pitch_deg": np.degrees(dr.ref_pitch)}
            for n, e in est.items():
                series[f"{n}_roll_deg"] = np.degrees(e.roll)
                series[f"{n}_pitch_deg"] = np.degrees(e.pitch)
                series[f"{n}_accel_used"] = e.accel_used
    metrics = {}
    for n in names:
        metrics[n] = {seg: {m: _spread([r[seg][m] for r in per[n]]) for m in METRICS} for seg in SEGMENTS}
        metrics[n]["runtime_s"] = _spread(runtimes[n])
        if n in heading:
            metrics[n]["heading"] = {"rms_deg": _spread([h[0] for h in heading[n]]),
                                     "max_deg": _spread([h[1] for h in heading[n]])}
    gate_json = {"xi_a_mps2": gate.xi_a, "xi_w_mps2": gate.xi_w, "L_m": gate.L, "d_m": list(d),
                 "kp_per_s": gate.kp, "ki_per_s2": gate.ki, "tau_s": gate.tau, "hold_s": gate.hold_s,
                 "init_s": init_s, "disturbances": dist_mod.PRESETS[profile].describe() if disturbances else None,
                 "thresholds_seed0": {"sigma_a_mps2": th0.sigma_a, "sigma_w_radps": th0.sigma_w,
                                      "sigma_wdot_radps2": th0.sigma_wdot, "theory": list(th0.theory),
                                      "noise_std": list(th0.noise_std)}}
    return AttitudeStudyResult(profile=profile, grade=g.name, compensation=compensation, seeds=seed_list,
                               duration_s=float(traj.t[-1] + dt), rate_hz=rate, lever_arm=d, temperature=tdesc,
                               metrics=metrics, gate=gate_json, series=series,
                               gnss={"rate_hz": gnss.rate_hz, "vel_std_mps": gnss.vel_std,
                                     "used_by": "aekf_gnss", "antenna": "at the IMU (no antenna lever arm)"},
                               fusion={"gyroscope_range_dps": fusion.gyroscope_range,
                                       "source": f"sensor grade {g.name} full scale (0: none stated, over-range "
                                                 "recovery off)"},
                               filter_settings=fs_json)


def _profile_settings(profile: str, names, settings) -> tuple:
    """({name: {field: value}} for :func:`run_filters`, the result's ``filter_settings``) of ``settings``
    (None / 'defaults' / 'tuned', :func:`run_attitude_study`)."""
    if settings in (None, "defaults"):
        return {}, {"tuned": {}, "defaults": list(names)}
    if settings != "tuned":
        raise InputError(f"filter settings: {settings!r} is invalid; valid: 'tuned', 'defaults' or None")
    from imutherm.studies.attitude.filter_settings import load_settings

    fs = load_settings()
    tuned = fs.for_profile(profile, names)
    return tuned, {"file": fs.path, "tuned": tuned, "defaults": [n for n in names if n not in tuned],
                   "seeds": fs.meta.get("seeds")}
