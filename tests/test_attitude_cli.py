"""``imutherm attitude`` in-process: result keys, outputs, and bad input."""

import json

import numpy as np
import pytest

from imutherm import InputError
from imutherm.cli.attitude import main
from imutherm.imu.sensor_model import SITES
from imutherm.studies.attitude.attitude_study import GateConfig, run_attitude_study

NAMES = ("gated", "kf", "ungated", "fusion")
SEGMENTS = ("overall", "stable", "manoeuvre")
METRICS = ("roll_rms_deg", "pitch_rms_deg", "roll_max_deg", "pitch_max_deg")


def test_cli_flight_writes_required_keys(tmp_path, capsys):
    out = tmp_path / "att"
    rc = main(["--profile", "flight", "--duration", "60", "--seeds", "2", "--compensation", "improved",
               "--out", str(out)])
    assert rc == 0
    d = json.loads((out / "attitude.json").read_text())
    assert d["profile"] == "flight" and d["grade"] == "adis16355" and d["seeds"] == [0, 1]
    for n in NAMES:
        for seg in SEGMENTS:
            for m in METRICS:
                v = d["filters"][n][seg][m]
                assert set(v) == {"mean", "std"} and np.isfinite(v["mean"]) and v["std"] >= 0
        assert d["filters"][n]["runtime_s"]["mean"] > 0
    assert (out / "attitude.png").stat().st_size > 10_000
    assert (out / "attitude_series.npz").exists()
    assert not list(tmp_path.glob(".att.*"))  # no temporary directory left behind
    assert "gated" in capsys.readouterr().out


def test_temperature_csv_is_interpolated(tmp_path):
    csv = tmp_path / "temps.csv"
    rows = ["time_s," + ",".join(SITES), "0," + ",".join(["20"] * 6), "100," + ",".join(["30"] * 6)]
    csv.write_text("\n".join(rows) + "\n")
    res = run_attitude_study("static", compensation="none", temperature_csv=csv, duration=20.0,
                             names=("gated", "kf"))
    assert res.temperature["min_C"] == pytest.approx(20.0)
    assert res.temperature["max_C"] == pytest.approx(21.99, abs=0.01)  # 20 s of a 0.1 °C/s ramp
    assert res.metrics["gated"]["manoeuvre"]["roll_rms_deg"] is None  # static: no manoeuvre samples
    assert res.metrics["gated"]["overall"]["roll_rms_deg"]["mean"] < 5.0  # uncompensated: tens of mg bias


@pytest.mark.parametrize("time_value", ["inf", "0", "1200"])
def test_single_row_temperature_csv_is_constant(tmp_path, time_value):
    """A steady-run probes.csv of ``imutherm solve`` has one row at time_s = inf: a constant temperature."""
    from imutherm.studies.attitude.attitude_study import read_temperature_csv, temperature_on

    csv = tmp_path / "probes.csv"
    temps = ["31.5", "32", "33.25", "34", "35", "36.5"]
    csv.write_text("time_s," + ",".join(SITES) + "\n" + time_value + "," + ",".join(temps) + "\n")
    tc, T = read_temperature_csv(csv)
    assert tc.shape == (1,) and T.shape == (1, 6)
    temp, desc = temperature_on(np.arange(5) * 0.01, temperature_csv=csv)
    np.testing.assert_array_equal(temp, np.tile(np.array(temps, float), (5, 1)))
    assert desc["min_C"] == 31.5 and desc["max_C"] == 36.5
    res = run_attitude_study("static", compensation="none", temperature_csv=csv, duration=20.0, names=("gated",))
    assert res.temperature["max_C"] == 36.5


def test_temperature_csv_nonfinite_rejected_unless_single_row(tmp_path):
    from imutherm.studies.attitude.attitude_study import read_temperature_csv

    csv = tmp_path / "t.csv"
    csv.write_text("time_s," + ",".join(SITES) + "\n0," + ",".join(["25"] * 6) + "\ninf," + ",".join(["26"] * 6) + "\n")
    with pytest.raises(InputError, match="t.csv: column 'time_s' contains NaN or inf"):
        read_temperature_csv(csv)
    csv.write_text("time_s," + ",".join(SITES) + "\ninf," + ",".join(["25"] * 5 + ["inf"]) + "\n")
    with pytest.raises(InputError, match="t.csv: temperature CSV contains NaN or inf temperatures"):
        read_temperature_csv(csv)


@pytest.mark.parametrize("args, message", [
    (["--profile", "loop"], "--profile: 'loop' is unknown; valid: static, swing, shake, flight"),
    (["--profile", "static", "--grade", "adis99"], "unknown grade 'adis99'; valid grades: adis16355"),
    (["--profile", "static", "--temperature", "95"], "95.00 °C at site gyro_x (t = 0.00 s) is outside the "
                                                     "calibrated range; valid: -40..70 °C"),
    (["--profile", "static", "--compensation", "magic"], "--compensation: 'magic' is unknown; valid: none, "
                                                         "conventional, improved"),
])
def test_cli_bad_input(tmp_path, capsys, args, message):
    rc = main(args + ["--duration", "20", "--out", str(tmp_path / "o")])
    assert rc == 2
    err = capsys.readouterr().err
    assert message in err and err.startswith("imutherm attitude: error:")
    assert not (tmp_path / "o").exists()


