"""Issue 58: one list of explanations, profile intervals of re-tuned knobs, knobs at a bound as symptoms, and the
next experiment that separates an ambiguous verdict (toy reduced models, tests/_toy_reduced.py: seconds each)."""

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from imutherm.studies.correlation import correlate, result_json, updated_model_toml
from imutherm.studies.correlation.profile import CHI2_95, profile_interval, residual_floor_K2

sys.path.insert(0, str(Path(__file__).resolve().parent))  # tests/_toy_reduced.py

CANDIDATES = ("power@reg_5v", "power@processor", "contact@bond")
NUISANCE = {"k_board_W_mK": 18.5, "mount_h_W_m2K": 470.0, "convection_scale": 1.05}


def _linear_profile_cost(X, y, j):
    """The profile objective of coefficient j of y ≈ X β: the others least-squares at each value of β_j."""
    others = [i for i in range(X.shape[1]) if i != j]

    def cost(b):
        r = y - X[:, j] * b
        r = r - X[:, others] @ np.linalg.lstsq(X[:, others], r, rcond=None)[0]
        return float(r @ r)
    return cost


@pytest.mark.parametrize("j", [0, 1, 2])
def test_the_profile_interval_of_a_linear_model_is_the_analytic_one(j):
    """y = X β + N(0, σ²), σ known, three correlated regressors: the profile interval of β_j equals
    β̂_j ± 1.96 σ sqrt((XᵀX)⁻¹_jj) (exact for a linear model) to 0.1 % of its half width; with n_eff / n = 0.25 it
    is twice as wide; a range narrower than the interval leaves that end open."""
    rng = np.random.default_rng(j)
    n, sigma = 200, 0.3
    t = np.linspace(0, 1, n)
    X = np.column_stack([np.ones(n), t, t**2 + 0.2 * t])  # correlated columns: the profile re-fits the others
    y = X @ np.array([1.0, -2.0, 0.5]) + rng.normal(0, sigma, n)
    beta = np.linalg.lstsq(X, y, rcond=None)[0]
    half = math.sqrt(CHI2_95) * sigma * math.sqrt(np.linalg.inv(X.T @ X)[j, j])
    cost = _linear_profile_cost(X, y, j)
    p = profile_interval(cost, beta[j], beta[j] - 50 * half, beta[j] + 50 * half, sigma**2)
    lo, hi = p["ci95"]
    assert lo == pytest.approx(beta[j] - half, abs=1e-3 * half) and hi == pytest.approx(beta[j] + half, abs=1e-3 * half)
    assert p["open"] == (False, False)
    wide = profile_interval(cost, beta[j], beta[j] - 50 * half, beta[j] + 50 * half, sigma**2, ratio=0.25)
    assert wide["ci95"][1] - beta[j] == pytest.approx(2 * half, rel=1e-3)
    cut = profile_interval(cost, beta[j], beta[j] - 0.5 * half, beta[j] + 50 * half, sigma**2)
    assert cut["open"] == (True, False) and cut["ci95"][0] == pytest.approx(beta[j] - 0.5 * half)
    # the floor: a residual below the noise and the stated form error does not narrow the interval
    assert residual_floor_K2(0.0, n, 3, 0.05, 0.2) == pytest.approx(0.05**2 + 0.2**2)
    assert residual_floor_K2(4.0 * n, n, 0, 0.05, float("nan")) == pytest.approx(4.0)


