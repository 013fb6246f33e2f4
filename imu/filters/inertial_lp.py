"""The specific force low-passed in an almost-inertial frame before it corrects the tilt (VQF's idea).

D. Laidig, T. Seel, "VQF: Highly accurate IMU orientation estimation with bias estimation and magnetic
disturbance rejection", Information Fusion 91, 2023, §3.2: each accelerometer sample is rotated into the
frame of the current strapdown estimate (which turns with the body's estimated attitude and so is inertial
up to the estimate's error), low-passed there by a second-order Butterworth filter of time constant
``tau_acc`` (cut-off ``fc = √2 / (2π tau_acc)``), and the low-passed vector, rotated back into the body,
is the measurement of the vertical. Accelerations that change sign within ``tau_acc`` (a swing, a shake,
vibration, the tangential and centripetal terms of an oscillation) average out; gravity, fixed in that
frame, does not. Without the rotation a low-pass would lag the body's own turning.

The same filter is applied here to the bias-corrected angular rate rotated into that frame: its low-passed
magnitude is the *sustained* rotation (a coordinated turn: near 0 for an oscillation about a fixed axis),
the quantity Liu et al.'s rate gate is meant to test (its threshold ``sqrt(ξω / L)`` is the rate at which a
sustained turn of radius L makes a centripetal acceleration ξω).

Coefficients: the bilinear transform with pre-warping, as ``vqf.VQF.filterCoeffs``. The state of one
3-vector is (x1, x2, y1, y2) per component, started at the first input (steady state).
"""

from __future__ import annotations

import math

import numpy as np
from imutherm.lazy_jit import njit

#: VQF's default tauAcc [s] (Laidig & Seel 2023, Table 1)
TAU_ACC_S = 3.0


def butter2_coeffs(tau: float, dt: float) -> np.ndarray:
    """(b0, b1, b2, a1, a2) of the second-order Butterworth low-pass with time constant tau [s] at step dt [s]
    (cut-off √2 / (2π tau), VQF's convention)."""
    fc = math.sqrt(2.0) / (2.0 * math.pi * tau)
    C = math.tan(math.pi * fc * dt)
    D = C * C + math.sqrt(2.0) * C + 1.0
    b0 = C * C / D
    return np.array([b0, 2.0 * b0, b0, 2.0 * (C * C - 1.0) / D, (1.0 - math.sqrt(2.0) * C + C * C) / D])


@njit(cache=True)
def lp3(st, off, x0, x1, x2, c):
    """Filter one 3-vector sample (x0, x1, x2) with the state st[off:off+12] (x1,x2,y1,y2 per component);
    returns the filtered components. Direct form I."""
    out = np.empty(3)
    xs = (x0, x1, x2)
    for i in range(3):
        j = off + 4 * i
        y = c[0] * xs[i] + c[1] * st[j] + c[2] * st[j + 1] - c[3] * st[j + 2] - c[4] * st[j + 3]
        st[j + 1] = st[j]
        st[j] = xs[i]
        st[j + 3] = st[j + 2]
        st[j + 2] = y
        out[i] = y
    return out


@njit(cache=True)
def lp3_init(st, off, x0, x1, x2):
    """Start the state st[off:off+12] at the steady state of the input (x0, x1, x2)."""
    xs = (x0, x1, x2)
    for i in range(3):
        j = off + 4 * i
        st[j] = st[j + 1] = st[j + 2] = st[j + 3] = xs[i]


# --------------------------------------------------------------------------- rest detection (bias at rest)
#: VQF's rest detector and its defaults (Laidig & Seel 2023, §3.4; the ``vqf`` package's VQFParams): the unit is at
#: rest while, for ``REST_MIN_S``, the gyro stays within ``REST_TH_GYR`` of its low-pass (time constant
#: ``REST_TAU``) whose magnitude stays below ``REST_TH_GYR`` too (VQF's biasClip: no bias beyond 2 °/s), and the
#: accelerometer within ``REST_TH_ACC`` of its own low-pass. There the low-passed gyro is the bias.
REST_TH_GYR = math.radians(2.0)
REST_TH_ACC = 0.5
REST_MIN_S = 1.5
REST_TAU = 0.5
#: time constant [s] with which a filter's bias estimate follows the low-passed gyro at rest (a first-order pull:
#: 3 s of rest remove 95 % of a bias error; VQF's rest update, a Kalman filter with biasSigmaRest 0.03 °/s,
#: converges within the same seconds)
REST_BIAS_TAU = 1.0
#: layout of a rest detector's state: low-pass of ω (3), of f (3), time at rest [s] (1), started (1)
REST_STATE = 8


@njit(cache=True)
def rest_step(st, off, gx, gy, gz, fx, fy, fz, alpha, dt):
    """One sample of the rest detector (constants above) with the state st[off:off+8]; alpha = dt / (REST_TAU + dt)
    (first-order low-pass). Returns (at_rest, low-passed ω x, y, z [rad/s])."""
    if st[off + 7] == 0.0:
        st[off], st[off + 1], st[off + 2] = gx, gy, gz
        st[off + 3], st[off + 4], st[off + 5] = fx, fy, fz
        st[off + 7] = 1.0
    b = 1.0 - alpha
    lx, ly, lz = alpha * gx + b * st[off], alpha * gy + b * st[off + 1], alpha * gz + b * st[off + 2]
    ax, ay, az = alpha * fx + b * st[off + 3], alpha * fy + b * st[off + 4], alpha * fz + b * st[off + 5]
    st[off], st[off + 1], st[off + 2] = lx, ly, lz
    st[off + 3], st[off + 4], st[off + 5] = ax, ay, az
    dw = (gx - lx) ** 2 + (gy - ly) ** 2 + (gz - lz) ** 2
    da = (fx - ax) ** 2 + (fy - ay) ** 2 + (fz - az) ** 2
    th2 = REST_TH_GYR * REST_TH_GYR
    if dw < th2 and lx * lx + ly * ly + lz * lz < th2 and da < REST_TH_ACC * REST_TH_ACC:
        st[off + 6] += dt
    else:
        st[off + 6] = 0.0
    return st[off + 6] >= REST_MIN_S, lx, ly, lz
