"""Simulated calibration rig, conventional / improved fits, compensation and ``imutherm calibrate``."""

import dataclasses as dc
import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from imutherm import InputError
from imutherm.imu.calibration import (
    Calibration, accel_positions_18, calibrate_unit, evaluate_calibration,
)
from imutherm.imu.compensation import compensate
from imutherm.imu.sensor_model import G0, ImuSamples, draw_unit, load_grade, simulate_imu

QUIET = {"bias_instability": 0.0, "rate_random_walk": 0.0, "lsb": 0.0, "turn_on_bias": 0.0,
         "power_on_curve_fraction": 0.0}


def _linear_unit(seed=0, quiet=True):
    """An adis16355 unit whose model is exactly N = K(T) E + D(T): Lin et al.'s terms and Wang et al.'s roll coupling off;
    optionally white noise only."""
    g = load_grade("adis16355")
    if quiet:
        g = dc.replace(g, gyro=dc.replace(g.gyro, **QUIET), accel=dc.replace(g.accel, **QUIET), temp_sensor_lsb_C=0.0)
    u = draw_unit(g, np.random.default_rng(seed))
    z3 = np.zeros(3)
    z33 = np.zeros((3, 3))
    return dc.replace(u, accel=dc.replace(u.accel, asym=z3, k2=z3, dM_dT=z33),
                      gyro=dc.replace(u.gyro, g_sens=z33, dM_dT=z33, roll_coupling=np.zeros((3, 2))))


def _true_K(triad, T):
    return (1.0 + triad.sf0 + triad.sf_T(np.full(3, T)))[:, None] * triad.M0


@pytest.fixture(scope="module")
def ideal_cal():
    unit = draw_unit("ideal", np.random.default_rng(0))
    # a perfect rig too (no second-mounting error): then both fitted models are the identity
    return unit, calibrate_unit(unit, np.random.default_rng(1), noise=False, dwell_s=0.2, settle_s=0.0,
                                oven_mount_deg=0.0, table_mount_deg=0.0)


def test_room_fit_recovers_K_and_bias_within_noise():
    """White noise only: each position/rate mean has std sigma/sqrt(m) (sigma = density*sqrt(fs), m samples per
    dwell); least squares over the design A = [E, 1] gives cov = sigma^2/m (A^T A)^-1. Every element of K and D
    must lie within 5 standard deviations of the truth (K0 R_table at 25 °C, bias0)."""
    unit = _linear_unit(seed=3)
    dwell, fs = 1.0, unit.grade.sample_rate_hz
    cal = calibrate_unit(unit, np.random.default_rng(4), dwell_s=dwell, settle_s=0.0)
    m = dwell * fs
    R_table = Rotation.from_rotvec(np.radians(cal.meta.table_mount_rotvec_deg)).as_matrix()
    from imutherm.imu.calibration import _gyro_runs

    designs = {"accel": G0 * accel_positions_18(),
               "gyro": _gyro_runs(cal.meta.rig.room_rates_dps)[0]}
    for name, E in designs.items():
        spec, truth, fit = getattr(unit.grade, name), getattr(unit, name), getattr(cal, name)
        A = np.hstack([E, np.ones((len(E), 1))])
        sd = np.sqrt(np.diag(np.linalg.inv(A.T @ A))) * spec.noise_density * np.sqrt(fs) / np.sqrt(m)
        # the fit sees the table input only: the fixture's (unknown) misalignment is absorbed in K_room
        err_K = fit.K_room - truth.K0() @ R_table
        err_D = fit.D_room - truth.bias0
        assert np.all(np.abs(err_K) < 5 * sd[None, :3]), (name, err_K / sd[None, :3])
        assert np.all(np.abs(err_D) < 5 * sd[3]), (name, err_D / sd[3])
        # and the noise really is resolved: errors are not all far below the predicted std
        assert np.abs(err_K / sd[None, :3]).max() > 0.2


