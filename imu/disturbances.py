"""Realistic disturbances on top of a motion profile: vibration, turbulence, wind, gusts, sync error, jitter.

Each disturbance is a frozen dataclass (``None`` switches it off) collected in
:class:`Disturbances`; :func:`apply` turns a clean :class:`~imutherm.imu.motion.Trajectory`
into a :class:`DisturbedRecord`: the perturbed truth (still kinematically exact:
attitude perturbations are carried as Euler jets and composed with the profile's
attitude, so ω_b, ω̇_b and f_b stay consistent), the sensor inputs (truth plus
vibration, at jittered sample instants) and the reference attitude the IMU is
scored against (delayed by the sync error). :data:`PRESETS` gives one set per
profile, each number with its source or marked [ASSUMED].

* **Vibration** (:class:`Vibration`): narrow-band lines plus a flat broadband
  floor, linear [g] and angular [°/s], generated at 2× the part's internal
  sample rate, passed through the part's analog bandwidth (2-pole Butterworth),
  sampled at its internal rate, averaged by its Bartlett filter and read by the
  host at the output rate as the latest register value (:class:`SensorChain`).
  Vibration above the output Nyquist frequency therefore aliases, as it does in
  the real part. The angular vibration's attitude amplitude (< 0.01°) is not
  added to the truth.
* **Turbulence** (:class:`Turbulence`): Dryden gust velocities u_g, v_g, w_g and
  rotational gusts p_g, q_g with MIL-F-8785C §3.7 low-altitude intensities and
  scale lengths; the aircraft's response by a plunge / side-force model
  (gust load ``(w_g − w_a)/T_h``, Hoblit, *Gust Loads on Aircraft*, AIAA 1988,
  ch. 2) and an attitude-hold model for roll and pitch (below).
* **Wind** (:class:`Wind`): steady wind with the MIL-F-8785C §3.7.3.3 logarithmic
  shear ``W(h) = W20 ln(h/z0) / ln(20 ft/z0)`` and discrete 1−cos gusts
  (§3.7.2). A steady uniform wind does not change the specific force of an
  aircraft flying airspeed-referenced manoeuvres; the shear does: climbing or
  descending through it accelerates the air mass the aircraft flies in by
  ``dW/dh · ḣ``.
* **Sync error** ``sync_s``: the reference attitude at IMU time t is the truth at
  ``t − sync_s`` (a reference logged on another clock; the paper names it for
  its swing test).
* **Sample jitter** ``jitter_s``: the IMU samples the motion at ``t_k + j_k``,
  ``j_k ~ N(0, jitter_s²)``, while the filters assume a uniform step.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy import signal

from imutherm import InputError
from imutherm.imu.attitude_math import G0, quat_to_dcm, quat_to_euler
from imutherm.imu.motion import Jet, Trajectory, assemble_trajectory

FT = 0.3048  # [m]
KT = 0.514444  # [m/s]


# --------------------------------------------------------------------------- vibration
@dataclass(frozen=True)
class Spectrum:
    """A vibration spectrum: narrow-band lines and a flat broadband floor, per axis.

    lines : ((f [Hz], rms [unit]), ...)   sinusoids, random phase per axis
    band : (f_lo, f_hi) [Hz]              extent of the broadband floor
    psd : float [unit^2/Hz]               one-sided PSD of the floor (0: none)
    axis_weights : (3,) [-]               amplitude factor per body axis (x, y, z)
    The unit is g for linear and °/s for angular vibration.
    """

    lines: tuple = ()
    band: tuple = (0.0, 0.0)
    psd: float = 0.0
    axis_weights: tuple = (1.0, 1.0, 1.0)

    def rms(self) -> float:
        """Total rms per axis of unit weight [unit]: sqrt(Σ rms_i² + psd (f_hi − f_lo))."""
        return math.sqrt(sum(a * a for _, a in self.lines) + self.psd * (self.band[1] - self.band[0]))


@dataclass(frozen=True)
class SensorChain:
    """How the part sees vibration: analog bandwidth, internal sampling, averaging, host read-out.

    bandwidth_hz [Hz]    2-pole Butterworth low-pass of the sensing element and its amplifier
    internal_hz [Hz]     internal sample rate
    avg_taps [-]         Bartlett (triangular) averaging filter length, 1 = none
    Default: ADIS16355 datasheet (Rev. PrG, recalled, not verified): 350 Hz bandwidth, 819.2 SPS internal,
    SENS_AVG Bartlett filter; 8 taps [ASSUMED] (a user sampling at 100 Hz sets some averaging).
    """

    bandwidth_hz: float = 350.0
    internal_hz: float = 819.2
    avg_taps: int = 8

    def gain(self, f) -> np.ndarray:
        """|H(f)| [-] of the analog low-pass and the Bartlett filter at frequencies f [Hz]."""
        f = np.asarray(f, float)
        ha = 1.0 / np.sqrt(1.0 + (f / self.bandwidth_hz) ** 4)
        w = _bartlett(self.avg_taps)
        _, hb = signal.freqz(w, 1, worN=np.atleast_1d(f), fs=self.internal_hz)
        return ha * np.abs(hb).reshape(f.shape)


def _bartlett(n: int) -> np.ndarray:
    w = np.bartlett(n + 2)[1:-1] if n > 1 else np.ones(1)
    return w / w.sum()


@dataclass(frozen=True)
class Vibration:
    """Linear [g] and angular [°/s] vibration spectra and the part's sensing chain."""

    linear: Spectrum = Spectrum()
    angular: Spectrum = Spectrum()
    chain: SensorChain = SensorChain()


