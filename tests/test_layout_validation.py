"""Every kind of bad layout fails early with one clear message naming file, part and field."""

import pytest

from imutherm import InputError
from imutherm.geometry.build import build_geometry
from imutherm.geometry.layout import load_layout


def comp(d, name):
    return next(c for c in d["components"] if c["name"] == name)


def part(d, name):
    return next(c for c in d["parts"] if c["name"] == name)


CASES = {
    "overlap": (lambda d: comp(d, "accel_y").__setitem__("center_mm", [44.0, 16.5]),
                None, ["part 'accel_x'", "overlaps part 'accel_y'"]),
    "outside_cavity": (lambda d: part(d, "standoff_1").__setitem__("min_mm", [1.0, 4.5, 3.0]),
                       None, ["part 'standoff_1'", "outside the cavity"]),
    "off_board": (lambda d: comp(d, "adc").__setitem__("center_mm", [60.0, 6.5]),
                  None, ["component 'adc'", "'center_mm'", "leaves board 'main'"]),
    "zero_size": (lambda d: comp(d, "processor").__setitem__("size_mm", [14.0, 0.0, 1.6]),
                  None, ["component 'processor'", "'size_mm'", "> 0"]),
    "negative_size": (lambda d: d["boards"][1].__setitem__("size_mm", [-1.6, 38.0, 14.0]),
                      None, ["board 'xboard'", "'size_mm'", "> 0"]),
    "unknown_material": (lambda d: comp(d, "adc").__setitem__("material", "unobtainium"),
                         None, ["component 'adc'", "'material'", "unknown material 'unobtainium'", "valid:", "copper"]),
    "negative_power": (lambda d: comp(d, "reg_5v").__setitem__("power_W", -0.4),
                       None, ["component 'reg_5v'", "'power_W'", ">= 0"]),
    "non_finite": (lambda d: d["housing"].__setitem__("wall_mm", float("nan")),
                   None, ["[housing]", "'wall_mm'", "finite"]),
    "infinite_position": (lambda d: part(d, "standoff_2").__setitem__("min_mm", [float("inf"), 4.5, 3.0]),
                          None, ["part 'standoff_2'", "'min_mm'", "finite"]),
    "duplicate_name": (lambda d: comp(d, "accel_y").__setitem__("name", "accel_x"),
                       None, ["duplicate name 'accel_x'"]),
    "reserved_name": (lambda d: part(d, "standoff_1").__setitem__("name", "housing"),
                      None, ["duplicate name 'housing'"]),
    "unknown_scheme": (None, "foam", ["unknown scheme 'foam'", "valid: air, grease, potted"]),
    "unknown_scheme_in_file": (lambda d: d["schemes"].__setitem__("foam", {"fill": "air"}),
                               None, ["scheme 'foam'", "unknown scheme", "valid: air, grease, potted"]),
    "unknown_key": (lambda d: comp(d, "gyro_z").__setitem__("colour", "red"),
                    None, ["components[", "unknown key(s) 'colour'", "valid:", "power_W"]),
    "unknown_top_key": (lambda d: d.__setitem__("enviroment", {"ambient_C": 70.0}),
                        None, ["unknown key(s) 'enviroment'", "valid:", "environment"]),
    "unknown_board": (lambda d: comp(d, "gyro_y").__setitem__("board", "zboard"),
                      None, ["component 'gyro_y'", "'board'", "unknown board 'zboard'", "main"]),
    "missing_field": (lambda d: comp(d, "adc").pop("power_W"), None, ["component 'adc'", "'power_W'", "required"]),
    "bond_gap_too_large": (lambda d: d["schemes"]["grease"].__setitem__("max_bond_gap_mm", 0.5),
                           "grease", ["scheme 'grease'", "'processor'", "max_bond_gap_mm"]),
    "die_too_big": (lambda d: comp(d, "gyro_z").__setitem__("die_mm", [8.0, 3.0, 0.3]),
                    None, ["component 'gyro_z'", "'die_mm'", "does not fit"]),
    "bad_site_part": (lambda d: d["sites"].__setitem__("gyro_q", {"part": "gyro_q_die"}),
                      None, ["site 'gyro_q'", "'part'", "unknown part 'gyro_q_die'"]),
    "unknown_mounting_kind": (lambda d: d["mounting"].__setitem__("kind", "bolted"),
                              None, ["[mounting]", "'kind'", "unknown value 'bolted'", "valid: fixture, free"]),
    # containers of the wrong TOML type: a clear message, not AttributeError / TypeError
    "sites_not_a_table": (lambda d: d.__setitem__("sites", 3),
                          None, ["layout", "field 'sites'", "must be a table of named sites", "got int 3"]),
    "schemes_not_a_table": (lambda d: d.__setitem__("schemes", [1]),
                            None, ["layout", "field 'schemes'", "must be a table of named schemes", "got list [1]"]),
    "move_to_back_not_names": (lambda d: d["schemes"]["grease"].__setitem__("move_to_back", [[1]]),
                               "grease", ["scheme 'grease'", "field 'move_to_back'", "component names", "[1]"]),
    "boards_not_a_list": (lambda d: d.__setitem__("boards", 3),
                          None, ["layout", "field 'boards'", "must be an array of tables", "got int 3"]),
    "parts_not_a_list": (lambda d: d.__setitem__("parts", "standoff_1"),
                         None, ["layout", "field 'parts'", "must be an array of tables", "got str 'standoff_1'"]),
    "components_not_a_list": (lambda d: d.__setitem__("components", {"name": "adc"}),
                              None, ["layout", "field 'components'", "must be an array of tables", "got dict"]),
    "site_part_and_board": (lambda d: d["sites"].__setitem__("gyro_x", {"part": "gyro_x_die", "board": "main"}),
                            None, ["site 'gyro_x'", "field 'board'", "not both"]),
    "site_neither_part_nor_board": (lambda d: d["sites"].__setitem__("tp9", {"at_mm": [1.0, 1.0]}),
                                    None, ["site 'tp9'", "needs 'part'", "'board'"]),
    # two thermal-via fields in the same board (adc moved under the processor's pad) clash
    "via_fields_overlap": (lambda d: comp(d, "adc").update(side="bottom", center_mm=[13.5, 11.5], exposed_pad=True,
                                                           vias=True, pad_mm=[3.0, 2.0]),
                           "air", ["scheme 'air'", "'processor_vias'", "overlaps", "'adc_vias'"]),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_layout_message(case, write_layout):
    mutate, scheme, fragments = CASES[case]
    path = write_layout(mutate)
    with pytest.raises(InputError) as info:
        build_geometry(load_layout(path), scheme)
    msg = str(info.value)
    assert str(path) in msg
    assert "\n" not in msg
    for frag in fragments:
        assert frag in msg, (frag, msg)


def test_missing_file_and_bad_toml(tmp_path):
    with pytest.raises(InputError, match="layout file not found"):
        load_layout(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("name = [unclosed\n")
    with pytest.raises(InputError, match="not valid TOML"):
        load_layout(bad)
