"""Heights without asking (issue 55 item 1): the KiCad library names quoted in the issue and the families it
names each get a height with its source; the sizes in a name are read wherever they stand; a part of no known
height gets an estimate by the stated rule, listed as such; ``--strict-heights`` refuses naming every such part;
``--heights-template`` writes them to fill in and reads back."""

from __future__ import annotations

import pytest

from imutherm import InputError
from imutherm.ecad.board import Footprint, Rect
from imutherm.ecad.heights import ESTIMATE, is_estimated, resolve_height
from imutherm.ecad.name_dims import name_dims
from imutherm.ecad.packages import package_class
from imutherm.ecad.read import read_board
from imutherm.ecad.to_layout import ImportOptions, import_board

from kicad_writer import kicad_board, part


def _height(library: str, ref: str = "U1", body=(4.0, 3.0), fields=None) -> tuple:
    fp = Footprint(ref, library, "v", "top", 0.0, 0.0, 0.0, None, None, (), fields or {})
    return resolve_height(fp, package_class(library), {}, Rect(0.0, 0.0, *body))


# (library name, height [mm], words of its source); the first eight are the names issue 55 quotes
LIBRARY_NAMES = [
    ("Diode_SMD:D_SMA", 2.44, "DO-214AC"),
    ("LED_THT:LED_D3.0mm", 5.8, "T-1 (3 mm)"),
    ("Crystal:Crystal_SMD_0603-2Pin_6.0x3.5mm", 1.5, "ceramic SMD crystals by size"),
    ("Inductor_SMD:L_10.4x10.4_H4.8", 4.8, "the footprint name: the name's H4.8"),
    ("Connector_USB:USB_Micro-AB_Molex_47590-0001", 3.0, "Molex 47346 2.5 mm, 47590"),
    ("TerminalBlock_MetzConnect:TerminalBlock_MetzConnect_Type101_RT01602HBWC_1x02_P5.00mm_Horizontal", 12.5,
     "Metz Type 101"),
    ("Package_SO:SOP-8_3.9x4.9mm_P1.27mm", 1.75, "sop.yaml: SOP-8_3.9x4.9mm overall height max 1.75"),
    ("Sensor_Motion:InvenSense_QFN-24_3x3mm_P0.4mm", 1.0, "JEDEC MO-220"),
    # the families issue 55 names
    ("Package_SO:SOP-8_5.28x5.23mm_P1.27mm", 2.16, "SOP-8_5.28x5.23mm overall height max 2.16"),
    ("Package_SO:SOP-4_3.8x4.1mm_P2.54mm", 2.24, "CPC1017N"),
    ("Diode_SMD:D_SOD-123", 1.35, "SOD-123"),
    ("Diode_SMD:D_SMB", 2.44, "DO-214AA"),
    ("Diode_SMD:D_SMC", 2.62, "DO-214AB"),
    ("Package_SO:SSOP-20_5.3x7.2mm_P0.65mm", 2.0, "MO-150"),
    ("Package_SO:TSSOP-16_4.4x5mm_P0.65mm", 1.2, "MO-153"),
    ("Package_SO:MSOP-10_3x3mm_P0.5mm", 1.1, "MO-187"),
    ("Package_DFN_QFN:DFN-8-1EP_3x3mm_P0.5mm_EP1.66x2.38mm", 1.0, "MO-229"),
    ("Vendor:TI_WQFN-16_3x3mm", 0.8, "profile W"),
    ("Package_LGA:Bosch_LGA-14_3x2.5mm_P0.5mm", 1.0, "LGA"),
    ("Capacitor_SMD:CP_Elec_5x5.4", 5.4, "can size D x L"),
    ("Capacitor_THT:CP_Radial_D10.0mm_P5.00mm", 16.0, "10 x 16"),
    ("Capacitor_THT:CP_Radial_D6.3mm_L11.0mm_P2.50mm", 11.0, "the footprint name's L<length>"),
    ("Capacitor_THT:C_Radial_D5.0mm_H7.0mm_P2.00mm", 7.0, "the name's H7.0"),
    ("Oscillator:Oscillator_SMD_Abracon_ASE-4Pin_3.2x2.5mm", 1.2, "3225 1.2"),
    ("Connector_USB:USB_C_Receptacle_GCT_USB4105-xx-A_16P_TopMnt_Horizontal", 3.5, "USB-C"),
    ("Connector_JST:JST_SH_BM04B-SRSS-TB_1x04-1MP_P1.00mm_Vertical", 4.25, "JST SH"),
    ("Connector_JST:JST_PH_B2B-PH-K_1x02_P2.00mm_Vertical", 6.0, "JST PH"),
    ("Connector_Molex:Molex_PicoBlade_53047-0410_1x04_P1.25mm_Vertical", 4.2, "PicoBlade"),
    ("Connector_PinSocket_2.54mm:PinSocket_1x08_P2.54mm_Vertical", 8.5, "Conn_PinSocket/parameters.yaml"),
    ("Connector_PinSocket_1.27mm:PinSocket_2x05_P1.27mm_Vertical", 4.6, "Conn_PinSocket/parameters.yaml"),
    ("Connector_PinHeader_2.54mm:PinHeader_1x04_P2.54mm_Horizontal", 4.1, "THT-1x2.54mm_Horizontal"),
    ("Button_Switch_THT:SW_PUSH_6mm_H5mm", 5.0, "the footprint name: the name's H5"),
    ("Button_Switch_SMD:SW_SPST_B3U-1000P", 1.6, "Omron B3U"),
    ("Button_Switch_SMD:SW_Push_1P1T_NO_CK_KMR2", 1.9, "cq_cuk_kmr2x.py"),
    ("Fuse:Fuse_1206_3216Metric", 1.8, "GRM31"),
    ("Fuse:Fuse_Littelfuse-NANO2-451_453", 3.8, "NANO2"),
    ("Buzzer_Beeper:Buzzer_12x9.5RM7.6", 9.5, "Buzzer_<diameter>x<height>"),
    ("RF_Module:ESP32-WROOM-32", 3.3, "ESP32-WROOM-32 3.1"),
    ("RF_GPS:ublox_NEO", 3.3, "NEO-M8 2.4"),
    ("Battery:BatteryHolder_Keystone_3034_1x20mm", 5.2, "CR2032"),
    ("LoaDy:CR2032_SMD", 5.2, "IEC 60086 name CRddhh"),
    ("Battery:BatteryHolder_Keystone_3008_1x2450", 7.0, "IEC 60086 name CRddhh"),
    ("Battery:BatteryHolder_Keystone_2460_1xAA", 16.0, "AA cell"),
    ("Battery:BatteryHolder_Keystone_2466_1xAAA", 12.5, "AAA cell"),
    ("Battery:BatteryHolder_Keystone_1042_1x18650", 22.0, "18650"),
    ("Fuse:Fuseholder_Clip-5x20mm_Littelfuse_111_Inline_P20.00x5.00mm_D1.17mm_Horizontal", 10.0, "fuse holders"),
    ("Connector_FFC-FPC:Hirose_FH12-24S-0.5SH_1x24-1MP_P0.50mm_Horizontal", 2.5, "FFC / FPC"),
    ("Connector_BarrelJack:BarrelJack_CUI_PJ-102AH_Horizontal", 11.0, "barrel jacks"),
    ("Relay_THT:Relay_SPDT_Omron-G5LE-1", 15.7, "G5LE"),
    ("Button_Switch_Keyboard:SW_Cherry_MX_1.00u_PCB", 11.6, "Cherry MX"),
    ("Inductor_SMD:L_Bourns-SRN6045TA", 4.5, "SSHH: size SS, height HH in 0.1 mm"),
    ("Inductor_SMD:L_Bourns-SRR1005", 5.0, "SSHH"),
    ("Inductor_SMD:L_Coilcraft_XAL1010-XXX", 10.0, "SSHH"),
    ("Inductor_SMD:L_Sunlord_MWSA0503S", 3.0, "SSHH"),
    ("Inductor_SMD:L_12x12mm_H6mm", 6.0, "the name's H6"),
    ("Inductor_SMD:L_1008_2520Metric", 2.5, "1008CS"),
    ("Crystal:Crystal_C26-LF_D2.1mm_L6.5mm_Horizontal", 2.1, "a cylinder lying down"),
    ("Package_TO_SOT_THT:TO-220-3_Vertical", 19.0, "TO-220AB"),
    ("Package_TO_SOT_THT:TO-220-3_Horizontal_TabDown", 4.7, "TO-220AB body thickness"),
    ("Package_TO_SOT_THT:TO-92_Inline", 8.0, "TO-92"),
    ("Package_DIP:DIP-8_W7.62mm", 5.33, "MS-001"),
    ("Package_TO_SOT_SMD:SOT-563", 0.6, "sub-millimetre SOT"),
    ("Package_TO_SOT_SMD:SOT-669_LFPAK", 1.2, "LFPAK56 1.1"),
    ("Package_TO_SOT_SMD:SC-59", 1.3, "SC-59 (SOT-346) 1.3"),
    ("Package_LCC:PLCC-44", 4.57, "MO-047"),
    ("LED_SMD:LED_PLCC-2", 1.9, "PLCC-2"),
    ("Resistor_THT:R_Axial_DIN0207_L6.3mm_D2.5mm_P7.62mm_Horizontal", 2.5, "a cylinder lying down"),
    ("Resistor_THT:R_Axial_Power_L20.0mm_W6.4mm_P22.40mm", 6.4, "an axial body lying down stands its width"),
    ("Capacitor_THT:CP_Axial_L10.0mm_D4.5mm_P15.00mm_Horizontal", 4.5, "a cylinder lying down"),
    ("LED_THT:LED_Rectangular_W5.0mm_H2.0mm", 8.6, "rectangular through-hole LEDs"),   # W x H: a face
]


