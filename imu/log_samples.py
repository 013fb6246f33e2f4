"""A recorded log's rows to the samples the filters take: repeats, repeated stamps, jitter and gaps.

What a real logger writes, and what becomes of it (:func:`regularise`):

* **sample-and-hold repeats**: a row whose six IMU values equal the row before's is the logger writing the last
  sample again because no new one came (the RepoIMU pendulum logs: 44 % of the rows; BROAD trial 27: runs of 3-5
  rows). The rows' time column stays regular, so the repeats are *kept as a time base*: the new samples are put
  at their rows' times and interpolated linearly onto the rows' regular grid (its median step), which fills the
  held rows with the straight line between the samples around them, as the reference-log reader does
  (:func:`imutherm.imu.reference_log.true_samples`, :func:`~imutherm.imu.reference_log.resample_uniform`). They
  are counted, never refused; a hold longer than the gap limit is a gap (below).
* **repeated time stamps** (a row with new values at the previous row's time): dropped and counted.
* **irregular true steps** (jitter): within :data:`MAX_STEP_SPREAD` of the median the samples are kept at their
  true times (``true_steps``: the filters that take a per-sample step integrate over them); beyond it they are
  resampled onto a uniform grid at the median step.
* **gaps** (the time column jumps by more than :data:`GAP_STEPS` median steps): bridged, i.e. resampled across
  by the same linear interpolation, with a warning naming the row, up to ``max_gap_s`` (default
  :data:`MAX_BRIDGE_S`); a longer one is refused naming the row and this rule, and the option that bridges it.

Every refusal is one :class:`imutherm.InputError` line naming the file, the row and the rule.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from imutherm import InputError

#: largest deviation of a true time step from the median step, as a fraction of it, read as is; beyond it the
#: samples are resampled onto a uniform grid at the median step from their true times
MAX_STEP_SPREAD = 0.5
#: a time-column step longer than this many median steps is a gap (bridged up to the gap limit, else refused)
GAP_STEPS = 5.0
#: default gap limit [s]: longer gaps (and holds) are refused unless bridged explicitly (``--max-gap``). Across a
#: bridged gap the gyro is the straight line between the samples around it, so the attitude integrates an
#: assumed rate there: 0.5 s of hand motion at 100 °/s is 50° of rotation left to the accelerometer to correct
MAX_BRIDGE_S = 0.5


@dataclass(frozen=True)
class Samples:
    """The filters' samples of a log.

    t : (N,) [s] sample times (a uniform grid when ``resampled``); imu : (N,6) gyro and accelerometer values on
    them (as read, in the log's units); ref : (N,k) the reference columns on them or None; dt : float [s] the
    filters' sample period (the median step of the rows); n_rows : rows read; n_repeats : sample-and-hold rows
    (interpolated on the rows' grid); n_dup_time : rows dropped for a repeated time stamp; step_spread : float [-]
    max |step − dt| / dt of the true samples; resampled : the samples were put on a uniform grid (repeats, a gap,
    or steps beyond MAX_STEP_SPREAD); true_steps : (N,) [s] the step ending at each sample (the first: dt) where
    the true times are kept, else None; gaps : ((row, t_before [s], length [s]), ...) gaps bridged;
    longest_hold_s : float [s] the longest stretch one sample was held (0 without repeats); max_gap_s [s] the
    limit applied.
    """

    t: np.ndarray = field(repr=False)
    imu: np.ndarray = field(repr=False)
    ref: np.ndarray | None = field(repr=False)
    dt: float
    n_rows: int
    n_repeats: int
    n_dup_time: int
    step_spread: float
    resampled: bool
    true_steps: np.ndarray | None = field(repr=False)
    gaps: tuple
    longest_hold_s: float
    max_gap_s: float

    def warnings(self) -> tuple:
        """One-line notes on the bridged gaps (none: ())."""
        if not self.gaps:
            return ()
        row, t0, length = max(self.gaps, key=lambda g: g[2])
        return (f"{len(self.gaps)} gap(s) in the time column bridged by linear interpolation (the longest "
                f"{length:.3g} s after row {row}, t = {t0:.6g} s; gaps over {GAP_STEPS:g} median steps up to "
                f"{self.max_gap_s:g} s are bridged, --max-gap): the attitude there integrates an interpolated gyro",)


def _interp(grid, t, x):
    return np.column_stack([np.interp(grid, t, x[:, j]) for j in range(x.shape[1])])


def regularise(where: str, t, imu, ref=None, *, rows=None, max_gap_s: float = MAX_BRIDGE_S) -> Samples:
    """The module docstring's rules on a log's rows: t (M,) [s] the time column, imu (M,6) the IMU values, ref
    (M,k) reference columns or None (NaN kept), rows (M,) the row number of each in the file for the messages
    (default 2, 3, ...: a header row first), max_gap_s [s] the gap limit. ``where`` names the file."""
    t = np.asarray(t, float)
    imu = np.asarray(imu, float)
    rows = np.arange(2, t.size + 2) if rows is None else np.asarray(rows)
    if not (math.isfinite(max_gap_s) and max_gap_s > 0):
        raise InputError(f"--max-gap: {max_gap_s!r} is invalid; valid: a positive time [s]")
    steps = np.diff(t)
    if np.any(steps < 0):
        i = int(np.flatnonzero(steps < 0)[0])
        raise InputError(f"{where}: time_s is not strictly increasing at row {rows[i + 1]} ({t[i]:.6g} then "
                         f"{t[i + 1]:.6g} s); rule: times increase; valid: strictly increasing times [s]")
    rep = np.zeros(t.size, bool)
    rep[1:] = np.all(imu[1:] == imu[:-1], axis=1)
    same_t = np.zeros(t.size, bool)
    same_t[1:] = steps == 0
    keep = ~same_t
    if keep.sum() < 2:
        raise InputError(f"{where}: all {t.size} rows (rows {rows[0]}-{rows[-1]}) share the time stamp {t[0]:.6g} s; "
                         "rule: a log's times increase; valid: a time column [s] that increases row by row")
    tr = t[keep]
    row_steps = np.diff(tr)
    dt = float(np.median(row_steps))
    kept_rows = rows[keep]
    gaps = []
    for i in np.flatnonzero(row_steps > GAP_STEPS * dt):
        s = float(row_steps[i])
        if s > max_gap_s:
            raise InputError(f"{where}: the time column jumps {s:.4g} s ({s / dt:.0f} median steps of {dt:.4g} s) "
                             f"after row {kept_rows[i]} (t = {tr[i]:.6g} s); rule: gaps over {GAP_STEPS:g} median "
                             f"steps are bridged up to {max_gap_s:g} s; valid: --max-gap {math.ceil(s * 10) / 10:g} "
                             "to bridge it (samples interpolated linearly across), or split the log there")
        gaps.append((int(kept_rows[i]), float(tr[i]), s))
    new = keep & ~rep
    new[0] = True
    tt, xt = t[new], imu[new]
    true_step = np.diff(tt)
    hold = 0.0
    if np.any(rep & keep):
        i = int(np.argmax(true_step))
        hold = float(true_step[i])
        if hold > max_gap_s and not any(g[2] >= hold for g in gaps):
            r0 = rows[new][i]
            raise InputError(f"{where}: rows {r0}-{rows[new][i + 1] - 1} hold one sample for {hold:.4g} s (the IMU "
                             f"gave no new value after t = {tt[i]:.6g} s); rule: a hold over {max_gap_s:g} s is a "
                             f"gap; valid: --max-gap {math.ceil(hold * 10) / 10:g} to bridge it (samples "
                             "interpolated linearly across), or split the log there")
    spread = float(np.max(np.abs(true_step - dt)) / dt) if true_step.size else 0.0
    n_rep = int(np.sum(rep))
    resampled = bool(np.any(rep & keep) or gaps or spread > MAX_STEP_SPREAD)
    rr = None if ref is None else np.asarray(ref, float)[keep]
    if resampled:  # onto the rows' regular grid: held samples and gaps filled by the line between true samples
        grid = tt[0] + dt * np.arange(int(np.floor((tt[-1] - tt[0]) / dt + 1e-9)) + 1)
        x = _interp(grid, tt, xt)
        r = None if rr is None else _interp(grid, tr, rr)
        return Samples(grid, x, r, dt, int(t.size), n_rep, int(np.sum(same_t & ~rep)), spread, True, None,
                       tuple(gaps), hold, float(max_gap_s))
    r = None if rr is None else rr
    return Samples(tt, xt, r, dt, int(t.size), n_rep, int(np.sum(same_t & ~rep)), spread, False,
                   np.concatenate([[dt], true_step]), (), 0.0, float(max_gap_s))