def test_a_found_knob_carries_its_profile_interval_everywhere(tmp_path):
    """A cavity emissivity of 0.3 hidden (nominal 0.77): the finding's interval is the profile's, covers 0.3, is
    far narrower than the re-tune's range 0.02-0.9, and the verdict, words, json `parameters`, the explanations
    list and updated_model.toml all carry the same value."""
    from _toy_reduced import toy_models, toy_runs
    res = correlate(toy_runs({**NUISANCE, "cavity_emissivity": 0.3}, np.random.default_rng(4)), models=toy_models(),
                    candidates=CANDIDATES, rerun=False)
    assert res.verdict == "finding", res.timings["reason"]
    f = res.findings[0]
    lo, hi = f.ci95
    assert lo <= 0.3 <= hi and hi - lo < 0.2 and f.open_ends == (False, False)
    j = result_json(res)
    p = j["parameters"]["cavity_emissivity"]
    assert p["value"] == pytest.approx(f.value) and p["ci95"] == pytest.approx([lo, hi]) and p["ci95_from"] == "profile"
    assert j["explanations"][0]["name"] == "cavity_emissivity" and j["explanations"][0]["kind"] == "parameter"
    assert j["explanations"][0]["qualifies"]
    assert f"{f.value:.3g}" in res.words
    toml = updated_model_toml(res)
    line = next(x for x in toml.splitlines() if x.startswith("cavity_emissivity"))
    assert float(line.split("=")[1].split("#")[0]) == pytest.approx(f.value, rel=1e-5)


def test_a_knob_pushed_to_its_bound_is_a_symptom_not_a_finding():
    """A 30 % power excess (the re-tune's power_scale stops at 1.15): the knob ends at its bound with strong
    evidence, and is reported as a symptom of the model's form, with how far the model is off and where (scheme,
    site, phase), never as a finding or the verdict's name."""
    from _toy_reduced import toy_models, toy_runs
    res = correlate(toy_runs({**NUISANCE, "power_scale": 1.30}, np.random.default_rng(3)), models=toy_models(),
                    candidates=("contact@bond",), rerun=False)
    assert "power_scale" not in [f.parameter for f in res.findings], res.timings["reason"]
    assert res.verdict != "finding"
    s = next(x for x in res.symptoms if x.parameter == "power_scale")
    assert s.bound == "upper" and s.value == pytest.approx(1.15, rel=1e-3)
    w = s.form_off["where"][0]
    assert w["scheme"] in ("air", "grease") and w["phase"] in ("rise", "plateau") and w["site"] in res.runs[0].sites
    # how far off: the re-tuned physics' RMS, above the noise (the other knobs took what they could of the rest)
    assert s.form_off["rms_K"] == pytest.approx(res.physics.rms_K, rel=1e-6) and s.form_off["rms_K"] > res.noise_K
    assert "symptom of the model's form" in s.words() and "symptom" in res.timings["reason"]
    assert result_json(res)["symptoms"][0]["parameter"] == "power_scale"


def test_a_form_knob_moved_where_the_form_is_visibly_off_is_a_symptom_not_a_finding():
    """Nothing hidden, the model's form off in air (a broad loss of 0.4 x the cavity's own pattern plus +-1 K
    between gyro_x and gyro_y, which no knob makes): the re-tune takes the cavity emissivity far down to take up the
    broad part, and leaves ~0.4 K RMS, beyond twice the stated form error. It is no finding (it was one before
    issue 58's rule); it is a form symptom saying how far the model is off and where (air, gyro_x). A hidden
    cavity emissivity alone stays a finding (test_a_found_knob_carries_its_profile_interval_everywhere)."""
    from _toy_reduced import toy_models, toy_runs

    def extra(scheme, t):
        g = (0.4 * np.array([6.0, 5.5, 5.0, 3.0, 3.0, 3.0]) + np.array([0.0, 0.0, 0.0, 1.0, -1.0, 0.0])
             if scheme == "air" else np.zeros(6))
        return g[None, :] * (1.0 - np.exp(-t[:, None] / 150.0))
    res = correlate(toy_runs(dict(NUISANCE), np.random.default_rng(3), extra), models=toy_models(),
                    candidates=CANDIDATES, rerun=False)
    assert res.findings == () and res.verdict != "finding", res.timings["reason"]
    s = next(x for x in res.symptoms if x.parameter == "cavity_emissivity")
    assert s.bound == "form" and s.value < 0.4 and s.form_off["rms_K"] > 2 * s.form_band_K > 0
    assert (s.form_off["where"][0]["scheme"], s.form_off["where"][0]["site"]) == ("air", "gyro_x")
    assert "is not a finding" in s.words() and "air gyro_x" in s.words()
    assert result_json(res)["symptoms"][0]["bound"] == "form"