@pytest.mark.parametrize("library, height, words", LIBRARY_NAMES, ids=[n for n, _, _ in LIBRARY_NAMES])
def test_library_names_get_a_height_with_its_source(library, height, words):
    h, source = _height(library)
    assert h == pytest.approx(height) and words in source and not is_estimated(source), source


def test_sizes_are_read_wherever_they_stand_in_a_name():
    """Body sizes, heights and diameters anywhere, not pitches, pad sizes, exposed pads or pin counts."""
    assert name_dims("Vendor_Prefix_L_7.3x7.3_H3.5_extra").height_mm == 3.5
    assert name_dims("Inductor_SMD:L_10.4x10.4_H4.8").body_mm == (10.4, 10.4)
    assert name_dims("MyLib:Sensor_5.0x3.0x1.1mm_P0.5mm").height_mm == 1.1
    assert name_dims("LED_THT:LED_D5.0mm").diameter_mm == 5.0
    qfn = name_dims("Package_DFN_QFN:QFN-24-1EP_4x4mm_P0.5mm_EP2.8x2.8mm")
    assert qfn.body_mm == (4.0, 4.0) and qfn.height_mm is None
    for no_body in ("Connector_PinHeader_2.54mm:PinHeader_2x20_P2.54mm_Vertical", "Resistor_SMD:R_Array_Convex_4x0603",
                    "Capacitor_SMD:C_0603_1608Metric_Pad1.05x0.95mm_HandSolder"):
        assert name_dims(no_body).body_mm is None and name_dims(no_body).height_mm is None, no_body
    # the package class is found anywhere, after any vendor prefix
    assert package_class("Sensor_Motion:InvenSense_QFN-24_3x3mm_P0.4mm").name == "QFN / DFN / SON"
    assert package_class("RP2350_60QFN_minimal:RP2350-QFN-60-1EP_7x7_P0.4mm").name == "QFN / DFN / SON"
    assert package_class("Package_TO_SOT_SMD:SOT-23-3").name == "SOT-23"
    assert package_class("Connector_Coaxial:SMA_Amphenol_132134_Vertical").kind == "connector"   # not a diode