def vibration_raw(spec: Spectrum, duration: float, fs: float, rng: np.random.Generator) -> np.ndarray:
    """(M, 3) [unit] vibration at rate ``fs`` [Hz] over ``duration`` [s], before the sensing chain.

    Lines: ``√2 rms sin(2π f t + φ)``, φ uniform per axis. Floor: white noise shaped in the frequency
    domain to exactly zero outside ``band`` (so its PSD is ``psd`` inside, its rms ``sqrt(psd Δf)``).
    """
    m = int(math.ceil(duration * fs)) + 1
    t = np.arange(m) / fs
    out = np.zeros((m, 3))
    for f, a in spec.lines:
        ph = rng.uniform(0, 2 * np.pi, 3)
        out += math.sqrt(2.0) * a * np.sin(2 * np.pi * f * t[:, None] + ph)
    if spec.psd > 0 and spec.band[1] > spec.band[0]:
        from scipy import fft

        mf = fft.next_fast_len(m, real=True)
        x = fft.rfft(rng.standard_normal((mf, 3)), axis=0)
        fr = fft.rfftfreq(mf, 1.0 / fs)
        x[(fr < spec.band[0]) | (fr > spec.band[1])] = 0.0
        out += fft.irfft(x, n=mf, axis=0)[:m] * math.sqrt(spec.psd * fs / 2.0)
    return out * np.asarray(spec.axis_weights, float)


def through_chain(raw: np.ndarray, fs: float, t_out, chain: SensorChain) -> np.ndarray:
    """Pass ``raw`` (M, 3) sampled at ``fs`` [Hz] (a multiple of ``chain.internal_hz``) through the part:
    analog low-pass, internal sampling, Bartlett average, host read at ``t_out`` [s] (latest internal sample)."""
    k = int(round(fs / chain.internal_hz))
    sos = signal.butter(2, chain.bandwidth_hz, fs=fs, output="sos")
    y = signal.sosfilt(sos, raw, axis=0)[::k]
    y = signal.lfilter(_bartlett(chain.avg_taps), 1.0, y, axis=0)
    idx = np.minimum(np.floor(np.asarray(t_out, float) * chain.internal_hz + 1e-9).astype(int), len(y) - 1)
    return y[idx]


def vibration_samples(vib: Vibration, t, rng: np.random.Generator):
    """(accel (N,3) [m/s^2], gyro (N,3) [rad/s]) vibration as the part outputs it at sample times ``t`` [s]."""
    t = np.asarray(t, float)
    fs = 2 * vib.chain.internal_hz
    dur = float(t[-1]) + 0.05
    out = []
    for spec, scale in ((vib.linear, G0), (vib.angular, math.radians(1.0))):
        if not spec.lines and spec.psd == 0:
            out.append(np.zeros((t.size, 3)))
            continue
        # 1 s of start-up before t = 0 so the filters are settled
        raw = vibration_raw(spec, dur + 1.0, fs, rng)
        y = through_chain(raw, fs, t + 1.0, vib.chain)
        out.append(y * scale)
    return out[0], out[1]


