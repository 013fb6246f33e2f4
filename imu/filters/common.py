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
    resets : (K,) int | None    sample index of each reset the filter made after its innovations said it had
                                diverged (aekf's NIS monitor and re-level); None: the filter has no such monitor
    """

    name: str
    roll: np.ndarray
    pitch: np.ndarray
    gravity: np.ndarray
    accel_used: np.ndarray
    runtime_s: float
    yaw: np.ndarray | None = None
    resets: np.ndarray | None = None


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


def sample_steps(steps, n: int, dt: float) -> np.ndarray:
    """The time step ending at each sample, (n,) [s]: ``steps`` (a record's true, irregular steps, step k from
    sample k-1 to k; checked (n,), finite and > 0) or, None, the uniform ``dt`` [s].

    The filters that take it integrate each sample over its own step; what is designed at one rate (gate
    low-passes, the inertial low-pass's coefficients, windows and timers counted in samples) keeps ``dt``, the
    median step: a step within ±50 % of it (:data:`imutherm.imu.log_samples.MAX_STEP_SPREAD`; beyond, a log is
    resampled) moves a first-order low-pass's weight of one sample by at most that factor."""
    if steps is None:
        return np.full(n, float(dt))
    s = np.asarray(steps, float)
    if s.shape != (n,) or not (np.all(np.isfinite(s)) and np.all(s > 0)):
        raise InputError(f"attitude filter: steps {s.shape} are invalid; valid: ({n},) finite time steps > 0 [s]")
    return np.ascontiguousarray(s)


#: what a gyro sample is (the ``gyro_sample`` field of gated, kf and aekf): 'point', the rate at the sample's
#: instant (the simulated sensor: the step from sample k-1 to k integrates the trapezoid (ω_{k-1} + ω_k)/2), or
#: 'interval', the mean rate over the step ending at it (the step integrates ω_k: what a MEMS gyro's decimation
#: filter outputs, and the convention of VQF, Madgwick, Mahony and Fusion; on BROAD's fast rotations, up to
#: 1400 °/s at 286 Hz, the trapezoid's half-sample lag alone cost the kf 0.6° RMS)
GYRO_SAMPLES = ("point", "interval")


def check_gyro_sample(where: str, value) -> None:
    """InputError unless ``value`` is one of :data:`GYRO_SAMPLES`."""
    if value not in GYRO_SAMPLES:
        raise InputError(f"{where}: gyro_sample={value!r} is invalid; valid: {', '.join(GYRO_SAMPLES)}")


def step_rates(gyro, gyro_sample: str = "point") -> np.ndarray:
    """The rate (N,3) [rad/s] integrated over the step ending at each sample: the trapezoid of the two samples
    around it ('point'; the first sample: itself) or the sample itself ('interval'), :data:`GYRO_SAMPLES`."""
    gyro = np.asarray(gyro, float)
    if gyro_sample == "interval":
        return gyro.copy()
    wbar = np.empty_like(gyro)
    wbar[0] = gyro[0]
    wbar[1:] = 0.5 * (gyro[:-1] + gyro[1:])
    return wbar


def initial_quat(accel, dt: float, init_s: float) -> np.ndarray:
    """Leveling: quaternion (4,) [-] from the mean specific force of the first ``init_s`` [s], yaw 0."""
    n0 = max(1, int(round(init_s / dt)))
    roll, pitch = roll_pitch_from_accel(np.mean(np.asarray(accel, float)[:n0], axis=0))
    return euler_to_quat(roll, pitch, 0.0)


def initial_bias(gyro, dt: float, init_s: float) -> np.ndarray:
    """Power-on gyro bias (3,) [rad/s]: mean rate over the first ``init_s`` [s] (the unit is at rest)."""
    n0 = max(1, int(round(init_s / dt)))
    return np.mean(np.asarray(gyro, float)[:n0], axis=0)


#: samples of the causal cubic fit that differentiates the gyro for the lever-arm term: 41 at 100 Hz (0.4 s)
#: reproduces the swing profile's lever-arm term within 7 mm/s^2 (8.7 rad/s^2 peak, d = 5.8 cm) with a white-noise
#: gain of 12.5 rad/s^2 per rad/s. Measured (aekf, swing / vehicle, seeds 0-2): a 9-sample quadratic (2 mm/s^2,
#: gain 47) gives the same swing error and doubles the vehicle's (0.58 m lever arm: its noise reaches the gate);
#: 41 samples cost the vehicle 0.0-0.2 deg roll RMS against no correction.
LEVER_FIT_SAMPLES = 41


def lever_arm_accel(gyro, dt: float, lever_arm, bias=None, n_fit: int = LEVER_FIT_SAMPLES) -> np.ndarray:
    """Specific force of the lever arm (N,3) [m/s^2]: ``ω̇ × d + ω × (ω × d)`` in body axes.

    gyro (N,3) [rad/s]; lever_arm d (3,) [m] of the sensor from the rotation centre; bias (3,) [rad/s] removed
    from the gyro first (None: zero). ``ω̇`` is the slope at the newest sample of a least-squares cubic
    through the last ``n_fit`` samples (Savitzky-Golay end-point derivative: causal, no delay), zero for the
    first ``n_fit - 1`` samples. Subtracting it from the accelerometer gives the specific force at the rotation
    centre (the standard lever-arm correction, e.g. Groves, *Principles of GNSS, Inertial, and Multisensor
    Integrated Navigation Systems*, 2nd ed., §2.5.5).
    """
    from scipy.signal import savgol_coeffs

    w = np.asarray(gyro, float) - (0.0 if bias is None else np.asarray(bias, float))
    d = np.asarray(lever_arm, float)
    if d.shape != (3,) or not np.all(np.isfinite(d)):
        raise InputError(f"lever_arm_accel: lever_arm={lever_arm!r} is invalid; valid: three finite lengths [m]")
    wd = np.zeros_like(w)
    if len(w) >= n_fit:
        c = savgol_coeffs(n_fit, 3, deriv=1, delta=dt, pos=n_fit - 1, use="dot")  # c @ w[k-n_fit+1 .. k]
        for i in range(3):
            wd[n_fit - 1:, i] = np.convolve(w[:, i], c[::-1], mode="valid")
    return np.cross(wd, d) + np.cross(w, np.cross(w, d))
