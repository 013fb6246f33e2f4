"""The sensor library (imu/sensor_library.toml): figures against their datasheet tables, the conversion to the
thermal error model's grade fields, the chip -> grade matching and the grade an imported site gets."""

import math
from statistics import median

import numpy as np
import pytest

from imutherm import InputError
from imutherm.imu import sensor_library as L
from imutherm.imu.grades import GRADES
from imutherm.imu.sensor_model import T_RANGE_C, draw_unit, load_grade

DEG = math.pi / 180.0
G0 = 9.80665

#: the chips issue 56 lists, as a board names them
ISSUE_CHIPS = ["ICM-42688-P", "ICM-42605", "ICM-45686", "ICM-20948", "ICM-20602", "MPU-6000", "MPU-6050", "MPU-6500",
               "MPU-9250", "BMI088", "BMI270", "BMI160", "BMX160", "BMI323", "LSM6DSO", "LSM6DSOX", "LSM6DSV16X",
               "LSM6DS3", "LSM9DS1", "ISM330DHCX", "ASM330LHH", "BNO055", "BNO085", "BNO086", "ADXL355", "ADIS16470",
               "ADIS16505"]


def fig(chip, part, key):
    return L.library()[chip][part][key]


def test_the_three_original_grades_unchanged():
    """adis16355 / adis16488 / ideal keep their numbers (imu/grades.py) and their load."""
    a = GRADES["adis16355"]
    assert (a["gyro"]["noise_rms_dps"], a["gyro"]["bias_temp_amplitude_dps"], a["accel"]["bias_temp_amplitude_mg"],
            a["accel"]["noise_rms_mg"], a["gyro"]["full_scale_dps"]) == (0.6, 0.6, 30.0, 3.5, 300.0)
    g = load_grade("adis16355")
    assert g.gyro.noise_density == pytest.approx(0.6 * DEG / 10.0)
    assert g.accel.bias_temp_amplitude == pytest.approx(30e-3 * G0)
    assert load_grade("adis16488").gyro.bias_instability == pytest.approx(5.1 / 3600.0 * DEG)
    ideal = load_grade("ideal")
    assert ideal.gyro.noise_density == 0.0 and ideal.accel.bias_temp_amplitude == 0.0
    assert "chip" not in a and "figures" not in GRADES["adis16488"]


def test_every_issue_chip_in_the_library_with_sources():
    for name in ISSUE_CHIPS:
        key = L.match_chip(name)
        assert key is not None, name
        g = GRADES[key]
        assert g["chip"] == key and load_grade(key).name == key
        for part in ("gyro", "accel", "chip"):
            for f, (v, src) in g["figures"][part].items():
                assert L.status(src) in ("checked", "recalled", "assumed"), (key, f, src)
                assert v is None or (math.isfinite(v) and v >= 0), (key, f, v)
    # every figure in the file says where it comes from
    for key, c in L.library().items():
        for part in ("gyro", "accel"):
            for f, d in c.get(part, {}).items():
                assert d["src"].startswith(("DS ", "recalled, not checked")), (key, part, f)


