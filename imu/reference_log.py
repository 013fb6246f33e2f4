"""Real IMU logs with an optical reference: the ``;``-separated two-header-line layout, true sample times,
and inclination scoring with the fixed reference-to-IMU rotation estimated from the data.

Layout (RepoIMU, Szczęsna et al., *Reference Data Set for Accuracy Evaluation of Orientation Estimation
Algorithms for Inertial Motion Capture Systems*, ICCVG 2016, LNCS 9972, pp. 509-520,
doi:10.1007/978-3-319-46418-3_45)::

    Time;Vicon Orientation;;;;IMU Acceleration;;;IMU Gyroscope;;;IMU Magnetometer;;
    s;W;X;Y;Z;X;Y;Z;X;Y;Z;X;Y;Z
    0;1;0.0003222;...

time [s]; reference quaternion W, X, Y, Z (reference body -> world, world z up); accelerometer [m/s^2];
gyroscope [rad/s]; magnetometer (unused). Cells may use a decimal comma (``-8,00E-05``) or be empty (NaN).

What a real log needs before a filter sees it:

* **sample-and-hold repeats** (:func:`true_samples`): the logger writes the last IMU sample again when no
  new one came (44 % of the rows here); a new sample is a row whose six IMU values differ from the row
  before, and its time is that row's. Duplicate time stamps are dropped with their row.
* **irregular true sample times** (:func:`resample_uniform`): the filters here take one sample period, so
  the true samples are interpolated linearly onto a uniform grid at their median step (each grid value is
  the straight line between the two true samples around it; the gyro's integral over the record is kept
  to the interpolation error of a linear rate).
* **the fixed rotation** ``A`` from the reference body frame to the IMU frame (:func:`estimate_alignment`):
  a least-squares rotation (Kabsch / Wahba, SVD) between pairs of directions seen in both frames: the
  angular-rate directions while the unit turns (reference rate from consecutive quaternions) and the
  up direction while it is quasi-static (|f| near its rest value, |ω| small). Rate pairs alone leave the
  rotation about a single swing axis free; the up pairs fix it. The estimate uses the reference and the
  raw sensor only, never a filter's output, so every filter is scored against the same vertical.
* **inclination** (:func:`inclination_error_deg`): the angle between a filter's vertical and the
  reference's vertical carried into the IMU frame by ``A``; it does not depend on heading.
"""

from __future__ import annotations

import gzip
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from imutherm import InputError


@dataclass(frozen=True)
class ReferenceLog:
    """A reference log as read (rows, not yet de-duplicated).

    path : str; t : (N,) [s]; quat : (N,4) [-] reference body -> world (W, X, Y, Z), NaN where missing;
    accel : (N,3) [m/s^2] and gyro : (N,3) [rad/s] in the IMU's own axes; layout : 'semicolon' | 'broad';
    movement : (N,) bool the rows the data set scores (BROAD's ``movement``), None: every row after a skip;
    aligned : the data set's reference is already in the IMU frame (BROAD), so identity is the expected rotation.
    """

    path: str
    t: np.ndarray = field(repr=False)
    quat: np.ndarray = field(repr=False)
    accel: np.ndarray = field(repr=False)
    gyro: np.ndarray = field(repr=False)
    layout: str = "semicolon"
    movement: np.ndarray | None = field(default=None, repr=False)
    aligned: bool = False


#: the HDF5 datasets of a BROAD trial (Laidig, Caruso, Cereatti, Seel, "BROAD - A Benchmark for Robust Inertial
#: Orientation Estimation", Data 6 (7), 72, 2021, doi:10.3390/data6070072)
BROAD_KEYS = ("imu_gyr", "imu_acc", "opt_quat", "movement")


