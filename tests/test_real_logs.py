"""Real logs that just work, alignment only on evidence, filters on real motion: hostile logs refused in
one line, the sample-and-hold BROAD trial read as the reference reader reads it, a known mounting (90° yaw; x/y
swapped with z flipped) detected and restored, an aligned log kept at the identity, the low-pass modes stable at
any time constant, the bias learned at rest, the gyro sample conventions, and the cross-validation by file."""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from imutherm import InputError
from imutherm.cli.attitude import main
from imutherm.imu.attitude_math import G0, euler_to_quat, gravity_dir_body, quat_to_dcm
from imutherm.imu.imu_log import read_imu_csv, write_imu_csv
from imutherm.studies.attitude import real_benchmark as rb

DT = 0.01
BROAD27 = rb.DATA_DIRS["broad"] / "27_disturbed_phone_vibration_B.hdf5"


def _rest_log(n=2000, seed=0):
    rng = np.random.default_rng(seed)
    return (np.arange(n) * DT, rng.normal(0, 1e-3, (n, 3)),
            np.array([0.0, 0.0, -G0]) + rng.normal(0, 0.02, (n, 3)))


@pytest.mark.parametrize("case", ["utf16", "same_time"])
def test_hostile_logs_refused_in_one_line(case, tmp_path, capsys):
    """The UTF-16 log (the ';' check used to decode its first line as UTF-8) and the log whose rows all share one
    time stamp (a reduction over no steps) end in one line and exit 2, never a traceback; nothing is written."""
    t, g, a = _rest_log()
    if case == "utf16":
        p = tmp_path / "u16.csv"
        p.write_bytes(write_imu_csv(tmp_path / "ok.csv", t, g, a).read_text().encode("utf-16"))
        want = "is UTF-16 text; valid: UTF-8"
    else:
        p = write_imu_csv(tmp_path / "same.csv", np.zeros_like(t), g, a)
        want = "all 2000 rows (rows 6-2005) share the time stamp 0 s; rule: a log's times increase"
    assert main(["--imu-csv", str(p), "--out", str(tmp_path / "o"), "--no-plot"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and want in err[0] and "Traceback" not in err[0]
    assert not (tmp_path / "o").exists()


def test_a_long_hold_is_a_gap_named_by_its_rows(tmp_path):
    """One sample held for 0.8 s on a regular time column: refused naming the rows and the rule, bridged with
    --max-gap; short holds are kept as the time base and counted."""
    t, g, a = _rest_log(3000)
    g[1000:1080], a[1000:1080] = g[999], a[999]  # held 0.8 s
    g[2000:2003], a[2000:2003] = g[1999], a[1999]  # held 30 ms
    p = write_imu_csv(tmp_path / "h.csv", t, g, a)
    with pytest.raises(InputError, match=r"rows 1005-1085 hold one sample for 0.81 s .*rule: a hold over 0.5 s is a "
                                         r"gap; valid: --max-gap 0.9"):
        read_imu_csv(p)
    log = read_imu_csv(p, max_gap_s=0.9)
    assert log.n_repeats == 83 and log.resampled and log.longest_hold_s == pytest.approx(0.81)
    assert log.t.size == 3000 and log.dt == pytest.approx(DT)  # the rows' regular time base kept


def _broad_as_csv(path, out):
    """A BROAD trial as the project's CSV: FLU axes (its IMU reads +g on z at rest), interval gyro samples, every
    row (held ones too) at t = k / rate, the reference roll / pitch only on the movement rows (NaN elsewhere, so
    that the CSV path scores the rows the reference reader scores)."""
    from imutherm.imu.reference_log import quat_to_dcm_wxyz, read_broad_hdf5

    log = read_broad_hdf5(path)
    T = np.diag([1.0, -1.0, -1.0])
    r = np.einsum("nji,j->ni", quat_to_dcm_wxyz(log.quat), np.array([0.0, 0.0, -1.0])) @ T.T  # down, FRD
    roll, pitch = np.arctan2(r[:, 1], r[:, 2]), np.arctan2(-r[:, 0], np.hypot(r[:, 1], r[:, 2]))
    roll[~log.movement] = pitch[~log.movement] = np.nan
    return write_imu_csv(out, log.t, log.gyro @ T.T, log.accel @ T.T, roll=roll, pitch=pitch, axes="FLU",
                         gyro_sample="interval")


@pytest.mark.skipif(not BROAD27.exists(), reason="the shared BROAD development files are not here")
def test_sample_and_hold_trial_keeps_its_samples_and_scores_as_the_reference_reader(tmp_path, capsys):
    """BROAD trial 27 (496 held rows in runs of 3-5 on a regular 3.5 ms time column; refused as a 21 ms gap before)
    as a CSV: accepted, the repeats kept as the time base and counted, `--align auto` keeps the identity (the data
    set's reference is aligned; a fitted rotation does not beat it), and every filter scores what the reference
    reader (the HDF5 path) scores, within 0.002° (the two paths level the axes by different fixed rotations)."""
    p = _broad_as_csv(BROAD27, tmp_path / "b27.csv")
    names = "gated,kf,aekf,vqf"
    assert main(["--imu-csv", str(p), "--out", str(tmp_path / "o"), "--no-plot", "--filters", names,
                 "--align", "auto"]) == 0
    out = capsys.readouterr().out
    assert "496 sample-and-hold repeats kept as the time base" in out and "identity kept" in out
    d = json.loads((tmp_path / "o" / "attitude.json").read_text())
    assert d["samples"]["n_repeats"] == 496 and d["samples"]["longest_hold_s"] == pytest.approx(0.021, abs=1e-3)
    assert d["filters"]["vqf"]["alignment"]["applied"] is False
    assert main(["--imu-csv", str(BROAD27), "--out", str(tmp_path / "r"), "--filters", names]) == 0
    ref = json.loads((tmp_path / "r" / "attitude.json").read_text())
    assert ref["sample_and_hold_repeats"] == 496 and ref["alignment"]["angle_deg"] == 0.0
    for n in names.split(","):
        assert d["filters"][n]["inclination_rms_deg"] == pytest.approx(ref["filters"][n]["inclination_rms_deg"],
                                                                       abs=2e-3), n
        assert ref["filters"][n]["inclination_rms_deg"] < 0.5, n  # VQF 0.37°, ours 0.31-0.36° (dev figures)
        # the in-motion divergence check on both paths (the CSV path integrates the true steps): nothing flagged,
        # the same worst window within 0.05°
        assert d["filters"][n]["motion_check"]["flagged"] == [] == ref["filters"][n]["motion_check"]["flagged"], n
        assert d["filters"][n]["motion_check"]["worst_deg"] == pytest.approx(
            ref["filters"][n]["motion_check"]["worst_deg"], abs=0.05), n


def _tilting_log(Cri, tmp_path, name):
    """An IMU that rests at several tilts and moves between them (60 s at 100 Hz, interval gyro samples from the
    attitude's own increments), its reference (roll, pitch) that of a body whose frame holds the IMU's as
    ``v_ref = Cri v_imu``. Returns the CSV path."""
    t = np.arange(0.0, 60.0, DT)
    phi = np.radians(25.0) * np.clip(np.sin(2 * np.pi * t / 30.0) * 2, -1, 1) * (t > 9)
    th = np.radians(15.0) * np.clip(np.cos(2 * np.pi * t / 20.0) * 2, -1, 1) * (t > 9)
    C = quat_to_dcm(euler_to_quat(phi, th, 0.0 * t))
    f = np.einsum("nji,j->ni", C, np.array([0.0, 0.0, -G0]))
    dC = np.einsum("nji,njk->nik", C[:-1], C[1:])
    gyro = np.vstack([np.zeros((1, 3)), np.stack([dC[:, 2, 1] - dC[:, 1, 2], dC[:, 0, 2] - dC[:, 2, 0],
                                                  dC[:, 1, 0] - dC[:, 0, 1]], -1) / (2 * DT)])
    rng = np.random.default_rng(4)
    gyro += rng.normal(0, 1e-3, gyro.shape)
    f += rng.normal(0, 1e-2, f.shape)
    r_ref = np.einsum("nij,kj->nik", C, Cri)[:, 2, :]  # down in the reference body
    roll = np.arctan2(r_ref[:, 1], r_ref[:, 2])
    pitch = np.arctan2(-r_ref[:, 0], np.hypot(r_ref[:, 1], r_ref[:, 2]))
    return write_imu_csv(tmp_path / name, t, gyro, f, roll=roll, pitch=pitch, gyro_sample="interval")


MOUNTS = {"yaw90": (quat_to_dcm(euler_to_quat(0.0, 0.0, math.radians(90.0))), "turned 90° in yaw", "0,0,90"),
          "swap_xy_flip_z": (np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]),
                             "IMU x along +y of the reference, IMU y along +x of the reference, IMU z along -z",
                             "180,0,90")}


