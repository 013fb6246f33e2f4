"""The rotation between a log's reference body frame and its IMU frame, decided on the record's own evidence.

A recorded log's reference (roll, pitch of the reference body) and its IMU agree, if the frames are the same, in
two ways that need no filter (:func:`consistency`):

* **at rest** (|ω| < 5 °/s, ||f| - g| < 0.02 g): the accelerometer's down direction -f/|f| is the reference's down
  carried into the IMU frame, ``A r_ref``;
* **in motion**: the gyro, integrated alone over a short window (:data:`WINDOW_S`, the rest window's mean rate as
  bias), turns the reference's down at the window's start into its down at the window's end (the vertical is fixed
  in an inertial frame): ``A r_ref(t+W) = Φᵀ A r_ref(t)``, Φ the gyro's rotation over the window; windows that
  turn the unit by less than :data:`MIN_TURN_DEG` carry no information on A and are left out.

The consistency residual of a rotation A is the mean of the two kinds' median angles [deg]. :func:`decide` fits A
(least squares from each of the 24 axis permutations with signs, :func:`signed_permutations`, so that a 90° yaw or
a swapped axis is found from its own basin) and keeps it only when it lowers the residual against the identity's
by :data:`MARGIN_DEG` and by :data:`MARGIN_FRAC` of it (the stated margin): a correctly aligned record keeps the
identity, and says so. A kept rotation of :data:`MOUNT_DEG` or more is a *mounting error*, named
(:func:`describe`) with the fix (the ``--align`` roll, pitch, yaw that undoes it).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from imutherm.imu.attitude_math import G0

#: window over which the gyro alone carries the reference's down [s]
WINDOW_S = 0.5
#: a window must turn the unit by this much to count [deg]
MIN_TURN_DEG = 5.0
#: still samples: |ω| below this [rad/s] and ||f| - g| below STILL_ACC g
STILL_RATE = math.radians(5.0)
STILL_ACC = 0.02
#: a fitted rotation is applied only if it lowers the consistency residual by at least MARGIN_DEG [deg] and by at
#: least MARGIN_FRAC of the identity's
MARGIN_DEG = 0.5
MARGIN_FRAC = 0.3
#: a kept rotation this large [deg] is a mounting error (named, with the fix)
MOUNT_DEG = 10.0
#: windows (and still samples) used by the fit, at most (evenly spaced)
FIT_POINTS = 1500


def signed_permutations() -> list:
    """The 24 proper rotations that map axes onto axes (permutations with signs, det +1); the first is the identity."""
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            m = np.zeros((3, 3))
            for i, (j, s) in enumerate(zip(perm, signs)):
                m[i, j] = s
            if np.linalg.det(m) > 0:
                out.append(m)
    out.sort(key=lambda m: -np.trace(m))
    return out


def _rotvec(v) -> np.ndarray:
    th = float(np.linalg.norm(v))
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    if th < 1e-12:
        return np.eye(3) + K
    return np.eye(3) + math.sin(th) / th * K + (1 - math.cos(th)) / th**2 * K @ K


def _strapdown(gyro, dt) -> np.ndarray:
    """Body -> inertial rotation matrices (N,3,3) of the gyro alone (interval samples, from the identity)."""
    from imutherm.imu.reference_log import quat_to_dcm_wxyz

    n = len(gyro)
    q = np.empty((n, 4))
    w, x, y, z = 1.0, 0.0, 0.0, 0.0
    for k, (gx, gy, gz) in enumerate(np.asarray(gyro, float).tolist()):
        hx, hy, hz = 0.5 * dt * gx, 0.5 * dt * gy, 0.5 * dt * gz
        nn = math.sqrt(hx * hx + hy * hy + hz * hz)
        s = math.sin(nn) / nn if nn > 1e-12 else 1.0
        c = math.cos(nn)
        dx, dy, dz = hx * s, hy * s, hz * s
        w, x, y, z = (w * c - x * dx - y * dy - z * dz, w * dx + x * c + y * dz - z * dy,
                      w * dy - x * dz + y * c + z * dx, w * dz + x * dy - y * dx + z * c)
        q[k] = (w, x, y, z)
    return quat_to_dcm_wxyz(q)


@dataclass(frozen=True)
class Evidence:
    """The pairs a rotation is tested on: still (S,) indices with m (S,3) the accelerometer's down and u (S,3) the
    reference's down there; windows: u0, u1 (K,3) the reference's down at a window's start and end, Phi (K,3,3) the
    gyro's rotation over it (body at the end <- body at the start)."""

    m: np.ndarray = field(repr=False)
    u: np.ndarray = field(repr=False)
    u0: np.ndarray = field(repr=False)
    u1: np.ndarray = field(repr=False)
    Phi: np.ndarray = field(repr=False)

    def thin(self, n: int) -> "Evidence":
        """At most n of each kind, evenly spaced."""
        a = np.unique(np.linspace(0, len(self.m) - 1, min(n, len(self.m))).astype(int)) if len(self.m) else []
        b = np.unique(np.linspace(0, len(self.u0) - 1, min(n, len(self.u0))).astype(int)) if len(self.u0) else []
        return Evidence(self.m[a], self.u[a], self.u0[b], self.u1[b], self.Phi[b])


