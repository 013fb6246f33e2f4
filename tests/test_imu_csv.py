"""``imutherm attitude --imu-csv``: round trip in g and m/s², axes conventions, and bad logs refused."""

import json

import numpy as np
import pytest

from imutherm import InputError
from imutherm.cli.attitude import main
from imutherm.imu.imu_log import read_imu_csv, write_imu_csv
from imutherm.studies.attitude.recorded import log_filters
from imutherm.studies.attitude import filter_benchmark as fb


@pytest.fixture(scope="module")
def rec():
    return fb.make_records([("swing", (0,))])[0]  # 60 s, 100 Hz, 5 ms sync error, jitter


def _t(rec):
    return np.arange(len(rec.gyro)) * rec.dt + 12.5  # the log's clock need not start at 0


def test_round_trip_g_and_mps2_agree(tmp_path, rec, capsys):
    a = write_imu_csv(tmp_path / "a.csv", _t(rec), rec.gyro, rec.accel, roll=rec.roll, pitch=rec.pitch)
    b = write_imu_csv(tmp_path / "b.csv", _t(rec), rec.gyro, rec.accel, roll=rec.roll, pitch=rec.pitch,
                      gyro_units="deg/s", accel_units="g", axes="FLU")
    assert "accel_units: g" in b.read_text()
    out = {}
    for name, path in (("a", a), ("b", b)):
        assert main(["--imu-csv", str(path), "--platform", "aircraft", "--lever-arm", "0,0.03,0.05",
                     "--out", str(tmp_path / name)]) == 0
        out[name] = json.loads((tmp_path / name / "attitude.json").read_text())
    assert out["b"]["units"] == {"gyro": "deg/s", "accel": "g", "axes": "FLU"}
    assert set(out["a"]["filters"]) == set(log_filters()) and out["a"]["reference"] is True
    for n in log_filters():
        for k in ("roll_rms_deg", "pitch_rms_deg", "roll_max_deg", "pitch_max_deg", "accel_used_fraction"):
            assert out["a"]["filters"][n][k] == pytest.approx(out["b"]["filters"][n][k], rel=1e-6, abs=1e-6)
    # the same figures as the benchmark's own run of the record (same lever arm and turn radius, 100 Hz)
    gated = fb.score(fb.run_one("gated", rec), rec)
    assert out["a"]["filters"]["gated"]["roll_rms_deg"] == pytest.approx(gated["roll_rms_deg"], rel=1e-6)
    assert (tmp_path / "a" / "attitude.png").exists()
    assert "accelerometer used on" in capsys.readouterr().out


def test_arbitrary_rate_and_no_reference(tmp_path, rec):
    """Every other sample (50 Hz) with 1 % timestamp jitter and no reference column."""
    t = _t(rec)[::2] + np.random.default_rng(0).normal(0, 2e-4, len(rec.gyro[::2]))
    p = write_imu_csv(tmp_path / "c.csv", t, rec.gyro[::2], rec.accel[::2])
    assert main(["--imu-csv", str(p), "--platform", "aircraft", "--out", str(tmp_path / "c")]) == 0
    d = json.loads((tmp_path / "c" / "attitude.json").read_text())
    assert d["rate_hz"] == pytest.approx(50.0, rel=1e-3) and d["reference"] is False
    assert d["turn_radius_m"] == pytest.approx(1146.0)
    assert d["filters"]["gated"]["roll_rms_deg"] is None
    assert 0.1 < d["filters"]["gated"]["accel_used_fraction"] <= 1.0  # the gate opens at rest
    assert not (tmp_path / "c" / "attitude.png").exists()


def _good(tmp_path, rec, **kw):
    return write_imu_csv(tmp_path / "log.csv", _t(rec), rec.gyro, rec.accel, **kw)


def test_accel_in_g_declared_as_mps2_is_refused(tmp_path, rec):
    p = _good(tmp_path, rec, accel_units="g")
    text = p.read_text().replace("# accel_units: g\n", "")
    p.write_text(text)  # no declaration: the default m/s2
    with pytest.raises(InputError, match="looks like the accelerometer is in g"):
        read_imu_csv(p)
    assert read_imu_csv(p, accel_units="g").g_rest == pytest.approx(9.81, abs=0.05)
    assert main(["--imu-csv", str(p), "--out", str(tmp_path / "o")]) == 2
    assert not (tmp_path / "o").exists()
    with pytest.raises(InputError, match="header declares accel_units 'm/s2' but the option says 'g'"):
        read_imu_csv(_good(tmp_path, rec), accel_units="g")
    q = _good(tmp_path, rec)
    q.write_text(q.read_text().replace("# accel_units: m/s2\n", ""))
    with pytest.raises(InputError, match="looks like the accelerometer is in m/s"):
        read_imu_csv(q, accel_units="g")


def test_header_and_option_must_agree(tmp_path, rec):
    with pytest.raises(InputError, match="header declares gyro_units 'rad/s' but the option says 'deg/s'"):
        read_imu_csv(_good(tmp_path, rec), gyro_units="deg/s")
    with pytest.raises(InputError, match="axes 'XYZ' is unknown; valid: FRD, FLU, RFU"):
        read_imu_csv(_good(tmp_path, rec), axes="XYZ")