def test_invensense_mpu6000_against_ps_mpu_6000a_rev34():
    """MPU-6000/6050 Product Specification PS-MPU-6000A-00 rev 3.4, sections 6.1 (gyro) and 6.2 (accel)."""
    assert L.library()["mpu6000"]["datasheet"].endswith("PS-MPU-6000A-00 rev 3.4")
    assert fig("mpu6000", "gyro", "bias_change_dps")["v"] == 20.0          # ZRO variation -40..85 degC +-20 deg/s
    assert fig("mpu6000", "gyro", "bias_change_dps")["range_C"] == [-40.0, 85.0]
    assert fig("mpu6000", "gyro", "noise_density_dps_rthz")["v"] == 0.005  # rate noise spectral density
    assert fig("mpu6000", "gyro", "g_sensitivity_dps_per_g")["v"] == 0.1   # linear acceleration sensitivity
    assert fig("mpu6000", "accel", "bias_change_mg")["v"] == 35.0          # zero-g change 0..70 degC, x/y
    assert fig("mpu6000", "accel", "bias_change_mg")["range_C"] == [0.0, 70.0]
    assert fig("mpu6000", "accel", "sf_tempco_pct_per_C")["v"] == 0.02
    assert fig("mpu6000", "accel", "noise_density_ug_rthz")["v"] == 400.0
    assert L.library()["mpu6000"]["temp_lsb_C"]["v"] == pytest.approx(1 / 340, rel=1e-3)  # 340 LSB/degC
    g = GRADES["mpu6000"]
    assert g["counts"]["checked"] == 18 and g["counts"]["recalled"] == 0
    # the conversion rule: the ZRO change over -40..85 is the curve's peak over -40..70 (65 K from 25 degC both)
    assert g["gyro"]["bias_temp_amplitude_dps"] == pytest.approx(20.0)
    assert g["accel"]["bias_temp_amplitude_mg"] == pytest.approx(35.0 / 45.0 * 65.0)  # 0..70: 45 K from 25 degC
    assert g["accel"]["sf_temp_amplitude_ppm"] == pytest.approx(0.02e-2 * 65.0 * 1e6)
    assert g["gyro"]["sf_temp_amplitude_ppm"] == pytest.approx(2.0e-2 / 65.0 * 65.0 * 1e6)
    s = load_grade("mpu6000")
    assert s.gyro.noise_density == pytest.approx(0.005 / math.sqrt(2) * DEG)          # ARW = ND / sqrt 2
    assert s.accel.noise_density == pytest.approx(400e-6 * G0 / math.sqrt(2))
    assert s.gyro.g_sensitivity == pytest.approx(0.1 * DEG / G0)
    assert s.gyro.misalignment == pytest.approx(0.02) and s.accel.misalignment == pytest.approx(0.02)
    assert s.gyro.initial_bias == pytest.approx(20.0 * DEG) and s.accel.initial_sf == pytest.approx(0.03)
    assert s.gyro.full_scale == pytest.approx(2000.0 * DEG) and s.gyro.lsb == pytest.approx(2000 / 32768 * DEG)
    assert s.temp_sensor_lsb_C == pytest.approx(1 / 340, rel=1e-3)


def test_invensense_mpu9250_and_icm20948_tables():
    """MPU-9250 PS-MPU-9250A-01 rev 1.0 Tables 1-2; ICM-20948 DS-000189 rev 1.3 Table 2."""
    assert fig("mpu9250", "gyro", "bias_change_dps")["v"] == 30.0
    assert fig("mpu9250", "gyro", "sf_change_pct")["v"] == 4.0
    assert fig("mpu9250", "gyro", "noise_density_dps_rthz")["v"] == 0.01
    assert fig("mpu9250", "accel", "bias_tempco_mg_per_C")["v"] == 1.5
    assert fig("mpu9250", "accel", "sf_tempco_pct_per_C")["v"] == 0.026
    assert fig("mpu9250", "accel", "noise_density_ug_rthz")["v"] == 300.0
    assert GRADES["mpu9250"]["accel"]["bias_temp_amplitude_mg"] == pytest.approx(1.5 * 65.0)
    assert fig("icm20948", "accel", "bias_tempco_mg_per_C")["v"] == 0.80   # +-0.80 mg/degC, 0..85 degC
    assert GRADES["icm20948"]["accel"]["bias_temp_amplitude_mg"] == pytest.approx(0.80 * 65.0)
    assert fig("icm20948", "accel", "noise_density_ug_rthz")["v"] == 230.0
    assert fig("icm20948", "accel", "sf_tempco_pct_per_C")["v"] == 0.026
    # the MPU-6500 is the MPU-9250's die: its figures, said to be assumed
    assert GRADES["mpu6500"]["gyro"] == GRADES["mpu9250"]["gyro"]
    assert GRADES["mpu6500"]["counts"]["checked"] == 0
    assert all("same die as the MPU-9250" in s for _v, s in GRADES["mpu6500"]["figures"]["gyro"].values()
               if "median" not in s)
    # ICM-42688-P: the noise densities read on the datasheet's first page, the tempcos recalled
    assert L.status(fig("icm42688p", "gyro", "noise_density_dps_rthz")["src"]) == "checked"
    assert fig("icm42688p", "gyro", "noise_density_dps_rthz")["v"] == 0.0028
    assert L.status(fig("icm42688p", "gyro", "bias_tempco_dps_per_C")["src"]) == "recalled"


