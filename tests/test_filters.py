"""Attitude filters: gate thresholds by hand, step/class/batch agreement, zero-noise exactness."""

import math

import numpy as np
import pytest

from imutherm import InputError
from imutherm.imu import motion
from imutherm.imu.attitude_math import gravity_dir_body
from imutherm.imu.filters import (ComplementaryFilter, FusionParams, FusionPeer, GatedParams, GatedStrapdown,
                                  GravityKF, KFParams, gate_noise_std, gate_thresholds, initial_quat, run_fusion,
                                  run_gated, run_kf, run_ungated)
from imutherm.imu.filters.common import initial_bias
from imutherm.imu.filters.gated import debounce

DT = 0.01


def _noisy(tr, seed=1, gyro_sd=0.01, accel_sd=0.03, bias=(0.002, -0.001, 0.0015)):
    rng = np.random.default_rng(seed)
    g = tr.omega_b + rng.normal(0, gyro_sd, tr.omega_b.shape) + np.asarray(bias)
    a = tr.f_b + rng.normal(0, accel_sd, tr.f_b.shape)
    return g, a


@pytest.fixture(scope="module")
def short_flight():
    return motion.flight_profile(60.0, 100.0, lever_arm=(0.3, 0.0, 0.05))


def test_gate_thresholds_hand_computation():
    xi_a, xi_w, d, L = 0.5, 0.2, (0.4, 0.1, 0.2), 500.0
    g = 9.80665
    dfx = math.sqrt(((xi_a + g) ** 2 - g**2) / 3)  # = sqrt((0.25 + 9.80665) / 3) = 1.830906
    assert dfx == pytest.approx(1.830906, rel=1e-6)
    dfz = xi_a / 3
    sa = math.sqrt(2 * dfx**2 + dfz**2)
    sw = math.sqrt(xi_w / L)  # 0.02
    dwy = xi_w / math.sqrt(3 * (0.4**2 + 0.2**2))
    th = gate_thresholds(xi_a, xi_w, d, L)
    assert th.sigma_a == pytest.approx(sa, rel=1e-12) and th.sigma_a == pytest.approx(2.594650, rel=1e-6)
    assert th.sigma_w == pytest.approx(0.02, rel=1e-12) and th.sigma_w == pytest.approx(sw)
    assert th.dwdot == pytest.approx((xi_w / math.sqrt(3 * 0.05), dwy, xi_w / math.sqrt(3 * 0.17)), rel=1e-12)
    assert th.sigma_wdot == pytest.approx(math.sqrt(3) * dwy, rel=1e-12)  # = xi_w / sqrt(dx^2 + dz^2)
    assert th.sigma_wdot == pytest.approx(0.2 / math.sqrt(0.2), rel=1e-12)
    wide = gate_thresholds(xi_a, xi_w, d, L, noise_std=(0.01, 0.002, 0.3))
    assert (wide.sigma_a, wide.sigma_w, wide.sigma_wdot) == pytest.approx((sa + 0.01, 0.022, th.sigma_wdot + 0.3))
    assert wide.theory == pytest.approx(th.theory)


@pytest.mark.parametrize("kw, match", [
    (dict(xi_a=-1.0), "xi_a=-1.0 is invalid; valid: a positive finite number"),
    (dict(L=0.0), "L=0.0 is invalid"),
    (dict(d=(1.0, 2.0)), "d=.* is invalid; valid: three finite lever-arm lengths"),
    (dict(noise_std=(0.1, -1, 0)), "noise_std"),
])
def test_gate_thresholds_bad_input(kw, match):
    args = dict(xi_a=0.1, xi_w=0.1, d=(0.1, 0.0, 0.0), L=100.0)
    args.update(kw)
    with pytest.raises(InputError, match=match):
        gate_thresholds(**args)


def test_debounce():
    ok = np.array([1, 1, 1, 0, 1, 1, 1, 1, 0, 1], bool)
    assert debounce(ok, 0).tolist() == ok.tolist()
    assert debounce(ok, 2).tolist() == [0, 0, 1, 0, 0, 0, 1, 1, 0, 0]


