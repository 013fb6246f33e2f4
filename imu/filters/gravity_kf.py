"""The horizontal-attitude KF paper's Kalman filter on the gravity direction.

State r = third column of C_bn^T... i.e. the gravity (down) direction in body
axes, ``r = C_bn [0, 0, 1]``, with ``dr/dt = -ω × r``. Covariance ``P = p I``
stays isotropic (the transition is a rotation), so the filter carries a scalar
p: ``p += q dt`` each sample, and at a measurement ``K = p / (p + R)``,
``p ← (1 - K) p``. The measurement is the accelerometer direction
``r_m = -f̄ / |f̄|``; the correction is projected onto the tangent plane of the
unit sphere (``(I - r rᵀ)(r_m - r)``, the horizontal-attitude KF paper eq. 31-32) and ``|r|`` is
renormalised to 1.

Gates (the horizontal-attitude KF paper §4): gate 1, the maximum of ``||f| - g|`` over a window of n
samples below ``a``: the measurement period becomes nT and f̄ is the window
mean; gate 2, the innovation norm ``|r_m - r|`` below ``innov_max``. Our
addition (not in the KF paper): if gate 1 has passed for a total of
``reject_timeout_s`` [s] of windows since gate 2 last accepted, the filter
**re-levels**: ``r ← r_m`` (the window's accelerometer direction) and
``p ← p0`` (recovery from a diverged state; accepting a single measurement
with its small gain K would leave the next innovation above the gate again).

Real sensors: ``g`` is the |f| this accelerometer reads at rest
and ``a`` = a design allowance plus the level the window maximum of
``||f| - g|`` does not exceed at rest at the record's own sample rate and
window (mean + 4 std): :func:`kf_params_from_rest`. With nominal g and a fixed
0.15 m/s², a part reading 9.90 m/s² at rest never passed gate 1, so the
re-level timer never ran either.

Propagation uses the trapezoidal rate ``(ω_{k-1} + ω_k)/2 - b`` and the exact
rotation (Rodrigues). The horizontal-attitude KF paper notes that the plain KF (its eq. 32) ignores
the equivalent gyro drift and that one must either inflate the system noise
or augment the state with it; ``kb > 0`` does the latter in the form of the
KF paper's nonlinear observer (eq. 14): at each accepted measurement
``b ← b - kb (r_m × r) nT``. ``kb = 0`` is the plain eq. 32 filter.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np
from imutherm.lazy_jit import njit

from imutherm.imu.filters.registry import FilterSpec, Tuned, register
from imutherm import InputError
from imutherm.imu.attitude_math import G0
from imutherm.imu.filters.common import (AttitudeEstimate, check_gyro_sample, check_samples, estimate_from_gravity,
                                         initial_bias, initial_quat, sample_steps, step_rates)
from imutherm.imu.filters.quat_step import quat_step_jit, rotate, rotate_jit
from imutherm.imu.filters.inertial_lp import REST_BIAS_TAU, REST_STATE, REST_TAU, lp3, lp3_init, rest_step


@dataclass(frozen=True)
class KFParams:
    """Parameters of the horizontal-attitude KF paper's filter.

    n_window : int [samples]  gate-1 window and measurement period (nT)
    a : float [m/s^2]         gate 1 threshold on max ||f| - g| in the window (:func:`kf_params_from_rest`
                              adds the rest noise level to this design allowance)
    innov_max : float [-]     gate 2 threshold on |r_m - r| (≈ angle [rad])
    q : float [1/s]           process noise density of r (inflated for the unestimated gyro bias)
    R : float [-]             measurement noise variance of r_m
    p0 : float [-]            initial variance
    reject_timeout_s : float [s]  re-level after this much gate-1-passing time of gate-2 rejections (inf: never)
    kb : float [1/s^2]        gyro-bias gain of the augmented state (0: plain eq. 32 KF)
    g : float [m/s^2]         |f| reference (the accelerometer's reading at rest)
    tau_acc : float [s]       0 (default): the KF paper's window mean and gate 1 as published; > 0: the
                              measurement is the specific force low-passed in a strapdown frame
                              (:func:`_kf_lp_core`, :mod:`imutherm.imu.filters.inertial_lp`) and gate 1 inflates R
                              by (max e_a / a)² instead of rejecting, and gate 2 is widened to 3 σ of the
                              innovation (sqrt(p + R_eff)) where that exceeds innov_max
    sf_std : float [-]        low-pass mode: gyro scale-factor uncertainty; the process noise of r grows by
                              (sf_std |ω|)² [rad²/s] (fast motion makes the gyro-only prediction worse)
    gyro_sample : str         'point' (trapezoid) or 'interval' (ω_k over the step ending at k): what a gyro
                              sample is (:data:`~imutherm.imu.filters.common.GYRO_SAMPLES`)
    rest_bias : bool          low-pass mode: the bias follows the low-passed gyro while the unit is at rest
                              (VQF's rest detector, :func:`~imutherm.imu.filters.inertial_lp.rest_step`)
    """

    n_window: int = 10
    a: float = 0.05
    innov_max: float = 0.05
    q: float = 2e-6
    R: float = 2e-4
    p0: float = 1e-4
    reject_timeout_s: float = 20.0
    kb: float = 0.002
    g: float = G0
    tau_acc: float = 0.0
    sf_std: float = 0.0
    gyro_sample: str = "point"
    rest_bias: bool = True

    def __post_init__(self):
        check_gyro_sample("KFParams", self.gyro_sample)
        if not (isinstance(self.n_window, (int, np.integer)) and self.n_window >= 1):
            raise InputError(f"KFParams: n_window={self.n_window!r} is invalid; valid: an integer >= 1")
        for name in ("a", "innov_max", "q", "R", "p0", "reject_timeout_s", "g", "kb"):
            v = getattr(self, name)
            if not (v > 0 or (name == "kb" and v == 0)) or math.isnan(v):
                raise InputError(f"KFParams: {name}={v!r} is invalid; valid: a positive number")
        if not (math.isfinite(self.tau_acc) and self.tau_acc >= 0):
            raise InputError(f"KFParams: tau_acc={self.tau_acc!r} is invalid; valid: a time constant >= 0 [s]")


@dataclass(frozen=True)
class KFState:
    """State of the horizontal-attitude KF paper's filter.

    r : (3,) [-] gravity direction in body axes; p : float [-] variance (P = p I);
    bias : (3,) [rad/s] gyro-bias estimate;
    prev_gyro : (3,) [rad/s] or None; win_sum : (3,) [m/s^2] accel sum over the window;
    win_max : float [m/s^2] max ||f| - g| in the window; win_n : int samples in the window;
    reject_t : float [s] time since gate 2 last accepted while gate 1 passed;
    used : bool, whether the last step applied a measurement;
    lp : state vector of :func:`_kf_lp_core` (``tau_acc > 0``; None before the first sample).
    """

    r: tuple
    p: float
    bias: tuple = (0.0, 0.0, 0.0)
    prev_gyro: tuple | None = None
    win_sum: tuple = (0.0, 0.0, 0.0)
    win_max: float = 0.0
    win_n: int = 0
    reject_t: float = 0.0
    used: bool = False
    lp: tuple | None = None

    @property
    def gravity(self) -> np.ndarray:
        """(3,) [-] estimated gravity direction in body axes."""
        return np.array(self.r)


def window_max_level(accel, g: float, n_window: int, k: float = 4.0) -> float:
    """Level [m/s^2] the gate-1 statistic max ||f| - g| over windows of ``n_window`` samples stays below at
    rest: mean + k std over the consecutive windows of ``accel`` (M,3) [m/s^2] (a record at rest)."""
    a = np.asarray(accel, float)
    m = (len(a) // n_window) * n_window
    if m < 3 * n_window:
        raise InputError(f"kf gate: a rest window of {len(a)} samples is too short for n_window={n_window}; "
                         "valid: at least 3 windows")
    e = np.abs(np.linalg.norm(a[:m], axis=1) - g).reshape(-1, n_window).max(axis=1)
    return float(e.mean() + k * e.std())


def kf_params_from_rest(gyro, accel, dt: float, init_s: float, params: KFParams) -> KFParams:
    """``params`` with g = the mean |f| over the first ``init_s`` [s] (at rest) and a = params.a (the design
    allowance [m/s^2]) + :func:`window_max_level` of that rest window. gyro (N,3) [rad/s], accel (N,3) [m/s^2]."""
    n0 = max(1, int(round(init_s / dt)))
    a = np.asarray(accel, float)[:n0]
    g_ref = float(np.mean(np.linalg.norm(a, axis=1)))
    return replace(params, g=g_ref, a=params.a + window_max_level(a, g_ref, params.n_window))


def _propagate(rx, ry, rz, wx, wy, wz, dt):
    """r ← exp(-[ω dt]×) r (Rodrigues), plain floats."""
    return rotate(rx, ry, rz, -wx * dt, -wy * dt, -wz * dt)


def _measure(rx, ry, rz, p, b, sx, sy, sz, R, innov_max, reject_t, period, timeout, kb, p0):
    """Gate 2 and the update (or the re-level after ``timeout``); returns (rx, ry, rz, p, b, reject_t, used)."""
    fn = math.sqrt(sx * sx + sy * sy + sz * sz)
    mx, my, mz = -sx / fn, -sy / fn, -sz / fn
    vx, vy, vz = mx - rx, my - ry, mz - rz
    if math.sqrt(vx * vx + vy * vy + vz * vz) >= innov_max:
        if reject_t + period < timeout:
            return rx, ry, rz, p, b, reject_t + period, False
        return mx, my, mz, p0, b, 0.0, True  # re-level
    if kb > 0.0:
        c = kb * period
        b = (b[0] - c * (my * rz - mz * ry), b[1] - c * (mz * rx - mx * rz), b[2] - c * (mx * ry - my * rx))
    K = p / (p + R)
    d = rx * vx + ry * vy + rz * vz
    rx, ry, rz = rx + K * (vx - d * rx), ry + K * (vy - d * ry), rz + K * (vz - d * rz)
    inv = 1.0 / math.sqrt(rx * rx + ry * ry + rz * rz)
    return rx * inv, ry * inv, rz * inv, (1.0 - K) * p, b, 0.0, True


def kf_step(state: KFState, gyro, accel, dt: float, params: KFParams) -> KFState:
    """One step of the horizontal-attitude KF paper's filter (procedural form).

    gyro (3,) [rad/s], accel (3,) [m/s^2] specific force, dt [s]. Returns the new state.
    """
    if params.tau_acc > 0:
        S = kf_lp_state0(state.r, state.p, state.bias) if state.lp is None else np.array(state.lp)
        _, u = run_kf_lp_core(np.asarray(gyro, float).reshape(1, 3), np.asarray(accel, float).reshape(1, 3), dt,
                              params, S)
        return replace(state, r=tuple(S[0:3]), p=float(S[3]), bias=tuple(S[4:7]), prev_gyro=tuple(S[23:26]),
                       lp=tuple(S), used=bool(u[0]))
    gx, gy, gz = (float(v) for v in gyro)
    fx, fy, fz = (float(v) for v in accel)
    pg = state.prev_gyro if state.prev_gyro is not None and params.gyro_sample == "point" else (gx, gy, gz)
    b = state.bias
    rx, ry, rz = _propagate(*state.r, 0.5 * (pg[0] + gx) - b[0], 0.5 * (pg[1] + gy) - b[1],
                            0.5 * (pg[2] + gz) - b[2], dt)
    p = state.p + params.q * dt
    ea = abs(math.sqrt(fx * fx + fy * fy + fz * fz) - params.g)
    ws = state.win_sum
    sx, sy, sz = ws[0] + fx, ws[1] + fy, ws[2] + fz
    wmax = ea if state.win_n == 0 or ea > state.win_max else state.win_max
    wn = state.win_n + 1
    reject_t, used = state.reject_t, False
    if wn == params.n_window:
        if wmax < params.a:
            rx, ry, rz, p, b, reject_t, used = _measure(rx, ry, rz, p, b, sx, sy, sz, params.R, params.innov_max,
                                                        reject_t, params.n_window * dt, params.reject_timeout_s,
                                                        params.kb, params.p0)
        sx = sy = sz = 0.0
        wmax, wn = 0.0, 0
    return replace(state, r=(rx, ry, rz), p=p, bias=b, prev_gyro=(gx, gy, gz), win_sum=(sx, sy, sz), win_max=wmax,
                   win_n=wn, reject_t=reject_t, used=used)


class GravityKF:
    """Thin class over :func:`kf_step` (the horizontal-attitude KF paper's Kalman filter on the gravity direction).

    params : KFParams; r0 : (3,) initial gravity direction in body axes [-];
    bias0 : (3,) [rad/s] initial gyro-bias estimate.
    """

    name = "kf"

    def __init__(self, params: KFParams, r0, bias0=(0.0, 0.0, 0.0)):
        self.params = params
        r0 = np.asarray(r0, float)
        r0 = r0 / np.linalg.norm(r0)
        self.state = KFState(r=tuple(float(v) for v in r0), p=params.p0, bias=tuple(float(v) for v in bias0))

    def update(self, gyro, accel, dt: float) -> KFState:
        """Process one sample: gyro (3,) [rad/s], accel (3,) [m/s^2], dt [s]; returns the new state."""
        self.state = kf_step(self.state, gyro, accel, dt, self.params)
        return self.state

    @property
    def gravity(self) -> np.ndarray:
        """(3,) [-] current gravity direction estimate."""
        return self.state.gravity


def run_kf(gyro, accel, dt: float, params: KFParams, r0=None, bias0=None, *,
           init_s: float = 10.0, steps=None) -> AttitudeEstimate:
    """Run the horizontal-attitude KF paper's filter over a record (batch loop, equals repeated :func:`kf_step`).

    gyro (N,3) [rad/s], accel (N,3) [m/s^2], dt [s], r0 (3,) [-] initial gravity
    direction (None → leveling over the first ``init_s`` [s]); bias0 (3,) [rad/s]
    initial gyro bias (None → mean gyro over the first ``init_s``, at rest); steps (N,) [s] the true step
    ending at each sample of an irregular record (None: ``dt``): r, the strapdown frame and the process noise
    advance over it; the measurement window, timers and low-pass keep ``dt``
    (:func:`~imutherm.imu.filters.common.sample_steps`).
    """
    gyro, accel = check_samples(gyro, accel, dt)
    dts = sample_steps(steps, len(gyro), dt)
    t0 = time.perf_counter()
    if r0 is None:
        from imutherm.imu.attitude_math import gravity_dir_body

        r0 = gravity_dir_body(initial_quat(accel, dt, init_s))
    r0 = np.asarray(r0, float)
    r0 = r0 / np.linalg.norm(r0)
    if bias0 is None:
        bias0 = initial_bias(gyro, dt, init_s)
    if params.tau_acc > 0:
        r, used = run_kf_lp_core(gyro, accel, dt, params, kf_lp_state0(r0, params.p0, bias0), steps=dts)
        return estimate_from_gravity("kf", r, used, time.perf_counter() - t0)
    wbar = step_rates(gyro, params.gyro_sample)
    r, used = _kf_loop(np.ascontiguousarray(wbar, float), np.ascontiguousarray(accel, float), float(dt), dts,
                       int(params.n_window), float(params.a), float(params.g), float(params.q), float(params.R),
                       float(params.innov_max), float(params.reject_timeout_s), float(params.kb), float(params.p0),
                       np.asarray(bias0, float), float(r0[0]), float(r0[1]), float(r0[2]))
    return estimate_from_gravity("kf", r, used, time.perf_counter() - t0)


_measure_compiled = njit(cache=True)(_measure)


@njit(cache=True)
def _kf_loop(wbar, accel, dt, dts, nw, a, g, q, R, imax, timeout, kb, p0, bias0, rx, ry, rz):
    """The per-sample loop of :func:`run_kf` (compiled; the arithmetic of :func:`kf_step`); dt [s] the design
    step (the window's period), dts (N,) [s] the step ending at each sample."""
    n = wbar.shape[0]
    period = nw * dt
    b = (bias0[0], bias0[1], bias0[2])
    p = p0
    sx = sy = sz = 0.0
    wmax, wn, reject_t = 0.0, 0, 0.0
    out = np.empty((n, 3))
    used = np.zeros(n, np.bool_)
    for k in range(n):
        h = dts[k]
        rx, ry, rz = rotate_jit(rx, ry, rz, -(wbar[k, 0] - b[0]) * h, -(wbar[k, 1] - b[1]) * h,
                                -(wbar[k, 2] - b[2]) * h)
        p = p + q * h
        fx, fy, fz = accel[k, 0], accel[k, 1], accel[k, 2]
        ea = abs(math.sqrt(fx * fx + fy * fy + fz * fz) - g)
        sx, sy, sz = sx + fx, sy + fy, sz + fz
        if wn == 0 or ea > wmax:
            wmax = ea
        wn += 1
        if wn == nw:
            if wmax < a:
                rx, ry, rz, p, b, reject_t, u = _measure_compiled(rx, ry, rz, p, b, sx, sy, sz, R, imax, reject_t,
                                                                  period, timeout, kb, p0)
                used[k] = u
            sx = sy = sz = 0.0
            wmax, wn = 0.0, 0
        out[k, 0], out[k, 1], out[k, 2] = rx, ry, rz
    return out, used


# --------------------------------------------------------------------------- inertial low-pass mode
#: state vector of :func:`_kf_lp_core`: r (3), p (1), bias (3), strapdown frame q_I (4), low-pass of f_I (12),
#: previous gyro (3), started (1), samples in the window (1), rejection time (1), window max of e_a (1), rest
#: detector (8)
_KF_LP_STATE = 30 + REST_STATE


@njit(cache=True)
def _kf_lp_core(gyro, accel, dt, dts, nw, a, g, q, R, imax, timeout, kb, p0, c, S, sf2, trap, rest):
    """The horizontal-attitude KF paper's KF with the measurement low-passed in a strapdown (almost-inertial) frame.

    The frame q_I is the gyro-only strapdown attitude (bias-corrected with the filter's estimate, never
    corrected by the accelerometer, as VQF's inertial frame, so the low-pass is outside the feedback loop).
    Each sample: r propagated as in the KF paper; f_I = C(q_I) f low-passed (coefficients c); e_a = ||f̄_I| - g|.
    Every ``nw`` samples the measurement r_m = -C(q_I)ᵀ f̄_I / |f̄_I| updates r through the KF paper's gate 2 and
    re-level, with gate 1 as a variance inflation instead of a rejection: R / w, w = min(1, (a / max e_a)²)
    over the window (and the bias gain kb w), gate 2 at max(innov_max, 3 sqrt(p + R / w)); process noise
    q + sf2 |ω|² over each step dts[k] [s] (dt [s]: the design step of the window and the low-pass c). The rate
    of a step: the trapezoid (``trap``: point samples) or the sample (interval samples). At rest (``rest``:
    :func:`~imutherm.imu.filters.inertial_lp.rest_step`) the bias follows the low-passed gyro with REST_BIAS_TAU.
    Returns (gravity (N,3), used (N,) bool); S updated in place.
    """
    n = gyro.shape[0]
    out = np.empty((n, 3))
    used = np.zeros(n, np.bool_)
    rx, ry, rz, p = S[0], S[1], S[2], S[3]
    bx, by, bz = S[4], S[5], S[6]
    qw, qx, qy, qz = S[7], S[8], S[9], S[10]
    period = nw * dt
    ra = dt / (REST_TAU + dt)
    for k in range(n):
        gx, gy, gz = gyro[k, 0], gyro[k, 1], gyro[k, 2]
        fx, fy, fz = accel[k, 0], accel[k, 1], accel[k, 2]
        h = dts[k]
        if S[26] == 0.0:
            S[23], S[24], S[25] = gx, gy, gz
        if rest:
            at_rest, lgx, lgy, lgz = rest_step(S, 30, gx, gy, gz, fx, fy, fz, ra, dt)
            if at_rest:
                kr = h / REST_BIAS_TAU
                bx, by, bz = bx + kr * (lgx - bx), by + kr * (lgy - by), bz + kr * (lgz - bz)
        if trap:
            wx, wy, wz = 0.5 * (S[23] + gx) - bx, 0.5 * (S[24] + gy) - by, 0.5 * (S[25] + gz) - bz
        else:
            wx, wy, wz = gx - bx, gy - by, gz - bz
        S[23], S[24], S[25] = gx, gy, gz
        rx, ry, rz = rotate_jit(rx, ry, rz, -wx * h, -wy * h, -wz * h)
        p = p + q * h + sf2 * h * (wx * wx + wy * wy + wz * wz)
        # strapdown frame q_I <- q_I ⊗ exp(ω dt / 2)
        qw, qx, qy, qz = quat_step_jit(qw, qx, qy, qz, 0.5 * h * wx, 0.5 * h * wy, 0.5 * h * wz)
        c00, c01, c02 = 1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qw * qz), 2 * (qx * qz + qw * qy)
        c10, c11, c12 = 2 * (qx * qy + qw * qz), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qw * qx)
        c20, c21, c22 = 2 * (qx * qz - qw * qy), 2 * (qy * qz + qw * qx), 1 - 2 * (qx * qx + qy * qy)
        f0, f1, f2 = c00 * fx + c01 * fy + c02 * fz, c10 * fx + c11 * fy + c12 * fz, c20 * fx + c21 * fy + c22 * fz
        if S[26] == 0.0:
            lp3_init(S, 11, f0, f1, f2)
            S[26] = 1.0
        lf = lp3(S, 11, f0, f1, f2, c)
        e_a = abs(math.sqrt(lf[0] * lf[0] + lf[1] * lf[1] + lf[2] * lf[2]) - g)
        if S[27] == 0.0 or e_a > S[29]:
            S[29] = e_a
        S[27] += 1.0
        if S[27] >= nw:
            wgt = 1.0 if S[29] < a else (a / S[29]) ** 2
            sx = c00 * lf[0] + c10 * lf[1] + c20 * lf[2]
            sy = c01 * lf[0] + c11 * lf[1] + c21 * lf[2]
            sz = c02 * lf[0] + c12 * lf[1] + c22 * lf[2]
            Re = R / wgt
            gate2 = max(imax, 3.0 * math.sqrt(p + Re))  # the KF paper's gate 2, widened to 3 sigma of the innovation
            rx, ry, rz, p, b, S[28], u = _measure_compiled(rx, ry, rz, p, (bx, by, bz), sx, sy, sz, Re, gate2,
                                                           S[28], period, timeout, kb * wgt, p0)
            bx, by, bz = b[0], b[1], b[2]
            used[k] = u and wgt >= 0.5
            S[27] = 0.0
        out[k, 0], out[k, 1], out[k, 2] = rx, ry, rz
    S[0], S[1], S[2], S[3] = rx, ry, rz, p
    S[4], S[5], S[6] = bx, by, bz
    S[7], S[8], S[9], S[10] = qw, qx, qy, qz
    return out, used


def kf_lp_state0(r0, p0, b0) -> np.ndarray:
    """Initial state of :func:`_kf_lp_core`: r0 (3,) [-], p0 [-], b0 (3,) [rad/s]; the strapdown frame starts
    level with the body's down along r0 (yaw 0)."""
    from imutherm.imu.attitude_math import euler_to_quat, roll_pitch_from_gravity

    S = np.zeros(_KF_LP_STATE)
    S[0:3] = r0
    S[3] = p0
    S[4:7] = b0
    roll, pitch = roll_pitch_from_gravity(np.asarray(r0, float))
    S[7:11] = euler_to_quat(roll, pitch, 0.0)
    return S


def run_kf_lp_core(gyro, accel, dt, params: "KFParams", S, steps=None):
    """:func:`_kf_lp_core` with ``params``, designed at ``dt`` [s]; steps (N,) [s] the true steps (None: ``dt``);
    returns (gravity (N,3), used (N,))."""
    from imutherm.imu.filters.inertial_lp import butter2_coeffs

    return _kf_lp_core(np.ascontiguousarray(gyro, float), np.ascontiguousarray(accel, float), float(dt),
                       sample_steps(steps, len(gyro), dt), int(params.n_window), float(params.a), float(params.g),
                       float(params.q), float(params.R), float(params.innov_max), float(params.reject_timeout_s),
                       float(params.kb), float(params.p0), butter2_coeffs(params.tau_acc, dt), S,
                       float(params.sf_std ** 2), params.gyro_sample == "point", bool(params.rest_bias))


# --------------------------------------------------------------------------- the registry's entry

def kf_design(x) -> KFParams:
    """``kf``'s design params on the record ``x`` (FilterInputs): ``x.design['kf']``, else the defaults."""
    return x.design.get("kf") or KFParams()


def _run_kf_spec(x, p):  # the design KFParams plus the rest window's |f| reference and gate level
    p = replace(p or kf_design(x), gyro_sample=x.gyro_sample)
    return run_kf(x.gyro, x.accel, x.dt, kf_params_from_rest(x.gyro, x.accel, x.dt, x.init_s, p), init_s=x.init_s,
                  steps=x.steps)


register(FilterSpec("kf", _run_kf_spec, KFParams, "ours",
                    "the horizontal-attitude KF paper's gravity-direction KF; KFParams", "tab:green",
                    base=kf_design, groups={"study", "sweep", "varying_dt", "real_tuned"}, linestyle="--", rank=20,
                    tuning=(Tuned("tau_acc", 1.0, 3.16, (0.1, 1000.0), "tau_acc [s]; 0 = the KF paper's window mean "
                                                                       "and gate 1", off=(0.0,)),
                            Tuned("q", 1e-7, 3.16e-4, (1e-10, 0.1), "q [rad^2/s] the process noise of the gravity "
                                                                    "direction"))))