def test_cli_csv_missing_site_column(tmp_path, capsys):
    csv = tmp_path / "temps.csv"
    cols = [s for s in SITES if s != "accel_y"]
    csv.write_text("time_s," + ",".join(cols) + "\n0," + ",".join(["25"] * 5) + "\n")
    rc = main(["--profile", "static", "--duration", "20", "--temperature-csv", str(csv), "--out", str(tmp_path / "o")])
    assert rc == 2
    err = capsys.readouterr().err
    assert "temps.csv: column 'accel_y' is missing; valid header: time_s, gyro_x" in err


@pytest.mark.slow
def test_flight_accuracy_targets():
    """Flight, adis16355, improved, 25 °C, seeds 0..5 (none of them used to tune anything: the gate design is
    physical, GateConfig defaults): gated roll / pitch RMS <= 1.0° overall and <= 0.5° in stable flight (mean
    over seeds), and the gate is worth more than the seed-to-seed spread: gated beats the same update without
    gate by more than 3 std of either. (The old claim gated < fusion compared against the peer at its defaults;
    the fair comparison, every filter tuned by one procedure on other seeds, is benchmarks/bench_attitude.py.)"""
    res = run_attitude_study("flight", grade="adis16355", temperature_C=25.0, compensation="improved", seeds=6)
    assert res.seeds == tuple(range(6))
    m = {n: {seg: {k: res.metrics[n][seg][k] for k in ("roll_rms_deg", "pitch_rms_deg")}
             for seg in ("overall", "stable")} for n in ("gated", "ungated")}
    for k in ("roll_rms_deg", "pitch_rms_deg"):
        g, u = m["gated"]["overall"][k], m["ungated"]["overall"][k]
        assert g["mean"] <= 1.0, m["gated"]
        assert m["gated"]["stable"][k]["mean"] <= 0.5, m["gated"]
        assert g["mean"] + 3 * max(g["std"], u["std"]) < u["mean"], (g, u)


def test_study_rejects_too_short_rest():
    with pytest.raises(InputError, match="init_s=0.50 s .* is too short; valid: at least 1 s"):
        run_attitude_study("flight", duration=60.0, compensation="none", gate=GateConfig(init_s=0.5))


def test_cli_vehicle_with_realistic_disturbances(tmp_path):
    out = tmp_path / "veh"
    assert main(["--profile", "vehicle", "--duration", "80", "--disturbances", "realistic", "--no-plot",
                 "--out", str(out)]) == 0
    d = json.loads((out / "attitude.json").read_text())
    assert d["gate"]["disturbances"]["vibration"] is True and d["gate"]["disturbances"]["sync_ms"] == 5.0
    for n in NAMES:
        assert np.isfinite(d["filters"][n]["overall"]["roll_rms_deg"]["mean"])
    clean = run_attitude_study("vehicle", duration=80.0, names=("kf",))
    assert clean.gate["disturbances"] is None


@pytest.mark.slow
def test_realistic_flight_is_of_the_papers_order_and_turbulence_shuts_the_gate():
    """With the flight's realistic disturbances the gated filter is no longer ~5x better than the paper's
    measured 2.3 / 2.5° (1σ): its whole-record RMS over seeds 0-2 lies between 0.3° and 6° in roll and
    between 1° and 6° in pitch (docs/benchmarks/attitude.md: 0.52 / 4.05° on seeds 0-5); light turbulence alone keeps the gate
    shut on most stable-flight samples (clean: open on all of them)."""
    from imutherm.imu import disturbances
    from imutherm.studies.attitude import filter_benchmark as fb

    res = run_attitude_study("flight", seeds=3, names=("gated",), disturbances=True)
    o = res.metrics["gated"]["overall"]
    assert 0.3 < o["roll_rms_deg"]["mean"] < 6.0 and 1.0 < o["pitch_rms_deg"]["mean"] < 6.0
    clean = run_attitude_study("flight", seeds=3, names=("gated",))
    assert o["pitch_rms_deg"]["mean"] > 3 * clean.metrics["gated"]["overall"]["pitch_rms_deg"]["mean"]
    from imutherm.imu import motion

    stable = motion.make_profile("flight", None, 100.0).stable
    turb = {"flight": disturbances.Disturbances(turbulence=disturbances.PRESETS["flight"].turbulence)}
    for dist, lo, hi in ((False, 0.99, 1.0), (turb, 0.0, 0.5)):
        rec = fb.make_records([("flight", (0,))], disturbances=dist)[0]
        used = fb.run_one("gated", rec).accel_used[stable].mean()
        assert lo <= used <= hi