# --------------------------------------------------------------------------- the next experiment, closed loop

#: two regulators side by side on the toy: the same pattern at the board's three test points, different at the
#: gyro block (the 3.3 V one sits under gyro_x) and in grease
_TWIN = {"power@reg_5v": {"air": np.array([10.0, 6.0, 3.0, 2.0, 1.5, 1.0]),
                          "grease": np.array([6.0, 3.0, 1.5, 1.0, 0.8, 0.5])},
         "power@reg_3v3": {"air": np.array([10.0, 6.0, 3.0, 8.0, 1.5, 1.0]),
                           "grease": np.array([6.0, 3.0, 1.5, 4.5, 0.8, 0.5])}}


def _twin_models():
    """The toy's models with the two regulators of :data:`_TWIN` (and their knobs) in place of its own patterns."""
    import _toy_reduced as toy
    from imutherm.unit import knobs

    class Twin(toy.ToyReduced):
        def __init__(self, scheme):
            super().__init__(scheme)
            self.knobs = {k.name: k for k in [k for k, _ in knobs.RETUNE] + [knobs.effect_knob(n) for n in _TWIN]}

        def gain_tau(self, values):
            base = {k: v for k, v in values.items() if k not in _TWIN}
            g, _ = super().gain_tau(base)
            dT, tau = toy.BASE[self.scheme]
            for name, pat in _TWIN.items():
                g = g + pat[self.scheme] * values.get(name, 0.0)
            return g, tau * (g / dT) ** 0.5

    m = toy.toy_models()
    from dataclasses import replace
    return replace(m, roms={k: Twin(k[0]) for k in m.roms}), Twin


def _twin_run(Twin, values, rng, scheme, sites, times, power_scale=1.0, name="air.csv", noise_K=0.05):
    from imutherm.measured import MeasuredRun
    import _toy_reduced as toy
    idx = [toy.SITES.index(s) for s in sites]
    y = Twin(scheme).rise({**values, "power_scale": values.get("power_scale", 1.0) * power_scale}, times)[:, idx]
    v = 70.0 + y + rng.normal(0.0, noise_K, y.shape)
    return MeasuredRun(name, scheme, 70.0, power_scale, 0.0, "die", tuple(sites), times, v, tuple(range(len(times))))


def test_an_ambiguous_verdict_is_settled_by_the_proposed_experiment(tmp_path):
    """Closed loop: 0.8 W at the 5 V regulator hidden, measured in air at the three test points only, where the
    3.3 V regulator reads the same: the verdict is ambiguous between the two, both named with their fitted values;
    the proposed experiment (the design grid's best separation) is made by the same generator, the file added,
    correlate run again: the 5 V regulator is named alone. The proposal is in correlation.json and on page 1."""
    models, Twin = _twin_models()
    truth = {**NUISANCE, "power@reg_5v": 0.8}
    rng = np.random.default_rng(11)
    first = _twin_run(Twin, truth, rng, "air", ("tp1", "tp2", "tp3"), np.linspace(0.0, 1500.0, 40))
    cands = ("power@reg_5v", "power@reg_3v3")
    res = correlate([first], models=models, candidates=cands, rerun=False)
    assert res.verdict == "ambiguous" and set(res.ambiguous_set) == set(cands), res.timings["reason"]
    amb = {e["name"]: e for e in res.explanations if e.get("ambiguous")}
    assert set(amb) == set(cands) and amb["power@reg_5v"]["value"] == pytest.approx(0.8, abs=0.1)
    nxt = res.next_experiment
    assert nxt is not None and nxt["settles"] and nxt["separation_sigmas"] >= 3.0
    assert nxt["scheme"] in ("air", "grease") and "gyro_x" in nxt["probes"]  # where the two differ
    j = result_json(res)
    assert {k: j["next_experiment"][k] for k in ("scheme", "power_scale", "ambient_C", "duration_s", "probes")} == \
        {k: nxt[k] for k in ("scheme", "power_scale", "ambient_C", "duration_s", "probes")}
    assert "separation_K" in j["next_experiment"] and "Next experiment" in res.words
    from imutherm.reports.correlation_report import first_page_figure
    fig = first_page_figure(res)
    assert any("Next experiment" in t.get_text() for t in fig.texts)
    # the bench runs it (the same generator, the truth), and correlate is run again with the file added
    t = np.linspace(0.0, nxt["duration_s"], 40)
    second = _twin_run(Twin, truth, rng, nxt["scheme"], nxt["probes"], t, nxt["power_scale"], name="next.csv")
    again = correlate([first, second], models=models, candidates=cands, rerun=False)
    assert again.verdict == "effect" and again.named_effects == ("power@reg_5v",), again.timings["reason"]
    assert again.after.values["power@reg_5v"] == pytest.approx(0.8, abs=0.1) and again.next_experiment is None


