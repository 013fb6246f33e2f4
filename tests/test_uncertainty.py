"""``imutherm compare --uncertainty``: the propagation on models with a known answer, the inputs' ranges
and sources, the answer's words; the reduced models against the full FEM (slow)."""

import math

import numpy as np
import pytest

from imutherm.studies.uncertainty import uncertainty


def _uniform(*ranges):
    return tuple(uncertainty.UncertainInput(f"x{i}", "-", lo, hi, False, "test") for i, (lo, hi) in enumerate(ranges))


def test_linear_model_variance_quantiles_and_sobol_are_analytic():
    # Y = sum a_i X_i, X_i ~ U(lo_i, hi_i): mean sum a_i m_i, variance sum a_i^2 w_i^2 / 12,
    # S1_i = ST_i = a_i^2 w_i^2 / 12 / variance (no interaction)
    ins = _uniform((0.0, 1.0), (2.0, 4.0), (-1.0, 1.0))
    a = np.array([3.0, -1.0, 0.5])
    X, Y, st = uncertainty.propagate(lambda X: {"y": X @ a}, ins, samples=1024, seed=1)
    s = st["y"]
    w = np.array([1.0, 2.0, 2.0])
    var = np.sum(a**2 * w**2 / 12)
    assert len(X) == 1024 * (3 + 2) and s["n"] == len(X)
    assert s["mean"] == pytest.approx(3 * 0.5 - 3.0 + 0.0, abs=0.01)
    assert s["std"] ** 2 == pytest.approx(var, rel=0.02)
    for j, name in enumerate(("x0", "x1", "x2")):
        exact = a[j] ** 2 * w[j] ** 2 / 12 / var
        assert s["sobol"][name]["S1"] == pytest.approx(exact, abs=max(0.02, s["sobol"][name]["S1_conf"]))
        assert s["sobol"][name]["ST"] == pytest.approx(exact, abs=max(0.02, s["sobol"][name]["ST_conf"]))
    assert s["drivers"][0] == "x0"


def test_interval_of_a_sum_of_two_uniforms_is_the_triangle_s():
    # X1 + X2, X_i ~ U(0, 1): triangular, F(y) = y^2 / 2 below 1, so q05 = sqrt(0.1), q95 = 2 - sqrt(0.1), q50 = 1
    ins = _uniform((0.0, 1.0), (0.0, 1.0))
    _, _, st = uncertainty.propagate(lambda X: {"y": X.sum(axis=1)}, ins, samples=2048, seed=2)
    s = st["y"]
    assert s["q05"] == pytest.approx(math.sqrt(0.1), abs=0.01)
    assert s["q95"] == pytest.approx(2 - math.sqrt(0.1), abs=0.01)
    assert s["q50"] == pytest.approx(1.0, abs=0.01)


def test_log_uniform_input_and_the_design_size():
    ins = (uncertainty.UncertainInput("h", "W/m^2 K", 100.0, 10000.0, True, "test"),)
    X = uncertainty.to_values(ins, uncertainty.design(ins, 1024, 0))
    assert X.min() >= 100.0 and X.max() <= 10000.0
    assert np.median(X) == pytest.approx(1000.0, rel=0.03)      # log-uniform: the median is the geometric mean
    with pytest.raises(Exception, match="power of 2"):
        uncertainty.design(ins, 100, 0)


def _geo(layout=None, scheme="grease"):
    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.layout import load_layout

    return build_geometry(load_layout(layout), scheme)


def test_every_input_has_a_range_a_source_and_holds_the_model_value():
    from imutherm.unit import knobs

    geo = _geo()
    ins = uncertainty.inputs(geo)
    names = [i.name for i in ins]
    assert "supply_V" in names and "contact@bond" in names and len(set(names)) == len(names)
    nominal = knobs.nominal_values(geo)
    from imutherm.unit.model import GREASE_WETTED_JOINT_W_M2K, ModelOptions

    nominal.update(supply_V=9.0, cavity_emissivity=ModelOptions().cavity_emissivity, cavity_law_blend=0.0,
                   **{"contact@bond": GREASE_WETTED_JOINT_W_M2K})
    for i in ins:
        assert i.lo < i.hi and len(i.source) > 20, i
        assert i.nominal == pytest.approx(nominal[i.name]) and i.lo <= i.nominal <= i.hi, (i.name, i.nominal)
    # the cavity law's form is an input under the s2s law (the default) and only there: the blend acts on it alone
    assert "cavity_law_blend" in names
    for other in (ModelOptions(cavity_law="effective"), ModelOptions(cavity_radiation=False)):
        assert "cavity_law_blend" not in [i.name for i in uncertainty.inputs(geo, other)]
    blend = next(i for i in uncertainty.inputs(geo, ModelOptions(cavity_law_blend=0.3)) if i.name == "cavity_law_blend")
    assert (blend.lo, blend.hi, blend.nominal, blend.log) == (0.0, 1.0, 0.3, False)


