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
