"""Liu et al. 2012 motion gate: thresholds from allowed errors, and the gate signals.

The strapdown attitude is corrected toward the accelerometer attitude only when::

    ||f_b| - g0| < σa,   |ω_ib| < σω,   |ω̇_ib| < σω̇

PAPER.md (Liu et al. 2012, §3.2) derives the theoretical thresholds from the allowed
linear-acceleration error ξa and the allowed centripetal / tangential error ξω,
the lever arm d = [dx, dy, dz] from the CG and the turn radius L::

    δF_bx = δF_by = sqrt(((ξa + g)^2 - g^2) / 3),  δF_bz = ξa / 3,  σa = |δF|
    σω = sqrt(ξω / L)
    δω̇_x = ξω / sqrt(3 (dy² + dz²)),  δω̇_y = ξω / sqrt(3 (dx² + dz²)),  δω̇_z = ξω / sqrt(3 (dx² + dy²))
    σω̇ = sqrt(3) · δω̇_y        (strict case dx >> dy, dz)

and each threshold is widened by R(·), the standard deviation of the same
gate signal measured in steady (static) conditions. Liu et al. 2012 write the last
one as ``sqrt(3 δω̇_y)``; we use ``sqrt(3) · δω̇_y``, the dimensionally
consistent reading (PAPER.md's), which has units of angular acceleration.

Gate signals (:func:`gate_signals`) are computed from the samples after a
first-order low-pass of time constant ``tau`` [s] (the sensor noise of Liu et al. 2012's unit
would otherwise keep ``|ω|`` and the differentiated ``|ω̇|`` above any useful
threshold); ``ω̇`` is the backward difference of the low-passed rate.

Real sensors: the rate signal is the **bias-corrected** rate
``|LP(ω) - b|`` (a 0.58 °/s gyro bias would otherwise exceed a 0.55 °/s
threshold forever), and the specific-force signal compares ``|f|`` with the
magnitude the accelerometer itself reads at rest, ``g_ref`` (a real part reads
9.89-9.91 m/s² at rest, 0.1 m/s² above nominal g, which exceeds a 0.08 m/s²
threshold). The widening R(·) is the level the gate signal at rest does not
exceed, ``mean + k std`` over the rest window (:func:`gate_noise_level`, k = 4),
measured at the record's own sample rate: the std alone (Liu et al. 2012's reading)
lies *below* the mean of a positive signal such as ``|LP(ω)|``, so a gate
widened by it alone can stay shut at rest.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from imutherm import InputError
from imutherm.imu.attitude_math import G0


@dataclass(frozen=True)
class GateThresholds:
    """Gate thresholds of Liu et al.'s strapdown filter.

    sigma_a : float [m/s^2]      threshold on ||f| - g0| (theory + noise widening)
    sigma_w : float [rad/s]      threshold on |ω|
    sigma_wdot : float [rad/s^2] threshold on |ω̇|
    theory : (3,) tuple          the un-widened (σa [m/s^2], σω [rad/s], σω̇ [rad/s^2])
    noise_std : (3,) tuple       the widening R(·) added ([m/s^2], [rad/s], [rad/s^2])
    dF_b : (3,) tuple [m/s^2]    δF_bx, δF_by, δF_bz
    dwdot : (3,) tuple [rad/s^2] per-axis angular-acceleration limits δω̇_x, δω̇_y, δω̇_z (inf if undefined)
    """

    sigma_a: float
    sigma_w: float
    sigma_wdot: float
    theory: tuple
    noise_std: tuple
    dF_b: tuple
    dwdot: tuple


def gate_thresholds(xi_a: float, xi_w: float, d, L: float, noise_std=(0.0, 0.0, 0.0),
                    g: float = G0) -> GateThresholds:
    """Gate thresholds from PAPER.md's formulas (Liu et al. 2012, §3.2).

    xi_a : allowed linear-acceleration error ξa [m/s^2] (> 0)
    xi_w : allowed centripetal / tangential acceleration error ξω [m/s^2] (> 0)
    d : (3,) lever arm [dx, dy, dz] of the sensor from the CG [m]
    L : turn / circling radius [m] (> 0)
    noise_std : (R_a [m/s^2], R_w [rad/s], R_wdot [rad/s^2]) std of the gate signals
        measured in steady conditions, added to each threshold
    g : gravity [m/s^2]
    """
    for name, val in (("xi_a", xi_a), ("xi_w", xi_w), ("L", L)):
        if not (isinstance(val, (int, float, np.floating)) and math.isfinite(val) and val > 0):
            raise InputError(f"gate_thresholds: {name}={val!r} is invalid; valid: a positive finite number")
    d = np.asarray(d, float)
    if d.shape != (3,) or not np.all(np.isfinite(d)):
        raise InputError(f"gate_thresholds: d={d!r} is invalid; valid: three finite lever-arm lengths [m]")
    ns = tuple(float(v) for v in noise_std)
    if len(ns) != 3 or any(not math.isfinite(v) or v < 0 for v in ns):
        raise InputError(f"gate_thresholds: noise_std={noise_std!r} is invalid; valid: three finite values >= 0")
    dfx = math.sqrt(((xi_a + g) ** 2 - g**2) / 3.0)
    dfz = xi_a / 3.0
    sa = math.sqrt(2 * dfx**2 + dfz**2)
    sw = math.sqrt(xi_w / L)
    dx, dy, dz = d

    def lim(a, b):
        s = a * a + b * b
        return xi_w / math.sqrt(3.0 * s) if s > 0 else math.inf

    dwd = (lim(dy, dz), lim(dx, dz), lim(dx, dy))
    swd = math.sqrt(3.0) * dwd[1]
    return GateThresholds(
        sigma_a=sa + ns[0], sigma_w=sw + ns[1], sigma_wdot=swd + ns[2],
        theory=(sa, sw, swd), noise_std=ns, dF_b=(dfx, dfx, dfz), dwdot=dwd,
    )


def lowpass_alpha(dt: float, tau: float) -> float:
    """Coefficient α = dt / (τ + dt) of the first-order low-pass y_k = α x_k + (1-α) y_{k-1}."""
    return dt / (tau + dt)


def lowpass(x, alpha):
    """First-order low-pass along axis 0 started at x[0] (y_0 = x_0)."""
    x = np.asarray(x, float)
    beta = 1.0 - alpha
    zi = beta * x[0:1]
    y, _ = lfilter([alpha], [1.0, -beta], x, axis=0, zi=zi)
    return y


def gate_signals(gyro, accel, dt: float, tau: float, g: float = G0, bias=(0.0, 0.0, 0.0)):
    """Gate signals (e_a [m/s^2], e_w [rad/s], e_wdot [rad/s^2]), each (N,).

    e_a = |LP(|f|) - g|, e_w = |LP(ω) - b|, e_wdot = |(LP(ω)_k - LP(ω)_{k-1}) / dt|
    (0 at k = 0), with LP the first-order low-pass of time constant ``tau`` [s].
    gyro (N,3) [rad/s], accel (N,3) [m/s^2], dt [s], g [m/s^2] the |f| reference
    (the rest reading of this accelerometer), bias (3,) [rad/s] the gyro-bias estimate.
    """
    gyro = np.asarray(gyro, float)
    accel = np.asarray(accel, float)
    alpha = lowpass_alpha(dt, tau)
    fn = np.sqrt(accel[:, 0] * accel[:, 0] + accel[:, 1] * accel[:, 1] + accel[:, 2] * accel[:, 2])
    e_a = np.abs(lowpass(fn, alpha) - g)
    w = lowpass(gyro, alpha)
    wc = w - np.asarray(bias, float)
    e_w = np.sqrt(wc[:, 0] * wc[:, 0] + wc[:, 1] * wc[:, 1] + wc[:, 2] * wc[:, 2])
    wd = np.zeros_like(w)
    wd[1:] = (w[1:] - w[:-1]) / dt
    e_wd = np.sqrt(wd[:, 0] * wd[:, 0] + wd[:, 1] * wd[:, 1] + wd[:, 2] * wd[:, 2])
    return e_a, e_w, e_wd


def _rest_signals(gyro, accel, dt, tau, g, bias, skip_s):
    sig = gate_signals(gyro, accel, dt, tau, g, bias)
    k0 = int(round((5 * tau if skip_s is None else skip_s) / dt))
    if len(sig[0]) - k0 < 10:
        raise InputError(f"gate: steady window of {len(sig[0])} samples is too short for tau={tau} s; "
                         "valid: at least 5 tau + 10 samples of rest")
    return [s[k0:] for s in sig]


def gate_noise_std(gyro, accel, dt: float, tau: float, g: float = G0, skip_s: float | None = None,
                   bias=(0.0, 0.0, 0.0)):
    """Standard deviations of the three gate signals over a steady window [m/s^2, rad/s, rad/s^2].

    The first ``skip_s`` [s] (default 5 τ) are skipped so the low-pass start-up does not count.
    """
    return tuple(float(np.std(s)) for s in _rest_signals(gyro, accel, dt, tau, g, bias, skip_s))


#: widening factor k of :func:`gate_noise_level` (a half-normal signal exceeds mean + 4 std on ~0.1 % of samples)
NOISE_K = 4.0


def gate_noise_level(gyro, accel, dt: float, tau: float, g: float = G0, bias=(0.0, 0.0, 0.0),
                     k: float = NOISE_K, skip_s: float | None = None):
    """R(·) used to widen the thresholds: ``mean + k std`` of each gate signal over a window at rest.

    gyro (M,3) [rad/s], accel (M,3) [m/s^2] of the rest window at the record's sample period dt [s];
    g [m/s^2] the |f| reference and bias (3,) [rad/s] estimated from the same window.
    Returns (R_a [m/s^2], R_w [rad/s], R_wdot [rad/s^2]): the level the signals at rest stay below.
    """
    return tuple(float(np.mean(s) + k * np.std(s)) for s in _rest_signals(gyro, accel, dt, tau, g, bias, skip_s))


def rest_reference(gyro, accel, dt: float, init_s: float):
    """(g_ref [m/s^2], bias (3,) [rad/s]) from the first ``init_s`` [s] (the unit at rest):
    the mean |f| this accelerometer reads at rest and the mean gyro rate."""
    n0 = max(1, int(round(init_s / dt)))
    a = np.asarray(accel, float)[:n0]
    return float(np.mean(np.linalg.norm(a, axis=1))), np.mean(np.asarray(gyro, float)[:n0], axis=0)
