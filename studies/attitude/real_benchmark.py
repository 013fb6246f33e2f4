"""Every attitude filter on real recordings with an optical reference, scored by inclination.

Data (the development set, ``../shared/data``; cite them where you use them):

* ``repoimu/``: six RepoIMU pendulum trials (Szczęsna, Skurowski, Pruszowski, Pęszor, Paszkuta, Wojciechowski,
  *Reference Data Set for Accuracy Evaluation of Orientation Estimation Algorithms for Inertial Motion Capture
  Systems*, ICCVG 2016, LNCS 9972, pp. 509-520, doi:10.1007/978-3-319-46418-3_45), ``;``-separated
  (:func:`imutherm.imu.reference_log.read_semicolon_log`): a consumer MEMS IMU on a swinging pendulum, Vicon
  reference in its own body frame;
* ``broad-dev/``: three trials of BROAD (Laidig, Caruso, Cereatti, Seel, *BROAD - A Benchmark for Robust Inertial
  Orientation Estimation*, Data 6 (7), 72, 2021, doi:10.3390/data6070072; CC BY 4.0), HDF5
  (:func:`~imutherm.imu.reference_log.read_broad_hdf5`): fast rotation, fast translation, a vibrating phone;
  OptiTrack reference aligned to the IMU frame by the data set's authors.

Procedure per file (:func:`prepare`), identical for our filters and the peers:

1. true samples: sample-and-hold repeats and repeated time stamps dropped
   (:func:`~imutherm.imu.reference_log.true_samples`), then interpolated linearly onto a uniform grid at the
   rows' median step (11 ms RepoIMU, 3.5 ms BROAD), the held samples filled by the straight line between the new
   ones (:mod:`imutherm.imu.log_samples`: the ``--imu-csv`` reader does the same);
2. the IMU axes turned by the smallest rotation that takes the specific force of the rest window (the first
   ``init_s`` [s]) to -z, so that every filter starts near level in its FRD convention (a fixed, proper
   rotation: the scores are unchanged by it);
3. the reference-to-IMU rotation: RepoIMU's estimated from the reference and the raw sensor
   (:func:`~imutherm.imu.reference_log.estimate_alignment`), once per file, never from a filter; BROAD's is the
   identity (the data set's reference is aligned to the IMU frame) and its world is ENU (up = z);
4. the filters run with the rest window ``init_s`` (RepoIMU 1 s: the pendulum is released 1.3-1.5 s into each
   file; BROAD 8 s: its trials start with 26-46 s at rest), the gyro samples read as means over the step ending
   at them (``gyro_sample='interval'``, as every peer integrates them), at their library defaults or at the
   settings given (:func:`run`);
5. score: the inclination error (the angle between the filter's and the reference's vertical), the filter's
   estimate linearly interpolated to each scored row's time: RepoIMU every row after ``skip_s`` = 5 s with a
   reference, BROAD the rows its ``movement`` marks with a reference (as the data set's publication scores 6D
   filters); RMS [deg] per file.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from imutherm.imu.reference_log import (Alignment, estimate_alignment, inclination_error_deg, read_reference_log,
                                        resample_uniform, true_samples)

#: the shared real recordings (relative to the repository's parent folder, or the folder the environment variable
#: IMUTHERM_SHARED_DATA names: a git worktree elsewhere), one folder per data set
SHARED = Path(os.environ.get("IMUTHERM_SHARED_DATA") or Path(__file__).resolve().parents[3] / "shared" / "data")
DATA_DIRS = {"repoimu": SHARED / "repoimu", "broad": SHARED / "broad-dev"}
DATA_DIR = DATA_DIRS["repoimu"]
#: rest window [s] per layout (RepoIMU: released 1.3-1.5 s in; BROAD: 26-46 s at rest first, the --imu-csv default)
INIT_S = {"semicolon": 1.0, "broad": 8.0}
SKIP_S = 5.0
#: files of the data sets
PATTERNS = ("*.csv.gz", "*.csv", "*.hdf5", "*.h5")


@dataclass(frozen=True)
class RealRecord:
    """One prepared file: name; dataset ('repoimu' | 'broad'); dt [s] grid step; gyro, accel (N,3) on the grid in
    the turned axes (FRD-like); t0 [s] the grid's first time; M (3,3) IMU -> turned axes; t_rows (R,) [s] and
    quat_rows (R,4) the reference rows scored; align : the reference-to-IMU rotation; init_s [s] the rest window;
    n_rows, n_repeats, n_dup_time; step_median_true [s]; n_ref_missing : rows without a reference value."""

    name: str
    dataset: str
    dt: float
    gyro: np.ndarray = field(repr=False)
    accel: np.ndarray = field(repr=False)
    t0: float
    M: np.ndarray = field(repr=False)
    t_rows: np.ndarray = field(repr=False)
    quat_rows: np.ndarray = field(repr=False)
    align: Alignment
    init_s: float
    n_rows: int
    n_repeats: int
    n_dup_time: int
    step_median_true: float
    n_ref_missing: int = 0

    @property
    def short(self) -> str:
        """A short label: ``02a/1`` (RepoIMU test / segment), ``B07`` (BROAD trial number)."""
        if self.dataset == "broad":
            return "B" + self.name.split("_")[0]
        return self.name.replace("Pendulum_Test", "").replace("_Trial1_Segment_", "/")


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


def identity_alignment() -> Alignment:
    """The rotation of a reference already in the IMU frame, its world ENU (up = z)."""
    return Alignment(np.eye(3), np.array([0.0, 0.0, 1.0]), 0.0, float("nan"), float("nan"), 0, 0)


def prepare(path, *, init_s: float | None = None, skip_s: float = SKIP_S) -> RealRecord:
    """Steps 1-3 of the module docstring for one file (init_s None: :data:`INIT_S` of its layout)."""
    return prepare_log(read_reference_log(path), init_s=init_s, skip_s=skip_s)


def prepare_log(log, *, init_s: float | None = None, skip_s: float = SKIP_S, name: str | None = None,
                level: bool = True) -> RealRecord:
    """:func:`prepare` of a log already read (:class:`~imutherm.imu.reference_log.ReferenceLog`, e.g. a
    simulated or transformed one: :mod:`imutherm.studies.attitude.filter_stress`); name None: the file's stem; level
    False: step 2 skipped (the IMU axes kept, so the filters start in the mounting's attitude, upside down or on a
    side)."""
    path = log.path
    init_s = INIT_S[log.layout] if init_s is None else float(init_s)
    ts = true_samples(log.t, log.gyro, log.accel)
    dt = float(np.median(np.diff(log.t)[np.diff(log.t) > 0]))
    grid, x = resample_uniform(ts.t, np.hstack([ts.gyro, ts.accel]), dt)
    n0 = int(round(init_s / dt))
    M = level_rotation(x[:n0, 3:].mean(axis=0)) if level else np.eye(3)
    ok = np.all(np.isfinite(log.quat), axis=1)
    if log.aligned:
        al = identity_alignment()
        keep = log.movement & ok & (log.t <= grid[-1])
    else:
        al = estimate_alignment(ts.t, log.quat[ts.idx], ts.gyro, ts.accel)
        keep = (log.t >= log.t[0] + skip_s) & (log.t <= grid[-1]) & ok
    name = name or Path(path).name.split(".")[0]
    return RealRecord(name, "broad" if log.layout == "broad" else "repoimu", dt, x[:, :3] @ M.T, x[:, 3:] @ M.T,
                      float(grid[0]), M, log.t[keep], log.quat[keep], al, init_s, ts.n_rows, ts.n_repeats,
                      ts.n_dup_time, ts.step_median, int(np.sum(~ok)))


def data_files(dirs=None) -> list:
    """The data sets' files, by folder then name (dirs None: :data:`DATA_DIRS`, those present)."""
    out = []
    for d in (DATA_DIRS.values() if dirs is None else dirs):
        d = Path(d)
        if d.is_dir():
            out += sorted({f for p in PATTERNS for f in d.glob(p)})
    return out


