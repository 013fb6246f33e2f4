"""Liu et al. 2012 gated strapdown attitude filter, and its ungated complementary baseline.

Quaternion integration of the gyros (trapezoidal rate, exact exponential),
corrected toward the accelerometer's gravity direction with a proportional +
integral (gyro-bias) feedback (Mahony form) **only while the motion gate is
open** (:mod:`imutherm.imu.filters.gate`). The ungated complementary filter is
the same update with the gate always open: the comparison isolates the gate.

The gate is debounced: it opens only after all three conditions have held
for ``hold_s`` [s] without interruption (the end of a manoeuvre is not
instantaneous; the ramp-down of an acceleration would otherwise leak into
the attitude).

Real sensors: the rate condition tests the **bias-corrected** rate
``|LP(ω) - b|`` with the filter's current bias estimate b, the specific-force
condition compares with ``g`` = the |f| this accelerometer reads at rest (see
:func:`imutherm.imu.filters.gate.rest_reference`). Recovery path: if the
specific-force and angular-acceleration conditions have held for
``recover_s`` [s] without interruption while the rate condition still fails
(e.g. the bias changed during a long manoeuvre, so the corrected rate at rest
exceeds σω and the bias loop, which runs only while the gate is open, can
never correct it), the gate opens anyway. Justification: with ``|f| = g`` and
a steady rate the specific force has no linear-acceleration part beyond the
small centripetal ``ω × (ω × d)``; a coordinated turn, the case the rate
condition is for, fails the ``|f|`` condition (load factor 1/cos φ) unless
the bank is below ~8° (|f| - g < σa ≈ 0.09 m/s²), so ``recover_s`` must be
longer than such a shallow turn: 30 s. Measured on ``flight`` (2 seeds):
recover_s = 5 s let shallow turns in (roll / pitch RMS 0.64 / 0.90° instead
of 0.44 / 0.64°); 30 s gives the same figures as no recovery.

Update for sample k (gyro ω_k [rad/s], specific force f_k [m/s^2])::

    ω̄ = (ω_{k-1} + ω_k)/2 - b
    if gate open:  e = m × r  (m = -f/|f|, r = C_bn [0,0,1] from q)
                   ω̄ += kp e;  b -= ki e dt
    q ← normalise(q ⊗ exp(ω̄ dt / 2))

filterpy style: :func:`gated_step` is the procedural step on a frozen
:class:`GatedState`; :class:`GatedStrapdown` and :class:`ComplementaryFilter`
are thin classes over it; :func:`run_gated` / :func:`run_ungated` are the
equivalent tight batch loops (plain floats and ``math``) used by the studies.
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
from imutherm.imu.filters.quat_step import (down_axis_jit, gravity_error, gravity_error_jit, pi_correction,
                                            pi_correction_jit, quat_step, quat_step_jit)
from imutherm.imu.filters.inertial_lp import REST_BIAS_TAU, REST_STATE, REST_TAU, butter2_coeffs, lp3, lp3_init, rest_step
from imutherm.imu.filters.gate import (GateThresholds, lowpass, gate_noise_level, gate_signals, gate_thresholds,
                                      lowpass_alpha, rest_reference)


@dataclass(frozen=True)
class GatedParams:
    """Parameters of the gated strapdown / complementary filter.

    thresholds : GateThresholds | None  gate (None: gate always open = ungated)
    kp : float [1/s]        proportional gain toward the accelerometer attitude
    ki : float [1/s^2]      integral gain (gyro-bias estimate)
    tau : float [s]         low-pass time constant of the gate signals
    hold_s : float [s]      the conditions must hold this long before the gate opens
    g : float [m/s^2]       |f| reference of the ||f| - g| gate (the accelerometer's reading at rest)
    recover_s : float [s]   recovery: open after |f| and ω̇ conditions held this long even if the
                            rate condition fails (inf: never)
    tau_acc : float [s]     0 (default): Liu et al. 2012's per-sample on/off gate as published; > 0: the
                            accelerometer and the rate are low-passed in the estimate's frame
                            (:mod:`imutherm.imu.filters.inertial_lp`) before the gate and the correction,
                            the rate gate tests the low-passed (sustained) rate, on/off, and the |f| and ω̇
                            gates become a gain weight Π min(1, (σ/e)²) (:func:`_lp_core`; ``tau``,
                            ``hold_s``, ``recover_s`` unused)
    gyro_sample : str       'point': a gyro sample is the rate at its instant, the step from k-1 to k
                            integrates (ω_{k-1} + ω_k)/2 (the simulated sensor's samples); 'interval': it is the
                            mean rate over the step ending at it, the step integrates ω_k (what a MEMS gyro's
                            decimation filter outputs and every peer assumes; recorded logs)
    rest_bias : bool        low-pass mode: the bias follows the low-passed gyro while the unit is at rest
                            (VQF's rest detector, :func:`~imutherm.imu.filters.inertial_lp.rest_step`)
    g_at_rest : bool        low-pass mode with ``rest_bias``: the |f| reference g re-read at every rest (the
                            rest detector's low-passed |f|): a biased accelerometer reads another |f| at rest in
                            another orientation, and the |f| weight (σa / e_a)² starved the correction there
                            (issue 57: on a simulated icm42688p tumble gated's vertical sat > 3° off the
                            accelerometer's on 16 windows of rest; none with it)
    turn_gate : bool        low-pass mode: the rate gate tests the sustained **turn** rate, the component of the
                            low-passed rate along the estimate's vertical, |ω̄_I · u_I| (True), not its magnitude
                            |ω̄_I| (False). σω = sqrt(ξω / L) bounds the centripetal acceleration ω v = ω² L of a turn
                            of radius L, a rotation about the vertical; at Liu et al. 2012's moderate attitudes the two
                            are the same while the vehicle turns, but a unit rolled or pitched over (the only way to
                            upside down or vertical) turns about a horizontal axis, carries no such acceleration, and
                            |ω̄_I| shut the correction for the whole manoeuvre (issue 57: a 30 °/s tumble through
                            every orientation without rests, gyro scale factor 1 %, gated 2.0x VQF's inclination RMS,
                            1.07x with it; the stress set holds it)
    """

    thresholds: GateThresholds | None
    kp: float = 0.3
    ki: float = 0.003
    tau: float = 0.1
    hold_s: float = 1.0
    g: float = G0
    recover_s: float = 30.0
    tau_acc: float = 0.0
    gyro_sample: str = "point"
    rest_bias: bool = True
    g_at_rest: bool = True
    turn_gate: bool = True

    def __post_init__(self):
        check_gyro_sample("GatedParams", self.gyro_sample)
        for name in ("kp", "ki", "tau", "hold_s", "g"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0) or (name in ("tau", "g") and v <= 0):
                raise InputError(f"GatedParams: {name}={v!r} is invalid; valid: a finite number >= 0 "
                                 "(tau, g > 0)")
        if not (math.isfinite(self.tau_acc) and self.tau_acc >= 0):
            raise InputError(f"GatedParams: tau_acc={self.tau_acc!r} is invalid; valid: a time constant >= 0 [s] "
                             "(0: Liu et al. 2012's per-sample gate)")
        if not (self.recover_s > 0):
            raise InputError(f"GatedParams: recover_s={self.recover_s!r} is invalid; valid: a number > 0 [s] "
                             "(inf: no recovery)")


@dataclass(frozen=True)
class GatedState:
    """State of the gated strapdown filter.

    q : (4,) [-] attitude body→nav; bias : (3,) [rad/s] gyro-bias estimate;
    prev_gyro : (3,) [rad/s] last gyro sample (None before the first);
    lp_f : float [m/s^2] low-passed |f|; lp_w : (3,) [rad/s] low-passed ω;
    run : int [samples] consecutive samples with all gate conditions true;
    quiet : int [samples] consecutive samples with the |f| and ω̇ conditions true (recovery);
    gate_open : bool, whether the last update used the accelerometer;
    lp : the state vector of :func:`_lp_core` (``tau_acc > 0``; None before the first sample).
    """

    q: tuple
    bias: tuple = (0.0, 0.0, 0.0)
    prev_gyro: tuple | None = None
    lp_f: float | None = None
    lp_w: tuple | None = None
    run: int = 0
    quiet: int = 0
    gate_open: bool = False
    lp: tuple | None = None

    @property
    def gravity(self) -> np.ndarray:
        """(3,) [-] estimated gravity direction in body axes."""
        w, x, y, z = self.q
        return np.array([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)])


def _hold_samples(hold_s: float, dt: float) -> int:
    """Number of samples the gate conditions must already hold before sample k opens it."""
    return int(round(hold_s / dt)) if math.isfinite(hold_s) else 2**62


def debounce(ok, n_hold: int) -> np.ndarray:
    """(N,) bool: True where ``ok`` has been True for more than ``n_hold`` consecutive samples before."""
    ok = np.asarray(ok, bool)
    idx = np.arange(ok.size)
    last_false = np.maximum.accumulate(np.where(~ok, idx, -1))
    run = idx - last_false  # consecutive trues ending at k (0 where ok is False)
    return run > n_hold


def _update(q, b, wbx, wby, wbz, fx, fy, fz, is_open, kp, ki, dt):
    """One attitude update with plain floats; returns (q, b). Used by :func:`gated_step`; the batch loop
    :func:`_loop` inlines the same arithmetic (tested equal: ``run_gated`` equals repeated ``gated_step``)."""
    w, x, y, z = q
    bx, by, bz = b
    wx, wy, wz = wbx - bx, wby - by, wbz - bz
    if is_open:
        fn = math.sqrt(fx * fx + fy * fy + fz * fz)
        mx, my, mz = -fx / fn, -fy / fn, -fz / fn
        ex, ey, ez = gravity_error(w, x, y, z, mx, my, mz)
        wx, wy, wz, bx, by, bz = pi_correction(wx, wy, wz, bx, by, bz, ex, ey, ez, kp, ki, dt)
    return quat_step(w, x, y, z, 0.5 * dt * wx, 0.5 * dt * wy, 0.5 * dt * wz), (bx, by, bz)


def gated_step(state: GatedState, gyro, accel, dt: float, params: GatedParams) -> GatedState:
    """One step of the gated strapdown filter (procedural form).

    state : GatedState; gyro (3,) [rad/s]; accel (3,) [m/s^2] specific force; dt [s];
    params : GatedParams (``thresholds=None`` → ungated). Returns the new state.
    """
    if params.tau_acc > 0:
        S = lp_state0(state.q, state.bias) if state.lp is None else np.array(state.lp)
        _, used, _ = run_lp_core(np.asarray(gyro, float).reshape(1, 3), np.asarray(accel, float).reshape(1, 3),
                                 dt, params, S)
        return replace(state, q=tuple(S[0:4]), bias=tuple(S[4:7]), prev_gyro=tuple(S[34:37]), lp=tuple(S),
                       gate_open=bool(used[0]))
    gx, gy, gz = (float(v) for v in gyro)
    fx, fy, fz = (float(v) for v in accel)
    pg = state.prev_gyro if state.prev_gyro is not None and params.gyro_sample == "point" else (gx, gy, gz)
    wbx, wby, wbz = 0.5 * (pg[0] + gx), 0.5 * (pg[1] + gy), 0.5 * (pg[2] + gz)
    th = params.thresholds
    run, quiet = state.run, state.quiet
    if th is None:
        is_open, lp_f, lp_w = True, state.lp_f, state.lp_w
    else:
        alpha = lowpass_alpha(dt, params.tau)
        beta = 1.0 - alpha
        fn = math.sqrt(fx * fx + fy * fy + fz * fz)
        if state.lp_f is None:
            lp_f, lp_w, old = fn, (gx, gy, gz), (gx, gy, gz)
        else:
            old = state.lp_w
            lp_f = alpha * fn + beta * state.lp_f
            lp_w = (alpha * gx + beta * old[0], alpha * gy + beta * old[1], alpha * gz + beta * old[2])
        e_a = abs(lp_f - params.g)
        b = state.bias
        c0, c1, c2 = lp_w[0] - b[0], lp_w[1] - b[1], lp_w[2] - b[2]
        e_w = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
        d0, d1, d2 = (lp_w[0] - old[0]) / dt, (lp_w[1] - old[1]) / dt, (lp_w[2] - old[2]) / dt
        e_wd = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        ok_aw = e_a < th.sigma_a and e_wd < th.sigma_wdot
        ok = ok_aw and e_w < th.sigma_w
        run = run + 1 if ok else 0
        quiet = quiet + 1 if ok_aw else 0
        is_open = run > _hold_samples(params.hold_s, dt) or quiet > _hold_samples(params.recover_s, dt)
    q, b = _update(state.q, state.bias, wbx, wby, wbz, fx, fy, fz, is_open, params.kp, params.ki, dt)
    return replace(state, q=q, bias=b, prev_gyro=(gx, gy, gz), lp_f=lp_f, lp_w=lp_w, run=run, quiet=quiet,
                   gate_open=is_open)


class GatedStrapdown:
    """Thin class over :func:`gated_step` (Liu et al. 2012 gated strapdown filter).

    params : GatedParams; q0 : (4,) initial quaternion body→nav [-]; bias0 : (3,) [rad/s].
    """

    name = "gated"

    def __init__(self, params: GatedParams, q0, bias0=(0.0, 0.0, 0.0)):
        self.params = params
        self.state = GatedState(q=tuple(float(v) for v in q0), bias=tuple(float(v) for v in bias0))

    def update(self, gyro, accel, dt: float) -> GatedState:
        """Process one sample: gyro (3,) [rad/s], accel (3,) [m/s^2], dt [s]; returns the new state."""
        self.state = gated_step(self.state, gyro, accel, dt, self.params)
        return self.state

    @property
    def gravity(self) -> np.ndarray:
        """(3,) [-] current gravity direction estimate in body axes."""
        return self.state.gravity


class ComplementaryFilter(GatedStrapdown):
    """Ungated complementary filter (baseline): the same update with the gate always open.

    params : GatedParams (its ``thresholds`` are ignored); q0 (4,) [-]; bias0 (3,) [rad/s].
    """

    name = "ungated"

    def __init__(self, params: GatedParams, q0, bias0=(0.0, 0.0, 0.0)):
        super().__init__(replace(params, thresholds=None), q0, bias0)


def _loop(gyro, accel, gate, dts, kp, ki, q0, b0, rate_gate=None, gyro_sample="point"):
    """Tight batch loop of :func:`_update` (inlined, compiled with numba); returns (gravity (N,3), used (N,) bool).

    dts (N,) [s] the step ending at each sample (:func:`~imutherm.imu.filters.common.sample_steps`);
    gate (N,) bool: the accelerometer is used where True. ``rate_gate`` = (lp_w (N,3) [rad/s],
    ok_aw (N,) bool, sigma_w [rad/s], n_hold, n_recover): the gate is instead decided inside the loop
    from the bias-corrected rate |lp_w - b| with the current bias estimate (see :func:`gated_step`).
    """
    n = len(gyro)
    wbar = step_rates(gyro, gyro_sample)
    fn = np.sqrt(accel[:, 0] * accel[:, 0] + accel[:, 1] * accel[:, 1] + accel[:, 2] * accel[:, 2])
    m = -accel / fn[:, None]
    if rate_gate is None:
        lpw, ok_aw, sig_w, n_hold, n_rec = np.zeros((1, 3)), np.zeros(1, bool), 0.0, 0, 0
        gate_in = np.ascontiguousarray(gate, dtype=bool)
    else:
        lpw, ok_aw, sig_w, n_hold, n_rec = rate_gate
        gate_in = np.zeros(n, bool)
    return _loop_core(np.ascontiguousarray(wbar, float), np.ascontiguousarray(m, float), gate_in,
                      rate_gate is not None, np.ascontiguousarray(lpw, float), np.ascontiguousarray(ok_aw, bool),
                      float(sig_w), int(n_hold), int(n_rec), np.asarray(dts, float), float(kp), float(ki),
                      np.asarray(q0, float), np.asarray(b0, float))


@njit(cache=True)
def _loop_core(wbar, m, gate_in, use_rate, lpw, ok_aw, sig_w, n_hold, n_rec, dts, kp, ki, q0, b0):
    """The per-sample loop of :func:`_loop` (scalar arithmetic in the order of :func:`_update`)."""
    n = wbar.shape[0]
    gl = gate_in.copy()
    sw2 = sig_w * sig_w
    run = 0
    quiet = 0
    w, x, y, z = q0[0], q0[1], q0[2], q0[3]
    bx, by, bz = b0[0], b0[1], b0[2]
    out = np.empty((n, 3))
    for k in range(n):
        dt = dts[k]
        hdt = 0.5 * dt
        wx, wy, wz = wbar[k, 0] - bx, wbar[k, 1] - by, wbar[k, 2] - bz
        if use_rate:
            if ok_aw[k]:
                quiet += 1
                c0, c1, c2 = lpw[k, 0] - bx, lpw[k, 1] - by, lpw[k, 2] - bz
                run = run + 1 if c0 * c0 + c1 * c1 + c2 * c2 < sw2 else 0
            else:
                quiet = 0
                run = 0
            gl[k] = run > n_hold or quiet > n_rec
        if gl[k]:
            mx, my, mz = m[k, 0], m[k, 1], m[k, 2]
            ex, ey, ez = gravity_error_jit(w, x, y, z, mx, my, mz)
            wx, wy, wz, bx, by, bz = pi_correction_jit(wx, wy, wz, bx, by, bz, ex, ey, ez, kp, ki, dt)
        w, x, y, z = quat_step_jit(w, x, y, z, hdt * wx, hdt * wy, hdt * wz)
        out[k, 0], out[k, 1], out[k, 2] = down_axis_jit(w, x, y, z)
    return out, gl


def default_thresholds(gyro, accel, dt: float, *, xi_a: float, xi_w: float, d, L: float, tau: float,
                       init_s: float, g: float | None = None, bias=None) -> GateThresholds:
    """Liu et al. 2012 thresholds widened by the gate signals' rest level over the first ``init_s`` [s] (at rest).

    gyro (N,3) [rad/s], accel (N,3) [m/s^2], dt [s], xi_a/xi_w [m/s^2], d (3,) [m], L [m], tau [s];
    g [m/s^2] |f| reference and bias (3,) [rad/s] (None: estimated from the same rest window,
    :func:`rest_reference`). The widening is :func:`gate_noise_level` (mean + 4 std at rest).
    """
    n0 = int(round(init_s / dt))
    g_ref, b_ref = rest_reference(gyro, accel, dt, init_s)
    g = g_ref if g is None else g
    bias = b_ref if bias is None else bias
    noise = gate_noise_level(gyro[:n0], accel[:n0], dt, tau, g, bias)
    return gate_thresholds(xi_a, xi_w, d, L, noise_std=noise, g=G0)


def run_gated(gyro, accel, dt: float, params: GatedParams, q0=None, bias0=None, *, init_s: float = 10.0,
              name: str = "gated", steps=None) -> AttitudeEstimate:
    """Run the gated strapdown filter over a whole record (batch, equals repeated :func:`gated_step`).

    gyro (N,3) [rad/s], accel (N,3) [m/s^2], dt [s], params : GatedParams
    (``thresholds=None`` → gate always open), q0 (4,) [-] initial attitude
    (None → leveling over the first ``init_s`` [s]), bias0 (3,) [rad/s] initial
    gyro-bias estimate (None → mean gyro over the first ``init_s``, the unit at rest); steps (N,) [s] the true
    step ending at each sample of an irregular record (None: ``dt`` throughout): the attitude and bias
    integrate over it, the gates and low-passes keep ``dt`` (:func:`~imutherm.imu.filters.common.sample_steps`).
    """
    gyro, accel = check_samples(gyro, accel, dt)
    dts = sample_steps(steps, len(gyro), dt)
    t0 = time.perf_counter()
    if q0 is None:
        q0 = initial_quat(accel, dt, init_s)
    if bias0 is None:
        bias0 = initial_bias(gyro, dt, init_s)
    th = params.thresholds
    if params.tau_acc > 0:
        if th is not None:
            params = replace(params, thresholds=lp_thresholds(gyro, accel, dt, params, bias0, init_s))
        r, gate, _ = run_lp_core(gyro, accel, dt, params, lp_state0(q0, bias0), steps=dts)
    elif th is None:
        r, gate = _loop(gyro, accel, np.ones(len(gyro), bool), dts, params.kp, params.ki, q0, bias0,
                        gyro_sample=params.gyro_sample)
    else:
        e_a, _, e_wd = gate_signals(gyro, accel, dt, params.tau, params.g)
        lpw = lowpass(gyro, lowpass_alpha(dt, params.tau))
        ok_aw = (e_a < th.sigma_a) & (e_wd < th.sigma_wdot)
        r, gate = _loop(gyro, accel, None, dts, params.kp, params.ki, q0, bias0,
                        (lpw, ok_aw, th.sigma_w, _hold_samples(params.hold_s, dt),
                         _hold_samples(params.recover_s, dt)), gyro_sample=params.gyro_sample)
    return estimate_from_gravity(name, r, gate, time.perf_counter() - t0)


def run_ungated(gyro, accel, dt: float, params: GatedParams, q0=None, bias0=None, *,
                init_s: float = 10.0, steps=None) -> AttitudeEstimate:
    """Ungated complementary baseline: :func:`run_gated` with the gate always open (same gains)."""
    return run_gated(gyro, accel, dt, replace(params, thresholds=None, tau_acc=0.0), q0, bias0, init_s=init_s,
                     name="ungated", steps=steps)


# --------------------------------------------------------------------------- inertial low-pass mode
#: layout of the state vector of :func:`_lp_core`: q (4), bias (3), low-pass of f_I (12), of ω_I (12), previous
#: low-passed ω_I (3), previous gyro (3), started flag (1), strapdown frame q_I (4), rest detector (8), the |f|
#: reference re-read at rest (1; 0: not yet, params.g)
_LP_STATE = 43 + REST_STATE


@njit(cache=True)
def _lp_core(gyro, accel, dts, kp, ki, g, sa, sw, swd, c, S, trap, rest, dt0, g_rest, turn):
    """Liu et al. 2012 strapdown with the accelerometer low-passed in a strapdown frame and a soft gate.

    gyro, accel (N,3) raw samples; S (51,) state (see :data:`_LP_STATE`), updated in place. Per sample: the rate
    ω̄ = (ω_{k-1} + ω_k)/2 - b (``trap``: point samples) or ω_k - b (interval samples); the strapdown frame q_I
    (the gyro alone, bias-corrected, never corrected by the accelerometer: VQF's almost-inertial frame, so the
    low-pass stays outside the correction loop and any tau_acc is stable); f_I = C(q_I) f and ω_I = C(q_I) (ω - b)
    low-passed there (:mod:`imutherm.imu.filters.inertial_lp`, coefficients c); the gate signals of Liu et al. 2012 on
    the low-passed vectors, e_a = ||f̄_I| - g|, e_w = |ω̄_I · u_I| (``turn``: the turn rate about the
    estimate's vertical u_I = C(q_I) C(q)ᵀ [0, 0, 1]; else |ω̄_I|), e_ẇ = |Δω̄_I| / dt; gain weight
    w = min(1, (σa / e_a)²) min(1, (σω̇ / e_ẇ)²), and w = 0 while e_w > σω (a sustained turn: the apparent vertical
    is not the vertical); the PI correction of Liu et al. 2012 toward m = -C(q_I)ᵀ f̄_I / |f̄_I| with kp w and ki w (the
    bias in motion); at rest (``rest``: :func:`~imutherm.imu.filters.inertial_lp.rest_step`) the bias follows the
    low-passed gyro with REST_BIAS_TAU (the bias at rest). dts (N,) [s] the step ending at each sample; dt0 [s] the
    design step of the rest detector. Returns (gravity (N,3), used (N,) = w >= 0.5, w (N,)).
    """
    n = gyro.shape[0]
    out = np.empty((n, 3))
    used = np.zeros(n, np.bool_)
    wt = np.empty(n)
    w, x, y, z = S[0], S[1], S[2], S[3]
    bx, by, bz = S[4], S[5], S[6]
    qw, qx, qy, qz = S[38], S[39], S[40], S[41]
    if g_rest and S[42 + REST_STATE] > 0.0:  # the |f| reference read at an earlier rest
        g = S[42 + REST_STATE]
    ra = dt0 / (REST_TAU + dt0)
    for k in range(n):
        dt = dts[k]
        hdt = 0.5 * dt
        gx, gy, gz = gyro[k, 0], gyro[k, 1], gyro[k, 2]
        fx, fy, fz = accel[k, 0], accel[k, 1], accel[k, 2]
        if S[37] == 0.0:
            S[34], S[35], S[36] = gx, gy, gz
        if rest:
            at_rest, lgx, lgy, lgz = rest_step(S, 42, gx, gy, gz, fx, fy, fz, ra, dt0)
            if at_rest:
                if g_rest:  # the |f| reference re-read in this orientation (issue 57: a biased accelerometer's
                    # |f| at rest moves with the attitude, and the |f| weight then starved the correction at rest)
                    g = math.sqrt(S[45] * S[45] + S[46] * S[46] + S[47] * S[47])
                    S[42 + REST_STATE] = g
                kr = dt / REST_BIAS_TAU
                bx, by, bz = bx + kr * (lgx - bx), by + kr * (lgy - by), bz + kr * (lgz - bz)
        if trap:
            wx, wy, wz = 0.5 * (S[34] + gx) - bx, 0.5 * (S[35] + gy) - by, 0.5 * (S[36] + gz) - bz
        else:
            wx, wy, wz = gx - bx, gy - by, gz - bz
        S[34], S[35], S[36] = gx, gy, gz
        # strapdown frame q_I <- q_I ⊗ exp(ω̄ dt / 2) (the gyro alone)
        qw, qx, qy, qz = quat_step_jit(qw, qx, qy, qz, hdt * wx, hdt * wy, hdt * wz)
        c00, c01, c02 = 1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qw * qz), 2 * (qx * qz + qw * qy)
        c10, c11, c12 = 2 * (qx * qy + qw * qz), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qw * qx)
        c20, c21, c22 = 2 * (qx * qz - qw * qy), 2 * (qy * qz + qw * qx), 1 - 2 * (qx * qx + qy * qy)
        fn0, fn1, fn2 = c00 * fx + c01 * fy + c02 * fz, c10 * fx + c11 * fy + c12 * fz, c20 * fx + c21 * fy + c22 * fz
        ux, uy, uz = gx - bx, gy - by, gz - bz
        wn0, wn1, wn2 = c00 * ux + c01 * uy + c02 * uz, c10 * ux + c11 * uy + c12 * uz, c20 * ux + c21 * uy + c22 * uz
        if S[37] == 0.0:
            lp3_init(S, 7, fn0, fn1, fn2)
            lp3_init(S, 19, wn0, wn1, wn2)
            S[31], S[32], S[33] = wn0, wn1, wn2
            S[37] = 1.0
        lf = lp3(S, 7, fn0, fn1, fn2, c)
        lw = lp3(S, 19, wn0, wn1, wn2, c)
        e_a = abs(math.sqrt(lf[0] * lf[0] + lf[1] * lf[1] + lf[2] * lf[2]) - g)
        if turn:  # the turn rate: the sustained rate's component along the estimate's vertical in the I frame
            rbx, rby, rbz = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
            ux = c00 * rbx + c01 * rby + c02 * rbz
            uy = c10 * rbx + c11 * rby + c12 * rbz
            uz = c20 * rbx + c21 * rby + c22 * rbz
            e_w = abs(lw[0] * ux + lw[1] * uy + lw[2] * uz)
        else:
            e_w = math.sqrt(lw[0] * lw[0] + lw[1] * lw[1] + lw[2] * lw[2])
        d0, d1, d2 = (lw[0] - S[31]) / dt, (lw[1] - S[32]) / dt, (lw[2] - S[33]) / dt
        e_wd = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        S[31], S[32], S[33] = lw[0], lw[1], lw[2]
        q_w = 1.0
        if e_a > sa:
            q_w *= (sa / e_a) ** 2
        if e_w > sw:
            q_w = 0.0  # a sustained turn: Liu et al. 2012's on/off rate gate on the low-passed rate
        if e_wd > swd:
            q_w *= (swd / e_wd) ** 2
        wt[k] = q_w
        used[k] = q_w >= 0.5
        # measurement in body axes: C(q_I)ᵀ f̄_I
        mbx = c00 * lf[0] + c10 * lf[1] + c20 * lf[2]
        mby = c01 * lf[0] + c11 * lf[1] + c21 * lf[2]
        mbz = c02 * lf[0] + c12 * lf[1] + c22 * lf[2]
        mn = math.sqrt(mbx * mbx + mby * mby + mbz * mbz)
        if mn > 0.0 and q_w > 0.0:
            mx, my, mz = -mbx / mn, -mby / mn, -mbz / mn
            ex, ey, ez = gravity_error_jit(w, x, y, z, mx, my, mz)
            wx, wy, wz, bx, by, bz = pi_correction_jit(wx, wy, wz, bx, by, bz, ex, ey, ez, kp * q_w, ki * q_w, dt)
        w, x, y, z = quat_step_jit(w, x, y, z, hdt * wx, hdt * wy, hdt * wz)
        out[k, 0], out[k, 1], out[k, 2] = down_axis_jit(w, x, y, z)
    S[0], S[1], S[2], S[3] = w, x, y, z
    S[4], S[5], S[6] = bx, by, bz
    S[38], S[39], S[40], S[41] = qw, qx, qy, qz
    return out, used, wt


def lp_thresholds(gyro, accel, dt, params: "GatedParams", bias, init_s: float) -> GateThresholds:
    """The thresholds of ``params`` with the rate threshold's widening R_ω re-measured on the signal the
    low-pass mode tests: |LP(ω - b)| (second-order, ``tau_acc``) over the rest window ``init_s`` [s], mean +
    4 std after its first 2 tau_acc (at rest the estimate's frame does not turn, so the body-frame low-pass is
    the same signal)."""
    from scipy.signal import lfilter

    th = params.thresholds
    n0 = max(2, int(round(init_s / dt)))
    c = butter2_coeffs(params.tau_acc, dt)
    x = np.asarray(gyro, float)[:n0] - np.asarray(bias, float)
    y = lfilter(c[:3], np.r_[1.0, c[3:]], x, axis=0)
    e = np.linalg.norm(y[min(n0 - 1, int(2 * params.tau_acc / dt)):], axis=1)
    rw = float(e.mean() + 4.0 * e.std())
    return replace(th, sigma_w=th.theory[1] + rw, noise_std=(th.noise_std[0], rw, th.noise_std[2]))


def lp_state0(q0, b0) -> np.ndarray:
    """Initial state vector of :func:`_lp_core` (attitude q0 (4,) [-], bias b0 (3,) [rad/s]); the strapdown frame
    starts at q0."""
    S = np.zeros(_LP_STATE)
    S[0:4] = np.asarray(q0, float)
    S[4:7] = np.asarray(b0, float)
    S[38:42] = np.asarray(q0, float)
    return S


def run_lp_core(gyro, accel, dt, params: "GatedParams", S, steps=None):
    """:func:`_lp_core` with ``params`` (its thresholds; inf where None = ungated) and the low-pass designed at
    ``dt`` [s]; steps (N,) [s] the true steps (None: ``dt``); returns its outputs."""
    th = params.thresholds
    sa, sw, swd = (math.inf,) * 3 if th is None else (th.sigma_a, th.sigma_w, th.sigma_wdot)
    return _lp_core(np.ascontiguousarray(gyro, float), np.ascontiguousarray(accel, float),
                    sample_steps(steps, len(gyro), dt),
                    float(params.kp), float(params.ki), float(params.g), float(sa), float(sw), float(swd),
                    butter2_coeffs(params.tau_acc, dt), S, params.gyro_sample == "point", bool(params.rest_bias),
                    float(dt), bool(params.g_at_rest), bool(params.turn_gate))


# --------------------------------------------------------------------------- the registry's entries

def _gyro_sample(p, x):  # the record's gyro sample convention into our filters' params
    return replace(p, gyro_sample=x.gyro_sample)


def gate_design(x) -> GatedParams:
    """``gated``'s params on the record ``x`` (FilterInputs): the rest window's thresholds and |f| reference
    with the gains of its GateConfig (``kp_lp`` in the low-pass mode, ``tau_acc`` > 0)."""
    g = x.gate
    return GatedParams(x.thresholds, kp=g.kp_lp if g.tau_acc > 0 else g.kp, ki=g.ki, tau=g.tau, hold_s=g.hold_s,
                       g=x.g_ref, recover_s=g.recover_s, tau_acc=g.tau_acc)


def ungated_design(x) -> GatedParams:
    """``ungated``'s params on ``x``: ``gated``'s with the plain seed gain ``kp`` of the GateConfig."""
    return replace(gate_design(x), kp=x.gate.kp)


def _run_gated_spec(x, p):
    return run_gated(x.gyro, x.accel, x.dt, _gyro_sample(p or gate_design(x), x), init_s=x.init_s, steps=x.steps)


def _run_ungated_spec(x, p):
    return run_ungated(x.gyro, x.accel, x.dt, _gyro_sample(p or ungated_design(x), x), init_s=x.init_s,
                       steps=x.steps)


register(FilterSpec("gated", _run_gated_spec, GatedParams, "ours",
                    "Liu et al. 2012 gated strapdown (PAPER.md §3.2); GateConfig", "tab:blue", base=gate_design,
                    groups={"study", "sweep", "varying_dt", "real_tuned"}, rank=10,
                    tuning=(Tuned("tau_acc", 1.0, 31.6, (0.1, 1000.0), "tau_acc [s]; 0 = Liu et al. 2012's per-sample "
                                  "gate", off=(0.0,)),
                            Tuned("kp", 0.0316, 1.0, (1e-3, 10.0), "kp [1/s] the correction gain (kp_lp in the "
                                                                   "low-pass mode)"))))
register(FilterSpec("ungated", _run_ungated_spec, GatedParams, "ours",
                    "Liu et al. 2012 update with the gate always open (baseline)", "tab:gray",
                    base=ungated_design, groups={"study", "varying_dt", "real_tuned"}, linestyle=":", rank=30,
                    tuning=(Tuned("kp", 1e-3, 1.0, (1e-4, 10.0), "kp [1/s], ki [1/s^2] = kp^2 / 30 along Liu et al. "
                                                                 "2012's ratio (0.3, 0.003), the gate always open",
                                  derived={"ki": lambda kp: kp * kp / 30.0}),)))
