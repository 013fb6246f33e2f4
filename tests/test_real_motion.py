"""Filters on real motion: the real-log reader, true samples, alignment recovery and inclination scoring; the
gated filter's inertial low-pass mode on a known answer."""

import gzip
import math

import numpy as np
import pytest

from imutherm import InputError
from imutherm.imu.attitude_math import G0, euler_to_quat, gravity_dir_body, quat_to_dcm
from imutherm.imu.filters import GatedParams, GatedStrapdown, default_thresholds, run_gated
from imutherm.imu.reference_log import (Alignment, estimate_alignment, inclination_error_deg, kabsch,
                                        read_semicolon_log, rotation_angle_deg, true_samples)

DT = 0.01


def _motion(T=60.0, dt=DT, roll_amp=math.radians(30.0), f_swing=0.6, yaw_rate=math.radians(20.0),
            a_lin=2.0, f_lin=0.8, rest_s=2.0):
    """Known motion: level rest, then roll swinging roll_amp sin(2π f t) while yawing at yaw_rate, with a
    horizontal linear acceleration a_lin sin(2π f_lin t) north. Returns t, quat (body->NED), gyro (FRD), f_b."""
    t = np.arange(0.0, T, dt)
    s = np.clip(t - rest_s, 0.0, None)
    on = (t > rest_s).astype(float)
    phi = roll_amp * np.sin(2 * np.pi * f_swing * s) * on
    phid = roll_amp * 2 * np.pi * f_swing * np.cos(2 * np.pi * f_swing * s) * on
    psi = yaw_rate * s
    psid = yaw_rate * on
    q = euler_to_quat(phi, 0.0 * phi, psi)
    gyro = np.column_stack([phid, psid * np.sin(phi), psid * np.cos(phi)])
    a_n = np.column_stack([a_lin * np.sin(2 * np.pi * f_lin * s) * on, 0 * t, 0 * t])
    C = quat_to_dcm(q)  # body -> nav
    f_b = np.einsum("nji,nj->ni", C, a_n - np.array([0.0, 0.0, G0]))
    return t, q, gyro, f_b


def _tilt_err_deg(r_est, q):
    r = gravity_dir_body(q)
    c = np.sum(r * r_est / np.linalg.norm(r_est, axis=1)[:, None], axis=1)
    return np.degrees(np.arccos(np.clip(c, -1, 1)))


def test_gated_inertial_lowpass_known_answer():
    """Swing + yaw + 2 m/s² oscillating linear acceleration (tilt 0 known): the low-pass mode averages the
    acceleration out (RMS tilt error < 0.5°, tolerance: the 1 s Butterworth (cut-off √2 rad/s) leaves
    (√2 / 5.03)² = 8 % of the 0.8 Hz term, 0.16 m/s² or 0.9° of apparent tilt, which the kp = 1/s correction
    loop attenuates by another ~5x); Liu et al. 2012's instantaneous update with the gate always open tilts by ~5x
    more."""
    t, q, gyro, f = _motion()
    th = default_thresholds(gyro, f, DT, xi_a=3.7e-4, xi_w=0.1, d=(0.08, 0, 0), L=0.5, tau=0.1, init_s=1.5,
                            g=G0, bias=(0, 0, 0))
    lp = run_gated(gyro, f, DT, GatedParams(th, kp=1.0, ki=0.0, tau_acc=1.0), init_s=1.5)
    raw = run_gated(gyro, f, DT, GatedParams(None, kp=1.0, ki=0.0), init_s=1.5)
    e_lp = _tilt_err_deg(lp.gravity, q)[t > 5]
    e_raw = _tilt_err_deg(raw.gravity, q)[t > 5]
    rms = lambda e: float(np.sqrt(np.mean(e**2)))  # noqa: E731
    assert rms(e_lp) < 0.5, rms(e_lp)
    assert rms(e_raw) > 5 * rms(e_lp)
    assert lp.accel_used[t > 5].mean() > 0.9  # the swing is an oscillation: the low-passed rate gate stays open


def test_gated_lowpass_rejects_sustained_turn():
    """A sustained coordinated-turn-like rate (20 °/s yaw, no swing) with the centripetal specific force of a
    0.5 m radius: the low-passed rate exceeds sqrt(ξω / L) and the correction stops (the tilt stays at its
    gyro-only value 0 instead of following the apparent vertical, 11.6° off)."""
    t = np.arange(0.0, 40.0, DT)
    w = math.radians(20.0) * (t > 2)
    gyro = np.column_stack([0 * t, 0 * t, w])
    # centripetal acceleration of a 0.5 m radius would be 0.06 m/s²; make the apparent vertical 11.6° off
    a_h = G0 * math.tan(math.radians(11.6)) * (t > 2)
    f = np.column_stack([0 * t, a_h, -G0 + 0 * t])  # body y: a steady horizontal specific force
    th = default_thresholds(gyro, f, DT, xi_a=3.7e-4, xi_w=0.1, d=(0.08, 0, 0), L=1146.0, tau=0.1, init_s=1.5,
                            g=G0, bias=(0, 0, 0))
    e = run_gated(gyro, f, DT, GatedParams(th, kp=1.0, ki=0.0, tau_acc=1.0), init_s=1.5)
    tilt = np.degrees(np.arccos(np.clip(e.gravity[:, 2], -1, 1)))
    assert tilt[-1] < 1.0 and e.accel_used[t > 10].mean() < 0.05