def load_all(dirs=None, **kw) -> list[RealRecord]:
    """:func:`prepare` for every file of :func:`data_files`."""
    return [prepare(f, **kw) for f in data_files(dirs)]


def errors(rec: RealRecord, gravity) -> np.ndarray:
    """Inclination error [deg] (R,) of a filter's gravity direction (N,3) on ``rec``'s grid at the scored rows."""
    g = np.asarray(gravity, float)
    tg = rec.t0 + rec.dt * np.arange(len(g))
    d = np.column_stack([np.interp(rec.t_rows, tg, g[:, j]) for j in range(3)]) @ rec.M  # back to IMU axes
    return inclination_error_deg(d, rec.quat_rows, rec.align)


#: contiguous blocks of the scored rows over which a file's scoring noise is measured (:func:`score`)
NOISE_BLOCKS = 10


def score(rec: RealRecord, gravity) -> dict:
    """Inclination error of a filter's gravity direction (N,3) on ``rec``'s grid: rms_deg, max_deg, p95_deg, and
    noise_deg, the standard error of the RMS: the spread of the RMS over :data:`NOISE_BLOCKS` contiguous blocks of
    the scored rows, / sqrt(blocks) (how much the file's figure would move on another stretch of the same motion)."""
    e = errors(rec, gravity)
    blocks = [float(np.sqrt(np.mean(b ** 2))) for b in np.array_split(e, NOISE_BLOCKS)]
    return {"rms_deg": float(np.sqrt(np.mean(e**2))), "max_deg": float(np.max(e)),
            "p95_deg": float(np.percentile(e, 95)), "noise_deg": float(np.std(blocks) / np.sqrt(NOISE_BLOCKS))}


