"""Motion profiles: consistent truth kinematics for the IMU simulation.

Every profile is built from smooth analytic histories (quintic smoothstep
ramps, sinusoids with smooth envelopes) carried as second-order *jets*
(value, first and second time derivative), so that the Euler angles, the body
rate ``ω_b`` and the body angular acceleration ``ω̇_b`` are exact derivatives
of the attitude, and the specific force follows analytically from the
velocity history. No numerical differentiation is involved.

Frames (see :mod:`imutherm.imu.attitude_math`): navigation NED, body FRD,
quaternion body→nav, ZYX Euler angles. The specific force at the sensor
includes the lever arm ``d`` [m] from the rotation centre (turntable axis or
the aircraft CG) to the sensor, in body axes::

    f_b = C_bn (a_n - g_n) + ω̇_b × d + ω_b × (ω_b × d)

Profiles
--------
``static``  level (or fixed tilt) at rest.
``swing``   turntable oscillation about one body axis, sinusoidal, 80° amplitude,
            200 °/s peak rate, with a smooth amplitude envelope.
``shake``   level table shaken horizontally in bursts, peak acceleration above 1 g.
``vehicle`` ground vehicle: start from rest, accelerate, turns with body roll outward
            (roll gradient), hills, braking with nose dive (pitch gradient), lane change, stop.
``handheld`` a unit held in the hand: picked up, tilted and turned by the wrist (up to
            ~190 °/s), carried while walking (step accelerations), put down.
``flight``  takeoff acceleration, climb, level legs, coordinated turns (bank
            from ``tan φ = V ψ̇ cos γ / (V γ̇ + g cos γ)``, i.e. ``tan φ = V ω / g`` in
            level flight), pitch manoeuvre, circling, descent, landing
            deceleration; the aircraft x axis is along the velocity (zero angle
            of attack and sideslip).

Each sample carries a segment name and a phase label, ``'stable'`` (no
acceleration of the rotation centre and no rotation) or ``'manoeuvre'``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from imutherm import InputError
from imutherm.imu.attitude_math import G0, euler_to_quat, quat_to_dcm

PROFILES = ("static", "swing", "shake", "flight", "vehicle", "handheld")

#: default sensor lever arm from the rotation centre [m], per profile; vehicle: 0.5 m ahead of and 0.3 m
#: above the reference point [ASSUMED, a dashboard mount]; handheld: 8 cm from the wrist [ASSUMED]
DEFAULT_LEVER_ARM = {"static": (0.0, 0.0, 0.0), "swing": (0.0, 0.03, 0.05), "shake": (0.0, 0.0, 0.0),
                     "flight": (0.3, 0.0, 0.05), "vehicle": (0.5, 0.0, -0.3), "handheld": (0.08, 0.0, 0.0)}


# --------------------------------------------------------------------------- jets
class Jet:
    """Second-order jet: value and first two time derivatives of an array quantity.

    ``Jet(v, d1, d2)`` with arrays of the same shape; arithmetic and the
    elementary functions used here propagate the derivatives exactly.
    """

    __slots__ = ("v", "d1", "d2")

    def __init__(self, v, d1=0.0, d2=0.0):
        v = np.asarray(v, float)
        self.v = v
        self.d1 = np.broadcast_to(np.asarray(d1, float), v.shape) if np.ndim(d1) == 0 else np.asarray(d1, float)
        self.d2 = np.broadcast_to(np.asarray(d2, float), v.shape) if np.ndim(d2) == 0 else np.asarray(d2, float)

    @staticmethod
    def _lift(o):
        return o if isinstance(o, Jet) else Jet(o)

    def __add__(self, o):
        o = self._lift(o)
        return Jet(self.v + o.v, self.d1 + o.d1, self.d2 + o.d2)

    __radd__ = __add__

    def __neg__(self):
        return Jet(-self.v, -self.d1, -self.d2)

    def __sub__(self, o):
        return self + (-self._lift(o))

    def __rsub__(self, o):
        return self._lift(o) - self

    def __mul__(self, o):
        o = self._lift(o)
        return Jet(self.v * o.v, self.d1 * o.v + self.v * o.d1, self.d2 * o.v + 2 * self.d1 * o.d1 + self.v * o.d2)

    __rmul__ = __mul__

    def _apply(self, f0, f1, f2):
        return Jet(f0, f1 * self.d1, f2 * self.d1**2 + f1 * self.d2)

    def sin(self):
        s, c = np.sin(self.v), np.cos(self.v)
        return self._apply(s, c, -s)

    def cos(self):
        s, c = np.sin(self.v), np.cos(self.v)
        return self._apply(c, -s, -c)

    @staticmethod
    def atan2(y: "Jet", x: "Jet") -> "Jet":
        """atan2 of two jets (derivative of the angle of the vector (x, y))."""
        den = x.v**2 + y.v**2
        num = x.v * y.d1 - y.v * x.d1
        dnum = x.v * y.d2 - y.v * x.d2
        dden = 2 * (x.v * x.d1 + y.v * y.d1)
        return Jet(np.arctan2(y.v, x.v), num / den, (dnum * den - num * dden) / den**2)


def _smoothstep(u):
    """Quintic smoothstep s(u) on [0,1] and its derivatives s', s'', s''' and integral S (u clipped)."""
    uc = np.clip(u, 0.0, 1.0)
    inside = (u > 0) & (u < 1)
    s = uc**3 * (10 - 15 * uc + 6 * uc**2)
    s1 = np.where(inside, 30 * uc**2 * (1 - uc) ** 2, 0.0)
    s2 = np.where(inside, 60 * uc - 180 * uc**2 + 120 * uc**3, 0.0)
    s3 = np.where(inside, 60 - 360 * uc + 360 * uc**2, 0.0)
    integ = np.where(u <= 1, uc**4 * (2.5 - 3 * uc + uc**2), 0.5 + (u - 1))
    integ = np.where(u <= 0, 0.0, integ)
    return s, s1, s2, s3, integ


class _Schedule:
    """A scalar history made of smoothstep ramps: x(t) = x0 + Σ Δ_i s((t - t_i)/T_i).

    Gives jets of x (order 2), of ẋ (order 2: ẋ, ẍ, x⃛) and the integral ∫x dt.
    """

    def __init__(self, x0: float = 0.0):
        self.x0 = x0
        self.ramps: list[tuple[float, float, float]] = []

    def ramp(self, t0: float, dur: float, delta: float) -> None:
        if delta != 0.0:
            self.ramps.append((t0, dur, delta))

    def jets(self, t):
        t = np.asarray(t, float)
        x = np.full_like(t, self.x0)
        d1, d2, d3 = np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)
        integ = self.x0 * t
        # after a ramp: x += Δ and ∫ += Δ (t - t0 - dur/2); accumulated with difference arrays
        step = np.zeros(t.size + 1)
        const = np.zeros(t.size + 1)
        for t0, dur, delta in self.ramps:
            i0, i1 = np.searchsorted(t, [t0, t0 + dur], side="left")
            sl = slice(i0, i1)
            s, s1, s2, s3, S = _smoothstep((t[sl] - t0) / dur)
            x[sl] += delta * s
            d1[sl] += delta * s1 / dur
            d2[sl] += delta * s2 / dur**2
            d3[sl] += delta * s3 / dur**3
            integ[sl] += delta * dur * S
            step[i1] += delta
            const[i1] -= delta * (t0 + dur / 2)
        cs = np.cumsum(step)[:-1]
        x += cs
        integ += cs * t + np.cumsum(const)[:-1]
        return Jet(x, d1, d2), Jet(d1, d2, d3), integ


# --------------------------------------------------------------------------- result
@dataclass(frozen=True)
class Trajectory:
    """Truth kinematics sampled at ``t``.

    Fields
    ------
    profile : str                 profile name
    t : (N,) [s]                  sample times (uniform, from 0)
    quat : (N, 4) [-]             attitude quaternion body→nav (NED), scalar first
    roll, pitch, yaw : (N,) [rad] ZYX Euler angles of ``quat``
    omega_b : (N, 3) [rad/s]      body rate relative to the navigation (≈ inertial) frame, body axes
    omega_dot_b : (N, 3) [rad/s^2] body angular acceleration, body axes
    f_b : (N, 3) [m/s^2]          specific force at the sensor (lever arm included), body axes
    vel_n : (N, 3) [m/s]          velocity of the rotation centre in NED (zero for the table profiles
                                  except ``shake``, where it is the integral of the table acceleration)
    lever_arm : (3,) [m]          sensor position from the rotation centre, body axes
    segment : (N,) str            segment name of each sample (e.g. 'takeoff', 'turn-1')
    phase : (N,) str              'stable' or 'manoeuvre'
    """

    profile: str
    t: np.ndarray
    quat: np.ndarray
    roll: np.ndarray
    pitch: np.ndarray
    yaw: np.ndarray
    omega_b: np.ndarray
    omega_dot_b: np.ndarray
    f_b: np.ndarray
    vel_n: np.ndarray
    lever_arm: np.ndarray
    segment: np.ndarray
    phase: np.ndarray

    @property
    def stable(self) -> np.ndarray:
        """(N,) bool: samples labelled 'stable'."""
        return self.phase == "stable"

    @property
    def rate_hz(self) -> float:
        """Sample rate [Hz]."""
        return 1.0 / float(self.t[1] - self.t[0])


def assemble_trajectory(profile, t, roll: Jet, pitch: Jet, yaw: Jet, a_n, lever_arm, segment, phase,
                        vel_n=None) -> Trajectory:
    """The :class:`Trajectory` of ``profile`` (its name): body rate [rad/s], angular acceleration [rad/s^2] and
    specific force [m/s^2] from the Euler angles' jets [rad, rad/s, rad/s^2] on times ``t`` [s], the nav-frame
    acceleration ``a_n`` (n, 3) [m/s^2] and the sensor's ``lever_arm`` (3,) [m]; ``segment`` and ``phase``
    label each sample; ``vel_n`` (n, 3) [m/s] the nav velocity (None: zero)."""
    sphi, cphi = roll.sin(), roll.cos()
    sth, cth = pitch.sin(), pitch.cos()
    rdot = Jet(roll.d1, roll.d2)
    pdot = Jet(pitch.d1, pitch.d2)
    ydot = Jet(yaw.d1, yaw.d2)
    p = rdot - ydot * sth
    q = pdot * cphi + ydot * cth * sphi
    r = -(pdot * sphi) + ydot * cth * cphi
    omega = np.stack([p.v, q.v, r.v], -1)
    omega_dot = np.stack([p.d1, q.d1, r.d1], -1)
    quat = euler_to_quat(roll.v, pitch.v, yaw.v)
    c_nb = quat_to_dcm(quat)
    g_n = np.array([0.0, 0.0, G0])
    f_cg = np.einsum("nji,nj->ni", c_nb, np.asarray(a_n, float) - g_n)
    d = np.asarray(lever_arm, float)
    f_b = f_cg + np.cross(omega_dot, d) + np.cross(omega, np.cross(omega, d))
    return Trajectory(
        profile=profile,
        t=t,
        quat=quat,
        roll=roll.v.copy(),
        pitch=pitch.v.copy(),
        yaw=yaw.v.copy(),
        omega_b=omega,
        omega_dot_b=omega_dot,
        f_b=f_b,
        vel_n=np.zeros((t.size, 3)) if vel_n is None else np.asarray(vel_n, float),
        lever_arm=d.copy(),
        segment=np.asarray(segment),
        phase=np.asarray(phase),
    )


def _time(duration: float, rate_hz: float) -> np.ndarray:
    n = int(round(duration * rate_hz))
    return np.arange(n) / rate_hz


def _labels(t, segments):
    """Per-sample segment names and phases from [(name, phase, t_start, t_end), ...]."""
    seg = np.empty(t.shape, dtype=object)
    ph = np.empty(t.shape, dtype=object)
    for name, phase, t0, t1 in segments:
        m = (t >= t0 - 1e-9) & (t < t1 - 1e-9)
        seg[m] = name
        ph[m] = phase
    name, phase = segments[-1][0], segments[-1][1]
    seg[seg == None] = name  # noqa: E711  (tail rounding)
    ph[ph == None] = phase  # noqa: E711
    return seg.astype(str), ph.astype(str)


def _check_common(duration, rate_hz, lever_arm, min_duration):
    if not np.isfinite(rate_hz) or rate_hz <= 0:
        raise InputError(f"motion: rate_hz={rate_hz!r} is invalid; valid: a positive sample rate [Hz]")
    if not np.isfinite(duration) or duration < min_duration:
        raise InputError(f"motion: duration={duration!r} s is invalid; valid: a duration >= {min_duration} s")
    d = np.asarray(lever_arm, float)
    if d.shape != (3,) or not np.all(np.isfinite(d)):
        raise InputError(f"motion: lever_arm={lever_arm!r} is invalid; valid: three finite lengths [m]")
    return d


# --------------------------------------------------------------------------- profiles
def static_profile(duration: float = 60.0, rate_hz: float = 100.0, *, roll_deg: float = 0.0,
                   pitch_deg: float = 0.0, yaw_deg: float = 0.0, lever_arm=(0.0, 0.0, 0.0)) -> Trajectory:
    """Unit at rest at a fixed attitude.

    duration [s], rate_hz [Hz], roll_deg/pitch_deg/yaw_deg [deg], lever_arm (3,) [m].
    """
    d = _check_common(duration, rate_hz, lever_arm, 1.0)
    t = _time(duration, rate_hz)
    z = np.zeros_like(t)
    j = lambda deg: Jet(np.full_like(t, np.radians(deg)), z, z)  # noqa: E731
    seg, ph = _labels(t, [("static", "stable", 0.0, t[-1] + 1)])
    return assemble_trajectory("static", t, j(roll_deg), j(pitch_deg), j(yaw_deg), np.zeros((t.size, 3)), d, seg, ph)


def swing_profile(duration: float = 60.0, rate_hz: float = 100.0, *, axis: str = "x",
                  amplitude_deg: float = 80.0, peak_rate_dps: float = 200.0, settle_s: float = 10.0,
                  envelope_s: float = 5.0, lever_arm=(0.0, 0.0, 0.0)) -> Trajectory:
    """Turntable swing about body ``axis`` ('x' roll or 'y' pitch).

    angle(t) = E(t) · A · sin(Ω (t - t0)), Ω = peak_rate / A, with a smoothstep
    envelope E rising over ``envelope_s`` after ``settle_s`` of rest and falling
    over the last ``envelope_s`` before a final ``settle_s`` of rest. Between the
    envelopes the rate peaks at ``peak_rate_dps``.

    duration [s], rate_hz [Hz], amplitude_deg [deg], peak_rate_dps [deg/s],
    settle_s [s], envelope_s [s], lever_arm (3,) [m] from the table axis.
    """
    d = _check_common(duration, rate_hz, lever_arm, 2 * settle_s + 2 * envelope_s + 1.0)
    if axis not in ("x", "y"):
        raise InputError(f"swing: axis={axis!r} is invalid; valid: 'x' (roll) or 'y' (pitch)")
    t = _time(duration, rate_hz)
    A = np.radians(amplitude_deg)
    W = np.radians(peak_rate_dps) / A
    t0, t3 = settle_s, duration - settle_s
    env = _Schedule(0.0)
    env.ramp(t0, envelope_s, 1.0)
    env.ramp(t3 - envelope_s, envelope_s, -1.0)
    e, _, _ = env.jets(t)
    ph = W * (t - t0)
    osc = Jet(A * np.sin(ph), A * W * np.cos(ph), -A * W**2 * np.sin(ph))
    angle = e * osc
    zero = Jet(np.zeros_like(t))
    roll, pitch = (angle, zero) if axis == "x" else (zero, angle)
    seg, phl = _labels(t, [("rest", "stable", 0.0, t0), ("swing", "manoeuvre", t0, t3),
                           ("rest-end", "stable", t3, t[-1] + 1)])
    return assemble_trajectory("swing", t, roll, pitch, Jet(np.zeros_like(t)), np.zeros((t.size, 3)), d, seg, phl)


def shake_profile(duration: float = 60.0, rate_hz: float = 100.0, *, peak_accel_g: float = 1.2,
                  freq_hz: float = 2.0, burst_s: float = 6.0, gap_s: float = 6.0, settle_s: float = 10.0,
                  lever_arm=(0.0, 0.0, 0.0)) -> Trajectory:
    """Level table shaken horizontally (fore-aft and sideways) in bursts, attitude constant.

    a_n(t) = E(t) · a_pk · [sin(2π f t), sin(2π 0.7 f t + 1)] · [1, 0.8] in each burst,
    E a smoothstep-shaped envelope; peak horizontal acceleration above 1 g.

    duration [s], rate_hz [Hz], peak_accel_g [g], freq_hz [Hz], burst_s [s], gap_s [s],
    settle_s [s] rest at the start, lever_arm (3,) [m].
    """
    d = _check_common(duration, rate_hz, lever_arm, settle_s + burst_s + 1.0)
    t = _time(duration, rate_hz)
    env = _Schedule(0.0)
    segs = [("rest", "stable", 0.0, settle_s)]
    t0, k = settle_s, 1
    ramp = min(1.0, burst_s / 4)
    while t0 + burst_s <= duration - 1.0:
        env.ramp(t0, ramp, 1.0)
        env.ramp(t0 + burst_s - ramp, ramp, -1.0)
        segs.append((f"shake-{k}", "manoeuvre", t0, t0 + burst_s))
        nxt = min(t0 + burst_s + gap_s, duration)
        segs.append((f"rest-{k}", "stable", t0 + burst_s, nxt if nxt < duration else t[-1] + 1))
        t0, k = t0 + burst_s + gap_s, k + 1
    e, _, _ = env.jets(t)
    a = peak_accel_g * G0
    w1, w2 = 2 * np.pi * freq_hz, 2 * np.pi * 0.7 * freq_hz
    a_n = np.zeros((t.size, 3))
    a_n[:, 0] = a * e.v * np.sin(w1 * t)
    a_n[:, 1] = 0.8 * a * e.v * np.sin(w2 * t + 1.0)
    from scipy.integrate import cumulative_trapezoid

    vel = cumulative_trapezoid(a_n, t, axis=0, initial=0.0)
    zero = Jet(np.zeros_like(t))
    seg, ph = _labels(t, segs)
    return assemble_trajectory("shake", t, zero, zero, zero, a_n, d, seg, ph, vel)


#: the flight plan: (name, phase, nominal duration [s], ΔA [m/s^2], Δγ [deg], Δψ̇ [deg/s]);
#: A is the along-path acceleration (V = ∫A dt): takeoff and landing apply thrust / brakes
#: within 2 s and hold about 0.25 g, as a real aircraft does (60 m/s after 24 s).
_TAKEOFF = [
    ("ground", "stable", 20.0, 0, 0, 0),
    ("takeoff", "manoeuvre", 2.0, 2.5, 0, 0),
    ("takeoff", "manoeuvre", 22.0, 0, 0, 0),
    ("takeoff", "manoeuvre", 2.0, -2.5, 0, 0),
    ("rotate", "manoeuvre", 6.0, 0, 8.0, 0),
    ("climb", "stable", 30.0, 0, 0, 0),
    ("level-off", "manoeuvre", 6.0, 0, -8.0, 0),
]
_CYCLE = [
    ("level", "stable", 20.0, 0, 0, 0),
    ("turn", "manoeuvre", 4.0, 0, 0, 3.0),
    ("turn", "manoeuvre", 30.0, 0, 0, 0),
    ("turn", "manoeuvre", 4.0, 0, 0, -3.0),
    ("level", "stable", 20.0, 0, 0, 0),
    ("pitch", "manoeuvre", 4.0, 0, 6.0, 0),
    ("pitch", "manoeuvre", 8.0, 0, -12.0, 0),
    ("pitch", "manoeuvre", 4.0, 0, 6.0, 0),
    ("level", "stable", 20.0, 0, 0, 0),
    ("circle", "manoeuvre", 5.0, 0, 0, -6.0),
    ("circle", "manoeuvre", 60.0, 0, 0, 0),
    ("circle", "manoeuvre", 5.0, 0, 0, 6.0),
]
_LANDING = [
    ("level", "stable", 20.0, 0, 0, 0),
    ("descent-entry", "manoeuvre", 6.0, 0, -4.0, 0),
    ("descent", "stable", 30.0, 0, 0, 0),
    ("flare", "manoeuvre", 6.0, 0, 4.0, 0),
    ("landing", "manoeuvre", 2.0, -2.5, 0, 0),
    ("landing", "manoeuvre", 22.0, 0, 0, 0),
    ("landing", "manoeuvre", 2.0, 2.5, 0, 0),
    ("stop", "stable", 10.0, 0, 0, 0),
]


def _plan_schedules(plan, t: np.ndarray):
    """Speed, flight-path angle and heading-rate schedules of a plan [(name, phase, T [s], dv [m/s],
    dγ [deg], dψ̇ [deg/s]), ...] ramped segment by segment, and the segments (name, phase, start, end [s])
    (the last one open to the end of ``t``)."""
    acc, gam, psid = _Schedule(0.0), _Schedule(0.0), _Schedule(0.0)
    segs, t0 = [], 0.0
    for name, phase, T, dv, dg, dw in plan:
        acc.ramp(t0, T, dv)
        gam.ramp(t0, T, np.radians(dg))
        psid.ramp(t0, T, np.radians(dw))
        segs.append((name, phase, t0, t0 + T))
        t0 += T
    segs[-1] = (segs[-1][0], segs[-1][1], segs[-1][2], t[-1] + 1)
    return acc, gam, psid, segs


def flight_plan(duration: float) -> list[tuple[str, str, float, float, float, float]]:
    """Segments of the flight profile filling ``duration`` [s].

    Takeoff, one or more cycles (level, coordinated turn, level, pitch
    manoeuvre, level, circling) and landing. Extra time beyond the nominal
    plan adds whole cycles and stretches the level legs; a shorter duration
    compresses every segment proportionally (sharper manoeuvres, lower speed).
    Returns [(name, phase, duration [s], ΔA [m/s^2], Δγ [deg], Δψ̇ [deg/s]), ...]
    with numbered segment names ('turn-1', 'level-2', ...).
    """
    fixed = sum(s[2] for s in _TAKEOFF + _LANDING)
    cyc = sum(s[2] for s in _CYCLE)
    n_cyc = max(1, int((duration - fixed) // cyc))
    plan = _TAKEOFF + _CYCLE * n_cyc + _LANDING
    nominal = sum(s[2] for s in plan)
    if duration >= nominal:
        n_level = sum(1 for s in plan if s[0] == "level")
        extra = (duration - nominal) / n_level
        plan = [(n, p, T + (extra if n == "level" else 0.0), dv, dg, dw) for n, p, T, dv, dg, dw in plan]
    else:
        k = duration / nominal
        plan = [(n, p, T * k, dv, dg, dw) for n, p, T, dv, dg, dw in plan]
    counts: dict[str, int] = {}
    out = []
    prev = None
    for n, p, T, dv, dg, dw in plan:
        if n != prev:
            counts[n] = counts.get(n, 0) + 1
        prev = n
        out.append((f"{n}-{counts[n]}", p, T, dv, dg, dw))
    return out


def flight_profile(duration: float = 400.0, rate_hz: float = 100.0, *, lever_arm=(0.0, 0.0, 0.0),
                   heading_deg: float = 0.0) -> Trajectory:
    """Aircraft flight: takeoff, climb, coordinated turns, pitch manoeuvre, circling, descent, landing.

    Along-path acceleration A (V = ∫A), flight-path angle γ and turn rate ψ̇ are smoothstep histories
    (see :func:`flight_plan`); the body x axis is along the velocity
    (pitch = γ, yaw = heading ψ) and the bank is coordinated (zero lateral
    specific force): ``φ = atan2(V cos γ ψ̇, V γ̇ + g cos γ)``.

    duration [s] (>= 60; default 400 s, one cycle; 3600 s gives ~12 cycles),
    rate_hz [Hz], lever_arm (3,) [m] sensor position from the CG, heading_deg [deg].
    """
    d = _check_common(duration, rate_hz, lever_arm, 60.0)
    t = _time(duration, rate_hz)
    acc, gam, psid, segs = _plan_schedules(flight_plan(duration), t)
    aj, _, v_int = acc.jets(t)
    Vj = Jet(v_int, aj.v, aj.d1)
    Vdj = aj
    gj, gdj, _ = gam.jets(t)
    wj, wdj, psi_int = psid.jets(t)
    yaw = Jet(np.radians(heading_deg) + psi_int, wj.v, wj.d1)
    cg, sg = gj.cos(), gj.sin()
    num = Vj * cg * wj
    den = Vj * gdj + G0 * cg
    roll = Jet.atan2(num, den)
    # nav acceleration: V̇ u + V (ψ̇ cosγ y_w - γ̇ z_w)
    u = np.stack([cg.v * np.cos(yaw.v), cg.v * np.sin(yaw.v), -sg.v], -1)
    yw = np.stack([-np.sin(yaw.v), np.cos(yaw.v), np.zeros_like(t)], -1)
    zw = np.stack([sg.v * np.cos(yaw.v), sg.v * np.sin(yaw.v), cg.v], -1)
    a_n = Vdj.v[:, None] * u + (Vj.v * wj.v * cg.v)[:, None] * yw - (Vj.v * gdj.v)[:, None] * zw
    seg, ph = _labels(t, segs)
    return assemble_trajectory("flight", t, roll, gj, yaw, a_n, d, seg, ph, Vj.v[:, None] * u)


def make_profile(name: str, duration: float | None = None, rate_hz: float = 100.0, **kwargs) -> Trajectory:
    """Build profile ``name`` (one of :data:`PROFILES`); ``duration`` [s] None → the profile default."""
    builders = {"static": static_profile, "swing": swing_profile, "shake": shake_profile,
                "flight": flight_profile, "vehicle": vehicle_profile, "handheld": handheld_profile}
    if name not in builders:
        raise InputError(f"motion: profile={name!r} is unknown; valid: {', '.join(PROFILES)}")
    if duration is not None:
        kwargs["duration"] = float(duration)
    return builders[name](rate_hz=rate_hz, **kwargs)


# --------------------------------------------------------------------------- ground vehicle
#: the drive: (name, phase, nominal duration [s], ΔA [m/s^2], Δγ [deg], Δψ̇ [deg/s]) as in the flight plan;
#: speeds 14 m/s (50 km/h) in town, 5 m/s round a corner; the speed returns to exactly 0 at the stop
#: (the ΔA ramps integrate to +14, -9, +9, -14 m/s, and they scale together when the plan is compressed).
_DRIVE = [
    ("rest", "stable", 20.0, 0, 0, 0),
    ("accelerate", "manoeuvre", 2.0, 2.0, 0, 0), ("accelerate", "manoeuvre", 5.0, 0, 0, 0),
    ("accelerate", "manoeuvre", 2.0, -2.0, 0, 0),
    ("cruise", "stable", 20.0, 0, 0, 0),
    ("turn", "manoeuvre", 2.0, 0, 0, 12.0), ("turn", "manoeuvre", 5.5, 0, 0, 0),
    ("turn", "manoeuvre", 2.0, 0, 0, -12.0),
    ("cruise", "stable", 15.0, 0, 0, 0),
    ("hill", "manoeuvre", 4.0, 0, 3.0, 0), ("hill", "stable", 10.0, 0, 0, 0), ("hill", "manoeuvre", 8.0, 0, -6.0, 0),
    ("hill", "stable", 10.0, 0, 0, 0), ("hill", "manoeuvre", 4.0, 0, 3.0, 0),
    ("cruise", "stable", 15.0, 0, 0, 0),
    ("brake", "manoeuvre", 1.0, -3.0, 0, 0), ("brake", "manoeuvre", 2.0, 0, 0, 0),
    ("brake", "manoeuvre", 1.0, 3.0, 0, 0),
    ("corner", "manoeuvre", 1.5, 0, 0, -20.0), ("corner", "manoeuvre", 3.0, 0, 0, 0),
    ("corner", "manoeuvre", 1.5, 0, 0, 20.0),
    ("accelerate", "manoeuvre", 1.5, 2.0, 0, 0), ("accelerate", "manoeuvre", 3.0, 0, 0, 0),
    ("accelerate", "manoeuvre", 1.5, -2.0, 0, 0),
    ("cruise", "stable", 20.0, 0, 0, 0),
    ("lane-change", "manoeuvre", 1.0, 0, 0, 8.0), ("lane-change", "manoeuvre", 2.0, 0, 0, -16.0),
    ("lane-change", "manoeuvre", 1.0, 0, 0, 8.0),
    ("cruise", "stable", 20.0, 0, 0, 0),
    ("stop", "manoeuvre", 2.0, -2.0, 0, 0), ("stop", "manoeuvre", 5.0, 0, 0, 0), ("stop", "manoeuvre", 2.0, 2.0, 0, 0),
    ("rest", "stable", 10.0, 0, 0, 0),
]


def _fill(plan, duration: float, stretch: str):
    """Stretch the ``stretch`` segments (duration above the nominal) or compress all (below) to fill ``duration``;
    number the segment names. Returns [(name, phase, duration [s], ΔA, Δγ, Δψ̇), ...]."""
    nominal = sum(s[2] for s in plan)
    if duration >= nominal:
        n = sum(1 for s in plan if s[0] == stretch)
        extra = (duration - nominal) / n
        plan = [(a, p, T + (extra if a == stretch else 0.0), *r) for a, p, T, *r in plan]
    else:
        plan = [(a, p, T * duration / nominal, *r) for a, p, T, *r in plan]
    counts: dict[str, int] = {}
    out, prev = [], None
    for a, p, T, *r in plan:
        if a != prev:
            counts[a] = counts.get(a, 0) + 1
        prev = a
        out.append((f"{a}-{counts[a]}", p, T, *r))
    return out


#: body roll per g of lateral acceleration [deg/g], outward in a turn: Gillespie, Fundamentals of Vehicle
#: Dynamics (SAE 1992), ch. 8: passenger cars 3-7 deg/g; we take 5
VEHICLE_ROLL_GRADIENT_DEG_PER_G = 5.0
#: body pitch per g of longitudinal acceleration [deg/g] (squat / dive): [ASSUMED] 1.5, typical of a passenger car
VEHICLE_PITCH_GRADIENT_DEG_PER_G = 1.5


def vehicle_profile(duration: float = 240.0, rate_hz: float = 100.0, *, lever_arm=(0.0, 0.0, 0.0),
                    heading_deg: float = 0.0, roll_gradient_deg_per_g: float = VEHICLE_ROLL_GRADIENT_DEG_PER_G,
                    pitch_gradient_deg_per_g: float = VEHICLE_PITCH_GRADIENT_DEG_PER_G) -> Trajectory:
    """Ground vehicle drive (:data:`_DRIVE`): rest, accelerate to 14 m/s, a 90° turn at 0.3 g, a hill
    (road grade ±5 %), braking at 0.3 g, a tight corner, a lane change, stop, rest.

    Unlike the aircraft the turns are not coordinated: the lateral acceleration ``V ψ̇ cos γ`` appears in
    the specific force and the body rolls *outward* by ``roll_gradient · a_y / g``; the body pitches by
    ``γ + pitch_gradient · A / g`` (squat when accelerating, dive when braking). Body x is along the
    velocity heading (no tyre slip).

    duration [s] (>= 60, default 240; longer stretches the cruise legs), rate_hz [Hz], lever_arm (3,) [m]
    sensor from the vehicle's reference point, heading_deg [deg], gradients [deg/g].
    """
    d = _check_common(duration, rate_hz, lever_arm, 60.0)
    t = _time(duration, rate_hz)
    acc, gam, psid, segs = _plan_schedules(_fill(_DRIVE, duration, "cruise"), t)
    aj, _, v_int = acc.jets(t)
    Vj = Jet(np.maximum(v_int, 0.0), aj.v, aj.d1)
    gj, gdj, _ = gam.jets(t)
    wj, _, psi_int = psid.jets(t)
    yaw = Jet(np.radians(heading_deg) + psi_int, wj.v, wj.d1)
    cg, sg = gj.cos(), gj.sin()
    a_lat = Vj * wj * cg
    roll = a_lat * (-np.radians(roll_gradient_deg_per_g) / G0)
    pitch = gj + aj * (np.radians(pitch_gradient_deg_per_g) / G0)
    u = np.stack([cg.v * np.cos(yaw.v), cg.v * np.sin(yaw.v), -sg.v], -1)
    yw = np.stack([-np.sin(yaw.v), np.cos(yaw.v), np.zeros_like(t)], -1)
    zw = np.stack([sg.v * np.cos(yaw.v), sg.v * np.sin(yaw.v), cg.v], -1)
    a_n = aj.v[:, None] * u + a_lat.v[:, None] * yw - (Vj.v * gdj.v)[:, None] * zw
    seg, ph = _labels(t, segs)
    return assemble_trajectory("vehicle", t, roll, pitch, yaw, a_n, d, seg, ph, Vj.v[:, None] * u)


# --------------------------------------------------------------------------- handheld
#: the handheld session: (name, phase, nominal duration [s], Δroll [deg], Δpitch [deg], Δyaw [deg], walking 0/1)
_HANDHELD = [
    ("rest", "stable", 15.0, 0, 0, 0, 0),
    ("pick-up", "manoeuvre", 1.5, 10, -25, 0, 0), ("hold", "stable", 8.0, 0, 0, 0, 0),
    ("tilt", "manoeuvre", 1.5, 35, 0, 0, 0), ("hold", "stable", 6.0, 0, 0, 0, 0),
    ("tilt", "manoeuvre", 1.5, -70, 0, 0, 0), ("hold", "stable", 6.0, 0, 0, 0, 0),
    ("tilt", "manoeuvre", 1.0, 35, 30, 90, 0), ("hold", "stable", 6.0, 0, 0, 0, 0),
    ("flick", "manoeuvre", 0.6, 60, 0, 0, 0), ("flick", "manoeuvre", 0.6, -60, 0, 0, 0),
    ("flick", "manoeuvre", 0.6, 0, -40, 0, 0), ("flick", "manoeuvre", 0.6, 0, 40, 0, 0),
    ("hold", "stable", 6.0, 0, 0, 0, 0),
    ("walk", "manoeuvre", 2.0, 0, -5, -90, 1), ("walk", "manoeuvre", 30.0, 0, 0, 0, 1),
    ("walk", "manoeuvre", 3.0, 0, 0, 120, 1), ("walk", "manoeuvre", 15.0, 0, 0, 0, 1),
    ("hold", "stable", 6.0, 0, 0, 0, 0),
    ("put-down", "manoeuvre", 1.5, -10, 0, 0, 0),
    ("rest", "stable", 10.0, 0, 0, 0, 0),
]
#: walking: step frequency [Hz] and the hand's acceleration amplitudes [m/s^2] (fore-aft and vertical at the
#: step frequency, lateral at half of it), attitude sway amplitudes [deg]. [ASSUMED] from gait studies of the
#: trunk (Zijlstra & Hof, Gait & Posture 18 (2003): step frequency ~1.8-2 Hz, vertical trunk acceleration
#: ~±0.3 g, fore-aft ~±0.15 g, lateral ~±0.1 g at the stride frequency); a held unit is taken to follow the trunk.
WALK_STEP_HZ = 1.9
WALK_ACCEL_MPS2 = (1.5, 1.0, 3.0)
WALK_SWAY_DEG = (2.0, 1.5)


def handheld_profile(duration: float = 150.0, rate_hz: float = 100.0, *,
                     lever_arm=(0.08, 0.0, 0.0)) -> Trajectory:
    """A unit held in the hand (:data:`_HANDHELD`): at rest on a table, picked up, tilted by ±35°, turned,
    flicked about roll and pitch (smoothstep of 60° in 0.6 s: 190 °/s peak), carried while walking
    (step accelerations of :data:`WALK_ACCEL_MPS2` at :data:`WALK_STEP_HZ`, sway of :data:`WALK_SWAY_DEG`),
    put down. The hand's hold phases are labelled 'stable' (no linear acceleration, no rotation:
    tremor is a disturbance of :mod:`imutherm.imu.disturbances`).

    duration [s] (>= 60, default 150; longer stretches the holds), rate_hz [Hz], lever_arm (3,) [m]
    sensor from the wrist, the rotation centre (default 8 cm forward).
    """
    d = _check_common(duration, rate_hz, lever_arm, 60.0)
    t = _time(duration, rate_hz)
    R, P, Y, W = _Schedule(0.0), _Schedule(0.0), _Schedule(0.0), _Schedule(0.0)
    plan = [(n, p, T, dr, dp, dy, w) for n, p, T, dr, dp, dy, w in _HANDHELD]
    segs, t0, walking = [], 0.0, 0
    filled = _fill([(n, p, T, (dr, dp, dy, w)) for n, p, T, dr, dp, dy, w in plan], duration, "hold")
    for name, phase, T, (dr, dp, dy, w) in filled:
        R.ramp(t0, T, np.radians(dr))
        P.ramp(t0, T, np.radians(dp))
        Y.ramp(t0, T, np.radians(dy))
        if w != walking:  # walking envelope ramps up over the first walking segment, down over the next
            W.ramp(t0 - (0.0 if w else 1.0), 1.0, 1.0 if w else -1.0)
            walking = w
        segs.append((name, phase, t0, t0 + T))
        t0 += T
    segs[-1] = (segs[-1][0], segs[-1][1], segs[-1][2], t[-1] + 1)
    e, _, _ = W.jets(t)
    w1, w2 = 2 * np.pi * WALK_STEP_HZ, np.pi * WALK_STEP_HZ

    def osc(amp, w, ph=0.0):
        s, c = np.sin(w * t + ph), np.cos(w * t + ph)
        return e * Jet(amp * s, amp * w * c, -amp * w * w * s)

    rj, _, _ = R.jets(t)
    pj, _, _ = P.jets(t)
    yj, _, _ = Y.jets(t)
    roll = rj + osc(np.radians(WALK_SWAY_DEG[0]), w2, 0.3)
    pitch = pj + osc(np.radians(WALK_SWAY_DEG[1]), w1, 1.1)
    # walking acceleration in the walking direction (the heading), lateral and vertical
    ax, ay, az = (osc(a, w, ph).v for a, w, ph in
                  zip(WALK_ACCEL_MPS2, (w1, w2, w1), (0.0, 0.5, 1.6)))
    ch, sh = np.cos(yj.v), np.sin(yj.v)
    a_n = np.stack([ax * ch - ay * sh, ax * sh + ay * ch, az], -1)
    from scipy.integrate import cumulative_trapezoid

    vel = cumulative_trapezoid(a_n, t, axis=0, initial=0.0)
    seg, ph = _labels(t, segs)
    return assemble_trajectory("handheld", t, roll, pitch, yj, a_n, d, seg, ph, vel)
