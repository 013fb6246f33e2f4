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
    for where in (text, report, printed):
        assert "Liu" not in where and "paper" not in where.lower()
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