@pytest.mark.slow
def test_the_closed_loop_through_the_finite_element_generator(tmp_path):
    """Closed loop on make_case's full FEM (a 4 mm generator mesh against the inversion's 6 mm, ±10 % nuisance on
    the board, mount and convection, noise and offsets): 0.4 W more at the 5 V regulator, the first file (air)
    handed over at gyro_x and accel_x only, where the 3.3 V regulator reads the same: ambiguous between the two
    (and the re-tune's power_scale, which ends at its upper bound 1.15 wanting more power: its move past the bound
    would make the 3.3 V regulator's reading at two probes, so it joins the set, issue 58 item 2).
    The proposed design is generated by make_case with the same truth (its scheme, power, duration, probes), the
    file added, correlate run again: the 5 V regulator named alone, within 1.5x of 0.4 W. A useless design (the
    first experiment repeated) added instead leaves it unsettled: the proposal, not more data, settles it."""
    from imutherm.measured import MeasuredRun, read_measured
    from imutherm.studies.correlation import build_models
    from imutherm.studies.correlation.hidden_effect import make_case
    models = build_models([("air", 70.0), ("grease", 70.0)], mesh_size_mm=6.0, min_cells=1)
    every = models.roms[("air", 70.0)].site_names
    cands = ("power@reg_5v", "power@reg_3v3")
    gen = {"value": 0.4, "mesh_size_mm": 4.0, "min_cells": 1, "sites": every}
    cases = []

    def measured(name, scheme, probes, power_scale=1.0, duration_s=1500.0, samples=40):
        # the same seed: make_case draws the same nuisance (the hidden value is given), so the same truth; every
        # site generated, the design's probes handed over
        case = make_case(tmp_path / name, "power@reg_5v", np.random.default_rng(7), experiments=((scheme, 70.0),),
                         power_scale=power_scale, t_end=duration_s, samples=samples, **gen)
        cases.append(case)
        r = read_measured(case.files[0])
        idx = [r.sites.index(s) for s in probes]
        return MeasuredRun(r.path, r.scheme, r.ambient_C, r.power_scale, r.t_power_on_s, r.probe, tuple(probes),
                           r.times_s, r.values_C[:, idx], r.lines)

    sites = ("gyro_x", "accel_x")
    first = measured("first", "air", sites)
    res = correlate([first], models=models, candidates=cands, rerun=False)
    assert res.verdict == "ambiguous" and set(cands) <= set(res.ambiguous_set) <= set(cands) | {"power_scale"}, \
        res.timings["reason"]
    nxt = res.next_experiment
    assert nxt is not None and nxt["settles"] and set(nxt["candidates"]) == set(res.ambiguous_set), nxt
    second = measured("next", nxt["scheme"], nxt["probes"], nxt["power_scale"], nxt["duration_s"])
    assert cases[1].nuisance == cases[0].nuisance
    settled = correlate([first, second], models=models, candidates=cands, rerun=False)
    assert settled.named_effects == ("power@reg_5v",), (settled.verdict, settled.timings["reason"])
    assert 0.4 / 1.5 <= settled.after.values["power@reg_5v"] <= 0.4 * 1.5
    repeat = measured("repeat", "air", sites, samples=41)  # the same truth, its own noise and probe offsets
    assert cases[2].nuisance == cases[0].nuisance
    useless = correlate([first, repeat], models=models, candidates=cands, rerun=False)
    assert useless.named_effects != ("power@reg_5v",), (useless.verdict, useless.timings["reason"])


