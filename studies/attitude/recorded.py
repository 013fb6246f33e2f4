"""Every attitude filter on a user's recorded log (:mod:`imutherm.imu.imu_log`), scored against its reference.

The gates' design inputs that depend on the platform (lever arm d from the rotation centre, turn radius L)
come from :data:`PLATFORMS` unless given; everything else is the filters' defaults
(:class:`~imutherm.studies.attitude.attitude_study.GateConfig`), with the leveling window ``init_s`` at the start of
the log. The |f| reference, gyro bias and gate widening are measured on the log's own rest window at its
own sample rate (:func:`~imutherm.studies.attitude.attitude_study.run_filters`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from imutherm import InputError
from imutherm.imu.attitude_math import roll_pitch_from_gravity
from imutherm.imu.filters.run import GateConfig, run_filters
from imutherm.studies.attitude.attitude_study import error_metrics

#: platform defaults of the gate design inputs: lever arm d (3,) [m] and turn radius L [m].
#: handheld: no lever arm (the rotation centre of hand and body motion moves between wrist, elbow and shoulder, so
#: no fixed d holds; a wrong one is worse than none: the aekf subtracts ω × (ω × d), 46 m/s² at BROAD's 1400 °/s
#: for the 8 cm once assumed here, which tripled its error on that trial, 3.7° -> 1.2° with none; with d = 0 the
#: gated filter's angular-acceleration gate, which bounds the tangential term ω̇ × d, is open), arm swing radius
#: 0.5 m [ASSUMED]; vehicle: dashboard mount
#: 0.5 m ahead / 0.3 m above the reference point, town-corner radius 50 m [ASSUMED]; aircraft: the flight
#: profile's 0.3 m lever arm and the 1146 m standard-rate turn radius at 60 m/s (GateConfig).
PLATFORMS = {
    "handheld": ((0.0, 0.0, 0.0), 0.5),
    "vehicle": ((0.5, 0.0, -0.3), 50.0),
    "aircraft": ((0.3, 0.0, 0.05), GateConfig.L),
}

#: the simulated motion profile whose tuned settings (``studies/attitude/filter_settings.toml``, the one tuning
#: procedure of :mod:`imutherm.studies.attitude.filter_tuning` on seeds 100-101) stand for each platform where a setting
#: is taken from the file: handheld -> the handheld profile, vehicle -> the vehicle profile, aircraft -> the flight
PLATFORM_PROFILE = {"handheld": "handheld", "vehicle": "vehicle", "aircraft": "flight"}


def platform_setting(platform: str, name: str) -> dict:
    """The params fields of filter ``name`` (one of the registry's group ``platform_tuned``) on ``platform``: its tuned
    setting on the platform's profile (:data:`PLATFORM_PROFILE`), never its library defaults. The ``mahony`` peer's
    ahrs defaults (1.0, 0.3) are a trap on real motion (9.5° mean and 46° on one held-out record; 3.44° on RepoIMU):
    the integral gain winds the bias estimate up under sustained accelerations. Tuned on simulated records (the
    study's chain, seeds 100-101), not on the data the recorded-log benchmarks score; the file names the grid, the
    scores and the command."""
    from imutherm.studies.attitude.filter_settings import load_settings

    prof = PLATFORM_PROFILE[platform]
    tuned = load_settings().for_profile(prof, (name,))
    if name not in tuned:
        raise InputError(f"filter settings: no [{prof}.{name}] entry for platform {platform!r}; valid: rerun "
                         "benchmarks/tune_study_filters.py (its profiles include the platforms')")
    return tuned[name]


def platform_settings(platform: str, names=None) -> dict:
    """{filter: {field: value}} of ``platform`` for :func:`~imutherm.studies.attitude.attitude_study.run_filters`'s
    ``settings`` (fields of each filter's registry ``params_cls`` on top of its library defaults). handheld: the
    real-motion settings of every filter in :mod:`imutherm.studies.attitude.real_settings` (the one tuning procedure on
    the nine real development files, cross-validated by file; ours and the peers alike), and ``mahony``'s tuned
    profile setting where that file has none; vehicle / aircraft: the library defaults (the papers' filters) but
    ``mahony``, at its profile's tuned setting (:func:`platform_setting`: every filter whose registry entry
    says ``platform_tuned``). names None: every filter."""
    from imutherm.imu.filters.registry import filter_names, platform_tuned_filters

    if platform not in PLATFORMS:
        raise InputError(f"--platform: {platform!r} is unknown; valid: {', '.join(PLATFORMS)}")
    names = filter_names(gnss=False) if names is None else tuple(names)
    out = {}
    if platform == "handheld":
        from imutherm.studies.attitude.real_settings import load_real_settings

        out = load_real_settings().for_names(names)
    for name in platform_tuned_filters():
        if name in names and name not in out:
            out[name] = platform_setting(platform, name)
    return out


@dataclass(frozen=True)
class RecordedResult:
    """Result of :func:`run_recorded`.

    source : str; rate_hz [Hz]; n_samples; duration_s [s]; units : dict; platform : str; lever_arm (3,) [m];
    turn_radius_m [m]; init_s [s]; g_rest_mps2 [m/s^2];
    metrics : {filter: {roll_rms_deg, pitch_rms_deg, roll_max_deg, pitch_max_deg (None without a reference),
               accel_used_fraction [-], runtime_s [s], time_steps: 'true' (integrated over the log's true
               per-sample steps) | 'median' (one sample period, the median step: VQF) | 'uniform' (a regular
               or resampled log)}}
    fusion : dict  the fusion peer's gyro range (:func:`imutherm.imu.filters.fusion_peer.fusion_range_info`)
    series : dict  t [s], per filter <name>_roll_deg / _pitch_deg / _accel_used, reference truth_*_deg if present
    samples : dict  what was done to the rows (:func:`sample_report`): repeats and repeated times dropped, the
                    step statistics, resampled or not, which filters took the true steps
    warnings : tuple  one-line notes on the log that do not refuse it (:attr:`imutherm.imu.imu_log.ImuLog.warnings`)
    """

    source: str
    rate_hz: float
    n_samples: int
    duration_s: float
    units: dict
    platform: str
    lever_arm: tuple
    turn_radius_m: float
    init_s: float
    g_rest_mps2: float
    has_reference: bool
    metrics: dict
    series: dict = field(repr=False)
    fusion: dict = field(default_factory=dict)
    samples: dict = field(default_factory=dict)
    warnings: tuple = ()

    def to_json(self) -> dict:
        return {"source": self.source, "rate_hz": self.rate_hz, "n_samples": self.n_samples,
                "duration_s": self.duration_s, "units": self.units, "platform": self.platform,
                "lever_arm_m": list(self.lever_arm), "turn_radius_m": self.turn_radius_m, "init_s": self.init_s,
                "g_rest_mps2": self.g_rest_mps2, "reference": self.has_reference,
                "frames": "FRD body, NED navigation, ZYX Euler; errors are estimate - reference [deg]",
                "samples": self.samples, "warnings": list(self.warnings), "fusion": self.fusion,
                "filters": self.metrics}


#: relative step spread below which a log counts as regular (the rounding of its time stamps)
REGULAR_SPREAD = 1e-6


def true_steps(log):
    """The per-sample steps (N,) [s] the filters get for ``log``: its true steps where they are irregular and
    kept (not resampled), else None (uniform: the median step)."""
    if log.true_steps is None or log.step_spread <= REGULAR_SPREAD:
        return None
    return log.true_steps


def sample_report(log, names) -> dict:
    """What became of the log's rows, for attitude.json: n_rows, n_repeats (sample-and-hold rows, interpolated on
    the rows' grid), longest_hold_s [s], gaps (bridged: row, t_s, length_s) and max_gap_s [s], n_dup_time
    (rows with a repeated time stamp dropped), step_median_s [s] (the filters' sample period), step_spread [-]
    (max |step - median| / median of the true samples), step_min_s / step_max_s [s], resampled (put on a uniform
    grid: spread beyond :data:`imutherm.imu.log_samples.MAX_STEP_SPREAD`), and, for an irregular log kept as it is,
    the filters that integrate its true steps and those run at the median step."""
    from imutherm.imu.filters.registry import in_group
    from imutherm.imu.log_samples import MAX_STEP_SPREAD

    st = log.true_steps
    out = {"n_rows": int(log.n_rows), "n_repeats": int(log.n_repeats), "n_dup_time": int(log.n_dup_time),
           "longest_hold_s": float(log.longest_hold_s), "max_gap_s": float(log.max_gap_s),
           "gaps": [{"row": r, "t_s": t0, "length_s": ln} for r, t0, ln in log.gaps], "step_median_s": float(log.dt),
           "step_spread": float(log.step_spread),
           "step_min_s": float(np.min(st[1:])) if st is not None and st.size > 1 else float(log.dt),
           "step_max_s": float(np.max(st[1:])) if st is not None and st.size > 1 else float(log.dt),
           "resampled": bool(log.resampled), "max_step_spread": MAX_STEP_SPREAD}
    if true_steps(log) is not None:
        true = in_group("varying_dt", names)
        out["true_steps"] = list(true)
        out["median_step"] = [n for n in names if n not in true]
    return out


def log_filters() -> tuple:
    """Every registered filter a recorded log can run (:mod:`imutherm.imu.filters.registry`: all but those
    that need GNSS velocity fixes, which a CSV log of gyro and accelerometer samples does not carry)."""
    from imutherm.imu.filters.registry import filter_names

    return filter_names(gnss=False)


def run_recorded(log, *, platform: str = "handheld", lever_arm=None, turn_radius_m: float | None = None,
                 init_s: float = GateConfig.init_s, names=None, fusion=None, align="none") -> RecordedResult:
    """Run ``names`` on ``log`` (an :class:`~imutherm.imu.imu_log.ImuLog`); platform in :data:`PLATFORMS`,
    lever_arm (3,) [m] and turn_radius_m [m] override its defaults; init_s [s] the rest window; fusion a
    FusionParams (None: its defaults, the gyro range not declared: over-range recovery off); align (:func:`reference_alignment`):
    'none', 'auto' or the IMU's (roll, pitch, yaw) [deg] in the reference's body frame. Scores include the
    inclination (angle between the filter's and the reference's vertical, independent of heading)."""
    if platform not in PLATFORMS:
        raise InputError(f"--platform: {platform!r} is unknown; valid: {', '.join(PLATFORMS)}")
    d0, L0 = PLATFORMS[platform]
    d = tuple(float(v) for v in (d0 if lever_arm is None else lever_arm))
    if len(d) != 3 or not np.all(np.isfinite(d)):
        raise InputError(f"--lever-arm: {lever_arm!r} is invalid; valid: three finite lengths x,y,z [m]")
    L = float(L0 if turn_radius_m is None else turn_radius_m)
    if not (np.isfinite(L) and L > 0):
        raise InputError(f"--turn-radius: {turn_radius_m!r} is invalid; valid: a positive length [m]")
    from imutherm.imu.filters.registry import in_group

    names = log_filters() if names is None else names
    unknown = [n for n in names if n not in log_filters()]
    if unknown:
        raise InputError(f"filters: {unknown} unknown or not runnable on a recorded log (aekf_gnss needs GNSS "
                         f"fixes); valid: {', '.join(log_filters())}")
    gate = replace(GateConfig(), L=L, init_s=float(init_s))
    steps = true_steps(log)
    true_step_filters = in_group("varying_dt", names)
    est, _ = run_filters(log.gyro, log.accel, log.dt, d, gate, names=tuple(names),
                         settings=platform_settings(platform, names), steps=steps, gyro_sample=log.gyro_sample,
                         design={"fusion": fusion})
    metrics = {}
    series = {"t": log.t}
    if log.has_reference:
        series["truth_roll_deg"] = np.degrees(log.ref_roll)
        series["truth_pitch_deg"] = np.degrees(log.ref_pitch)
        series["phase"] = np.full(log.t.size, "stable")
    valid = None
    align_info = None
    if log.has_reference:
        valid = np.isfinite(log.ref_roll) & np.isfinite(log.ref_pitch)
        if not np.any(valid):
            raise InputError(f"{log.path}: the reference columns have no value; valid: numbers where the reference "
                             "saw the unit (empty cells are skipped)")
        A, align_info = reference_alignment(log, align, valid, init_s)
        r_ref = _down(log.ref_roll, log.ref_pitch) @ A.T
        ref_roll, ref_pitch = roll_pitch_from_gravity(r_ref)
        series["truth_roll_deg"] = np.degrees(ref_roll)
        series["truth_pitch_deg"] = np.degrees(ref_pitch)
    mounting = align_info.get("mounting") if align_info and align_info["mode"] == "none" else None
    warnings = list(log.warnings)
    if mounting:
        warnings.append(mounting_warning(align_info))
    for n, e in est.items():
        if log.has_reference and mounting:  # the reference disagrees with the IMU by a mounting: not filter error
            m = {k: None for k in ("roll_rms_deg", "pitch_rms_deg", "roll_max_deg", "pitch_max_deg",
                                   "inclination_rms_deg", "inclination_max_deg")}
            m["not_scored"] = "mounting error between the reference and the IMU frames (see warnings)"
        elif log.has_reference:
            m = error_metrics(e.roll - ref_roll, e.pitch - ref_pitch, {"all": valid})["all"]
            c = np.sum(e.gravity[valid] / np.linalg.norm(e.gravity[valid], axis=1)[:, None] * r_ref[valid], axis=1)
            inc = np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))
            m["inclination_rms_deg"] = float(np.sqrt(np.mean(inc**2)))
            m["inclination_max_deg"] = float(np.max(inc))
            m["reference_samples_dropped"] = int(np.sum(~valid))
        else:
            m = {k: None for k in ("roll_rms_deg", "pitch_rms_deg", "roll_max_deg", "pitch_max_deg")}
        m["accel_used_fraction"] = float(np.mean(e.accel_used))
        m["runtime_s"] = e.runtime_s
        m["resets_s"] = None if e.resets is None else [float(k * log.dt) for k in e.resets]  # divergence monitor
        from imutherm.imu.filters.rest_check import rest_disagreement

        m["rest_off_deg"] = rest_disagreement(log.gyro, log.accel, log.dt, e.gravity)  # [(t [s], angle [deg])]
        from imutherm.studies.attitude.real_benchmark import motion_check_json

        m["motion_check"] = motion_check_json(log.gyro, log.accel, log.dt, e.gravity, init_s, platform=platform,
                                              steps=steps)  # the in-motion divergence check
        m["time_steps"] = "uniform" if steps is None else ("true" if n in true_step_filters else "median")
        if align_info is not None:
            m["alignment"] = align_info
        metrics[n] = m
        series[f"{n}_roll_deg"] = np.degrees(e.roll)
        series[f"{n}_pitch_deg"] = np.degrees(e.pitch)
        series[f"{n}_accel_used"] = e.accel_used
    from imutherm.imu.filters.fusion_peer import fusion_range_info

    return RecordedResult(source=log.path, rate_hz=log.rate_hz, n_samples=int(log.t.size),
                          duration_s=float(log.t[-1] + log.dt), units=log.units, platform=platform, lever_arm=d,
                          turn_radius_m=L, init_s=float(init_s), g_rest_mps2=log.g_rest,
                          has_reference=log.has_reference, metrics=metrics, series=series,
                          fusion=fusion_range_info(fusion, log.gyro), samples=sample_report(log, names),
                          warnings=tuple(warnings))


def mounting_warning(info: dict) -> str:
    """The one-line note on a mounting error found under ``--align none`` (:func:`reference_alignment`)."""
    r, p, y = info["align_rpy_deg"]
    return (f"the reference and the IMU disagree by a mounting rotation of {info['fitted_angle_deg']:.0f}° "
            f"({info['mounting']}): with it the record's consistency residual falls from "
            f"{info['identity']['residual_deg']:.2f}° to {info['fitted']['residual_deg']:.2f}°, so scores against "
            f"the reference as logged would measure the mounting, not the filters, and are not given. Fix: "
            f"--align {r:g},{p:g},{y:g} (the IMU's roll,pitch,yaw in the reference body frame) or --align auto")


def _down(roll, pitch) -> np.ndarray:
    """Gravity direction (N,3) in body axes of ZYX roll, pitch [rad] (FRD in NED)."""
    return np.column_stack([-np.sin(pitch), np.sin(roll) * np.cos(pitch), np.cos(roll) * np.cos(pitch)])


def reference_alignment(log, align, valid, init_s: float):
    """(A (3,3) reference body -> IMU, info dict) for ``align``: a declared (roll, pitch, yaw) [deg] of the IMU frame
    in the reference body frame; 'auto': the rotation fitted on the record's own evidence
    (:func:`imutherm.imu.mounting.decide`: rest samples and gyro windows), applied only when it beats the identity by
    the stated margin, else the identity, and info says which and why; 'none': the identity, with the same test run
    so that a mounting error of 10° or more (a 90° yaw, an axis swap, a sign flip) is found and named
    (info["mounting"]: what it is and the --align that undoes it)."""
    from imutherm.imu.attitude_math import euler_to_quat, quat_to_dcm
    from imutherm.imu.mounting import decide
    from imutherm.imu.reference_log import rotation_angle_deg

    if isinstance(align, str) and align in ("none", "auto"):
        n0 = max(1, int(round(init_s / log.dt)))
        r_ref = np.where(valid[:, None], _down(log.ref_roll, log.ref_pitch), np.nan)
        d = decide(r_ref, log.gyro, log.accel, log.dt, log.g_rest, log.gyro[:n0].mean(axis=0))
        info = {"mode": align, **d.to_json()}
        if align == "auto":
            info["angle_deg"] = rotation_angle_deg(d.A)
            return d.A, info
        info["angle_deg"] = 0.0
        if not d.mounting:
            info["mounting"] = None
        return np.eye(3), info
    rpy = np.radians(np.asarray(align, float))
    A = quat_to_dcm(euler_to_quat(*rpy)).T  # v_ref = C v_imu  ->  v_imu = C^T v_ref
    return A, {"mode": "declared", "rpy_deg": [float(v) for v in np.degrees(rpy)], "angle_deg": rotation_angle_deg(A)}
