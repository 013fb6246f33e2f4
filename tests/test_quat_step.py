"""The shared quaternion correct-and-step (imu/filters/quat_step.py) equals, on a random sequence, the
arithmetic it replaced in the gated filters' and the KF's loops (kept here, written out, as the reference)."""

import math

import numpy as np

from imutherm.imu.filters.quat_step import (down_axis, gravity_error, gravity_error_jit, pi_correction, quat_step,
                                            quat_step_jit, rotate, rotate_jit)
from imutherm.lazy_jit import njit


def _old_correct_and_step(w, x, y, z, mx, my, mz, kp, hdt, wx, wy, wz):
    """The copy that was inlined in gated.py (_update, _loop_core, _lp_core) and gravity_kf.py (_kf_lp_core)."""
    rx = 2 * (x * z - w * y)
    ry = 2 * (y * z + w * x)
    rz = 1 - 2 * (x * x + y * y)
    ex = my * rz - mz * ry
    ey = mz * rx - mx * rz
    ez = mx * ry - my * rx
    wx += kp * ex
    wy += kp * ey
    wz += kp * ez
    hx, hy, hz = hdt * wx, hdt * wy, hdt * wz
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


def _new_correct_and_step(w, x, y, z, mx, my, mz, kp, hdt, wx, wy, wz, err, step):
    ex, ey, ez = err(w, x, y, z, mx, my, mz)
    wx, wy, wz = wx + kp * ex, wy + kp * ey, wz + kp * ez
    return step(w, x, y, z, hdt * wx, hdt * wy, hdt * wz)


@njit
def _old_loop(m, om, kp, hdt, q0):
    out = np.empty((m.shape[0], 4))
    w, x, y, z = q0[0], q0[1], q0[2], q0[3]
    for k in range(m.shape[0]):
        w, x, y, z = _old_kernel(w, x, y, z, m[k, 0], m[k, 1], m[k, 2], kp, hdt, om[k, 0], om[k, 1], om[k, 2])
        out[k] = w, x, y, z
    return out


@njit
def _new_loop(m, om, kp, hdt, q0):
    out = np.empty((m.shape[0], 4))
    w, x, y, z = q0[0], q0[1], q0[2], q0[3]
    for k in range(m.shape[0]):
        ex, ey, ez = gravity_error_jit(w, x, y, z, m[k, 0], m[k, 1], m[k, 2])
        wx, wy, wz = om[k, 0] + kp * ex, om[k, 1] + kp * ey, om[k, 2] + kp * ez
        w, x, y, z = quat_step_jit(w, x, y, z, hdt * wx, hdt * wy, hdt * wz)
        out[k] = w, x, y, z
    return out


_old_kernel = njit(_old_correct_and_step)


def _sequence(n=4000, seed=3):
    rng = np.random.default_rng(seed)
    m = rng.normal(size=(n, 3))
    m /= np.linalg.norm(m, axis=1, keepdims=True)
    om = rng.normal(scale=2.0, size=(n, 3))
    om[::7] *= 1e-14  # the Taylor branch of sin(|h|)/|h|
    return m, om


def test_the_shared_step_equals_the_old_inlined_arithmetic_on_a_random_sequence():
    m, om = _sequence()
    q0 = np.array([0.9, 0.1, -0.3, 0.2]) / np.linalg.norm([0.9, 0.1, -0.3, 0.2])
    # plain floats (gated_step's path)
    q_old, q_new = tuple(q0), tuple(q0)
    for k in range(300):
        q_old = _old_correct_and_step(*q_old, *m[k], 0.3, 0.005, *om[k])
        q_new = _new_correct_and_step(*q_new, *m[k], 0.3, 0.005, *om[k], gravity_error, quat_step)
        assert q_new == q_old, k
    # compiled, inlined into a loop (the batch loops' path)
    old = _old_loop(m, om, 0.3, 0.005, q0)
    new = _new_loop(m, om, 0.3, 0.005, q0)
    assert np.max(np.abs(new - old)) <= 1e-12
    assert np.allclose(np.linalg.norm(new, axis=1), 1.0, rtol=0, atol=1e-14)


def _old_rotate(rx, ry, rz, ax, ay, az):
    """The Rodrigues copy that was inlined in gravity_kf.py (_propagate, _kf_loop, _kf_lp_core)."""
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
    return (rx * c + s * cx + c1 * dot * ax, ry * c + s * cy + c1 * dot * ay, rz * c + s * cz + c1 * dot * az)


_old_rotate_jit = njit(_old_rotate)


@njit
def _rotate_loops(r0, a):
    old, new = np.empty_like(a), np.empty_like(a)
    ox, oy, oz = nx, ny, nz = r0[0], r0[1], r0[2]
    for k in range(a.shape[0]):
        ox, oy, oz = _old_rotate_jit(ox, oy, oz, a[k, 0], a[k, 1], a[k, 2])
        nx, ny, nz = rotate_jit(nx, ny, nz, a[k, 0], a[k, 1], a[k, 2])
        old[k] = ox, oy, oz
        new[k] = nx, ny, nz
    return old, new


def test_the_shared_rotation_is_rodrigues_and_the_old_arithmetic():
    """rotate(r, a) turns r by the rotation vector a (scipy's rotation, to rounding), with the arithmetic of the
    KF's three copies it replaced: equal to the bit in plain floats, and compiled into a loop."""
    from scipy.spatial.transform import Rotation

    _, a = _sequence(n=2000, seed=5)
    a *= 0.05                       # ~0.1 rad steps; every 7th in the Taylor branch
    r = np.array([0.2, -0.5, 0.84]) / np.linalg.norm([0.2, -0.5, 0.84])
    for k in range(300):
        assert rotate(*r, *a[k]) == _old_rotate(*r, *a[k]), k
        assert np.allclose(rotate(*r, *a[k]), Rotation.from_rotvec(a[k]).apply(r), rtol=0, atol=1e-15)
    old, new = _rotate_loops(r, a)
    assert np.array_equal(old, new)
    assert np.allclose(np.linalg.norm(new, axis=1), 1.0, rtol=0, atol=1e-12)


def test_the_down_axis_and_the_pi_correction():
    """down_axis(q) = C(q)ᵀ [0, 0, 1] (scipy's rotation body→nav, inverted); the PI law moves the rate by kp e and
    the bias by -ki e dt."""
    from scipy.spatial.transform import Rotation

    q = np.array([0.9, 0.1, -0.3, 0.2]) / np.linalg.norm([0.9, 0.1, -0.3, 0.2])
    expected = Rotation.from_quat(np.r_[q[1:], q[0]]).inv().apply([0.0, 0.0, 1.0])
    assert np.allclose(down_axis(*q), expected, rtol=0, atol=1e-15)
    out = pi_correction(1.0, 2.0, 3.0, 0.1, 0.2, 0.3, 0.5, -0.5, 0.25, 2.0, 0.4, 0.01)
    assert np.allclose(out, (2.0, 1.0, 3.5, 0.098, 0.202, 0.299), rtol=0, atol=1e-15)
