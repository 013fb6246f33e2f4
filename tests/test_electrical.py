"""Powers from the electrical design: regulator losses by hand calculation, the supply as an uncertain input,
and every bad electrical input refused in one line naming the rail, the part and the field."""

import pytest

from imutherm import InputError
from imutherm.cli import main
from imutherm.geometry.build import build_geometry
from imutherm.geometry.electrical import rail_losses
from imutherm.geometry.layout import load_layout
from imutherm.unit.knobs import supply_power_knob


def rail(d, name):
    return next(r for r in d["rails"] if r["name"] == name)


def comp(d, name):
    return next(c for c in d["components"] if c["name"] == name)


def test_reference_regulator_losses_by_hand():
    """LDO cascade 9 V -> 5 -> 3.3 -> 1.8 V, I_q 5 mA each, loads from the reference layout's [[rails]]."""
    powers = {c.name: c.power_W for c in load_layout(None).components}
    i_1v8 = 0.150                                  # DSP core
    i_3v3 = 0.025 + 0.001 + (i_1v8 + 0.005)        # DSP I/O + ADC DVDD + reg_1v8's input current
    i_5v = 3 * 0.006 + 3 * 0.0007 + 0.007 + (i_3v3 + 0.005)  # gyros, accels, ADC AVDD + reg_3v3's input
    assert i_5v == pytest.approx(0.2131, abs=1e-12)
    assert powers["reg_1v8"] == pytest.approx((3.3 - 1.8) * 0.150 + 3.3 * 0.005, rel=1e-12)   # 0.2415 W
    assert powers["reg_3v3"] == pytest.approx((5.0 - 3.3) * i_3v3 + 5.0 * 0.005, rel=1e-12)   # 0.3327 W
    assert powers["reg_5v"] == pytest.approx((9.0 - 5.0) * i_5v + 9.0 * 0.005, rel=1e-12)     # 0.8974 W
    assert powers["processor"] == 0.35  # loads keep their stated dissipation
    src = {c.name: c.power_source for c in load_layout(None).components}
    assert src["reg_5v"].startswith("electrical: rail 'rail_5v', (9 - 5) V x 213.1 mA + 9 V x 5 mA")
    assert src["processor"] == "layout power_W"


def test_supply_voltage_moves_only_the_first_regulator():
    spec = load_layout(None).electrical
    assert spec.supply_V == 9.0 and spec.supply_range_V == (6.2, 12.0)
    lo, nom = rail_losses(spec, 6.2), rail_losses(spec)
    assert lo["reg_5v"].loss_W == pytest.approx(1.2 * 0.2131 + 6.2 * 0.005, rel=1e-12)       # 0.287 W
    assert lo["reg_3v3"].loss_W == nom["reg_3v3"].loss_W and lo["reg_1v8"].loss_W == nom["reg_1v8"].loss_W
    knob, source = supply_power_knob(build_geometry(None, "air"))
    i_in = 0.2131 + 0.005
    assert knob.name == "power@reg_5v" and knob.part == "reg_5v" and knob.unit == "W"
    assert knob.lo == pytest.approx((6.2 - 9.0) * i_in, rel=1e-12)
    assert knob.hi == pytest.approx((12.0 - 9.0) * i_in, rel=1e-12)
    assert "the paper states none" in source and "6.2..12 V" in source
    from imutherm.unit.knobs import RETUNE, uncertain_inputs
    inputs = uncertain_inputs(build_geometry(None, "air"))
    assert inputs[:len(RETUNE)] == RETUNE and inputs[-1] == (knob, source)


def test_switching_regulator_loss_from_its_efficiency(write_layout):
    def buck(d):
        r = rail(d, "rail_5v")
        r["kind"] = "switching"
        r["efficiency"] = 0.85
        del r["dropout_V"], r["quiescent_A"]
    lay = load_layout(write_layout(buck))
    p_out = 5.0 * 0.2131
    reg = next(c for c in lay.components if c.name == "reg_5v")
    assert reg.power_W == pytest.approx(p_out * (1 / 0.85 - 1), rel=1e-12)   # 0.188 W
    loss = rail_losses(lay.electrical, 12.0)["reg_5v"]
    assert loss.loss_W == pytest.approx(reg.power_W, rel=1e-12)              # no supply dependence
    assert loss.input_A == pytest.approx(p_out / 0.85 / 12.0, rel=1e-12)


def test_explicit_power_wins_and_says_so(write_layout):
    lay = load_layout(write_layout(lambda d: comp(d, "reg_5v").__setitem__("power_W", 0.4)))
    reg = next(c for c in lay.components if c.name == "reg_5v")
    assert reg.power_W == 0.4 and "electrical design gives 0.8974 W" in reg.power_source


