"""
Attitude filters on a real recorded log (RepoIMU pendulum)
==========================================================

``imutherm attitude --imu-csv FILE`` runs every attitude filter of the package (the gated strapdown
filter and the gravity-direction Kalman filter of the source papers, the ungated baseline, the adaptive
EKF) and the peers (x-io Fusion, VQF, the ``ahrs`` package's Madgwick, Mahony and EKF) on your own log.

The log here is a real one: a consumer MEMS IMU on a swinging pendulum with a Vicon optical reference,
from the public RepoIMU data set (Szczęsna et al., 2016), kept in the project's shared data folder
(``shared/data/repoimu``, beside the repository). The example

1. converts a RepoIMU file into the ``--imu-csv`` layout (``time_s``, ``gyro_x..z``, ``accel_x..z``; units and
   axes declared in ``# key: value`` header lines),
2. runs the filters on it (all but the slowest, the adaptive EKF),
3. scores each by its **inclination** error, the angle between its vertical and the optical reference's,
   after a fixed rotation between the optical body frame and the IMU frame estimated from the
   accelerometer alone (near-static samples, Wahba's problem), so that no filter's output is used to align.

If the shared folder is not there (``IMUTHERM_SHARED`` can point at it), the example says so and stops.
"""

# %%
# Find the shared log
# -------------------
import gzip
import json
import os
import sys
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np


OUT = Path(os.environ.get("IMUTHERM_EXAMPLES_OUT", tempfile.gettempdir())) / "imutherm-examples" / "attitude_log"
HERE = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
candidates = [Path(p) for p in (os.environ.get("IMUTHERM_SHARED"),) if p] + [HERE.parent.parent / "shared"]
RECORD = "Pendulum_Test02a_Trial1_Segment_1.csv.gz"
found = [c / "data" / "repoimu" / RECORD for c in candidates if (c / "data" / "repoimu" / RECORD).is_file()]
if not found:
    print(f"skipped: {RECORD} not found in {', '.join(str(c / 'data' / 'repoimu') for c in candidates)}; "
          "set IMUTHERM_SHARED to the shared folder that holds data/repoimu")
    sys.exit(0)
source = found[0]

# %%
# Convert it to the ``--imu-csv`` layout
# --------------------------------------
# RepoIMU: ``;``-separated, two header lines; time [s], Vicon quaternion W, X, Y, Z, accelerometer
# [m/s²], gyro [rad/s], magnetometer. As in many real logs the sampling is not uniform: a few time stamps
# repeat, and some 750 steps differ from the median 11 ms by more than half of it (up to a 0.19 s gap).
# ``--imu-csv`` reads such a file directly (repeats kept as the time base, the gap bridged with a warning
# naming its row); here each step is spelled out: the record is resampled, linearly, onto a uniform grid at
# its median step. The IMU's x axis points up at rest; a fixed permutation
# (a rotation) makes it the down axis z of an FRD frame, so that the filters' roll and pitch are far from the
# pitch = ±90° singularity.
with gzip.open(source, "rt") as f:
    raw = np.loadtxt(f, delimiter=";", skiprows=2)
steps = np.diff(raw[:, 0])
raw = raw[np.r_[True, steps > 0]]
step = float(np.median(np.diff(raw[:, 0])))
print(f"{int((steps <= 0).sum())} repeated time stamps; {int((abs(steps - step) > step / 2).sum())} steps off the "
      f"median {step * 1e3:.1f} ms by more than half of it, the longest {steps.max():.2f} s")
t = np.arange(raw[0, 0], raw[-1, 0], step)
data = np.column_stack([np.interp(t, raw[:, 0], raw[:, j]) for j in range(1, 11)])
quat, accel, gyro = data[:, 0:4], data[:, 4:7], data[:, 7:10]
P = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])   # new = P @ old (det +1)
accel_frd, gyro_frd = accel @ P.T, gyro @ P.T
OUT.mkdir(parents=True, exist_ok=True)
log = OUT / "pendulum.csv"
with open(log, "w") as f:
    f.write("# gyro_units: rad/s\n# accel_units: m/s2\n# axes: FRD\n")
    f.write("time_s,gyro_x,gyro_y,gyro_z,accel_x,accel_y,accel_z\n")
    np.savetxt(f, np.column_stack([t - t[0], gyro_frd, accel_frd]), delimiter=",", fmt="%.7g")
print(f"{source.name}: {len(raw)} samples over {t[-1] - t[0]:.1f} s, resampled to {len(t)} at {step * 1e3:.1f} ms")

