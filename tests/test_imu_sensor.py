"""Truth model of the IMU sensors: grades, ideal unit, noise, temperature-sensor lag, input checks."""

import dataclasses as dc

import math

import numpy as np
import pytest

from imutherm import InputError
from imutherm.imu.sensor_model import (
    G0, GM_ADEV_PEAK, SITES, ImuSamples, draw_unit, load_grade, simulate_imu, temperature_sensor_lag, unit_from_dict,
    unit_to_dict,
)


def _static(n=200, T=25.0, fs=100.0, f=(0.0, 0.0, G0), w=(0.0, 0.0, 0.0)):
    t = np.arange(n) / fs
    return t, np.tile(w, (n, 1)), np.tile(f, (n, 1)), np.full((n, 6), T)


def test_contract_constants():
    assert SITES == ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
    assert G0 == 9.80665


def test_unknown_grade_lists_valid_ones():
    with pytest.raises(InputError, match=r"unknown grade 'adis9999'.*valid grades: adis16355, adis16488, ideal"):
        load_grade("adis9999")
    with pytest.raises(InputError, match="valid grades"):
        draw_unit("nope", np.random.default_rng(0))


def test_grades_in_si():
    g = load_grade("adis16355")
    # the horizontal-attitude KF paper: gyro noise 0.6 deg/s and accel noise 3.5 mg, read as rms at 100 Hz
    assert g.gyro.noise_density * np.sqrt(100.0) == pytest.approx(np.radians(0.6))
    assert g.accel.noise_density * np.sqrt(100.0) == pytest.approx(3.5e-3 * G0)
    assert g.gyro.bias_instability == pytest.approx(np.radians(0.015))
    assert g.accel.bias_instability == pytest.approx(0.7e-3 * G0)
    assert load_grade("adis16488").accel.bias_instability < g.accel.bias_instability


@pytest.mark.parametrize("ideal_kw", [{"grade": "ideal"}, {"grade": "adis16355", "ideal": True}])
def test_ideal_unit_noise_free_returns_truth_exactly(ideal_kw):
    rng = np.random.default_rng(3)
    grade = ideal_kw.pop("grade")
    unit = draw_unit(grade, rng, **ideal_kw)
    n = 500
    t = np.arange(n) / 100.0
    omega = np.column_stack([np.sin(t), 0.3 * np.cos(2 * t), -0.7 * np.ones(n)])
    f = np.column_stack([0.5 * np.ones(n), -2.0 * np.sin(t), G0 * np.cos(0.1 * t)])
    temp = np.column_stack([np.linspace(-40, 70, n)] * 6) + np.arange(6)
    s = simulate_imu(unit, t, omega, f, temp, rng, noise=False)
    assert isinstance(s, ImuSamples)
    np.testing.assert_array_equal(s.gyro, omega)
    np.testing.assert_array_equal(s.accel, f)
    np.testing.assert_array_equal(s.temp_C, temp)  # no lag, no offset
    np.testing.assert_array_equal(s.t, t)


def test_ideal_grade_with_noise_flag_is_still_exact():
    rng = np.random.default_rng(4)
    unit = draw_unit("ideal", rng)
    t, w, f, T = _static()
    s = simulate_imu(unit, t, w + 0.1, f, T, rng, noise=True)
    np.testing.assert_array_equal(s.gyro, w + 0.1)
    np.testing.assert_array_equal(s.accel, f)


def test_noise_false_is_deterministic_and_reproducible_from_seed():
    unit = draw_unit("adis16355", np.random.default_rng(11))
    t, w, f, T = _static(T=-10.0)
    a = simulate_imu(unit, t, w, f, T, np.random.default_rng(1), noise=False)
    b = simulate_imu(unit, t, w, f, T, None, noise=False)
    np.testing.assert_array_equal(a.accel, b.accel)
    np.testing.assert_array_equal(a.gyro, b.gyro)
    # noisy runs: same seed -> same samples, different seed -> different samples
    c = simulate_imu(unit, t, w, f, T, np.random.default_rng(5))
    d = simulate_imu(unit, t, w, f, T, np.random.default_rng(5))
    e = simulate_imu(unit, t, w, f, T, np.random.default_rng(6))
    np.testing.assert_array_equal(c.accel, d.accel)
    assert not np.array_equal(c.accel, e.accel)
    u2 = draw_unit("adis16355", np.random.default_rng(11))
    np.testing.assert_array_equal(u2.accel.bias_curve, unit.accel.bias_curve)


