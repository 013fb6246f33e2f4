"""Users' own recorded IMU logs (CSV): reading, unit and axis conversion, and the checks that refuse a bad log.

Format: a header row naming the columns, optional ``# key: value`` comment lines above it declaring
units and axes, one row per sample::

    # gyro_units: deg/s
    # accel_units: g
    # axes: FLU
    time_s,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z,roll_deg,pitch_deg
    0.000,0.12,-0.05,0.02,0.001,-0.002,1.000,0.1,-0.2
    ...

* ``time_s`` [s], increasing, any rate (:mod:`imutherm.imu.log_samples`): rows repeating the previous row's six
  IMU values (sample-and-hold) are kept as the time base, the held samples interpolated between the new ones on
  the rows' regular grid, and counted; rows repeating a time stamp are dropped and counted; steps within
  :data:`MAX_STEP_SPREAD` of the median are kept as they are (``true_steps``: the filters that take a per-sample
  step integrate over them, the others run at the median step); steps that vary more are resampled onto a
  uniform grid at the median step from the true times (linear); a step over :data:`GAP_STEPS` median steps is a
  gap, bridged (linear, warned) up to ``max_gap_s`` (default :data:`MAX_BRIDGE_S`, ``--max-gap``) and refused
  beyond, naming the row;
* ``gyro_x..z`` in ``gyro_units`` (:data:`GYRO_UNITS`, default rad/s), ``accel_x..z`` the *specific force*
  (what an accelerometer reads: +1 g upward at rest) in ``accel_units`` (:data:`ACCEL_UNITS`, default m/s2);
* ``axes`` (:data:`AXES`, default FRD): the sensor's body axes, converted to FRD;
* ``gyro_sample`` (default interval): a gyro sample is the mean rate over the step ending at it (``interval``: what
  a MEMS gyro's decimation filter outputs) or the rate at its instant (``point``); our filters integrate it so
  (:data:`~imutherm.imu.filters.common.GYRO_SAMPLES`), the peers always as ``interval``;
* optional reference ``roll_deg``, ``pitch_deg`` [deg]: ZYX Euler angles of the FRD body in NED; empty or
  NaN cells (optical dropouts) are kept as NaN and left out of the scores.

A level unit whose z axis reads up (+1 g on FRD z at rest: a z-up log read as FRD, 180° of roll) is not
refused, since a unit may rest upside down, but warned (``warnings``, :func:`z_up_warning`: for a log declared
FRD the fix is ``axes FLU`` or ``RFU``; for one declared z-up already, an upside-down rest or a swapped /
sign-flipped axis).

Checks (each a one-line :class:`imutherm.InputError` naming the file, the row(s), the rule and what would be
valid): missing
columns, non-numeric or non-finite values, non-monotonic time, gaps, a log shorter than the leveling
window, an accelerometer whose magnitude at rest is not g in the declared unit (the typical mistake, g
declared as m/s² or the reverse, is named as such), a gyro declared rad/s whose values exceed any MEMS
range (deg/s declared as rad/s), a gyro off by 180/π either way (:func:`scale_check`), and a first
window that is not at rest (the filters level and measure the gyro bias there).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from imutherm import InputError
from imutherm.imu.attitude_math import G0
from imutherm.imu.filters.common import GYRO_SAMPLES
from imutherm.imu.log_samples import GAP_STEPS, MAX_BRIDGE_S, MAX_STEP_SPREAD

GYRO_UNITS = {"rad/s": 1.0, "deg/s": math.pi / 180.0}
ACCEL_UNITS = {"m/s2": 1.0, "g": G0}
_ALIASES = {"m/s^2": "m/s2", "m/s²": "m/s2", "mps2": "m/s2", "dps": "deg/s", "°/s": "deg/s", "rad/sec": "rad/s",
            "deg/sec": "deg/s"}
#: body axes conventions -> rotation matrix taking that frame's components to FRD
AXES = {
    "FRD": np.eye(3),
    "FLU": np.diag([1.0, -1.0, -1.0]),                                  # x forward, y left, z up
    "RFU": np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]),  # x right, y forward, z up
}
COLUMNS = ("time_s", "gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
REFERENCE = ("roll_deg", "pitch_deg")
#: fastest MEMS gyro full scale [rad/s] (±4000 °/s parts exist; beyond it a "rad/s" log is in deg/s)
MAX_GYRO_RADPS = math.radians(4000.0)
#: largest log read [bytes] (a 1 h log at 200 Hz is ~65 MB)
MAX_LOG_BYTES = 512 * 2**20


@dataclass(frozen=True)
class ImuLog:
    """A checked, converted log.

    path : str; t : (N,) [s]; gyro : (N,3) [rad/s] FRD; accel : (N,3) [m/s^2] FRD specific force;
    ref_roll, ref_pitch : (N,) [rad] or None (NaN where the reference has no value); dt : float [s] median step; rate_hz : float [Hz];
    units : {"gyro": ..., "accel": ..., "axes": ...} as declared; g_rest : float [m/s^2] |f| over the rest window;
    step_spread : float [-] max |step − dt| / dt of the true samples; n_repeats : sample-and-hold rows (all six IMU
    values equal to the row before), interpolated on the rows' grid; n_dup_time : rows dropped for a repeated
    time stamp; resampled : the samples were put on a uniform grid (repeats, a bridged gap, steps beyond
    MAX_STEP_SPREAD);
    true_steps : (N,) [s] the step ending at each sample (the first: dt) where the true samples are kept, None
    when resampled; warnings : one-line notes on the log that do not refuse it (a z axis reading up at rest, gaps
    bridged); n_rows : data rows read; gaps : ((row, t [s], length [s]), ...) bridged; longest_hold_s [s] the
    longest one sample was held; max_gap_s [s] the gap limit applied; gyro_sample : 'interval' | 'point' as declared
    (what a gyro sample is, :data:`~imutherm.imu.filters.common.GYRO_SAMPLES`)
    """

    path: str
    t: np.ndarray = field(repr=False)
    gyro: np.ndarray = field(repr=False)
    accel: np.ndarray = field(repr=False)
    ref_roll: np.ndarray | None = field(repr=False)
    ref_pitch: np.ndarray | None = field(repr=False)
    dt: float
    rate_hz: float
    units: dict
    g_rest: float
    step_spread: float
    n_repeats: int = 0
    n_dup_time: int = 0
    resampled: bool = False
    true_steps: np.ndarray | None = field(default=None, repr=False)
    warnings: tuple = ()
    n_rows: int = 0
    gaps: tuple = ()
    longest_hold_s: float = 0.0
    max_gap_s: float = MAX_BRIDGE_S
    gyro_sample: str = "interval"

    @property
    def has_reference(self) -> bool:
        return self.ref_roll is not None


def _norm_unit(value: str, table: dict, what: str, where: str) -> str:
    v = value.strip()
    v = _ALIASES.get(v, _ALIASES.get(v.lower(), v))
    if v not in table:
        v2 = v.upper() if table is AXES else v.lower()
        if v2 not in table:
            raise InputError(f"{where}: {what} {value!r} is unknown; valid: {', '.join(table)}")
        v = v2
    return v


def read_imu_csv(path, *, gyro_units: str | None = None, accel_units: str | None = None, axes: str | None = None,
                 init_s: float = 8.0, max_gap_s: float = MAX_BRIDGE_S, gyro_sample: str | None = None) -> ImuLog:
    """Read and check a recorded log (module docstring). Options override nothing silently: a unit given both
    in the header and as an option must agree. init_s [s] is the leveling window that must be at rest; max_gap_s
    [s] the longest gap (or hold) bridged (:mod:`imutherm.imu.log_samples`)."""
    from imutherm.textio import read_text

    path = Path(path)
    text = read_text(path, "IMU CSV", max_bytes=MAX_LOG_BYTES)
    meta, lines, line_no = {}, [], []
    for no, line in enumerate(text.splitlines(), start=1):
        s = line.strip()
        if not s:
            continue
        if s.startswith("#"):
            if ":" in s and not lines:
                k, v = s[1:].split(":", 1)
                meta[k.strip().lower()] = v.strip()
            continue
        lines.append(line)
        line_no.append(no)
    line_no = np.array(line_no)  # a row's number in messages is its line in the file
    declared = {}
    for key, opt, table, default in (("gyro_units", gyro_units, GYRO_UNITS, "rad/s"),
                                     ("accel_units", accel_units, ACCEL_UNITS, "m/s2"), ("axes", axes, AXES, "FRD"),
                                     ("gyro_sample", gyro_sample, dict.fromkeys(GYRO_SAMPLES), "interval")):
        hv = None if key not in meta else _norm_unit(meta[key], table, key, f"{path} header")
        ov = None if opt is None else _norm_unit(opt, table, key, f"--{key.replace('_', '-')}")
        if hv is not None and ov is not None and hv != ov:
            raise InputError(f"{path}: the header declares {key} {hv!r} but the option says {ov!r}; "
                             "valid: give one, or the same in both")
        declared[key] = ov or hv or default
    try:
        rows = list(csv.reader(io.StringIO("\n".join(lines))))
    except csv.Error as exc:
        raise InputError(f"{path}: not a valid CSV file ({exc})") from None
    if len(rows) < 3:
        raise InputError(f"{path}: an IMU log needs a header row and at least two samples")
    header = [h.strip() for h in rows[0]]
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise InputError(f"{path}: column(s) {', '.join(missing)} missing; valid header: {','.join(COLUMNS)}"
                         f"[,{','.join(REFERENCE)}]")
    ref_present = [c for c in REFERENCE if c in header]
    if len(ref_present) == 1:
        raise InputError(f"{path}: reference column {ref_present[0]!r} without its pair; valid: both "
                         f"{' and '.join(REFERENCE)} or neither")
    cols = list(COLUMNS) + (list(REFERENCE) if ref_present else [])
    idx = [header.index(c) for c in cols]
    data = np.empty((len(rows) - 1, len(cols)))
    n_imu = len(COLUMNS)
    for i, r in enumerate(rows[1:]):
        try:  # reference cells may be empty or NaN (optical dropouts); the IMU's may not
            data[i] = [float(r[j]) if (c < n_imu or r[j].strip()) else math.nan for c, j in enumerate(idx)]
        except (ValueError, IndexError):
            raise InputError(f"{path}: row {line_no[i + 1]} is short or not numeric; valid: {len(header)} numbers "
                             "per row") from None
    if not np.all(np.isfinite(data[:, :n_imu])):
        i, j = np.argwhere(~np.isfinite(data[:, :n_imu]))[0]
        raise InputError(f"{path}: {cols[j]} is not finite in row {line_no[i + 1]}; valid: finite numbers")
    from imutherm.imu.log_samples import regularise

    sm = regularise(str(path), data[:, 0], data[:, 1:7], data[:, 7:] if ref_present else None,
                    rows=line_no[1:], max_gap_s=max_gap_s)
    t, dt = sm.t, sm.dt
    t_rows = data[:, 0]
    n0 = int(round(init_s / dt))

    def row_at(time):  # the file line of the data row at ``time`` [s] (the log's own clock)
        return int(line_no[1 + min(int(np.searchsorted(t_rows, time)), len(t_rows) - 1)])

    win = f"first {init_s:g} s, rows {line_no[1]}-{row_at(t[0] + init_s)}"
    data = np.column_stack([t, sm.imu] + ([sm.ref] if ref_present else []))
    R = AXES[declared["axes"]]
    gyro = data[:, 1:4] @ R.T * GYRO_UNITS[declared["gyro_units"]]
    accel = data[:, 4:7] @ R.T * ACCEL_UNITS[declared["accel_units"]]
    if n0 < 10 or n0 > len(t):
        raise InputError(f"{path}: {len(t)} samples at {1 / dt:.4g} Hz (rows {line_no[1]}-{line_no[-1]}) do not cover the "
                         f"{init_s:g} s leveling window at rest with at least 10 samples; rule: the filters level on "
                         "the log's first init_s; valid: a longer log or --init-s")
    g_rest = float(np.mean(np.linalg.norm(accel[:n0], axis=1)))
    unit = declared["accel_units"]
    if not (0.8 * G0 < g_rest < 1.2 * G0):
        raw = g_rest / ACCEL_UNITS[unit]
        hint = ""
        if unit == "m/s2" and 0.8 < raw < 1.2:
            hint = " — it looks like the accelerometer is in g: declare accel_units g"
        elif unit == "g" and 0.8 * G0 < raw < 1.2 * G0:
            hint = " — it looks like the accelerometer is in m/s²: declare accel_units m/s2"
        raise InputError(f"{path}: the accelerometer reads |f| = {raw:.4g} {unit} at rest ({win}), "
                         f"not g (9.81 m/s², 1 g){hint}; rule: |f| within 20 % of g at rest; valid: specific force "
                         f"in the declared accel_units ({', '.join(ACCEL_UNITS)})")
    if declared["gyro_units"] == "rad/s" and np.max(np.abs(gyro)) > MAX_GYRO_RADPS:
        k = int(np.argmax(np.max(np.abs(gyro), axis=1)))
        raise InputError(f"{path}: the gyro reaches {np.max(np.abs(gyro)):.4g} rad/s near row "
                         f"{row_at(t[k])}, beyond any MEMS range ({MAX_GYRO_RADPS:.1f} "
                         "rad/s, the rule) — it looks like deg/s: declare gyro_units deg/s")
    # at rest: the specific-force direction over 0.5 s blocks of the window stays within 2°
    nb = max(1, int(round(0.5 / dt)))
    blocks = accel[: (n0 // nb) * nb].reshape(-1, nb, 3).mean(axis=1)
    mean = accel[:n0].mean(axis=0)
    cosang = blocks @ mean / (np.linalg.norm(blocks, axis=1) * np.linalg.norm(mean))
    tilt = float(np.degrees(np.arccos(np.clip(np.min(cosang), -1.0, 1.0))))
    if tilt > 2.0:
        raise InputError(f"{path}: the unit is not at rest over the first {init_s:g} s ({win}: the specific force "
                         f"turns by {tilt:.1f}°; rule: within 2°); valid: a log that starts with {init_s:g} s at "
                         "rest, or a shorter --init-s")
    scale_check(path, gyro, accel, dt, n0, declared["gyro_units"])
    warnings = list(sm.warnings())
    if mean[2] > 0.5 * np.linalg.norm(mean):  # at rest f points along +z: a level FRD unit reads -1 g there
        warnings.append(z_up_warning(mean[2] / G0, declared["axes"]))
    rr = rp = None
    if ref_present:
        rr, rp = np.radians(data[:, 7]), np.radians(data[:, 8])
    return ImuLog(str(path), t - t[0], gyro, accel, rr, rp, dt, 1.0 / dt,
                  {"gyro": declared["gyro_units"], "accel": declared["accel_units"], "axes": declared["axes"]},
                  g_rest, sm.step_spread, sm.n_repeats, sm.n_dup_time, sm.resampled, sm.true_steps, tuple(warnings),
                  sm.n_rows, sm.gaps, sm.longest_hold_s, sm.max_gap_s, declared["gyro_sample"])


def z_up_warning(fz_g: float, axes: str) -> str:
    """The note on a log whose z axis, read as ``axes`` and turned to FRD, reads up at rest (fz_g [g] > 0 on the
    FRD z axis; a level FRD unit reads -1 g). For a log declared FRD the likely fix is a z-up declaration; for one
    already declared z-up (FLU, RFU) it is not: its sensor z reads down, so the unit rested upside down, or an axis
    is swapped or sign-flipped against the declaration."""
    if axes == "FRD":
        return (f"at rest the specific force reads {fz_g:+.2f} g on the FRD z axis (a level FRD unit reads -1 g): "
                "the log's z axis points up. If the unit rested level, declare its axes FLU (or RFU; --axes or "
                "'# axes:' in the header): read as FRD, its roll is off by 180°.")
    return (f"at rest the specific force reads {fz_g:+.2f} g on the FRD z axis although the log declares {axes} "
            f"(z up: a level unit reads +1 g on its own z): its z axis points down. The unit rested upside down, or "
            f"its axes are not {axes} (an axis swapped or sign-flipped: FRD if x forward and z down); with a "
            "reference, attitude --imu-csv detects and names a mounting rotation (--align auto applies it).")


def _integrate_down(gyro, r0, dt):
    """Down direction in body axes (N,3) from r0 [-] by the gyro (N,3) [rad/s]: dr/dt = −ω × r, exact per step."""
    out = np.empty((len(gyro), 3))
    x, y, z = (float(v) for v in r0)
    for k, (wx, wy, wz) in enumerate(gyro.tolist()):
        out[k] = (x, y, z)
        a = math.sqrt(wx * wx + wy * wy + wz * wz) * dt
        if a > 0:  # rotate r by −a about ω (Rodrigues)
            ux, uy, uz = wx * dt / a, wy * dt / a, wz * dt / a
            c, s_ = math.cos(a), -math.sin(a)
            d = (ux * x + uy * y + uz * z) * (1 - c)
            x, y, z = (x * c + (uy * z - uz * y) * s_ + ux * d, y * c + (uz * x - ux * z) * s_ + uy * d,
                       z * c + (ux * y - uy * x) * s_ + uz * d)
    return out


#: gyro-unit check: quasi-static 0.5 s blocks tilted at least this much from the start are compared [deg]
CHECK_TILT_DEG = 15.0


def scale_check(path, gyro, accel, dt: float, n0: int, unit: str) -> None:
    """Refuse a gyro whose declared unit is off by 180/π either way.

    The down direction integrated from the rest window with the gyro (bias = its rest mean) must follow the
    accelerometer's down direction at the quasi-static moments (0.5 s blocks, |f| within 5 % of its rest
    value, per-axis std < 0.5 m/s^2) that are tilted by more than :data:`CHECK_TILT_DEG` from the start.
    The median angle between the two is computed for the gyro read as declared, ×(π/180) and ×(180/π);
    if the declared reading is off by more than 10° and another is three times closer, the log is refused.
    No such moments (a log that never comes to rest tilted): no check.
    """
    nb = max(1, int(round(0.5 / dt)))
    m = (len(accel) // nb) * nb
    blk = accel[:m].reshape(-1, nb, 3)
    mean, std = blk.mean(axis=1), blk.std(axis=1)
    g0 = float(np.mean(np.linalg.norm(accel[:n0], axis=1)))
    down = -mean / np.linalg.norm(mean, axis=1)[:, None]
    r0 = -accel[:n0].mean(axis=0)
    r0 /= np.linalg.norm(r0)
    tilt = np.degrees(np.arccos(np.clip(down @ r0, -1, 1)))
    ok = (np.abs(np.linalg.norm(mean, axis=1) - g0) < 0.05 * g0) & np.all(std < 0.5, axis=1) & (tilt > CHECK_TILT_DEG)
    if not np.any(ok):
        return
    centre = np.flatnonzero(ok) * nb + nb // 2
    bias = gyro[:n0].mean(axis=0)
    err = {}
    for label, f in (("declared", 1.0), ("x pi/180", math.pi / 180), ("x 180/pi", 180 / math.pi)):
        r = _integrate_down((gyro[: centre[-1] + 1] - bias) * f, r0, dt)[centre]
        err[label] = float(np.median(np.degrees(np.arccos(np.clip(np.sum(r * down[ok], axis=1), -1, 1)))))
    best = min(err, key=err.get)
    if best != "declared" and err["declared"] > 10.0 and err[best] < err["declared"] / 3:
        other = {"rad/s": "deg/s", "deg/s": "rad/s"}[unit]
        raise InputError(f"{path}: read as {unit}, the gyro turns the down direction {err['declared']:.0f}° away "
                         f"from the accelerometer's at rest after rotating (read as {other}: {err[best]:.1f}°) — "
                         f"it looks like the gyro is in {other}: declare gyro_units {other}")


def write_imu_csv(path, t, gyro, accel, *, roll=None, pitch=None, gyro_units: str = "rad/s",
                  accel_units: str = "m/s2", axes: str = "FRD", gyro_sample: str = "point") -> Path:
    """Write a log in the format above: t (N,) [s], gyro (N,3) [rad/s] and accel (N,3) [m/s^2] in FRD,
    converted to the stated units and axes; roll, pitch (N,) [rad] optional reference; gyro_sample declared in the
    header (default 'point': the simulated sensor's samples, which is what the project writes)."""
    R = AXES[axes]
    g = np.asarray(gyro, float) @ R / GYRO_UNITS[gyro_units]  # R orthogonal: FRD -> axes is R^T, rows @ R
    a = np.asarray(accel, float) @ R / ACCEL_UNITS[accel_units]
    cols = [np.asarray(t, float)[:, None], g, a]
    head = list(COLUMNS)
    if roll is not None:
        cols += [np.degrees(np.asarray(roll))[:, None], np.degrees(np.asarray(pitch))[:, None]]
        head += list(REFERENCE)
    arr = np.hstack(cols)
    path = Path(path)
    with path.open("w", encoding="utf-8") as fh:
        fh.write(f"# gyro_units: {gyro_units}\n# accel_units: {accel_units}\n# axes: {axes}\n"
                 f"# gyro_sample: {gyro_sample}\n")
        fh.write(",".join(head) + "\n")
        np.savetxt(fh, arr, delimiter=",", fmt="%.10g")
    return path
