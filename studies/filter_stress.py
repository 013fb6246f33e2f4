"""A stress set for the attitude filters: records that leave moderate attitudes, from simulation and the
development files, every filter judged by its worst file as well as its mean (issue 57).

Records (:func:`stress_records`), each a :class:`~imutherm.studies.real_benchmark.RealRecord` scored exactly as
the real-motion benchmark scores its files (inclination RMS, :func:`~imutherm.studies.real_benchmark.score`):

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


def tumble_log(*, rate_hz: float = 100.0, rate_dps: float = 10.0, rest_s: float = 60.0, grade: str = "adis16355",
               seed: int = 0, plan=None, name: str | None = None) -> ReferenceLog:
    """A simulated record of :func:`tumble_plan` (or ``plan``) as a BROAD-like :class:`ReferenceLog`: gyro (N,3)
    [rad/s], accel (N,3) [m/s^2] specific force of pure rotation (no linear acceleration), the true quaternion
    (body -> ENU), ``movement`` every row after the first segment; the sensor errors of ``grade``
    (:func:`grade_noise`), drawn with ``seed``. Gyro samples are the mean rate over the step ending at them
    (interval samples, as the benchmark reads logs)."""
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
    gyro = rates + bg + rng.normal(0.0, nz.gyro_density * math.sqrt(rate_hz), (n, 3))
    accel = f + rng.normal(0.0, nz.accel_bias, 3) + rng.normal(0.0, nz.accel_density * math.sqrt(rate_hz), (n, 3))
    movement = np.ones(n, bool)
    movement[:int(round(plan[0][0] / dt))] = False
    label = name or f"sim_{grade}_{rate_hz:g}Hz_{rate_dps:g}dps_rest{rest_s:g}s"
    return ReferenceLog(label, np.arange(n) * dt, q, accel, gyro, "broad", movement, True)