def test_temperature_curves_zero_at_room_and_scaled_to_grade():
    g = load_grade("adis16355")
    Tg = np.stack([np.linspace(-40, 70, 221)] * 3, -1)
    for seed in range(5):
        u = draw_unit(g, np.random.default_rng(seed))
        np.testing.assert_allclose(u.accel.bias_T(np.full(3, 25.0)), 0.0, atol=1e-15)
        peak = np.abs(u.accel.bias_T(Tg)).max(axis=0)
        amp = g.accel.bias_temp_amplitude
        assert np.all(peak >= 0.5 * amp * 0.999) and np.all(peak <= 1.5 * amp * 1.001)
        # strongly nonlinear: a straight line through the end points misses by a sizeable fraction
        b = u.accel.bias_T(Tg)
        line = b[0] + (b[-1] - b[0]) * (Tg - Tg[0]) / (Tg[-1] - Tg[0])
        assert np.abs(b - line).max() > 0.1 * amp


def test_uncompensated_accel_excursion_is_tens_of_mg():
    g = load_grade("adis16355")
    Tg = np.stack([np.linspace(-40, 70, 221)] * 3, -1)
    ex = [np.ptp(draw_unit(g, np.random.default_rng(s)).accel.bias_T(Tg), axis=0).max() / G0 * 1e3
          for s in range(10)]
    assert 10.0 < np.median(ex) < 100.0


def test_white_noise_level_matches_density():
    """Only white noise on: sample std = density*sqrt(fs); with n = 20000 samples the relative
    standard error of a std estimate is 1/sqrt(2n) = 0.5 %, so 3 % is a > 5-sigma tolerance."""
    g = load_grade("adis16355")
    quiet = {"bias_instability": 0.0, "rate_random_walk": 0.0, "lsb": 0.0, "turn_on_bias": 0.0,
             "power_on_curve_fraction": 0.0}
    g2 = dc.replace(g, gyro=dc.replace(g.gyro, **quiet), accel=dc.replace(g.accel, **quiet), temp_sensor_lsb_C=0.0)
    unit = draw_unit(g2, np.random.default_rng(2), ideal=True)
    t, w, f, T = _static(n=20000)
    s = simulate_imu(unit, t, w, f, T, np.random.default_rng(8))
    np.testing.assert_allclose(s.gyro.std(axis=0), g.gyro.noise_density * 10.0, rtol=0.03)
    np.testing.assert_allclose(s.accel.std(axis=0), g.accel.noise_density * 10.0, rtol=0.03)


def test_gm_adev_peak_constant():
    """Peak of the first-order Gauss-Markov Allan deviation (IEEE Std 952 Annex C / El-Sheimy et al. 2008):
    AVAR(T) = (q Tc^2/T)[1 - Tc/(2T)(3 - 4 e^-T/Tc + e^-2T/Tc)], q = 2 sigma^2/Tc; sigma = Tc = 1."""
    T = np.linspace(0.5, 5.0, 450001)
    avar = (2.0 / T) * (1.0 - (3.0 - 4.0 * np.exp(-T) + np.exp(-2.0 * T)) / (2.0 * T))
    assert np.sqrt(avar.max()) == pytest.approx(GM_ADEV_PEAK, abs=5e-5)
    assert T[avar.argmax()] == pytest.approx(1.893, abs=2e-3)


