"""Site-temperature tables (one home for the thermal-to-IMU hand-off): one writer, one reader, the site
names defined once."""

import numpy as np
import pytest

from imutherm import InputError
from imutherm.site_table import ACCEL_SITES, GYRO_SITES, SITES, read_site_table, write_site_table


def test_site_names_are_defined_once():
    import imutherm.imu.sensor_model as sm
    import imutherm.studies.thermal.thermal_study as ts

    assert sm.SITES is SITES and ts.GYRO_SITES is GYRO_SITES and ts.ACCEL_SITES is ACCEL_SITES
    assert GYRO_SITES + ACCEL_SITES == SITES


@pytest.fixture(scope="module")
def coarse_run():
    """A real power-on transient of the reference unit (coarse mesh, linear laws: a few seconds)."""
    from imutherm.studies.thermal.thermal_study import run_scheme
    from imutherm.unit.model import ModelOptions

    opts = ModelOptions(exterior="fixed", radiation=False, cavity_radiation=False)
    return run_scheme(None, "grease", mesh_size_mm=6.0, min_cells=1, options=opts, transient=True, t_end=300.0)


def test_round_trip_through_the_writers_of_every_command(coarse_run, tmp_path):
    """The probe table of a real run, written by the one writer and read back by the one reader (as
    ``imutherm attitude --temperature-csv`` and the reports read it): times to 9 digits, temperatures
    to 1e-6 K, every site in the file's order, the IMU's six in SITES order."""
    from imutherm.studies.attitude.attitude_study import read_temperature_csv
    from imutherm.studies.thermal.thermal_study import probe_table

    header, rows = probe_table(coarse_run)
    assert header[0] == "time_s" and set(SITES) < set(header[1:]) and len(rows) > 5
    path = write_site_table(tmp_path / "probes.csv", rows[:, 0], header[1:], rows[:, 1:])
    t, T, names = read_site_table(path, None)
    assert names == tuple(header[1:])
    assert np.allclose(t, rows[:, 0], rtol=1e-8, atol=0) and np.abs(T - rows[:, 1:]).max() <= 5e-7
    t6, T6 = read_temperature_csv(path)
    idx = [header.index(s) for s in SITES]
    assert np.array_equal(t6, t) and np.abs(T6 - rows[:, idx]).max() <= 5e-7
    # the steady state: one row at time inf
    st = write_site_table(tmp_path / "steady.csv", [np.inf], header[1:], np.asarray(coarse_run.steady.probe_C)[None])
    ts, Ts, _ = read_site_table(st)
    assert np.isinf(ts[0]) and Ts.shape == (1, 6)


def test_cli_tables_are_the_writers(tmp_path):
    """``imutherm solve`` writes probes.csv with this module (same header and number formats)."""
    from imutherm.cli import main

    out = tmp_path / "s"
    assert main(["solve", "--scheme", "air", "--out", str(out), "--mesh-size", "6", "--min-cells", "1",
                 "--exterior", "fixed", "--no-radiation", "--no-cavity-radiation"]) == 0
    line = (out / "probes.csv").read_text().splitlines()[1].split(",")
    assert line[0] == "inf" and all(len(v.split(".")[1]) == 6 for v in line[1:])
    t, T, names = read_site_table(out / "probes.csv", None)
    assert names[:6] == SITES and T.shape == (1, len(names))


@pytest.mark.parametrize("names, shape", [(["a", "a"], (2, 2)), (["time_s"], (2, 1)), (["a"], (2, 2))])
def test_writer_refuses_inconsistent_columns(names, shape, tmp_path):
    with pytest.raises(InputError, match="site table"):
        write_site_table(tmp_path / "x.csv", [0.0, 1.0], names, np.zeros(shape))
