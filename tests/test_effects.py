"""The candidate-effect library: parsing, bounds, each effect's physics on the reference unit (coarse mesh)."""

import math

import numpy as np
import pytest

from imutherm import InputError
from imutherm.cli import main
from imutherm.geometry.build import build_geometry
from imutherm.geometry.layout import load_layout
from imutherm.geometry.mesh import build_mesh
from imutherm.unit.effects import (ambient_drift_rise, apply_model_effects, candidate_names, effect_problem,
                                      first_order_lag, list_effects, parse_effect, setting)
from imutherm.unit.model import ModelOptions
from imutherm.thermal.solve import solve_steady

COARSE = dict(max_cell_mm=5.0, min_cells=1)


def test_parse_and_refuse():
    s = parse_effect("contact@bond:h_W_m2K=500")
    assert s.name == "contact@bond" and s.value("h_W_m2K") == 500 and s.target == "bond"
    assert parse_effect(s.text()) == s
    for bad, msg in (("contact:h_W_m2K=500", "unknown effect"), ("contact@nowhere:h_W_m2K=5", "unknown effect"),
                     ("emissivity:eps=1.5", "outside its physical bounds"), ("emissivity:e=0.5", "unknown parameter"),
                     ("emissivity", "expected NAME"), ("emissivity:eps=abc", "not PARAM=NUMBER"),
                     ("probe_lag:tau_s=nan", "outside")):
        with pytest.raises(InputError, match=msg):
            parse_effect(bad)


def test_list_effects_cli(capsys):
    assert main(["solve", "--list-effects"]) == 0
    out = capsys.readouterr().out
    for name in ("contact@{bond,standoff,lid,board}", "emissivity", "cavity_emissivity", "power@{", "fixture_leak",
                 "probe_lag", "ambient_drift"):
        assert name in out
    assert out == list_effects() + "\n"
    assert "power@reg_5v" in candidate_names()


def test_first_order_lag_is_exact_for_a_step_and_a_ramp():
    t = np.array([0.0, 0.5, 3.0, 10.0, 40.0])
    tau = 7.0
    ramp = 2.0 * t  # x = a t from y(0) = 0: y = a (t - tau (1 - e^{-t/tau}))
    np.testing.assert_allclose(first_order_lag(t, ramp, tau), 2.0 * (t - tau * (1 - np.exp(-t / tau))), rtol=1e-12)
    step = np.ones_like(t)  # x = 1 held from y(0) = 0: y = 1 - e^{-t/tau}
    np.testing.assert_allclose(first_order_lag(t, step, tau, initial=0.0), 1 - np.exp(-t / tau), rtol=1e-12)


def test_ambient_drift_limits():
    t = np.array([1e-3, 1e5])
    y = ambient_drift_rise(t, [100.0], 1e-3)
    assert y[0, 0] == pytest.approx(0.5e-3 * 1e-3**2 / 100.0, rel=1e-3)  # r t^2 / (2 tau) at t -> 0
    assert y[1, 0] == pytest.approx(1e-3 * (1e5 - 100.0), rel=1e-9)  # settled ramp: lags by tau


@pytest.fixture(scope="module")
def unit():
    lay = load_layout(None)
    out = {}
    for scheme in ("air", "grease"):
        g = build_geometry(lay, scheme)
        grid = build_mesh(g, **COARSE)
        st = solve_steady(effect_problem(apply_model_effects(g, ModelOptions()), grid), probes=dict(g.sites))
        out[scheme] = (g, grid, dict(zip(st.probe_names, st.probe_C - 70.0)), st)
    return out


def _rise(unit, scheme, *settings):
    g, grid, _, _ = unit[scheme]
    v = apply_model_effects(g, ModelOptions(), settings)
    st = solve_steady(effect_problem(v, grid), probes=dict(g.sites))
    return dict(zip(st.probe_names, st.probe_C - 70.0)), st


@pytest.mark.slow
def test_power_effect_is_linear_in_the_extra_power(unit):
    """The model is linear in power up to the exterior laws' weak nonlinearity: +0.1 W and +0.2 W at reg_5v."""
    base = unit["grease"][2]
    r1, st1 = _rise(unit, "grease", setting("power@reg_5v", extra_W=0.1))
    r2, _ = _rise(unit, "grease", setting("power@reg_5v", extra_W=0.2))
    assert st1.power_in_W == pytest.approx(unit["grease"][3].power_in_W + 0.1, rel=1e-9)
    for s in base:
        d1, d2 = r1[s] - base[s], r2[s] - base[s]
        assert d1 > 0 and d2 == pytest.approx(2 * d1, rel=0.05)


@pytest.mark.slow
def test_contact_and_emissivity_effects_act_where_they_should(unit):
    base = unit["grease"][2]
    bond, _ = _rise(unit, "grease", setting("contact@bond", h_W_m2K=100.0))
    assert bond["tp1"] > base["tp1"] + 0.5  # the power chips lose their grease path
    emis, _ = _rise(unit, "grease", setting("emissivity", eps=0.05))
    assert all(emis[s] > base[s] for s in base)  # a bare housing runs hotter everywhere
    cav, _ = _rise(unit, "air", setting("cavity_emissivity", eps=0.05))
    air = unit["air"][2]
    assert cav["tp1"] > air["tp1"] + 0.3  # less cavity radiation: the hot board sheds less to the walls
    with pytest.raises(InputError, match="no bond lines"):
        apply_model_effects(unit["air"][0], ModelOptions(), [setting("contact@bond", h_W_m2K=100.0)])