# --------------------------------------------------------------------------- turbulence
@dataclass(frozen=True)
class AircraftResponse:
    """How the airframe turns gusts into accelerations and attitude changes (light single-engine aircraft).

    airspeed_mps [m/s]        true airspeed (the flight profile's cruise, 60 m/s)
    wing_loading_Npm2 [N/m^2] W/S; Cessna 172: 1111 kg on 16.2 m^2 = 673 N/m^2 (type certificate data)
    cl_alpha [1/rad]          lift-curve slope of the aircraft, 4.6 (Roskam, Airplane Flight Dynamics, app. B)
    cy_beta [1/rad]           side-force derivative, -0.31 (Roskam app. B, Cessna 172)
    span_m [m]                wing span b, 11.0 (Cessna 172)
    roll_tau_s [s]            roll-subsidence time constant 1/|L_p|, 0.3 [ASSUMED, light aircraft]
    pitch_tau_s [s]           pitch-rate damping time constant, 0.3 [ASSUMED]
    hold_w_radps [rad/s]      natural frequency of the pilot's / autopilot's attitude hold, 0.8 [ASSUMED]
    hold_zeta [-]             its damping ratio, 0.7 [ASSUMED]
    rho_kgpm3 [kg/m^3]        air density, 1.19 (ISA at 300 m)
    """

    airspeed_mps: float = 60.0
    wing_loading_Npm2: float = 673.0
    cl_alpha: float = 4.6
    cy_beta: float = -0.31
    span_m: float = 11.0
    roll_tau_s: float = 0.3
    pitch_tau_s: float = 0.3
    hold_w_radps: float = 0.8
    hold_zeta: float = 0.7
    rho_kgpm3: float = 1.19

    @property
    def plunge_tau_s(self) -> float:
        """Plunge-mode time constant T_h = 2 (W/S) / (ρ g V C_Lα) [s]: the gust load is (w_g − w_a)/T_h."""
        return 2 * self.wing_loading_Npm2 / (self.rho_kgpm3 * G0 * self.airspeed_mps * self.cl_alpha)

    @property
    def side_tau_s(self) -> float:
        """Side-force time constant 2 (W/S) / (ρ g V |C_Yβ|) [s]."""
        return 2 * self.wing_loading_Npm2 / (self.rho_kgpm3 * G0 * self.airspeed_mps * abs(self.cy_beta))


#: MIL-F-8785C §3.7.3.1 low-altitude wind speed at 20 ft by turbulence level [kt]
W20_KT = {"light": 15.0, "moderate": 30.0, "severe": 45.0}


@dataclass(frozen=True)
class Turbulence:
    """Dryden turbulence, MIL-F-8785C low-altitude model (valid 10 ft < h < 1000 ft).

    level : 'light' | 'moderate' | 'severe' (W20 = 15 / 30 / 45 kt, MIL-F-8785C §3.7.3.1)
    altitude_m [m] : altitude the intensities and scale lengths are taken at (fixed; default 250 m, the
        flight profile's height after its climb)
    aircraft : AircraftResponse
    """

    level: str = "light"
    altitude_m: float = 250.0
    aircraft: AircraftResponse = AircraftResponse()

    def __post_init__(self):
        if self.level not in W20_KT:
            raise InputError(f"Turbulence: level={self.level!r} is unknown; valid: {', '.join(W20_KT)}")
        h = self.altitude_m / FT
        if not (10.0 < h < 1000.0):
            raise InputError(f"Turbulence: altitude_m={self.altitude_m!r} is outside the low-altitude model; "
                             "valid: 3.05 .. 304.8 m (10 .. 1000 ft)")