def test_noise_free_conventional_absorbs_oven_mounting_improved_cancels_it():
    """The mechanism of Liu et al. 2012: the conventional K of every segment equals K(T) R_oven (R_oven the unknown
    second mounting), while the improved sigma is fitted on N(T) - N(25 °C) in the same mounting."""
    unit = _linear_unit(seed=5, quiet=False)
    cal = calibrate_unit(unit, np.random.default_rng(6), noise=False, dwell_s=0.2, settle_s=0.0, oven_mount_deg=1.0,
                         table_mount_deg=0.0)  # a perfect step-1 fixture: the fits do not know it
    R = Rotation.from_rotvec(np.radians(cal.meta.oven_mount_rotvec_deg)).as_matrix()
    assert np.degrees(np.linalg.norm(Rotation.from_matrix(R).as_rotvec())) == pytest.approx(1.0)
    centres = 0.5 * (cal.segment_edges_C[:-1] + cal.segment_edges_C[1:])
    for k in (0, 9, 21):
        Tk = centres[k]
        np.testing.assert_allclose(cal.accel.K_conv[k], _true_K(unit.accel, Tk) @ R, atol=1e-9)
        np.testing.assert_allclose(cal.accel.D_conv[k], unit.accel.bias0 + unit.accel.bias_T(np.full(3, Tk)), atol=1e-9)
        np.testing.assert_allclose(cal.gyro.K_conv[k], _true_K(unit.gyro, Tk) @ R, atol=1e-9)
    np.testing.assert_allclose(cal.accel.K_room, unit.accel.K0(), atol=1e-12)
    # at a segment node, improved compensation is exact; conventional is off by about g*theta
    Tk = centres[9]
    f = G0 * np.array([[0.6, 0.0, 0.8], [0.0, -1.0, 0.0], [0.48, 0.6, -0.64]])
    n = len(f)
    s = simulate_imu(unit, np.arange(n) / 100.0, np.zeros((n, 3)), f, np.full((n, 6), Tk), None, noise=False)
    np.testing.assert_allclose(compensate(s, cal, "improved").accel, f, atol=1e-9)
    err_conv = np.abs(compensate(s, cal, "conventional").accel - f).max()
    assert 0.2 * G0 * np.radians(1.0) < err_conv < 1.2 * G0 * np.radians(1.0)


def test_thermal_misalignment_is_what_the_improved_model_cannot_follow():
    """With a temperature-dependent misalignment dM/dT in the truth, the conventional per-segment K
    follows it (exact at a node without mounting errors) while the improved per-axis sigma(N) cannot: at a
    segment node its worst error is the cross-axis term (T - 25) dM f (±30 %)."""
    unit = _linear_unit(seed=5, quiet=False)
    dM = np.radians(2e-3) * np.array([[0.0, 1.0, -1.0], [1.0, 0.0, 1.0], [-1.0, 1.0, 0.0]])  # [1/K]
    unit = dc.replace(unit, accel=dc.replace(unit.accel, dM_dT=dM))
    cal = calibrate_unit(unit, np.random.default_rng(6), noise=False, dwell_s=0.2, settle_s=0.0, oven_mount_deg=0.0,
                         table_mount_deg=0.0)
    centres = 0.5 * (cal.segment_edges_C[:-1] + cal.segment_edges_C[1:])
    Tk = centres[0]  # -37.5 °C
    f = G0 * np.array([[0.6, 0.0, 0.8], [0.0, -1.0, 0.0], [0.48, 0.6, -0.64]])
    n = len(f)
    s = simulate_imu(unit, np.arange(n) / 100.0, np.zeros((n, 3)), f, np.full((n, 6), Tk), None, noise=False)
    np.testing.assert_allclose(compensate(s, cal, "conventional").accel, f, atol=1e-9)
    err = compensate(s, cal, "improved").accel - f
    expect = (Tk - 25.0) * f @ dM.T  # cross-axis change the per-axis sigma(N) does not model
    assert np.abs(expect).max() > 1e-3 * G0  # > 1 mg: a real test
    # sigma(N) is a per-axis quadratic fitted over the 18 positions, so it absorbs part of the cross-axis term
    # at some positions; the worst case remains the full term
    assert 0.7 < np.abs(err).max() / np.abs(expect).max() < 1.3