def test_supply_input_and_its_regulator_loss_from_the_reference_toml_by_hand():
    # layouts/imu_reference.toml: supply 9 V, supply_range_V [6.2, 12]; reg_5v (LDO, I_q 5 mA) feeds the 5 V rail's
    # 3 gyros x 6 mA + 3 accels x 0.7 mA + ADC 7 mA + reg_3v3's input (25 + 1 + 150 + 5 + 5 mA) = 213.1 mA
    geo = _geo()
    sup = next(i for i in uncertainty.inputs(geo) if i.name == "supply_V")
    i_in = 0.2131 + 0.005                                   # reg_5v's input current: its loss per volt [W/V]
    assert (sup.lo, sup.hi, sup.nominal, sup.unit) == (6.2, 12.0, 9.0, "V")
    assert sup.knob == "power@reg_5v" and sup.per_unit == pytest.approx(i_in, rel=1e-12)
    assert "supply_range_V" in sup.source and "6.2..12 V" in sup.source
    sm = uncertainty.SchemeModel("grease", geo, None, None, None, (sup,), ("supply_V",), (), 0.0)
    from imutherm.unit.effects import power_part

    p9 = power_part(geo, "reg_5v").power_W
    assert p9 == pytest.approx((9.0 - 5.0) * 0.2131 + 9.0 * 0.005, rel=1e-12)          # 0.8974 W
    for v in (6.2, 9.0, 12.0):                                                        # (V - 5 V) I_load + V I_q
        extra = uncertainty.knob_values(sm, [v])["power@reg_5v"]
        assert p9 + extra == pytest.approx((v - 5.0) * 0.2131 + v * 0.005, rel=1e-12)  # 0.287 .. 1.555 W
    # one place: the layout
    assert not hasattr(uncertainty, "ASSUMED_SUPPLY_V") and not hasattr(uncertainty, "SUPPLY_RANGE_V")


def test_a_layout_with_another_supply_range_changes_the_input(write_layout):
    def supply(d):
        d["electrical"]["supply_V"] = 12.0
        d["electrical"]["supply_range_V"] = [10.0, 15.0]
    sup = next(i for i in uncertainty.inputs(_geo(write_layout(supply))) if i.name == "supply_V")
    assert (sup.lo, sup.hi, sup.nominal) == (10.0, 15.0, 12.0)
    assert sup.per_unit == pytest.approx(0.2131 + 0.005, rel=1e-12) and "10..15 V" in sup.source


def test_a_layout_without_a_variable_supply_has_no_supply_input(write_layout):
    def none(d):
        del d["electrical"], d["rails"]
        for name, w in (("reg_5v", 0.813), ("reg_3v3", 0.299), ("reg_1v8", 0.225)):
            next(c for c in d["components"] if c["name"] == name)["power_W"] = w

    def buck(d):
        r = next(r for r in d["rails"] if r["name"] == "rail_5v")
        r["kind"], r["efficiency"] = "switching", 0.85
        del r["dropout_V"], r["quiescent_A"]

    def exact(d):
        d["electrical"]["supply_range_V"] = [9.0, 9.0]

    for mutate, words in ((none, "states no electrical design"), (buck, "linear regulator"),
                          (exact, "states its supply exactly")):
        geo = _geo(write_layout(mutate))
        assert "supply_V" not in [i.name for i in uncertainty.inputs(geo)]
        inp, note = uncertainty.supply_input(geo)
        assert inp is None and note.startswith("no supply-voltage input") and words in note, note


