"""Shared pieces of the attitude filters: the result object, input checks, initial leveling."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from imutherm import InputError
from imutherm.imu.attitude_math import euler_to_quat, roll_pitch_from_accel, roll_pitch_from_gravity


@dataclass(frozen=True)
class AttitudeEstimate:
    """Output of one attitude filter run.

    name : str                  filter name ('gated', 'kf', 'ungated', 'fusion')
    roll, pitch : (N,) [rad]    estimated roll and pitch after each sample
    gravity : (N, 3) [-]        estimated gravity direction in body axes (unit)
    accel_used : (N,) bool      True where the accelerometer corrected the estimate
    runtime_s : float [s]       wall time of the run
    yaw : (N,) [rad] | None     heading estimate where the filter has one (aekf, aekf_gnss)
    """

    name: str
    roll: np.ndarray
    pitch: np.ndarray
    gravity: np.ndarray
    accel_used: np.ndarray
    runtime_s: float
    yaw: np.ndarray | None = None


def estimate_from_gravity(name, r, used, runtime_s) -> AttitudeEstimate:
    """Build an :class:`AttitudeEstimate` from gravity directions ``r`` (N,3) [-]."""
    r = np.asarray(r, float)
    roll, pitch = roll_pitch_from_gravity(r)
    return AttitudeEstimate(name, roll, pitch, r, np.asarray(used, bool), float(runtime_s))


def check_samples(gyro, accel, dt):
    """Validate (gyro (N,3) [rad/s], accel (N,3) [m/s^2], dt [s]); return float arrays."""
    gyro = np.asarray(gyro, float)
    accel = np.asarray(accel, float)
    if gyro.ndim != 2 or gyro.shape[1] != 3 or accel.shape != gyro.shape or len(gyro) < 2:
        raise InputError(f"attitude filter: gyro {gyro.shape} and accel {accel.shape} are invalid; "
                         "valid: two (N, 3) arrays, N >= 2")
    if not (np.isfinite(dt) and dt > 0):
        raise InputError(f"attitude filter: dt={dt!r} is invalid; valid: a positive sample period [s]")
    if not (np.all(np.isfinite(gyro)) and np.all(np.isfinite(accel))):
        raise InputError("attitude filter: gyro/accel contain NaN or inf; valid: finite samples")
    return gyro, accel


def initial_quat(accel, dt: float, init_s: float) -> np.ndarray:
    """Leveling: quaternion (4,) [-] from the mean specific force of the first ``init_s`` [s], yaw 0."""
    n0 = max(1, int(round(init_s / dt)))
    roll, pitch = roll_pitch_from_accel(np.mean(np.asarray(accel, float)[:n0], axis=0))
    return euler_to_quat(roll, pitch, 0.0)


def initial_bias(gyro, dt: float, init_s: float) -> np.ndarray:
    """Power-on gyro bias (3,) [rad/s]: mean rate over the first ``init_s`` [s] (the unit is at rest)."""
    n0 = max(1, int(round(init_s / dt)))
    return np.mean(np.asarray(gyro, float)[:n0], axis=0)
