"""Gates on recorded-style data: a real part's bias, scale and noise at its own sample rate.

The record imitates a consumer MEMS IMU logged at 286 Hz (the rate of the public handheld recordings on
which the gates were found to stay shut): gyro bias 0.58 °/s on x (and -0.3 / 0.2 °/s on y / z), gyro
scale +0.5 %, gyro white noise 0.084 °/s rms (0.007 °/s/√Hz over 143 Hz, a BMI160-class density);
accelerometer scale +0.95 % so that it reads 9.90 m/s² at rest (those recordings read 9.89-9.91 m/s²),
white noise 0.021 m/s² rms (180 µg/√Hz over 143 Hz). Motion: 45 s rest, a 200 °/s, 80° turntable swing
(about 60 s of rejection), 45 s rest. Every gate must open at rest, and every filter must recover after the
swing, also when the gyro bias steps during the swing.
"""

from dataclasses import replace

import numpy as np
import pytest

from imutherm.imu import motion
from imutherm.imu.attitude_math import G0, gravity_dir_body
from imutherm.imu.filters import FusionParams, GatedParams, KFParams, run_fusion, run_gated, run_kf
from imutherm.imu.filters.fusion_peer import GYRO_FULL_SCALES_DPS, gyro_range_of_grade, looks_saturated, make_ahrs
from imutherm.studies.attitude.attitude_study import GateConfig, run_filters

RATE = 286.0
DT = 1.0 / RATE
D = (0.0, 0.03, 0.05)
GYRO_BIAS = np.radians([0.58, -0.3, 0.2])


def _record(seed=0, bias_step_dps=0.0, peak_rate_dps=200.0, duration=160.0, extra_rest_s=0.0):
    tr = motion.swing_profile(duration, RATE, settle_s=45.0, peak_rate_dps=peak_rate_dps, lever_arm=D)
    if extra_rest_s > 0:  # a longer final rest: hold the last (resting) sample
        n = int(round(extra_rest_s * RATE))
        t = np.concatenate([tr.t, tr.t[-1] + DT * np.arange(1, n + 1)])
        hold = lambda a: np.concatenate([a, np.repeat(a[-1:], n, axis=0)])  # noqa: E731
        tr = replace(tr, t=t, omega_b=hold(tr.omega_b), f_b=hold(tr.f_b), roll=hold(tr.roll),
                     pitch=hold(tr.pitch))
    rng = np.random.default_rng(seed)
    bias = np.tile(GYRO_BIAS, (tr.t.size, 1))
    bias[tr.t > 60.0, 1] += np.radians(bias_step_dps)  # a bias change during the long rejection
    gyro = 1.005 * tr.omega_b + bias + rng.normal(0, np.radians(0.084), tr.omega_b.shape)
    accel = 1.0095 * tr.f_b + rng.normal(0, 0.021, tr.f_b.shape)
    return tr, gyro, accel


@pytest.fixture(scope="module")
def rec():
    return _record()


def _deg_err(est, tr, mask):
    return np.degrees(max(np.max(np.abs(est.roll[mask] - tr.roll[mask])),
                          np.max(np.abs(est.pitch[mask] - tr.pitch[mask]))))


def test_record_looks_like_the_real_part(rec):
    tr, gyro, accel = rec
    rest = tr.t < 40
    assert 9.89 < np.mean(np.linalg.norm(accel[rest], axis=1)) < 9.91
    assert np.degrees(np.mean(gyro[rest, 0])) == pytest.approx(0.58, abs=0.01)


