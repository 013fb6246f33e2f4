"""Attitude conventions and small vectorised rotation helpers.

Conventions used by :mod:`imutherm.imu.motion` and :mod:`imutherm.imu.filters`
----------------------------------------------------------------------------
- Navigation frame **NED** (x north, y east, z down); gravity ``g_n = [0, 0, +G0]``.
- Body frame **FRD** (x forward, y right, z down).
- Attitude quaternion ``q = [w, x, y, z]`` rotates body vectors into the
  navigation frame: ``v_n = q ⊗ v_b ⊗ q*`` (scalar first).
- Euler angles ZYX (yaw ψ, pitch θ, roll φ), all [rad] inside the package.
- The accelerometer measures specific force ``f_b = C_bn (a_n - g_n)``; at rest
  and level it reads ``[0, 0, -G0]`` [m/s^2].
- The gravity direction in body axes is ``r = C_bn [0, 0, 1]`` (third row of
  ``C_nb``); at rest ``r = -f_b / |f_b|``. Roll and pitch follow from ``r``:
  ``φ = atan2(r_y, r_z)``, ``θ = atan2(-r_x, hypot(r_y, r_z))``.
"""

from __future__ import annotations

import numpy as np

from imutherm.constants import STANDARD_GRAVITY as G0  # [m/s^2]


def euler_to_quat(roll, pitch, yaw) -> np.ndarray:
    """Quaternion(s) body→nav from ZYX Euler angles.

    roll, pitch, yaw : array_like [rad]
    Returns (..., 4) [-] scalar-first unit quaternions.
    """
    roll, pitch, yaw = np.broadcast_arrays(*(np.asarray(a, float) for a in (roll, pitch, yaw)))
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.stack(
        [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ],
        axis=-1,
    )


def quat_to_euler(q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ZYX Euler angles (roll, pitch, yaw) [rad] of body→nav quaternion(s) ``q`` (..., 4)."""
    q = np.asarray(q, float)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def quat_to_dcm(q) -> np.ndarray:
    """Direction cosine matrix C_nb (..., 3, 3) [-] (body→nav) of quaternion(s) ``q``."""
    q = np.asarray(q, float)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
            np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
            np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
        ],
        -2,
    )


def gravity_dir_body(q) -> np.ndarray:
    """Gravity direction r = C_bn [0,0,1] (..., 3) [-] of body→nav quaternion(s) ``q``."""
    q = np.asarray(q, float)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)


def roll_pitch_from_gravity(r) -> tuple[np.ndarray, np.ndarray]:
    """(roll, pitch) [rad] from gravity direction(s) in body axes ``r`` (..., 3) (any length)."""
    r = np.asarray(r, float)
    roll = np.arctan2(r[..., 1], r[..., 2])
    pitch = np.arctan2(-r[..., 0], np.hypot(r[..., 1], r[..., 2]))
    return roll, pitch


def roll_pitch_from_accel(f) -> tuple[np.ndarray, np.ndarray]:
    """Accelerometer (leveling) roll and pitch [rad] from specific force ``f`` (..., 3) [m/s^2]."""
    return roll_pitch_from_gravity(-np.asarray(f, float))


def wrap_angle(a) -> np.ndarray:
    """Wrap angle(s) [rad] into [-π, π)."""
    return (np.asarray(a, float) + np.pi) % (2 * np.pi) - np.pi