@pytest.mark.parametrize("hold_s", [0.0, 0.3])
def test_gated_class_step_and_batch_agree(short_flight, hold_s):
    g, a = _noisy(short_flight)
    noise = gate_noise_std(g[:300], a[:300], DT, 0.1)
    th = gate_thresholds(0.01, 0.1, (0.3, 0.0, 0.05), 1146.0, noise_std=noise)
    params = GatedParams(th, kp=0.5, ki=0.01, tau=0.1, hold_s=hold_s)
    q0, b0 = initial_quat(a, DT, 3.0), initial_bias(g, DT, 3.0)
    batch = run_gated(g, a, DT, params, q0, b0)
    assert 0.05 < batch.accel_used.mean() < 0.95  # the gate both opens and closes here
    f = GatedStrapdown(params, q0, b0)
    r = np.array([f.update(g[k], a[k], DT).gravity for k in range(len(g))])
    assert np.max(np.abs(r - batch.gravity)) < 1e-12
    f2 = GatedStrapdown(params, q0, b0)
    used = np.array([f2.update(g[k], a[k], DT).gate_open for k in range(len(g))])
    assert np.array_equal(used, batch.accel_used)


def test_ungated_class_and_batch_agree(short_flight):
    g, a = _noisy(short_flight, seed=2)
    params = GatedParams(None, kp=0.3, ki=0.003)
    q0 = initial_quat(a, DT, 3.0)
    batch = run_ungated(g, a, DT, params, q0, (0.0, 0.0, 0.0))
    f = ComplementaryFilter(params, q0)
    r = np.array([f.update(g[k], a[k], DT).gravity for k in range(len(g))])
    assert np.max(np.abs(r - batch.gravity)) < 1e-12 and batch.accel_used.all()


def test_kf_class_step_and_batch_agree(short_flight):
    g, a = _noisy(short_flight, seed=3)
    params = KFParams(n_window=7, a=0.2, innov_max=0.05, reject_timeout_s=2.0, kb=0.01)
    r0 = gravity_dir_body(initial_quat(a, DT, 3.0))
    b0 = initial_bias(g, DT, 3.0)
    batch = run_kf(g, a, DT, params, r0, b0)
    assert 0.05 < batch.accel_used.mean() * params.n_window < 0.95
    f = GravityKF(params, r0, b0)
    states = [f.update(g[k], a[k], DT) for k in range(len(g))]
    r = np.array([s.r for s in states])
    assert np.max(np.abs(r - batch.gravity)) < 1e-12
    assert np.array_equal(np.array([s.used for s in states]), batch.accel_used)


def test_fusion_class_and_batch_agree(short_flight):
    g, a = _noisy(short_flight, seed=4)
    p = FusionParams(use_bias=False, gyroscope_range=300.0)
    batch = run_fusion(g[:2000], a[:2000], DT, p)
    f = FusionPeer(DT, p)
    r = np.array([f.update(g[k], a[k]) for k in range(2000)])
    assert np.max(np.abs(r - batch.gravity)) < 1e-12


def test_fusion_class_step_and_batch_agree_with_default_bias_stage(short_flight):
    """Default FusionParams() (use_bias=True, as the study runs it): class, step and batch all apply imufusion.Bias."""
    import imufusion

    from imutherm.imu.filters import fusion_step
    from imutherm.imu.filters.fusion_peer import make_ahrs, make_bias

    g, a = _noisy(short_flight, seed=5, bias=(0.02, -0.015, 0.01))  # ~1 deg/s offsets for Bias to remove
    n = 2000
    p = FusionParams(gyroscope_range=300.0)
    assert p.use_bias
    batch = run_fusion(g[:n], a[:n], DT, p)
    f = FusionPeer(DT, p)
    assert isinstance(f.bias, imufusion.Bias)
    r = np.array([f.update(g[k], a[k]) for k in range(n)])
    assert np.max(np.abs(r - batch.gravity)) < 1e-12
    assert np.max(np.abs(f.gravity - batch.gravity[-1])) < 1e-12
    ahrs, bias = make_ahrs(DT, p), make_bias(DT, p)
    r2 = np.array([fusion_step(ahrs, g[k], a[k], bias) for k in range(n)])
    assert np.max(np.abs(r2 - batch.gravity)) < 1e-12
    # the Bias stage matters on this record, so the agreement above is not vacuous
    nob = run_fusion(g[:n], a[:n], DT, FusionParams(use_bias=False))
    assert np.max(np.abs(nob.gravity - batch.gravity)) > 1e-4
    assert np.max(np.abs(np.asarray(bias.get_offset()))) > 0.1  # [deg/s] offset learnt at rest