def dryden_scales(altitude_m: float, w20_mps: float) -> dict:
    """MIL-F-8785C low-altitude intensities [m/s] and scale lengths [m] (h in ft inside the formulas)::

        σ_w = 0.1 W20,  σ_u = σ_v = σ_w / (0.177 + 0.000823 h)^0.4
        L_w = h,        L_u = L_v = h / (0.177 + 0.000823 h)^1.2
    """
    h = altitude_m / FT
    k = 0.177 + 0.000823 * h
    sw = 0.1 * w20_mps
    return {"sigma_u": sw / k**0.4, "sigma_v": sw / k**0.4, "sigma_w": sw,
            "L_u": h / k**1.2 * FT, "L_v": h / k**1.2 * FT, "L_w": h * FT}


def dryden_psd(f, sigma: float, L: float, V: float, kind: str) -> np.ndarray:
    """One-sided Dryden PSD [(m/s)^2/Hz] at frequency f [Hz] of a gust seen at airspeed V [m/s].

    kind 'u' (longitudinal): 4 σ² T / (1 + (2π f T)²); kind 'w' (vertical and lateral):
    2 σ² T (1 + 3 (2π f T)²) / (1 + (2π f T)²)², T = L / V. (MIL-F-8785C's Φ(Ω) in spatial frequency
    Ω = 2π f / V [rad/m], times 2π / V; each integrates to σ² over 0 < f < ∞.)
    """
    T = L / V
    x2 = (2 * np.pi * np.asarray(f, float) * T) ** 2
    if kind == "u":
        return 4 * sigma**2 * T / (1 + x2)
    return 2 * sigma**2 * T * (1 + 3 * x2) / (1 + x2) ** 2


def _filter_white(num, den, n: int, dt: float, rng, warm: int):
    """Drive the continuous shaping filter num/den (unit one-sided input PSD) with discrete white noise."""
    bd, ad = signal.cont2discrete((num, den), dt, method="bilinear")[:2]
    w = rng.standard_normal(n + warm) * math.sqrt(1.0 / (2.0 * dt))
    return signal.lfilter(np.ravel(bd), ad, w)[warm:]


def dryden_gusts(n: int, dt: float, turb: Turbulence, rng: np.random.Generator) -> dict:
    """Gust time series over n samples of step dt [s]: u_g, v_g, w_g [m/s] (Dryden forms of
    :func:`dryden_psd`) and p_g, q_g [rad/s] (MIL-F-8785C rotational forms, shaping filters
    ``H_p = σ_w sqrt(0.8/V) (π/4b)^(1/6) / (L_w^(1/3) (1 + 4b s/(πV)))`` and
    ``H_q = (s/V) / (1 + 4b s/(πV)) · H_w``). Each starts stationary (warm-up of 20 T discarded)."""
    ac = turb.aircraft
    V, b = ac.airspeed_mps, ac.span_m
    sc = dryden_scales(turb.altitude_m, W20_KT[turb.level] * KT)
    out = {}
    for key, kind in (("u", "u"), ("v", "w"), ("w", "w")):
        s, L = sc[f"sigma_{key}"], sc[f"L_{key}"]
        T = L / V
        warm = int(20 * T / dt) + 10
        if kind == "u":
            num, den = [s * math.sqrt(4 * T)], [T, 1.0]
        else:
            num, den = [s * math.sqrt(2 * T) * math.sqrt(3) * T, s * math.sqrt(2 * T)], [T * T, 2 * T, 1.0]
        out[f"{key}_g"] = _filter_white(num, den, n, dt, rng, warm)
    sw, Lw = sc["sigma_w"], sc["L_w"]
    Tb = 4 * b / (np.pi * V)
    kp = sw * math.sqrt(0.8 / V) * (np.pi / (4 * b)) ** (1 / 6) / Lw ** (1 / 3)
    out["p_g"] = _filter_white([kp], [Tb, 1.0], n, dt, rng, int(20 * Tb / dt) + 10)
    T = Lw / V
    num = np.polymul([1.0 / V, 0.0], [sw * math.sqrt(2 * T) * math.sqrt(3) * T, sw * math.sqrt(2 * T)])
    den = np.polymul([Tb, 1.0], [T * T, 2 * T, 1.0])
    out["q_g"] = _filter_white(num, den, n, dt, rng, int(20 * T / dt) + 10)
    out["scales"] = sc
    return out