@pytest.mark.parametrize("mount", list(MOUNTS))
def test_mounting_error_detected_named_and_restored(mount, tmp_path, capsys):
    """A log whose reference body holds the IMU turned by a known mounting (a 90° yaw; x and y swapped with z
    flipped, a proper 180° rotation): without --align the mounting is found, named with its fix and not scored as
    filter error; with --align auto the rotation is restored within 1° and the scores equal those with the fix
    declared (0.05°)."""
    Cri, words, fix = MOUNTS[mount]
    p = _tilting_log(Cri, tmp_path, f"{mount}.csv")
    res = {}
    for mode in ("none", "auto", fix):
        assert main(["--imu-csv", str(p), "--out", str(tmp_path / mode.replace(",", "_")), "--no-plot",
                     "--filters", "gated,vqf", "--align", mode]) == 0
        res[mode] = json.loads((tmp_path / mode.replace(",", "_") / "attitude.json").read_text())
    out = capsys.readouterr().out
    assert words in res["none"]["warnings"][0] and f"--align {fix}" in res["none"]["warnings"][0]
    assert res["none"]["filters"]["vqf"]["inclination_rms_deg"] is None and "not scored (mounting" in out
    al = res["auto"]["filters"]["vqf"]["alignment"]
    from imutherm.imu.reference_log import rotation_angle_deg

    assert al["applied"] and rotation_angle_deg(np.array(al["fitted_A"]) @ Cri) < 1.0  # A = Cri^T within 1°
    for n in ("gated", "vqf"):
        assert res["auto"]["filters"][n]["inclination_rms_deg"] == pytest.approx(
            res[fix]["filters"][n]["inclination_rms_deg"], abs=0.05)
        assert res[fix]["filters"][n]["inclination_rms_deg"] < 1.0


