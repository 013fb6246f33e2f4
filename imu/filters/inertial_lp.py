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
from numba import njit

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