#: the gate design inputs on real hand / body motion (:data:`imutherm.studies.attitude.recorded.PLATFORMS` handheld)
def _platform():
    from imutherm.studies.attitude.recorded import PLATFORMS

    return PLATFORMS["handheld"]


def run(names, rec: RealRecord, settings=None, *, fusion=None) -> dict:
    """Run ``names`` on ``rec`` (:func:`imutherm.studies.attitude.attitude_study.run_filters`: the handheld lever arm
    and turn radius, the record's rest window, interval gyro samples) with ``settings`` {name: {field: value}} on top
    of the library defaults (None: every filter at its defaults;
    :func:`imutherm.studies.attitude.recorded.platform_settings` gives a platform's), and score each: {name: score
    dict + accel_used_fraction, runtime_s}."""
    from imutherm.imu.filters import FusionParams
    from imutherm.imu.filters.run import GateConfig, run_filters

    d, L = _platform()
    from imutherm.imu.filters.rest_check import rest_disagreement

    est, _ = run_filters(rec.gyro, rec.accel, rec.dt, d, GateConfig(L=L, init_s=rec.init_s),
                         design={"fusion": fusion or FusionParams()}, names=tuple(names), settings=settings or {},
                         gyro_sample="interval")
    out = {}
    for n, e in est.items():
        s = score(rec, e.gravity)
        s["accel_used_fraction"] = float(np.mean(e.accel_used))
        s["runtime_s"] = float(e.runtime_s)
        s["resets_s"] = None if e.resets is None else [float(k * rec.dt) for k in e.resets]  # divergence monitor
        s["rest_off"] = [(rec.t0 + t, a) for t, a in rest_disagreement(rec.gyro, rec.accel, rec.dt, e.gravity)]
        s["motion_check"] = motion_check_json(rec.gyro, rec.accel, rec.dt, e.gravity, rec.init_s, t0=rec.t0)
        out[n] = s
    return out


def motion_check_json(gyro, accel, dt, gravity, init_s, *, platform: str = "handheld", t0: float = 0.0,
                      steps=None) -> dict:
    """The in-motion divergence check (:func:`~imutherm.imu.filters.motion_check.motion_disagreement`) of a filter's
    down direction (N,3), JSON-ready: window_s, bound_deg, dv_max_mps (the platform's velocity change across a
    window) and accel_bias_mps2 (the accelerometer bias allowed) of the bound, worst_deg, n_windows, flagged
    [(t_start [s], tilt [deg])] (times from ``t0`` [s])."""
    from imutherm.imu.filters.motion_check import ACCEL_BIAS, DV_MAX, motion_disagreement

    mc = motion_disagreement(gyro, accel, dt, gravity, init_s=init_s, dv_max=DV_MAX[platform], steps=steps)
    return {"window_s": mc.window_s, "bound_deg": mc.bound_deg, "dv_max_mps": DV_MAX[platform],
            "accel_bias_mps2": ACCEL_BIAS, "worst_deg": mc.worst_deg,
            "n_windows": int(mc.tilt_deg.size), "flagged": [(t0 + t, a) for t, a in mc.flagged]}


