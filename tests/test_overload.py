"""Lin et al.'s overload table: estimator algebra (noise-free), recovery within tolerance, CLI, attitude effect."""

import json

import numpy as np
import pytest

from imutherm import InputError
from imutherm.imu.overload import OverloadRig, calibrate_overload, compensate_overload, truth_coefficients
from imutherm.imu.sensor_model import G0, draw_unit, simulate_imu

RIG = OverloadRig(power_ons=1)


def test_noise_free_recovery_is_exact():
    """Without noise, every load's Ka, K2 and D1 equal the truth (0.5 % / 1e-6 deg/s/g): the half-period and band
    sums are algebraically right; what remains (0.2 % at 1 g) is the up axis' 1 g seen through the misalignment,
    which shifts the zero of |u| away from the zero of the table's A."""
    rng = np.random.default_rng(0)
    unit = draw_unit("adis16355", rng)
    r = calibrate_overload(unit, rng, RIG, noise=False)
    t = truth_coefficients(unit)
    pl = r.per_load
    assert np.allclose(pl["asym"][0], t.asym[:, None], rtol=5e-3)
    assert np.allclose(pl["k2"][0], t.k2[:, None], rtol=5e-3, atol=1e-8)  # atol 1e-4 mg/g^2
    assert np.allclose(pl["D1"][0], t.D1[:, :, None], atol=np.radians(1e-6) / G0)


@pytest.mark.parametrize("seed", [1, 4])
def test_recovered_coefficients_within_tolerance(seed):
    """With the grade's noise (3 power-ons, 1..10 g, 40 cycles per load), the joint estimates are within
    Ka 200 ppm, K2 0.015 mg/g^2 and D1 0.006 deg/s/g of the truth: about 3.5 sigma of the spread measured over six
    units (55 ppm, 0.004 mg/g^2, 0.0015 deg/s/g); the truth's own 1-sigma sizes are 500 ppm, 0.3 mg/g^2 and
    0.05 deg/s/g."""
    rng = np.random.default_rng(seed)
    unit = draw_unit("adis16355", rng)
    d = calibrate_overload(unit, rng).to_json()
    j, t = d["joint"], d["truth"]
    assert np.all(np.abs(np.subtract(j["asym_ppm"], t["asym_ppm"])) < 200)
    assert np.all(np.abs(np.subtract(j["k2_mg_per_g2"], t["k2_mg_per_g2"])) < 0.015)
    assert np.all(np.abs(np.subtract(j["D1_dps_per_g"], t["D1_dps_per_g"])) < 0.006)
    # per-load scatter falls with load: the 10 g asymmetry estimates are closer to the truth than the 1 g ones
    a = np.array(d["per_load"]["asym_ppm"]) - np.array(t["asym_ppm"])[None, :, None]
    assert np.sqrt(np.mean(a[..., -1] ** 2)) < np.sqrt(np.mean(a[..., 0] ** 2))


def test_compensation_removes_the_terms():
    rng = np.random.default_rng(2)
    unit = draw_unit("adis16355", rng)
    ideal = draw_unit("adis16355", np.random.default_rng(2), ideal=True)
    from dataclasses import replace

    u = replace(ideal, accel=replace(ideal.accel, asym=unit.accel.asym, k2=unit.accel.k2),
                gyro=replace(ideal.gyro, g_sens=unit.gyro.g_sens))
    f = np.array([[5 * G0, -3 * G0, -G0], [-8 * G0, 2 * G0, 0.5 * G0]])
    s = simulate_imu(u, np.arange(2) * 0.01, np.zeros((2, 3)), f, np.full((2, 6), 25.0), None, noise=False)
    c = compensate_overload(s, truth_coefficients(unit))
    assert np.allclose(c.accel, f, atol=1e-6 * G0)  # 1 ug: the fixed point converged
    assert np.allclose(c.gyro, 0.0, atol=np.radians(1e-3))


def test_cli_overload_writes_results(tmp_path):
    from imutherm.cli.calibrate import main

    assert main(["--procedure", "overload", "--seed", "3", "--out", str(tmp_path / "ov")]) == 0
    d = json.loads((tmp_path / "ov" / "overload.json").read_text())
    assert d["loads_g"] == [float(g) for g in range(1, 11)]
    assert set(d["attitude_on_shake"]) == {"1.2g", "5g"}
    for row in d["attitude_on_shake"].values():
        for f in ("gated", "kf", "aekf", "aekf_gnss"):
            assert set(row[f]) == {"without", "with"} and row[f]["with"]["roll_rms_deg"] < 2.0


