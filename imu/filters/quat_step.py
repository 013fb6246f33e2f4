"""The quaternion correct-and-step the gated filters and the KF's strapdown frame share, as plain-float
functions and their numba kernels inlined into the batch loops (``inline="always"``: no call overhead, the
same arithmetic in the same order as the copies it replaces).

:func:`gravity_error` is the correction's error vector, e = m × r, between the measured down direction
``m`` (unit, body axes) and the estimate's ``r = C(q)ᵀ [0, 0, 1]`` (:func:`down_axis`); :func:`pi_correction`
the rate and bias corrected by it (the gated filters' proportional-integral law); :func:`quat_step` the step
``q ⊗ exp(h)`` with ``h = ω dt / 2`` [rad], renormalised (sin(|h|)/|h| by its Taylor terms below
|h|² = 1e-24); :func:`rotate` the KF's propagation of the down direction itself by a rotation vector
(Rodrigues, the same Taylor switch).

numba's cache is keyed on the calling kernel's own file: after an edit here, touch ``gated.py`` and
``gravity_kf.py`` (or clear their ``__pycache__``) so that their cached kernels are compiled again.
"""

from __future__ import annotations

import math

from imutherm.lazy_jit import njit


def gravity_error(w, x, y, z, mx, my, mz):
    """(ex, ey, ez) = m × r [-] of the unit quaternion (w, x, y, z) body→nav and the unit down direction
    (mx, my, mz) measured in body axes."""
    rx = 2 * (x * z - w * y)
    ry = 2 * (y * z + w * x)
    rz = 1 - 2 * (x * x + y * y)
    return my * rz - mz * ry, mz * rx - mx * rz, mx * ry - my * rx


def quat_step(w, x, y, z, hx, hy, hz):
    """(w, x, y, z) ⊗ exp(h), renormalised; h = (hx, hy, hz) = ω dt / 2 [rad]."""
    n2 = hx * hx + hy * hy + hz * hz
    if n2 > 1e-24:
        nn = math.sqrt(n2)
        s = math.sin(nn) / nn
        c = math.cos(nn)
    else:
        s = 1.0 - n2 / 6.0
        c = 1.0 - n2 / 2.0
    dx, dy, dz = hx * s, hy * s, hz * s
    w, x, y, z = (w * c - x * dx - y * dy - z * dz, w * dx + x * c + y * dz - z * dy,
                  w * dy - x * dz + y * c + z * dx, w * dz + x * dy - y * dx + z * c)
    inv = 1.0 / math.sqrt(w * w + x * x + y * y + z * z)
    return w * inv, x * inv, y * inv, z * inv


def down_axis(w, x, y, z):
    """r = C(q)ᵀ [0, 0, 1] [-]: the navigation frame's down axis in body axes, of the unit quaternion (w, x, y, z)
    body→nav."""
    return 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)


def pi_correction(wx, wy, wz, bx, by, bz, ex, ey, ez, kp, ki, dt):
    """(ω + kp e, b - ki e dt): the rate [rad/s] and gyro bias [rad/s] corrected by the error e [-] with the gains
    kp [1/s], ki [1/s²] over the step dt [s]."""
    return wx + kp * ex, wy + kp * ey, wz + kp * ez, bx - ki * ex * dt, by - ki * ey * dt, bz - ki * ez * dt


def rotate(rx, ry, rz, ax, ay, az):
    """r rotated by the rotation vector a [rad] (Rodrigues: r cos|a| + sin|a|/|a| a × r + (1 - cos|a|)/|a|² (a·r) a;
    Taylor terms below |a|² = 1e-24)."""
    th2 = ax * ax + ay * ay + az * az
    if th2 > 1e-24:
        th = math.sqrt(th2)
        s = math.sin(th) / th
        c1 = (1.0 - math.cos(th)) / th2
    else:
        s = 1.0 - th2 / 6.0
        c1 = 0.5 - th2 / 24.0
    cx, cy, cz = ay * rz - az * ry, az * rx - ax * rz, ax * ry - ay * rx
    dot = ax * rx + ay * ry + az * rz
    c = 1.0 - c1 * th2
    return rx * c + s * cx + c1 * dot * ax, ry * c + s * cy + c1 * dot * ay, rz * c + s * cz + c1 * dot * az


#: the kernels the batch loops call (inlined into them by numba)
gravity_error_jit = njit(inline="always")(gravity_error)
quat_step_jit = njit(inline="always")(quat_step)
down_axis_jit = njit(inline="always")(down_axis)
pi_correction_jit = njit(inline="always")(pi_correction)
rotate_jit = njit(inline="always")(rotate)
