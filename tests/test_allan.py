"""The simulated sensor noise against its grade, by Allan deviation computed with ``allantools``.

For each grade with noise (adis16355, adis16488), gyro and accelerometer, a unit at rest at 25 °C with
every deterministic error off (``draw_unit(..., ideal=True)`` keeps the grade's noise) is recorded for 2 h
at 100 Hz; the overlapping Allan deviation of each axis is averaged over the three axes:

* angle / velocity random walk N: σ(1 s) = N (the white term dominates at 1 s), within 10 %;
* bias instability B: σ(τ) at the Gauss-Markov Allan peak τ = 1.89 Tc equals sqrt(B² + N²/τ) (the process
  is scaled so that its Allan peak is B), within 25 % (≈ 40 independent 190 s blocks per axis, three axes);
* rate random walk K: with the Gauss-Markov term switched off, a 40 h record at 10 Hz, σ(τ) at
  τ = 2·10^4 s equals sqrt(N²/τ + K² τ / 3) within 35 % (six 2·10^4 s blocks, three axes: the estimate
  itself scatters by ~20 %).
"""

import dataclasses as dc

import allantools
import numpy as np
import pytest

from imutherm.imu.sensor_model import draw_unit, load_grade, simulate_imu


def _adev(grade, kind, rate, hours, taus, seed):
    n = int(hours * 3600 * rate)
    t = np.arange(n) / rate
    unit = draw_unit(grade, np.random.default_rng(seed), ideal=True)
    s = simulate_imu(unit, t, np.zeros((n, 3)), np.zeros((n, 3)), np.full((n, 6), 25.0), np.random.default_rng(seed))
    y = s.gyro if kind == "gyro" else s.accel
    if kind == "accel":
        y = y - y.mean(axis=0)
    out = []
    for i in range(3):
        tau_out, ad, _, _ = allantools.oadev(y[:, i], rate=rate, data_type="freq", taus=np.asarray(taus, float))
        out.append(ad)
    return tau_out, np.mean(out, axis=0)


@pytest.mark.slow
@pytest.mark.parametrize("grade", ["adis16355", "adis16488"])
@pytest.mark.parametrize("kind", ["gyro", "accel"])
def test_allan_white_noise_and_bias_instability(grade, kind):
    g = load_grade(grade)
    spec = getattr(g, kind)
    g = dc.replace(g, **{kind: dc.replace(spec, lsb=0.0)})  # quantisation is white, below the noise here
    tau_pk = 1.89 * spec.bias_corr_time_s  # the Gauss-Markov Allan peak
    tau, ad = _adev(g, kind, 100.0, 2.0, [1.0, tau_pk], seed=11)
    assert ad[0] == pytest.approx(spec.noise_density, rel=0.10), (ad[0], spec.noise_density)
    floor = np.sqrt(spec.bias_instability**2 + spec.noise_density**2 / tau_pk)  # B with the white part there
    assert ad[1] == pytest.approx(floor, rel=0.25), (ad[1], floor)


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["gyro", "accel"])
def test_allan_rate_random_walk(kind):
    g = load_grade("adis16355")
    spec = getattr(g, kind)
    g = dc.replace(g, **{kind: dc.replace(spec, bias_instability=0.0, lsb=0.0)})
    tau0 = 2.0e4
    tau, ad = _adev(g, kind, 10.0, 40.0, [tau0], seed=12)
    expect = np.sqrt(spec.noise_density**2 / tau0 + spec.rate_random_walk**2 * tau0 / 3.0)
    assert spec.rate_random_walk**2 * tau0 / 3.0 > 4 * spec.noise_density**2 / tau0  # RRW dominates there
    assert ad[0] == pytest.approx(expect, rel=0.35), (ad[0], expect)