def test_bad_rig():
    with pytest.raises(InputError, match="loads_g"):
        OverloadRig(loads_g=(0.0, 2.0))
    with pytest.raises(InputError, match="bands"):
        OverloadRig(bands=2)


def test_load_dependent_truth_recovered_per_load_noise_free():
    """Lin et al.'s findings as the truth model (LoadDependence: Ka +6 %/g, K2 and D1 -5 %/g): without noise the
    procedure's per-load Ka, K2, D1 equal the truth's per-load values (0.5 %), and the trends it reports equal
    the model's."""
    from imutherm.imu.overload import LoadDependence

    rng = np.random.default_rng(2)
    unit = draw_unit("adis16355", rng)
    dep = LoadDependence()
    r = calibrate_overload(unit, rng, OverloadRig(loads_g=(1.0, 4.0, 10.0), power_ons=1, cycles=6), noise=False,
                           dependence=dep)
    tp, pl = r.truth_per_load, r.per_load
    assert np.allclose(tp["asym"][0, :, 2] / tp["asym"][0, :, 0], 1 + 9 * dep.asym_per_g)
    assert np.allclose(tp["k2"][0, :, 2] / tp["k2"][0, :, 0], 1 + 9 * dep.k2_per_g)
    assert np.allclose(pl["asym"], tp["asym"], rtol=5e-3)
    assert np.allclose(pl["k2"], tp["k2"], rtol=5e-3, atol=1e-8)
    assert np.allclose(pl["D1"], tp["D1"], atol=np.radians(1e-6) / G0)
    tr = r.trends()
    for key, want in (("asym", dep.asym_per_g), ("k2", dep.k2_per_g)):
        assert np.allclose(tr[key]["truth_rel_per_g"], want) and np.allclose(tr[key]["recovered_rel_per_g"], want,
                                                                              atol=2e-3)
    d = r.to_json()["load_dependence"]
    assert d["asym_per_g"] == dep.asym_per_g and len(d["truth_per_load"]["asym_ppm"][0][0]) == 3
    with pytest.raises(InputError, match="k2_per_g"):
        LoadDependence(k2_per_g=-0.2)


@pytest.mark.slow
def test_load_dependent_truth_with_noise():
    """With the grade's noise (3 power-ons, 1..10 g, 40 cycles per load) on the load-dependent truth: at 5-10 g every
    per-load value is within Ka 1500 ppm, K2 0.15 mg/g^2, D1 0.02 deg/s/g of the truth's value for that load and
    power-on (about 1.5x the largest error measured over 2 units x 3 power-ons x 3 axes: 1060 ppm, 0.10 mg/g^2,
    0.012 deg/s/g; below 5 g the noise is larger: up to 3500 ppm, 1.4 mg/g^2, 0.034 deg/s/g at 1 g), and the
    D1 trend (its own-axis terms, per g) within 0.002 deg/s/g per g of the truth's (measured <= 0.0007; the
    truth's slopes are up to 0.004). The Ka and K2 trends are not asserted: this grade's noise hides them
    (docs/reference/overload.md)."""
    from imutherm.imu.overload import LoadDependence

    rng = np.random.default_rng(0)
    unit = draw_unit("adis16355", rng)
    r = calibrate_overload(unit, rng, dependence=LoadDependence())
    hi = r.loads_g >= 5.0
    pl, tp = r.per_load, r.truth_per_load
    assert np.max(np.abs(pl["asym"] - tp["asym"])[..., hi]) * 1e6 < 1500
    assert np.max(np.abs(pl["k2"] - tp["k2"])[..., hi]) * G0 * 1e3 < 0.15
    assert np.degrees(np.max(np.abs(pl["D1"] - tp["D1"])[..., hi]) * G0) < 0.02
    tr = r.trends()["D1"]
    assert np.all(np.abs(np.subtract(tr["recovered_per_g"], tr["truth_per_g"])) < 0.002), tr