# %%
# Run the filters on it
# ---------------------
# ``imutherm attitude --imu-csv pendulum.csv --init-s 1 --out DIR`` runs every filter and writes
# ``attitude.json``, ``attitude_series.npz``; here the same through the Python API
# (:func:`imutherm.imu.imu_log.read_imu_csv`, :func:`imutherm.studies.attitude.recorded.run_recorded`), so that the
# slowest filter, the adaptive EKF ``aekf`` (several times the others together), can be left out to keep
# the example short. The pendulum rests only for the first second or two: the leveling window is 1 s.
from imutherm.imu.imu_log import read_imu_csv
from imutherm.studies.attitude.recorded import log_filters, run_recorded

imu_log = read_imu_csv(log, init_s=1.0)
result = run_recorded(imu_log, platform="handheld", init_s=1.0, names=[n for n in log_filters() if n != "aekf"])
series = result.series
filters = [k[: -len("_roll_deg")] for k in series if k.endswith("_roll_deg") and not k.startswith("truth")]
for name in filters:
    print(f"{name:9} accelerometer used on {100 * result.metrics[name]['accel_used_fraction']:5.1f} % of samples")

# %%
# Score the inclination against the optical reference
# ----------------------------------------------------
def up_in_body(roll_deg, pitch_deg):
    """The upward unit vector in FRD body axes from ZYX roll and pitch."""
    r, p = np.radians(roll_deg), np.radians(pitch_deg)
    return -np.column_stack([-np.sin(p), np.sin(r) * np.cos(p), np.cos(r) * np.cos(p)])


def rotate_inverse(q, v):
    """v (world) in the body axes of the body-to-world quaternion q = [w, x, y, z]."""
    w, x, y, z = (q / np.linalg.norm(q, axis=1, keepdims=True)).T
    R = np.stack([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                  [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])   # (3, 3, N)
    return np.einsum("jin,j->ni", R, v)


def angle_deg(u, v):
    return np.degrees(np.arccos(np.clip(np.sum(u * v, axis=1), -1.0, 1.0)))


def align(f_up, ref_up):
    """Wahba's problem: the rotation R (optical body -> IMU axes) that best maps ref_up onto f_up."""
    U, _, Vt = np.linalg.svd(f_up.T @ ref_up)
    return U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt


f_norm = np.linalg.norm(accel_frd, axis=1)
still = (abs(f_norm - np.median(f_norm[: 90])) < 0.15) & (np.linalg.norm(gyro_frd, axis=1) < 0.2)
f_up = accel_frd[still] / f_norm[still, None]                        # specific force points up when still
# The optical world's vertical axis is not documented with the files: take the world axis whose vertical
# the near-static accelerometer readings follow best (for a pendulum swinging about one axis, every axis
# across the swing axis fits equally, up to a rotation about it, which the alignment absorbs).
fits = {}
for axis, w in zip("xyz", np.eye(3)):
    ref_up = rotate_inverse(quat, w)
    R = align(f_up, ref_up[still])
    fits[axis] = (float(np.sqrt(np.mean(angle_deg(f_up, ref_up[still] @ R.T) ** 2))), ref_up @ R.T)
axis = min(fits, key=lambda a: fits[a][0])
ref_imu = fits[axis][1]
print("alignment residual per world axis taken as vertical [deg RMS]: "
      + ", ".join(f"{a} {v[0]:.2f}" for a, v in fits.items()) + f"; using {axis}, {still.sum()} near-static samples")

tt = series["t"]
ref_i = ref_imu[np.searchsorted(t - t[0], tt).clip(0, len(t) - 1)]
errors = {}
for name in filters:
    est = up_in_body(series[f"{name}_roll_deg"], series[f"{name}_pitch_deg"])
    errors[name] = angle_deg(est, ref_i)
print("filter     inclination error RMS / max [deg]")
for name, e in sorted(errors.items(), key=lambda kv: np.sqrt(np.mean(kv[1] ** 2))):
    print(f"{name:10} {np.sqrt(np.mean(e ** 2)):6.2f} / {e.max():6.2f}")
(OUT / "inclination.json").write_text(json.dumps(
    {n: {"rms_deg": float(np.sqrt(np.mean(e ** 2))), "max_deg": float(e.max())} for n, e in errors.items()}, indent=1))

# %%
# The inclination error over the record
# -------------------------------------
fig, (a, b) = plt.subplots(2, 1, figsize=(10, 6), sharex=True, gridspec_kw={"height_ratios": [1, 2]})
a.plot(t - t[0], np.linalg.norm(gyro, axis=1), lw=0.6, color="0.3")
a.set(ylabel="|ω| [rad/s]", title=f"RepoIMU {source.name[:-7]}: swinging pendulum, Vicon reference")
for name, e in errors.items():
    b.plot(tt, e, lw=0.8, label=f"{name} ({np.sqrt(np.mean(e ** 2)):.2f}° RMS)")
b.set(xlabel="time [s]", ylabel="inclination error [deg]", yscale="log", ylim=(1e-2, 90))
b.legend(ncol=3, fontsize=8)
b.grid(alpha=0.3)
plt.show()