def _broad_rate(path, rate) -> float:
    """The ``sampling_rate`` attribute as a positive number [Hz], or a one-line InputError saying what it is."""
    r = np.asarray(rate)
    if r.dtype.kind in "SUO":
        text = r.item() if r.size == 1 else r.tolist()
        text = text.decode("utf-8", "replace") if isinstance(text, bytes) else text
        raise InputError(f"{path}: attribute sampling_rate is text ({str(text)[:40]!r}); valid: a number [Hz]")
    if r.size != 1 or r.dtype.kind not in "fiu":
        raise InputError(f"{path}: attribute sampling_rate is {r.dtype} of shape {r.shape}; valid: one number [Hz]")
    v = float(r.reshape(-1)[0])
    if not (math.isfinite(v) and v > 0):
        raise InputError(f"{path}: attribute sampling_rate is {v}; valid: a positive number [Hz]")
    return v


def _broad_dataset(h, key, path, cols) -> np.ndarray:
    """Dataset ``key`` of the open BROAD file ``h`` as a float array (N, cols) (cols None: (N,)); a group, a
    scalar, text or a wrong shape refused in one line naming the file and the key."""
    import h5py

    obj = h[key]
    if not isinstance(obj, h5py.Dataset):
        raise InputError(f"{path}: '{key}' is a {type(obj).__name__.lower()}, not a dataset; valid: BROAD's "
                         f"datasets {', '.join(BROAD_KEYS)} at the file's top level")
    want = "(N,)" if cols is None else f"(N, {cols})"
    if obj.shape == () or obj.shape is None:
        raise InputError(f"{path}: '{key}' is a scalar dataset; valid: an array {want}")
    if obj.dtype.kind not in "fiub":
        raise InputError(f"{path}: '{key}' holds {obj.dtype} ({'text' if obj.dtype.kind in 'SUO' else 'not numbers'}); "
                         f"valid: numbers, an array {want}")
    if (cols is None and len(obj.shape) != 1) or (cols is not None and (len(obj.shape) != 2 or obj.shape[1] != cols)):
        raise InputError(f"{path}: '{key}' has shape {obj.shape}; valid: {want}")
    return np.asarray(obj[()], float if obj.dtype.kind != "b" else bool)


def read_broad_hdf5(path) -> ReferenceLog:
    """Read a BROAD trial (HDF5; h5py): ``imu_gyr`` [rad/s], ``imu_acc`` [m/s^2] in the IMU frame, ``opt_quat``
    (w, x, y, z; IMU -> ENU, synchronised and aligned to the IMU frame by the data set's authors; NaN where the
    optical system lost the body), ``movement`` (the rows scored) and the attribute ``sampling_rate`` [Hz]; rows
    at t = k / rate. The data set's rows keep a regular time base: the IMU's sample-and-hold repeats are rows
    like any other (:func:`true_samples` finds them). Refused in one line (InputError, naming the file and what
    is wrong) for a file that is not HDF5, lacks a dataset or the rate, or is not shaped like BROAD (a group
    where a dataset should be, a scalar dataset, text or byte strings, a rate given as text)."""
    import h5py

    path = Path(path)
    try:
        with h5py.File(path, "r") as h:
            missing = [k for k in BROAD_KEYS if k not in h]
            rate = h.attrs.get("sampling_rate")
            if missing or rate is None:
                raise InputError(f"{path}: not a BROAD trial ({', '.join(missing) or 'sampling_rate'} missing); "
                                 f"valid: HDF5 with datasets {', '.join(BROAD_KEYS)} and attribute sampling_rate")
            rate = _broad_rate(path, rate)
            gyro, acc, quat = (_broad_dataset(h, k, path, c) for k, c in zip(BROAD_KEYS[:3], (3, 3, 4)))
            movement = _broad_dataset(h, "movement", path, None).astype(bool)
    except OSError as exc:
        raise InputError(f"{path}: cannot be read as HDF5 ({exc})") from None
    n = len(gyro)
    if acc.shape != (n, 3) or quat.shape != (n, 4) or movement.shape != (n,):
        raise InputError(f"{path}: BROAD datasets of unequal length (gyro {gyro.shape}, acc {acc.shape}, "
                         f"quat {quat.shape}, movement {movement.shape}); valid: (N,3), (N,3), (N,4), (N,)")
    if n < 2:
        raise InputError(f"{path}: {n} rows; valid: a BROAD trial of at least 2 rows")
    bad = ~(np.all(np.isfinite(gyro), axis=1) & np.all(np.isfinite(acc), axis=1))
    if np.any(bad):
        raise InputError(f"{path}: row {int(np.argmax(bad))} lacks an IMU value; valid: finite gyro and "
                         "accelerometer in every row (only the reference may be NaN)")
    return ReferenceLog(str(path), np.arange(n) / rate, quat, acc, gyro, "broad", movement, True)


