"""A stress set for the attitude filters: records that leave moderate attitudes, from simulation and the
development files, every filter judged by its worst file as well as its mean (issue 57).

Records (:func:`stress_records`), each a :class:`~imutherm.studies.attitude.real_benchmark.RealRecord` scored exactly as
the real-motion benchmark scores its files (inclination RMS, :func:`~imutherm.studies.attitude.real_benchmark.score`):

* **simulated** (:func:`tumble_log`): pure rotation about the sensor (no linear acceleration) at 5-20 °/s
  through upside down (|roll| > 90°), vertical (|pitch| > 70°) and back to level, rests of 1-10 min between the
  turns, a sensor grade of :mod:`imutherm.imu.grades` (white noise at its density, a constant bias drawn at its
  ``initial_bias``, a bias random walk at its ``rate_random_walk``; temperature effects left out), at 100-1000 Hz;
* **from the development files** (:func:`transformed_log`): a BROAD trial with its body frame turned (a rotated
  mounting: upside down, on its side; the reference quaternion turned with it), time-reversed (the gyro
  negated, the reference read backwards; the rest window moved to the start), concatenated with itself (a
  record of several minutes) and resampled to another rate.

The simulated truth is known exactly; the transformed BROAD records keep the data set's optical reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from imutherm import InputError
from imutherm.imu.reference_log import ReferenceLog

#: standard gravity [m/s^2] of the simulated records (the filters take |f| at rest from the record itself)
G_SIM = 9.80665


@dataclass(frozen=True)
class SimNoise:
    """The errors a simulated record carries, SI: gyro / accel white-noise density [rad/s/sqrt(Hz)],
    [m/s^2/sqrt(Hz)], constant bias 1-sigma [rad/s], [m/s^2], gyro bias random walk [rad/s/sqrt(s)]; source."""

    gyro_density: float
    accel_density: float
    gyro_bias: float
    accel_bias: float
    gyro_rw: float
    source: str


def grade_noise(grade: str) -> SimNoise:
    """:class:`SimNoise` of a grade of :mod:`imutherm.imu.grades` (its noise densities, initial biases and rate
    random walk; the temperature curves and misalignments are not simulated here)."""
    from imutherm.imu.sensor_model import load_grade

    g = load_grade(grade)
    return SimNoise(g.gyro.noise_density, g.accel.noise_density, g.gyro.initial_bias, g.accel.initial_bias,
                    g.gyro.rate_random_walk, f"imu/grades.py {grade}")


def _qmul(a, b):
    w0, x0, y0, z0 = a
    w1, x1, y1, z1 = b
    return np.array([w0 * w1 - x0 * x1 - y0 * y1 - z0 * z1, w0 * x1 + x0 * w1 + y0 * z1 - z0 * y1,
                     w0 * y1 - x0 * z1 + y0 * w1 + z0 * x1, w0 * z1 + x0 * y1 - y0 * x1 + z0 * w1])


def _qexp(v):
    """Quaternion (4,) of the rotation vector v (3,) [rad]."""
    th = float(np.linalg.norm(v))
    if th < 1e-15:
        return np.array([1.0, 0.5 * v[0], 0.5 * v[1], 0.5 * v[2]])
    s = math.sin(0.5 * th) / th
    return np.array([math.cos(0.5 * th), s * v[0], s * v[1], s * v[2]])


def quat_rotate_inv(q, v):
    """C(q)ᵀ v for quaternions q (N,4) (body -> world, w x y z) and a world vector v (3,): v in body axes (N,3)."""
    w, x, y, z = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    C = np.empty((len(q), 3, 3))
    C[:, 0, 0], C[:, 0, 1], C[:, 0, 2] = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
    C[:, 1, 0], C[:, 1, 1], C[:, 1, 2] = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
    C[:, 2, 0], C[:, 2, 1], C[:, 2, 2] = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
    return np.einsum("nji,j->ni", C, np.asarray(v, float))


#: the tumble plan: (duration [s], body rate [deg/s] (3,)) per segment; rests have rate 0. Slow turns through
#: upside down (roll 180°), on the side and vertical (pitch ±90°), combined axes, each followed by a rest, and
#: back to level; ``rest_s`` scales the rests between the turns.
def tumble_plan(rate_dps: float = 10.0, rest_s: float = 60.0) -> list:
    """Segments (duration [s], body rate (3,) [deg/s]) of :func:`tumble_log` (first: the 10 s rest window)."""
    if not (rate_dps > 0 and math.isfinite(rate_dps) and rest_s >= 0 and math.isfinite(rest_s)):
        raise InputError(f"tumble: rate_dps={rate_dps!r}, rest_s={rest_s!r} are invalid; valid: a rate > 0 "
                         "[deg/s] and a rest >= 0 [s]")
    turn = 90.0 / rate_dps  # [s] per quarter turn

    def rot(axis, quarters):
        r = np.zeros(3)
        r[axis] = math.copysign(rate_dps, quarters)
        return (abs(quarters) * turn, r)

    rest = (rest_s, np.zeros(3))
    short = (min(rest_s, 5.0), np.zeros(3))
    plan = [(10.0, np.zeros(3)),
            rot(0, 2), rest, rot(0, 2), short,                 # roll through upside down, rest there, back level
            rot(1, 1), rest, rot(1, -1), short,                # pitch to vertical, rest, back
            rot(1, -1), short, rot(1, 1), short,               # the other vertical
            rot(0, -1), rest, rot(0, 1), short,                # on the side
            (2 * turn, np.array([rate_dps, rate_dps, 0.0]) / math.sqrt(2.0)), rest,   # combined axes, upside down
            (2 * turn, -np.array([rate_dps, rate_dps, 0.0]) / math.sqrt(2.0)), short,
            rot(2, 4), rot(0, 4), rot(1, 4), rest]             # full turns about each axis, then a final rest
    return plan


def random_tour_plan(seed: int, *, duration_s: float = 300.0, rate_dps=(20.0, 90.0), angle_deg=(60.0, 270.0),
                     pause_s=(0.0, 3.0)) -> list:
    """Segments (duration [s], body rate (3,) [deg/s]) of a hand-held tour: after a 10 s rest, turns about axes drawn
    uniformly on the sphere (body axes), each through an angle drawn in ``angle_deg`` at a rate drawn in
    ``rate_dps``, each followed by a pause drawn in ``pause_s`` (0: none), until ``duration_s`` [s]."""
    if not (duration_s > 10 and 0 < rate_dps[0] <= rate_dps[1] and 0 < angle_deg[0] <= angle_deg[1]
            and 0 <= pause_s[0] <= pause_s[1]):
        raise InputError(f"tour: duration_s={duration_s!r}, rate_dps={rate_dps!r}, angle_deg={angle_deg!r}, "
                         f"pause_s={pause_s!r} are invalid; valid: > 10 s and ordered positive ranges")
    rng = np.random.default_rng(seed)
    plan, t = [(10.0, np.zeros(3))], 10.0
    while t < duration_s:
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        rate, ang, pause = rng.uniform(*rate_dps), rng.uniform(*angle_deg), rng.uniform(*pause_s)
        plan.append((ang / rate, rate * axis))
        plan.append((pause, np.zeros(3)))
        t += ang / rate + pause
    return plan


def tumble_log(*, rate_hz: float = 100.0, rate_dps: float = 10.0, rest_s: float = 60.0, grade: str = "adis16355",
               seed: int = 0, plan=None, name: str | None = None, gyro_sf: float = 0.0,
               bias_step_dps: float = 0.0, accel_bias_x: float = 1.0) -> ReferenceLog:
    """A simulated record of :func:`tumble_plan` (or ``plan``) as a BROAD-like :class:`ReferenceLog`: gyro (N,3)
    [rad/s], accel (N,3) [m/s^2] specific force of pure rotation (no linear acceleration), the true quaternion
    (body -> ENU), ``movement`` every row after the first segment; the sensor errors of ``grade``
    (:func:`grade_noise`), drawn with ``seed``. Gyro samples are the mean rate over the step ending at them
    (interval samples, as the benchmark reads logs). gyro_sf [-]: 1-sigma scale-factor and misalignment error of
    each gyro matrix element (0: none); bias_step_dps [deg/s]: a gyro-bias step of this size on every axis at the
    record's middle (a temperature or turn-on change the rest window did not see); accel_bias_x: the grade's
    accelerometer bias 1-sigma times this (a part worse than the grade, or a calibration off)."""
    if not (math.isfinite(rate_hz) and 10.0 <= rate_hz <= 10000.0):
        raise InputError(f"tumble: rate_hz={rate_hz!r} is invalid; valid: 10-10000 [Hz]")
    plan = tumble_plan(rate_dps, rest_s) if plan is None else plan
    nz = grade_noise(grade)
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    rates = np.concatenate([np.tile(np.radians(np.asarray(r, float)), (max(1, int(round(d / dt))), 1))
                            for d, r in plan])
    n = len(rates)
    q = np.empty((n, 4))
    qk = np.array([1.0, 0.0, 0.0, 0.0])
    for k in range(n):
        if k:
            qk = _qmul(qk, _qexp(rates[k] * dt))
            qk /= np.linalg.norm(qk)
        q[k] = qk
    f = quat_rotate_inv(q, [0.0, 0.0, G_SIM])
    bg = rng.normal(0.0, nz.gyro_bias, 3) + np.cumsum(rng.normal(0.0, nz.gyro_rw * math.sqrt(dt), (n, 3)), axis=0)
    gyro = rates @ (np.eye(3) + rng.normal(0.0, gyro_sf, (3, 3))).T if gyro_sf > 0 else rates
    bg[n // 2:] += math.radians(bias_step_dps)
    gyro = gyro + bg + rng.normal(0.0, nz.gyro_density * math.sqrt(rate_hz), (n, 3))
    accel = (f + rng.normal(0.0, nz.accel_bias * accel_bias_x, 3)
             + rng.normal(0.0, nz.accel_density * math.sqrt(rate_hz), (n, 3)))
    movement = np.ones(n, bool)
    movement[:int(round(plan[0][0] / dt))] = False
    label = name or f"sim_{grade}_{rate_hz:g}Hz_{rate_dps:g}dps_rest{rest_s:g}s"
    return ReferenceLog(label, np.arange(n) * dt, q, accel, gyro, "broad", movement, True)


def _quat_of_dcm(R) -> np.ndarray:
    """Unit quaternion (4,) (w x y z) of a rotation matrix R (3,3)."""
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(np.asarray(R, float)).as_quat()
    return np.array([w, x, y, z])


#: rotated mountings of the stress set: body axes of the new mounting from the old (upside down: a half turn
#: about x; on its side: a quarter turn about x; nose up: a quarter turn about y)
MOUNTS = {"upside_down": np.diag([1.0, -1.0, -1.0]),
          "on_side": np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]]),
          "nose_up": np.array([[0.0, 0.0, -1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])}


def transformed_log(log: ReferenceLog, *, mount=None, palindrome: int = 0, rate_hz: float | None = None,
                    name: str | None = None) -> ReferenceLog:
    """A development record transformed: ``mount`` (3,3) a rotation from the IMU axes to a new mounting's
    (gyro and accelerometer turned, the reference quaternion with them: C' = C Mᵀ); ``palindrome`` n > 0: the
    record followed by itself time-reversed (gyro negated, rows backwards), that pair repeated n times (a record
    of 2n times the length that starts at the file's rest and keeps continuous motion); ``rate_hz``: the samples
    re-cut to this rate (each new gyro / accelerometer sample the mean over its step, from the integrals of the
    rows; the reference and ``movement`` the nearest row). Sample-and-hold repeats are kept by the first two."""
    t, q, f, w, mv = log.t, log.quat, log.accel, log.gyro, log.movement
    if mount is not None:
        Rm = np.asarray(mount, float)
        if Rm.shape != (3, 3) or not np.allclose(Rm @ Rm.T, np.eye(3), atol=1e-9) or np.linalg.det(Rm) < 0:
            raise InputError(f"stress: mount {Rm.tolist()} is invalid; valid: a 3x3 rotation matrix")
        f, w = f @ Rm.T, w @ Rm.T
        qc = _quat_of_dcm(Rm)
        q = _qmul(q.T, np.array([qc[0], -qc[1], -qc[2], -qc[3]])).T  # q ⊗ conj(q_M), row by row
    if palindrome:
        dt = float(np.median(np.diff(t)))
        fwd = (q, f, w, mv)
        rev = (q[-2::-1], f[-2::-1], -w[-2::-1], mv[-2::-1])
        parts = [fwd, rev] * int(palindrome)
        q, f, w, mv = (np.concatenate([p[i] for p in parts]) for i in range(4))
        t = np.arange(len(q)) * dt
    if rate_hz is not None:
        if not (math.isfinite(rate_hz) and rate_hz > 0):
            raise InputError(f"stress: rate_hz={rate_hz!r} is invalid; valid: a positive rate [Hz]")
        dt0 = float(np.median(np.diff(t)))
        tn = np.arange(t[0], t[-1], 1.0 / rate_hz)
        edges = np.concatenate([[t[0] - dt0], t])  # row k covers (t[k-1], t[k]] (interval samples)

        def recut(x):
            cum = np.concatenate([np.zeros((1, 3)), np.cumsum(x * dt0, axis=0)])
            c = np.column_stack([np.interp(tn, edges, cum[:, j]) for j in range(3)])
            out = np.empty_like(c)
            out[1:] = np.diff(c, axis=0) * rate_hz
            out[0] = x[0]
            return out

        idx = np.clip(np.searchsorted(t, tn), 0, len(t) - 1)
        f, w, q, mv, t = recut(f), recut(w), q[idx], mv[idx], tn - tn[0]
    return replace(log, path=name or log.path, t=t, quat=q, accel=f, gyro=w, movement=mv)


#: the filters the stress set scores: the own three and the peers VQF and imufusion
STRESS_FILTERS = ("kf", "aekf", "gated", "vqf", "fusion")
#: the reference filter of the x-VQF columns
REF = "vqf"

#: the simulated records: (label, tumble_log keywords)
SIM_CASES = (
    ("sim consumer 100 Hz 10 deg/s, 1 min rests", dict(grade="adis16355", rate_hz=100.0, rate_dps=10.0, rest_s=60.0)),
    ("sim consumer 100 Hz 5 deg/s, 2 min rests (21 min)", dict(grade="adis16355", rate_hz=100.0, rate_dps=5.0,
                                                                rest_s=120.0, seed=1)),
    ("sim consumer 1000 Hz 20 deg/s, 1 min rests", dict(grade="adis16355", rate_hz=1000.0, rate_dps=20.0,
                                                         rest_s=60.0, seed=2)),
    ("sim industrial 100 Hz 15 deg/s, 5 min rests (33 min)", dict(grade="adis16488", rate_hz=100.0, rate_dps=15.0,
                                                                   rest_s=300.0, seed=3)),
    ("sim consumer 1 % scale factor, 0.5 deg/s bias step", dict(grade="adis16355", rate_hz=100.0, rate_dps=10.0,
                                                                 rest_s=30.0, seed=4, gyro_sf=0.01,
                                                                 bias_step_dps=0.5)),
    ("sim industrial, 10x its accelerometer bias (20 mg)", dict(grade="adis16488", rate_hz=200.0, rate_dps=10.0,
                                                                 rest_s=30.0, seed=5, accel_bias_x=10.0)),
    ("sim bmi160 (phone-grade part, 25 mg, 3 deg/s bias) 200 Hz", dict(grade="bmi160", rate_hz=200.0,
                                                                        rate_dps=10.0, rest_s=60.0, seed=7)),
    ("sim icm42688p 500 Hz 20 deg/s", dict(grade="icm42688p", rate_hz=500.0, rate_dps=20.0, rest_s=60.0, seed=8)),
    ("sim consumer 100 Hz 10 deg/s, 10 min rests (63 min)", dict(grade="adis16355", rate_hz=100.0, rate_dps=10.0,
                                                                  rest_s=600.0, seed=6)),
    # issue 57, gated's held-out failure: turns above the rate gate's 25.6 °/s (handheld L = 0.5 m) without rests;
    # the rate gate tested |ω| and shut gated's correction through every roll-over (3.6° against VQF's 1.8°)
    ("sim icm42688p 200 Hz 30 deg/s, no rests, 1 % scale factor", dict(grade="icm42688p", rate_hz=200.0,
                                                                        rate_dps=30.0, rest_s=0.0, seed=13,
                                                                        gyro_sf=0.01)),
)

#: a record family kept out of issue 57's development (defined before any was run, first run by the final benchmark):
#: hand-held tours about random axes (:func:`random_tour_plan`) at 20-90 °/s with pauses of 0-3 s, 5 min, gyro scale
#: factor and misalignment 0.5 % per matrix element (1σ), three grades and rates
HELDOUT_CASES = (
    ("held-out tour bmi160 200 Hz", dict(grade="bmi160", rate_hz=200.0, seed=21, gyro_sf=0.005), 21),
    ("held-out tour icm42688p 400 Hz", dict(grade="icm42688p", rate_hz=400.0, seed=22, gyro_sf=0.005), 22),
    ("held-out tour adis16488 100 Hz", dict(grade="adis16488", rate_hz=100.0, seed=23, gyro_sf=0.005), 23),
)

#: the transformed development records: (label, BROAD file stem, transformed_log keywords, level)
DEV_CASES = (
    ("B07 mounted upside down", "07_undisturbed_fast_rotation_B", dict(mount=MOUNTS["upside_down"]), False),
    ("B16 mounted on its side", "16_undisturbed_fast_translation_B", dict(mount=MOUNTS["on_side"]), False),
    ("B27 mounted nose up", "27_disturbed_phone_vibration_B", dict(mount=MOUNTS["nose_up"]), False),
    ("B07 forward-reverse x2 (12 min)", "07_undisturbed_fast_rotation_B", dict(palindrome=2), True),
    ("B16 forward-reverse x2 (12 min)", "16_undisturbed_fast_translation_B", dict(palindrome=2), True),
    ("B16 at 100 Hz", "16_undisturbed_fast_translation_B", dict(rate_hz=100.0), True),
    ("B27 at 1000 Hz", "27_disturbed_phone_vibration_B", dict(rate_hz=1000.0), True),
)


def stress_records(broad_dir=None, *, quick: bool = False, heldout: bool = False):
    """The stress set: [(label, RealRecord)] of :data:`SIM_CASES` and, where ``broad_dir`` (None: the shared
    ``broad-dev`` folder) holds the files, :data:`DEV_CASES`; heldout: :data:`HELDOUT_CASES` too (after them).
    quick: the first simulated and the first two transformed records only."""
    from pathlib import Path

    from imutherm.imu.reference_log import read_broad_hdf5
    from imutherm.studies.attitude.real_benchmark import DATA_DIRS, prepare_log

    out = []
    for label, kw in SIM_CASES[:1] if quick else SIM_CASES:
        out.append((label, prepare_log(tumble_log(**kw), init_s=8.0, name=label)))
    d = Path(broad_dir) if broad_dir is not None else DATA_DIRS["broad"]
    for label, stem, kw, level in DEV_CASES[:2] if quick else DEV_CASES:
        f = d / f"{stem}.hdf5"
        if f.is_file():
            out.append((label, prepare_log(transformed_log(read_broad_hdf5(f), **kw), init_s=8.0, name=label,
                                           level=level)))
    for label, kw, plan_seed in HELDOUT_CASES if heldout and not quick else ():
        out.append((label, prepare_log(tumble_log(plan=random_tour_plan(plan_seed), name=label, **kw), init_s=8.0,
                                       name=label)))
    return out


@dataclass(frozen=True)
class StressTable:
    """Inclination RMS [deg] per record and filter (rms {filter: [per record]}), the records' labels, each filter's
    mean x VQF (mean of its RMS over the mean of VQF's) and worst file x VQF (max over records of its RMS / VQF's on
    that record), the aekf's reported resets per record, and the in-motion divergence check's flagged windows per
    record and filter (motion {filter: [(flagged, windows)]}, :mod:`~imutherm.imu.filters.motion_check`)."""

    labels: tuple
    rms: dict
    mean_x_ref: dict
    worst_x_ref: dict
    worst_file: dict
    resets: dict
    motion: dict


def stress_table(records, names=STRESS_FILTERS) -> StressTable:
    """Run ``names`` (with VQF) at the handheld settings of ``imutherm attitude --imu-csv`` on ``records``
    [(label, RealRecord)] and tabulate (:class:`StressTable`)."""
    from imutherm.imu.filters.run import GateConfig, run_filters
    from imutherm.studies.attitude.real_benchmark import score
    from imutherm.studies.attitude.recorded import PLATFORMS, platform_settings
    from imutherm.imu.filters import FusionParams

    from imutherm.imu.filters.motion_check import motion_disagreement

    names = tuple(dict.fromkeys(tuple(names) + (REF,)))
    rms = {n: [] for n in names}
    resets = {n: [] for n in names}
    motion = {n: [] for n in names}
    d, L = PLATFORMS["handheld"]
    for _, rec in records:
        est, _ = run_filters(rec.gyro, rec.accel, rec.dt, d, GateConfig(L=L, init_s=rec.init_s),
                             design={"fusion": FusionParams()}, names=names,
                             settings=platform_settings("handheld", names), gyro_sample="interval")
        for n in names:
            rms[n].append(score(rec, est[n].gravity)["rms_deg"])
            r = est[n].resets
            resets[n].append(None if r is None else int(len(r)))
            mc = motion_disagreement(rec.gyro, rec.accel, rec.dt, est[n].gravity, init_s=rec.init_s)
            motion[n].append((len(mc.flagged), int(mc.tilt_deg.size)))
    ref = np.array(rms[REF])
    mean_x = {n: float(np.mean(rms[n]) / np.mean(ref)) for n in names}
    ratio = {n: np.array(rms[n]) / ref for n in names}
    worst = {n: float(np.max(ratio[n])) for n in names}
    labels = tuple(lab for lab, _ in records)
    worst_file = {n: labels[int(np.argmax(ratio[n]))] for n in names}
    return StressTable(labels, rms, mean_x, worst, worst_file, resets, motion)


def format_stress_table(t: StressTable) -> str:
    """Markdown: one row per record (inclination RMS [deg] per filter), then mean x VQF and worst file x VQF."""
    names = list(t.rms)
    lines = ["| record | " + " | ".join(names) + " |", "|---" * (len(names) + 1) + "|"]
    for i, lab in enumerate(t.labels):
        cells = []
        for n in names:
            c = f"{t.rms[n][i]:.2f}"
            if t.resets[n][i]:
                c += f" ({t.resets[n][i]} resets)"
            if t.motion[n][i][0]:
                c += f" [{t.motion[n][i][0]}/{t.motion[n][i][1]} flagged]"
            cells.append(c)
        lines.append(f"| {lab} | " + " | ".join(cells) + " |")
    lines.append("| **mean x VQF** | " + " | ".join(f"{t.mean_x_ref[n]:.2f}" for n in names) + " |")
    lines.append("| **worst file x VQF** | " + " | ".join(f"{t.worst_x_ref[n]:.2f}" for n in names) + " |")
    lines.append("| **motion check: records flagged** | " + " | ".join(
        f"{sum(1 for f, _ in t.motion[n] if f)} of {len(t.labels)}" for n in names) + " |")
    return "\n".join(lines)