def evidence(r_ref, gyro, accel, dt: float, g_rest: float, bias) -> Evidence:
    """Still pairs and gyro windows of a record: r_ref (N,3) [-] the reference's down in its body frame (NaN where
    missing), gyro (N,3) [rad/s], accel (N,3) [m/s^2] in the IMU frame on the same samples, dt [s], g_rest
    [m/s^2] |f| at rest, bias (3,) [rad/s]."""
    r_ref = np.asarray(r_ref, float)
    gyro = np.asarray(gyro, float) - np.asarray(bias, float)
    accel = np.asarray(accel, float)
    ok = np.all(np.isfinite(r_ref), axis=1)
    fn = np.linalg.norm(accel, axis=1)
    still = ok & (np.linalg.norm(gyro, axis=1) < STILL_RATE) & (np.abs(fn - g_rest) < STILL_ACC * G0)
    C = _strapdown(gyro, dt)
    w = max(1, int(round(WINDOW_S / dt)))
    i0 = np.arange(0, len(gyro) - w, max(1, w // 2))
    i1 = i0 + w
    Phi = np.einsum("nji,njk->nik", C[i1], C[i0])  # C(t1)^T C(t0): body(t0) -> body(t1)
    turn = np.degrees(np.arccos(np.clip((np.trace(Phi, axis1=1, axis2=2) - 1) / 2, -1, 1)))
    use = ok[i0] & ok[i1] & (turn > MIN_TURN_DEG)
    return Evidence(-accel[still] / fn[still, None], r_ref[still], r_ref[i0[use]], r_ref[i1[use]], Phi[use])


def _angles(a, b) -> np.ndarray:
    a = a / np.linalg.norm(a, axis=1, keepdims=True)
    b = b / np.linalg.norm(b, axis=1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.sum(a * b, axis=1), -1.0, 1.0)))


def consistency(A, ev: Evidence) -> dict:
    """Residuals [deg] of rotation A (reference body -> IMU) on ``ev``: still (median angle between A u and the
    accelerometer's down), motion (median angle between A u1 and Φ A u0), residual (their mean; the one present if
    only one kind is), n_still, n_windows."""
    out = {"n_still": int(len(ev.m)), "n_windows": int(len(ev.u0)), "still_deg": None, "motion_deg": None}
    if len(ev.m):
        out["still_deg"] = float(np.median(_angles(ev.u @ A.T, ev.m)))
    if len(ev.u0):
        out["motion_deg"] = float(np.median(_angles(ev.u1 @ A.T, np.einsum("nij,nj->ni", ev.Phi, ev.u0 @ A.T))))
    vals = [v for v in (out["still_deg"], out["motion_deg"]) if v is not None]
    out["residual_deg"] = float(np.mean(vals)) if vals else None
    return out


def _residuals(A, ev: Evidence) -> np.ndarray:
    """Cross-product residuals (smooth in A) of both kinds, each kind weighted to count equally."""
    parts = []
    if len(ev.m):
        parts.append(np.cross(ev.u @ A.T, ev.m).ravel() / math.sqrt(len(ev.m)))
    if len(ev.u0):
        parts.append(np.cross(ev.u1 @ A.T, np.einsum("nij,nj->ni", ev.Phi, ev.u0 @ A.T)).ravel()
                     / math.sqrt(len(ev.u0)))
    return np.concatenate(parts)


def fit(ev: Evidence) -> np.ndarray:
    """The rotation A minimising the residuals of :func:`consistency`: least squares on a rotation vector from each
    of :func:`signed_permutations`, the best kept."""
    from scipy.optimize import least_squares

    thin = ev.thin(FIT_POINTS)
    best, cost = np.eye(3), math.inf
    for A0 in signed_permutations():
        r = least_squares(lambda v: _residuals(_rotvec(v) @ A0, thin), np.zeros(3), method="lm", max_nfev=200)
        if r.cost < cost:
            best, cost = _rotvec(r.x) @ A0, r.cost
    return best


