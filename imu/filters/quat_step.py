"""The quaternion correct-and-step the gated filters and the KF's strapdown frame share, as plain-float
functions and their numba kernels inlined into the batch loops (``inline="always"``: no call overhead, the
same arithmetic in the same order as the copies it replaces).

:func:`gravity_error` is the correction's error vector, e = m × r, between the measured down direction
``m`` (unit, body axes) and the estimate's ``r = C(q)ᵀ [0, 0, 1]``; :func:`quat_step` the step
``q ⊗ exp(h)`` with ``h = ω dt / 2`` [rad], renormalised (sin(|h|)/|h| by its Taylor terms below
|h|² = 1e-24).

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


#: the kernels the batch loops call (inlined into them by numba)
gravity_error_jit = njit(inline="always")(gravity_error)
quat_step_jit = njit(inline="always")(quat_step)