@pytest.mark.slow
def test_fixture_leak_takes_its_conductance(unit):
    """A leak G at the x = 0 face carries G times the face's mean rise (trapezoid mean: exact for the
    bilinear face field); the face's total loss grows by about that (its convection drops a little)."""
    G = 0.1
    _, st = _rise(unit, "air", setting("fixture_leak", G_W_K=G))
    base = unit["air"][3]
    grid = unit["air"][1]
    face = st.T_C.reshape(len(grid.xs), len(grid.ys), len(grid.zs))[0] - 70.0

    def trap(a):
        w = np.zeros_like(a)
        w[:-1] += np.diff(a) / 2
        w[1:] += np.diff(a) / 2
        return w

    w = trap(grid.ys)[:, None] * trap(grid.zs)[None, :]
    leak = G * float((w * face).sum() / w.sum())
    assert st.energy_balance_rel_error < 1e-6
    assert leak > 0.05
    assert st.heat_out_W["xmin"] - base.heat_out_W["xmin"] == pytest.approx(leak, rel=0.2)


@pytest.mark.slow
def test_solve_cli_with_effects(tmp_path):
    import json
    out = tmp_path / "o"
    assert main(["solve", "--scheme", "grease", "--mesh-size", "6", "--min-cells", "1", "--transient",
                 "--t-end", "600", "--no-progress", "--effect", "probe_lag:tau_s=60",
                 "--effect", "ambient_drift:rate_K_per_h=10", "--out", str(out)]) == 0
    r = json.loads((out / "result.json").read_text())
    assert r["effects"] == ["probe_lag:tau_s=60", "ambient_drift:rate_K_per_h=10"]
    assert main(["solve", "--effect", "ambient_drift:rate_K_per_h=10", "--mesh-size", "6", "--out",
                 str(tmp_path / "x")]) == 2  # a drifting ambient has no steady state
    assert main(["solve", "--scheme", "air", "--effect", "contact@bond:h_W_m2K=100", "--mesh-size", "6",
                 "--out", str(tmp_path / "y")]) == 2  # air has no bond lines
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


def test_cavity_emissivity_under_s2s_sets_the_housing_inner_emissivity():
    """Under the s2s cavity law the effect changes the emissivity the radiosity exchange sees: the housing's and
    lid's inner faces get the wall emissivity whose pair emissivity with the boards' 0.9 is the parameter (bare
    Al 0.05 -> 0.05, anodised pair 0.77 -> 0.84); the other surfaces keep theirs, and the exchange weakens."""
    from imutherm.unit import knobs
    from imutherm.unit.effects import wall_emissivity_for_pair
    from imutherm.unit.model import cavity_exchange_law
    assert wall_emissivity_for_pair(0.77) == pytest.approx(0.842, abs=1e-3)
    assert wall_emissivity_for_pair(0.05) == pytest.approx(0.0503, abs=1e-4)
    assert wall_emissivity_for_pair(0.9) == pytest.approx(1.0)
    g = build_geometry(load_layout(None), "air")
    grid = build_mesh(g, max_cell_mm=6.0, min_cells=1)
    opts = ModelOptions(cavity_law="s2s", cavity_patch_mm=10.0)
    nom = cavity_exchange_law(g, grid, opts)
    v = apply_model_effects(g, opts, (setting("cavity_emissivity", eps=0.05),))
    bare = cavity_exchange_law(v.geometry, grid, v.options)
    walls = np.isin(nom.patches.part, [grid.part_names.index(n) for n in ("housing", "lid")])
    assert walls.any() and (~walls).any()
    np.testing.assert_allclose(bare.emissivity[walls], wall_emissivity_for_pair(0.05))
    np.testing.assert_allclose(nom.emissivity[walls], 0.84)
    np.testing.assert_array_equal(bare.emissivity[~walls], nom.emissivity[~walls])
    assert np.abs(np.diag(bare.X)).sum() < 0.6 * np.abs(np.diag(nom.X)).sum()
    assert knobs.effect_knob("cavity_emissivity", opts).nodes == knobs.S2S_EMISSIVITY_NODES
    assert knobs.effect_knob("cavity_emissivity", ModelOptions(cavity_law="effective")).nodes == 2  # linear in eps
    # s2s: the default
    assert knobs.effect_knob("cavity_emissivity", ModelOptions()).nodes == knobs.S2S_EMISSIVITY_NODES


def test_the_cavity_emissivity_knob_is_nominal_at_the_models_own_emissivities():
    """The form knob's nominal value (correlation.FORM_RETUNE): under s2s the pair emissivity of a 0.9 board and
    the anodised housing's 0.84 inner wall, 1 / (1/0.9 + 1/0.84 - 1) = 0.7683 (Incropera eq. 13.24), whose
    wall emissivity is 0.84 again; under the effective law the option itself; a wall option wins."""
    from imutherm.unit import knobs
    from imutherm.unit.effects import wall_emissivity_for_pair
    g = build_geometry(None, "air")
    pair = knobs.cavity_pair_nominal(g, ModelOptions(cavity_law="s2s"))
    assert pair == pytest.approx(1 / (1 / 0.9 + 1 / 0.84 - 1), rel=1e-12)
    assert wall_emissivity_for_pair(pair) == pytest.approx(0.84, rel=1e-12)
    assert knobs.cavity_pair_nominal(g, ModelOptions(cavity_law="effective", cavity_emissivity=0.5)) == 0.5
    assert knobs.cavity_pair_nominal(g, ModelOptions(cavity_law="s2s", cavity_wall_emissivity=0.05)) == pytest.approx(
        1 / (1 / 0.9 + 1 / 0.05 - 1), rel=1e-12)
