"""Simulated GNSS velocity for aided attitude filters (Wang et al.: the IKF uses the receiver's velocity).

The receiver reports the NED velocity of the IMU (antenna at the IMU: no
antenna lever arm) at ``rate_hz`` with white noise of ``vel_std`` [m/s] per
axis. Defaults are assumed values of a low-cost receiver, not taken from
Wang et al. (it gives none): 5 Hz output and 0.05 m/s (1 sigma) Doppler velocity
accuracy, the order a u-blox M8-class datasheet states (recalled, not
verified).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from imutherm import InputError
from imutherm.imu.attitude_math import quat_to_dcm


@dataclass(frozen=True)
class GnssConfig:
    """GNSS velocity settings: rate_hz [Hz] output rate, vel_std [m/s] white noise per axis (1 sigma)."""

    rate_hz: float = 5.0
    vel_std: float = 0.05

    def __post_init__(self):
        for name in ("rate_hz", "vel_std"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"GNSS: {name}={v!r} is invalid; valid: a positive number")


@dataclass(frozen=True)
class GnssVelocity:
    """GNSS velocity fixes: idx (M,) sample index of each fix, vel_n (M,3) [m/s] NED, std [m/s] stated noise."""

    idx: np.ndarray
    vel_n: np.ndarray
    std: float


def sensor_velocity(traj) -> np.ndarray:
    """NED velocity of the sensor (N,3) [m/s]: rotation-centre velocity + C_nb (ω × d)."""
    c_nb = quat_to_dcm(traj.quat)
    lever = np.cross(traj.omega_b, np.asarray(traj.lever_arm, float))
    return np.asarray(traj.vel_n, float) + np.einsum("nij,nj->ni", c_nb, lever)


def simulate_gnss(traj, rng: np.random.Generator, config: GnssConfig = GnssConfig()) -> GnssVelocity:
    """GNSS velocity fixes of trajectory ``traj`` (:class:`imutherm.imu.motion.Trajectory`).

    Fixes every ``round(rate / rate_hz)`` samples from the first sample; noise from ``rng``.
    """
    if not isinstance(rng, np.random.Generator):
        raise InputError("simulate_gnss: rng must be a numpy.random.Generator")
    step = max(1, int(round(traj.rate_hz / config.rate_hz)))
    idx = np.arange(0, traj.t.size, step)
    v = sensor_velocity(traj)[idx] + rng.standard_normal((idx.size, 3)) * config.vel_std
    return GnssVelocity(idx=idx, vel_n=v, std=config.vel_std)
