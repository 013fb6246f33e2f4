"""The measured-file reader: metadata, sparse cells, steady rows, and a refusal naming file and line for bad input."""

import math

import numpy as np
import pytest

from imutherm import InputError
from imutherm.measured import read_measured, write_measured

SITES = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z", "tp1", "tp2", "tp3")
SCHEMES = ("air", "grease", "potted")
GOOD = """# scheme = air
# ambient_C = 70
# power_scale = 0.9
# t_power_on_s = 10
# probe = surface_ir
time_s,tp1,gyro_x
10,70.0,70.1
310,85.0,
inf,90.0,81.0
"""


def _write(tmp_path, text, name="m.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_reads_metadata_sparse_cells_and_steady_row(tmp_path):
    r = read_measured(_write(tmp_path, GOOD), SITES, SCHEMES)
    assert (r.scheme, r.ambient_C, r.power_scale, r.t_power_on_s, r.probe) == ("air", 70.0, 0.9, 10.0, "surface_ir")
    assert r.sites == ("tp1", "gyro_x")
    np.testing.assert_array_equal(r.times_s, [0.0, 300.0, math.inf])  # since power-on
    assert math.isnan(r.values_C[1, 1]) and r.values_C[2, 0] == 90.0
    assert r.n_values == 5 and r.lines == (7, 8, 9)
    np.testing.assert_allclose(r.rise_K[2], [20.0, 11.0])


def test_round_trip(tmp_path):
    p = tmp_path / "w.csv"
    write_measured(p, {"scheme": "grease", "ambient_C": 25.0}, ("tp1", "tp2"), [0.0, 60.0, math.inf],
                   [[25.0, 25.0], [30.5, math.nan], [40.0, 33.0]])
    r = read_measured(p, SITES, SCHEMES)
    assert r.scheme == "grease" and r.ambient_C == 25.0
    np.testing.assert_allclose(r.values_C[[0, 2]], [[25.0, 25.0], [40.0, 33.0]])
    assert math.isnan(r.values_C[1, 1])


@pytest.mark.parametrize("change, message", [
    (lambda t: t.replace("tp1,gyro_x", "tp1,gyro_q"), r"m\.csv:6: unknown site column 'gyro_q'"),
    (lambda t: t.replace("310,85.0,", "5,85.0,"), r"m\.csv:8: time_s is not increasing"),
    (lambda t: t.replace("310,85.0,", "310,nan,"), r"m\.csv:8: column 'tp1' holds 'nan'"),
    (lambda t: t.replace("# scheme = air\n", ""), r"m\.csv: metadata '# scheme = \.\.\.' is missing"),
    (lambda t: t.replace("# ambient_C = 70\n", ""), r"metadata '# ambient_C = \.\.\.' is missing"),
    (lambda t: t.replace("scheme = air", "scheme = vacuum"), r"m\.csv:1: scheme 'vacuum' is not in the layout"),
    (lambda t: t.replace("310,85.0,", "310,85.0"), r"m\.csv:8: 2 cells, the header has 3"),
    (lambda t: t.replace("inf,90.0,81.0", "inf,90.0,81.0\n400,1,1"), r"m\.csv:10: time_s is not increasing"),
    (lambda t: t.replace("# probe = surface_ir", "# probe = thermocouple"), r"m\.csv:5: probe 'thermocouple'"),
    (lambda t: t.replace("# probe = surface_ir", "# colour = red"), r"m\.csv:5: unknown metadata key 'colour'"),
    (lambda t: t.replace("time_s,tp1", "t,tp1"), r"m\.csv:6: the first column must be 'time_s'"),
    (lambda t: t.replace("10,70.0,70.1", "10,abc,70.1"), r"m\.csv:7: column 'tp1': 'abc' is not a number"),
    (lambda t: t.split("time_s")[0], r"m\.csv: no header line"),
])
def test_refusals_name_file_and_line(tmp_path, change, message):
    with pytest.raises(InputError, match=message):
        read_measured(_write(tmp_path, change(GOOD)), SITES, SCHEMES)

