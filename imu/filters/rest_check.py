"""A filter-independent divergence check: at rest the specific force is gravity, so a filter whose vertical
departs from the accelerometer's there has lost it (issue 57: `attitude --imu-csv` says so in one line for every
filter, ours and the peers, beside the aekf's own NIS monitor).

Rest is VQF's rest detector (:func:`~imutherm.imu.filters.inertial_lp.rest_step`: low-passed gyro below 2 °/s and
gyro / accelerometer within their thresholds of their low-passes for 1.5 s; Laidig & Seel, Information Fusion 91,
2023). Over the rest samples of each ``window_s`` of the record (at least 1 s of them) the mean angle between the filter's vertical and the low-passed
accelerometer's is compared with ``bound_deg``: 3° by default, above what an accelerometer's own error at rest
gives (bias and misalignment: the grades of :mod:`imutherm.imu.grades` give 0.6° for 10 mg, 1.2° for 20 mg).
"""

from __future__ import annotations

import math

import numpy as np
from imutherm.lazy_jit import njit

from imutherm import InputError
from imutherm.imu.filters.inertial_lp import REST_STATE, REST_TAU, rest_step


@njit(cache=True)
def _rest_angles(gyro, accel, gravity, dt):
    """(N,) angle [rad] between gravity[k] and the low-passed -accel at rest samples, NaN elsewhere."""
    n = gyro.shape[0]
    st = np.zeros(REST_STATE)
    a = dt / (REST_TAU + dt)
    out = np.full(n, np.nan)
    for k in range(n):
        at_rest, _, _, _ = rest_step(st, 0, gyro[k, 0], gyro[k, 1], gyro[k, 2], accel[k, 0], accel[k, 1],
                                     accel[k, 2], a, dt)
        if at_rest:
            fx, fy, fz = -st[3], -st[4], -st[5]
            gx, gy, gz = gravity[k, 0], gravity[k, 1], gravity[k, 2]
            c = (fx * gx + fy * gy + fz * gz) / (math.sqrt(fx * fx + fy * fy + fz * fz)
                                                 * math.sqrt(gx * gx + gy * gy + gz * gz))
            out[k] = math.acos(min(1.0, max(-1.0, c)))
    return out


def rest_disagreement(gyro, accel, dt: float, gravity, *, bound_deg: float = 3.0, window_s: float = 5.0) -> list:
    """Windows of rest where a filter's vertical is off the accelerometer's: [(t_start [s], mean angle [deg])] of
    each ``window_s`` of the record holding at least 1 s of rest samples whose mean angle there exceeds
    ``bound_deg``. gyro (N,3) [rad/s],
    accel (N,3) [m/s^2], gravity (N,3) [-] the filter's gravity direction in body axes, dt [s]."""
    if not (bound_deg > 0 and window_s > 0 and math.isfinite(bound_deg) and math.isfinite(window_s)):
        raise InputError(f"rest check: bound_deg={bound_deg!r}, window_s={window_s!r} are invalid; valid: positive "
                         "numbers [deg], [s]")
    ang = _rest_angles(np.ascontiguousarray(gyro, float), np.ascontiguousarray(accel, float),
                       np.ascontiguousarray(gravity, float), float(dt))
    w = max(1, int(round(window_s / dt)))
    need = max(1, int(round(1.0 / dt)))  # a window counts with at least 1 s of rest samples in it
    out = []
    for s in range(0, len(ang) - w + 1, w):
        a = ang[s:s + w]
        a = a[np.isfinite(a)]
        if a.size >= need:
            m = float(np.degrees(np.mean(a)))
            if m > bound_deg:
                out.append((s * dt, m))
    return out