def test_bosch_bmi088():
    """BMI088 data sheet BST-BMI088-DS001-13 rev 1.3: +-24 g, +-2000 deg/s, 0.125 degC/LSB; tempcos recalled."""
    c = L.library()["bmi088"]
    assert "BST-BMI088-DS001-13" in c["datasheet"]
    assert fig("bmi088", "accel", "range_g")["v"] == 24.0 and fig("bmi088", "gyro", "range_dps")["v"] == 2000.0
    assert c["temp_lsb_C"]["v"] == 0.125
    assert L.status(fig("bmi088", "gyro", "bias_tempco_dps_per_C")["src"]) == "recalled"
    g = GRADES["bmi088"]
    assert g["gyro"]["bias_instability_dps"] == pytest.approx(2.0 / 3600.0)       # 2 deg/h (recalled)
    assert g["accel"]["lsb_mg"] == pytest.approx(24000 / 32768)
    assert g["gyro"]["bias_temp_amplitude_dps"] == pytest.approx(0.015 * 65.0)


def test_st_lsm6dso():
    """LSM6DSO DS12140 rev 2: +-16 g, +-2000 dps, ODR up to 6664 Hz (checked); tempcos recalled."""
    assert fig("lsm6dso", "gyro", "odr_max_hz")["v"] == 6664.0 and fig("lsm6dso", "accel", "range_g")["v"] == 16.0
    assert L.status(fig("lsm6dso", "gyro", "odr_max_hz")["src"]) == "checked"
    assert L.status(fig("lsm6dso", "accel", "bias_tempco_mg_per_C")["src"]) == "recalled"
    assert L.match_chip("LSM6DSO") == "lsm6dso" and L.match_chip("LSM6DSOXTR") == "lsm6dsox"


def test_analog_devices_adis16470_and_adxl355():
    """ADIS16470 Rev. C p.1: 0.008 deg/s/rtHz, in-run 8 deg/h, 13 ug: the model's density is the ARW, ND / sqrt 2
    (ADI's own ARW, 0.34 deg/rth, agrees).
    ADXL355 is an accelerometer only: its grade's gyros are the generic consumer grade's."""
    s = load_grade("adis16470")
    assert s.gyro.noise_density == pytest.approx(0.008 / math.sqrt(2) * DEG)
    assert s.gyro.noise_density == pytest.approx(0.34 / 60.0 * DEG, rel=0.01)           # ARW 0.34 deg/rth
    assert s.accel.bias_instability == pytest.approx(13e-6 * G0)
    assert s.gyro.bias_instability == pytest.approx(8.0 / 3600.0 * DEG)
    assert s.accel.noise_density == pytest.approx(0.037 / 60.0, rel=1e-9)            # VRW 0.037 m/s/rth
    assert GRADES["adxl355"]["gyro"]["bias_temp_amplitude_dps"] == \
        GRADES["generic_mems"]["gyro"]["bias_temp_amplitude_dps"]
    assert GRADES["adxl355"]["accel"]["noise_rms_mg"] == pytest.approx(22.5e-3 / math.sqrt(2) * 10.0)