def _first_order_follow(x, dt, tau):
    """y' = (x − y)/τ, exact for x held over each step; returns (y, y')."""
    a = math.exp(-dt / tau)
    y = signal.lfilter([1 - a], [1.0, -a], x, zi=[a * x[0]])[0]
    return y, (x - y) / tau


def _attitude_hold(rate_gust, dt, tau, wn, zeta):
    """Attitude perturbation jet of an airframe whose rate follows the rotational gust with time constant τ
    (rate damping) while a pilot / autopilot holds the attitude (natural frequency wn, damping ζ)::

        θ̈ = (g − θ̇)/τ − 2 ζ wn θ̇ − wn² θ,   g the rotational gust [rad/s]

    integrated exactly for g held over each step (zero-order-hold transfer functions, ``lfilter``)."""
    den = [1.0, 1.0 / tau + 2 * zeta * wn, wn * wn]
    out = []
    for num in ([1.0 / tau], [1.0 / tau, 0.0]):  # θ and θ̇
        b, a, _ = signal.cont2discrete((num, den), dt, method="zoh")
        out.append(signal.lfilter(np.ravel(b), a, rate_gust))
    th, thd = out
    thdd = (rate_gust - thd) / tau - 2 * zeta * wn * thd - wn * wn * th
    return Jet(th, thd, thdd)


# --------------------------------------------------------------------------- wind
@dataclass(frozen=True)
class Wind:
    """Steady wind with logarithmic shear, and discrete gusts.

    w20_kt [kt]        wind at 20 ft (MIL-F-8785C §3.7.3.3); from_deg [deg] direction it blows from
    z0_m [m]           roughness length, 0.15 ft = 0.046 m (MIL-F-8785C, Category C)
    ground_m [m]       height of the sensor above the ground when on the runway (shear applied above it)
    gusts : ((t [s], d_m [m], v_m [m/s]), ...)  1−cos vertical gusts (MIL-F-8785C §3.7.2):
        w = v_m/2 (1 − cos(π x / d_m)), x = V (t − t_i) over 0 ≤ x ≤ 2 d_m
    """

    w20_kt: float = 15.0
    from_deg: float = 0.0
    z0_m: float = 0.15 * FT
    ground_m: float = 2.0
    gusts: tuple = ()

    def speed(self, h) -> np.ndarray:
        """Wind speed [m/s] at height h [m] by the log law (heights at or below z0 clipped just above it: ~0)."""
        h = np.maximum(np.asarray(h, float), self.z0_m * 1.0001)
        return self.w20_kt * KT * np.log(h / self.z0_m) / math.log(20 * FT / self.z0_m)


def discrete_gust(t, V: float, gusts) -> np.ndarray:
    """Vertical 1−cos gust velocity [m/s] (up positive) at times t [s] for airspeed V [m/s]."""
    t = np.asarray(t, float)
    w = np.zeros_like(t)
    for t0, dm, vm in gusts:
        x = V * (t - t0)
        m = (x >= 0) & (x <= 2 * dm)
        w[m] += 0.5 * vm * (1 - np.cos(np.pi * x[m] / dm))
    return w


# --------------------------------------------------------------------------- the set
@dataclass(frozen=True)
class Disturbances:
    """Switchable disturbances (None / 0: off). sync_s [s] reference delay, jitter_s [s] rms sample jitter."""

    vibration: Vibration | None = None
    turbulence: Turbulence | None = None
    wind: Wind | None = None
    sync_s: float = 0.0
    jitter_s: float = 0.0
    source: str = ""

    def describe(self) -> dict:
        """JSON-ready description of the switches."""
        return {"vibration": self.vibration is not None, "turbulence": None if self.turbulence is None else
                self.turbulence.level, "wind_w20_kt": None if self.wind is None else self.wind.w20_kt,
                "gusts": 0 if self.wind is None else len(self.wind.gusts), "sync_ms": 1e3 * self.sync_s,
                "jitter_ms": 1e3 * self.jitter_s, "source": self.source}