# --------------------------------------------------------------------------- a knob at its bound and an effect in its place

#: a standoff contact on the toy whose pattern is nearly the cavity's own (both couple the boards to the housing):
#: per unit of log(1000 / h) [K]
_STANDOFF = {"air": np.array([5.5, 5.2, 4.4, 2.9, 2.7, 2.6]), "grease": np.array([1.1, 0.9, 1.0, 0.45, 0.5, 0.4])}


def _standoff_models():
    """The toy's models with a ``contact@standoff`` effect of pattern :data:`_STANDOFF` beside its own."""
    import _toy_reduced as toy
    from dataclasses import replace
    from imutherm.unit import knobs

    class Standoff(toy.ToyReduced):
        def __init__(self, scheme):
            super().__init__(scheme)
            self.knobs["contact@standoff"] = knobs.effect_knob("contact@standoff")

        def gain_tau(self, values):
            g, _ = super().gain_tau({k: v for k, v in values.items() if k != "contact@standoff"})
            dT, tau = toy.BASE[self.scheme]
            if "contact@standoff" in values:
                g = g + _STANDOFF[self.scheme] * np.log(1000.0 / values["contact@standoff"])
            return g, tau * (g / dT) ** 0.5

    m = toy.toy_models()
    return replace(m, roms={k: Standoff(k[0]) for k in m.roms}), Standoff


def _standoff_runs(Standoff, values, rng, samples=40):
    from imutherm.measured import MeasuredRun
    import _toy_reduced as toy
    t = np.linspace(0.0, 1500.0, samples)
    out = []
    for s in ("air", "grease"):
        y = Standoff(s).rise(values, t)
        out.append(MeasuredRun(f"{s}.csv", s, 70.0, 1.0, 0.0, "die", toy.SITES, t,
                               70.0 + y + rng.normal(0.0, 0.05, y.shape), tuple(range(samples))))
    return out


