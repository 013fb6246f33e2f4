"""What real boards legitimately have, written by the test one case at a time (issue 55 items 2, 3 and 5): each
imports, and the import says what it did. Boards from ``tests/kicad_writer.py``; the shared real boards are in
``tests/test_import_boards.py``, the bad input in ``tests/test_hostile_inputs.py``."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imutherm import InputError
from imutherm.ecad.outline_loops import chain, inside
from imutherm.ecad.read import read_board
from imutherm.ecad.to_layout import ImportOptions, import_board

from kicad_writer import kicad_board, part

SOIC = "Package_SO:SOIC-8_3.9x4.9mm"
R0603 = "Resistor_SMD:R_0603_1608Metric"


def _board(tmp_path, parts, name="b.kicad_pcb", **kw):
    path = tmp_path / name
    path.write_text(kicad_board(parts, **kw))
    return read_board(path)


def _fates(result) -> dict:
    return {d.footprint.ref: (d.fate, d.reason) for d in result.decisions}


# ------------------------------------------------------------------ item 2: the stack-up and the copper layers
def test_dielectric_sublayers_are_summed(tmp_path):
    """A dielectric of two sublayers (KiCad's 'add sublayer') counts both: 0.976 mm, as the board states
    (before: the first sublayer only, 0.746 mm, and a refusal)."""
    stack = [("F.Mask", "Top Solder Mask", 0.01), ("F.Cu", "copper", 0.035), ("dielectric 1", "core", [0.3, 0.13]),
             ("In1.Cu", "copper", 0.035), ("dielectric 2", "prepreg", [0.321, 0.1]), ("B.Cu", "copper", 0.035),
             ("B.Mask", "Bottom Solder Mask", 0.01)]
    board = _board(tmp_path, [part("U1", SOIC, (110, 105, 0))], copper=3, stackup=stack, thickness=0.976)
    assert board.thickness_mm == pytest.approx(0.976) and board.notes == ()
    assert board.copper_um == pytest.approx((35.0, 35.0, 35.0))


@pytest.mark.parametrize("dialect", ["kicad5", "kicad7", "kicad9"])
def test_renamed_copper_layers_keep_every_pad(tmp_path, dialect):
    """Outer copper named C1F / C4B: KiCad 5 writes those names on every pad, KiCad 6+ keep the user's name in
    the layer table only. A part without fab or courtyard takes its body from its pads on either (before: every
    pad lost on KiCad 5, then 'no fab outline, courtyard or pads')."""
    pads = [("1", "smd", -1.5, 0, 1.0, 2.0), ("2", "smd", 1.5, 0, 1.0, 2.0)]
    parts = [dict(part("U1", "Vendor:ChipNoFab", (110, 105, 0), pads=pads), fab=None),
             dict(part("U2", SOIC, (120, 115, 90), side="bottom"))]
    stack = [("F.Cu", "copper", 0.018), ("dielectric 1", "core", 0.5), ("In1.Cu", "copper", 0.035),
             ("dielectric 2", "prepreg", 0.5), ("In2.Cu", "copper", 0.035), ("dielectric 3", "core", 0.5),
             ("B.Cu", "copper", 0.07)]   # KiCad names the stack-up's layers canonically, whatever the table says
    board = _board(tmp_path, parts, dialect=dialect, copper=4, copper_names=("C1F", "C2", "C3", "C4B"), stackup=stack,
                   thickness=1.658)
    u1, u2 = board.footprints
    assert len(u1.pads) == 2 and len(u2.pads) == 2 and (u1.side, u2.side) == ("top", "bottom")
    assert board.copper_um == pytest.approx((18.0, 35.0, 35.0, 70.0)) and board.notes == ()
    r = import_board(board, ImportOptions(powers={"U1": (0.1, "t")}, heights={"U1": (1.0, "t")}))
    assert _fates(r)["U1"][0] == "modelled" and r.decisions[0].body.width == pytest.approx(4.0)


# ------------------------------------------------------------------ item 2: panels, parts outside the outline
def _panel_text(dialect="kicad7") -> str:
    """Two copies of a 30 x 20 mm board (same references, as KiKit's copies have) joined by a 3 mm tab with mouse
    bites at both ends (KiKit's NPTH footprints: 0.5 mm holes, 0.8 mm apart, 0.25 mm inside each board), a
    fiducial on the tab, and a part left outside the panel."""
    pts = [(100, 100), (130, 100), (130, 108.5), (140, 108.5), (140, 100), (170, 100), (170, 120), (140, 120),
           (140, 111.5), (130, 111.5), (130, 120), (100, 120)]
    edge = "\n".join(f'  (gr_line (start {a[0]} {a[1]}) (end {b[0]} {b[1]}) (layer "Edge.Cuts") (width 0.05))'
                     for a, b in zip(pts, pts[1:] + pts[:1]))
    parts = []
    for k, x0 in enumerate((100, 140)):
        parts += [part("U1", SOIC, (x0 + 10, 110, 0), fields={"Power_W": "0.2"}),
                  part("U2", "Package_LGA:LGA-14_3x2.5mm_P0.5mm", (x0 + 20, 105, 0), fab=(-1.5, -1.25, 1.5, 1.25))]
        for i in range(5):   # bites along the tab's end at this board
            x = 129.75 if k == 0 else 140.25
            parts.append(dict(part(f"KiKit_MB_{k}_{i}", "kikit:NPTH", (x, 108.6 + 0.7 * i, 0), fab=None,
                                   pads=[("", "np_thru_hole", 0, 0, 0.5, 0.5, 0.5)]), attr=()))
    parts.append(dict(part("FID1", "Fiducial:Fiducial_1mm_Mask2mm", (135, 110, 0), pads=[("1", "smd", 0, 0, 1, 1)])))
    parts.append(part("U9", SOIC, (200, 110, 0)))
    return kicad_board(parts, dialect=dialect, outline=None, extra=edge)


def test_a_panel_models_the_board_holding_the_site(tmp_path):
    path = tmp_path / "panel.kicad_pcb"
    path.write_text(_panel_text())
    r = import_board(read_board(path), ImportOptions(sites={"U2": "imu"}))
    fates = {(d.footprint.ref, round(d.footprint.x)): (d.fate, d.reason) for d in r.decisions}
    assert r.board.width_mm == pytest.approx(30.0) and r.board.height_mm == pytest.approx(20.0)
    assert fates[("U1", 10)][0] == "modelled" and fates[("U2", 20)][0] == "modelled"   # the left copy: top left
    assert fates[("U1", 50)] == ("skipped", "on another board of the panel")
    assert sum(reason == "on the panel's frame" for _, reason in fates.values()) == 1    # the tab's fiducial
    assert all(reason in ("on another board of the panel", "outside the board outline") or "mouse bites" in reason
               for (ref, _), (_, reason) in fates.items() if ref.startswith("KiKit"))
    assert fates[("U9", 100)] == ("skipped", "outside the board outline")
    assert [n for n in r.notes if n.startswith("the file holds 2 boards and a frame")]
    assert sum(c.power_W for c in r.spec.components) == pytest.approx(0.2)   # one copy's power, not two


def test_a_site_on_another_board_of_the_panel_is_refused_in_one_line(tmp_path):
    text = _panel_text().replace('"U2"', '"U7"', 1)   # the first copy's sensor renamed: U2 only on the second
    path = tmp_path / "panel.kicad_pcb"
    path.write_text(text)
    r = import_board(read_board(path), ImportOptions(sites={"U2": "imu"}))   # the board holding U2 is chosen
    assert {d.footprint.ref for d in r.decisions if d.fate == "modelled"} == {"U1", "U2"}
    assert r.board.footprints[[d.footprint.ref for d in r.decisions].index("U2")].x == pytest.approx(20.0)
    with pytest.raises(InputError, match=r"--site U[27]: not on the board modelled \(on another board of the panel\)"):
        import_board(read_board(path), ImportOptions(sites={"U2": "imu", "U7": "probe"}))


def test_overhanging_edge_parts_are_kept_and_cut_at_the_edge(tmp_path):
    """A USB receptacle 1.5 mm past the right edge and a horizontal header past the bottom: kept, cut at the
    board's edge, the note giving the footprint's position (not its body centre)."""
    usb = part("J1", "Connector_USB:USB_C_Receptacle_HRO_TYPE-C-31-M-12", (137.5, 115, 90), fab=(-4.5, -3.6, 4.5, 3.6))
    hdr = part("J2", "Connector_PinHeader_2.54mm:PinHeader_1x04_P2.54mm_Horizontal", (115, 127, 0),
               fab=(-5, -1.5, 5, 4.5))
    r = import_board(_board(tmp_path, [usb, hdr, part("U1", SOIC, (110, 110, 0))]),
                     ImportOptions(powers={"U1": (0.1, "t")}, heights={"J1": (3.2, "t"), "J2": (2.5, "t")},
                                   keep=frozenset({"J1", "J2"}), exact=True))
    comps = {c.name: c for c in r.spec.components}
    assert comps["J1"].size_mm[:2] == pytest.approx((7.2 - 1.1, 9.0))    # 7.2 wide, 1.1 mm past x = 140 cut off
    notes = [n for n in r.notes if "overhangs" in n]
    assert notes[0].startswith("J1 at (37.50, 15.00) mm: its body overhangs the board's right edge by 1.10 mm")
    assert notes[1].startswith("J2 at (15.00, 3.00) mm: its body overhangs the board's bottom edge by 1.50 mm")
    assert all("kept, cut at the edge" in n for n in notes)


def test_a_part_left_outside_the_board_is_skipped_and_its_power_said_left_out(tmp_path):
    r = import_board(_board(tmp_path, [part("U1", SOIC, (110, 110, 0)), part("U9", SOIC, (200, 110, 0))]),
                     ImportOptions(powers={"U1": (0.1, "t"), "U9": (0.2, "t")}))
    assert _fates(r)["U9"] == ("skipped", "outside the board outline")
    assert "--power U9: not on the board modelled (outside the board outline): left out" in r.notes
    assert sum(c.power_W for c in r.spec.components) == pytest.approx(0.1)


# ------------------------------------------------------------------ item 2: overlaps by design
def _switch_and_led(led_power):
    """A key switch (14 x 14 mm body) with a reverse-mount LED in its middle, as keyboards place them."""
    sw = part("SW1", "Button_Switch_Keyboard:SW_Cherry_MX_1.00u_PCB", (115, 115, 0), fab=(-7, -7, 7, 7),
              pads=[("1", "thru_hole", -3.8, -2.5, 2.2, 2.2, 1.5), ("2", "thru_hole", 2.5, -5.1, 2.2, 2.2, 1.5)])
    led = part("D1", "LED_SMD:LED_1206_3216Metric_ReverseMount", (115, 110, 0), fab=(-1.6, -0.8, 1.6, 0.8),
               fields={"Power_W": str(led_power)} if led_power else None)
    return [sw, led, part("U1", SOIC, (130, 105, 0))]


def test_a_part_inside_another_by_design_is_merged_and_noted(tmp_path):
    opts = ImportOptions(powers={"U1": (0.1, "t")}, heights={"SW1": (11.6, "Cherry MX")}, keep=frozenset({"D1"}))
    r = import_board(_board(tmp_path, _switch_and_led(0)), ImportOptions(powers={"U1": (0.1, "t")},
                                                                        heights={"SW1": (11.6, "Cherry MX")}))
    assert _fates(r)["D1"] == ("merged", "unpowered, body 3.2 x 1.6 mm <= 10 mm^2")   # small: merged anyway
    r = import_board(_board(tmp_path, _switch_and_led(0)), opts)   # kept, but unpowered inside the switch: both
    assert _fates(r)["D1"][0] == "modelled" and _fates(r)["SW1"][0] == "merged"    # ... the switch gives way
    r = import_board(_board(tmp_path, _switch_and_led(0.03)), replace_keep(opts))
    assert _fates(r)["D1"][0] == "modelled" and _fates(r)["SW1"][0] == "merged"
    assert _fates(r)["SW1"][1].startswith("around D1's body")
    note = next(n for n in r.notes if "as placed by design" in n)
    assert note.startswith("SW1 at (15.00, 15.00) mm lies around D1's body on the top side (100 % of D1's area)")


def replace_keep(opts):
    return ImportOptions(powers=opts.powers, heights=opts.heights)


def test_crossing_fab_outlines_are_trimmed(tmp_path):
    a = part("J1", "Vendor:ConnA", (110, 110, 0), fab=(-3, -2, 3, 2))
    b = part("J2", "Vendor:ConnB", (115.5, 110, 0), fab=(-3, -2, 3, 2))   # 0.5 mm into J1
    r = import_board(_board(tmp_path, [a, b, part("U1", SOIC, (130, 120, 0))]),
                     ImportOptions(powers={"U1": (0.1, "t"), "J2": (0.01, "t")},
                                   heights={"J1": (3.0, "t"), "J2": (3.0, "t")}, keep=frozenset({"J1"}), exact=True))
    comps = {c.name: c for c in r.spec.components}
    assert comps["J1"].size_mm[0] == pytest.approx(5.5) and comps["J2"].size_mm[0] == pytest.approx(6.0)
    assert any("J1's trimmed by 0.50 mm to meet J2's" in n for n in r.notes)


# ------------------------------------------------------------------ item 2: mounting holes and standoffs
def test_a_hole_without_a_body_is_a_mounting_hole_whatever_its_name(tmp_path):
    holes = [dict(part(f"H{i}", "", (x, y, 0), fab=None, pads=[("1", "thru_hole", 0, 0, 5.6, 5.6, 3.2)]), attr=())
             for i, (x, y) in enumerate(((104, 104), (136, 126)), 1)]
    wire = dict(part("J5", "", (120, 104, 0), fab=None, pads=[("1", "thru_hole", 0, 0, 2.4, 2.4, 1.3)]), attr=())
    r = import_board(_board(tmp_path, holes + [wire, part("U1", SOIC, (120, 115, 0))]),
                     ImportOptions(powers={"U1": (0.1, "t")}))
    fates = _fates(r)
    assert fates["H1"] == ("skipped", "mounting hole (a 3.2 mm hole without a body: a standoff is placed under it)")
    assert fates["J5"] == ("skipped", "one pad and no body outline: a wire or test pad")
    standoffs = [p for p in r.spec.parts if p.name.startswith("standoff")]
    assert len(standoffs) == 2


def test_standoffs_of_a_d_shaped_board_stand_inside_its_outline(tmp_path):
    """No mounting hole, a D-shaped outline (flat left side, a half circle of 20 mm radius on the right): the
    corner standoffs move inside the outline (before: at the bounding box's corners, off the board)."""
    arc = "(gr_arc (start 120 100) (mid 140 120) (end 120 140) (layer \"Edge.Cuts\") (width 0.05))"
    lines = "\n".join(f'  (gr_line (start {a[0]} {a[1]}) (end {b[0]} {b[1]}) (layer "Edge.Cuts") (width 0.05))'
                      for a, b in (((120, 140), (100, 140)), ((100, 140), (100, 100)), ((100, 100), (120, 100))))
    board = _board(tmp_path, [part("U1", SOIC, (115, 120, 0))], outline=None, extra=f"  {arc}\n{lines}")
    r = import_board(board, ImportOptions(powers={"U1": (0.1, "t")}))
    loops, _ = chain(board.outline)
    x0, y0 = r.spec.boards[0].min_mm[:2]
    for s in (p for p in r.spec.parts if p.name.startswith("standoff")):
        xs = np.array([s.min_mm[0], s.min_mm[0] + s.size_mm[0]]) - x0
        ys = np.array([s.min_mm[1], s.min_mm[1] + s.size_mm[1]]) - y0
        gx, gy = np.meshgrid(xs, ys)
        assert inside(loops, gx, gy).all(), s.name
    assert any("moved along the diagonals to lie inside its outline" in n for n in r.notes)


# ------------------------------------------------------------------ item 3: powers from dissipation only
def test_power_ratings_are_never_read_as_dissipations(tmp_path):
    """Fifteen resistors with an Altium-style POWER = 0.1W rating and one regulator with its dissipation in a
    Pd field: the board dissipates 0.046 W, not 1.546 W; the printout names the rating fields left out."""
    parts = [part(f"R{i}", R0603, (102 + 2 * i, 125, 0), fab=(-0.8, -0.4, 0.8, 0.4), fields={"POWER": "0.1W"})
             for i in range(1, 16)]
    parts.append(part("U1", "Package_TO_SOT_SMD:SOT-223-3_TabPin2", (120, 110, 0), fab=(-3.25, -1.75, 3.25, 1.75),
                      fields={"Pd": "46mW", "Power Rating": "1W"}))
    r = import_board(_board(tmp_path, parts), ImportOptions())
    assert sum(c.power_W for c in r.spec.components) == pytest.approx(0.046)
    u1 = next(d for d in r.decisions if d.footprint.ref == "U1")
    assert u1.power_source == "the footprint's Pd field"
    assert "R1, R2, R3" in next(n for n in r.notes if "field POWER is a power rating" in n)
    assert any(n.startswith("U1: field Power Rating is a power rating") for n in r.notes)


@pytest.mark.parametrize("text, watts", [("0.046", 0.046), ("46mW", 0.046), ("46 mW", 0.046), ("0,046 W", 0.046),
                                         ("150uW", 150e-6), ("", None), ("see datasheet", None)])
def test_dissipation_field_values(text, watts):
    from imutherm.ecad.power_fields import power_from_fields

    value, source, note = power_from_fields("U1", {"Dissipation": text})
    assert value == (pytest.approx(watts) if watts is not None else None)
    assert ("left out" in note) == (text == "see datasheet")


# ------------------------------------------------------------------ item 5: what is unusual, said
def test_a_stack_up_of_kicad_default_dielectrics_is_said_and_modelled_at_1_6_mm(tmp_path):
    """Four copper layers and KiCad's 2-layer default dielectric (1.51 mm) three times: 4.69 mm in all."""
    stack = [("F.Mask", "Top Solder Mask", 0.01), ("F.Cu", "copper", 0.035), ("dielectric 1", "core", 1.51),
             ("In1.Cu", "copper", 0.035), ("dielectric 2", "prepreg", 1.51), ("In2.Cu", "copper", 0.035),
             ("dielectric 3", "core", 1.51), ("B.Cu", "copper", 0.035), ("B.Mask", "Bottom Solder Mask", 0.01)]
    board = _board(tmp_path, [part("U1", SOIC, (110, 105, 0))], copper=4, stackup=stack, thickness=4.69)
    assert board.thickness_mm == 1.6
    assert board.notes == ("the stack-up repeats KiCad's default 1.51 mm dielectric (a 2-layer board's) 3 times and "
                           "sums to 4.690 mm: a stack-up never set; modelled at KiCad's default 1.6 mm (set the "
                           "dielectrics in KiCad's Board Setup > Physical Stackup)",)


def test_a_thick_board_and_a_copper_count_that_disagrees_are_said(tmp_path):
    thick = [("F.Cu", "copper", 0.035), ("dielectric 1", "core", 3.93), ("B.Cu", "copper", 0.035)]
    board = _board(tmp_path, [part("U1", SOIC, (110, 105, 0))], copper=2, stackup=thick, thickness=4.0)
    assert board.thickness_mm == pytest.approx(4.0)
    assert board.notes == ("the board is 4.000 mm thick, thicker than the usual boards (up to 3.2 mm): taken as the "
                           "stack-up says",)
    many = [("F.Cu", "copper", 0.035)] + [row for i in range(1, 100) for row in
                                          ((f"dielectric {i}", "prepreg", 0.005), (f"In{i}.Cu", "copper", 0.005))]
    many += [("dielectric 100", "core", 0.3), ("B.Cu", "copper", 0.035)]   # 101 copper layers in the stack-up
    board = _board(tmp_path, [part("U1", SOIC, (110, 105, 0))], copper=4, stackup=many, thickness=1.36)
    assert board.copper_layers == 4 and board.copper_um == pytest.approx((35.0, 5.0, 5.0, 35.0))
    assert board.notes[0].startswith("the stack-up lists 101 copper layers, the layer table 4 (the layers that carry "
                                     "copper): the table's 4 modelled")


def test_edge_snapping_never_moves_a_powered_part_and_says_what_it_moved(tmp_path):
    """Two parts without a die 0.3 mm from a chip's edge line: the unpowered one snaps to it and is listed with
    its move; the powered one (5 mW, too little for a die of its own) keeps its exact body."""
    chip = part("U1", SOIC, (110, 110, 0), fab=(-2, -2.5, 2, 2.5))
    soft = part("J1", "Vendor:Conn", (120.3, 115, 0), fab=(-3, -2, 3, 2))     # left edge 117.3 ... no line near
    led = part("D1", "Vendor:Lamp", (112.3, 120, 0), fab=(-2, -1.5, 2, 1.5))   # left edge 110.3, 0.3 past U1's centre
    r = import_board(_board(tmp_path, [chip, soft, led]),
                     ImportOptions(powers={"U1": (0.3, "t"), "D1": (0.005, "t")},
                                   heights={"J1": (3.0, "t"), "D1": (1.0, "t")}, keep=frozenset({"J1"})))
    comps = {c.name: c for c in r.spec.components}
    assert comps["D1"].size_mm[:2] == pytest.approx((4.0, 3.0))   # exact
    note = next(n for n in r.notes if "snapped" in n)
    assert "J1 " in note and "D1" not in note and "powered parts and sites never are" in note


@pytest.mark.parametrize("value, fields, words", [
    ("DNP", {}, "value 'DNP'"), ("10k DNF", {}, "value '10k DNF'"), ("do not fit", {}, "value 'do not fit'"),
    ("NP", {}, "value 'NP'"), ("ADXL355", {"Populate": "No"}, "field Populate = 'No'"),
    ("ADXL355", {"DNI": "DNI"}, "field DNI = 'DNI'"), ("ADXL355", {"Config": "DNP"}, "field Config = 'DNP'")])
def test_do_not_populate_parts_are_skipped_with_their_reason(tmp_path, value, fields, words):
    parts = [part("U2", SOIC, (120, 110, 0), value=value, fields=fields), part("U1", SOIC, (110, 110, 0))]
    r = import_board(_board(tmp_path, parts), ImportOptions(powers={"U1": (0.1, "t")}))
    assert _fates(r)["U2"] == ("skipped", f"marked do-not-populate ({words})")


def test_values_that_only_look_like_dnp_are_kept(tmp_path):
    parts = [part("U2", SOIC, (120, 110, 0), value="NPN_BC847"), part("Q1", SOIC, (130, 110, 0), value="DNPX12"),
             part("U1", SOIC, (110, 110, 0))]
    r = import_board(_board(tmp_path, parts), ImportOptions(powers={"U1": (0.1, "t")}))
    assert _fates(r)["U2"][0] != "skipped" and _fates(r)["Q1"][0] != "skipped"


def test_an_empty_height_field_is_no_height_given(tmp_path):
    parts = [part("U1", SOIC, (110, 110, 0), fields={"Height_mm": "", "Power_W": "0.1"})]
    r = import_board(_board(tmp_path, parts), ImportOptions())
    assert r.decisions[0].height_mm == pytest.approx(1.75) and "SOIC" in r.decisions[0].height_source


def test_duplicate_references_are_told_apart_and_refused_only_when_named(tmp_path):
    parts = [part("U4", SOIC, (110, 110, 0), fields={"Power_W": "0.02"}),
             part("U4", SOIC, (125, 110, 0), fields={"Power_W": "0.02"}), part("U1", SOIC, (110, 122, 0))]
    board = _board(tmp_path, parts)
    r = import_board(board, ImportOptions(powers={"U1": (0.1, "t")}))
    assert {c.name for c in r.spec.components} == {"U1", "U4", "U4_2"}
    assert any(n.startswith("duplicate references on the board: U4 (2 footprints)") for n in r.notes)
    with pytest.raises(InputError, match=r"U4 is a duplicate reference: 2 footprints carry it \(at \(10.00, 20.00\) "
                                         r"mm; \(25.00, 20.00\) mm\)"):
        import_board(board, ImportOptions(powers={"U1": (0.1, "t")}, sites={"U4": "imu"}))


def test_control_characters_in_values_and_fields_make_valid_toml(tmp_path):
    parts = [part("U1", SOIC, (110, 110, 0), value="AB\x7fC", fields={"Power_W": "0.1", "Note": "x\x1by"})]
    r = import_board(_board(tmp_path, parts), ImportOptions())
    assert r.spec.components[0].name == "U1" and "\x7f" not in r.text


def test_an_outline_that_does_not_close_is_its_rectangle_and_said(tmp_path):
    text = kicad_board([part("U1", SOIC, (110, 110, 0))]).replace("(end 100.0 100.0)", "(end 100.0 100.5)")
    path = tmp_path / "gap.kicad_pcb"
    path.write_text(text)
    r = import_board(read_board(path), ImportOptions(powers={"U1": (0.1, "t")}))
    assert math.isclose(r.board.width_mm, 40.0) and any("does not close" in n for n in r.notes)