def test_a_name_stating_an_impossible_height_is_estimated_instead():
    for name in ("Capacitor_SMD:CP_Elec_5x99999", "MyLib:L_5x5_H400", "Buzzer_Beeper:Buzzer_12x1000"):
        h, source = _height(name, "C1")
        assert is_estimated(source) and h <= 3.0, (name, source)


def test_a_damaged_files_endless_name_is_cut_before_matching():
    """Only the first 256 characters of a footprint name (and the last 256 of its library nickname) are matched,
    so a name of a million characters costs no more than a real one (no timed test: the cut is asserted)."""
    from imutherm.ecad.name_dims import MAX_NAME_CHARS, matched_name

    huge = "N" * 1_000_000 + ":" + "x" * 1_000_000 + "_QFN-24"
    assert len(matched_name(huge)) == 2 * MAX_NAME_CHARS + 1 and package_class(huge) is None
    assert package_class("Package_DFN_QFN:" + "x" * 200 + "_QFN-24").name == "QFN / DFN / SON"
    assert is_estimated(_height("SO-1" * 250_000)[1]) is False   # SOIC-like: the cut name still matches


def test_the_user_and_the_footprint_field_win_over_the_name():
    assert _height("Inductor_SMD:L_10.4x10.4_H4.8", fields={"Height_mm": "5.1"}) == (
        5.1, "the footprint's Height_mm field")
    fp = Footprint("L1", "Inductor_SMD:L_10.4x10.4_H4.8", "v", "top", 0.0, 0.0, 0.0, None, None, ())
    assert resolve_height(fp, None, {"L1": (6.0, "--height L1=6")}, Rect(0, 0, 1, 1)) == (6.0, "--height L1=6")