def describe(A) -> str:
    """A mounting rotation A (reference body -> IMU) in words, as the IMU frame sits in the reference body frame:
    the nearest axis mapping (a yaw of 90° / 180° / 270°, swapped or flipped axes) and the angle off it if more than
    2°; a rotation nearest the identity by its angle and axis."""
    from imutherm.imu.reference_log import rotation_angle_deg

    B = np.asarray(A).T  # IMU axes in the reference body frame
    P = min(signed_permutations(), key=lambda m: rotation_angle_deg(B @ m.T))
    off = rotation_angle_deg(B @ P.T)
    names = "xyz"
    if np.allclose(P, np.eye(3)):
        from scipy.spatial.transform import Rotation

        v = Rotation.from_matrix(B).as_rotvec()
        ax = v / np.linalg.norm(v)
        return f"a {math.degrees(np.linalg.norm(v)):.0f}° rotation about ({ax[0]:.2f}, {ax[1]:.2f}, {ax[2]:.2f})"
    if P[2, 2] == 1.0:
        words = f"the IMU turned {round(math.degrees(math.atan2(P[1, 0], P[0, 0]))) % 360}° in yaw (about z)"
    else:
        maps = []
        for i in range(3):
            j = int(np.argmax(np.abs(P[:, i])))
            maps.append(f"IMU {names[i]} along {'-' if P[j, i] < 0 else '+'}{names[j]} of the reference")
        words = "axes " + ", ".join(maps)
    return words + (f", {off:.0f}° off that" if off > 2.0 else "")


def align_rpy_deg(A) -> tuple:
    """The ``--align`` roll, pitch, yaw [deg] (the IMU's ZYX Euler angles in the reference body frame) of A."""
    from scipy.spatial.transform import Rotation

    yaw, pitch, roll = Rotation.from_matrix(np.asarray(A).T).as_euler("ZYX", degrees=True)
    return tuple(float(round(v, 1)) + (360.0 if round(v, 1) <= -180.0 else 0.0) + 0.0 for v in (roll, pitch, yaw))


@dataclass(frozen=True)
class Decision:
    """Result of :func:`decide`: A (3,3) the rotation to apply (identity unless the fit won); fitted (3,3) the
    best-fitting rotation; applied : bool; angle_deg [deg] of the fitted rotation; identity, fit : the
    :func:`consistency` dicts; mounting : a description when the fitted rotation is a mounting error (>= MOUNT_DEG and
    past the margin), else None; align_rpy_deg : the ``--align`` that applies it; why : one line."""

    A: np.ndarray = field(repr=False)
    fitted: np.ndarray = field(repr=False)
    applied: bool
    angle_deg: float
    identity: dict
    fit: dict
    mounting: str | None
    align_rpy_deg: tuple
    why: str

    def to_json(self) -> dict:
        return {"applied": self.applied, "fitted_angle_deg": self.angle_deg, "identity": self.identity,
                "fitted": self.fit, "fitted_A": self.fitted.tolist(), "mounting": self.mounting,
                "align_rpy_deg": list(self.align_rpy_deg), "why": self.why,
                "rule": f"a fitted rotation applies if it lowers the consistency residual by >= {MARGIN_DEG:g}° and "
                        f">= {100 * MARGIN_FRAC:.0f} % of the identity's; >= {MOUNT_DEG:g}° is a mounting error"}


def decide(r_ref, gyro, accel, dt: float, g_rest: float, bias) -> Decision:
    """Fit the reference-to-IMU rotation on the record's evidence and decide by the margin (module docstring)."""
    from imutherm.imu.reference_log import rotation_angle_deg

    ev = evidence(r_ref, gyro, accel, dt, g_rest, bias)
    I = np.eye(3)
    ci = consistency(I, ev)
    if ci["residual_deg"] is None:
        return Decision(I, I, False, 0.0, ci, ci, None, (0.0, 0.0, 0.0),
                        "no still samples and no turning windows with a reference: identity kept (nothing to test)")
    A = fit(ev)
    ca = consistency(A, ev)
    angle = rotation_angle_deg(A)
    gain = ci["residual_deg"] - ca["residual_deg"]
    wins = gain >= MARGIN_DEG and gain >= MARGIN_FRAC * ci["residual_deg"]
    rpy = align_rpy_deg(A)
    if not wins:
        why = (f"identity kept: the best-fitting rotation ({angle:.1f}°) has a consistency residual of "
               f"{ca['residual_deg']:.2f}° against the identity's {ci['residual_deg']:.2f}° (to apply, it must be "
               f"lower by {MARGIN_DEG:g}° and by {100 * MARGIN_FRAC:.0f} %)")
        return Decision(I, A, False, angle, ci, ca, None, rpy, why)
    mount = describe(A) if angle >= MOUNT_DEG else None
    why = (f"a rotation of {angle:.1f}° lowers the consistency residual from {ci['residual_deg']:.2f}° to "
           f"{ca['residual_deg']:.2f}°")
    return Decision(A, A, True, angle, ci, ca, mount, rpy, why)