def test_static_zero_noise_gives_zero_error():
    from imutherm.imu.sensor_model import draw_unit, simulate_imu

    tr = motion.static_profile(30.0, 100.0, roll_deg=12.0, pitch_deg=-7.0, yaw_deg=40.0)
    unit = draw_unit("adis16355", np.random.default_rng(0), ideal=True)
    s = simulate_imu(unit, tr.t, tr.omega_b, tr.f_b, np.full((tr.t.size, 6), 25.0), None, noise=False)
    th = gate_thresholds(0.01, 0.1, (0.0, 0.0, 0.0), 1000.0)
    for est in (run_gated(s.gyro, s.accel, DT, GatedParams(th)), run_kf(s.gyro, s.accel, DT, KFParams()),
                run_ungated(s.gyro, s.accel, DT, GatedParams(th))):
        assert np.max(np.abs(est.roll - tr.roll)) < 1e-12, est.name
        assert np.max(np.abs(est.pitch - tr.pitch)) < 1e-12, est.name
    fus = run_fusion(s.gyro, s.accel, DT)  # single precision inside the library
    assert np.degrees(np.max(np.abs(fus.roll[500:] - tr.roll[500:]))) < 0.01
    assert np.degrees(np.max(np.abs(fus.pitch[500:] - tr.pitch[500:]))) < 0.01


def test_swing_ideal_tracking():
    tr = motion.swing_profile(40.0, 100.0)
    th = gate_thresholds(0.01, 0.1, (0.0, 0.0, 0.0), 1000.0)
    est = run_gated(tr.omega_b, tr.f_b, DT, GatedParams(th))
    assert np.degrees(np.max(np.abs(est.roll - tr.roll))) < 0.02  # trapezoidal rate, exact exponential
    assert not est.accel_used[(tr.t > 12) & (tr.t < 28)].any()  # 200 deg/s swing is gated out


def test_gate_rejects_coordinated_turn():
    tr = motion.flight_profile(400.0, 100.0, lever_arm=(0.3, 0.0, 0.05))
    noise = (0.005, 0.001, 0.05)
    th = gate_thresholds(3.7e-4, 0.1, (0.3, 0.0, 0.05), 1146.0, noise_std=noise)
    params = GatedParams(th)
    gated = run_gated(tr.omega_b, tr.f_b, DT, params)
    ungated = run_ungated(tr.omega_b, tr.f_b, DT, params)
    circle = (tr.segment == "circle-1")
    steady = circle & (tr.t > tr.t[circle][0] + 6) & (tr.t < tr.t[circle][-1] - 6)
    assert not gated.accel_used[steady].any()
    err_g = np.degrees(np.max(np.abs(gated.roll - tr.roll)))
    err_u = np.degrees(np.max(np.abs(ungated.roll - tr.roll)))
    assert err_g < 0.5 and err_u > 10.0


def test_kf_innovation_gate_and_recovery():
    tr = motion.static_profile(30.0, 100.0)
    r0 = gravity_dir_body(np.array([np.cos(0.1), np.sin(0.1), 0.0, 0.0]))  # 11.5 deg roll error
    stuck = run_kf(tr.omega_b, tr.f_b, DT, KFParams(innov_max=0.05, reject_timeout_s=1e9), r0, (0, 0, 0))
    assert not stuck.accel_used.any() and np.degrees(abs(stuck.roll[-1])) > 11.0
    rec = run_kf(tr.omega_b, tr.f_b, DT, KFParams(innov_max=0.05, reject_timeout_s=2.0), r0, (0, 0, 0))
    assert rec.accel_used.any() and np.degrees(abs(rec.roll[-1])) < 0.05


def test_filter_bad_input():
    with pytest.raises(InputError, match="gyro .* and accel .* are invalid; valid: two \\(N, 3\\) arrays"):
        run_kf(np.zeros((10, 3)), np.zeros((9, 3)), DT, KFParams())
    with pytest.raises(InputError, match="dt=-1"):
        run_gated(np.zeros((10, 3)), np.ones((10, 3)), -1, GatedParams(None))
    with pytest.raises(InputError, match="n_window"):
        KFParams(n_window=0)
    with pytest.raises(InputError, match="kp"):
        GatedParams(None, kp=-1.0)
