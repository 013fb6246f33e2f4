"""Fair attitude-filter comparison: every filter at its published defaults and tuned by one common procedure.

Records: the attitude study's chain (trajectory → disturbances → unit drawn from ``seed`` →
two-step calibration → samples at 25 °C → ``improved`` compensation); one
unit and calibration per seed, reused across profiles. By default every profile
carries its realistic disturbances (:data:`imutherm.imu.disturbances.PRESETS`:
vibration through the sensor chain, turbulence / wind shear / gusts on the
flight, 5 ms reference sync error, 0.2 ms sample jitter), and a filter is
scored against the *reference* attitude (the truth delayed by the sync
error), as a test with an external reference would score it;
``disturbances=False`` gives the idealised records.

Tuning procedure: the study's one procedure (:mod:`imutherm.studies.attitude.filter_tuning`, the same for every
filter, ours and the peers): each filter's axes as the registry declares them
(:class:`~imutherm.imu.filters.registry.Tuned`), one x3.16 ladder, an axis grown while the best lies on its
open edge, the published defaults a candidate too; here minimising the mean over the **training** records
of ``(roll RMS + pitch RMS) / 2`` over the whole record. A filter without axes (``aekf_gnss``) is reported at
its defaults only. Training set: :data:`TRAIN` (profiles ``flight`` and ``shake``, seeds 100-101); the table
is reported on :data:`HELD_OUT` seeds 0-5 of ``flight``, ``swing``, ``vehicle`` and ``handheld`` (the last
three never trained on); :func:`check_split` refuses an overlap.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from imutherm import InputError
from imutherm.imu import motion
from imutherm.imu.attitude_math import wrap_angle
from imutherm.imu.filters import FusionParams
from imutherm.imu.gnss import GnssConfig, simulate_gnss
from imutherm.imu.filters.run import GateConfig, run_filters
from imutherm.imu.motion import DEFAULT_LEVER_ARM

#: training (profile, seeds) and held-out (profile, seeds) sets of the benchmark
TRAIN = (("flight", (100, 101)), ("shake", (100, 101)))
HELD_OUT = (("flight", tuple(range(6))), ("swing", tuple(range(6))), ("vehicle", tuple(range(6))),
            ("handheld", tuple(range(6))))

#: the gates' design turn radius L [m] per profile: the platform's
#: (:data:`imutherm.studies.attitude.recorded.PLATFORMS`, as ``--imu-csv --platform`` uses), GateConfig.L (the
#: aircraft's 1146 m) for the others
TURN_RADIUS = {"vehicle": 50.0, "handheld": 0.5}


@dataclass(frozen=True)
class Record:
    """One simulated, compensated record: gyro (N,3) [rad/s], accel (N,3) [m/s^2], dt [s], reference roll/pitch
    (N,) [rad] (the truth, delayed by the sync error when disturbed), lever_arm (3,) [m], init_s [s] rest at
    the start, profile, seed, turn_radius [m] the gates' design turn radius L for the profile's platform
    (:data:`TURN_RADIUS`); gnss: the simulated GNSS velocity fixes (:class:`imutherm.imu.gnss.GnssVelocity`,
    default receiver) for ``aekf_gnss``; lever_comp: every gravity-referenced filter gets the accelerometer with
    its lever-arm term removed (``run_filters(lever_comp=True)``; ``aekf`` removes it itself either way);
    gyro_range_dps [deg/s]: the grade's gyro full scale, the fusion peer's gyroscope range (0: none stated)."""

    profile: str
    seed: int
    gyro: np.ndarray = field(repr=False)
    accel: np.ndarray = field(repr=False)
    dt: float
    roll: np.ndarray = field(repr=False)
    pitch: np.ndarray = field(repr=False)
    lever_arm: tuple
    init_s: float
    turn_radius: float = GateConfig.L
    gnss: object = field(default=None, repr=False)
    lever_comp: bool = False
    gyro_range_dps: float = 0.0


def check_split(train=TRAIN, held_out=HELD_OUT) -> None:
    """Raise InputError if a (profile, seed) pair is in both the training and the held-out set."""
    tr = {(p, s) for p, seeds in train for s in seeds}
    ho = {(p, s) for p, seeds in held_out for s in seeds}
    both = sorted(tr & ho)
    if both:
        raise InputError(f"filter benchmark: {both} are both training and held-out records; valid: disjoint sets")


def make_records(sets, grade: str = "adis16355", compensation: str = "improved", *,
                 disturbances=True, lever_comp: bool = False) -> list[Record]:
    """Records for [(profile, seeds), ...]; one unit + calibration per seed, 25 °C.

    disturbances : True (each profile's :data:`~imutherm.imu.disturbances.PRESETS`), False / None (idealised)
    or a dict {profile: Disturbances} (a profile missing from it: idealised).
    """
    from imutherm.imu import disturbances as dist_mod
    from imutherm.imu.calibration import calibrate_unit
    from imutherm.imu.compensation import compensate
    from imutherm.imu.filters.fusion_peer import gyro_range_of_grade
    from imutherm.imu.sensor_model import draw_unit, load_grade, simulate_imu

    g = load_grade(grade)
    rate = g.sample_rate_hz
    gyro_range = gyro_range_of_grade(g)
    units = {}
    out = []
    for profile, seeds in sets:
        d = DEFAULT_LEVER_ARM[profile]
        traj = motion.make_profile(profile, None, rate, lever_arm=d)
        rest = float(np.sum(traj.segment == traj.segment[0])) / rate
        init_s = min(GateConfig.init_s, rest)
        for s in seeds:
            if s not in units:
                rng = np.random.default_rng(s)
                unit = draw_unit(g, rng)
                units[s] = (unit, calibrate_unit(unit, rng))
            unit, cal = units[s]
            rng = np.random.default_rng([s, motion.PROFILES.index(profile)])  # the noise of this record
            dist = (dist_mod.PRESETS.get(profile) if disturbances is True else
                    (disturbances or {}).get(profile))
            dr = dist_mod.apply(traj, dist, np.random.default_rng([s, motion.PROFILES.index(profile), 1]))
            raw = simulate_imu(unit, traj.t, dr.omega_in, dr.f_in, np.full((traj.t.size, 6), 25.0), rng)
            smp = compensate(raw, cal, compensation)
            fixes = simulate_gnss(traj, np.random.default_rng([s, motion.PROFILES.index(profile), 0x6E55]),
                                  GnssConfig())
            out.append(Record(profile, s, smp.gyro, smp.accel, 1.0 / rate, dr.ref_roll, dr.ref_pitch, d, init_s,
                              TURN_RADIUS.get(profile, GateConfig.L), fixes, lever_comp, gyro_range))
    return out


def run_one(name: str, rec: Record, values: dict | None = None):
    """AttitudeEstimate of filter ``name`` on ``rec`` with ``values`` {field: value} of its registry
    ``params_cls`` (as the settings file names them; None: its defaults on this record)."""
    est, _ = run_filters(rec.gyro, rec.accel, rec.dt, rec.lever_arm, GateConfig(init_s=rec.init_s, L=rec.turn_radius),
                         design={"fusion": FusionParams(gyroscope_range=rec.gyro_range_dps)}, names=(name,),
                         gnss=rec.gnss, lever_comp=rec.lever_comp, settings=None if values is None else {name: values})
    return est[name]


def score(est, rec: Record) -> dict:
    """Whole-record roll / pitch RMS and max |error| [deg]."""
    r = np.degrees(wrap_angle(est.roll - rec.roll))
    p = np.degrees(wrap_angle(est.pitch - rec.pitch))
    return {"roll_rms_deg": float(np.sqrt(np.mean(r * r))), "pitch_rms_deg": float(np.sqrt(np.mean(p * p))),
            "roll_max_deg": float(np.max(np.abs(r))), "pitch_max_deg": float(np.max(np.abs(p)))}


def objective(name: str, values: dict, records) -> float:
    """Mean over ``records`` of (roll RMS + pitch RMS) / 2 [deg]; inf if the filter fails or diverges."""
    tot = 0.0
    for rec in records:
        try:
            m = score(run_one(name, rec, values), rec)
        except (InputError, FloatingPointError, ValueError, ZeroDivisionError):
            return math.inf
        v = 0.5 * (m["roll_rms_deg"] + m["pitch_rms_deg"])
        if not math.isfinite(v):
            return math.inf
        tot += v
    return tot / len(records)


@dataclass(frozen=True)
class TuneResult:
    """Result of :func:`tune`: values {field: value} (the chosen point, or the defaults' values when they win),
    objective [deg] on the training records, evaluations, objective at the defaults [deg], wall time [s];
    grid, at_bound, chosen: as in the study's settings file (:func:`imutherm.studies.attitude.filter_tuning.search`)."""

    name: str
    values: dict
    objective: float
    n_eval: int
    default_objective: float
    runtime_s: float
    grid: dict = field(default_factory=dict)
    at_bound: tuple = ()
    chosen: str = "grid"


def tune(name: str, records) -> TuneResult:
    """The study's tuning procedure (:func:`imutherm.studies.attitude.filter_tuning.tune_filter`, the registry's axes)
    for filter ``name`` on training ``records``; InputError for a filter without axes."""
    from imutherm.studies.attitude.filter_tuning import tune_filter

    t0 = time.perf_counter()
    r = tune_filter(name, lambda pt: objective(name, pt, records))
    return TuneResult(name=name, values=dict(r["values"]), objective=float(r["score"]),
                      n_eval=int(r["evaluations"]) + 1, default_objective=float(r["default_score"]),
                      runtime_s=time.perf_counter() - t0, grid=r["grid"], at_bound=tuple(r["at_bound"]),
                      chosen=r["chosen"])


def table(names, records, tuned: dict) -> dict:
    """{name: {profile: {"defaults"|"tuned": {metric: {mean, std}}}}} over the seeds of each profile
    (std: population, ddof=0), plus runtime per record [s]."""
    out = {}
    for name in names:
        out[name] = {}
        for setting, values in (("defaults", None), ("tuned", tuned.get(name))):
            if setting == "tuned" and values is None:
                continue
            per = {}
            for rec in records:
                est = run_one(name, rec, values)
                m = score(est, rec)
                m["runtime_s"] = est.runtime_s
                per.setdefault(rec.profile, []).append(m)
            for prof, ms in per.items():
                out[name].setdefault(prof, {})[setting] = {
                    k: {"mean": float(np.mean([m[k] for m in ms])), "std": float(np.std([m[k] for m in ms]))}
                    for k in ms[0]} | {"n_seeds": len(ms)}
    return out


__all__ = ["TRAIN", "HELD_OUT", "Record", "TuneResult", "check_split", "make_records", "run_one",
           "score", "objective", "tune", "table"]