def test_layout_without_electrical_design_takes_explicit_powers(write_layout):
    def explicit(d):
        del d["electrical"], d["rails"]
        for name, w in (("reg_5v", 0.813), ("reg_3v3", 0.299), ("reg_1v8", 0.225)):
            comp(d, name)["power_W"] = w
    lay = load_layout(write_layout(explicit))
    assert lay.electrical is None
    assert {c.name: c.power_W for c in lay.components}["reg_5v"] == 0.813
    assert load_layout("imu_cardguide").electrical == load_layout(None).electrical  # the same electronics


def _no_electrical(d):
    del d["electrical"], d["rails"]


def _supply(v, rng):
    def f(d):
        d["electrical"]["supply_V"] = v
        d["electrical"]["supply_range_V"] = rng
    return f


def _loop(d):
    rail(d, "rail_5v")["input"] = "rail_1v8"


BAD = {
    "below_dropout_nominal": (_supply(6.0, [6.0, 12.0]),
                              ["rail 'rail_5v'", "regulator 'reg_5v'", "fed 6 V from the supply",
                               "1.2 V dropout", "valid: an input >= 6.2 V"]),
    "below_dropout_in_range": (_supply(9.0, [5.5, 12.0]), ["rail 'rail_5v'", "regulator 'reg_5v'", "5.5 V"]),
    "range_misses_nominal": (_supply(13.0, [6.2, 12.0]), ["[electrical]", "'supply_range_V'", "13"]),
    "no_power_no_rail": (_no_electrical, ["component 'reg_5v'", "'power_W' is required", "[[rails]]"]),
    "unknown_regulator": (lambda d: rail(d, "rail_3v3").__setitem__("regulator", "reg_9v"),
                          ["rail 'rail_3v3'", "'regulator'", "unknown component 'reg_9v'"]),
    "unknown_load": (lambda d: rail(d, "rail_1v8")["loads_A"].__setitem__("dsp", 0.1),
                     ["rail 'rail_1v8'", "'loads_A'", "unknown component 'dsp'"]),
    "negative_load": (lambda d: rail(d, "rail_1v8")["loads_A"].__setitem__("processor", -0.1),
                      ["rail 'rail_1v8'", "'loads_A'", "processor"]),
    "unknown_input": (lambda d: rail(d, "rail_3v3").__setitem__("input", "rail_12v"),
                      ["rail 'rail_3v3'", "'input'", "unknown rail 'rail_12v'", "valid: supply"]),
    "loop": (_loop, ["loop", "rail_5v", "rail_1v8"]),
    "linear_with_efficiency": (lambda d: rail(d, "rail_5v").__setitem__("efficiency", 0.9),
                               ["rail 'rail_5v'", "'efficiency'", "switching"]),
    "switching_no_efficiency": (lambda d: rail(d, "rail_5v").__setitem__("kind", "switching"),
                                ["rail 'rail_5v'", "'efficiency'", "required"]),
    "rails_without_supply": (lambda d: d.pop("electrical"), ["'electrical'", "[electrical]", "[[rails]]"]),
    "duplicate_regulator": (lambda d: rail(d, "rail_3v3").__setitem__("regulator", "reg_5v"),
                            ["rail 'rail_3v3'", "'reg_5v' already regulates"]),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_electrical_input_is_refused(case, write_layout):
    mutate, fragments = BAD[case]
    path = write_layout(mutate)
    with pytest.raises(InputError) as info:
        load_layout(path)
    msg = str(info.value)
    assert str(path) in msg and "\n" not in msg
    for frag in fragments:
        assert frag in msg, (frag, msg)


def test_cli_refuses_a_supply_below_dropout_with_exit_2(write_layout, tmp_path, capsys):
    path = write_layout(_supply(6.0, [6.0, 12.0]))
    assert main(["geometry", str(path), "--out", str(tmp_path / "g")]) == 2
    err = capsys.readouterr().err
    assert "reg_5v" in err and "dropout" in err and "Traceback" not in err


def test_sweep_varies_the_supply_voltage(tmp_path):
    """``electrical.supply_V`` is a sweep key [V]; each case's regulator loss follows from it."""
    from imutherm.studies.sweep import key_unit, plan_sweep

    plan = plan_sweep(None, "air", ["electrical.supply_V=6.2,12"], mesh_size_mm=8.0, min_cells=1)
    assert key_unit("electrical.supply_V") == "V" and len(plan.cases) == 2
    with pytest.raises(InputError, match="supply_range_V"):
        plan_sweep(None, "air", ["electrical.supply_V=13"], mesh_size_mm=8.0, min_cells=1)
