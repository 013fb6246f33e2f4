"""The filter runner lives with the filters (imu/filters/run.py) and passes one record, FilterInputs, from which
each filter reads what it needs; the studies' old entry point is a re-export that maps its keyword arguments."""

import numpy as np
import pytest

from imutherm import InputError
from imutherm.imu.filters import FusionParams, GatedParams, KFParams
from imutherm.imu.filters.run import GateConfig, filter_inputs, run_filters
from imutherm.imu.motion import make_profile
from imutherm.imu.sensor_model import draw_unit, simulate_imu
from imutherm.studies.attitude import attitude_study


@pytest.fixture(scope="module")
def swing():
    traj = make_profile("swing", duration=40.0, rate_hz=100.0)
    unit = draw_unit("adis16355", np.random.default_rng(0))
    raw = simulate_imu(unit, traj.t, traj.omega_b, traj.f_b, np.full((traj.t.size, 6), 25.0),
                       np.random.default_rng(1))
    return traj, raw


def test_each_filter_derives_its_default_from_the_one_record(swing):
    traj, raw = swing
    gate = GateConfig(kp=0.2, tau_acc=3.0, kp_lp=0.7)
    x = filter_inputs(raw.gyro, raw.accel, 0.01, traj.lever_arm, gate, design={"kf": KFParams(q=1e-6)})
    gated, ungated = x.default("gated"), x.default("ungated")
    assert isinstance(gated, GatedParams) and gated.thresholds is x.thresholds and gated.g == x.g_ref
    assert (gated.kp, ungated.kp, gated.tau_acc) == (0.7, 0.2, 3.0)   # kp_lp in the low-pass mode; ungated: kp
    assert x.default("kf") == KFParams(q=1e-6) and x.default("fusion") == FusionParams()
    rest = np.linalg.norm(raw.accel[:800], axis=1).mean()   # the accelerometer's own |f| over the 8 s at rest
    assert x.g_ref == pytest.approx(rest, rel=1e-3)
    with pytest.raises(InputError, match="unknown"):
        x.default("nope")


def test_the_studies_entry_point_is_the_same_runner(swing):
    traj, raw = swing
    names = ("gated", "kf", "fusion")
    fusion, kf = FusionParams(gyroscope_range=300.0), KFParams(q=1e-6)
    old, th_old = attitude_study.run_filters(raw.gyro, raw.accel, 0.01, traj.lever_arm, names=names,
                                             fusion=fusion, kf=kf)
    new, th_new = run_filters(raw.gyro, raw.accel, 0.01, traj.lever_arm, names=names,
                              design={"fusion": fusion, "kf": kf})
    assert th_old == th_new
    for n in names:
        assert np.array_equal(old[n].roll, new[n].roll) and np.array_equal(old[n].pitch, new[n].pitch), n
    # and the design changes what kf runs with (the test can fail)
    other, _ = run_filters(raw.gyro, raw.accel, 0.01, traj.lever_arm, names=("kf",))
    assert not np.array_equal(other["kf"].roll, new["kf"].roll)
    assert attitude_study.GateConfig is GateConfig