def test_aligned_log_keeps_identity_under_auto(tmp_path, capsys):
    """The same motion with the reference in the IMU's own frame: --align auto keeps the identity and says why; no
    mounting warning without --align either."""
    p = _tilting_log(np.eye(3), tmp_path, "aligned.csv")
    for mode in ("auto", "none"):
        assert main(["--imu-csv", str(p), "--out", str(tmp_path / mode), "--no-plot", "--filters", "vqf",
                     "--align", mode]) == 0
        d = json.loads((tmp_path / mode / "attitude.json").read_text())
        assert d["filters"]["vqf"]["alignment"]["applied"] is False and d["warnings"] == []
        assert d["filters"]["vqf"]["inclination_rms_deg"] < 1.0
    assert "reference -> IMU rotation (auto): identity kept" in capsys.readouterr().out


def test_declared_z_up_log_is_not_told_to_declare_flu(tmp_path):
    """A log declared FLU whose z axis reads down at rest (x/y swapped, z flipped against FLU): the note names an
    upside-down rest or a swapped / flipped axis, and does not tell the user to declare FLU."""
    t, g, a = _rest_log()
    p = write_imu_csv(tmp_path / "flu.csv", t, g, -a, axes="FLU")  # written FRD->FLU of a unit reading +g: z down
    w = read_imu_csv(p).warnings
    assert len(w) == 1 and "although the log declares FLU" in w[0] and "declare its axes FLU" not in w[0]