@pytest.mark.parametrize("ref, body, kind", [("U1", (5.0, 5.0), "ic"), ("U2", (30.0, 20.0), "ic"),
                                             ("J1", (8.0, 3.0), "connector"), ("J2", (40.0, 30.0), "connector"),
                                             ("R1", (1.0, 0.5), "passive"), ("L1", (6.0, 6.0), "inductor"),
                                             ("SW1", (4.0, 3.0), "electromechanical"), ("Q1", (3.0, 1.4), "discrete")])
def test_the_estimate_rule(ref, body, kind):
    """An unknown part's height: its kind's factor on the body's shorter side, within the kind's bounds; the source
    says so (and starts with 'estimated')."""
    factor, lo, hi, _ = ESTIMATE[kind]
    h, source = _height("MyLib:Unknown_Thing", ref, body)
    assert h == pytest.approx(min(max(factor * min(body), lo), hi), abs=0.005)
    assert is_estimated(source) and f"for a part of kind {kind}" in source and "Height_mm" in source


def _unknown_board(tmp_path, n=7):
    """A board with a powered SOIC and ``n`` 3 x 3 mm parts of an unknown library (each an estimated height,
    merged unless kept)."""
    parts = [part("U1", "Package_SO:SOIC-8_3.9x4.9mm", (105, 105, 0), fields={"Power_W": "0.2"})]
    parts += [part(f"U{10 + i}", f"MyLib:Mystery{i}", (110 + 5 * (i % 4), 112 + 6 * (i // 4), 0),
                   fab=(-1.5, -1.5, 1.5, 1.5))
              for i in range(n)]
    path = tmp_path / "unknown.kicad_pcb"
    path.write_text(kicad_board(parts))
    return path


def test_estimated_heights_are_listed_in_the_notes_and_the_layout(tmp_path):
    r = import_board(read_board(_unknown_board(tmp_path)), ImportOptions(keep=frozenset({"U10"})))
    u10 = next(d for d in r.decisions if d.footprint.ref == "U10")
    assert u10.fate == "modelled" and u10.height_mm == pytest.approx(1.5) and is_estimated(u10.height_source)
    note = next(n for n in r.notes if n.startswith("ESTIMATED heights of 7 parts"))
    assert "U10 1.5 mm, U11 1.5 mm (merged)" in note
    assert "height 1.5 mm ESTIMATED (no height found): estimated: 0.5 x" in r.text
    assert "# heights ESTIMATED (no height in the footprint, its name or the package tables; imutherm.ecad.heights): " \
           "U10 1.5 mm, U11 1.5 mm," in r.text
    comp = next(c for c in r.spec.components if c.name == "U10")
    assert is_estimated(comp.height_source) and not is_estimated(
        next(c for c in r.spec.components if c.name == "U1").height_source)


def test_strict_heights_refuses_listing_every_part(tmp_path):
    with pytest.raises(InputError) as exc:
        import_board(read_board(_unknown_board(tmp_path)), ImportOptions(strict_heights=True))
    msg = str(exc.value)
    assert "\n" not in msg and "no height found for 7 parts" in msg
    assert all(f"U{10 + i} (MyLib:Mystery{i}" in msg for i in range(7))   # all of them, not five


def test_the_heights_template_round_trip(tmp_path, capsys):
    from imutherm.cli.import_board import main as import_main

    board, template, out = _unknown_board(tmp_path), tmp_path / "heights.csv", tmp_path / "u.toml"
    args = [str(board), "--out", str(out), "--heights-template", str(template), "--strict-heights"]
    assert import_main(args) == 2 and not out.exists()   # refused, but the template is written first
    assert "no height found for 7 parts" in capsys.readouterr().err
    text = template.read_text()
    assert text.count("estimated (replace with the datasheet height)") == 7 and "# U13: 'MyLib:Mystery3'" in text
    # passed back unedited: still estimates, so still refused
    assert import_main([str(board), "--out", str(out), "--heights", str(template), "--strict-heights"]) == 2
    capsys.readouterr()
    # filled in with the datasheet's heights: accepted, each height and its source kept
    filled = text.replace("estimated (replace with the datasheet height)", "Mystery datasheet")
    filled = filled.replace(",1.5,", ",0.9,")
    template.write_text(filled)
    assert import_main([str(board), "--out", str(out), "--heights", str(template), "--strict-heights"]) == 0
    printed = capsys.readouterr().out
    assert "ESTIMATED" not in printed and "7 from the user" in printed and out.exists()


def test_estimated_heights_reach_the_reports_parameters_page(tmp_path):
    """The study summary carries each estimated height with its rule; the parameters page lists them."""
    from imutherm.reports.study_report import estimated_height_lines
    from imutherm.studies.end_to_end.summary import estimated_heights

    r = import_board(read_board(_unknown_board(tmp_path)), ImportOptions(keep=frozenset({"U10"})))
    est = estimated_heights(r.spec)
    assert list(est) == ["U10"] and est["U10"][0] == pytest.approx(1.5) and is_estimated(est["U10"][1])
    lines = estimated_height_lines({"estimated_heights": est})
    assert lines[0].startswith("  height of U10 1.5 mm ESTIMATED (estimated: 0.5 x the body's shorter side")
    assert estimated_height_lines({}) == []


@pytest.mark.parametrize("case", ["exists", "is_out", "no_folder"])
def test_a_bad_heights_template_path_is_refused_in_one_line(tmp_path, capsys, case):
    from imutherm.cli.import_board import main as import_main

    board, out = _unknown_board(tmp_path), tmp_path / "u.toml"
    existing = tmp_path / "h.csv"
    existing.write_text("keep me")
    template = {"exists": existing, "is_out": out, "no_folder": tmp_path / "nowhere" / "h.csv"}[case]
    assert import_main([str(board), "--out", str(out), "--heights-template", str(template)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("imutherm import: error: --heights-template") and "\n" not in err, err
    assert not out.exists() and existing.read_text() == "keep me"