@dataclass(frozen=True)
class DisturbedRecord:
    """Output of :func:`apply`.

    truth : Trajectory                 perturbed truth kinematics (turbulence / wind included)
    omega_in : (N,3) [rad/s]           body rate the gyros sense (truth at jittered instants + vibration)
    f_in : (N,3) [m/s^2]               specific force the accelerometers sense (same)
    ref_roll, ref_pitch : (N,) [rad]   the reference attitude at each IMU sample (sync error included)
    disturbances : Disturbances
    """

    truth: Trajectory
    omega_in: np.ndarray = field(repr=False)
    f_in: np.ndarray = field(repr=False)
    ref_roll: np.ndarray = field(repr=False)
    ref_pitch: np.ndarray = field(repr=False)
    disturbances: Disturbances = Disturbances()


def _nav_accel(traj: Trajectory):
    """The profile's CG acceleration a_n (N,3) [m/s^2] in NED, recovered from f_b (lever arm removed)."""
    d = traj.lever_arm
    f_cg = traj.f_b - np.cross(traj.omega_dot_b, d) - np.cross(traj.omega_b, np.cross(traj.omega_b, d))
    c_nb = quat_to_dcm(traj.quat)
    return np.einsum("nij,nj->ni", c_nb, f_cg) + np.array([0.0, 0.0, G0])


def perturb(traj: Trajectory, d_roll: Jet, d_pitch: Jet, da_body) -> Trajectory:
    """Truth with small attitude perturbations and an extra CG acceleration.

    The perturbed body is the profile's body rotated by the ZYX Euler perturbation (d_roll, d_pitch, 0)
    (jets: value, rate, acceleration [rad, rad/s, rad/s^2]); ``da_body`` (N,3) [m/s^2] is an extra
    acceleration of the CG in the *perturbed* body axes (gust loads). Rates, angular accelerations and the
    specific force are recomputed exactly: ``ω' = Rᵀ ω + ω_δ``, ``ω̇' = Rᵀ ω̇ − ω_δ × Rᵀ ω + ω̇_δ``.
    """
    a_n = _nav_accel(traj)
    z = Jet(np.zeros_like(traj.t))
    dp = assemble_trajectory("delta", traj.t, d_roll, d_pitch, z, np.zeros((traj.t.size, 3)), np.zeros(3),
                   traj.segment, traj.phase)
    R = quat_to_dcm(dp.quat)  # perturbed body -> profile body
    w_rot = np.einsum("nji,nj->ni", R, traj.omega_b)
    omega = w_rot + dp.omega_b
    omega_dot = np.einsum("nji,nj->ni", R, traj.omega_dot_b) - np.cross(dp.omega_b, w_rot) + dp.omega_dot_b
    q = _qmul(traj.quat, dp.quat)
    c_nb = quat_to_dcm(q)
    a_n2 = a_n + np.einsum("nij,nj->ni", c_nb, np.asarray(da_body, float))
    f_cg = np.einsum("nji,nj->ni", c_nb, a_n2 - np.array([0.0, 0.0, G0]))
    d = traj.lever_arm
    f_b = f_cg + np.cross(omega_dot, d) + np.cross(omega, np.cross(omega, d))
    roll, pitch, yaw = quat_to_euler(q)
    from scipy.integrate import cumulative_trapezoid

    vel = traj.vel_n + cumulative_trapezoid(a_n2 - a_n, traj.t, axis=0, initial=0.0)
    return replace(traj, quat=q, roll=roll, pitch=pitch, yaw=yaw, omega_b=omega, omega_dot_b=omega_dot,
                   f_b=f_b, vel_n=vel)


def _qmul(a, b):
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2], -1)


def airborne(traj: Trajectory, ground_m: float = 2.0) -> tuple[np.ndarray, np.ndarray]:
    """(height above the runway [m], climb rate ḣ [m/s]) of a flight trajectory, from its velocity."""
    from scipy.integrate import cumulative_trapezoid

    hdot = -traj.vel_n[:, 2]
    return ground_m + cumulative_trapezoid(hdot, traj.t, initial=0.0), hdot


