"""A user's own unit (issue 56 items 3-5): reference data belongs to a layout, a grease scheme that bonds the parts
that set the hot spot and the sensor temperatures, the import's memory estimate with the cavity exchange.

The imported unit is examples/boards/openuav (KiCad 7, 80 footprints, ICM-42688-P at U3) through the import API,
on a coarse mesh (6 mm, one cell through thin parts) and a short power-on so the suite stays fast.
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import numpy as np
import pytest

from imutherm import InputError
from imutherm.cli.compare import main as compare_main
from imutherm.ecad.read import read_board
from imutherm.ecad.to_layout import ImportOptions, import_board
from imutherm.ecad.user_tables import read_electrical, read_value_csv
from imutherm.geometry.layout import load_layout
from imutherm.unit.grease_choice import import_unit

BOARDS = Path(__file__).resolve().parents[1] / "examples" / "boards"
COARSE = ["--mesh-size", "6", "--min-cells", "1", "--t-end", "500", "--no-progress", "--jobs", "1"]


def _pdf_text(path) -> str:
    from pypdf import PdfReader

    return "\n".join(p.extract_text() for p in PdfReader(path).pages)


def _openuav(folder: Path, extra: str = "") -> Path:
    """openuav imported with its powers, heights, electrical design and IMU site; ``extra`` appended to the TOML."""
    board = folder / "openuav.kicad_pcb"
    board.write_bytes(gzip.decompress((BOARDS / "openuav.kicad_pcb.gz").read_bytes()))
    opts = ImportOptions(powers=read_value_csv(BOARDS / "openuav_powers.csv", "power_W"),
                         heights=read_value_csv(BOARDS / "openuav_heights.csv", "height_mm"), sites={"U3": "imu"},
                         electrical=read_electrical(BOARDS / "openuav_electrical.toml"))
    out = folder / "openuav.toml"
    out.write_text(import_board(read_board(board), opts).text + extra)
    return out


@pytest.fixture(scope="module")
def imported_study(tmp_path_factory):
    """The end-to-end study of the imported unit (one scheme, one seed, one filter): its folder and printout."""
    folder = tmp_path_factory.mktemp("user-unit")
    layout = _openuav(folder)
    out = folder / "out"
    import contextlib
    import io

    buf = io.StringIO()
    with contextlib.redirect_stdout(buf):
        assert compare_main([str(layout), *COARSE, "--schemes", "air", "--seeds", "1", "--profiles", "flight",
                             "--filters", "gated", "--no-mesh-error", "--out", str(out)]) == 0
    return out, buf.getvalue()


def test_an_imported_unit_carries_no_paper_figures(imported_study):
    out, printed = imported_study
    text = (out / "summary.json").read_text()
    s = json.loads(text)
    assert "paper" not in s and "reference" not in s
    report = _pdf_text(out / "report.pdf")
    for where in (text, report, printed):   # (a sensor grade's source may cite a datasheet-quoting paper: not these)
        assert "Liu" not in where and "paper_targets" not in where and "paper's" not in where
    # the paper's figures by value: 16 / 8 / 4 K simulated, > 20 K and 800 s measured
    assert "scheme1_air_max_rise_K" not in text and "no_grease_near_steady_s" not in text
    assert "against the paper" not in report and "paper vs this model" not in report.lower()


def test_the_reference_unit_declares_the_paper():
    from imutherm.studies.compare import paper_thermal, thermal_table
    from imutherm.studies.paper import layout_paper

    ref = load_layout("imu_reference")
    assert ref.reference_data.source.startswith("Liu et al. 2012")
    assert layout_paper(ref)["thermal"]["simulated"]["scheme1_air_max_rise_K"] == 16.0
    assert paper_thermal(ref)["simulated_max_rise_K"] == {"air": 16.0, "grease": 8.0, "potted": 4.0}
    # the card-guide unit is another design: the paper's figures are not its figures
    assert layout_paper(load_layout("imu_cardguide")) is None and paper_thermal(load_layout("imu_cardguide")) is None
    summary = {"max_rise_K": 10.0, "hottest_part": "u", "sites": {"tp1": {"rise_K": 5.0, "t95_s": 300.0}},
               "gyro_spread_K": 0.1, "accel_spread_K": 0.2, "energy_balance_rel_error": 1e-9}
    cols, rows = thermal_table({"paper": paper_thermal(ref), "schemes": {"air": summary}})
    assert "paper sim.\n[K]" in cols and rows[0][cols.index("paper sim.\n[K]")] == "16"
    assert rows[0][cols.index("paper meas.\nsettle [s]")] == "800"
    cols, rows = thermal_table({"schemes": {"air": summary}})
    assert not any("paper" in c for c in cols) and len(rows[0]) == len(cols) == 10


BENCH = """# scheme = air
# ambient_C = 25
time_s,gyro_x
100,{early}
inf,{steady}
"""


def test_a_bench_file_is_set_beside_the_model(tmp_path):
    """A user's own bench readings declared in the layout: the comparison at the reading's time and site."""
    from imutherm.studies.paper import bench_comparison, bench_lines

    (tmp_path / "bench_air.csv").write_text(BENCH.format(early=27.0, steady=29.5))
    layout = _openuav(tmp_path, '\n[reference_data]\nsource = "our bench, thermocouple on U3"\n'
                                'measured = ["bench_air.csv"]\n')
    lay = load_layout(layout)
    names = [s.name for s in lay.sites]
    amb = lay.ambient_C
    t = np.array([0.0, 200.0, 400.0])
    T = amb + np.outer([0.0, 2.0, 3.0], np.ones(len(names)))   # the model's rise: 1 K at 100 s, 3 K settled
    b = bench_comparison(lay, {"air": (names, t, T)})
    assert b["source"] == "our bench, thermocouple on U3" and b["files"] == ["bench_air.csv"]
    (early, steady) = b["rows"]
    assert early["site"] == "gyro_x" and early["time_s"] == 100.0
    assert early["measured_K"] == pytest.approx(2.0) and early["model_K"] == pytest.approx(1.0)
    assert steady["time_s"] is None and steady["model_K"] == pytest.approx(3.0)
    assert steady["difference_K"] == pytest.approx(3.0 - 4.5)
    assert "bench at 25 C, model at 70 C ambient" in steady["note"]
    lines = bench_lines(b)
    assert lines[0].startswith("your reference data (our bench") and "RMS difference" in lines[-1]
    # a scheme the model did not run is said, not compared
    b = bench_comparison(lay, {"potted": (names, t, T)})
    assert b["rows"] == [] and b["not_compared"] == ["bench_air (scheme air not run)"]
    # declared nothing: no comparison
    assert bench_comparison(load_layout("imu_cardguide"), {"air": (names, t, T)}) is None


def test_compare_prints_and_reports_the_bench_readings(tmp_path, capsys):
    (tmp_path / "bench_air.csv").write_text(BENCH.format(early=72.0, steady=74.0).replace("= 25", "= 70"))
    layout = _openuav(tmp_path, '\n[reference_data]\nsource = "our bench, thermocouple on U3"\n'
                                'measured = ["bench_air.csv"]\n')
    out = tmp_path / "out"
    assert compare_main([str(layout), *COARSE, "--thermal-only", "--schemes", "air", "--no-mesh-error",
                         "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    data = json.loads((out / "compare.json").read_text())
    assert "paper" not in data and data["reference"]["rows"][-1]["measured_K"] == pytest.approx(4.0)
    assert "your reference data (our bench, thermocouple on U3): 2 readings" in printed
    assert "Liu" not in printed and "paper" not in printed
    report = _pdf_text(out / "report.pdf")
    assert "Your reference data beside this model" in report and "bench_air.csv" in report and "Liu" not in report


@pytest.mark.parametrize("table, words", [
    ('paper_figures = "liu2012"', "'source' is required"),
    ('source = "x"', "declares nothing"),
    ('source = "x"\nmeasured = ["nope.csv"]', "measured 'nope.csv': file not found"),
    ('source = "x"\nfigures = "liu2012"', "unknown field(s) ['figures']"),
])
def test_a_bad_reference_data_table_is_refused_in_one_line(tmp_path, table, words):
    path = tmp_path / "unit.toml"
    path.write_text(Path(load_layout("imu_cardguide").path).read_text() + f"\n[reference_data]\n{table}\n")
    with pytest.raises(InputError, match=r"\[reference_data\]") as exc:
        load_layout(path)
    assert words in str(exc.value) and "\n" not in str(exc.value)


# ------------------------------------------------------------------ item 4: a grease scheme that does its job
def _grease_board(tmp_path):
    """A 50 x 40 mm board without copper pours: four 0.2 W chips in 10 x 10 mm QFPs, a 0.09 W diode in a SOD-323
    (9.1 % of the power, the hottest part in air: +46 K against the chips' +23 K at a 6 mm mesh), a 0.1 W regulator
    on the bottom right under the IMU, the IMU (3 mW)."""
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from kicad_writer import kicad_board, part

    qfp = "Package_QFP:LQFP-64_10x10mm_P0.5mm"
    chips = [f"U{4 + i}" for i in range(4)]
    parts = [part("U1", "Package_LGA:LGA-14_3x2.5mm_P0.5mm", (135, 125, 0), fab=(-1.5, -1.25, 1.5, 1.25)),
             *[part(ref, qfp, (*xy, 0), fab=(-5, -5, 5, 5)) for ref, xy in
               zip(chips, ((108, 108), (108, 130), (121, 108), (121, 130)))],
             part("D1", "Diode_SMD:D_SOD-323", (143, 106, 0), fab=(-0.85, -0.65, 0.85, 0.65)),
             part("U3", "Package_TO_SOT_SMD:SOT-223-3_TabPin2", (135, 125, 0), side="bottom",
                  fab=(-3.25, -1.75, 3.25, 1.75))]
    path = tmp_path / "g.kicad_pcb"
    path.write_text(kicad_board(parts, outline=(100.0, 100.0, 150.0, 140.0)))
    powers = {"U1": (0.003, "t"), "D1": (0.09, "t"), "U3": (0.1, "t"), **{c: (0.2, "t") for c in chips}}
    heights = {"U1": (0.9, "t"), "D1": (1.0, "t"), "U3": (1.8, "t"), **{c: (1.6, "t") for c in chips}}
    return read_board(path), powers, heights


def test_the_grease_scheme_bonds_the_parts_that_set_the_hot_spot_and_the_sensor(tmp_path):
    board, powers, heights = _grease_board(tmp_path)
    r = import_unit(board, ImportOptions(powers=powers, heights=heights, sites={"U1": "imu"}))
    grease = r.spec.schemes["grease"]
    # the diode (9 % of the power) sets the hot spot; the bottom-side regulator under the IMU its temperature
    assert grease.move_to_back == ("D1",) and grease.bond_in_place == ("U3",)   # not the 0.2 W chips, not the IMU
    assert sum(p[0] for p in powers.values()) * 0.1 > powers["D1"][0]
    note = next(n for n in r.notes if n.startswith("grease scheme: the parts chosen"))
    assert "D1 (" in note and "U3 (" in note and "--grease" in note
    assert "U3 where they are (bottom side)" in grease.description or "U3 where" in grease.description
    from imutherm.geometry.build import build_geometry

    geo = build_geometry(r.spec, "grease")
    bond = geo.part("U3_bond")
    assert bond.lo[2] == pytest.approx(geo.part("housing").hole[0][2])   # from the cavity floor (the base) ...
    assert bond.hi[2] == pytest.approx(geo.part("U3").lo[2])             # ... to the regulator where it is
    # bonded, the hot spot and the sensor run cooler than in air (the rule's point)
    from imutherm.studies.thermal.thermal_study import run_scheme

    air, gr = (run_scheme(r.spec, s, mesh_size_mm=6, min_cells=1).metrics for s in ("air", "grease"))
    # (the diode's heat leaves mostly through its leads; the grease touches its moulded body)
    assert air.max_part == "D1_die" and gr.max_rise_K < air.max_rise_K - 2.0
    assert gr.probe_rise_K["gyro_x"] < air.probe_rise_K["gyro_x"] - 1.0
    # --grease chooses instead: the diode alone, the regulator left where it is, unbonded
    r = import_unit(board, ImportOptions(powers=powers, heights=heights, sites={"U1": "imu"}, grease=("D1",)))
    assert r.spec.schemes["grease"].move_to_back == ("D1",) and r.spec.schemes["grease"].bond_in_place == ()


# ------------------------------------------------------------ item 4: the memory estimate with the cavity exchange
def test_the_import_memory_estimate_holds_the_cavity_exchange_within_30_percent(tmp_path):
    """drone-fc (not among the boards the constants were measured on), the air scheme at a coarse mesh with 3 mm
    cavity patches, so the s2s exchange is a good part of the peak: the estimate against the peak resident memory of
    ``imutherm solve`` in a process of its own (measured by a parent that runs nothing else)."""
    import subprocess
    import sys
    from dataclasses import replace

    from imutherm.studies.cost import solve_memory
    from imutherm.unit.model import ModelOptions

    board = tmp_path / "drone-fc.kicad_pcb"
    board.write_bytes(gzip.decompress((BOARDS / "drone-fc.kicad_pcb.gz").read_bytes()))
    opts = ImportOptions(powers=read_value_csv(BOARDS / "drone-fc_powers.csv", "power_W"),
                         heights=read_value_csv(BOARDS / "drone-fc_heights.csv", "height_mm"), sites={"U2": "imu"},
                         grease=())
    layout = tmp_path / "drone.toml"
    layout.write_text(import_board(read_board(board), opts).text)
    est = solve_memory(load_layout(layout), "air", 4.0, 1, replace(ModelOptions(), cavity_patch_mm=3.0))
    assert est["patches"] > 1000 and est["exchange_bytes"] > 0.3 * est["bytes"]
    cmd = [sys.executable, "-m", "imutherm.cli", "solve", str(layout), "--scheme", "air", "--mesh-size", "4",
           "--min-cells", "1", "--cavity-patch-mm", "3", "--out", str(tmp_path / "out")]
    probe = ("import resource, subprocess, sys; subprocess.run(sys.argv[1:], check=True, capture_output=True); "
             "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)")
    peak = int(subprocess.run([sys.executable, "-c", probe, *cmd], check=True, capture_output=True,
                              text=True).stdout.split()[-1]) * 1024   # kB on Linux
    assert abs(est["bytes"] - peak) <= 0.3 * peak, (est, peak)


def test_the_import_prints_the_exchange_in_its_estimate():
    from imutherm.cli.import_board import _estimate

    text = _estimate(load_layout("imu_reference"))
    assert "of it the cavity exchange" in text and "patches" in text and "potted" in text


def test_a_part_that_cannot_be_bonded_is_said_with_why_and_grease(tmp_path, capsys):
    """The hot part sits over the standoff under a mounting hole: it cannot move to the back. The import's notes and
    the air scheme's description (the report's page of the unit) say so and name --grease."""
    import sys

    sys.path.insert(0, str(Path(__file__).parent))
    from kicad_writer import kicad_board, part

    hole = lambda ref, x, y: part(ref, "MountingHole:MountingHole_3.2mm_M3", (x, y, 0), fab=None,  # noqa: E731
                                  pads=[("", "np_thru_hole", 0, 0, 3.2, 3.2)], attr=("exclude_from_bom",))
    parts = [hole("H1", 104, 104), hole("H2", 136, 104), hole("H3", 104, 126), hole("H4", 136, 126),
             part("U1", "Package_SO:SOIC-8_3.9x4.9mm", (136.0, 126.0, 0), fab=(-2, -2.5, 2, 2.5)),
             part("U2", "Package_SO:SOIC-8_3.9x4.9mm", (120.0, 115.0, 0), fab=(-2, -2.5, 2, 2.5))]
    path = tmp_path / "holes.kicad_pcb"
    path.write_text(kicad_board(parts))
    r = import_unit(read_board(path), ImportOptions(powers={"U1": (0.3, "t"), "U2": (0.05, "t")}))
    said = [n for n in r.notes if n.startswith("grease scheme: U1 cannot be bonded")]
    assert said and "standoff under H4" in said[0] and "--grease" in said[0]
    assert "grease" not in r.spec.schemes
    air = r.spec.schemes["air"].description
    assert "No grease scheme" in air and "U1" in air and "--grease" in air
    # and compare's printout says it too
    layout = tmp_path / "holes.toml"
    layout.write_text(r.text)
    assert compare_main([str(layout), "--steady-only", "--schemes", "air", "--mesh-size", "6", "--min-cells", "1",
                         "--no-progress", "--no-mesh-error", "--jobs", "1", "--out", str(tmp_path / "out")]) == 0
    printed = capsys.readouterr().out
    assert "air scheme: " in printed and "U1 cannot be bonded" in printed and "--grease" in printed


def test_a_bad_bench_file_is_refused_before_any_solve(tmp_path, capsys):
    (tmp_path / "bench_air.csv").write_text("# scheme = air\n# ambient_C = 70\ntime_s,no_such_site\ninf,75\n")
    layout = _openuav(tmp_path, '\n[reference_data]\nsource = "our bench"\nmeasured = ["bench_air.csv"]\n')
    assert compare_main([str(layout), *COARSE, "--thermal-only", "--out", str(tmp_path / "out")]) == 2
    printed = capsys.readouterr()
    assert "bench_air.csv" in printed.err and "no_such_site" in printed.err
    assert "s2s cavity law" not in printed.out   # refused before the cost checks and solves
