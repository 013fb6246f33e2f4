"""A filter-independent divergence check in motion (issue 57): the specific force turned into an almost-inertial
frame with a filter's vertical and averaged over a window of tens of seconds. Averaged there, the linear
acceleration is the window's velocity change over its length, Δv / W, near zero for hand-held, pendulum or vehicle
motion over such a window, and what is left is the angle between the filter's vertical and gravity: its attitude
error. The rest check (:mod:`~imutherm.imu.filters.rest_check`) sees rests only; this one sees every window.

Per sample k: the horizontal part, with respect to the filter's down direction r_k (body axes, unit), of the
specific force normalised by the accelerometer's |f| at rest, h_k = -f_k / g - ((-f_k / g) · r_k) r_k (a vector
of length sin(angle) between r_k and the apparent vertical), turned into the frame of a strapdown integration of
the bias-corrected gyro alone (VQF's almost-inertial frame, Laidig & Seel, Information Fusion 91, 2023: fixed to
the earth up to the gyro's drift). Its mean over a window of W seconds is the filter's tilt error (as a
small-angle vector) plus the window's mean horizontal linear acceleration / g plus the accelerometer's noise
averaged over the window's N samples.

Bound (the rule, no tuned number): a window is flagged when |mean h| exceeds
``atan((dv_max / W + K σ_f / sqrt(N) + b_a) / g)``, with ``dv_max`` [m/s] the largest velocity change across a
window the platform makes (stated per platform: :data:`DV_MAX`), σ_f [m/s^2] the accelerometer's white noise per
sample (the std over the rest window, per axis), K = 4 (:data:`~imutherm.imu.filters.gate.NOISE_K`: a Gaussian
component exceeds 4 σ on 0.006 % of windows) and b_a [m/s^2] the accelerometer's bias (:data:`ACCEL_BIAS`): the
specific force is gravity plus that bias, so a filter whose vertical is right, or one following the accelerometer
with a lag while the bias turns with the body, lies up to b_a / g from the averaged specific force; the check sees
divergence, not the accelerometer's own error (common to every gravity-referenced filter). Left out: the
strapdown frame's own drift over a window (a gyro bias error b turns the averaged vectors by b W, e.g. 0.03 °/s
x 30 s = 0.9°: a rotation of vectors of length |h| ≤ 1, not an offset; against hand motion of 1 m/s it adds
b v / g ≈ 0.005°).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from imutherm.lazy_jit import njit

from imutherm import InputError
from imutherm.imu.filters.gate import NOISE_K
from imutherm.imu.filters.quat_step import quat_step_jit

#: window [s] of the check: tens of seconds (the linear acceleration of hand or pendulum motion averages out)
WINDOW_S = 30.0
#: the largest velocity change across a window [m/s] per platform of ``imutherm attitude --imu-csv``
#: [ASSUMED]: handheld 3 m/s (a hand's speed stays below ~1.5 m/s at both ends of a window of tens of seconds:
#: walking pace, an arm swing's peak); vehicle 15 m/s (0-54 km/h, a town car's acceleration over 30 s); aircraft
#: 30 m/s (the flight profile's speed changes)
DV_MAX = {"handheld": 3.0, "vehicle": 15.0, "aircraft": 30.0}
#: the accelerometer bias [m/s^2] the bound allows: 20 mg, a consumer MEMS part's initial zero-g tolerance (the
#: ICM-42688-P's in imu/sensor_library.toml: recalled, not checked; the BMI160's is given as 25 mg in
#: imu/grades.py, the industrial parts' are below 5 mg): the worst a recorded log of unknown part is assumed to carry
ACCEL_BIAS = 0.020 * 9.80665


@dataclass(frozen=True)
class MotionCheck:
    """Result of :func:`motion_disagreement`.

    window_s : float [s]     window length W
    bound_deg : float [deg]  the flag bound (module docstring)
    tilt_deg : (M,) [deg]    the tilt of the window mean of h, one per window (windows start every W / 2)
    t_start : (M,) [s]       start time of each window from the record's first sample
    flagged : list           [(t_start [s], tilt [deg])] of the windows above the bound
    """

    window_s: float
    bound_deg: float
    tilt_deg: np.ndarray
    t_start: np.ndarray
    flagged: list

    @property
    def worst_deg(self) -> float:
        """Largest window tilt [deg] (0 without a full window)."""
        return float(np.max(self.tilt_deg)) if self.tilt_deg.size else 0.0


@njit(cache=True)
def _horizontal_inertial(gyro, accel, gravity, dts, bias, g):
    """(N,3) h_k of the module docstring in the strapdown frame of the gyro (interval samples, bias removed)."""
    n = gyro.shape[0]
    out = np.empty((n, 3))
    w, x, y, z = 1.0, 0.0, 0.0, 0.0
    for k in range(n):
        if k:
            hdt = 0.5 * dts[k]
            w, x, y, z = quat_step_jit(w, x, y, z, hdt * (gyro[k, 0] - bias[0]), hdt * (gyro[k, 1] - bias[1]),
                                       hdt * (gyro[k, 2] - bias[2]))
        rx, ry, rz = gravity[k, 0], gravity[k, 1], gravity[k, 2]
        rn = math.sqrt(rx * rx + ry * ry + rz * rz)
        rx, ry, rz = rx / rn, ry / rn, rz / rn
        mx, my, mz = -accel[k, 0] / g, -accel[k, 1] / g, -accel[k, 2] / g
        d = mx * rx + my * ry + mz * rz
        hx, hy, hz = mx - d * rx, my - d * ry, mz - d * rz
        c00, c01, c02 = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
        c10, c11, c12 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
        c20, c21, c22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
        out[k, 0] = c00 * hx + c01 * hy + c02 * hz
        out[k, 1] = c10 * hx + c11 * hy + c12 * hz
        out[k, 2] = c20 * hx + c21 * hy + c22 * hz
    return out


def motion_bound_deg(window_s: float, n_window: int, g: float, noise_f: float, dv_max: float,
                     accel_bias: float = ACCEL_BIAS) -> float:
    """The flag bound [deg]: atan((dv_max / W + K σ_f / sqrt(N) + b_a) / g) (module docstring); window_s W [s],
    n_window N samples, g and noise_f σ_f [m/s^2], dv_max [m/s], accel_bias b_a [m/s^2]."""
    return math.degrees(math.atan((dv_max / window_s + NOISE_K * noise_f / math.sqrt(n_window) + accel_bias) / g))


def motion_disagreement(gyro, accel, dt: float, gravity, *, init_s: float, dv_max: float = DV_MAX["handheld"],
                        window_s: float = WINDOW_S, accel_bias: float = ACCEL_BIAS, steps=None) -> MotionCheck:
    """The check of the module docstring on a filter's down direction ``gravity`` (N,3) [-] (body axes) with the
    record's gyro (N,3) [rad/s] (interval samples), accel (N,3) [m/s^2], dt [s] (steps (N,) [s] the true steps of an
    irregular record, None: dt). The gyro bias, |f| reference g and the accelerometer's noise σ_f are measured over
    the rest window ``init_s`` [s] at the start; windows of ``window_s`` [s] start every half window; dv_max [m/s]
    and accel_bias [m/s^2] enter the bound (module docstring)."""
    gyro = np.ascontiguousarray(gyro, float)
    accel = np.ascontiguousarray(accel, float)
    gravity = np.ascontiguousarray(gravity, float)
    if gravity.shape != gyro.shape or accel.shape != gyro.shape or gyro.ndim != 2 or gyro.shape[1] != 3:
        raise InputError(f"motion check: gyro {gyro.shape}, accel {accel.shape}, gravity {gravity.shape} are "
                         "invalid; valid: three (N, 3) arrays")
    if not (all(math.isfinite(v) and v > 0 for v in (dt, init_s, dv_max, window_s))
            and math.isfinite(accel_bias) and accel_bias >= 0):
        raise InputError(f"motion check: dt={dt!r}, init_s={init_s!r}, dv_max={dv_max!r}, window_s={window_s!r}, "
                         f"accel_bias={accel_bias!r} are invalid; valid: positive numbers [s], [s], [m/s], [s] and a "
                         "bias >= 0 [m/s^2]")
    n = len(gyro)
    n0 = max(2, int(round(init_s / dt)))
    g = float(np.mean(np.linalg.norm(accel[:n0], axis=1)))
    noise_f = float(np.mean(np.std(accel[:n0], axis=0)))
    bias = np.mean(gyro[:n0], axis=0)
    dts = np.full(n, float(dt)) if steps is None else np.ascontiguousarray(steps, float)
    h = _horizontal_inertial(gyro, accel, gravity, dts, bias, g)
    w = max(2, int(round(window_s / dt)))
    bound = motion_bound_deg(window_s, w, g, noise_f, dv_max, accel_bias)
    starts = np.arange(0, n - w + 1, max(1, w // 2))
    if starts.size == 0:
        return MotionCheck(window_s, bound, np.zeros(0), np.zeros(0), [])
    cum = np.vstack([np.zeros((1, 3)), np.cumsum(h, axis=0)])
    mean = (cum[starts + w] - cum[starts]) / w
    tilt = np.degrees(np.arcsin(np.clip(np.linalg.norm(mean, axis=1), 0.0, 1.0)))
    t = starts * dt
    flagged = [(float(a), float(b)) for a, b in zip(t, tilt) if b > bound]
    return MotionCheck(window_s, bound, tilt, t, flagged)