def test_gated_lowpass_step_and_batch_agree():
    t, q, gyro, f = _motion(T=20.0)
    th = default_thresholds(gyro, f, DT, xi_a=3.7e-4, xi_w=0.1, d=(0.08, 0, 0), L=0.5, tau=0.1, init_s=1.5,
                            g=G0, bias=(0, 0, 0))
    p = GatedParams(th, kp=1.0, ki=0.01, tau_acc=1.0)
    q0 = euler_to_quat(0.0, 0.0, 0.0)
    # the batch re-measures the rate widening on the rest window: give the step the same thresholds
    from imutherm.imu.filters.gated import lp_thresholds
    p_run = GatedParams(lp_thresholds(gyro, f, DT, p, (0, 0, 0), 1.5), kp=1.0, ki=0.01, tau_acc=1.0)
    batch = run_gated(gyro, f, DT, p, q0, (0.0, 0.0, 0.0), init_s=1.5)
    fl = GatedStrapdown(p_run, q0)
    r = np.array([fl.update(gyro[k], f[k], DT).gravity for k in range(len(t))])
    assert np.max(np.abs(r - batch.gravity)) < 1e-12


def _rot(axis, ang):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(ang) * K + (1 - math.cos(ang)) * K @ K


def _dcm_to_quat(C):
    """Body->world quaternions (W,X,Y,Z) of rotation matrices C (N,3,3) (trace method; angles < 180°)."""
    w = 0.5 * np.sqrt(np.clip(1 + np.trace(C, axis1=1, axis2=2), 1e-12, None))
    return np.column_stack([w, (C[:, 2, 1] - C[:, 1, 2]) / (4 * w), (C[:, 0, 2] - C[:, 2, 0]) / (4 * w),
                            (C[:, 1, 0] - C[:, 0, 1]) / (4 * w)])


def _reference_log(A, up_world=(0.0, 0.0, 1.0)):
    """A swing about the world's horizontal axis with rests; reference body == world at rest; the IMU frame
    = A · reference body. Returns t, quat, gyro_imu, accel_imu."""
    t = np.arange(0.0, 60.0, DT)
    up = np.asarray(up_world, float)
    axis = np.cross(up, [1.0, 0.0, 0.0]) if abs(up[0]) < 0.9 else np.cross(up, [0.0, 1.0, 0.0])
    axis2 = np.cross(up, axis)
    amp = np.where((t % 20) < 14, math.radians(40.0), 0.0) * np.clip((t % 20) - 2, 0, 1)
    ang = amp * np.sin(2 * np.pi * 0.5 * t)
    ang2 = 0.3 * amp * np.sin(2 * np.pi * 0.37 * t)
    C = np.array([_rot(axis, a) @ _rot(axis2, b) for a, b in zip(ang, ang2)])  # ref body -> world
    quat = _dcm_to_quat(C)
    dC = np.einsum("nji,njk->nik", C[:-1], C[1:])
    w_ref = np.vstack([np.stack([dC[:, 2, 1] - dC[:, 1, 2], dC[:, 0, 2] - dC[:, 2, 0], dC[:, 1, 0] - dC[:, 0, 1]],
                                -1) / (2 * DT), np.zeros((1, 3))])
    f_ref = np.einsum("nji,j->ni", C, G0 * up)  # at rest / slow: specific force = +g up, in the body
    return t, quat, w_ref @ A.T, f_ref @ A.T


@pytest.mark.parametrize("up_world", [(0.0, 0.0, 1.0), (-1.0, 0.0, 0.0)])
def test_alignment_recovers_known_rotation(up_world):
    """A log rotated by a known 150° rotation (and a world whose up is -x, as the RepoIMU world is): the
    estimate recovers A within 0.5° and a perfect filter scores an inclination error below 0.5°."""
    A = _rot((0.3, -0.5, 0.8), math.radians(150.0))
    t, quat, gyro, accel = _reference_log(A, up_world)
    al = estimate_alignment(t, quat, gyro, accel)
    assert rotation_angle_deg(al.A.T @ A) < 0.5
    assert np.degrees(np.arccos(np.clip(al.up_world @ np.asarray(up_world), -1, 1))) < 0.5
    down_true = -accel / np.linalg.norm(accel, axis=1)[:, None]
    assert np.max(inclination_error_deg(down_true, quat, al)) < 0.5
    perp = np.cross(down_true, (0.6, 0.0, 0.8))
    perp /= np.linalg.norm(perp, axis=1)[:, None]
    tilted = down_true + math.tan(math.radians(3.0)) * perp  # a filter 3° off everywhere
    assert np.median(inclination_error_deg(tilted, quat, al)) == pytest.approx(3.0, abs=0.5)


def test_kabsch_exact():
    A = _rot((1, 2, 3), 1.0)
    u = np.random.default_rng(0).normal(size=(20, 3))
    assert np.allclose(kabsch(u, u @ A.T), A)


def test_read_semicolon_log_decimal_comma_gaps_and_repeats(tmp_path):
    lines = ["Time;Vicon Orientation;;;;IMU Acceleration;;;IMU Gyroscope;;;IMU Magnetometer;;",
             "s;W;X;Y;Z;X;Y;Z;X;Y;Z;X;Y;Z",
             "0;1;0;0;0;9,81;0;0;0,01;0;0;0;0;0",
             "0,011;1;0;0;0;9,81;0;0;0,01;0;0;0;0;0",  # sample-and-hold repeat
             "0,022;;;;;9,80;0;-8,00E-05;0,02;0;0;0;0;0",  # optical dropout
             "0,022;1;0;0;0;9,80;0;0;0,03;0;0;0;0;0",  # repeated time stamp
             "0,033;1;0;0;0;9,79;0;0;0,04;0;0;0;0;0"]
    p = tmp_path / "log.csv.gz"
    with gzip.open(p, "wt") as fh:
        fh.write("\n".join(lines) + "\n")
    log = read_semicolon_log(p)
    assert log.t.tolist() == [0.0, 0.011, 0.022, 0.022, 0.033]
    assert np.isnan(log.quat[2]).all() and log.accel[2, 2] == pytest.approx(-8e-5)
    ts = true_samples(log.t, log.gyro, log.accel)
    assert ts.idx.tolist() == [0, 2, 4] and ts.n_repeats == 1 and ts.n_dup_time == 1