def _room_only(s, cal):
    """Compensation with the room-temperature calibration alone (sigma = 0): E = K_room^-1 (N - D_room)."""
    return (np.linalg.solve(cal.gyro.K_room, (s.gyro - cal.gyro.D_room).T).T,
            np.linalg.solve(cal.accel.K_room, (s.accel - cal.accel.D_room).T).T)


def test_improved_sigma_is_zero_at_room_temperature_and_continuous_across_it():
    """Liu et al. 2012 eq. 2-3: sigma is relative to the 25 °C calibration, so at 25 °C the improved model is the room
    fit. 25 °C is a segment edge (fitted nodes 22.5 / 27.5 °C): without the sigma = 0 room node the segment lookup
    applied the 27.5 °C sigma there (~1-3 mg on a noise-free unit)."""
    unit = _linear_unit(seed=7, quiet=False)  # exactly N = K(T) E + D(T): the room fit is exact
    unit = dc.replace(unit, temp_offset_C=np.zeros(6))  # reported temperature = die temperature
    cal = calibrate_unit(unit, np.random.default_rng(8), noise=False, dwell_s=0.2, settle_s=0.0,
                         table_mount_deg=0.0)  # a perfect step-1 fixture (the fits do not know its misalignment)
    np.testing.assert_allclose(cal.room_temp_C, 25.0, rtol=0, atol=1e-9)  # mean of equal readings
    f = G0 * np.array([[0.6, 0.0, 0.8], [0.0, -1.0, 0.0], [0.48, 0.6, -0.64], [0.0, 0.0, 1.0]])
    w = np.radians([[10.0, 0.0, 0.0], [0.0, -50.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 200.0]])
    n = len(f)

    def residual_mg(T, interp):
        s = simulate_imu(unit, np.arange(n) / 100.0, w, f, np.full((n, 6), T), None, noise=False)
        c = compensate(s, cal, "improved", interp=interp)
        return s, c, (c.accel - f) / G0 * 1e3

    # the old lookup at 25 °C: the segment [25, 30) sigma, fitted at 27.5 °C, is far from zero there
    k = int(np.searchsorted(cal.segment_edges_C, 25.0, side="right") - 1)
    s25 = simulate_imu(unit, np.arange(n) / 100.0, w, f, np.full((n, 6), 25.0), None, noise=False)
    a, b, c0 = (cal.accel.sigma[k, :, j] for j in range(3))
    assert np.abs(a * s25.accel**2 + b * s25.accel + c0).max() / G0 * 1e3 > 0.5
    for interp in ("segment", "linear"):
        s, c, r = residual_mg(25.0, interp)
        g_room, a_room = _room_only(s, cal)
        np.testing.assert_allclose(c.accel, a_room, rtol=0, atol=1e-12)  # = the room fit's compensation
        np.testing.assert_allclose(c.gyro, g_room, rtol=0, atol=1e-12)
        assert np.abs(r).max() < 1e-6  # and the room fit's residual is ~0 on this unit [mg]
    # linear mode interpolates through the sigma = 0 node: continuous across 25 °C
    Ts = 25.0 + np.array([-0.5, -0.1, -0.01, -0.001, 0.0, 0.001, 0.01, 0.1, 0.5])
    res = np.array([residual_mg(T, "linear")[2] for T in Ts])  # (9, n, 3) [mg]
    jump = np.abs(np.diff(res, axis=0)).max(axis=(1, 2))
    assert np.all(jump <= 2.0 * np.abs(np.diff(Ts)) + 1e-9)  # Lipschitz, < 2 mg/°C: no step at 25 °C
    assert np.abs(res).max() < 1.0  # sigma interpolated between 0 at 25 °C and the fitted 22.5 / 27.5 °C nodes
    # with the unit's own temperature-sensor offsets the node sits at each site's reported room temperature
    unit_off = _linear_unit(seed=7, quiet=False)
    cal_off = calibrate_unit(unit_off, np.random.default_rng(8), noise=False, dwell_s=0.2, settle_s=0.0)
    np.testing.assert_allclose(cal_off.room_temp_C, 25.0 + unit_off.temp_offset_C, atol=1e-12)
    s = simulate_imu(unit_off, np.arange(n) / 100.0, w, f, np.full((n, 6), 25.0), None, noise=False)
    for interp in ("segment", "linear"):
        c = compensate(s, cal_off, "improved", interp=interp)
        np.testing.assert_allclose(c.accel, _room_only(s, cal_off)[1], rtol=0, atol=1e-12)