def table(names, recs, settings=None) -> dict:
    """{name: {"files": {file: score}, "mean_rms_deg"}} of :func:`run` over ``recs``."""
    per = {n: {} for n in names}
    for r in recs:
        for n, s in run(names, r, settings).items():
            per[n][r.name] = s
    return {n: {"files": per[n], "mean_rms_deg": float(np.mean([s["rms_deg"] for s in per[n].values()]))}
            for n in names}


def run_reference_log(path, *, names, init_s: float | None = None, skip_s: float = SKIP_S, fusion=None) -> dict:
    """``imutherm attitude --imu-csv`` on a reference log (``;``-separated RepoIMU layout or a BROAD HDF5 trial):
    :func:`prepare`, every filter in ``names`` at the handheld platform's settings
    (:func:`imutherm.studies.attitude.recorded.platform_settings`), the inclination scores. fusion : FusionParams or
    None (its defaults: gyro range not declared, over-range recovery off; never the data's peak). Returns a JSON-ready
    dict."""
    from imutherm.imu.filters.fusion_peer import fusion_range_info
    from imutherm.studies.attitude.recorded import platform_settings

    rec = prepare(path, init_s=init_s, skip_s=skip_s)
    res = run(names, rec, platform_settings("handheld", names), fusion=fusion)
    from imutherm.studies.attitude.real_settings import load_real_settings

    entries = load_real_settings().entries
    ref = res.get("vqf", {}).get("rms_deg")
    filters = {n: {"inclination_rms_deg": s["rms_deg"], "inclination_max_deg": s["max_deg"],
                   "x_vqf": None if not ref else s["rms_deg"] / ref,
                   "dev_cv_mean_x_vqf": entries.get(n, {}).get("cv_x_vqf"),
                   "dev_cv_worst_x_vqf": entries.get(n, {}).get("cv_worst_x_vqf"),
                   "accel_used_fraction": s["accel_used_fraction"], "runtime_s": s["runtime_s"],
                   "resets_s": s["resets_s"], "rest_off_deg": s["rest_off"], "motion_check": s["motion_check"]}
               for n, s in res.items()}
    al = rec.align
    broad = rec.dataset == "broad"
    return {"source": str(path), "layout": "BROAD HDF5" if broad else "semicolon, two header lines (RepoIMU)",
            "rows": rec.n_rows, "sample_and_hold_repeats": rec.n_repeats, "repeated_times": rec.n_dup_time,
            "true_step_median_s": rec.step_median_true, "grid_step_s": rec.dt, "init_s": rec.init_s,
            "scored": "the rows marked movement" if broad else f"every row after {skip_s:g} s",
            "reference_rows_missing": rec.n_ref_missing, "reference_rows_scored": int(rec.t_rows.size),
            "alignment": {"mode": "the data set's" if broad else "auto", "angle_deg": al.angle_deg,
                          "A": al.A.tolist(), "up_world": al.up_world.tolist(),
                          "rate_resid_deg": None if broad else al.rate_resid_deg,
                          "vertical_resid_deg": None if broad else al.up_resid_deg},
            "platform": "handheld", "score": "inclination: angle between the filter's and the reference's vertical",
            "fusion": fusion_range_info(fusion, rec.gyro @ rec.M), "filters": filters}


__all__ = ["DATA_DIRS", "DATA_DIR", "RealRecord", "prepare", "prepare_log", "data_files", "load_all", "errors",
           "score", "run", "motion_check_json",
           "table", "level_rotation", "identity_alignment", "run_reference_log"]