def read_reference_log(path) -> ReferenceLog:
    """:func:`read_broad_hdf5` for ``.hdf5`` / ``.h5``, else :func:`read_semicolon_log`."""
    if Path(path).suffix.lower() in (".hdf5", ".h5"):
        return read_broad_hdf5(path)
    return read_semicolon_log(path)


def _num(cell: str) -> float:
    s = cell.strip()
    if not s:
        return math.nan
    return float(s.replace(",", "."))


def read_semicolon_log(path) -> ReferenceLog:
    """Read a ``;``-separated log with two header lines (module docstring; ``.gz`` accepted).

    Raises InputError (one line, naming the file and row) for a short or non-numeric row or fewer than 14
    columns."""
    path = Path(path)
    opener = gzip.open if path.suffix == ".gz" else open
    try:
        with opener(path, "rt", encoding="utf-8-sig") as fh:
            lines = fh.read().splitlines()
    except OSError as exc:
        raise InputError(f"{path}: cannot be read ({exc.strerror or exc})") from None
    if len(lines) < 4 or ";" not in lines[0]:
        raise InputError(f"{path}: not a ';'-separated log with two header lines and samples; valid: "
                         "Time;Vicon Orientation (W,X,Y,Z);IMU Acceleration (X,Y,Z);IMU Gyroscope (X,Y,Z)[;...]")
    rows = []
    for i, line in enumerate(lines[2:], start=3):
        if not line.strip():
            continue
        cells = line.split(";")
        if len(cells) < 11:
            raise InputError(f"{path}: row {i} has {len(cells)} fields; valid: at least 11 (time, quaternion, "
                             "accelerometer, gyroscope)")
        try:
            rows.append([_num(c) for c in cells[:11]])
        except ValueError:
            raise InputError(f"{path}: row {i} is not numeric; valid: numbers (decimal point or comma)") from None
    d = np.array(rows)
    if np.any(~np.isfinite(d[:, [0, 5, 6, 7, 8, 9, 10]])):
        i = int(np.flatnonzero(~np.all(np.isfinite(d[:, [0, 5, 6, 7, 8, 9, 10]]), axis=1))[0])
        raise InputError(f"{path}: row {i + 3} lacks its time or an IMU value; valid: time, accelerometer and "
                         "gyroscope in every row (only the reference may be empty)")
    return ReferenceLog(str(path), d[:, 0], d[:, 1:5], d[:, 5:8], d[:, 8:11])


@dataclass(frozen=True)
class TrueSamples:
    """The IMU's own samples of a log: idx (M,) row of each, t (M,) [s], gyro (M,3), accel (M,3);
    n_rows, n_repeats (rows repeating the previous sample), n_dup_time (rows dropped for a repeated time),
    step_median [s], step_max [s] of the true samples."""

    idx: np.ndarray = field(repr=False)
    t: np.ndarray = field(repr=False)
    gyro: np.ndarray = field(repr=False)
    accel: np.ndarray = field(repr=False)
    n_rows: int
    n_repeats: int
    n_dup_time: int
    step_median: float
    step_max: float