def _slow_turns(T=120.0, dt=DT):
    """Known answer: 10 s level rest, then the body tilts to ±30° in roll and pitch with periods of 7 s and 11 s
    (no translation: the specific force is gravity alone). Returns t, quat, gyro (interval: the increments' mean
    rate over each step), f."""
    t = np.arange(0.0, T, dt)
    on = np.clip((t - 10.0) / 5.0, 0.0, 1.0)
    phi = math.radians(30.0) * np.sin(2 * np.pi * t / 7.0) * on
    th = math.radians(30.0) * np.sin(2 * np.pi * t / 11.0) * on
    q = euler_to_quat(phi, th, 0.0 * t)
    C = quat_to_dcm(q)
    f = np.einsum("nji,j->ni", C, np.array([0.0, 0.0, -G0]))
    dC = np.einsum("nji,njk->nik", C[:-1], C[1:])
    w = np.stack([dC[:, 2, 1] - dC[:, 1, 2], dC[:, 0, 2] - dC[:, 2, 0], dC[:, 1, 0] - dC[:, 0, 1]], -1) / (2 * dt)
    return t, q, np.vstack([np.zeros((1, 3)), w]), f


def _rms_tilt(est, q, mask):
    r = gravity_dir_body(q)
    c = np.sum(r * est.gravity / np.linalg.norm(est.gravity, axis=1)[:, None], axis=1)
    return float(np.sqrt(np.mean(np.degrees(np.arccos(np.clip(c, -1, 1)))[mask] ** 2)))


@pytest.mark.parametrize("tau_acc", [1.0, 10.0])
def test_gated_lowpass_is_stable_at_any_time_constant(tau_acc):
    """The gated filter's low-pass sits in a strapdown frame outside its correction loop: at kp 3 1/s with a 10 s
    low-pass (kp tau_acc = 30; inside the loop, as before, it oscillated to 20-90° on real files) it holds the tilt
    of the known slow turns with a 0.5 °/s gyro bias within 1° RMS after 30 s."""
    from imutherm.studies.attitude.attitude_study import GateConfig, run_filters

    t, q, w, f = _slow_turns()
    rng = np.random.default_rng(0)
    g = w + np.radians([0.5, -0.3, 0.2]) + rng.normal(0, 0.002, w.shape)
    a = f + rng.normal(0, 0.02, f.shape)
    est, _ = run_filters(g, a, DT, (0.0, 0.0, 0.0), GateConfig(L=0.5, init_s=8.0), names=("gated",),
                         settings={"gated": {"tau_acc": tau_acc, "kp": 3.0}}, gyro_sample="interval")
    assert _rms_tilt(est["gated"], q, t > 30.0) < 1.0


@pytest.mark.parametrize("name", ["gated", "kf", "aekf"])
def test_bias_learned_at_rest(name):
    """A vertical gyro bias of 0.5 °/s that appears after the rest window (a warm-up step), then 40 s level at rest:
    the accelerometer cannot see a bias about the vertical, so only the rest detector (VQF's, in the low-pass modes)
    finds it: the bias estimate within 0.05 °/s of it with the rest update, still more than 0.4 °/s off without."""
    from imutherm.imu.filters import AEKFParams, GatedParams, KFParams, run_aekf
    from imutherm.imu.filters.gate import gate_thresholds
    from imutherm.imu.filters.gated import lp_state0, run_lp_core
    from imutherm.imu.filters.gravity_kf import kf_lp_state0, kf_params_from_rest, run_kf_lp_core

    n = int(60.0 / DT)
    t = np.arange(n) * DT
    rng = np.random.default_rng(1)
    g = rng.normal(0, 0.002, (n, 3))
    g[t > 10.0, 2] += math.radians(0.5)
    a = np.array([0.0, 0.0, -G0]) + rng.normal(0, 0.02, (n, 3))
    b0, q0 = g[:800].mean(axis=0), np.array([1.0, 0.0, 0.0, 0.0])
    err = {}
    for rest in (True, False):
        if name == "gated":
            p = GatedParams(gate_thresholds(3.7e-4, 0.1, (0.0, 0.0, 0.0), 0.5), kp=1.0, tau_acc=1.0, g=G0,
                            gyro_sample="interval", rest_bias=rest)
            S = lp_state0(q0, b0)
            run_lp_core(g, a, DT, p, S)
            bz = S[6]
        elif name == "kf":
            p = kf_params_from_rest(g, a, DT, 8.0, KFParams(tau_acc=1.0, n_window=1, gyro_sample="interval",
                                                            rest_bias=rest))
            S = kf_lp_state0(np.array([0.0, 0.0, 1.0]), p.p0, b0)
            run_kf_lp_core(g, a, DT, p, S)
            bz = S[6]
        else:
            _, tr = run_aekf(g, a, DT, AEKFParams(tau_acc=1.0, gyro_sample="interval", rest_bias=rest), init_s=8.0,
                             return_trace=True)
            bz = tr.bias[-1, 2]
        err[rest] = abs(math.degrees(bz) - 0.5)
    assert err[True] < 0.05 < 0.4 < err[False], err


