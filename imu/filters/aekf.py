"""Adaptive error-state EKF (Wang et al.'s "intelligent KF"), with or without GNSS velocity aiding.

Wang et al. tunes the EKF's Q and R online with a neural network and a fuzzy
controller whose rules and weights it does not publish; we use two published
adaptation laws instead:

* **R: the Sage-Husa fading-memory estimator** (A. P. Sage, G. W. Husa,
  "Adaptive filtering with unknown prior statistics", JACC 1969; the fading
  form with forgetting factor b as in most INS/GNSS texts):
  ``R_k = Ĉ_ν,k - (H P⁻ Hᵀ)‾_k`` with fading means ``x̄_k = b x̄_{k-1} + (1 - b) x_k``
  of ``ν νᵀ`` and ``H P⁻ Hᵀ`` (averaging before subtracting keeps R positive; the
  per-sample form ``(1 - d) R + d (ν νᵀ - H P⁻ Hᵀ)`` collapsed to the floor and
  diverged here), ``b = 1 - T_meas / memory_s``, the means started from the
  initial R (so d is constant, not Sage-Husa's ``(1 - b)/(1 - b^(k+1))``, which
  assumes no prior), kept diagonal and floored at ``r_floor``. Both laws adapt
  only on consecutive updates (after a gated gap P⁻ is not in steady state).
  R is held at its measured start over the rest window ``init_s`` and adapted
  after it: there P⁻ falls from its 1° start, H P⁻ Hᵀ >> ν νᵀ (the leveling is
  far better than 1°) and the difference, noise of size d H P⁻ Hᵀ, drove R to
  the floor and the filter into rejecting its own rest samples once the block
  mean below made R ten times smaller.
* **the direction of f, and |f| re-read at rest** (issue 57): the gravity update uses the measured specific
  force scaled to |g| (``dir_only``), so |f| - g does not tilt the estimate, and at every rest (VQF's rest
  detector) the |f| reference of the gate is the rest reading of that orientation.
* **R bounded, divergence monitored** (issue 57): the adapted R stays within ``[r_min_x, r_max_x]`` times the
  accelerometer noise measured on the rest window. Unbounded, it ran away on slow turns through upside down
  and vertical: a correlated attitude error (a degree, normal while turning) read as noise raised R, the
  accelerometer was trusted less, the error grew (a simulated 5-20 °/s tumble,
  :mod:`imutherm.studies.attitude.filter_stress`: 18° inclination RMS, 72° peak; bounded 0.7°, VQF 0.6°), while on other
  axes R fell to its 1e-8 floor. In the low-pass mode a **NIS monitor** (windowed mean of νᵀ S_m⁻¹ ν over the
  quasi-static updates, S_m with the accelerometer allowed ``monitor_deg`` of error) declares divergence above the
  chi-square bound, re-levels the attitude on the measured vertical, resets P's attitude block and R, and reports the
  sample (``AttitudeEstimate.resets``); the block-mean mode keeps its own chi-square gate and re-level (reported too).
* **Q: autocovariance least squares** (Odelson, Rajamani, Rawlings, Automatica 42, 2006;
  :mod:`imutherm.imu.filters.noise_als`): on every stretch of rest (SHOE detector, Skog et al. 2010) of at
  least ``als_window_s``, the gyro white-noise density² ``q_g`` is re-estimated from the autocovariances of
  the accelerometer's tilt innovations at the end of each further ``als_window_s`` of rest (from the
  stretch's start: a growing window) and set into Q from the next sample on (causal: what a real-time
  filter would have by then). The bias random walk is not adapted. An earlier law, innovation-based
  covariance matching (Mohamed & Schwarz, J. Geodesy 73, 1999: ``Q̂ = K Ĉ_ν Kᵀ``), did not converge here:
  with the accelerometer measured every sample the gain is small and that law is neutral to first order in
  K (it drifted to 1.2-2.6× the true gyro noise in 600 s at rest, 10-25× with GNSS); it was removed.

Wang et al. starts both from Allan variance; we start them from the rest
window (the sample variance of gyro and accelerometer over the first
``init_s`` [s], i.e. the Allan variance at one sample) unless given.

States (error = true - estimate): attitude ``φ`` (NED, ``C_true = (I + [φ×]) C_est``),
velocity ``δv`` [m/s] (NED), gyro bias ``δb`` [rad/s]::

    φ̇ = -C_nb δb - C_nb n_g      δv̇ = -[(C_nb f)×] φ - C_nb n_a      δḃ = n_b

* ``aekf`` (no GNSS): the accelerometer is the measurement of gravity,
  ``f = -C_bn g_n`` (``|g_n|`` = the accelerometer's rest reading), as the mean
  over blocks of ``accel_avg_s`` (0.1 s: 10 samples at 100 Hz), one update per
  block. The mean is rotation-compensated (the running sum is rotated with each
  gyro increment, so it is the block's specific force in the current body
  frame: the accelerometer low-passed in a gyro-stabilised frame, as VQF does,
  Laidig & Seel, Information Fusion 91, 2023; averaging the specific force
  against vibration as in leveling, Groves, Principles of GNSS, Inertial and
  Multisensor Integrated Navigation Systems, 2nd ed., 2013, §5.6). An
  N-sample mean nulls every line at multiples of fs/N (10 Hz here: the
  aircraft's 80 / 160 / 240 Hz lines read at 100 Hz alias to 20 / 40 Hz) and
  divides broadband noise variance by N; R is that of one block mean (measured
  on the rest window's blocks). Per sample, the aircraft vibration (σ|f| 0.57
  m/s² at rest) kept ||f| - g| above the gate on most samples (3-6 % used on
  the flight) and the few that passed pulled the bias state (flight seeds 2 / 3: 29 / 25° roll RMS;
  with the block mean 0.5 / 0.4°);
  ``H_φ = -C_bn [g_n×]``. Short accelerations raise the innovation and
  Sage-Husa raises R. A sustained one (a coordinated turn: the apparent
  vertical is the body z axis) is coloured, not noise: the filter follows it
  and its bias state absorbs the difference (roll errors of tens of degrees
  after a 17° turn on the flight profile without it), so a sample updates only
  when ``||f| - g| < accel_gate`` (A. M. Sabatini, "Quaternion-based extended
  Kalman filter for determining orientation by inertial and magnetic
  sensing", IEEE TBME 53(7), 2006: measurement skipped under acceleration).
  A horizontal acceleration changes |f| only to second order (1.4 m/s² passes
  a 0.1 m/s² test and tilts the apparent vertical by 8°), so the innovation
  must also pass a chi-square test with the adapted S (the horizontal-attitude KF paper's gate 2 in
  its statistical form), with a re-level after ``reject_timeout_s`` of
  rejections. The adaptation therefore estimates the noise of the samples the
  filter uses; the gates, not R, keep the manoeuvres out. Given the lever arm
  (``run_aekf(lever_arm=...)``, which ``run_filters`` passes), the accelerometer's
  lever-arm term (:func:`imutherm.imu.filters.common.lever_arm_accel`) is removed
  first: on the swing profile it passed the |f| gate where perpendicular to
  gravity and, one-signed after the chi-square test, pulled the bias state
  (2.2° roll RMS without the correction, 0.5° with it).
  Heading is not observable; the velocity states are propagated but not
  observed.
* ``aekf_gnss``: the accelerometer drives the velocity ``v̇ = C_nb f + g_n``
  and the GNSS velocity (:mod:`imutherm.imu.gnss`) is the measurement,
  ``H = [0 I 0]``, at the receiver's rate; acceleration no longer disturbs
  the attitude, and heading becomes observable when the vehicle accelerates
  horizontally. R is the GNSS velocity noise, adapted the same way.

Initial attitude: leveling over the rest window, yaw 0 (the true start heading
of every profile here, as a magnetometer or the GNSS course would give it;
P0 yaw (5°)²); initial bias the rest-window mean rate.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np
from imutherm.lazy_jit import njit

from imutherm.imu.filters.registry import FilterSpec, Tuned, register
from imutherm import InputError
from imutherm.imu.filters.noise_als import NoiseEstimate, als_noise, stationary_segments
from imutherm.imu.filters.common import (AttitudeEstimate, check_gyro_sample, check_samples, initial_bias,
                                        initial_quat, lever_arm_accel, sample_steps)
from imutherm.imu.filters.inertial_lp import REST_STATE, REST_TAU, rest_step
from imutherm.imu.filters.aekf_math import (align_rotation, hpht, joseph_update, mm3, mv3,  # noqa: F401
                                            mat_mul, orthonormalise, propagate_cov, record_reset,
                                            reset_attitude, rotvec_dcm, skew)


@dataclass(frozen=True)
class AEKFParams:
    """Settings of the adaptive EKF.

    memory_s : float [s]            fading-memory time constant of both adaptation laws (b = 1 - dt_meas/memory_s)
    gyro_density0 : float | None [rad/s/sqrt(Hz)]  initial gyro white-noise density (None: rest-window std / sqrt(fs))
    accel_std0 : float | None [m/s^2]  initial accelerometer measurement std (None: rest-window std)
    gnss_std0 : float [m/s]         initial GNSS velocity measurement std
    bias_rw : float [rad/s/sqrt(s)] gyro-bias random walk (not adapted)
    accel_density : float [m/s^2/sqrt(Hz)]  velocity process noise (GNSS variant)
    adapt_q, adapt_r : bool         switch the adaptation laws off (plain EKF) for comparison
    als_window_s : float [s]        rest needed for an ALS estimate of the gyro noise (and between estimates)
    r_floor : float [unit^2]        floor of the adapted R diagonal
    accel_gate : float [m/s^2]      no-GNSS variant: a sample updates only if ||f| - g| < accel_gate
                                    (Sabatini 2006's acceleration test; inf: never skip)
    innov_gate : float [-]          no-GNSS variant: a sample updates only if νᵀ S⁻¹ ν < innov_gate (default the
                                    99.9 % point of chi-square with 3 dof)
    reject_timeout_s : float [s]    after this much time of innovation rejections the filter re-levels
                                    (attitude covariance reset to (10°)², as the horizontal-attitude KF paper's filter does here)
    accel_avg_s : float [s]         no-GNSS variant: the accelerometer is averaged over blocks of
                                    N = round(accel_avg_s / dt) samples (rotation-compensated) before the gate and
                                    the gravity update, one update per block (≤ 1.5 dt: every sample, no averaging)
    tau_acc : float [s]             0 (default): the block mean above; > 0 (no-GNSS variant): the measurement is
                                    the specific force low-passed in the gyro-propagated body frame (the
                                    second-order filter of :mod:`imutherm.imu.filters.inertial_lp`, its state
                                    vectors rotated with each gyro increment: VQF's low-pass in an almost-inertial
                                    frame), one update per ``lp_update_s`` (0: every sample), and the |f| gate
                                    becomes a variance inflation R / w, w = min(1, (accel_gate / e_a)²) (R is
                                    not adapted on inflated updates); no chi-square innovation test: the
                                    low-passed measurement's error is slow and correlated, not the white noise
                                    the test assumes, so the test rejected whole stretches and re-levelled
                                    (on the nine real development files at tau_acc 3.16 s its mean inclination
                                    RMS was 5.8° with the test, 2.6° without)
    lp_update_s : float [s]         update period of the low-pass mode
    sf_std : float [-]              gyro scale-factor uncertainty: the attitude process noise grows by
                                    (sf_std |ω|)² [rad²/s] (0: none)
    gyro_sample : str               'point' (trapezoid) or 'interval' (ω_k over the step ending at k): what a gyro
                                    sample is (:data:`~imutherm.imu.filters.common.GYRO_SAMPLES`)
    rest_bias : bool                low-pass mode: while the unit is at rest (VQF's rest detector,
                                    :func:`~imutherm.imu.filters.inertial_lp.rest_step`) each gyro sample updates the
                                    bias state as a zero-rate measurement (ZARU; Groves 2013, §15.3), variance the
                                    gyro noise density² / dt
    r_min_x, r_max_x : float [-]    no-GNSS: bounds of the adapted R, these multiples of the accelerometer noise
                                    measured on the rest window (its block means), never below ``r_floor`` (with
                                    GNSS: r_floor to (100 gnss_std0)²). Unbounded, the adaptation ran
                                    away on slow turns through upside down (issue 57: the innovation of a correlated
                                    attitude error read as noise, R raised, the accelerometer trusted less, the error
                                    grown: 18° RMS on a simulated tumble, 0.6° bounded)
    monitor_deg : float [deg]       NIS monitor: the innovations are tested against S = H P Hᵀ + (g tan
                                    monitor_deg)² I, not the adapted R: "is the vertical off by more than the
                                    accelerometer's few-degree error under handheld motion", not "is R right" (the
                                    low-pass mode's measurement error is correlated, so the adapted R flags healthy
                                    runs, and an R that ran away hides a diverged one)
    dir_only : bool                 no-GNSS: the accelerometer measures the vertical's direction only (the block mean
                                    or low-passed f scaled to |g| before the innovation, as the kf and VQF
                                    normalise it). With |f| measured too, |f| - g (a consumer part's 10 mg bias
                                    moves |f| at rest by 0.3 m/s² between upright and upside down) leaked into the
                                    tilt through the anisotropic adapted R: 12° off at rest upside down, 17° RMS on
                                    a simulated tumble (0.75° with the direction, VQF 0.79°)
    nis_window_s : float [s]        NIS monitor: the mean NIS of the quasi-static updates (weight 1) over each window
                                    of this length; above the 99.9 % point of chi-square with 3 dof (``innov_gate``,
                                    the bound of a single update, which correlated updates cannot exceed by chance
                                    more often) the filter has diverged: attitude covariance reset to (10°)² and R to
                                    its start, the sample reported (:attr:`AEKFTrace.resets`,
                                    ``AttitudeEstimate.resets``); inf: no monitor
    """

    memory_s: float = 5.0
    gyro_density0: float | None = None
    accel_std0: float | None = None
    gnss_std0: float = 0.1
    bias_rw: float = 3e-5
    accel_density: float = 0.05
    adapt_q: bool = True
    adapt_r: bool = True
    als_window_s: float = 60.0
    r_floor: float = 1e-8
    accel_gate: float = 0.1
    innov_gate: float = 16.27
    reject_timeout_s: float = 20.0
    accel_avg_s: float = 0.1
    tau_acc: float = 0.0
    lp_update_s: float = 0.0
    sf_std: float = 0.0
    gyro_sample: str = "point"
    rest_bias: bool = True
    r_min_x: float = 0.1
    r_max_x: float = 10.0
    monitor_deg: float = 2.0
    nis_window_s: float = 10.0
    dir_only: bool = True

    def __post_init__(self):
        check_gyro_sample("AEKFParams", self.gyro_sample)
        for name in ("r_min_x", "r_max_x", "monitor_deg", "nis_window_s"):
            v = getattr(self, name)
            if not (v > 0) or math.isnan(v) or (name == "monitor_deg" and v >= 90.0):
                raise InputError(f"AEKFParams: {name}={v!r} is invalid; valid: a positive number (monitor_deg < 90, "
                                 "nis_window_s inf: no monitor)")
        if not self.r_min_x <= 1.0 <= self.r_max_x:
            raise InputError(f"AEKFParams: r_min_x={self.r_min_x!r}, r_max_x={self.r_max_x!r} are invalid; valid: "
                             "r_min_x <= 1 <= r_max_x")
        for name in ("memory_s", "gnss_std0", "bias_rw", "accel_density", "r_floor", "accel_gate", "innov_gate",
                     "reject_timeout_s", "als_window_s", "accel_avg_s"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise InputError(f"AEKFParams: {name}={v!r} is invalid; valid: a positive number")
        for name in ("tau_acc", "lp_update_s", "sf_std"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v >= 0):
                raise InputError(f"AEKFParams: {name}={v!r} is invalid; valid: a number >= 0")
        for name in ("gyro_density0", "accel_std0"):
            v = getattr(self, name)
            if v is not None and not (np.isfinite(v) and v > 0):
                raise InputError(f"AEKFParams: {name}={v!r} is invalid; valid: a positive number or None")


@dataclass(frozen=True)
class AEKFTrace:
    """Adaptation history of one run: t_idx (M,) sample index of each update, R (M,3) [unit^2] adapted
    measurement-noise diagonal (unit = m/s^2 without GNSS, m/s with), q_gyro (M,) [(rad/s)^2/Hz] adapted gyro
    noise density² after each measurement (accepted or not), yaw (N,) [rad] heading estimate, bias (N,3) [rad/s]
    gyro-bias estimate; resets (K,) sample index of each reset (NIS monitor or re-level); nis: (window end
    sample (W,), window mean NIS (W,)) of the NIS monitor; als: the ALS estimates
    (:class:`imutherm.imu.filters.noise_als.NoiseEstimate`, the window
    [start, end) each used; q_gyro set into Q from sample ``end`` on)."""

    t_idx: np.ndarray
    R: np.ndarray
    q_gyro: np.ndarray
    yaw: np.ndarray
    bias: np.ndarray
    als: tuple = ()
    resets: np.ndarray | None = None
    nis: tuple = ()


@njit(cache=True)
def _aekf_loop(gyro, accel, dt, dts, C0, b0, g, qg0, r0, rbw, qa, memory_s, q_idx, q_val, adapt_r, r_floor,
               use_gnss, gidx, gvel, p0_yaw, accel_gate, innov_gate, reject_timeout, n_avg, n_hold, lpc, sf2,
               trap, rest, r_hi, nis_win, nis_hi, r_mon, dir_only):
    n = gyro.shape[0]
    rst = np.zeros(REST_STATE)  # rest detector (rest: a zero-rate update of the bias state at rest)
    ra = dt / (REST_TAU + dt)
    Hz = np.zeros((3, 9))
    for i in range(3):
        Hz[i, 6 + i] = 1.0
    C = C0.copy()
    b = b0.copy()
    v = np.zeros(3)
    if use_gnss and gidx.shape[0] > 0:
        v = gvel[0].copy()
    P = np.zeros((9, 9))
    P[0, 0] = P[1, 1] = (1.0 * np.pi / 180.0) ** 2
    P[2, 2] = p0_yaw
    for i in range(3, 6):
        P[i, i] = 0.1 ** 2
    for i in range(6, 9):
        P[i, i] = (0.05 * np.pi / 180.0) ** 2
    gn = np.array([0.0, 0.0, g])
    qg = qg0
    R = np.full(3, min(max(r0, r_floor), r_hi))
    r_start = R[0]
    Cv = np.zeros(3)  # Sage-Husa fading means of ν νᵀ and H P⁻ Hᵀ (diagonals)
    Hm = np.zeros(3)
    nis_s = 0.0  # NIS monitor: sum and count of the window's quasi-static updates
    nis_n = 0
    n_reset = 0
    n_per = 1
    if use_gnss and gidx.shape[0] > 1:
        n_per = gidx[1] - gidx[0]
    if not use_gnss:
        n_per = n_avg
    d = n_per * dt / memory_s  # fading weight per update: b = 1 - d
    if d > 0.5:
        d = 0.5
    m_max = gidx.shape[0] if use_gnss else n // n_avg + 1
    resets = np.empty(m_max + 1, np.int64)  # sample of each reset (NIS monitor or re-level), one a measurement at most
    nis_k = np.empty(m_max // max(1, nis_win) + 1, np.int64)  # NIS monitor: window end sample, window mean NIS
    nis_v = np.empty(m_max // max(1, nis_win) + 1)
    n_nis = 0
    fsum = np.zeros(3)  # no-GNSS: sum of the block's specific force, in the current body frame
    use_lp = lpc.shape[0] == 5 and not use_gnss
    lps = np.zeros((4, 3))  # low-pass state (x1, x2, y1, y2) in the current body frame (inertial low-pass mode)
    for i in range(4):
        lps[i] = accel[0]
    wgt = 1.0
    cnt = 0
    out_C = np.empty((n, 3, 3))
    out_b = np.empty((n, 3))
    t_idx = np.empty(m_max, np.int64)
    R_hist = np.empty((m_max, 3))
    q_hist = np.empty(m_max)
    used = np.zeros(n, np.bool_)
    m = 0
    rej_t = 0.0
    fresh = True
    gk = 0
    last_m = -1
    qj = 0
    I9 = np.eye(9)
    G = np.empty((6, 9))   # F P's non-zero rows (propagate_cov's work space)
    Hp = np.empty((6, 6))  # F P F^T's non-zero block
    for k in range(n):
        if qj < q_idx.shape[0] and q_idx[qj] == k:  # an ALS estimate of the gyro noise is ready
            qg = q_val[qj]
            qj += 1
        if k > 0:
            h = dts[k]  # the step from sample k-1 to k (dt: the design step of the blocks, memory and timers)
            w = (0.5 * (gyro[k - 1] + gyro[k]) if trap else gyro[k]) - b
            f = 0.5 * (accel[k - 1] + accel[k])
            Cf = mv3(C, f)
            Rk = rotvec_dcm(w * h)
            C = mm3(C, Rk)
            if not use_gnss:
                fsum = mv3(Rk.T, fsum)  # a nav-fixed vector seen from the rotated body
                if use_lp:
                    for i in range(4):
                        lps[i] = mv3(Rk.T, lps[i])
            v = v + (Cf + gn) * h
            propagate_cov(P, C, skew(Cf), h, G, Hp)
            for i in range(3):
                P[i, i] += (qg + sf2 * (w[0] * w[0] + w[1] * w[1] + w[2] * w[2])) * h
                P[3 + i, 3 + i] += qa * qa * h
                P[6 + i, 6 + i] += rbw * rbw * h
        if k % 50 == 0:
            C = orthonormalise(C)
        if rest and not use_gnss:
            at_rest, _, _, _ = rest_step(rst, 0, gyro[k, 0], gyro[k, 1], gyro[k, 2], accel[k, 0], accel[k, 1],
                                         accel[k, 2], ra, dt)
            if at_rest:  # the |f| reference re-read in this orientation (a biased accelerometer's |f| at rest moves
                # with the attitude: up to 2 |b_a| between upright and upside down), then the zero-rate update
                g = math.sqrt(rst[3] * rst[3] + rst[4] * rst[4] + rst[5] * rst[5])
                gn[2] = g
                # zero-rate update: the gyro sample measures the bias, variance q_g / dt per sample
                rz = qg / dt
                Sz = hpht(Hz, P)
                for i in range(3):
                    Sz[i, i] += rz
                dx = joseph_update(P, Hz, np.linalg.inv(Sz), np.full(3, rz), gyro[k] - b, I9)
                C = mm3(rotvec_dcm(dx[0:3]), C)
                b = b + dx[6:9]
        meas = False
        if use_gnss:
            if gk < gidx.shape[0] and gidx[gk] == k:
                H = np.zeros((3, 9))
                H[0, 3] = H[1, 4] = H[2, 5] = 1.0
                nu = gvel[gk] - v
                gk += 1
                meas = True
        else:
            fsum = fsum + accel[k]
            cnt += 1
            fk = fsum / n_avg
            if use_lp:
                y = lpc[0] * accel[k] + lpc[1] * lps[0] + lpc[2] * lps[1] - lpc[3] * lps[2] - lpc[4] * lps[3]
                lps[1] = lps[0].copy()
                lps[0] = accel[k].copy()
                lps[3] = lps[2].copy()
                lps[2] = y
                fk = y
            if cnt == n_avg:
                fsum = np.zeros(3)
                cnt = 0
            ea = abs(np.sqrt(fk[0] * fk[0] + fk[1] * fk[1] + fk[2] * fk[2]) - g)
            if use_lp:  # gate as variance inflation: R / w, w = min(1, (accel_gate / e_a)^2)
                wgt = 1.0 if ea < accel_gate else (accel_gate / ea) ** 2
            if cnt == 0 and (use_lp or ea < accel_gate):
                H = np.zeros((3, 9))
                H[:, 0:3] = -mm3(C.T, skew(gn))
                fn = np.sqrt(fk[0] * fk[0] + fk[1] * fk[1] + fk[2] * fk[2])
                if dir_only and fn > 0.0:  # the direction only: |f| - g (accelerometer bias and scale factor
                    fk = fk * (g / fn)     # along the vertical) is no tilt
                nu = fk + mv3(C.T, gn)
                meas = True
        if meas:
            HPH = hpht(H, P)
            if fresh and k >= n_hold:  # R is held over the rest window (started from its measured noise)
                for i in range(3):
                    Cv[i] = R[i] + HPH[i, i]
                    Hm[i] = HPH[i, i]
                fresh = False
            steady = k - last_m == n_per  # consecutive measurements (after a gated gap P⁻ is not steady)
            last_m = k
            S = HPH.copy()
            for i in range(3):
                S[i, i] += R[i] / wgt
            if adapt_r and steady and not fresh and wgt == 1.0:  # Sage-Husa, each term clipped at innov_gate S_ii,
                # R bounded to [r_floor, r_hi]
                for i in range(3):
                    c = nu[i] * nu[i]
                    cmax = innov_gate * S[i, i]
                    Cv[i] = (1.0 - d) * Cv[i] + d * (c if c < cmax else cmax)
                    Hm[i] = (1.0 - d) * Hm[i] + d * HPH[i, i]
                    ri = Cv[i] - Hm[i]
                    R[i] = r_floor if ri < r_floor else (r_hi if ri > r_hi else ri)
            nis = nu @ np.linalg.solve(S, nu)
            if use_lp and wgt == 1.0 and not fresh and nis_win > 0:  # NIS monitor on the quasi-static updates
                Sm = HPH.copy()
                for i in range(3):
                    Sm[i, i] += r_mon
                nis_s += nu @ np.linalg.solve(Sm, nu)
                nis_n += 1
                if nis_n == nis_win:
                    nis_k[n_nis] = k
                    nis_v[n_nis] = nis_s / nis_n
                    n_nis += 1
                    if nis_s / nis_n > nis_hi:  # diverged: re-level on the measured vertical, P and R reset, reported
                        if not use_gnss:
                            C = mm3(C, align_rotation(C[2], -fk).T)
                            H[:, 0:3] = -mm3(C.T, skew(gn))
                            nu = fk + mv3(C.T, gn)
                        R[:] = r_start
                        HPH, S = reset_attitude(P, H, R, wgt, p0_yaw)
                        nis = nu @ np.linalg.solve(S, nu)
                        n_reset = record_reset(resets, n_reset, k)
                        rej_t = 0.0
                    nis_s = 0.0
                    nis_n = 0
            accept = True
            if not use_gnss and not use_lp:  # innovation test (chi-square, 3 dof); re-level after reject_timeout
                if nis > innov_gate:
                    rej_t += n_per * dt
                    if rej_t < reject_timeout:
                        accept = False
                    else:
                        HPH, S = reset_attitude(P, H, R, wgt, p0_yaw)
                        rej_t = 0.0
                        n_reset = record_reset(resets, n_reset, k)
                else:
                    rej_t = 0.0
            if accept:
                dx = joseph_update(P, H, np.linalg.inv(S), R / wgt, nu, I9)
                C = mm3(rotvec_dcm(dx[0:3]), C)
                v = v + dx[3:6]
                b = b + dx[6:9]

                if wgt >= 0.5:
                    for j in range(k - n_per + 1 if not use_gnss else k, k + 1):
                        used[j] = True
            t_idx[m] = k
            R_hist[m] = R
            q_hist[m] = qg
            m += 1
        out_C[k] = C
        out_b[k] = b
    return out_C, out_b, used, t_idx[:m], R_hist[:m], q_hist[:m], resets[:n_reset], nis_k[:n_nis], nis_v[:n_nis]


def _als_schedule(gyro, accel, dt, params: AEKFParams, b0, qg0, n0) -> tuple:
    """ALS estimates at the end of every ``als_window_s`` of each rest stretch (growing windows from its start)."""
    sw = float(np.mean(np.std(gyro[:n0], axis=0)))
    sa = float(np.mean(np.std(accel[:n0], axis=0)))
    w = int(round(params.als_window_s / dt))
    out = []
    q, r = float(qg0), sa * sa
    for a, b in stationary_segments(gyro, accel, dt, sigma_w=sw, sigma_a=sa, min_s=params.als_window_s, bias=b0):
        for end in range(a + w, b + 1, w):
            e = als_noise(gyro[a:end], accel[a:end], dt, q_gyro0=q, accel_var0=r, bias_rw=params.bias_rw)
            q, r = e.q_gyro, e.accel_var
            if end < len(gyro):
                out.append(NoiseEstimate(q, r, a, end))
    return tuple(out)


def run_aekf(gyro, accel, dt: float, params: AEKFParams = AEKFParams(), *, gnss=None, init_s: float = 10.0,
             name: str | None = None, return_trace: bool = False, lever_arm=None, steps=None):
    """Run the adaptive EKF over a record.

    gyro (N,3) [rad/s], accel (N,3) [m/s^2], dt [s]; gnss : :class:`imutherm.imu.gnss.GnssVelocity` or None
    (no aiding); the first ``init_s`` [s] must be at rest. lever_arm (3,) [m] of the sensor from the rotation
    centre, or None: without GNSS, the accelerometer's lever-arm term (:func:`lever_arm_accel`) is removed
    before it is taken as gravity (with GNSS it is not: the receiver gives the sensor's own velocity). steps (N,) [s]
    the true step ending at each sample of an irregular record (None: ``dt``): the attitude, velocity and
    covariance advance over it; blocks, fading memory, the ALS windows and timers keep ``dt``
    (:func:`~imutherm.imu.filters.common.sample_steps`). Returns an :class:`AttitudeEstimate` named
    ``aekf`` / ``aekf_gnss`` (or ``name``), and with ``return_trace`` also an :class:`AEKFTrace`.
    """
    from imutherm.imu.attitude_math import quat_to_dcm, roll_pitch_from_gravity

    gyro, accel = check_samples(gyro, accel, dt)
    dts = sample_steps(steps, len(gyro), dt)
    t0 = time.perf_counter()
    n0 = max(2, int(round(init_s / dt)))
    C0 = quat_to_dcm(initial_quat(accel, dt, init_s))
    b0 = initial_bias(gyro, dt, init_s)
    n_avg = 1 if gnss is not None else max(1, int(round(params.accel_avg_s / dt)))
    n_avg = max(1, min(n_avg, n0 // 4))  # at least four blocks in the rest window
    rest_blocks = accel[:n0 // n_avg * n_avg].reshape(-1, n_avg, 3).mean(axis=1)
    g_ref = float(np.mean(np.linalg.norm(rest_blocks, axis=1)))
    accel_rest = accel  # the ALS works on the raw accelerometer (at rest the lever-arm term is zero)
    if lever_arm is not None and gnss is None:
        accel = accel - lever_arm_accel(gyro, dt, lever_arm, b0)
    fs = 1.0 / dt
    qg0 = (params.gyro_density0 if params.gyro_density0 is not None
           else float(np.mean(np.std(gyro[:n0], axis=0))) / np.sqrt(fs)) ** 2
    if gnss is None:  # R of one block mean: given per sample (white: / N), else measured on the rest blocks
        r0 = (params.accel_std0 ** 2 / n_avg if params.accel_std0 is not None
              else float(np.mean(np.std(rest_blocks, axis=0))) ** 2)
        gidx, gvel = np.zeros(0, np.int64), np.zeros((0, 3))
    else:
        r0 = params.gnss_std0 ** 2
        gidx = np.asarray(gnss.idx, np.int64)
        gvel = np.asarray(gnss.vel_n, float)
        if gidx.size == 0 or np.any(np.diff(gidx) <= 0) or gidx[-1] >= len(gyro) or gvel.shape != (gidx.size, 3):
            raise InputError("aekf: GNSS fixes must have increasing sample indices within the record and (M,3) "
                             "velocities")
    als = _als_schedule(gyro, accel_rest, dt, params, b0, qg0, n0) if params.adapt_q else ()
    if params.tau_acc > 0 and gnss is None:
        from imutherm.imu.filters.inertial_lp import butter2_coeffs

        lpc = butter2_coeffs(params.tau_acc, dt)
        n_avg = max(1, int(round(params.lp_update_s / dt)))
    else:
        lpc = np.zeros(0)
    q_idx = np.array([e.end for e in als], np.int64)
    q_val = np.array([e.q_gyro for e in als], float)
    if gnss is None:  # bounds about the accelerometer's noise measured on the rest window's blocks
        r_ref = float(np.mean(np.std(rest_blocks, axis=0))) ** 2
        r_floor, r_hi = max(params.r_floor, params.r_min_x * r_ref), max(params.r_floor, params.r_max_x * r_ref)
    else:  # GNSS: the receiver's velocity noise up to 100 times its stated std
        r_floor, r_hi = params.r_floor, max(params.r_floor, (100.0 * params.gnss_std0) ** 2)
    r_mon = (g_ref * math.tan(math.radians(params.monitor_deg))) ** 2 if gnss is None else 0.0
    nis_win = (int(round(params.nis_window_s / (n_avg * dt))) if math.isfinite(params.nis_window_s) else 0)
    C, bias, used, t_idx, R, q, resets, nis_k, nis_v = _aekf_loop(
                                            gyro, accel, float(dt), dts, C0, b0, g_ref, float(qg0), float(r0),
                                            params.bias_rw, params.accel_density, params.memory_s,
                                            q_idx, q_val, params.adapt_r, r_floor, gnss is not None,
                                            gidx, gvel, float(np.radians(5.0) ** 2), params.accel_gate,
                                            params.innov_gate, params.reject_timeout_s, n_avg, n0, lpc,
                                            float(params.sf_std ** 2), params.gyro_sample == "point",
                                            bool(params.rest_bias and lpc.shape[0] == 5), float(r_hi), nis_win,
                                            params.innov_gate, float(r_mon), params.dir_only)
    r = C[:, 2, :]  # gravity direction in body axes = third row of C_nb
    roll, pitch = roll_pitch_from_gravity(r)
    yaw = np.arctan2(C[:, 1, 0], C[:, 0, 0])
    label = name or ("aekf" if gnss is None else "aekf_gnss")
    est = AttitudeEstimate(label, roll, pitch, r, used, time.perf_counter() - t0, yaw=yaw, resets=resets)
    if return_trace:
        return est, AEKFTrace(t_idx=t_idx, R=R, q_gyro=q, yaw=yaw, bias=bias, als=als, resets=resets,
                              nis=(nis_k, nis_v))
    return est


# --------------------------------------------------------------------------- the registry's entries

def _run_aekf_spec(x, p):
    return run_aekf(x.gyro, x.accel, x.dt, replace(p or AEKFParams(), gyro_sample=x.gyro_sample), init_s=x.init_s,
                    lever_arm=x.lever_arm, steps=x.steps)


def _run_aekf_gnss_spec(x, p):
    return run_aekf(x.gyro, x.accel_raw, x.dt, replace(p or AEKFParams(), gyro_sample=x.gyro_sample), gnss=x.gnss,
                    init_s=x.init_s, steps=x.steps)


register(FilterSpec("aekf", _run_aekf_spec, AEKFParams, "ours",
                    "Wang et al.'s adaptive EKF (Sage-Husa R, ALS Q); AEKFParams", "tab:purple",
                    groups={"study", "varying_dt", "real_tuned"}, linestyle=(0, (3, 1)), rank=50,
                    tuning=(Tuned("tau_acc", 1.0, 1.0, (0.1, 100.0), "tau_acc [s]; 0 = the block mean", off=(0.0,)),
                            Tuned("memory_s", 1.0, 31.6, (0.1, 1000.0), "memory_s [s] the fading memory of the "
                                                                        "adaptation laws"))))
register(FilterSpec("aekf_gnss", _run_aekf_gnss_spec, AEKFParams, "ours",
                    "Wang et al.'s adaptive EKF with GNSS velocity", "tab:brown", needs_gnss=True,
                    groups={"varying_dt", "real_tuned"}, rank=60))