def test_gyro_in_deg_declared_as_rad_is_refused(tmp_path, rec):
    p = _good(tmp_path, rec, gyro_units="deg/s")
    p.write_text(p.read_text().replace("# gyro_units: deg/s\n", ""))
    with pytest.raises(InputError, match="looks like deg/s"):
        read_imu_csv(p)  # the 200 °/s swing read as 200 rad/s


def test_missing_columns_refused(tmp_path, rec):
    p = _good(tmp_path, rec)
    p.write_text(p.read_text().replace("accel_z", "acc_z"))
    with pytest.raises(InputError, match=r"column\(s\) accel_z missing; valid header: time_s,gyro_x"):
        read_imu_csv(p)
    q = _good(tmp_path, rec, roll=rec.roll, pitch=rec.pitch)
    q.write_text(q.read_text().replace("pitch_deg", "pitch"))
    with pytest.raises(InputError, match="reference column 'roll_deg' without its pair"):
        read_imu_csv(q)


def test_non_monotonic_time_and_gaps(tmp_path, rec):
    """Decreasing time refused naming the row; a gap of 0.2 s (20 median steps) bridged with a warning naming its
    row; one of 0.51 s refused naming the row and the rule, and bridged when --max-gap allows it."""
    t = _t(rec)
    t2 = t.copy()
    t2[500] = t2[498]
    p = write_imu_csv(tmp_path / "m.csv", t2, rec.gyro, rec.accel)
    with pytest.raises(InputError, match="time_s is not strictly increasing at row 506 .*rule: times increase"):
        read_imu_csv(p)
    cut = np.r_[0:3000, 3050:len(t)]  # 50 rows lost: the time column jumps 0.51 s, the motion went on
    t3 = t[cut]
    p = write_imu_csv(tmp_path / "g.csv", t3, rec.gyro[cut], rec.accel[cut])
    with pytest.raises(InputError, match=r"jumps 0.51 s .* after row 3005 .*rule: gaps over 5 median steps are "
                                         r"bridged up to 0.5 s; valid: --max-gap 0.6"):
        read_imu_csv(p)
    log = read_imu_csv(p, max_gap_s=0.6)
    assert log.gaps == ((3005, pytest.approx(t3[2999]), pytest.approx(0.51)),) and log.resampled
    assert log.t[-1] == pytest.approx(t3[-1] - t3[0]) and "bridged" in log.warnings[0]
    cut = np.r_[0:3000, 3018:len(t)]
    log = read_imu_csv(write_imu_csv(tmp_path / "s.csv", t[cut], rec.gyro[cut], rec.accel[cut]))
    assert len(log.gaps) == 1 and log.gaps[0][0] == 3005 and "after row 3005" in log.warnings[0]  # file lines
    assert main(["--imu-csv", str(p), "--max-gap", "-1", "--out", str(tmp_path / "o")]) == 2


def test_not_at_rest_or_non_numeric_refused(tmp_path, rec):
    p = write_imu_csv(tmp_path / "r.csv", _t(rec)[1500:], rec.gyro[1500:], rec.accel[1500:])  # starts mid-swing
    with pytest.raises(InputError, match="not at rest over the first 8 s"):
        read_imu_csv(p)
    q = _good(tmp_path, rec)
    lines = q.read_text().splitlines()
    lines[10] = lines[10].replace(",", ",x", 1)
    q.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match="row 11 is short or not numeric"):  # the file's line 11
        read_imu_csv(q)
    with pytest.raises(InputError, match="do not cover the 8 s leveling window"):
        read_imu_csv(write_imu_csv(tmp_path / "s.csv", _t(rec)[:300], rec.gyro[:300], rec.accel[:300]))


def test_cli_refuses_profile_and_csv_together(tmp_path, rec):
    p = _good(tmp_path, rec)
    assert main(["--imu-csv", str(p), "--profile", "swing", "--out", str(tmp_path / "x")]) == 2
    assert main(["--out", str(tmp_path / "y")]) == 2
    assert main(["--imu-csv", str(p), "--lever-arm", "1,2", "--out", str(tmp_path / "z")]) == 2


@pytest.fixture(scope="module")
def handheld():
    return fb.make_records([("handheld", (1,))])[0]  # comes to rest tilted by 35° and more, at most 190 °/s


def test_gyro_unit_off_by_180_over_pi_is_refused_both_ways(tmp_path, handheld):
    r = handheld
    t = np.arange(len(r.gyro)) * r.dt
    ok = write_imu_csv(tmp_path / "ok.csv", t, r.gyro, r.accel, gyro_units="deg/s")
    assert read_imu_csv(ok).units["gyro"] == "deg/s"  # declared right: passes the check
    p = write_imu_csv(tmp_path / "rad.csv", t, r.gyro, r.accel)  # rad/s data
    p.write_text(p.read_text().replace("# gyro_units: rad/s", "# gyro_units: deg/s"))
    with pytest.raises(InputError, match="it looks like the gyro is in rad/s: declare gyro_units rad/s"):
        read_imu_csv(p)
    q = write_imu_csv(tmp_path / "deg.csv", t, r.gyro, r.accel, gyro_units="deg/s")
    q.write_text(q.read_text().replace("# gyro_units: deg/s", "# gyro_units: rad/s"))
    with pytest.raises(InputError, match="looks like deg/s|looks like the gyro is in deg/s"):
        read_imu_csv(q)