def test_generic_is_the_consumer_median():
    consumer = [k for k, c in L.library().items() if c["class"] == "consumer" and "same_as" not in c]
    tcs = [L._given()[k]["gyro"]["bias_tc"][0] for k in consumer if "bias_tc" in L._given()[k]["gyro"]]
    assert len(tcs) >= 10
    assert GRADES["generic_mems"]["gyro"]["bias_temp_amplitude_dps"] == pytest.approx(median(tcs) * 65.0)
    nds = [L._given()[k]["accel"]["nd"][0] for k in consumer if "nd" in L._given()[k]["accel"]]
    assert GRADES["generic_mems"]["accel"]["noise_rms_mg"] == pytest.approx(median(nds) * 1e-3 / math.sqrt(2) * 10)


@pytest.mark.parametrize("chip", ["mpu6000", "icm42688p", "bmi088"])
def test_the_model_draws_the_chip_curves(chip):
    """The unit's bias and scale-factor curves peak at the chip's amplitudes x U(0.5, 1.5) over -40..70 degC."""
    unit = draw_unit(chip, np.random.default_rng(3))
    T = np.linspace(*T_RANGE_C, 221)[:, None].repeat(3, 1)
    for triad, spec in ((unit.gyro, unit.grade.gyro), (unit.accel, unit.grade.accel)):
        for curve, amp in ((triad.bias_T(T), spec.bias_temp_amplitude), (triad.sf_T(T), spec.sf_temp_amplitude)):
            peak = np.max(np.abs(curve), axis=0)
            assert np.all(peak >= 0.5 * amp * (1 - 1e-9)) and np.all(peak <= 1.5 * amp * (1 + 1e-9))


def test_combined_grade_and_unknown_grade():
    g = load_grade("bmi088+adxl355")
    assert g.gyro == load_grade("bmi088").gyro and g.accel == load_grade("adxl355").accel
    with pytest.raises(InputError, match="unknown grade 'nope'"):
        load_grade("nope")


# --------------------------------------------------------------------------- the grade follows the chip
import gzip  # noqa: E402
from pathlib import Path  # noqa: E402
from types import SimpleNamespace  # noqa: E402

from imutherm.imu import site_grades as SG  # noqa: E402

BOARDS = Path(__file__).resolve().parents[1] / "examples" / "boards"


def _import(tmp_path, name, ref, **kw):
    from imutherm.ecad.read import read_board
    from imutherm.ecad.to_layout import ImportOptions, import_board
    from imutherm.ecad.user_tables import read_electrical, read_value_csv

    path = tmp_path / f"{name}.kicad_pcb"
    path.write_bytes(gzip.decompress((BOARDS / f"{name}.kicad_pcb.gz").read_bytes()))
    el = read_electrical(BOARDS / "openuav_electrical.toml") if name == "openuav" else None
    opts = ImportOptions(powers=read_value_csv(BOARDS / f"{name}_powers.csv", "power_W"),
                         heights=read_value_csv(BOARDS / f"{name}_heights.csv", "height_mm"),
                         sites={ref: "imu"}, electrical=el, grade_rule=SG.site_grades, **kw)
    return import_board(read_board(path), opts)


def test_matching_aliases_and_footprints():
    assert [L.match_chip(v) for v in ("ICM42688P", "icm-42688-p", "MPU6050", "MPU-6000", "BMI088", "BMX160",
                                      "LSM6DSOXTR", "LSM6DSOTR", "LSM6DSV16XTR", "ISM330DHCXTR", "ADIS16470AMLZ")] == [
        "icm42688p", "icm42688p", "mpu6000", "mpu6000", "bmi088", "bmi160", "lsm6dsox", "lsm6dso", "lsm6dsv16x",
        "ism330dhcx", "adis16470"]
    assert L.match_chip("10k", "Package_LGA:Bosch_LGA-16_3x4.5mm_BMI088") == "bmi088"   # the footprint names it
    assert L.match_chip("STM32F405", "LQFP-64") is None and L.match_chip("", "") is None
    # siblings are not the chip: they get the generic grade (with its line) until they have an entry
    assert [L.match_chip(v) for v in ("BMI085", "MPU-9255", "LSM6DSL", "LSM6DS3TR-C", "LSM6DSO32", "ADIS16475",
                                      "ICM-20600", "ICM-20689")] == [None] * 8
    assert L.match_chip("ICM-42688-V") == "icm42688p" and L.match_chip("BNO086") == "bno085"