def test_gyro_sample_conventions_integrate_their_own_samples():
    """Interval samples (the mean rate over the step ending at them) integrated as interval, and point samples (the
    rate at the instant) as point, hold a fast roll (30° at 2 Hz: 377 °/s peak at 100 Hz) within 0.1° RMS; read the
    other way, each is half a sample of rotation off (1.9° at the peak rate)."""
    from imutherm.imu.filters import GatedParams, run_gated

    t = np.arange(0.0, 20.0, DT)
    on = t > 9.0
    amp, f0 = math.radians(30.0), 2.0
    phi = np.where(on, amp * (1.0 - np.cos(2 * np.pi * f0 * (t - 9.0))), 0.0)  # rate starting from 0
    q = euler_to_quat(phi, 0.0 * t, 0.0 * t)
    point = np.column_stack([np.where(on, amp * 2 * np.pi * f0 * np.sin(2 * np.pi * f0 * (t - 9.0)), 0.0),
                             0 * t, 0 * t])
    interval = np.column_stack([np.r_[0.0, np.diff(phi)] / DT, 0 * t, 0 * t])  # exact mean over each step
    a = np.einsum("nji,j->ni", quat_to_dcm(q), np.array([0.0, 0.0, -G0]))
    err = {}
    for label, g in (("point", point), ("interval", interval)):
        for conv in ("point", "interval"):
            est = run_gated(g, a * 0 + [0, 0, -1.5 * G0], DT, GatedParams(None, kp=0.0, ki=0.0, gyro_sample=conv),
                            init_s=8.0)  # kp 0: the gyro alone
            err[label, conv] = _rms_tilt(est, q, on)
    assert err["interval", "interval"] < 0.1 and err["point", "point"] < 0.1, err
    assert err["interval", "point"] > 0.5 and err["point", "interval"] > 0.5, err


def test_cross_validation_splits_by_file():
    """Leave-one-file-out: every file is scored once by a fold whose training files exclude it and include every
    other file (both data sets)."""
    from imutherm.studies.attitude.real_tuning import folds

    files = ["02a/1", "02a/2", "B07", "B16", "B27"]
    fs = folds(files)
    assert [test for _, test in fs] == files
    for train, test in fs:
        assert test not in train and set(train) | {test} == set(files)


@pytest.mark.skipif(not BROAD27.exists(), reason="the shared BROAD development files are not here")
def test_real_settings_file_is_the_procedures_output():
    """The --platform handheld settings come from studies/attitude/real_settings.toml: every filter tuned on the real files
    (the registry's real_filters) has an entry, each with its grid, its dev and cross-validated scores on the nine
    files, no guard breach, and gated, kf, aekf meet the issue's target (cv mean <= 1.3x VQF's, every file <= 2x)."""
    from imutherm.imu.filters.registry import real_filters
    from imutherm.studies.attitude.real_settings import load_real_settings
    from imutherm.studies.attitude.recorded import platform_settings

    rs = load_real_settings()
    assert set(rs.values) == set(real_filters()) and len(rs.meta["files"]) == 9
    for n, e in rs.entries.items():
        assert len(e["cv_rms"]) == len(e["dev_rms"]) == 9 and e["guard_breaches"] == []
    for n in ("gated", "kf", "aekf"):
        assert rs.entries[n]["cv_x_vqf"] <= 1.3 and rs.entries[n]["cv_worst_x_vqf"] <= 2.0
    assert platform_settings("handheld", ("kf",))["kf"] == rs.values["kf"]
    assert platform_settings("vehicle", ("kf",)) == {}
