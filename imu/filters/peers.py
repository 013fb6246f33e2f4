"""Peer 6D attitude filters beside imufusion: VQF and the ``ahrs`` package's Madgwick, Mahony and EKF.

All are run 6D (gyro + accelerometer, no magnetometer), causally, on the same
samples as our filters, with the same start: the initial attitude from
leveling over the first ``init_s`` [s] where the API takes one (ahrs filters;
VQF and imufusion initialise themselves from the first samples), and the
gyro corrected by the rest-window mean rate (the power-on bias every user
removes; VQF and imufusion additionally estimate the bias themselves).

Frames: the filters are fed FRD body axes, the gyro in rad/s and, as
"accelerometer", the gravity direction ``-f`` [m/s^2]: each of them aligns
its reference axis z with that vector, so its quaternion is body → a
z-down (NED-like, yaw free) frame and our ``gravity_dir_body(q)`` applies
directly (checked at a fixed tilt in the tests).

Published defaults (the "defaults" rows of the benchmark):

* **VQF** (``vqf`` 2.x, Laidig & Seel, Information Fusion 91, 2023): the C++
  ``VQF`` class (causal; ``offlineVQF`` looks ahead and is not comparable) with
  ``VQFParams`` defaults: tauAcc 3 s, rest and motion bias estimation on,
  biasSigmaMotion 0.1 °/s, ...
* **Madgwick** (``ahrs.filters.Madgwick``): gain 0.033 (``gain_imu``).
* **Mahony** (``ahrs.filters.Mahony``): k_P 1.0, k_I 0.3.
* **EKF** (``ahrs.filters.EKF``): noises var_gyr 0.3², var_acc 0.5², P0 = I.

The ahrs filters are pure Python per sample (176-554 µs per sample here), too
slow for a table over seeds and a tuning loop, so :func:`madgwick_loop`,
:func:`mahony_loop` and :func:`ekf_batch` are equivalents written for speed
(plain floats; the EKF compiled with numba, its 4x4 covariance algebra being
too slow in CPython) and tested to agree with the package to 1e-9.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
from imutherm.lazy_jit import njit

from imutherm.imu.filters.registry import FilterSpec, Tuned, register
from imutherm.imu.filters.common import (AttitudeEstimate, check_samples, estimate_from_gravity, initial_bias,
                                         initial_quat, sample_steps)


# --------------------------------------------------------------------------- Madgwick
@dataclass(frozen=True)
class MadgwickParams:
    """ahrs Madgwick IMU gain ``gain`` [rad/s] (published default 0.033)."""

    gain: float = 0.033


def madgwick_loop(gyro, acc, dt: float, gain: float, q0, steps=None) -> np.ndarray:
    """ahrs ``Madgwick.updateIMU`` over a record: Q[0] = q0, Q[t] = update(Q[t-1], gyr[t], acc[t]).

    gyro (N,3) [rad/s], acc (N,3) reference vector (any scale), dt [s], gain [rad/s], q0 (4,); steps (N,) [s]
    the true step ending at each sample (None: ``dt``; ahrs takes a dt per update too).
    Returns Q (N,4).
    """
    n = len(gyro)
    gl, al = np.asarray(gyro, float).tolist(), np.asarray(acc, float).tolist()
    hl = [float(dt)] * n if steps is None else np.asarray(steps, float).tolist()
    Q = [None] * n
    w, x, y, z = (float(v) for v in np.asarray(q0, float) / np.linalg.norm(q0))
    Q[0] = (w, x, y, z)
    sqrt = math.sqrt
    for t in range(1, n):
        gx, gy, gz = gl[t]
        if gx == 0.0 and gy == 0.0 and gz == 0.0:
            Q[t] = (w, x, y, z)
            continue
        dw = 0.5 * (-x * gx - y * gy - z * gz)
        dx = 0.5 * (w * gx + y * gz - z * gy)
        dy = 0.5 * (w * gy - x * gz + z * gx)
        dz = 0.5 * (w * gz + x * gy - y * gx)
        ax, ay, az = al[t]
        an = sqrt(ax * ax + ay * ay + az * az)
        if an > 0:
            ax, ay, az = ax / an, ay / an, az / an
            qn = sqrt(w * w + x * x + y * y + z * z)
            qw, qx, qy, qz = w / qn, x / qn, y / qn, z / qn
            f0 = 2.0 * (qx * qz - qw * qy) - ax
            f1 = 2.0 * (qw * qx + qy * qz) - ay
            f2 = 2.0 * (0.5 - qx * qx - qy * qy) - az
            if f0 != 0.0 or f1 != 0.0 or f2 != 0.0:
                g0 = -2.0 * qy * f0 + 2.0 * qx * f1
                g1 = 2.0 * qz * f0 + 2.0 * qw * f1 - 4.0 * qx * f2
                g2 = -2.0 * qw * f0 + 2.0 * qz * f1 - 4.0 * qy * f2
                g3 = 2.0 * qx * f0 + 2.0 * qy * f1
                gn = sqrt(g0 * g0 + g1 * g1 + g2 * g2 + g3 * g3)
                dw -= gain * g0 / gn
                dx -= gain * g1 / gn
                dy -= gain * g2 / gn
                dz -= gain * g3 / gn
        h = hl[t]
        w, x, y, z = w + dw * h, x + dx * h, y + dy * h, z + dz * h
        nn = sqrt(w * w + x * x + y * y + z * z)
        w, x, y, z = w / nn, x / nn, y / nn, z / nn
        Q[t] = (w, x, y, z)
    return np.array(Q)


# --------------------------------------------------------------------------- Mahony
@dataclass(frozen=True)
class MahonyParams:
    """ahrs Mahony gains: k_P [1/s] (default 1.0), k_I [1/s^2] (default 0.3)."""

    k_P: float = 1.0
    k_I: float = 0.3


def mahony_loop(gyro, acc, dt: float, k_P: float, k_I: float, q0, b0=(0.0, 0.0, 0.0), steps=None) -> np.ndarray:
    """ahrs ``Mahony.updateIMU`` over a record (bias state b starting at b0 [rad/s]); steps (N,) [s] the true
    step ending at each sample (None: ``dt``); returns Q (N,4)."""
    n = len(gyro)
    gl, al = np.asarray(gyro, float).tolist(), np.asarray(acc, float).tolist()
    hl = [float(dt)] * n if steps is None else np.asarray(steps, float).tolist()
    Q = [None] * n
    w, x, y, z = (float(v) for v in np.asarray(q0, float) / np.linalg.norm(q0))
    bx, by, bz = (float(v) for v in b0)
    Q[0] = (w, x, y, z)
    sqrt = math.sqrt
    for t in range(1, n):
        ox, oy, oz = gl[t]
        if ox == 0.0 and oy == 0.0 and oz == 0.0:
            Q[t] = (w, x, y, z)
            continue
        dt = hl[t]
        ax, ay, az = al[t]
        an = sqrt(ax * ax + ay * ay + az * az)
        if an > 0:
            ax, ay, az = ax / an, ay / an, az / an
            vx = 2.0 * (x * z - w * y)
            vy = 2.0 * (w * x + y * z)
            vz = 1.0 - 2.0 * (x * x + y * y)
            ex, ey, ez = ay * vz - az * vy, az * vx - ax * vz, ax * vy - ay * vx
            bx, by, bz = bx - k_I * ex * dt, by - k_I * ey * dt, bz - k_I * ez * dt
            ox, oy, oz = ox - bx + k_P * ex, oy - by + k_P * ey, oz - bz + k_P * ez
        dw = 0.5 * (-x * ox - y * oy - z * oz)
        dx = 0.5 * (w * ox + y * oz - z * oy)
        dy = 0.5 * (w * oy - x * oz + z * ox)
        dz = 0.5 * (w * oz + x * oy - y * ox)
        w, x, y, z = w + dw * dt, x + dx * dt, y + dy * dt, z + dz * dt
        nn = sqrt(w * w + x * x + y * y + z * z)
        w, x, y, z = w / nn, x / nn, y / nn, z / nn
        Q[t] = (w, x, y, z)
    return np.array(Q)


# --------------------------------------------------------------------------- EKF
@dataclass(frozen=True)
class EKFParams:
    """ahrs EKF (IMU mode, NED): var_gyr [(rad/s)^2] 0.3², var_acc [-] 0.5² (of the unit gravity vector)."""

    var_gyr: float = 0.09
    var_acc: float = 0.25


@njit(cache=True)
def _mm(A, B):
    n, m, k = A.shape[0], B.shape[1], A.shape[1]
    C = np.zeros((n, m))
    for i in range(n):
        for j in range(m):
            acc = 0.0
            for l in range(k):
                acc += A[i, l] * B[l, j]
            C[i, j] = acc
    return C


@njit(cache=True)
def _inv3(S):
    a, b, c = S[0, 0], S[0, 1], S[0, 2]
    d, e, f = S[1, 0], S[1, 1], S[1, 2]
    g, h, i = S[2, 0], S[2, 1], S[2, 2]
    A = e * i - f * h
    Bc = -(d * i - f * g)
    C = d * h - e * g
    det = a * A + b * Bc + c * C
    out = np.empty((3, 3))
    out[0, 0], out[0, 1], out[0, 2] = A / det, -(b * i - c * h) / det, (b * f - c * e) / det
    out[1, 0], out[1, 1], out[1, 2] = Bc / det, (a * i - c * g) / det, -(a * f - c * d) / det
    out[2, 0], out[2, 1], out[2, 2] = C / det, -(a * h - b * g) / det, (a * e - b * d) / det
    return out


@njit(cache=True)
def _ekf_loop(gyro, acc, dts, vg, va, q0):
    n = gyro.shape[0]
    Q = np.empty((n, 4))
    q = q0 / np.sqrt(np.sum(q0 * q0))
    Q[0] = q
    P = np.eye(4)
    F = np.empty((4, 4))
    W = np.empty((4, 3))
    H = np.empty((3, 4))
    for t in range(1, n):
        a = acc[t]
        an = np.sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2])
        if an == 0.0:
            Q[t] = q
            continue
        z = a / an
        dt = dts[t]
        gx, gy, gz = 0.5 * dt * gyro[t, 0], 0.5 * dt * gyro[t, 1], 0.5 * dt * gyro[t, 2]
        F[0, 0], F[0, 1], F[0, 2], F[0, 3] = 1.0, -gx, -gy, -gz
        F[1, 0], F[1, 1], F[1, 2], F[1, 3] = gx, 1.0, gz, -gy
        F[2, 0], F[2, 1], F[2, 2], F[2, 3] = gy, -gz, 1.0, gx
        F[3, 0], F[3, 1], F[3, 2], F[3, 3] = gz, gy, -gx, 1.0
        qt = np.empty(4)
        for i in range(4):
            qt[i] = F[i, 0] * q[0] + F[i, 1] * q[1] + F[i, 2] * q[2] + F[i, 3] * q[3]
        w, x, y, zz = q[0], q[1], q[2], q[3]
        h = 0.5 * dt
        W[0, 0], W[0, 1], W[0, 2] = -x * h, -y * h, -zz * h
        W[1, 0], W[1, 1], W[1, 2] = w * h, -zz * h, y * h
        W[2, 0], W[2, 1], W[2, 2] = zz * h, w * h, -x * h
        W[3, 0], W[3, 1], W[3, 2] = -y * h, x * h, w * h
        Pt = _mm(_mm(F, P), F.T.copy()) + vg * _mm(W, W.T.copy())
        qn = qt / np.sqrt(np.sum(qt * qt))
        w, x, y, zz = qn[0], qn[1], qn[2], qn[3]
        v0 = z[0] - 2.0 * (x * zz - w * y)
        v1 = z[1] - 2.0 * (w * x + y * zz)
        v2 = z[2] - (1.0 - 2.0 * (x * x + y * y))
        w, x, y, zz = qt[0], qt[1], qt[2], qt[3]
        H[0, 0], H[0, 1], H[0, 2], H[0, 3] = -2 * y, 2 * zz, -2 * w, 2 * x
        H[1, 0], H[1, 1], H[1, 2], H[1, 3] = 2 * x, 2 * w, 2 * zz, 2 * y
        H[2, 0], H[2, 1], H[2, 2], H[2, 3] = 2 * w, -2 * x, -2 * y, 2 * zz
        HT = H.T.copy()
        S = _mm(_mm(H, Pt), HT) + va * np.eye(3)
        K = _mm(_mm(Pt, HT), _inv3(S))
        P = _mm(np.eye(4) - _mm(K, H), Pt)
        q = np.empty(4)
        for i in range(4):
            q[i] = qt[i] + K[i, 0] * v0 + K[i, 1] * v1 + K[i, 2] * v2
        q = q / np.sqrt(np.sum(q * q))
        Q[t] = q
    return Q


def ekf_batch(gyro, acc, dt: float, var_gyr, var_acc, q0, steps=None) -> np.ndarray:
    """ahrs ``EKF.update`` (IMU, frame NED, P0 = I) over B records (numba-compiled loop per record).

    gyro, acc (B,N,3) [rad/s], [any scale]; var_gyr, var_acc scalars or (B,) (one setting per record);
    q0 (B,4); steps (N,) [s] the true step ending at each sample (None: ``dt``). Returns Q (B,N,4).
    """
    gyro = np.asarray(gyro, float)
    acc = np.asarray(acc, float)
    B = gyro.shape[0]
    vg = np.broadcast_to(np.asarray(var_gyr, float), (B,))
    va = np.broadcast_to(np.asarray(var_acc, float), (B,))
    q0 = np.broadcast_to(np.asarray(q0, float), (B, 4))
    dts = sample_steps(steps, gyro.shape[1], dt)
    return np.stack([_ekf_loop(np.ascontiguousarray(gyro[b]), np.ascontiguousarray(acc[b]), dts, float(vg[b]),
                               float(va[b]), np.array(q0[b])) for b in range(B)])


# --------------------------------------------------------------------------- VQF
@dataclass(frozen=True)
class VQFParams:
    """VQF settings tuned here (others at ``VQFParams`` defaults): tauAcc [s] 3.0, biasSigmaMotion [°/s] 0.1.

    biasSigmaMotion is the standard deviation of the converged bias-estimate uncertainty during motion (vqf
    ``VQFParams``); ``inf`` is its limit, no trust in the motion bias update: VQF's own
    ``motionBiasEstEnabled = False``. The filter caps the bias uncertainty at biasSigmaInit (0.5 °/s) and clips
    the bias at biasClip (2 °/s), so from about 2 °/s up it runs as with the update off (to 1e-6° here)."""

    tauAcc: float = 3.0
    biasSigmaMotion: float = 0.1


# --------------------------------------------------------------------------- runners
def _prep(gyro, accel, dt, init_s):
    gyro, accel = check_samples(gyro, accel, dt)
    q0 = initial_quat(accel, dt, init_s)
    b0 = initial_bias(gyro, dt, init_s)
    return gyro - b0, -accel, q0


def run_madgwick(gyro, accel, dt: float, params: MadgwickParams = MadgwickParams(), *,
                 init_s: float = 10.0, steps=None) -> AttitudeEstimate:
    """ahrs Madgwick (equivalent loop); gyro (N,3) [rad/s], accel (N,3) [m/s^2], dt [s]; steps (N,) [s] true
    steps (None: ``dt``)."""
    t0 = time.perf_counter()
    g, a, q0 = _prep(gyro, accel, dt, init_s)
    from imutherm.imu.attitude_math import gravity_dir_body

    Q = madgwick_loop(g, a, dt, params.gain, q0, steps=None if steps is None else sample_steps(steps, len(g), dt))
    return estimate_from_gravity("madgwick", gravity_dir_body(Q), np.ones(len(g), bool), time.perf_counter() - t0)


def run_mahony(gyro, accel, dt: float, params: MahonyParams = MahonyParams(), *,
               init_s: float = 10.0, steps=None) -> AttitudeEstimate:
    """ahrs Mahony (equivalent loop); gyro (N,3) [rad/s], accel (N,3) [m/s^2], dt [s]; steps (N,) [s] true
    steps (None: ``dt``)."""
    t0 = time.perf_counter()
    g, a, q0 = _prep(gyro, accel, dt, init_s)
    from imutherm.imu.attitude_math import gravity_dir_body

    Q = mahony_loop(g, a, dt, params.k_P, params.k_I, q0,
                    steps=None if steps is None else sample_steps(steps, len(g), dt))
    return estimate_from_gravity("mahony", gravity_dir_body(Q), np.ones(len(g), bool), time.perf_counter() - t0)


def run_ekf(gyro, accel, dt: float, params: EKFParams = EKFParams(), *, init_s: float = 10.0,
            steps=None) -> AttitudeEstimate:
    """ahrs EKF (IMU, NED; batched equivalent); gyro (N,3) [rad/s], accel (N,3) [m/s^2], dt [s]; steps (N,) [s]
    true steps (None: ``dt``)."""
    return run_ekf_many([gyro], [accel], dt, [params], init_s=init_s, steps=steps)[0]


def run_ekf_many(gyros, accels, dt: float, params_list, *, init_s: float = 10.0, steps=None) -> list[AttitudeEstimate]:
    """Several EKF runs (records of equal length and steps, one EKFParams each) in one vectorised pass."""
    from imutherm.imu.attitude_math import gravity_dir_body

    t0 = time.perf_counter()
    prep = [_prep(g, a, dt, init_s) for g, a in zip(gyros, accels)]
    Q = ekf_batch(np.stack([p[0] for p in prep]), np.stack([p[1] for p in prep]), dt,
                  [p.var_gyr for p in params_list], [p.var_acc for p in params_list], np.stack([p[2] for p in prep]),
                  steps=steps)
    rt = (time.perf_counter() - t0) / len(prep)
    return [estimate_from_gravity("ekf", gravity_dir_body(Q[i]), np.ones(Q.shape[1], bool), rt)
            for i in range(len(prep))]


def run_vqf(gyro, accel, dt: float, params: VQFParams = VQFParams(), *, init_s: float = 10.0) -> AttitudeEstimate:
    """VQF 6D (causal C++ ``VQF.updateBatch``); gyro (N,3) [rad/s], accel (N,3) [m/s^2], dt [s]. VQF takes one
    sampling time, fixed when it is constructed (no per-sample step): an irregular record runs at ``dt``."""
    import vqf

    t0 = time.perf_counter()
    g, a, _ = _prep(gyro, accel, dt, init_s)
    motion = ({"biasSigmaMotion": params.biasSigmaMotion} if math.isfinite(params.biasSigmaMotion)
              else {"motionBiasEstEnabled": False})  # inf: the motion bias update off
    f = vqf.VQF(dt, tauAcc=params.tauAcc, **motion)
    out = f.updateBatch(np.ascontiguousarray(g), np.ascontiguousarray(a))
    from imutherm.imu.attitude_math import gravity_dir_body

    # VQF always applies its low-passed accelerometer correction (no gate): accel_used is all True
    return estimate_from_gravity("vqf", gravity_dir_body(out["quat6D"]), np.ones(len(g), bool),
                                 time.perf_counter() - t0)


# --------------------------------------------------------------------------- the registry's entries

register(FilterSpec("vqf", lambda x, p: run_vqf(x.gyro, x.accel, x.dt, p or VQFParams(), init_s=x.init_s), VQFParams,
                    "peer", "VQF, Laidig & Seel, Information Fusion 91, 2023 (vqf package defaults)", "black",
                    groups={"study", "reference", "real_tuned"}, linestyle=(0, (5, 1, 1, 1, 1, 1)), rank=70,
                    tuning=(Tuned("tauAcc", 1.0, 1000.0, (0.1, 1e5), "tauAcc [s], VQF's accelerometer low-pass time "
                                                                     "constant (its main tuning parameter)"),
                            Tuned("biasSigmaMotion", 0.0316, 1.0, (1e-3, 2.0),
                                  "biasSigmaMotion [deg/s], the converged uncertainty of VQF's motion bias update "
                                  "(package default 0.1), bounded at VQF's biasClip 2 deg/s, the largest bias it "
                                  "admits; inf = the update off (motionBiasEstEnabled false), its limit",
                                  off=(math.inf,)))))
register(FilterSpec("madgwick", lambda x, p: run_madgwick(x.gyro, x.accel, x.dt, p or MadgwickParams(),
                                                          init_s=x.init_s, steps=x.steps), MadgwickParams, "peer",
                    "ahrs Madgwick defaults", "tab:orange", groups={"varying_dt", "real_tuned"}, rank=80,
                    tuning=(Tuned("gain", 3.16e-4, 0.1, (1e-5, 10.0), "gain [rad/s] (published default 0.033)"),)))
register(FilterSpec("mahony", lambda x, p: run_mahony(x.gyro, x.accel, x.dt, p or MahonyParams(), init_s=x.init_s,
                                                      steps=x.steps), MahonyParams, "peer",
                    "ahrs Mahony defaults (k_P 1.0, k_I 0.3), a trap on real motion: every motion profile and "
                    "recorded-log platform runs its tuned setting (studies.attitude.recorded.platform_setting); "
                    "not tuned on the real files, where the guard against its defaults keeps them (24 deg on BROAD "
                    "trial 16)",
                    "tab:pink", groups={"varying_dt", "platform_tuned"}, rank=90,
                    tuning=(Tuned("k_P", 3.16e-3, 1.0, (1e-4, 10.0), "k_P [1/s], k_I [1/s^2] = 0.3 k_P^2 (published "
                                                                    "default (1, 0.3))",
                                  derived={"k_I": lambda k: 0.3 * k * k}),)))
register(FilterSpec("ekf", lambda x, p: run_ekf(x.gyro, x.accel, x.dt, p or EKFParams(), init_s=x.init_s,
                                                steps=x.steps), EKFParams,
                    "peer", "ahrs EKF defaults", "tab:olive", groups={"varying_dt", "real_tuned"}, rank=100,
                    tuning=(Tuned("var_acc", 0.316, 3.16e4, (1e-3, 1e7), "var_acc [-] of the unit gravity vector "
                                                                        "(published default 0.25)"),)))