def test_every_gate_opens_at_rest(rec):
    tr, gyro, accel = rec
    est, th = run_filters(gyro, accel, DT, D, GateConfig(), names=("gated", "kf", "fusion"))
    rest = (tr.t > 10) & (tr.t < 44)  # after the 8 s leveling window, before the swing
    assert est["gated"].accel_used[rest].mean() > 0.99
    kf_windows = est["kf"].accel_used[rest].sum() * KFParams().n_window / rest.sum()
    assert kf_windows > 0.95
    assert est["fusion"].accel_used[rest].mean() > 0.99
    for e in est.values():
        # fusion: its Bias stage needs time to learn the 0.58 °/s (steady error ≈ bias / gain before it has)
        assert _deg_err(e, tr, rest & (tr.t > (25 if e.name == "fusion" else 0))) < 0.3, e.name
    # the defects the gates had: raw rate and nominal g keep Liu et al.'s gate shut at rest
    old = run_gated(gyro, accel, DT, GatedParams(th, g=G0), init_s=8.0, bias0=(0.0, 0.0, 0.0))
    assert old.accel_used[rest].mean() < 0.01


def test_gates_shut_during_swing_and_filters_recover(rec):
    tr, gyro, accel = rec
    est, _ = run_filters(gyro, accel, DT, D, GateConfig(), names=("gated", "kf", "ungated", "fusion"))
    swing = (tr.t > 55) & (tr.t < 105)
    assert est["gated"].accel_used[swing].mean() < 0.05
    end = tr.t > tr.t[-1] - 10
    for name in ("gated", "kf", "fusion"):
        assert est[name].accel_used[end].any(), name
        assert _deg_err(est[name], tr, end) < 0.5, name


def test_gated_recovers_after_a_bias_change_during_the_rejection():
    """A 0.8 °/s bias step during the swing leaves the bias-corrected rate above σω at rest: without the
    recovery path the gate stays shut for good (gyro-only, drifting); with it (recover_s = 30 s) the gate
    opens, the bias loop relearns the bias (slow pole of s² + kp s + ki: ~100 s), and after 300 s more
    rest the attitude is back within 0.5°."""
    tr, gyro, accel = _record(seed=1, bias_step_dps=0.8, extra_rest_s=300.0)
    end = tr.t > tr.t[-1] - 5
    stuck, th = run_filters(gyro, accel, DT, D, GateConfig(recover_s=float("inf")), names=("gated",))
    assert np.degrees(th.sigma_w) < 0.8
    rest_end = tr.t > tr.t[-1] - 40
    assert not stuck["gated"].accel_used[rest_end].any()
    assert _deg_err(stuck["gated"], tr, end) > 5.0
    rec_, _ = run_filters(gyro, accel, DT, D, GateConfig(), names=("gated", "kf"))
    assert rec_["gated"].accel_used[end].all()
    assert _deg_err(rec_["gated"], tr, end) < 0.5
    assert _deg_err(rec_["kf"], tr, end) < 0.5


def test_kf_relevels_after_a_stated_time_at_rest(rec):
    """KF started 35° off at rest: the innovation gate rejects every window; without the re-level it stays
    35° off (as it did on a real recording); with reject_timeout_s = 20 s it re-levels after 20 s of rest."""
    tr, gyro, accel = rec
    r0 = gravity_dir_body(np.array([np.cos(np.radians(17.5)), np.sin(np.radians(17.5)), 0.0, 0.0]))
    from imutherm.imu.filters.gravity_kf import kf_params_from_rest

    p = kf_params_from_rest(gyro, accel, DT, 8.0, KFParams())
    stuck = run_kf(gyro, accel, DT, KFParams(**{**p.__dict__, "reject_timeout_s": 1e9}), r0)
    rest = tr.t < 44
    assert not stuck.accel_used[rest].any() and np.degrees(abs(stuck.roll[rest][-1])) > 34.0
    relev = run_kf(gyro, accel, DT, p, r0)
    k_first = np.argmax(relev.accel_used)
    assert 19.5 < tr.t[k_first] < 21.5
    after = rest & (tr.t > 22)
    assert _deg_err(relev, tr, after) < 0.3


def _peak_rule(gyro) -> float:
    """The rule the fusion peer's range once came from [deg/s]: the smallest common full scale holding the
    record's largest |rate| (gyro (N,3) [rad/s]); kept here to show its failure."""
    m = float(np.degrees(np.max(np.abs(gyro))))
    return next(fs for fs in GYRO_FULL_SCALES_DPS if m <= fs)