def aero_disturbance(traj: Trajectory, turb: Turbulence | None, wind: Wind | None, rng) -> Trajectory:
    """Truth of an aircraft in turbulence, shear and gusts (see the module docstring); on the ground
    (height below ``wind.ground_m`` + 1 m, or before the first climb) nothing is applied."""
    n, dt = traj.t.size, float(traj.t[1] - traj.t[0])
    ground = 2.0 if wind is None else wind.ground_m
    h, hdot = airborne(traj, ground)
    flying = h > ground + 1.0
    ramp = np.clip((h - ground - 1.0) / 10.0, 0.0, 1.0)  # fade in over the first 10 m of height
    ac = (turb.aircraft if turb is not None else AircraftResponse())
    V = ac.airspeed_mps
    da = np.zeros((n, 3))
    d_roll = Jet(np.zeros(n))
    d_pitch = Jet(np.zeros(n))
    w_up = np.zeros(n)
    v_side = np.zeros(n)
    if turb is not None:
        gu = dryden_gusts(n, dt, turb, rng)
        w_up = gu["w_g"] * ramp
        v_side = gu["v_g"] * ramp
        d_roll = _attitude_hold(gu["p_g"] * ramp, dt, ac.roll_tau_s, ac.hold_w_radps, ac.hold_zeta)
        d_pitch = _attitude_hold(gu["q_g"] * ramp, dt, ac.pitch_tau_s, ac.hold_w_radps, ac.hold_zeta)
    if wind is not None and wind.gusts:
        w_up = w_up + discrete_gust(traj.t, V, wind.gusts) * flying
    if turb is not None or (wind is not None and wind.gusts):
        _, a_up = _first_order_follow(w_up, dt, ac.plunge_tau_s)
        _, a_side = _first_order_follow(v_side, dt, ac.side_tau_s)
        da[:, 2] = -a_up  # lift up = −z body (FRD)
        da[:, 1] = a_side
    if wind is not None:
        # air-mass acceleration from the shear: d/dt of the wind vector W(h) at climb rate ḣ
        dWdh = np.where(flying, wind.w20_kt * KT / (np.maximum(h, wind.z0_m * 2) *
                                                    math.log(20 * FT / wind.z0_m)), 0.0)
        frm = math.radians(wind.from_deg)
        a_w = -(dWdh * hdot)[:, None] * np.array([math.cos(frm), math.sin(frm), 0.0])  # NED, blows toward -from
        c_nb = quat_to_dcm(traj.quat)
        da += np.einsum("nji,nj->ni", c_nb, a_w)  # into the body (perturbation rotation < 1°: neglected here)
    return perturb(traj, d_roll, d_pitch, da)


def jittered(traj: Trajectory, jitter_s: float, rng) -> tuple[np.ndarray, np.ndarray]:
    """(ω_b, f_b) of ``traj`` at instants t_k + j_k, j_k ~ N(0, jitter_s²) (cubic spline, ω also through
    its exact derivative: ω(t+j) ≈ ω + ω̇ j + the spline's curvature term)."""
    if jitter_s <= 0:
        return traj.omega_b, traj.f_b
    from scipy.interpolate import CubicSpline

    j = rng.normal(0.0, jitter_s, traj.t.size)
    te = np.clip(traj.t + j, traj.t[0], traj.t[-1])
    w = CubicSpline(traj.t, traj.omega_b, axis=0)(te)
    f = CubicSpline(traj.t, traj.f_b, axis=0)(te)
    return w, f


def delayed(t, angle, sync_s: float) -> np.ndarray:
    """The reference angle [rad] at IMU times t [s] when the reference lags by ``sync_s`` [s]: truth(t − sync_s)
    (linear interpolation of the unwrapped angle, held at the ends)."""
    if sync_s == 0:
        return np.asarray(angle, float).copy()
    u = np.unwrap(np.asarray(angle, float))
    r = np.interp(np.asarray(t, float) - sync_s, t, u)
    return (r + np.pi) % (2 * np.pi) - np.pi