def test_ideal_unit_calibration_is_identity_and_compensation_exact(ideal_cal):
    unit, cal = ideal_cal
    for c in (cal.accel, cal.gyro):
        np.testing.assert_allclose(c.K_room, np.eye(3), atol=1e-12)
        np.testing.assert_allclose(c.sigma, 0.0, atol=1e-12)
    n = 50
    t = np.arange(n) / 100.0
    w = np.tile([0.1, -0.2, 0.3], (n, 1))
    f = np.tile([1.0, 2.0, 9.0], (n, 1))
    s = simulate_imu(unit, t, w, f, np.full((n, 6), 12.3), None, noise=False)
    for meth in ("none", "conventional", "improved"):
        c = compensate(s, cal, meth)
        np.testing.assert_allclose(c.gyro, w, atol=1e-12)
        np.testing.assert_allclose(c.accel, f, atol=1e-12)


def test_mounting_error_is_what_separates_the_methods():
    """Without the second-mounting error the two methods are about equal; with it the conventional degrades."""
    unit = draw_unit("adis16355", np.random.default_rng(0))
    res = {}
    for deg in (0.0, 1.0):
        cal = calibrate_unit(unit, np.random.default_rng(1), oven_mount_deg=deg, dwell_s=1.0)
        ev = evaluate_calibration(unit, cal, np.random.default_rng(2), n_temps=6, n_static=6, n_rates=3, dwell_s=1.0)
        res[deg] = ev.accel_max_residual_mg
    assert res[0.0]["conventional"] < 1.5 * res[0.0]["improved"]
    assert res[1.0]["conventional"] > res[0.0]["conventional"] + 8.0  # about g*1° = 17.5 mg cross-axis
    assert res[1.0]["improved"] == pytest.approx(res[0.0]["improved"], rel=0.3)


def test_compensation_rejects_temperature_outside_range(ideal_cal):
    unit, cal = ideal_cal
    n = 4
    temp = np.full((n, 6), 20.0)
    temp[2, 4] = 70.5
    s = ImuSamples(t=np.arange(n) / 100.0, gyro=np.zeros((n, 3)), accel=np.zeros((n, 3)), temp_C=temp)
    with pytest.raises(InputError, match=r"temp_C\[2, 4\] \(accel_y\): reported temperature 70.50 °C is outside "
                                         r"the calibrated range; valid: -40\.\.70 °C"):
        compensate(s, cal, "improved")
    temp[2, 4] = -41.0
    with pytest.raises(InputError, match="outside the calibrated range"):
        compensate(dc.replace(s, temp_C=temp), cal, "conventional")
    assert compensate(dc.replace(s, temp_C=temp), cal, "none") is not None  # no range check without a model


def test_compensation_bad_method_shapes_and_missing_calibration(ideal_cal):
    _, cal = ideal_cal
    n = 3
    s = ImuSamples(t=np.arange(n) / 100.0, gyro=np.zeros((n, 3)), accel=np.zeros((n, 3)), temp_C=np.zeros((n, 6)))
    with pytest.raises(InputError, match=r"'kalman' is not valid; valid: none, conventional, improved"):
        compensate(s, cal, "kalman")
    with pytest.raises(InputError, match=r"calibration: required for method 'improved'"):
        compensate(s, None, "improved")
    with pytest.raises(InputError, match=r"samples.accel: shape \(3, 2\) is invalid; expected \(3, 3\)"):
        compensate(dc.replace(s, accel=np.zeros((n, 2))), cal, "improved")
    with pytest.raises(InputError, match=r"samples.temp_C: shape \(2, 6\) is invalid; expected \(3, 6\)"):
        compensate(dc.replace(s, temp_C=np.zeros((2, 6))), cal, "conventional")
    with pytest.raises(InputError, match="interp"):
        compensate(s, cal, "improved", interp="cubic")