def test_grade_from_the_openuav_boards_icm42688p(tmp_path):
    """openuav (examples/boards, KiCad): U3 is an ICM-42688-P: every sensor site gets its grade, said in one line,
    and the study takes it."""
    r = _import(tmp_path, "openuav", "U3")
    assert {s.name: s.grade for s in r.spec.sites} == {s: "icm42688p" for s in
                                                       ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")}
    assert "site U3=imu: ICM-42688-P (TDK InvenSense ICM-42688-P Datasheet DS-000347 rev 1.7): grade icm42688p" \
        in r.notes
    assert 'grade = "icm42688p"' in r.text
    grade, lines = SG.study_grade(r.spec, None)
    assert grade == "icm42688p" and len(lines) == 2 and "DS-000347 rev 1.7" in lines[0]
    assert SG.study_grade(r.spec, "adis16488")[0] == "adis16488"   # --grade wins


def test_unknown_chip_gets_the_generic_grade(tmp_path):
    """drone-fc's U2 is an ICM-20689, not in the library: generic_mems, named in one line."""
    r = _import(tmp_path, "drone-fc", "U2")
    assert {s.grade for s in r.spec.sites if s.name.startswith(("gyro", "accel"))} == {"generic_mems"}
    line = next(n for n in r.notes if n.startswith("site U2=imu"))
    assert line == ("site U2=imu: unknown chip 'ICM-20689': generic consumer MEMS grade (generic_mems: the median of "
                    "the library's consumer chips); --grade U2=NAME names its grade")


def test_grade_option_overrides(tmp_path):
    assert SG.parse_grade_options(["BMI088"]) == {"*": "bmi088"}
    assert SG.parse_grade_options(["U2=icm20602", "U5=bmi088+adxl355"]) == {"U2": "icm20602", "U5": "bmi088+adxl355"}
    with pytest.raises(InputError, match="--grade: unknown grade 'nope'; valid: adis16355"):
        SG.parse_grade_options(["nope"])
    with pytest.raises(InputError, match="U2 is given twice"):
        SG.parse_grade_options(["U2=bmi088", "U2=icm20602"])
    r = _import(tmp_path, "drone-fc", "U2", grades={"U2": "icm20602"})
    assert {s.grade for s in r.spec.sites if s.name.startswith("gyro")} == {"icm20602"}
    assert any(n.startswith("site U2=imu: grade icm20602 (--grade; icm20602: ICM-20602") for n in r.notes)
    with pytest.raises(InputError, match="U9 is not a --site part"):
        _import(tmp_path, "drone-fc", "U2", grades={"U9": "icm20602"})


def test_import_cli_prints_the_grade(tmp_path, capsys):
    from imutherm.cli.import_board import main as import_main

    board = tmp_path / "drone-fc.kicad_pcb"
    board.write_bytes(gzip.decompress((BOARDS / "drone-fc.kicad_pcb.gz").read_bytes()))
    out = tmp_path / "fc.toml"
    assert import_main([str(board), "--powers", str(BOARDS / "drone-fc_powers.csv"), "--heights",
                        str(BOARDS / "drone-fc_heights.csv"), "--site", "U2=imu", "--grade", "mpu6000",
                        "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "note: site U2=imu: grade mpu6000 (--grade; mpu6000: MPU-6000/MPU-6050 (InvenSense" in text
    assert 'grade = "mpu6000"' in out.read_text()


def test_layout_site_grade_checked():
    from imutherm.ecad.to_layout import check_layout_text
    from imutherm.geometry.layout import load_layout, resolve_layout

    ref = load_layout("imu_reference")
    assert SG.study_grade(ref, None)[0] == "adis16355"     # the reference unit's sites name no grade
    text = resolve_layout("imu_reference").read_text()
    mixed = text.replace('gyro_x = { part = "gyro_x_die" }', 'gyro_x = { part = "gyro_x_die", grade = "bmi088" }') \
                .replace('accel_x = { part = "accel_x_die" }', 'accel_x = { part = "accel_x_die", grade = "ADXL355" }')
    spec = check_layout_text(mixed, "mixed.toml")
    grade, lines = SG.study_grade(spec, None)
    assert grade == "bmi088+adxl355" and lines[0].startswith("gyro sites gyro_x: grade bmi088: BMI088 (Bosch")
    assert load_grade(grade).accel == load_grade("adxl355").accel
    bad = text.replace('gyro_x = { part = "gyro_x_die" }', 'gyro_x = { part = "gyro_x_die", grade = "xyz" }')
    with pytest.raises(InputError, match="site 'gyro_x': field 'grade': unknown grade 'xyz'; valid"):
        SG.study_grade(check_layout_text(bad, "bad.toml"), None)  # the layout reads the name, the study checks it
    with pytest.raises(InputError, match="site 'gyro_x': field 'grade': 'x y' is not a grade name"):
        check_layout_text(bad.replace('"xyz"', '"x y"'), "bad.toml")


def test_compare_prints_the_grade_and_the_report_names_it(capsys):
    from imutherm.cli.compare import _study_config
    from imutherm.ecad.to_layout import check_layout_text
    from imutherm.geometry.layout import resolve_layout

    text = resolve_layout("imu_reference").read_text()
    for s in ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"):
        text = text.replace(f'{s} = {{ part = "{s}_die" }}', f'{s} = {{ part = "{s}_die", grade = "icm42688p" }}')
    spec = check_layout_text(text, "unit.toml")
    args = SimpleNamespace(run_model=(spec, None, None, None), grade=None, seeds=1, seed=0, out_of_range="linear",
                           profiles="flight", filter_defaults=False, filters=None)
    assert _study_config(args).grade == "icm42688p"
    out = capsys.readouterr().out
    assert "gyro sites gyro_x, gyro_y, gyro_z: grade icm42688p: ICM-42688-P (TDK InvenSense" in out
    summary = {"study": {"grade": "icm42688p"}, "sensor_grade": SG.grades_summary(spec, "icm42688p")}
    assert SG.grade_text(summary).startswith("grade icm42688p (icm42688p: ICM-42688-P (TDK InvenSense ICM-42688-P "
                                             "Datasheet DS-000347 rev 1.7); 4 figures read in the datasheet")
    assert SG.grade_text({"study": {"grade": "adis16355"}}) == "grade adis16355"   # an older summary.json


def test_docs_table_is_current():
    """docs/reference/sensor-library.md carries the generated table of the library as it is."""
    page = (Path(__file__).resolve().parents[1] / "docs" / "reference" / "sensor-library.md").read_text()
    assert L.markdown_table() in page


@pytest.mark.parametrize("chip", ["mpu6000", "mpu9250"])
def test_every_given_figure_moves_the_grade(chip):
    """The thermal error model uses every figure a chip gives: doubling any one changes the grade (the ODR, which
    only bounds the study's rate, is refused when below it)."""
    figs = L._fill(chip)
    ref = GRADES["adis16355"]
    base = L._grade(chip, chip, "", [], figs, ref)
    given = [(p, f) for p in ("gyro", "accel", "chip") for f, (_v, s) in figs[p].items() if L.status(s) == "checked"]
    assert len(given) >= 16
    for part, f in given:
        v, s = figs[part][f]
        changed = {p: dict(d) for p, d in figs.items()}
        if f == "odr_max_hz":
            changed[part][f] = (50.0, s)
            with pytest.raises(InputError, match="below the study's 100 Hz"):
                L._grade(chip, chip, "", [], changed, ref)
            continue
        changed[part][f] = (2.0 * v, s)
        other = L._grade(chip, chip, "", [], changed, ref)
        assert {k: other[k] for k in ("gyro", "accel", "temp_sensor_lsb_C")} != \
            {k: base[k] for k in ("gyro", "accel", "temp_sensor_lsb_C")}, (part, f)