def apply(traj: Trajectory, dist: Disturbances | None, rng: np.random.Generator) -> DisturbedRecord:
    """Apply ``dist`` to ``traj`` (see the module docstring). ``rng`` draws every random part, in the order
    turbulence, jitter, vibration. ``dist=None``: the clean record."""
    if dist is None:
        dist = Disturbances()
    if dist.sync_s < 0 or dist.jitter_s < 0 or not (math.isfinite(dist.sync_s) and math.isfinite(dist.jitter_s)):
        raise InputError(f"disturbances: sync_s={dist.sync_s!r}, jitter_s={dist.jitter_s!r}; valid: finite >= 0 [s]")
    truth = traj
    if dist.turbulence is not None or dist.wind is not None:
        truth = aero_disturbance(traj, dist.turbulence, dist.wind, rng)
    w, f = jittered(truth, dist.jitter_s, rng)
    if dist.vibration is not None:
        fa, wg = vibration_samples(dist.vibration, truth.t, rng)
        w, f = w + wg, f + fa
    return DisturbedRecord(truth, w, f, delayed(truth.t, truth.roll, dist.sync_s),
                           delayed(truth.t, truth.pitch, dist.sync_s), dist)


# --------------------------------------------------------------------------- presets
#: light single-engine piston aircraft, engine 2400 rpm (40 Hz), 2-blade propeller (blade passage 80 Hz):
#: MIL-STD-810H Method 514.8 Annex D describes propeller-aircraft vibration as peaks at the blade-passage
#: frequency and its harmonics over a broadband floor; the amplitudes here are [ASSUMED] for an instrument
#: mounted on the airframe structure, not the standard's (much higher) qualification test levels.
AIRCRAFT_VIBRATION = Vibration(
    linear=Spectrum(lines=((40.0, 0.02), (80.0, 0.10), (160.0, 0.05), (240.0, 0.03)), band=(15.0, 500.0),
                    psd=1.0e-5, axis_weights=(0.5, 0.5, 1.0)),
    angular=Spectrum(lines=((40.0, 0.2), (80.0, 0.3)), band=(15.0, 200.0), psd=1.0e-3),
)
#: passenger car: engine second order at 1800 rpm (60 Hz) and road-induced floor 2-80 Hz; rms 0.4 m/s^2,
#: between ISO 2631-1 Annex C's "not uncomfortable" (< 0.315) and "a little uncomfortable" (0.315-0.63)
#: [ASSUMED from that scale]; angular 0.5 deg/s rms [ASSUMED].
VEHICLE_VIBRATION = Vibration(
    linear=Spectrum(lines=((60.0, 0.01),), band=(2.0, 80.0), psd=2.0e-5, axis_weights=(0.6, 0.6, 1.0)),
    angular=Spectrum(band=(2.0, 40.0), psd=6.5e-3),
)
#: hand: physiological tremor, 8-12 Hz (Elble & Koller, Tremor, 1990); displacement ~ tens of um at the
#: hand, 0.01 g rms, angular 0.5 deg/s rms [ASSUMED within that literature's range].
HANDHELD_VIBRATION = Vibration(
    linear=Spectrum(band=(8.0, 12.0), psd=2.5e-5), angular=Spectrum(band=(8.0, 12.0), psd=0.0625),
)
#: reference-to-IMU clock offset [s]: [ASSUMED] 5 ms, a reference logged on its own clock and aligned by
#: timestamps (the paper's swing error is "partly time-sync"); sample jitter 0.2 ms rms [ASSUMED], host
#: time-stamping of a data-ready line.
SYNC_S = 5e-3
JITTER_S = 2e-4

PRESETS = {
    "flight": Disturbances(vibration=AIRCRAFT_VIBRATION, turbulence=Turbulence("light"),
                           wind=Wind(w20_kt=15.0, from_deg=30.0, gusts=((150.0, 30.0, 3.0), (300.0, 60.0, 4.0))),
                           sync_s=SYNC_S, jitter_s=JITTER_S, source="aircraft"),
    "swing": Disturbances(sync_s=SYNC_S, jitter_s=JITTER_S, source="turntable"),
    "shake": Disturbances(sync_s=SYNC_S, jitter_s=JITTER_S, source="shaker table"),
    "static": Disturbances(jitter_s=JITTER_S, source="static"),
    "vehicle": Disturbances(vibration=VEHICLE_VIBRATION, sync_s=SYNC_S, jitter_s=JITTER_S, source="car"),
    "handheld": Disturbances(vibration=HANDHELD_VIBRATION, sync_s=SYNC_S, jitter_s=JITTER_S, source="hand"),
}