def test_answer_says_whether_an_advantage_exceeds_the_uncertainty():
    st = {"diff_max_die_rise_K:air-grease": {"q05": 1.0, "q50": 3.0, "q95": 5.0, "drivers": ["supply_V"]},
          "diff_t95_s:air-grease": {"q05": -20.0, "q50": 10.0, "q95": 40.0, "drivers": []}}
    words = uncertainty.answer_words(st, ["air", "grease"])
    assert "grease is lower than air" in words[0] and "larger than the model's uncertainty" in words[0]
    assert "supply_V" in words[0]
    assert "within the model's uncertainty" in words[1]


#: the laws of the full-FEM checks below: the effective cavity law, whose reduced model is exact to ~2e-3 K at
#: drawn points (the FEM's effective conductivity is linear in the field). Under the s2s default the reduced
#: model's secant of the T^4 exchange about the nominal field is off by 0.13-0.18 K at the same checks (about
#: 1 % of the rise; docs/reference/study.md, "Uncertainty of the answer"): a known limit of the s2s reduced model, reported in
#: uncertainty.json's max_check_error_K, not a tolerance these tests relax.
CHECK_LAW = "effective"


@pytest.mark.slow
def test_propagation_on_the_reduced_models_checked_on_the_full_fem():
    from imutherm.unit.model import ModelOptions
    res = uncertainty.run_uncertainty(None, ("air", "grease"), samples=8, seed=0, checks=1, mesh_size_mm=6, min_cells=1,
                            options=ModelOptions(cavity_law=CHECK_LAW))
    assert res["draws"] == 8 * (len(uncertainty.inputs(_geo(), ModelOptions(cavity_law=CHECK_LAW))) + 2)
    assert res["imu"] is None and res["not_propagated"]
    assert "cavity_law_blend" not in [i["name"] for i in res["inputs"]]
    assert any("taken as exact" in n for n in res["notes"])
    air, grease = res["stats"]["max_die_rise_K:air"], res["stats"]["max_die_rise_K:grease"]
    assert 0 < air["q05"] < air["q50"] < air["q95"] and air["q50"] > grease["q50"]
    assert "contact@bond" not in res["applicable"]["air"] and "contact@bond" in res["applicable"]["grease"]
    assert res["max_check_error_K"] < 0.1, res["checks"]
    # the reduced transient (order-2 Krylov basis) is not the study's 1 %: measured 0.1-1.9 % at the default
    # checks (docs/reference/study.md); this guards that figure, it is not a claim of 1 %
    assert res["max_check_t95_rel_error"] < 0.03, res["checks"]
    assert res["answer"] and "diff_max_die_rise_K:air-grease" in res["stats"]


def test_compare_refuses_a_bad_sample_count_before_any_solve(tmp_path, capsys):
    from imutherm.cli import main

    rc = main(["compare", "--steady-only", "--uncertainty", "--uncertainty-samples", "100", "--out",
               str(tmp_path / "x"), "--no-progress"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1 and "power of 2" in err[0] and not (tmp_path / "x").exists()


@pytest.mark.slow
def test_compare_uncertainty_writes_its_json_and_pages(tmp_path, capsys):
    import json

    from imutherm.cli import main

    out = tmp_path / "c"
    rc = main(["compare", "--steady-only", "--schemes", "air,grease", "--uncertainty", "--uncertainty-samples", "4",
               "--uncertainty-checks", "1", "--mesh-size", "6", "--min-cells", "1", "--no-progress",
               "--cavity-law", CHECK_LAW, "--out", str(out)])
    text = capsys.readouterr().out
    unc = json.loads((out / "uncertainty.json").read_text())
    from imutherm.unit.model import ModelOptions
    assert rc == 0 and unc["draws"] == 4 * (len(uncertainty.inputs(_geo(), ModelOptions(cavity_law=CHECK_LAW))) + 2)
    assert "air - grease" in text
    assert unc["max_check_error_K"] < 0.1
    from pypdf import PdfReader

    pdf = "".join(p.extract_text() for p in PdfReader(out / "uncertainty.pdf").pages)
    assert "supply_V" in pdf and "Sobol" in pdf and "Not propagated" in pdf
