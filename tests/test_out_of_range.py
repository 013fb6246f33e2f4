"""Compensation beyond the calibrated range (error | hold | linear) and calibration with self-heating."""

import dataclasses as dc

import numpy as np
import pytest

from imutherm import InputError
from imutherm.imu.calibration import calibrate_unit
from imutherm.imu.compensation import compensate, out_of_range_mask
from imutherm.imu.sensor_model import G0, ImuSamples, draw_unit, load_grade, simulate_imu

QUIET = {"bias_instability": 0.0, "rate_random_walk": 0.0, "lsb": 0.0, "turn_on_bias": 0.0,
         "power_on_curve_fraction": 0.0, "noise_density": 0.0}


@pytest.fixture(scope="module")
def quiet_unit_cal():
    """A noise-free adis16355 unit (temperature curves, offsets and lags kept), calibrated without noise."""
    g = load_grade("adis16355")
    g = dc.replace(g, gyro=dc.replace(g.gyro, **QUIET), accel=dc.replace(g.accel, **QUIET), temp_sensor_lsb_C=0.0)
    unit = draw_unit(g, np.random.default_rng(3))
    cal = calibrate_unit(unit, np.random.default_rng(4), noise=False, dwell_s=0.2, settle_s=0.0, oven_mount_deg=0.0)
    return unit, cal


def _static(unit, T_die, n=50):
    t = np.arange(n) / 100.0
    f = np.tile(G0 * np.array([0.3, -0.5, 0.81]) / np.linalg.norm([0.3, -0.5, 0.81]), (n, 1))
    om = np.tile(np.radians([20.0, -10.0, 5.0]), (n, 1))
    raw = simulate_imu(unit, t, om, f, np.full((n, 6), T_die), None, noise=False)
    return raw, om, f


def test_error_policy_refuses_and_names_the_site(quiet_unit_cal):
    unit, cal = quiet_unit_cal
    raw, _, _ = _static(unit, 75.0)
    with pytest.raises(InputError, match=r"outside the calibrated range.*out_of_range='hold' or 'linear'"):
        compensate(raw, cal, "improved")
    with pytest.raises(InputError, match="out_of_range: 'clip' is not valid; valid: error, hold, linear"):
        compensate(raw, cal, "improved", out_of_range="clip")


def test_mask_flags_exactly_the_samples_beyond_each_sites_range(quiet_unit_cal):
    unit, cal = quiet_unit_cal
    lo, hi = cal.site_range_C()
    temp = np.tile((lo + hi) / 2, (4, 1))
    temp[1, 2] = hi[2] + 0.01
    temp[3, 5] = lo[5] - 0.01
    m = out_of_range_mask(temp, cal)
    assert m.sum() == 2 and m[1, 2] and m[3, 5]


def test_hold_is_the_compensation_at_the_range_end(quiet_unit_cal):
    unit, cal = quiet_unit_cal
    raw, _, _ = _static(unit, 80.0)
    _, hi = cal.site_range_C()
    at_edge = dc.replace(raw, temp_C=np.tile(hi, (raw.t.size, 1)))
    for method in ("conventional", "improved"):
        held = compensate(raw, cal, method, out_of_range="hold")
        ref = compensate(at_edge, cal, method)
        np.testing.assert_allclose(held.accel, ref.accel, rtol=0, atol=1e-12)
        np.testing.assert_allclose(held.gyro, ref.gyro, rtol=0, atol=1e-14)


def test_linear_is_continuous_at_the_edge_and_beats_no_compensation_beyond_it(quiet_unit_cal):
    unit, cal = quiet_unit_cal
    lo, hi = cal.site_range_C()
    off = unit.temp_offset_C
    # the die temperature at which every site reports just inside / just outside its range
    inside, _, _ = _static(unit, float(np.min(hi - off)) - 1e-6)
    raw_in = dc.replace(inside, temp_C=np.tile(hi - 1e-6, (inside.t.size, 1)))
    raw_out = dc.replace(inside, temp_C=np.tile(hi + 1e-6, (inside.t.size, 1)))
    a = compensate(raw_in, cal, "improved", interp="linear")
    b = compensate(raw_out, cal, "improved", interp="linear", out_of_range="linear")
    np.testing.assert_allclose(a.accel, b.accel, atol=1e-6)  # continuous across the edge
    # 6 K beyond: linear extrapolation of the calibration's trend leaves less than no compensation
    raw, om, f = _static(unit, 76.0)
    err = {m: np.abs(compensate(raw, cal, m, out_of_range="linear").accel - f).max() / G0 * 1e3
           for m in ("none", "improved")}
    assert np.isfinite(err["improved"]) and err["improved"] < err["none"]


def test_self_heating_shifts_each_sites_calibrated_range():
    unit = draw_unit("ideal", np.random.default_rng(0))
    rise = np.array([3.0, 4.0, 5.0, 6.0, 7.0, 8.0])
    cal_u = calibrate_unit(unit, np.random.default_rng(1), noise=False, dwell_s=0.2, settle_s=0.0,
                           self_heating=lambda Tc: rise * (1.0 + 0.002 * (70.0 - Tc)))
    cal_b = calibrate_unit(unit, np.random.default_rng(1), noise=False, dwell_s=0.2, settle_s=0.0)
    edges = np.linspace(-40.0, 70.0, 23)
    np.testing.assert_allclose(cal_b.site_edges(), np.repeat(edges[:, None], 6, 1), atol=1e-9)
    # ideal sensors report the die temperature: edges = chamber + rise(chamber), rise linear in the chamber
    want = edges[:, None] + rise[None, :] * (1.0 + 0.002 * (70.0 - edges[:, None]))
    np.testing.assert_allclose(cal_u.site_edges(), want, atol=1e-9)
    # in use at a 70 C ambient the dies sit at 70 + rise: inside the unit calibration, beyond the bare one
    temp = np.tile(70.0 + rise - 1e-6, (3, 1))
    assert not out_of_range_mask(temp, cal_u).any()
    assert out_of_range_mask(temp, cal_b).all()
    with pytest.raises(InputError, match="self_heating"):
        calibrate_unit(unit, np.random.default_rng(1), noise=False, dwell_s=0.2, settle_s=0.0,
                       self_heating=lambda Tc: np.ones(5))
