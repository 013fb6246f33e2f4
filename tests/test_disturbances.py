"""Disturbances checked against their definitions: vibration spectrum and chain, Dryden PSD, sync, jitter, shear."""

import math

import numpy as np
import pytest
from scipy import signal

from imutherm import InputError
from imutherm.imu import disturbances
from imutherm.imu import motion
from imutherm.imu.attitude_math import G0


def test_vibration_peak_and_rms():
    spec = disturbances.Spectrum(lines=((40.0, 0.02), (80.0, 0.10)), band=(15.0, 500.0), psd=1e-5)
    fs = 1638.4
    x = disturbances.vibration_raw(spec, 200.0, fs, np.random.default_rng(1))
    rms = np.sqrt(np.mean(x**2, axis=0))
    assert rms == pytest.approx(np.full(3, spec.rms()), rel=0.02)  # sqrt(0.02² + 0.1² + 1e-5·485)
    f, p = signal.welch(x[:, 2], fs, nperseg=8192)
    assert f[np.argmax(p)] == pytest.approx(80.0, abs=fs / 8192)  # the strongest line
    floor = np.median(p[(f > 100) & (f < 150)])
    assert floor == pytest.approx(1e-5, rel=0.1)  # the broadband level
    assert np.mean(p[(f > 520) & (f < 800)]) < 1e-3 * 1e-5  # nothing outside the band


def test_vibration_through_sensor_chain_aliases_with_the_chain_gain():
    """An 80 Hz line read at 100 Hz appears at 20 Hz with amplitude √2 rms |H(80 Hz)|."""
    chain = disturbances.SensorChain(bandwidth_hz=350.0, internal_hz=800.0, avg_taps=8)
    vib = disturbances.Vibration(linear=disturbances.Spectrum(lines=((80.0, 0.1),)), chain=chain)
    t = np.arange(20000) / 100.0
    acc, gyro = disturbances.vibration_samples(vib, t, np.random.default_rng(2))
    assert np.all(gyro == 0)
    z = acc[:, 2] / G0
    spec = np.abs(np.fft.rfft(z)) * 2 / len(z)
    fr = np.fft.rfftfreq(len(z), 0.01)
    k = np.argmax(spec)
    assert fr[k] == pytest.approx(20.0, abs=0.01)
    gain = float(chain.gain(80.0))
    assert 0.3 < gain < 0.9  # the Bartlett average attenuates 80 Hz noticeably
    assert spec[k] == pytest.approx(math.sqrt(2) * 0.1 * gain, rel=0.02)


@pytest.mark.parametrize("key,kind", [("u", "u"), ("w", "w")])
def test_dryden_psd_matches_the_mil_f_8785c_form(key, kind):
    turb = disturbances.Turbulence("moderate", altitude_m=250.0)
    dt = 0.05
    g = disturbances.dryden_gusts(200_000, dt, turb, np.random.default_rng(3))
    sc = g["scales"]
    x = g[f"{key}_g"]
    V = turb.aircraft.airspeed_mps
    sigma, L = sc[f"sigma_{key}"], sc[f"L_{key}"]
    assert np.std(x) == pytest.approx(sigma, rel=0.08)
    f, p = signal.welch(x, 1 / dt, nperseg=4096)
    m = (f > 0.02) & (f < 2.0)
    ratio = p[m] / disturbances.dryden_psd(f[m], sigma, L, V, kind)
    assert np.mean(ratio) == pytest.approx(1.0, abs=0.06)
    # band by band (decades), within 15 %
    for lo, hi in ((0.02, 0.2), (0.2, 2.0)):
        mm = (f[m] >= lo) & (f[m] < hi)
        assert np.mean(ratio[mm]) == pytest.approx(1.0, abs=0.15)


def test_dryden_scales_low_altitude_formulas():
    sc = disturbances.dryden_scales(1000 * 0.3048 - 1e-9, 30 * disturbances.KT)  # h = 1000 ft: L_u = 1000 / 1.0^1.2 ft
    assert sc["sigma_w"] == pytest.approx(0.1 * 30 * disturbances.KT)
    assert sc["L_w"] == pytest.approx(304.8, rel=1e-6)
    assert sc["L_u"] == pytest.approx(304.8, rel=1e-3) and sc["sigma_u"] == pytest.approx(sc["sigma_w"], rel=1e-3)


def test_sync_error_shifts_the_reference_by_the_stated_time():
    tr = motion.swing_profile(60.0, 100.0)
    dist = disturbances.Disturbances(sync_s=0.03)
    rec = disturbances.apply(tr, dist, np.random.default_rng(0))
    np.testing.assert_allclose(rec.ref_roll[3:], tr.roll[:-3], atol=1e-12)  # 30 ms = 3 samples
    rec = disturbances.apply(tr, disturbances.Disturbances(sync_s=0.0123), np.random.default_rng(0))
    exact = motion.swing_profile(60.0, 100.0)  # analytic truth at t - 12.3 ms via its rate
    m = slice(100, -100)
    assert np.max(np.abs(rec.ref_roll[m] - (exact.roll[m] - 0.0123 * exact.omega_b[m, 0]))) < 1e-3
    # the lag that best aligns reference and truth is the stated one
    lags = np.arange(-0.03, 0.031, 0.0005)
    err = [np.mean((rec.ref_roll[m] - disturbances.delayed(tr.t, tr.roll, s)[m]) ** 2) for s in lags]
    assert lags[int(np.argmin(err))] == pytest.approx(0.0123, abs=5e-4)
    with pytest.raises(InputError, match="sync_s"):
        disturbances.apply(tr, disturbances.Disturbances(sync_s=-1.0), np.random.default_rng(0))