def test_fusion_gyro_range_is_declared_not_the_datas_peak():
    """A 400 °/s swing of a sensor whose range is wider: with a 300 °/s range declared too small imufusion
    triggers its over-range re-initialisation; with the sensor's range (450 °/s) or none declared (the default:
    recovery off) it does not, and its error is smaller. The data's peak (here 450 °/s, the next common full
    scale) is no longer used: a record peaking just below a full scale got that scale and the recovery on every
    peak (a recorded log: 124 °/s -> 125 °/s, 1610 samples of over-range recovery)."""
    tr, gyro, accel = _record(peak_rate_dps=400.0)
    assert _peak_rule(gyro) == 450.0
    for rng_dps, expect in ((300.0, True), (450.0, False), (None, False), (0.0, False)):
        ahrs = make_ahrs(DT, FusionParams(gyroscope_range=rng_dps, use_bias=False))
        gd = np.degrees(gyro) * np.array([1.0, -1.0, -1.0])
        ag = accel * np.array([1.0, -1.0, -1.0]) / G0
        over = False
        for k in range(len(gd)):
            ahrs.update_no_magnetometer(gd[k], ag[k])
            over |= ahrs.get_flags().overrange_recovery
        assert over is expect, rng_dps
    swing = (tr.t > 10) & (tr.t < 150)
    dflt = run_fusion(gyro, accel, DT)
    assert np.array_equal(dflt.gravity, run_fusion(gyro, accel, DT, FusionParams(gyroscope_range=450.0)).gravity)
    err_300 = _deg_err(run_fusion(gyro, accel, DT, FusionParams(gyroscope_range=300.0)), tr, swing)
    assert _deg_err(dflt, tr, swing) < err_300, (_deg_err(dflt, tr, swing), err_300)  # 7.5° vs 11.1° (seed 0)
    # a record peaking at 123.5 °/s (as the recorded log's at 124 °/s): the old rule's 125 °/s range would have
    # triggered the recovery
    tr2, gyro2, accel2 = _record(peak_rate_dps=122.0, duration=110.0)
    assert _peak_rule(gyro2) == 125.0 and looks_saturated(gyro2) is None
    ahrs = make_ahrs(DT, FusionParams(gyroscope_range=125.0, use_bias=False))
    n_over = 0
    for g_, a_ in zip(np.degrees(gyro2) * np.array([1.0, -1.0, -1.0]), accel2 * np.array([1.0, -1.0, -1.0]) / G0):
        ahrs.update_no_magnetometer(g_, a_)
        n_over += ahrs.get_flags().overrange_recovery
    assert n_over > 100
    # clipped at a full scale: named
    assert looks_saturated(np.clip(gyro, -np.radians(300.0), np.radians(300.0))) == 300.0


def test_study_fusion_range_is_the_grades_full_scale(monkeypatch):
    """The attitude study gives the fusion peer its sensor grade's stated full scale (adis16355 +-300 °/s,
    adis16488 +-450 °/s, ideal: none), not the record's peak, and says so in attitude.json."""
    from imutherm.imu.filters import fusion_peer
    from imutherm.studies.attitude.attitude_study import run_attitude_study

    assert [gyro_range_of_grade(g) for g in ("adis16355", "adis16488", "ideal")] == pytest.approx([300, 450, 0])
    seen = []
    real = fusion_peer.make_ahrs
    monkeypatch.setattr(fusion_peer, "make_ahrs", lambda dt, p: seen.append(p.gyroscope_range) or real(dt, p))
    res = run_attitude_study("swing", duration=35.0, names=("fusion",))  # peaks at 200 °/s: the old rule, 250
    assert seen == [300.0]
    assert res.to_json()["fusion"]["gyroscope_range_dps"] == 300.0
