"""``imutherm solve`` and ``imutherm compare`` in-process on the reference unit (coarse mesh)."""

import csv
import json

import meshio
import numpy as np
import pytest

from imutherm.cli import main

COARSE = ["--mesh-size", "6", "--min-cells", "1"]
SITES = ["gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z", "tp1", "tp2", "tp3"]


@pytest.fixture(scope="module")
def transient(tmp_path_factory):
    out = tmp_path_factory.mktemp("solve") / "T"
    assert main(["solve", "--scheme", "grease", "--transient", "--t-end", "600", "--dt", "20", "--no-progress",
                 "--out", str(out)] + COARSE) == 0
    return out


def test_transient_result_json(transient):
    r = json.loads((transient / "result.json").read_text())
    assert r["scheme"] == "grease" and r["mode"] == "transient"
    for key in ("max_rise_K", "max_temperature_C", "hottest_part", "energy_balance_rel_error", "unknowns"):
        assert key in r
    assert r["max_temperature_C"] == pytest.approx(70.0 + r["max_rise_K"])
    assert set(r["sites"]) == set(SITES)
    for s in r["sites"].values():
        assert 0 < s["rise_K"] <= s["steady_rise_K"] + 1e-9  # heating up from ambient towards steady state
        assert 0 < s["t63_s"] < s["t95_s"] or s["t95_s"] is None
    assert r["energy_balance_rel_error"] < 1e-3
    assert r["steady_energy_balance_rel_error"] < 1e-6


def test_probes_csv_and_pvd(transient):
    with open(transient / "probes.csv") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["time_s"] + SITES
    data = np.array(rows[1:], float)
    assert data[0, 0] == 0 and data[-1, 0] == pytest.approx(600)
    assert np.allclose(data[0, 1:], 70.0)  # power-on from ambient
    assert np.all(np.diff(data[:, 0]) > 0)
    pvd = (transient / "field.pvd").read_text()
    assert "<Collection>" in pvd and pvd.count("<DataSet") == 11
    first = sorted(transient.glob("field*.vtu"))[0]
    mesh = meshio.read(first)
    assert "temperature_C" in mesh.point_data and "part" in mesh.cell_data


def test_steady_result_matches_energy_and_sites(tmp_path):
    out = tmp_path / "S"
    assert main(["solve", "--scheme", "air", "--out", str(out), "--site", "tp1", "--site", "gyro_z"] + COARSE) == 0
    r = json.loads((out / "result.json").read_text())
    assert list(r["sites"]) == ["tp1", "gyro_z"]
    assert sum(r["heat_out_W"].values()) == pytest.approx(r["power_W"], rel=1e-6)
    with open(out / "probes.csv") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["time_s", "tp1", "gyro_z"] and rows[1][0] == "inf"
    assert (out / "field.vtu").exists()


@pytest.mark.parametrize("args, message", [
    (["--transient", "--dt", "0"], "dt must be a finite number > 0"),
    (["--transient", "--dt", "-5"], "dt must be a finite number > 0"),
    (["--transient", "--t-end", "0"], "t_end must be a finite number > 0"),
    (["--transient", "--dt", "30", "--dt-max", "10"], "dt_max = 10.0 s must not be smaller than dt = 30.0 s"),
    (["--scheme", "foam"], "unknown scheme 'foam'"),
    (["--emissivity", "1.5"], "emissivity must be in [0, 1]"),
    (["--mount-conductance", "-3"], "must be a finite number >= 0"),
    (["--site", "gyro_w"], "unknown site(s) ['gyro_w']"),
])
def test_bad_input_one_line_no_files(tmp_path, capsys, args, message):
    out = tmp_path / "never"
    assert main(["solve", "--out", str(out)] + COARSE + args) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and err.strip().count("\n") == 0
    assert not out.exists() and not list(tmp_path.iterdir())


def test_compare_writes_the_report(tmp_path):
    out = tmp_path / "C"
    assert main(["compare", "--steady-only", "--no-progress", "--out", str(out)] + COARSE) == 0
    data = json.loads((out / "compare.json").read_text())
    assert list(data["schemes"]) == ["air", "grease", "potted"]
    rises = {s: r["max_rise_K"] for s, r in data["schemes"].items()}
    # the paper's ordering: air hottest, potted coolest
    assert rises["air"] > rises["grease"] > rises["potted"] > 0
    pdf = (out / "report.pdf").read_bytes()
    assert pdf[:5] == b"%PDF-" and len(pdf) > 30_000