def true_samples(t, gyro, accel) -> TrueSamples:
    """The new IMU samples among the rows (module docstring): rows repeating all six values of the row before
    are sample-and-hold repeats; rows whose time does not increase are dropped."""
    t = np.asarray(t, float)
    g = np.asarray(gyro, float)
    a = np.asarray(accel, float)
    keep_t = np.ones(t.size, bool)
    keep_t[1:] = np.diff(np.maximum.accumulate(t)) > 0
    imu = np.hstack([g, a])
    new = np.ones(t.size, bool)
    new[1:] = np.any(imu[1:] != imu[:-1], axis=1)
    idx = np.flatnonzero(new & keep_t)
    steps = np.diff(t[idx])
    return TrueSamples(idx, t[idx], g[idx], a[idx], int(t.size), int(np.sum(~new)), int(np.sum(~keep_t)),
                       float(np.median(steps)), float(np.max(steps)))


def resample_uniform(t, x, dt: float):
    """Linear interpolation of samples x (M,k) at increasing times t (M,) [s] onto the grid t[0] + k dt;
    returns (grid (N,) [s], values (N,k))."""
    t = np.asarray(t, float)
    x = np.asarray(x, float)
    grid = t[0] + dt * np.arange(int(math.floor((t[-1] - t[0]) / dt)) + 1)
    return grid, np.column_stack([np.interp(grid, t, x[:, j]) for j in range(x.shape[1])])


# --------------------------------------------------------------------------- rotations
def quat_to_dcm_wxyz(q) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of unit quaternions (W, X, Y, Z), body -> world."""
    q = np.asarray(q, float)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1)], -2)


def kabsch(u, v, w=None) -> np.ndarray:
    """Rotation A (3,3) minimising sum w_i |v_i - A u_i|^2 (Wahba's problem by SVD); u, v (M,3)."""
    u = np.asarray(u, float)
    v = np.asarray(v, float)
    w = np.ones(len(u)) if w is None else np.asarray(w, float)
    B = (v * w[:, None]).T @ u
    U, _, Vt = np.linalg.svd(B)
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))])
    return U @ D @ Vt


def rotation_angle_deg(A) -> float:
    """Angle [deg] of rotation matrix A."""
    return float(np.degrees(np.arccos(np.clip((np.trace(A) - 1.0) / 2.0, -1.0, 1.0))))


def reference_up_body(quat, up_world=(0.0, 0.0, 1.0)) -> np.ndarray:
    """Up direction (N,3) [-] in the reference body frame, C^T up_world, of body -> world quaternions."""
    return quat_to_dcm_wxyz(quat).transpose(0, 2, 1) @ np.asarray(up_world, float)