def test_jitter_samples_the_motion_at_the_jittered_instants():
    tr = motion.swing_profile(60.0, 100.0)
    rng = np.random.default_rng(4)
    w, f = disturbances.jittered(tr, 1e-3, rng)
    j = np.random.default_rng(4).normal(0.0, 1e-3, tr.t.size)
    m = slice(10, -10)
    pred = tr.omega_b[m, 0] + tr.omega_dot_b[m, 0] * j[m]  # first-order Taylor
    # second-order term: |ω̈| <= A Ω³ = 55 rad/s³ on this swing, j <= 5 ms: 7e-4 rad/s
    assert np.max(np.abs(w[m, 0] - pred)) < 0.5 * 55.0 * np.max(j) ** 2 + 1e-5
    assert np.std(w[m, 0] - tr.omega_b[m, 0]) == pytest.approx(np.std(tr.omega_dot_b[m, 0] * j[m]), rel=0.02)


def test_perturb_is_kinematically_exact():
    tr = motion.flight_profile(120.0, 100.0, lever_arm=(0.3, 0.0, 0.05))
    t = tr.t
    a, w = np.radians(1.0), 0.7
    dr = motion.Jet(a * np.sin(w * t), a * w * np.cos(w * t), -a * w * w * np.sin(w * t))
    dp = motion.Jet(0.5 * a * np.cos(w * t), -0.5 * a * w * np.sin(w * t), -0.5 * a * w * w * np.cos(w * t))
    p = disturbances.perturb(tr, dr, dp, np.zeros((t.size, 3)))
    # body rate from finite differences of the quaternion: ω = 2 Im(q* ⊗ q̇)
    q = p.quat
    qd = np.gradient(q, t, axis=0)
    qc = q * np.array([1, -1, -1, -1])
    om = 2 * disturbances._qmul(qc, qd)[:, 1:]
    np.testing.assert_allclose(om[5:-5], p.omega_b[5:-5], atol=2e-4)
    # ω̇: no worse than the clean profile's own finite-difference error (jerk steps at segment joins)
    fd = lambda tr_: np.abs(np.gradient(tr_.omega_b, t, axis=0) - tr_.omega_dot_b)[5:-5]  # noqa: E731
    assert np.all(fd(p) <= fd(tr) + 1e-4)
    # the CG acceleration is unchanged: |f_cg| identical, lever-arm terms recomputed
    d = np.array([0.3, 0.0, 0.05])
    cg = lambda tr_: tr_.f_b - np.cross(tr_.omega_dot_b, d) - np.cross(tr_.omega_b, np.cross(tr_.omega_b, d))  # noqa: E731
    np.testing.assert_allclose(np.linalg.norm(cg(p), axis=1), np.linalg.norm(cg(tr), axis=1), atol=1e-9)
    z = motion.Jet(np.zeros_like(t))
    same = disturbances.perturb(tr, z, z, np.zeros((t.size, 3)))
    np.testing.assert_allclose(same.f_b, tr.f_b, atol=1e-9)
    np.testing.assert_allclose(same.omega_b, tr.omega_b, atol=1e-12)


def test_wind_shear_accelerates_the_air_mass_in_the_climb():
    tr = motion.flight_profile(400.0, 100.0)
    wind = disturbances.Wind(w20_kt=20.0, from_deg=0.0)  # headwind on the initial heading (north)
    p = disturbances.aero_disturbance(tr, None, wind, np.random.default_rng(0))
    h, hdot = disturbances.airborne(tr, wind.ground_m)
    climb = (tr.segment == "climb-1")
    k = np.flatnonzero(climb)[len(np.flatnonzero(climb)) // 2]
    dwdh = wind.w20_kt * disturbances.KT / (h[k] * math.log(20 * disturbances.FT / wind.z0_m))
    expected = dwdh * hdot[k]  # the headwind grows with height: the air mass pushes back (−x)
    df = p.f_b[k] - tr.f_b[k]
    assert hdot[k] > 5 and expected > 0.02
    assert np.linalg.norm(df) == pytest.approx(expected, rel=1e-6)
    assert df[0] < 0
    ground = tr.segment == "ground-1"
    np.testing.assert_allclose(p.f_b[ground], tr.f_b[ground], atol=1e-12)  # nothing on the runway


def test_turbulence_response_magnitudes_light():
    """Light turbulence on the flight: gust load rms and attitude perturbations of a plausible size."""
    tr = motion.flight_profile(400.0, 100.0)
    p = disturbances.aero_disturbance(tr, disturbances.Turbulence("light"), None, np.random.default_rng(5))
    air = disturbances.airborne(tr)[0] > 20
    dn = (p.f_b[air, 2] - tr.f_b[air, 2]) / G0
    assert 0.02 < np.std(dn) < 0.15  # load-factor rms [g]
    droll = np.degrees(np.std((p.roll - tr.roll)[air]))
    assert 0.05 < droll < 1.0
    low = ~(disturbances.airborne(tr)[0] > 3.0)
    np.testing.assert_allclose(p.f_b[low], tr.f_b[low], atol=1e-9)  # nothing on the runway


def test_presets_cover_every_profile_and_are_reproducible():
    assert set(disturbances.PRESETS) >= set(motion.PROFILES)
    tr = motion.vehicle_profile(60.0, 100.0)
    a = disturbances.apply(tr, disturbances.PRESETS["vehicle"], np.random.default_rng(7))
    b = disturbances.apply(tr, disturbances.PRESETS["vehicle"], np.random.default_rng(7))
    np.testing.assert_array_equal(a.f_in, b.f_in)
    vib = np.sqrt(np.mean((a.f_in - a.truth.f_b) ** 2, axis=0))
    assert 0.05 < vib[2] < 0.6  # m/s² rms after the chain