def test_read_semicolon_log_refuses_missing_imu_value(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("a;b\nc;d\n0;1;0;0;0;;0;0;0;0;0\n0.1;1;0;0;0;1;0;0;0;0;0\n")
    with pytest.raises(InputError, match=r"row 3 lacks its time or an IMU value"):
        read_semicolon_log(p)


@pytest.mark.parametrize("name", ["kf", "aekf"])
def test_kf_aekf_inertial_lowpass_known_answer(name):
    """The same known motion (swing + yaw + 2 m/s² oscillating linear acceleration: 11.5° of apparent tilt
    amplitude, 8° RMS, unfiltered; tilt 0 known) with gyro and accelerometer noise through the horizontal-attitude KF paper's KF and
    Wang et al.'s AEKF in the low-pass mode (the handheld settings). Tolerance 0.8° RMS: the 1 s low-pass leaves
    8 % of the 0.8 Hz term (0.9° amplitude, 0.65° RMS), which these filters follow more closely than the
    gated filter's kp = 1/s loop."""
    from imutherm.imu.filters import AEKFParams, KFParams, run_aekf, run_kf
    from imutherm.imu.filters.gravity_kf import kf_params_from_rest

    t, q, gyro, f = _motion()
    rng = np.random.default_rng(3)
    g = gyro + rng.normal(0, 0.002, gyro.shape)
    a = f + rng.normal(0, 0.02, f.shape)
    if name == "kf":
        p = kf_params_from_rest(g, a, DT, 1.5, KFParams(tau_acc=1.0, n_window=1, sf_std=0.03))
        e = run_kf(g, a, DT, p, init_s=1.5)
    else:
        e = run_aekf(g, a, DT, AEKFParams(tau_acc=1.0, sf_std=0.03), init_s=1.5)
    err = _tilt_err_deg(e.gravity, q)[t > 5]
    assert float(np.sqrt(np.mean(err**2))) < 0.8


def test_kf_lowpass_step_and_batch_agree():
    from imutherm.imu.filters import GravityKF, KFParams, run_kf

    t, q, gyro, f = _motion(T=15.0)
    p = KFParams(tau_acc=1.0, n_window=3, sf_std=0.03, a=0.2)
    r0 = np.array([0.0, 0.0, 1.0])
    batch = run_kf(gyro, f, DT, p, r0, (0.0, 0.0, 0.0))
    fl = GravityKF(p, r0)
    states = [fl.update(gyro[k], f[k], DT) for k in range(len(t))]
    assert np.max(np.abs(np.array([s.r for s in states]) - batch.gravity)) < 1e-12
    assert np.array_equal([s.used for s in states], batch.accel_used)


def _write_semicolon(path, t, quat, gyro, accel):
    with gzip.open(path, "wt") as fh:
        fh.write("Time;Vicon Orientation;;;;IMU Acceleration;;;IMU Gyroscope;;;IMU Magnetometer;;\n")
        fh.write("s;W;X;Y;Z;X;Y;Z;X;Y;Z;X;Y;Z\n")
        for k in range(len(t)):
            q = ["" if not np.isfinite(v) else f"{v:.8g}".replace(".", ",") for v in quat[k]]
            vals = [f"{v:.8g}".replace(".", ",") for v in (*accel[k], *gyro[k])]
            fh.write(";".join([f"{t[k]:.4f}".replace(".", ",")] + q + vals + ["0", "0", "0"]) + "\n")


def test_cli_semicolon_log_repeats_gaps_and_auto_alignment(tmp_path, capsys):
    """A ';' log (decimal commas) rotated by a known 150°, every third row a sample-and-hold repeat and 50
    reference rows empty: the command reports the repeats, the missing rows and the rotation (within 0.5°),
    and the filters run on it."""
    import json

    from imutherm.cli.attitude import main

    A = _rot((0.3, -0.5, 0.8), math.radians(150.0))
    t, quat, gyro, accel = _reference_log(A, (-1.0, 0.0, 0.0))
    t, quat, gyro, accel = t[:3000], quat[:3000].copy(), gyro[:3000].copy(), accel[:3000].copy()
    rng = np.random.default_rng(1)  # sensor noise: a noise-free rest would repeat itself exactly
    gyro += rng.normal(0, 1e-3, gyro.shape)
    accel += rng.normal(0, 1e-2, accel.shape)
    gyro[2::3], accel[2::3] = gyro[1::3][: len(gyro[2::3])], accel[1::3][: len(accel[2::3])]
    quat[1000:1050] = np.nan
    p = tmp_path / "log.csv.gz"
    _write_semicolon(p, t, quat, gyro, accel)
    assert main(["--imu-csv", str(p), "--out", str(tmp_path / "o"), "--gyro-range", "2000"]) == 0
    out = capsys.readouterr().out
    assert "1000 sample-and-hold repeats" in out and "reference rows missing 50" in out
    d = json.loads((tmp_path / "o" / "attitude.json").read_text())
    assert d["alignment"]["angle_deg"] == pytest.approx(150.0, abs=0.5)
    # the synthetic gyro is the forward difference of the attitude (half a step early) and a third of it is held:
    # VQF within 3° (a wrong alignment would leave tens of degrees)
    assert d["filters"]["vqf"]["inclination_rms_deg"] < 3.0
    assert set(d["filters"]) >= {"gated", "kf", "aekf", "vqf", "fusion"}


def test_cli_warns_on_z_up_log_declared_frd(tmp_path, capsys):
    """A level unit at rest logged z-up but read as FRD: the fix is named (declare --axes FLU)."""
    from imutherm.cli.attitude import main
    from imutherm.imu.imu_log import write_imu_csv

    rng = np.random.default_rng(0)
    n = 2000
    t = np.arange(n) * 0.01
    gyro = rng.normal(0, 1e-3, (n, 3))
    accel = np.array([0.0, 0.0, G0]) + rng.normal(0, 0.02, (n, 3))  # +g on z: z points up
    p = write_imu_csv(tmp_path / "zup.csv", t, gyro, accel)
    assert main(["--imu-csv", str(p), "--out", str(tmp_path / "o"), "--no-plot"]) == 0
    out = capsys.readouterr().out
    assert "declare its axes FLU (or RFU; --axes" in out
    assert out.index("warning: at rest the specific force") < out.index("gated ")  # before the scores
    import json

    w = json.loads((tmp_path / "o" / "attitude.json").read_text())["warnings"]
    assert len(w) == 1 and "z axis points up" in w[0] and "off by 180" in w[0]
    level = write_imu_csv(tmp_path / "level.csv", t, gyro, -accel)  # the same unit read the right way up
    assert main(["--imu-csv", str(level), "--out", str(tmp_path / "l"), "--no-plot", "--filters", "gated"]) == 0
    assert json.loads((tmp_path / "l" / "attitude.json").read_text())["warnings"] == []


def test_cli_gyro_range_refused_when_not_positive(tmp_path):
    from imutherm.cli.attitude import main

    assert main(["--imu-csv", str(tmp_path / "x.csv"), "--gyro-range", "-5", "--out", str(tmp_path / "o")]) == 2


def test_imu_csv_fusion_gyro_range_is_declared_not_the_logs_peak(tmp_path, capsys):
    """The fusion peer's gyro range on a log comes from --gyro-range, never from the log's peak: a log peaking at
    113 °/s (the old rule gave it 125 °/s, just above its peak) runs with the range not declared (0: the
    library's over-range recovery off), or with the declared one; both are printed and written. A log clipped
    at 125 °/s is warned with the fix named."""
    import json

    from imutherm.cli.attitude import main
    from imutherm.imu.imu_log import write_imu_csv

    t, q, gyro, f = _motion(T=30.0, rest_s=9.0)  # roll swing 30° at 0.6 Hz: 113 °/s peak
    rng = np.random.default_rng(5)
    gyro = gyro + rng.normal(0, 1e-3, gyro.shape)
    f = f + rng.normal(0, 1e-2, f.shape)
    p = write_imu_csv(tmp_path / "log.csv", t, gyro, f)
    res = {}
    for label, extra in (("none", []), ("declared", ["--gyro-range", "250"])):
        assert main(["--imu-csv", str(p), "--out", str(tmp_path / label), "--no-plot", "--filters", "fusion,vqf"]
                    + extra) == 0
        res[label] = (json.loads((tmp_path / label / "attitude.json").read_text())["fusion"], capsys.readouterr().out)
    assert res["none"][0]["gyroscope_range_dps"] == 0.0 and res["none"][0]["looks_saturated_at_dps"] is None
    assert "gyro range not declared, its over-range recovery off" in res["none"][1]
    assert res["declared"][0]["gyroscope_range_dps"] == 250.0 and "gyro range 250 °/s" in res["declared"][1]
    assert "looks clipped" not in res["none"][1] + res["declared"][1]
    # clipped at a common full scale: the warning names it
    t2, q2, g2, f2 = _motion(T=30.0, rest_s=9.0, roll_amp=math.radians(40.0))  # 151 °/s peak
    g2 = np.clip(g2 + rng.normal(0, 1e-3, g2.shape), -math.radians(125.0), math.radians(125.0))
    c = write_imu_csv(tmp_path / "clip.csv", t2, g2, f2 + rng.normal(0, 1e-2, f2.shape))
    assert main(["--imu-csv", str(c), "--out", str(tmp_path / "c"), "--no-plot", "--filters", "fusion"]) == 0
    assert "declare --gyro-range 125" in capsys.readouterr().out


def test_imu_csv_reference_gaps_are_skipped_and_counted(tmp_path, capsys):
    """A comma CSV log whose reference has empty and NaN cells: accepted, scored on the valid samples, the dropped
    count printed and written."""
    import json

    from imutherm.imu.imu_log import write_imu_csv

    rng = np.random.default_rng(0)
    n = 3000
    t = np.arange(n) * 0.01
    gyro = rng.normal(0, 1e-3, (n, 3))
    accel = np.array([0.0, 0.0, -G0]) + rng.normal(0, 0.02, (n, 3))
    roll = np.zeros(n)
    p = write_imu_csv(tmp_path / "g.csv", t, gyro, accel, roll=roll, pitch=roll)
    lines = p.read_text().splitlines()
    head = 4  # three comment lines and the header
    for k in range(1500, 1600):  # 100 rows: the reference cells emptied, or NaN
        cells = lines[head + k].split(",")
        cells[-2:] = ["", ""] if k % 2 else ["nan", "nan"]
        lines[head + k] = ",".join(cells)
    p.write_text("\n".join(lines) + "\n")
    from imutherm.cli.attitude import main

    assert main(["--imu-csv", str(p), "--out", str(tmp_path / "o"), "--no-plot", "--filters", "gated,vqf"]) == 0
    assert "reference: 100 samples without a value" in capsys.readouterr().out
    d = json.loads((tmp_path / "o" / "attitude.json").read_text())
    assert d["filters"]["gated"]["reference_samples_dropped"] == 100
    assert np.isfinite(d["filters"]["gated"]["roll_rms_deg"]) and d["filters"]["gated"]["roll_rms_deg"] < 0.5


def test_imu_csv_repeats_and_irregular_steps_detected(tmp_path, capsys):
    """The known swing written as a comma CSV twice: clean at 100 Hz, and with true samples at irregular times
    (steps alternating 4 / 16 ms) of which every third row is written again as a sample-and-hold repeat. The
    second is reported (repeats dropped, resampled onto a uniform grid) and the filters score within 0.3° of the
    clean log (tolerance: linear interpolation of the 0.6 Hz swing at 4-16 ms steps)."""
    import json

    from imutherm.cli.attitude import main
    from imutherm.imu.attitude_math import quat_to_euler
    from imutherm.imu.imu_log import write_imu_csv

    t, q, gyro, f = _motion(T=40.0, rest_s=9.0)
    roll, pitch, _ = quat_to_euler(q)
    rng = np.random.default_rng(2)
    gyro = gyro + rng.normal(0, 1e-3, gyro.shape)
    f = f + rng.normal(0, 1e-2, f.shape)
    clean = write_imu_csv(tmp_path / "clean.csv", t, gyro, f, roll=roll, pitch=pitch)
    # irregular true times: evaluate the motion at t_true by interpolation of the 100 Hz truth
    t_true = np.cumsum(np.where(np.arange(len(t)) % 2, 0.016, 0.004))
    t_true = t_true[t_true < t[-1]]
    it = lambda x: np.column_stack([np.interp(t_true, t, x[:, j]) for j in range(x.shape[1])])  # noqa: E731
    g2, f2 = it(gyro), it(f)
    r2, p2 = np.interp(t_true, t, roll), np.interp(t_true, t, pitch)
    rows = np.repeat(np.arange(len(t_true)), np.where(np.arange(len(t_true)) % 3 == 0, 2, 1))
    t_rows = t_true[rows] + np.where(np.r_[False, rows[1:] == rows[:-1]], 0.003, 0.0)  # a repeat 3 ms later
    messy = write_imu_csv(tmp_path / "messy.csv", t_rows, g2[rows], f2[rows], roll=r2[rows], pitch=p2[rows])
    res = {}
    for name, path in (("clean", clean), ("messy", messy)):
        assert main(["--imu-csv", str(path), "--out", str(tmp_path / name), "--no-plot",
                     "--filters", "gated,kf,vqf"]) == 0
        res[name] = json.loads((tmp_path / name / "attitude.json").read_text())["filters"]
    out = capsys.readouterr().out
    assert f"{int(np.sum(np.arange(len(t_true)) % 3 == 0))} sample-and-hold repeats" in out
    assert "resampled onto a uniform" in out
    sm = json.loads((tmp_path / "messy" / "attitude.json").read_text())["samples"]  # the comma path writes it too
    assert sm["n_repeats"] == int(np.sum(np.arange(len(t_true)) % 3 == 0)) and sm["n_dup_time"] == 0
    assert sm["resampled"] and sm["step_spread"] > 0.5 and "true_steps" not in sm
    assert all(m["time_steps"] == "uniform" for m in res["messy"].values())
    for n in ("gated", "kf", "vqf"):
        for k in ("roll_rms_deg", "pitch_rms_deg"):
            assert res["messy"][n][k] == pytest.approx(res["clean"][n][k], abs=0.3), (n, k)


def _jittered_swing(seed=5, n=4000):
    """A roll oscillation (40° at 0.25 Hz about body x, no translation, after 10 s at rest) sampled at irregular
    true times: steps of 9 ms (60 %) and 12 ms (40 %), a spread of 33 % around the 9 ms median, below the
    resampling threshold (50 %), and a mean step 13 % longer than the median. Returns t, quat, gyro, f, steps."""
    from imutherm.imu.attitude_math import euler_to_quat, quat_to_dcm

    rng = np.random.default_rng(seed)
    steps = np.where(rng.random(n) < 0.6, 0.009, 0.012)
    steps[:1200] = 0.009  # the rest window at the median step
    t = np.concatenate([[0.0], np.cumsum(steps[1:])])
    on = t > 10.0
    A, w = math.radians(40.0), 2 * math.pi * 0.25
    roll = np.where(on, A * np.sin(w * (t - 10.0)), 0.0)
    q = euler_to_quat(roll, 0 * t, 0 * t)
    f = np.einsum("nji,nj->ni", quat_to_dcm(q), np.tile([0.0, 0.0, -G0], (n, 1)))
    gyro = np.column_stack([np.where(on, A * w * np.cos(w * (t - 10.0)), 0.0), 0 * t, 0 * t])
    return t, q, gyro, f, steps


def test_every_filter_that_takes_a_varying_step_integrates_the_true_steps():
    """On :func:`_jittered_swing` (gyro noise and a 0.4 °/s bias, accelerometer noise) every registered filter
    whose registry entry says ``varying_dt`` holds the tilt to < 1° RMS after 5 s of swinging when given the
    true steps (measured 0.02-0.65°), and is off by more than 2° at the median step (measured 2.4-4.8°: the
    gyro integrates 13 % too little time); the others (VQF, one sample period fixed at construction) run at the
    median either way."""
    from imutherm.imu.filters.registry import filter_names, in_group
    from imutherm.studies.attitude.attitude_study import GateConfig, run_filters

    t, q, gyro, f, steps = _jittered_swing()
    rng = np.random.default_rng(1)
    g = gyro + rng.normal(0, 0.002, gyro.shape) + np.radians([0.3, -0.2, 0.1])
    a = f + rng.normal(0, 0.02, f.shape)
    names = filter_names(gnss=False)
    dt = float(np.median(steps))
    true, _ = run_filters(g, a, dt, (0, 0, 0), GateConfig(init_s=8.0), names=names, steps=steps)
    median, _ = run_filters(g, a, dt, (0, 0, 0), GateConfig(init_s=8.0), names=names)
    late = t > 15.0
    for n in names:
        e_true = float(np.sqrt(np.mean(_tilt_err_deg(true[n].gravity, q)[late] ** 2)))
        e_med = float(np.sqrt(np.mean(_tilt_err_deg(median[n].gravity, q)[late] ** 2)))
        if n in in_group("varying_dt"):
            assert e_true < 1.0 < 2.0 < e_med, (n, e_true, e_med)
        else:
            assert e_true == e_med, n


def test_imu_csv_jitter_below_the_threshold_runs_on_the_true_steps(tmp_path, capsys):
    """:func:`_jittered_swing` as a comma CSV with two sample-and-hold repeats and one repeated time stamp: the
    log is not resampled (33 % < 50 %), attitude.json reports the repeats, the repeated stamp, the step spread
    and which filters integrated the true steps (every one but vqf) or ran at the median (vqf), and the scores
    show it (gated < 1° roll RMS against the reference, vqf > 2°)."""
    import json

    from imutherm.cli.attitude import main
    from imutherm.imu.attitude_math import quat_to_euler
    from imutherm.imu.imu_log import write_imu_csv

    t, q, gyro, f, steps = _jittered_swing()
    roll, pitch, _ = quat_to_euler(q)
    rng = np.random.default_rng(2)
    gyro = gyro + rng.normal(0, 1e-3, gyro.shape)
    f = f + rng.normal(0, 1e-2, f.shape)
    rows = np.r_[np.arange(2000), 1999, np.arange(2000, 3000), 2999, np.arange(3000, len(t))]  # two repeats
    t_rows = t[rows].copy()
    extra = 3500  # a row with the time stamp of the row before (new IMU values): dropped as a repeated stamp
    p = write_imu_csv(tmp_path / "jitter.csv", np.insert(t_rows, extra, t_rows[extra - 1]),
                      np.insert(gyro[rows], extra, gyro[rows][extra] * 1.01, axis=0),
                      np.insert(f[rows], extra, f[rows][extra], axis=0),
                      roll=np.insert(roll[rows], extra, roll[rows][extra - 1]),
                      pitch=np.insert(pitch[rows], extra, pitch[rows][extra - 1]))
    assert main(["--imu-csv", str(p), "--out", str(tmp_path / "o"), "--no-plot", "--platform", "aircraft",
                 "--filters", "gated,kf,aekf,vqf"]) == 0
    d = json.loads((tmp_path / "o" / "attitude.json").read_text())
    sm = d["samples"]
    assert sm["n_repeats"] == 2 and sm["n_dup_time"] == 1 and not sm["resampled"]
    assert sm["step_median_s"] == pytest.approx(0.009) and sm["step_spread"] == pytest.approx(1 / 3, abs=1e-6)
    assert sm["step_max_s"] == pytest.approx(0.012) and sm["true_steps"] == ["gated", "kf", "aekf"]
    assert sm["median_step"] == ["vqf"]
    assert [d["filters"][n]["time_steps"] for n in ("gated", "kf", "aekf", "vqf")] == ["true"] * 3 + ["median"]
    assert d["filters"]["gated"]["roll_rms_deg"] < 1.0 < 2.0 < d["filters"]["vqf"]["roll_rms_deg"]
    out = capsys.readouterr().out
    assert "gated, kf, aekf integrate the true steps, vqf at the median step" in out


def test_imu_csv_align_auto_recovers_known_rotation(tmp_path, capsys):
    """A comma CSV log whose roll/pitch reference belongs to a body rotated by a known (10°, -20°, 30°) from the
    IMU: with --align none the 39° mounting is named and not scored, --align auto recovers it (angle printed,
    within 0.5° of the declared rotation's) and the inclination scores match those with --align declared (0.2°)."""
    import json

    from imutherm.cli.attitude import main
    from imutherm.imu.imu_log import write_imu_csv

    # the IMU rests at several tilts (quasi-static moments at different attitudes), moving between them
    t = np.arange(0.0, 60.0, DT)
    phi = np.radians(25.0) * np.clip(np.sin(2 * np.pi * t / 30.0) * 2, -1, 1) * (t > 9)
    th = np.radians(15.0) * np.clip(np.cos(2 * np.pi * t / 20.0) * 2, -1, 1) * (t > 9)
    q_imu = euler_to_quat(phi, th, 0.0 * t)
    C = quat_to_dcm(q_imu)
    f = np.einsum("nji,j->ni", C, np.array([0.0, 0.0, -G0]))
    dC = np.einsum("nji,njk->nik", C[:-1], C[1:])
    gyro = np.vstack([np.zeros((1, 3)), np.stack([dC[:, 2, 1] - dC[:, 1, 2], dC[:, 0, 2] - dC[:, 2, 0],
                                                  dC[:, 1, 0] - dC[:, 0, 1]], -1) / (2 * DT)])
    rng = np.random.default_rng(4)
    gyro += rng.normal(0, 1e-3, gyro.shape)
    f += rng.normal(0, 1e-2, f.shape)
    rpy = (10.0, -20.0, 30.0)
    Cri = quat_to_dcm(euler_to_quat(*np.radians(rpy)))  # IMU frame in the reference body frame: v_ref = Cri v_imu
    C_ref = np.einsum("nij,kj->nik", C, Cri)  # reference body -> nav = C_imu Cri^T
    r_ref = C_ref[:, 2, :]  # down in the reference body
    roll_ref = np.arctan2(r_ref[:, 1], r_ref[:, 2])
    pitch_ref = np.arctan2(-r_ref[:, 0], np.hypot(r_ref[:, 1], r_ref[:, 2]))
    p = write_imu_csv(tmp_path / "a.csv", t, gyro, f, roll=roll_ref, pitch=pitch_ref)
    res = {}
    for mode in ("none", "auto", ",".join(str(v) for v in rpy)):
        assert main(["--imu-csv", str(p), "--out", str(tmp_path / mode.replace(",", "_")), "--no-plot",
                     "--filters", "gated,vqf", "--align", mode]) == 0
        res[mode] = json.loads((tmp_path / mode.replace(",", "_") / "attitude.json").read_text())["filters"]
    declared = ",".join(str(v) for v in rpy)
    assert res["auto"]["vqf"]["alignment"]["angle_deg"] == pytest.approx(
        res[declared]["vqf"]["alignment"]["angle_deg"], abs=0.5)
    assert res["none"]["vqf"]["inclination_rms_deg"] is None and res["none"]["vqf"]["alignment"]["mounting"]
    for n in ("gated", "vqf"):
        assert res["auto"][n]["inclination_rms_deg"] == pytest.approx(res[declared][n]["inclination_rms_deg"],
                                                                      abs=0.2)
        assert res[declared][n]["inclination_rms_deg"] < 1.0
    assert "reference -> IMU rotation (auto)" in capsys.readouterr().out


def test_mahony_is_never_run_at_the_ahrs_defaults_on_motion():
    """No default path runs the ``mahony`` peer at the ahrs defaults (k_P 1.0, k_I 0.3, the trap: 9.5° mean on
    held-out real records). Every recorded-log platform takes the tuned setting of its profile from the
    settings file (PLATFORM_PROFILE; the one tuning procedure on simulated seeds 100-101, not on the data the
    log benchmarks score), and ``imutherm attitude --profile P`` runs the tuned setting on every motion profile
    (``static``, at rest, is not tuned). On the known motion (2 m/s² at 0.8 Hz: 11.5° of apparent tilt
    amplitude) with a 0.6°/s gyro bias, a first-order complementary loop passes k_P / |jω + k_P| of the
    acceleration's tilt: 0.06 (0.5° RMS) at the handheld's k_P 0.316 and 0.20 (1.6° RMS) at k_P 1.
    Tolerances: < 1.0° RMS and > 1.4° RMS."""
    import dataclasses

    from imutherm.imu.filters.peers import MahonyParams, run_mahony
    from imutherm.imu.motion import PROFILES
    from imutherm.studies.attitude.attitude_study import _profile_settings
    from imutherm.studies.attitude.filter_settings import load_settings
    from imutherm.studies.attitude.recorded import PLATFORM_PROFILE, PLATFORMS, platform_settings

    fs = load_settings()
    for plat in PLATFORMS:
        p = MahonyParams(**platform_settings(plat, ("mahony",))["mahony"])
        assert dataclasses.asdict(p) == fs.profiles[PLATFORM_PROFILE[plat]]["mahony"], plat
        assert p.k_I <= 0.03 < MahonyParams().k_I, plat  # far from the ahrs integral gain that winds up
        assert fs.provenance[PLATFORM_PROFILE[plat]]["mahony"]["command"].startswith("python benchmarks/tune_")
    for prof in PROFILES:
        tuned, info = _profile_settings(prof, ("mahony",), "tuned")
        assert ("mahony" in tuned) == (prof != "static") and info["defaults"] == ([] if prof != "static" else ["mahony"])
    t, q, gyro, f = _motion()
    rng = np.random.default_rng(3)
    g = gyro + rng.normal(0, 0.002, gyro.shape) + np.radians([0.5, -0.3, 0.2])
    a = f + rng.normal(0, 0.02, f.shape)
    rms = {}
    for name, p in (("handheld", MahonyParams(**platform_settings("handheld", ("mahony",))["mahony"])),
                    ("ahrs", MahonyParams())):
        err = _tilt_err_deg(run_mahony(g, a, DT, p, init_s=1.5).gravity, q)[t > 5]
        rms[name] = float(np.sqrt(np.mean(err**2)))
    assert rms["handheld"] < 1.0 and rms["ahrs"] > 1.4, rms


def _turntable(T=70.0, dt=DT, roll=math.radians(20.0), pitch=math.radians(-10.0), yaw_rate=math.radians(30.0),
               radius=0.3, rest_s=10.0):
    """Known answer for every filter: a unit mounted at a fixed tilt (roll, pitch) on a turntable, radius m from
    its vertical axis, at rest for rest_s then turning at a constant yaw_rate. Its body rates are constant
    ([-ψ̇ sinθ, ψ̇ sinφ cosθ, ψ̇ cosφ cosθ]), the true roll and pitch never change, and the specific force carries
    the known centripetal acceleration ψ̇² radius (0.082 m/s², the apparent vertical 0.48° off the true one).
    Returns t, quat (body->NED), gyro (FRD) [rad/s], f_b [m/s²]."""
    t = np.arange(0.0, T, dt)
    on = (t > rest_s).astype(float)
    psi = yaw_rate * np.clip(t - rest_s, 0.0, None)
    psid = yaw_rate * on
    q = euler_to_quat(roll + 0 * t, pitch + 0 * t, psi)
    gyro = np.column_stack([-psid * math.sin(pitch), psid * math.sin(roll) * math.cos(pitch),
                            psid * math.cos(roll) * math.cos(pitch)])
    p_n = radius * np.column_stack([np.cos(psi), np.sin(psi), 0 * t])
    a_n = -(psid**2)[:, None] * p_n
    C = quat_to_dcm(q)
    f_b = np.einsum("nji,nj->ni", C, a_n - np.array([0.0, 0.0, G0]))
    return t, q, gyro, f_b


#: the turntable's gyro bias [rad/s]: measured at rest by every filter (the rest-window mean; x-io Fusion's own
#: offset stage), else it turns the vertical by about |b_h| / ψ̇ = 1.1° in the turn
TURNTABLE_BIAS = np.radians([0.5, -0.3, 0.2])
#: the known-answer bound [deg RMS]: between the gyro's exact answer (0°) and the accelerometer alone (0.48°)
TURNTABLE_BOUND = 0.3


@pytest.fixture(scope="module")
def turntable_record():
    """:func:`_turntable` after 30 s at rest (x-io Fusion's offset stage, imufusion.Bias: 5 s timeout, 0.02 Hz
    corner, learns a rest bias in ~25 s; every other filter takes the rest-window mean), with gyro noise
    0.002 rad/s, accelerometer noise 0.02 m/s² and the gyro bias :data:`TURNTABLE_BIAS`; GNSS velocity fixes of
    the unit (5 Hz, 0.01 m/s noise) for ``aekf_gnss``. Returns t, q, gyro, accel, f (exact), fixes."""
    from imutherm.imu.gnss import GnssVelocity

    rest, radius, rate = 30.0, 0.3, math.radians(30.0)
    t, q, gyro, f = _turntable(T=90.0, rest_s=rest, radius=radius, yaw_rate=rate)
    rng = np.random.default_rng(7)
    g = gyro + rng.normal(0, 0.002, gyro.shape) + TURNTABLE_BIAS
    a = f + rng.normal(0, 0.02, f.shape)
    psi, psid = rate * np.clip(t - rest, 0.0, None), rate * (t > rest)
    v = radius * np.column_stack([-np.sin(psi) * psid, np.cos(psi) * psid, 0 * t])
    idx = np.arange(0, t.size, int(round(0.2 / DT)))
    fixes = GnssVelocity(idx=idx, vel_n=v[idx] + rng.normal(0, 0.01, (idx.size, 3)), std=0.01)
    return t, q, g, a, f, fixes


def test_the_turntable_bound_fails_the_accelerometer_alone_and_an_uncorrected_gyro(turntable_record):
    """The bound of :func:`test_every_filter_holds_a_constant_rate_rotation` can fail: the vertical of the exact
    specific force is 0.48° off (the centripetal term), and the gyro integrated from the leveling without
    removing the rest bias is more than twice the bound off (measured 17.5°); with the rest-window bias removed
    it holds (0.25°: the random walk of the gyro noise over the 90 s record)."""
    from imutherm.imu.filters.common import initial_quat

    t, q, g, a, f, _ = turntable_record
    turn = t > 35.0
    down = -f / np.linalg.norm(f, axis=1)[:, None]
    acc_only = float(np.sqrt(np.mean(_tilt_err_deg(down, q)[turn] ** 2)))
    assert acc_only == pytest.approx(0.48, abs=0.01) and acc_only > TURNTABLE_BOUND
    q0 = initial_quat(a, DT, 8.0)
    for bias, ok in ((np.zeros(3), False), (g[: int(8.0 / DT)].mean(axis=0), True)):
        est = run_gated(g, a, DT, GatedParams(None, kp=0.0, ki=0.0), q0=q0, bias0=bias, init_s=8.0)
        e = float(np.sqrt(np.mean(_tilt_err_deg(est.gravity, q)[turn] ** 2)))
        assert (e < TURNTABLE_BOUND) if ok else (e > 2 * TURNTABLE_BOUND), (ok, e)


def _turntable_filters():
    from imutherm.imu.filters.registry import filter_names

    why = ("Madgwick's normalised gradient step corrects at a fixed rate (its gain, 0.18 deg/s at the flight's "
           "tuned 0.00316 rad/s): it follows any accelerometer tilt that moves slower, here the 0.48 deg "
           "centripetal tilt turning at 30 deg/s (measured 0.45 deg RMS; 0.04 deg at gain 1e-4)")
    return [pytest.param(n, marks=pytest.mark.xfail(strict=True, reason=why)) if n == "madgwick" else n
            for n in filter_names()]


@pytest.mark.parametrize("name", _turntable_filters())
def test_every_filter_holds_a_constant_rate_rotation(name, turntable_record):
    """Known answer for every registered filter (peers and the GNSS-aided one included), each at the settings
    the tuning procedure chose for the flight (its long coordinated turns are this case; a filter without
    flight settings at its defaults), on :func:`turntable_record`: the tilt error after the first 5 s of
    turning stays below :data:`TURNTABLE_BOUND` (0.3°) RMS. The accelerometer alone is 0.48° off and the gyro
    without its rest bias more than 0.3° (:func:`test_the_turntable_bound_fails_the_accelerometer_alone_and_an_uncorrected_gyro`),
    the exact gyro 0°; a frame or sign error in the gyro propagation shows as degrees (the body turns through
    360° every 12 s). Measured: gated 0.12, kf 0.23, ungated 0.10, fusion 0.20, aekf 0.02, aekf_gnss 0.06, vqf
    0.09, mahony 0.17, ekf 0.10; madgwick 0.45 (expected to fail, see its reason)."""
    from imutherm.studies.attitude.attitude_study import GateConfig, run_filters
    from imutherm.studies.attitude.filter_settings import load_settings

    t, q, g, a, _, fixes = turntable_record
    est, _ = run_filters(g, a, DT, (0.3, 0.0, 0.0), GateConfig(init_s=8.0), names=(name,), gnss=fixes,
                         settings=load_settings().for_profile("flight", (name,)))
    err = _tilt_err_deg(est[name].gravity, q)[t > 35.0]
    assert float(np.sqrt(np.mean(err**2))) < TURNTABLE_BOUND, (name, float(np.sqrt(np.mean(err**2))))