def test_bias_instability_is_the_allan_deviation_floor():
    """Only the Gauss-Markov bias on (accel B = 0.7 mg, Tc = 100 s), sampled at 1 Hz: the Allan deviation at its
    peak tau = 1.89 Tc must equal the grade's bias instability B (the GM sigma is B / 0.6174 = 1.62 B). 24 records
    of 60 000 s give ~7600 cluster differences at tau = 189 s: ~1 % spread of the ADEV over rng seeds; 8 %
    tolerance, while sigma = B (the old mapping) would read 0.62 B."""
    g = load_grade("ideal")
    B = 0.7e-3 * G0
    g = dc.replace(g, accel=dc.replace(g.accel, bias_instability=B, bias_corr_time_s=100.0),
                   sample_rate_hz=1.0)
    unit = draw_unit(g, np.random.default_rng(0))
    n, m = 60_000, 189
    t = np.arange(n, dtype=float)
    rng = np.random.default_rng(11)
    avar, tot = 0.0, 0
    for _ in range(8):
        s = simulate_imu(unit, t, np.zeros((n, 3)), np.zeros((n, 3)), np.full((n, 6), 25.0), rng)
        c = s.accel[: (n // m) * m].reshape(n // m, m, 3).mean(axis=1)
        d = np.diff(c, axis=0)
        avar += 0.5 * np.sum(d**2)
        tot += d.size
    assert np.sqrt(avar / tot) == pytest.approx(B, rel=0.08)


@pytest.mark.parametrize("grade", ["adis16355", "adis16488"])
def test_accels_repeat_worse_than_gyros_relative_to_their_curve(grade):
    """Liu et al. 2012: accelerometers repeat worse than gyros. The power-on change of the bias (turn-on bias and the
    change of the temperature curve, combined in quadrature) as a fraction of the curve amplitude must be larger
    for the accelerometers (adis16355: 5.3 % vs 3.9 %)."""
    g = load_grade(grade)

    def repeatability(s):
        return math.hypot(s.turn_on_bias / s.bias_temp_amplitude, s.power_on_curve_fraction)

    assert repeatability(g.accel) > 1.2 * repeatability(g.gyro)
    assert g.accel.power_on_curve_fraction > g.gyro.power_on_curve_fraction
    if grade == "adis16355":
        assert repeatability(g.accel) == pytest.approx(math.hypot(0.5 / 30.0, 0.05))
        assert repeatability(g.gyro) == pytest.approx(math.hypot(0.02 / 0.6, 0.02))


def test_temperature_rate_term_per_degC_per_min():
    unit = draw_unit("adis16355", np.random.default_rng(21))
    n = 601
    t = np.arange(n) / 10.0
    ramp = 20.0 + (2.0 / 60.0) * t  # 2 degC/min
    w, f = np.zeros((n, 3)), np.tile([0, 0, G0], (n, 1))
    s_ramp = simulate_imu(unit, t, w, f, np.column_stack([ramp] * 6), None, noise=False)
    k = n // 2
    s_soak = simulate_imu(unit, t[:3], w[:3], f[:3], np.full((3, 6), ramp[k]), None, noise=False)
    np.testing.assert_allclose(s_ramp.accel[k] - s_soak.accel[0], 2.0 * unit.accel.temp_rate_coeff, rtol=1e-6, atol=1e-12)
    np.testing.assert_allclose(s_ramp.gyro[k] - s_soak.gyro[0], 2.0 * unit.gyro.temp_rate_coeff, rtol=1e-6, atol=1e-15)


def test_lin_dynamic_terms():
    """Accelerometer asymmetry and K2, gyro g-sensitivity, isolated on an otherwise ideal unit."""
    ideal = draw_unit("adis16355", np.random.default_rng(0), ideal=True)
    asym, k2 = np.array([1e-3, -2e-3, 5e-4]), np.array([1e-4, 0.0, -1e-4])
    G = np.arange(9.0).reshape(3, 3) * 1e-4
    unit = dc.replace(ideal, accel=dc.replace(ideal.accel, asym=asym, k2=k2),
                      gyro=dc.replace(ideal.gyro, g_sens=G))
    a = 3.0 * G0
    f = np.array([[a, a, a], [-a, -a, -a]])
    s = simulate_imu(unit, [0.0, 0.01], np.zeros((2, 3)), f, np.full((2, 6), 25.0), None, noise=False)
    # scale (1 + asym/2) for + inputs, (1 - asym/2) for - inputs; K2 a^2 is even in a
    np.testing.assert_allclose(s.accel[0] + s.accel[1], asym * a + 2 * k2 * a**2, rtol=1e-9)
    np.testing.assert_allclose(s.accel[0] - s.accel[1], 2 * a, rtol=1e-12)
    np.testing.assert_allclose(s.gyro, f @ G.T, rtol=1e-12)


def test_temperature_sensor_lag_ramp_exact():
    tau, r = 7.0, 0.3
    t = np.linspace(0.0, 60.0, 601)
    y = temperature_sensor_lag(t, 10.0 + r * t, tau)
    exact = 10.0 + r * (t - tau * (1.0 - np.exp(-t / tau)))
    np.testing.assert_allclose(y, exact, atol=1e-10)


def test_temperature_sensor_step_response_first_order():
    """Step 20 -> 50 degC just after t=0: y = 50 - 30 exp(-t/tau). The sampled step is a ramp over the
    first interval dt, which shifts the response by dt/2: tolerance 30*dt/(2 tau)."""
    tau, dt = 5.0, 0.001
    t = np.arange(0.0, 30.0, dt)
    u = np.where(t > 0, 50.0, 20.0)
    y = temperature_sensor_lag(t, u, tau)
    exact = 50.0 - 30.0 * np.exp(-t / tau)
    np.testing.assert_allclose(y, exact, atol=30.0 * dt / (2 * tau))
    i = np.searchsorted(t, tau)
    assert y[i] == pytest.approx(50.0 - 30.0 / np.e, abs=0.01)  # 63.2 % at t = tau


def test_reported_temperature_is_lagged_and_offset():
    unit = draw_unit("adis16355", np.random.default_rng(9))
    g = dc.replace(unit.grade, temp_sensor_lsb_C=0.0)
    unit = dc.replace(unit, grade=g)
    n = 3001
    t = np.arange(n) / 100.0
    T = np.column_stack([np.where(t > 0, 40.0, 20.0)] * 6)
    s = simulate_imu(unit, t, np.zeros((n, 3)), np.tile([0, 0, G0], (n, 1)), T, None, noise=False)
    tau = unit.temp_tau_s[0]
    exact = 40.0 - 20.0 * np.exp(-t / tau)
    np.testing.assert_allclose(s.temp_C - unit.temp_offset_C, np.column_stack([exact] * 6), atol=20 * 0.01 / (2 * tau))


@pytest.mark.parametrize("field,bad,match", [
    ("omega_b", np.zeros((10, 2)), r"omega_b: shape \(10, 2\) is invalid; expected \(10, 3\)"),
    ("f_b", np.zeros((9, 3)), r"f_b: shape \(9, 3\) is invalid; expected \(10, 3\)"),
    ("temp_C", np.zeros((10, 5)), r"temp_C: shape \(10, 5\) is invalid; expected \(10, 6\)"),
    ("temp_C", np.full((10, 6), np.nan), r"temp_C: contains NaN"),
    ("t", np.zeros((10, 1)), r"t: shape \(10, 1\) is invalid; expected \(N\)"),
])
def test_bad_shapes_raise_input_error(field, bad, match):
    unit = draw_unit("adis16355", np.random.default_rng(0))
    args = dict(zip(("t", "omega_b", "f_b", "temp_C"), _static(n=10)))
    args[field] = bad
    with pytest.raises(InputError, match=match):
        simulate_imu(unit, args["t"], args["omega_b"], args["f_b"], args["temp_C"], np.random.default_rng(0))


def test_time_must_increase_and_rng_required():
    unit = draw_unit("adis16355", np.random.default_rng(0))
    t, w, f, T = _static(n=10)
    with pytest.raises(InputError, match="t: must be strictly increasing"):
        simulate_imu(unit, t[::-1], w, f, T, np.random.default_rng(0))
    with pytest.raises(InputError, match="rng: a numpy.random.Generator is required"):
        simulate_imu(unit, t, w, f, T, None)


def test_unit_json_round_trip():
    unit = draw_unit("adis16488", np.random.default_rng(12))
    u2 = unit_from_dict(unit_to_dict(unit))
    t, w, f, T = _static(n=50, T=-5.0)
    a = simulate_imu(unit, t, w, f, T, None, noise=False)
    b = simulate_imu(u2, t, w, f, T, None, noise=False)
    np.testing.assert_array_equal(a.accel, b.accel)
    np.testing.assert_array_equal(a.gyro, b.gyro)