def reference_rate_body(t, quat) -> np.ndarray:
    """Body angular rate (N,3) [rad/s] of body -> world quaternions by central differences of the DCMs
    (the skew part of C_{k-1}^T C_{k+1} over the two steps); NaN at the ends and where a quaternion is missing."""
    C = quat_to_dcm_wxyz(quat)
    n = len(t)
    out = np.full((n, 3), np.nan)
    if n < 3:
        return out
    dC = np.einsum("nji,njk->nik", C[:-2], C[2:])  # C_{k-1}^T C_{k+1}
    dtt = (t[2:] - t[:-2])[:, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        out[1:-1] = 0.5 * np.stack([dC[:, 2, 1] - dC[:, 1, 2], dC[:, 0, 2] - dC[:, 2, 0],
                                    dC[:, 1, 0] - dC[:, 0, 1]], -1) / dtt
    return out


@dataclass(frozen=True)
class Alignment:
    """Result of :func:`estimate_alignment`.

    A : (3,3) rotation reference body -> IMU frame; up_world : (3,) [-] the up direction in the reference's
    world frame (a motion-capture world need not be z-up); angle_deg [deg] the rotation angle of A;
    rate_resid_deg, up_resid_deg [deg] median angle between the paired directions after the fit;
    n_rate, n_still : pairs used.
    """

    A: np.ndarray = field(repr=False)
    up_world: np.ndarray = field(repr=False)
    angle_deg: float
    rate_resid_deg: float
    up_resid_deg: float
    n_rate: int
    n_still: int


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _angles(a, b):
    return np.degrees(np.arccos(np.clip(np.sum(_unit(a) * _unit(b), axis=-1), -1.0, 1.0)))


def estimate_alignment(t, quat, gyro, accel, *, min_rate: float = math.radians(20.0),
                       still_rate: float = math.radians(5.0), still_accel: float = 0.02,
                       n_iter: int = 10) -> Alignment:
    """Fixed rotation A from the reference body frame to the IMU frame, and the world's up direction.

    t (N,) [s], quat (N,4) reference body -> world, gyro (N,3) [rad/s] and accel (N,3) [m/s^2] in the IMU
    frame, on the same rows (true samples). Rate pairs: |ω| > ``min_rate`` [rad/s] in both, the unit
    directions of the gyro and of the reference rate, ``ω_imu = A ω_ref``. Still pairs: |ω| < ``still_rate``
    and ||f| - median still |f|| < ``still_accel`` · g: the accelerometer direction and the reference up,
    ``f/|f| = A C_ref^T up_world``. Alternating least squares from the rate-only fit: up_world = the mean of
    ``C_ref A^T f/|f|`` over the still pairs, then A = the weighted Kabsch fit of both kinds (the still pairs
    weighted to count as much as the rate pairs together). Raises InputError without 10 pairs of each kind.
    """
    t = np.asarray(t, float)
    gyro = np.asarray(gyro, float)
    accel = np.asarray(accel, float)
    quat = np.asarray(quat, float)
    wr = reference_rate_body(t, quat)
    ok = np.all(np.isfinite(wr), axis=1) & np.all(np.isfinite(quat), axis=1)
    wn = np.linalg.norm(gyro, axis=1)
    fn = np.linalg.norm(accel, axis=1)
    rn = np.linalg.norm(np.where(ok[:, None], wr, 0.0), axis=1)
    rate = ok & (wn > min_rate) & (rn > min_rate)
    still = ok & (wn < still_rate) & (rn < still_rate)
    if np.any(still):
        still &= np.abs(fn - float(np.median(fn[still]))) < still_accel * 9.80665
    if rate.sum() < 10 or still.sum() < 10:
        raise InputError(f"alignment: {int(rate.sum())} turning and {int(still.sum())} still samples; valid: at "
                         "least 10 of each to estimate the reference-to-IMU rotation (or declare it)")
    ur, vr = _unit(wr[rate]), _unit(gyro[rate])
    fs = _unit(accel[still])
    Cs = quat_to_dcm_wxyz(quat[still])
    A = kabsch(ur, vr)
    w = np.concatenate([np.ones(len(ur)), np.full(len(fs), len(ur) / len(fs))])
    for _ in range(n_iter):
        up_w = _unit(np.mean(Cs @ (A.T @ fs.T).T[..., None], axis=0)[:, 0])
        us = (Cs.transpose(0, 2, 1) @ up_w)
        A = kabsch(np.vstack([ur, us]), np.vstack([vr, fs]), w)
    us = Cs.transpose(0, 2, 1) @ up_w
    return Alignment(A, up_w, rotation_angle_deg(A), float(np.median(_angles(ur @ A.T, vr))),
                     float(np.median(_angles(us @ A.T, fs))), int(rate.sum()), int(still.sum()))


def reference_down_imu(quat, al: Alignment) -> np.ndarray:
    """The reference's down direction (N,3) [-] in the IMU frame: ``-A C_ref^T up_world``."""
    return -(reference_up_body(quat, al.up_world) @ al.A.T)


def inclination_error_deg(down_imu, quat, al: Alignment) -> np.ndarray:
    """Angle [deg] (N,) between a filter's down direction ``down_imu`` (N,3) in the IMU frame and the
    reference's (:func:`reference_down_imu`); NaN where the reference is missing."""
    return _angles(np.asarray(down_imu, float), reference_down_imu(quat, al))