def test_rig_config_validation():
    unit = draw_unit("ideal", np.random.default_rng(0))
    with pytest.raises(InputError, match="rig.settle_s"):
        calibrate_unit(unit, np.random.default_rng(0), dwell_s=1.0, settle_s=2.0)
    with pytest.raises(InputError, match="valid rig fields"):
        calibrate_unit(unit, np.random.default_rng(0), oven_angle=1.0)


def test_calibration_json_round_trip(tmp_path, ideal_cal):
    unit = _linear_unit(seed=7, quiet=False)
    cal = calibrate_unit(unit, np.random.default_rng(8), dwell_s=0.3, settle_s=0.0)
    path = tmp_path / "cal.json"
    cal.save_json(path)
    back = Calibration.load_json(path)
    n = 20
    s = simulate_imu(unit, np.arange(n) / 100.0, np.full((n, 3), 0.2), np.tile([0, 0, G0], (n, 1)),
                     np.full((n, 6), -12.0), np.random.default_rng(9))
    for meth in ("conventional", "improved"):
        for interp in ("segment", "linear"):
            np.testing.assert_array_equal(compensate(s, cal, meth, interp=interp).accel,
                                          compensate(s, back, meth, interp=interp).accel)
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"grade": "adis16355"}))
    with pytest.raises(InputError, match="missing field 'segment_edges_C'"):
        Calibration.load_json(bad)
    # the record of how it was made survives the round trip as a dataclass (rig settings, drawn mountings)
    assert back.meta == cal.meta and back.meta.rig.dwell_s == 0.3 and len(back.meta.oven_mount_rotvec_deg) == 3
    with pytest.raises(TypeError, match="use meta.rig"):
        cal.meta["rig"]
    d = cal.to_dict()
    d["meta"]["oven_mount_deg"] = 1.0
    with pytest.raises(InputError, match="meta: unknown field.*oven_mount_deg"):
        Calibration.from_dict(d)
    d = cal.to_dict()
    d["meta"]["rig"]["dwell_s"] = -1.0
    with pytest.raises(InputError, match="rig.dwell_s"):
        Calibration.from_dict(d)
    d = cal.to_dict()
    del d["meta"]
    assert Calibration.from_dict(d).meta is None


def test_cli_calibrate_writes_json_and_plot_and_reproduces_pattern(tmp_path):
    """In-process CLI on a fixed seed: required keys, the plot, and improved beats conventional by >= 3x."""
    from imutherm.cli import main

    out = tmp_path / "cal"
    assert main(["calibrate", "--grade", "adis16355", "--seed", "0", "--out", str(out)]) == 0
    d = json.loads((out / "calibration.json").read_text())
    for key in ("accel_max_residual_mg", "gyro_max_residual_dps"):
        assert set(d[key]) == {"uncompensated", "conventional", "improved"}
        assert all(np.isfinite(v) and v > 0 for v in d[key].values())
    assert d["grade"] == "adis16355" and d["seed"] == 0
    assert len(d["segments"]) == 22 and d["segments"][0]["range_C"] == [-40.0, -35.0]
    assert (out / "calibration_residuals.png").stat().st_size > 10_000
    a = d["accel_max_residual_mg"]
    assert a["conventional"] / a["improved"] >= 3.0
    assert a["uncompensated"] > 20.0 and a["improved"] < 10.0
    assert d["gyro_max_residual_dps"]["improved"] < d["gyro_max_residual_dps"]["uncompensated"]
    cal = Calibration.load_json(out / "calibration.json")
    assert cal.grade == "adis16355" and cal.segment_nodes_C.shape == (22, 6)


def test_cli_bad_grade_exit_2_and_nothing_written(tmp_path, capsys):
    from imutherm.cli import main

    out = tmp_path / "never"
    assert main(["calibrate", "--grade", "mpu9999", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "unknown grade 'mpu9999'" in err and "adis16355" in err
    assert not out.exists()
