"""Every attitude filter on real recordings with an optical reference, scored by inclination.

Data: the RepoIMU pendulum trials in ``../shared/data/repoimu`` (Szczęsna et al., ICCVG 2016, LNCS 9972,
pp. 509-520, doi:10.1007/978-3-319-46418-3_45), read by :func:`imutherm.imu.reference_log.read_semicolon_log`.

Procedure per file (:func:`prepare`), identical for our filters and the peers:

1. true samples: sample-and-hold repeats and repeated time stamps dropped
   (:func:`~imutherm.imu.reference_log.true_samples`);
2. the true samples interpolated linearly onto a uniform grid at the log's row step (the median step of the
   rows, 11 ms here), since every filter takes one sample period;
3. the IMU axes turned by the smallest rotation that takes the specific force of the rest window (the first
   ``init_s`` [s]) to -z, so that every filter starts near level in its FRD convention (a fixed, proper
   rotation: the scores are unchanged by it);
4. the reference-to-IMU rotation and the world's up direction estimated from the reference and the raw
   sensor (:func:`~imutherm.imu.reference_log.estimate_alignment`), once per file, never from a filter;
5. the filters run with the leveling / rest window ``init_s`` = 1 s (the pendulum is released 1.3-1.5 s
   into each file) and the gate design inputs and gated settings of ``--platform handheld`` (the defaults
   of ``imutherm attitude --imu-csv``: :data:`~imutherm.studies.recorded.PLATFORM_GATE`, ``PLATFORM_KF``, ``PLATFORM_AEKF``), each filter at its
   defaults unless ``params`` says otherwise;
6. score: the inclination error (angle between the filter's and the reference's vertical) at every row
   after ``skip_s`` = 5 s with a reference, the filter's estimate linearly interpolated to the row's time;
   RMS [deg] per file.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from imutherm.imu.reference_log import (Alignment, estimate_alignment, inclination_error_deg, read_semicolon_log,
                                        resample_uniform, true_samples)

#: the shared real recordings (relative to the repository's parent folder)
DATA_DIR = Path(__file__).resolve().parents[2] / "shared" / "data" / "repoimu"
INIT_S = 1.0
SKIP_S = 5.0


@dataclass(frozen=True)
class RealRecord:
    """One prepared file: name; dt [s] grid step; gyro, accel (N,3) on the grid in the turned axes (FRD-like);
    M (3,3) IMU -> turned axes; t_rows (R,) [s] and quat_rows (R,4) the reference rows scored; align : the
    reference-to-IMU rotation; n_rows, n_repeats, n_dup_time; step_median_true [s]."""

    name: str
    dt: float
    gyro: np.ndarray = field(repr=False)
    accel: np.ndarray = field(repr=False)
    t0: float
    M: np.ndarray = field(repr=False)
    t_rows: np.ndarray = field(repr=False)
    quat_rows: np.ndarray = field(repr=False)
    align: Alignment
    n_rows: int
    n_repeats: int
    n_dup_time: int
    step_median_true: float


def level_rotation(f_rest) -> np.ndarray:
    """Smallest rotation M (3,3) with M f̂ = [0, 0, -1] for the rest specific force f_rest (3,) [m/s^2]."""
    a = np.asarray(f_rest, float) / np.linalg.norm(f_rest)
    b = np.array([0.0, 0.0, -1.0])
    v = np.cross(a, b)
    c = float(a @ b)
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + K + K @ K / (1.0 + c)


def prepare(path, *, init_s: float = INIT_S, skip_s: float = SKIP_S) -> RealRecord:
    """Steps 1-4 of the module docstring for one file."""
    log = read_semicolon_log(path)
    ts = true_samples(log.t, log.gyro, log.accel)
    dt = float(np.median(np.diff(log.t)[np.diff(log.t) > 0]))
    grid, x = resample_uniform(ts.t, np.hstack([ts.gyro, ts.accel]), dt)
    n0 = int(round(init_s / dt))
    M = level_rotation(x[:n0, 3:].mean(axis=0))
    al = estimate_alignment(ts.t, log.quat[ts.idx], ts.gyro, ts.accel)
    keep = (log.t >= log.t[0] + skip_s) & (log.t <= grid[-1]) & np.all(np.isfinite(log.quat), axis=1)
    return RealRecord(Path(path).name.split(".")[0], dt, x[:, :3] @ M.T, x[:, 3:] @ M.T, float(grid[0]), M,
                      log.t[keep], log.quat[keep], al, ts.n_rows, ts.n_repeats, ts.n_dup_time, ts.step_median)


def load_all(data_dir=DATA_DIR, **kw) -> list[RealRecord]:
    """:func:`prepare` for every ``*.csv.gz`` / ``*.csv`` of ``data_dir``, sorted by name."""
    files = sorted(list(Path(data_dir).glob("*.csv.gz")) + list(Path(data_dir).glob("*.csv")))
    return [prepare(f, **kw) for f in files]


def score(rec: RealRecord, gravity) -> dict:
    """Inclination error of a filter's gravity direction (N,3) on ``rec``'s grid: rms_deg, max_deg, p95_deg."""
    g = np.asarray(gravity, float)
    tg = rec.t0 + rec.dt * np.arange(len(g))
    d = np.column_stack([np.interp(rec.t_rows, tg, g[:, j]) for j in range(3)]) @ rec.M  # back to IMU axes
    e = inclination_error_deg(d, rec.quat_rows, rec.align)
    return {"rms_deg": float(np.sqrt(np.mean(e**2))), "max_deg": float(np.max(e)),
            "p95_deg": float(np.percentile(e, 95))}


def run(names, rec: RealRecord, params=None, *, init_s: float = INIT_S) -> dict:
    """Run ``names`` on ``rec`` (:func:`imutherm.studies.attitude_study.run_filters`, platform handheld) and
    score each: {name: score dict + accel_used_fraction}."""
    from imutherm.studies.attitude_study import GateConfig, run_filters
    from imutherm.imu.filters import KFParams
    from imutherm.studies.recorded import PLATFORM_GATE, PLATFORM_KF, PLATFORMS, platform_params

    d, L = PLATFORMS["handheld"]
    gate = replace(GateConfig(), L=L, init_s=init_s, **PLATFORM_GATE["handheld"])
    est, _ = run_filters(rec.gyro, rec.accel, rec.dt, d, gate, kf=KFParams(**PLATFORM_KF["handheld"]),
                         names=tuple(names), params={**platform_params("handheld"), **(params or {})})
    out = {}
    for n, e in est.items():
        s = score(rec, e.gravity)
        s["accel_used_fraction"] = float(np.mean(e.accel_used))
        out[n] = s
    return out


def table(names, recs, params=None) -> dict:
    """{name: {file: score}} plus per name ``mean_rms_deg``."""
    per = {n: {} for n in names}
    for r in recs:
        for n, s in run(names, r, params).items():
            per[n][r.name] = s
    return {n: {"files": per[n], "mean_rms_deg": float(np.mean([s["rms_deg"] for s in per[n].values()]))}
            for n in names}


__all__ = ["DATA_DIR", "RealRecord", "prepare", "load_all", "score", "run", "table", "level_rotation"]


def run_reference_log(path, *, names, init_s: float = INIT_S, skip_s: float = SKIP_S, fusion=None) -> dict:
    """``imutherm attitude --imu-csv`` on a ``;``-separated reference log: :func:`prepare` (repeats, true
    times, alignment ``auto``), every filter in ``names`` (platform handheld), the inclination scores.
    fusion : FusionParams or None (its defaults: gyro range not declared, over-range recovery off; never the
    data's peak). Returns a JSON-ready dict."""
    from imutherm.imu.filters import FusionParams, KFParams
    from imutherm.imu.filters.fusion_peer import fusion_range_info
    from imutherm.studies.attitude_study import GateConfig, run_filters
    from imutherm.studies.recorded import PLATFORM_GATE, PLATFORM_KF, PLATFORMS, platform_params

    log = read_semicolon_log(path)
    n_missing = int(np.sum(~np.all(np.isfinite(log.quat), axis=1)))
    rec = prepare(path, init_s=init_s, skip_s=skip_s)
    d, L = PLATFORMS["handheld"]
    gate = replace(GateConfig(), L=L, init_s=init_s, **PLATFORM_GATE["handheld"])
    est, _ = run_filters(rec.gyro, rec.accel, rec.dt, d, gate, kf=KFParams(**PLATFORM_KF["handheld"]),
                         fusion=fusion or FusionParams(), names=tuple(names), params=platform_params("handheld"))
    filters = {}
    for n, e in est.items():
        s = score(rec, e.gravity)
        filters[n] = {"inclination_rms_deg": s["rms_deg"], "inclination_max_deg": s["max_deg"],
                      "accel_used_fraction": float(np.mean(e.accel_used)), "runtime_s": e.runtime_s}
    return {"source": str(path), "layout": "semicolon, two header lines (RepoIMU)", "rows": rec.n_rows,
            "sample_and_hold_repeats": rec.n_repeats, "repeated_times": rec.n_dup_time,
            "true_step_median_s": rec.step_median_true, "grid_step_s": rec.dt, "init_s": init_s, "skip_s": skip_s,
            "reference_rows_missing": n_missing, "reference_rows_scored": int(rec.t_rows.size),
            "alignment": {"mode": "auto", "angle_deg": rec.align.angle_deg, "A": rec.align.A.tolist(),
                          "up_world": rec.align.up_world.tolist(), "rate_resid_deg": rec.align.rate_resid_deg,
                          "vertical_resid_deg": rec.align.up_resid_deg},
            "platform": "handheld", "score": "inclination: angle between the filter's and the reference's vertical",
            "fusion": fusion_range_info(fusion, log.gyro), "filters": filters}