def test_an_effect_named_in_the_place_of_a_knob_at_its_bound_is_ambiguous_with_it():
    """Issue 58's held-out seed 62: the cavity emissivity ended at the re-tune's lower bound (0.02) and
    contact@standoff, not hidden, was named in its place. Toy: the data pull the cavity's coupling past the bound
    (-0.25 in the toy's linear law: weaker than any emissivity the model allows), and a standoff contact whose
    pattern is nearly the cavity's is a candidate. Before the rule it was named (ΔAICc 576); now the two are
    ambiguous, the knob with the direction it wants, listed among the explanations, and the next experiment
    separates them. A standoff truly hidden (h 400, the cavity at nominal) is still named, at its value; a
    regulator's power beside three knobs at their bounds too (the rule takes only an effect the freed knob makes)."""
    from _toy_reduced import toy_models, toy_runs
    models, Standoff = _standoff_models()
    cands = CANDIDATES + ("contact@standoff",)
    res = correlate(_standoff_runs(Standoff, {**NUISANCE, "cavity_emissivity": -0.25}, np.random.default_rng(5)),
                    models=models, candidates=cands, rerun=False)
    assert res.verdict == "ambiguous" and res.named_effects == (), res.timings["reason"]
    assert set(res.ambiguous_set) == {"contact@standoff", "cavity_emissivity"}
    assert "cavity_emissivity wants below 0.02" in res.timings["reason"]
    s = next(x for x in res.symptoms if x.parameter == "cavity_emissivity")
    assert s.bound == "lower"
    knob = next(e for e in res.explanations if e["name"] == "cavity_emissivity")
    assert knob["kind"] == "parameter" and knob["ambiguous"] and knob["value"] == pytest.approx(0.02, rel=1e-3)
    nxt = res.next_experiment
    assert nxt is not None and set(nxt["candidates"]) == {"contact@standoff", "cavity_emissivity"}
    assert result_json(res)["next_experiment"]["candidates"] == nxt["candidates"]
    real = correlate(_standoff_runs(Standoff, {**NUISANCE, "contact@standoff": 400.0}, np.random.default_rng(5)),
                     models=models, candidates=cands, rerun=False)
    assert real.named_effects == ("contact@standoff",), real.timings["reason"]
    assert real.after.values["contact@standoff"] == pytest.approx(400.0, rel=0.15)
    beside = correlate(toy_runs({**NUISANCE, "power_scale": 1.30, "power@reg_5v": 0.3}, np.random.default_rng(3)),
                       models=toy_models(), candidates=CANDIDATES, rerun=False)
    assert beside.named_effects == ("power@reg_5v",), beside.timings["reason"]
    assert {x.parameter for x in beside.symptoms if x.bound in ("lower", "upper")} >= {"power_scale"}


def test_a_knob_at_its_bound_joins_an_ambiguous_set_whose_candidate_it_would_make():
    """Issue 58 item 2: air data only, the cavity's coupling pulled past the re-tune's lower bound as above, and two
    candidates that read the same in air (a standoff and a board joint of one pattern): the verdict is ambiguous
    between the two, and the knob, whose move past its bound would make the first, joins the set with its value
    at the bound and the direction it wants; the next experiment is computed over all three."""
    import _toy_reduced as toy
    from dataclasses import replace
    from imutherm.measured import MeasuredRun
    from imutherm.unit import knobs
    pats = {"contact@standoff": _STANDOFF, "contact@board": {"air": _STANDOFF["air"],
                                                             "grease": _STANDOFF["grease"] + [0, 0, 0, 0.3, 0, 0]}}

    class Pair(toy.ToyReduced):
        def __init__(self, scheme):
            super().__init__(scheme)
            self.knobs.update({n: knobs.effect_knob(n) for n in pats})

        def gain_tau(self, values):
            g, _ = super().gain_tau({k: v for k, v in values.items() if k not in pats})
            dT, tau = toy.BASE[self.scheme]
            for n, p in pats.items():
                if n in values:
                    g = g + p[self.scheme] * np.log(1000.0 / values[n])
            return g, tau * (g / dT) ** 0.5

    m = toy.toy_models()
    models = replace(m, roms={k: Pair(k[0]) for k in m.roms})
    t = np.linspace(0.0, 1500.0, 40)
    y = Pair("air").rise({**NUISANCE, "cavity_emissivity": -0.25}, t)
    run = MeasuredRun("air.csv", "air", 70.0, 1.0, 0.0, "die", toy.SITES, t,
                      70.0 + y + np.random.default_rng(5).normal(0.0, 0.05, y.shape), tuple(range(40)))
    res = correlate([run], models=models, candidates=CANDIDATES + tuple(pats), rerun=False)
    assert res.verdict == "ambiguous" and set(res.ambiguous_set) == set(pats) | {"cavity_emissivity"}, \
        res.timings["reason"]
    assert "the knob joins the ambiguous set" in res.timings["reason"]
    knob = next(e for e in res.explanations if e["name"] == "cavity_emissivity")
    assert knob["kind"] == "parameter" and "wants below 0.02" in knob["in_words"]
    assert set(res.next_experiment["candidates"]) == set(res.ambiguous_set)
