"""The correlation workflow: verdict rules, hold-out design, noise estimate, the CLI, and proven blind:
a hidden effect in full-model data on a finer mesh is named and the gap shrinks (slow, coarse meshes)."""

import dataclasses
import json
import sys
from pathlib import Path
import math

import numpy as np
import pytest

from imutherm.cli import correlate as cli
from imutherm.measured import MeasuredRun, read_measured, write_measured
from imutherm.studies.correlation import (SPARSE_NOISE_K, Fit, build_models, correlate, heldout_worse_z, noise_sigma,
                                          result_json, updated_model_toml, verdict)
from imutherm.studies.correlation.holdout import holdout_folds
from imutherm.studies.correlation.hidden_effect import make_case

sys.path.insert(0, str(Path(__file__).resolve().parent))  # tests/_toy_reduced.py

KEYS = ("verdict", "named_effect", "parameters", "ranking", "rms_before_K", "rms_after_K", "max_before_K",
        "max_after_K", "heldout_rms_before_K", "heldout_rms_after_K")
#: the inversion's mesh in these tests (coarse, one cell across the thinnest part) and the generator's (finer)
INV_MM, GEN_MM = 6.0, 3.0
#: the model-form cases' generator mesh (the s2s law's view factors and radiosity cost more per node)
MF_GEN_MM = 5.0


def _fit(name, aicc, held, rms=None):
    rms = held if rms is None else rms
    return Fit(name, {}, rms, rms, 100, 50.0, 7, aicc, held, held)


def test_verdict_rules():
    none = _fit("none", 0.0, 1.0)
    # a clear winner: ahead of none by >= 10 and of the runner-up by >= 6, held-out better
    assert verdict(none, [_fit("a", -40, 0.12), _fit("b", -20, 0.5)], 0.05)[:2] == ("effect", "a")
    # two within the margin: ambiguous, both named
    v = verdict(none, [_fit("a", -40, 0.12), _fit("b", -37, 0.13)], 0.05)
    assert v[0] == "ambiguous" and set(v[2]) == {"a", "b"}
    # the re-tuned model already predicts within the noise: none
    assert verdict(_fit("none", 0.0, 0.08), [_fit("a", -5, 0.07)], 0.05)[0] == "none"
    # the best candidate still leaves far more than the noise and half the gap: not in the library
    assert verdict(none, [_fit("a", -40, 0.8)], 0.05)[0] == "not_in_library"
    # nothing clears the margin over none
    assert verdict(none, [_fit("a", -4, 0.9)], 0.05)[0] == "not_in_library"
    # a large ΔAICc from a change far below the noise (hundreds of readings fitting the model's own
    # discretisation error) is not an effect: sqrt(0.08^2 - 0.075^2) = 0.028 K < 1 x 0.05 K
    assert verdict(_fit("none", 0.0, 0.09, rms=0.08), [_fit("a", -30, 0.08, rms=0.075)], 0.05)[0] == "none"
    # sparse data (no AICc): by held-out RMS, a candidate must halve it
    nan = float("nan")
    assert verdict(_fit("none", nan, 4.0), [_fit("a", nan, 0.5), _fit("b", nan, 3.0)], 0.5)[:2] == ("effect", "a")
    assert verdict(_fit("none", nan, 4.0), [_fit("a", nan, 0.5), _fit("b", nan, 0.6)], 0.5)[0] == "ambiguous"
    assert verdict(_fit("none", nan, 4.0), [_fit("a", nan, 2.5)], 0.5)[0] == "not_in_library"


def _evidence_fit(name, aicc, series_ms, n=20):
    """A fit on the discrepancy term's path whose held-out readings are 12 series of ``n`` with these mean
    squares [K^2] (one per series)."""
    blocks = tuple(((0, k // 6, k % 6), float(ms) * n, n) for k, ms in enumerate(series_ms))
    held = float(np.sqrt(np.mean(series_ms)))
    return dataclasses.replace(_fit(name, aicc, held), criterion="evidence", heldout_blocks=blocks, signature_K=1.0)


def test_a_further_effect_on_a_model_within_the_noise_must_halve_what_is_left():
    """Forward selection without the term, from its second step on: once the effects named so far predict
    held-out data within 2 noise sigmas, a further one must halve what they leave (the mild campaign's bond line,
    0.097 K held out at noise 0.050 K, then power@reg_3v3, not hidden, for 0.083 K); on a model still well above
    the noise (two effects hidden together) a further effect needs only to predict better."""
    first = _fit("none", 0.0, 2.17)
    bond = _fit("contact@bond", -258.0, 0.097)
    assert verdict(bond, [_fit("contact@bond+power@reg_3v3", -270.1, 0.083)], 0.05, first)[0] == "none"
    assert verdict(bond, [_fit("contact@bond+x", -300.0, 0.045)], 0.05, first)[:2] == ("effect", "contact@bond+x")
    far = _fit("power@reg_5v", -200.0, 0.40)  # 8 noise sigmas left: the second hidden effect
    assert verdict(far, [_fit("power@reg_5v+contact@bond", -260.0, 0.30)], 0.05, first)[0] == "effect"


def test_the_held_out_difference_is_judged_against_its_series_scatter():
    """``heldout_worse_z``: the same 2.2 % worse held out (the gross path's 0.20 W regulator: 0.0443 against
    0.0433 K) is unresolved when the 12 held-out series scatter about the difference and resolved when every
    series is worse by it. The verdict's guard on the term's path (HELDOUT_WORSE_MARGIN): a candidate that
    predicts held-out data worse at all is named only with twice the evidence margin and an unresolved loss;
    one that predicts them no worse needs the plain margin."""
    rng = np.random.default_rng(3)
    base_ms = rng.uniform(0.3, 1.7, 12)
    base_ms *= 0.0433**2 / base_ms.mean()
    base = _evidence_fit("none", 0.0, base_ms)
    shift = 0.0443**2 - 0.0433**2
    noise = rng.normal(0.0, 4 * shift, 12)
    scatter = base_ms + shift + noise - noise.mean()  # better in some series, worse in others
    steady = base_ms + shift  # worse by the same in every series
    a, b = _evidence_fit("a", -30, scatter), _evidence_fit("a", -30, steady)
    assert a.heldout_rms_K == pytest.approx(b.heldout_rms_K, rel=1e-9) == pytest.approx(0.0443, rel=1e-9)
    assert 0.0 < heldout_worse_z(a, base) < 2.0 < heldout_worse_z(b, base)
    assert heldout_worse_z(base, a) == pytest.approx(-heldout_worse_z(a, base))
    assert math.isnan(heldout_worse_z(dataclasses.replace(a, heldout_blocks=()), base))
    assert verdict(base, [a], 0.05)[:2] == ("effect", "a")       # ΔC 30, 2.2 % worse, unresolved (z < 2)
    assert verdict(base, [b], 0.05)[0] != "effect"                # the same loss, resolved (z > 2)
    weak_worse = _evidence_fit("a", -15, base_ms * 1.01**2)       # ΔC 15 < 20 and 1 % worse (the toy nulls)
    assert verdict(base, [weak_worse], 0.05)[0] != "effect"
    assert verdict(base, [_evidence_fit("a", -15, base_ms * 0.99**2)], 0.05)[:2] == ("effect", "a")  # no worse


def test_a_refused_better_fit_makes_the_verdict_ambiguous_and_says_why():
    """A candidate refused on held-out data that fits better than the best acceptable one keeps the lesser one
    from being named: ambiguous, ordered by evidence, the refusal in the reason (the gross path's 0.20 W
    regulator beside its neighbour at the 1.8 V regulator)."""
    rng = np.random.default_rng(5)
    base_ms = rng.uniform(0.3, 1.7, 12)
    base_ms *= 0.0433**2 / base_ms.mean()
    base = _evidence_fit("none", 0.0, base_ms)
    worse = _evidence_fit("power@reg_5v", -28.9, base_ms * 1.08**2)   # fits best, resolved 8 % worse held out
    ok = _evidence_fit("power@reg_1v8", -16.9, base_ms * 0.999**2)
    v, named, amb, reason = verdict(base, [worse, ok], 0.05)
    assert (v, named, amb) == ("ambiguous", None, ("power@reg_5v", "power@reg_1v8"))
    assert "power@reg_5v fits better" in reason and "refused" in reason and "held-out" in reason


def _run(path, scheme, times, values, sites=("tp1",)):
    v = np.asarray(values, float).reshape(len(times), len(sites))
    return MeasuredRun(path, scheme, 70.0, 1.0, 0.0, "die", sites, np.asarray(times, float), v,
                       tuple(range(len(times))))


def test_hold_out_design():
    """Sparse files: leave one reading out; dense files: fit early, predict late; or leave a named file out."""
    sparse = [_run("a.csv", "air", [800.0, np.inf], [89.0, 90.0]), _run("g.csv", "grease", [300.0, np.inf], [77.6, 78])]
    folds = holdout_folds(sparse, "auto")
    assert len(folds) == 4
    for train, test in folds:  # each reading is held out once and trained on otherwise
        assert sum(int(m.sum()) for m in test.values()) == 1
        assert sum(int(m.sum()) for m in train.values()) == 3
    t = np.linspace(0, 1000, 20)
    dense = [_run("a.csv", "air", t, 70 + t / 100), _run("g.csv", "grease", t, 70 + t / 200)]
    (train, test), = holdout_folds(dense, "auto")
    for i in (0, 1):  # each file: its first 60 % of the time, then the rest
        assert int(train[i].sum()) == 12 and int(test[i].sum()) == 8
    (train, test), = holdout_folds(dense, "g.csv")
    assert int(test[1].sum()) == 20 and int(train[1].sum()) == 0
    with pytest.raises(Exception, match="--holdout 'x.csv': not one of the measured files"):
        holdout_folds(dense, "x.csv")


def test_noise_estimate_from_second_differences():
    rng = np.random.default_rng(0)
    t = np.linspace(0, 1000, 400)
    y = 70 + 10 * (1 - np.exp(-t / 200))[:, None] + rng.normal(0, 0.1, (400, 2))
    run = MeasuredRun("x.csv", "air", 70.0, 1.0, 0.0, "die", ("tp1", "tp2"), t, y, tuple(range(400)))
    assert noise_sigma(run) == pytest.approx(0.1, rel=0.15)
    sparse = _run("y.csv", "air", [800.0, np.inf], [89.0, 90.0])
    assert noise_sigma(sparse) == SPARSE_NOISE_K


def test_cli_lists_effects_and_refuses_bad_input(tmp_path, capsys):
    assert cli.main(["--list-effects"]) == 0
    out = capsys.readouterr().out
    assert "contact" in out and "probe_lag" in out
    assert cli.main(["--out", str(tmp_path / "o")]) == 2
    assert "--measured" in capsys.readouterr().err
    bad = tmp_path / "bad.csv"
    write_measured(bad, {"scheme": "vacuum", "ambient_C": 70.0}, ("tp1",), [0.0, 100.0], [[70.0], [75.0]])
    assert cli.main(["--measured", str(bad), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "bad.csv" in err and "vacuum" in err
    assert not (tmp_path / "o").exists()  # nothing half-written


def test_a_power_candidate_cannot_take_a_part_below_zero_power():
    """The fit's power@part bound: the part's layout power x the re-tune's lowest power_scale x the smallest
    run's power_scale, not the library's -1 W (which let the fit draw -1 W from the 0.04 W ADC on the paper's figures)."""
    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.layout import load_layout
    from imutherm.studies.correlation.fit import _knobs_for
    from imutherm.studies.correlation.forward_model import ForwardModel
    from imutherm.unit import knobs
    from imutherm.unit.effects import power_part

    lay = load_layout(None)
    geos = {s: build_geometry(lay, s) for s in ("air", "grease")}
    runs = [_run("a.csv", "air", [800.0], [89.0]), _run("g.csv", "grease", [300.0], [77.0])]
    runs[1] = MeasuredRun("g.csv", "grease", 70.0, 0.9, 0.0, "die", ("tp1",), np.array([300.0]),
                          np.array([[77.0]]), (0,))
    fwd = ForwardModel(runs, {}, geos)
    adc_W = power_part(geos["air"], "adc").power_W
    assert 0.0 < adc_W < 1.0  # the layout's ADC draws well under the library's 1 W
    knob = _knobs_for("power@adc", fwd)[-1]
    assert knob.name == "power@adc" and knob.part == "adc"
    assert knob.lo == pytest.approx(-adc_W * 0.85 * 0.9, rel=1e-12)
    assert knob.hi == 1.0
    # the worst case of every run at every re-tune keeps the part at or above zero
    assert adc_W * 0.85 * min(r.power_scale for r in runs) + knob.lo >= -1e-12
    # a part above 1 W keeps the library's -1 W; an unpowered target is floored at zero
    assert knobs.effect_knob("power@adc", min_power_W=2.5).lo == -1.0
    assert knobs.effect_knob("power@adc", min_power_W=0.0).lo == 0.0
    assert knobs.effect_knob("power@adc").lo == -1.0  # the reduced model's knob: the load is exact for any value


@pytest.fixture(scope="module")
def models():
    return build_models([("air", 70.0), ("grease", 70.0)], mesh_size_mm=INV_MM, min_cells=1)


@pytest.fixture(scope="module")
def models_effective():
    """The inversion's reduced models with the cavity law named (the effective conductivity), for the tests
    whose data are made with the other law (s2s) or whose figures depend on the law."""
    from imutherm.unit.model import ModelOptions
    return build_models([("air", 70.0), ("grease", 70.0)], mesh_size_mm=INV_MM, min_cells=1,
                        options=ModelOptions(cavity_law="effective"))


@pytest.mark.slow
def test_hidden_power_error_is_named_and_the_gap_shrinks(tmp_path, models):
    """0.35 W more at the 5 V regulator, generated on a finer mesh with ±10 % nuisance and noise, found blind."""
    case = make_case(tmp_path / "case", "power@reg_5v", np.random.default_rng(3), mesh_size_mm=GEN_MM, min_cells=1,
                     value=0.35, samples=30)
    runs = [read_measured(f) for f in case.files]
    res = correlate(runs, models=models)
    j = json.loads(json.dumps(result_json(res)))
    for k in KEYS:
        assert k in j
    assert res.verdict == "effect" and res.named_effect == "power@reg_5v"
    lo, hi = j["parameters"]["power@reg_5v"]["ci95"]
    assert lo <= 0.35 * 1.3 and hi >= 0.35 * 0.7  # the fitted power covers the hidden one (nuisance: ±10 %)
    assert j["heldout_rms_after_K"] <= 0.3 * j["heldout_rms_before_K"]
    # the corrected model re-run on the full FEM (the inversion's mesh) agrees with the reduced model's fit
    assert j["after_from"] == "full model re-run"
    assert j["rms_after_K"] <= 0.3 * j["rms_before_K"]
    assert abs(j["rms_after_K"] - j["rms_after_reduced_K"]) <= 0.3 * j["rms_before_K"]


@pytest.mark.slow
def test_no_hidden_effect_is_not_called_an_effect(tmp_path, models):
    """Null case: nuisance errors (±10 %), noise and offsets only: the verdict must not name an effect."""
    case = make_case(tmp_path / "case", "none", np.random.default_rng(11), mesh_size_mm=GEN_MM, min_cells=1,
                     samples=30)
    res = correlate([read_measured(f) for f in case.files], models=models, rerun=False)
    assert res.verdict != "effect", (res.verdict, res.named_effect, res.timings["reason"])


@pytest.mark.slow
def test_a_file_shorter_than_the_time_constant_is_refused(tmp_path, models):
    p = tmp_path / "short.csv"
    write_measured(p, {"scheme": "air", "ambient_C": 70.0}, ("tp1",), [0.0, 2.0, 4.0, 6.0], [[70.0]] * 4)
    with pytest.raises(Exception, match=r"short\.csv:.*ends at 6 s, before the model's time constant"):
        correlate([read_measured(p)], models=models)


@pytest.mark.slow
def test_cli_end_to_end_writes_the_outputs(tmp_path):
    """The paper's two sparse figures through the CLI on a coarse mesh: json, updated model, PDF."""
    from pypdf import PdfReader
    from pathlib import Path
    ex = Path(__file__).resolve().parents[1] / "examples" / "measured"
    out = tmp_path / "corr"
    assert cli.main(["--measured", str(ex / "paper_000_air.csv"), str(ex / "paper_000_grease.csv"),
                     "--mesh-size", str(INV_MM), "--min-cells", "1", "--out", str(out)]) == 0
    j = json.loads((out / "correlation.json").read_text())
    for k in KEYS:
        assert k in j
    assert j["verdict"] in ("effect", "finding", "none", "ambiguous", "not_in_library", "discrepancy")
    assert j["written_model"]["model"] in ("corrected", "corrected without the term", "nominal")
    assert math.isfinite(j["rms_after_K"]) and j["rms_after_K"] < j["rms_before_K"]
    assert "[retune]" in (out / "updated_model.toml").read_text()
    assert len(PdfReader(out / "correlation.pdf").pages) >= 3


# ------------------------------------------- data the model did not make: noise, duplicates, selection

def test_noise_estimate_ignores_a_cycle_sampled_five_times_a_period():
    """Probe noise 0.05 K on six sites plus a chamber cycle of 0.4 K sampled 5 times per period (the last
    campaign's miss: the MAD of second differences read 0.10 K): the estimate stays within 0.05 K x
    [0.8, 1.5], and a smooth residual (a slow drift) does not move it either."""
    rng = np.random.default_rng(4)
    n, m = 40, 6
    t = np.linspace(0, 1500, n)
    period = 5 * (t[1] - t[0])
    rise = 20 * (1 - np.exp(-t / 200))[:, None] * np.linspace(0.5, 1.0, m)
    cycle = 0.4 * np.cos(2 * np.pi * t / period + 0.7)[:, None] * np.linspace(0.6, 1.0, m)
    noise = rng.normal(0, 0.05, (n, m))
    sites = ("tp1", "tp2", "tp3", "gyro_x", "gyro_y", "gyro_z")
    cyc = MeasuredRun("c.csv", "air", 70.0, 1.0, 0.0, "die", sites, t, 70 + rise + cycle + noise, tuple(range(n)))
    assert 0.8 * 0.05 <= noise_sigma(cyc) <= 1.5 * 0.05
    # the previous estimate (MAD of second differences / sqrt 6) counted the cycle as noise
    d2 = np.diff(cyc.values_C, 2, axis=0)
    mad = np.median(1.4826 * np.median(np.abs(d2 - np.median(d2, axis=0)), axis=0) / math.sqrt(6))
    assert mad > 3 * 0.05
    drift = MeasuredRun("d.csv", "air", 70.0, 1.0, 0.0, "die", sites, t,
                        70 + rise + 0.5 * np.sin(np.pi * t / 1500)[:, None] + noise, tuple(range(n)))
    assert 0.8 * 0.05 <= noise_sigma(drift) <= 1.5 * 0.05


def test_the_same_measured_file_given_twice_is_refused(tmp_path, capsys):
    """By content, not by path: the same file twice, and a copy with other comments and number formatting."""
    a = tmp_path / "air.csv"
    write_measured(a, {"scheme": "air", "ambient_C": 70.0}, ("tp1", "tp2"), [0.0, 100.0, 400.0],
                   [[70.0, 70.0], [75.0, 74.0], [80.0, 78.5]])
    copy = tmp_path / "copy.csv"
    text = a.read_text().replace(",75.0000,", ",75.00,").replace("# scheme", "# a copy of air.csv\n# scheme")
    copy.write_text(text)
    other = tmp_path / "other.csv"
    write_measured(other, {"scheme": "air", "ambient_C": 70.0}, ("tp1", "tp2"), [0.0, 100.0, 400.0],
                   [[70.0, 70.0], [75.1, 74.0], [80.0, 78.5]])
    from imutherm import InputError
    from imutherm.studies.correlation import refuse_duplicates
    runs = [read_measured(p) for p in (a, copy)]
    assert runs[0].path != runs[1].path
    with pytest.raises(InputError, match=r"copy\.csv: the same readings as .*air\.csv"):
        refuse_duplicates(runs)
    with pytest.raises(InputError, match=r"air\.csv: the same file"):
        correlate([runs[0], runs[0]], models=None)  # refused before any model is built
    refuse_duplicates([read_measured(a), read_measured(other)])  # one reading differs: two experiments
    assert cli.main(["--measured", str(a), str(copy), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "given twice" in err and "Traceback" not in err
    assert not (tmp_path / "o").exists()


def test_effects_compatible_in_one_selection():
    """Two effects of one kind at two places may be chosen together; one effect not twice; two contacts that
    each share the board's conductivity with the reduced model's joint interpolation not together."""
    from imutherm.studies.correlation.selection import _compatible
    assert _compatible(("power@reg_5v",), "power@reg_3v3")
    assert not _compatible(("power@reg_5v",), "power@reg_5v")
    assert _compatible(("contact@board",), "contact@bond")
    assert not _compatible(("contact@board",), "contact@standoff")
    assert _compatible((), "contact@standoff")


def test_discrepancy_basis_is_smooth_and_scaled_with_the_rise():
    """The discrepancy's basis per series: ΔT s(t) and ΔT 4 s (1 - s), s the nominal normalised response:
    zero at power-on, the gain column equal to the site's rise on the plateau, the time-constant column
    vanishing there; its ridge is the posterior mean with the stated prior."""
    from imutherm.studies.correlation import Discrepancy

    class _F:  # a one-site, one-run stand-in for the forward model: a first-order rise of 10 K, tau 100 s
        runs = (_run("a.csv", "air", np.concatenate([np.linspace(0, 1500, 31), [np.inf]]), np.zeros(32)),)

        def rise(self, i, values, times=None):
            t = self.runs[0].times_s if times is None else np.asarray(times, float)
            return (10 * (1 - np.exp(-t / 100)))[:, None]

    from imutherm.studies.correlation import build_discrepancy
    d = build_discrepancy(_F(), {}, sigma_K=0.05, ratio=0.5, prior=0.1)
    F = d.basis[(0, 0)]
    assert F[0] == pytest.approx([0.0, 0.0])
    assert F[-1] == pytest.approx([10.0, 0.0])  # the steady row: the whole rise, no time-constant part
    assert 9.0 < np.max(F[:, 1]) <= 10.0  # 4 s (1 - s) peaks at 1 where s = 1/2 (between two readings here)
    assert d.lam == pytest.approx(0.05**2 / 0.5 / 0.1**2)
    # a 5 % gain error is recovered (posterior mean), a tiny ridge shrinkage
    r = 0.05 * F[:, 0]
    c = d.coefficients(r, 0, 0, np.ones(32, bool))
    assert c[0] == pytest.approx(0.05, rel=1e-3) and abs(c[1]) < 1e-3
    assert isinstance(d, Discrepancy)


def test_the_discrepancy_scale_is_its_maximum_likelihood_and_the_evidence_is_exact():
    """Discrepancy.profile: the prior scale by type-II maximum likelihood and C, -2 log of the marginal
    likelihood of the residual up to n log(2π s²). C equals the brute-force Gaussian with covariance
    s² I + p² Φ Φᵀ at any p; a residual of coefficients (0.05, 0.05) plus noise gives p within 10 % of 0.05;
    pure noise gives a scale that costs nothing (Occam factor ~0, p ~1e-6 of the rise)."""
    from imutherm.studies.correlation import DISCREPANCY_PRIOR_RANGE, build_discrepancy

    t = np.concatenate([np.linspace(0, 1500, 61), [np.inf]])

    base = 10 * (1 - np.exp(-t / 200))  # one run, one site: a first-order rise of 10 K, tau 200 s

    class _F:  # the model = the measured rise + the residual
        def __init__(self, resid):
            self.resid = resid
            self.runs = (_run("a.csv", "air", t, 70.0 + base),)

        def rise(self, i, values, times=None):
            if times is not None:  # the basis asks for the plateau: the model's own rise
                return (10 * (1 - np.exp(-np.asarray(times, float) / 200)))[:, None]
            return (base + self.resid)[:, None]

    sigma, ratio = 0.05, 1.0
    rng = np.random.default_rng(3)
    d = build_discrepancy(_F(np.zeros(len(t))), {}, sigma_K=sigma, ratio=ratio, prior=0.05)
    F = d.basis[(0, 0)]
    r = F @ np.array([0.05, 0.05]) + rng.normal(0, sigma, len(t))
    mask = {0: np.ones((len(t), 1), bool)}
    ps, C = d.profile(_F(r), {}, mask)
    p = ps["air"]  # one scale per cooling scheme
    assert set(ps) == {"air"} and p == pytest.approx(0.05, rel=0.1)
    # brute force: -2 log N(r; 0, s² I + p² F Fᵀ) + n log(2π s²) at p and at two other scales
    for q in (p, 0.01, 0.2):
        cov = sigma**2 * np.eye(len(t)) + q**2 * F @ F.T
        brute = float(r @ np.linalg.solve(cov, r) + np.linalg.slogdet(cov)[1] - len(t) * np.log(sigma**2))
        lam = sigma**2 / q**2
        closed = float((r @ r - r @ F @ np.linalg.solve(F.T @ F + lam * np.eye(2), F.T @ r)) / sigma**2
                       + np.linalg.slogdet(np.eye(2) + F.T @ F / lam)[1])
        assert closed == pytest.approx(brute, rel=1e-9)
        if q == p:
            assert C == pytest.approx(brute, rel=1e-6)
    p0, C0 = d.profile(_F(rng.normal(0, sigma, len(t))), {}, mask)
    assert p0["air"] < 1e-3 and p0["air"] >= DISCREPANCY_PRIOR_RANGE[0]


def test_with_the_discrepancy_term_a_real_effect_is_named_and_the_term_vanishes():
    """Toy data of the model's own form: a 0.3 W regulator error hidden. With the discrepancy term (its scale
    estimated per fit), the effect is named and, with it, the term's scale falls to below 0.3 % of the rise
    (it was ~3 % on the re-tuned model, which the error made wrong): the failure that kept the term opt-in at a
    fixed 5 % prior (the term took the effect: 'ambiguous') does not occur. With a smooth form error on top the
    effect is named when it explains the model's error (the term it leaves within 2 noise sigmas or halved:
    0.6 W on a 12 % form error) or when it is far beyond what the term leaves where it acts and the plain re-tune
    misses held-out data by more than 2 noise sigmas (issue 58: 0.15 W on 12 %, its signature 0.86 K in air
    against 0.25 K of term left, the plain re-tune ~0.22 K held out at noise 0.06 K: named, at its value), and
    the verdict abstains ('discrepancy', the best candidate said) when it is neither (0.08 W on 12 %)."""
    from _toy_reduced import toy_models, toy_runs
    models = toy_models()
    runs = toy_runs({**_TOY_NUISANCE, "power@reg_5v": 0.3}, np.random.default_rng(1))
    res = correlate(runs, models=models, candidates=_TOY_CANDIDATES, rerun=False, discrepancy=True)
    assert res.named_effects == ("power@reg_5v",), res.timings["reason"]
    assert res.after.values["power@reg_5v"] == pytest.approx(0.3, abs=0.1)
    assert res.retune.disc_prior > 0.01 and res.after.disc_prior < 0.003
    assert result_json(res)["discrepancy"]["prior_fraction_after"] == res.after.disc_prior
    big = toy_runs({**_TOY_NUISANCE, "power@reg_5v": 0.6}, np.random.default_rng(3), _toy_form(0.12))
    res = correlate(big, models=models, candidates=_TOY_CANDIDATES, rerun=False, discrepancy=True)
    assert res.named_effects[:1] == ("power@reg_5v",), res.timings["reason"]
    assert res.after.disc_rms_K <= 0.5 * res.retune.disc_rms_K
    far = toy_runs({**_TOY_NUISANCE, "power@reg_5v": 0.15}, np.random.default_rng(3), _toy_form(0.12))
    res = correlate(far, models=models, candidates=_TOY_CANDIDATES, rerun=False, discrepancy=True)
    assert res.named_effects[:1] == ("power@reg_5v",), res.timings["reason"]
    assert res.after.values["power@reg_5v"] == pytest.approx(0.15, abs=0.03)
    same = toy_runs({**_TOY_NUISANCE, "power@reg_5v": 0.08}, np.random.default_rng(3), _toy_form(0.12))
    res = correlate(same, models=models, candidates=_TOY_CANDIDATES, rerun=False, discrepancy=True)
    assert res.named_effects == () and res.verdict == "discrepancy", res.timings["reason"]
    assert "no library effect qualifies" in res.timings["reason"]


def test_an_effect_is_judged_where_it_acts_under_another_schemes_gross_form_error():
    """A poor bond line (h 150 W/m^2 K, grease scheme only) under a 12 % form error in air and 1 % in grease:
    the discrepancy term has one scale per scheme, so the grease term stays tight and the bond line must, and
    does, explain it; it is named, and the effect forward selection tries next (the cavity's emissivity, acting
    where the air form error is) is not, because it leaves the air scheme's term. With one scale for both
    schemes (the term of the previous version) the air error kept the grease term loose and the case was
    'discrepancy'; nulls of the same form error stay 'discrepancy'."""
    from _toy_reduced import toy_models, toy_runs
    models = toy_models()

    def form(s, t):  # 12 % of the rise in air, 1 % in grease
        return (0.12 if s == "air" else 0.01) * np.linspace(17, 8, 6) * (1 - np.exp(-t / 150))[:, None]

    runs = toy_runs({**_TOY_NUISANCE, "contact@bond": 150.0}, np.random.default_rng(3), form)
    res = correlate(runs, models=models, candidates=_TOY_CANDIDATES, rerun=False, discrepancy=True)
    assert res.named_effects == ("contact@bond",), res.timings["reason"]
    assert 75.0 < res.after.values["contact@bond"] < 300.0  # within 2x of the hidden 150 W/m^2 K
    assert set(res.retune.disc_priors) == {"air", "grease"}
    # before the bond line the grease term carries it; with it, the grease term's scale falls
    assert res.after.disc_priors["grease"] < res.retune.disc_priors["grease"] / 3
    assert res.after.disc_rms_by["grease"] <= 0.5 * res.retune.disc_rms_by["grease"]
    null = correlate(toy_runs(dict(_TOY_NUISANCE), np.random.default_rng(3), form), models=models,
                     candidates=_TOY_CANDIDATES, rerun=False, discrepancy=True)
    # no library effect; the air error looks to the re-tune like a weaker cavity radiation, which takes the cavity's
    # emissivity to 0.35, far outside its source's 0.63-0.86: since the blind campaign that move is named as a finding,
    # flagged as contradicting its source (without it the verdict was 'discrepancy', as before)
    assert null.named_effects == () and null.verdict in ("discrepancy", "finding"), null.timings["reason"]
    assert all(f.parameter == "cavity_emissivity" and f.contradicts_source for f in null.findings)


def test_what_an_effect_must_gain_without_the_term_and_leave_with_it():
    """The two standards a named effect is held to, with the figures of the gross campaign (2026-12-03) that
    set them. Without the term (``auto``'s first pass): the choice must predict held-out data within 2 noise
    sigmas *and* halve the re-tuned model's held-out error, else the term is asked (a weaker cavity
    emissivity re-tuned to 0.128 K held out, 2.5 sigmas, then named ``contact@board`` at 0.076 K: a gain of
    a form error's size). With the term: where the effects act, the term they leave within 2 noise sigmas or
    halved (a lid heat load named ``contact@bond`` left 0.153 K in grease, 2.96 sigmas, of 0.2 K)."""
    from imutherm.studies.correlation import explains_term
    from imutherm.studies.correlation.verdict import plain_explains
    noise = 0.052
    chosen = _fit("contact@board", -380.0, 0.076)
    sel = ([{"verdict": "effect"}, {"verdict": "none"}], [chosen])
    assert plain_explains(sel, noise)  # within 2 sigmas: the old standard alone
    assert not plain_explains(sel, noise, _fit("none", 0.0, 0.128))  # 0.076 > 0.128 / 2
    assert plain_explains(sel, noise, _fit("none", 0.0, 0.9))  # a real effect's gain
    assert not plain_explains(([{"verdict": "effect"}], [_fit("a", -90.0, 0.2)]), noise, _fit("none", 0.0, 0.9))
    assert plain_explains(([{"verdict": "none"}], []), noise, _fit("none", 0.0, 0.09))

    def with_term(name, left, signature=None):
        from dataclasses import replace
        return replace(_fit(name, 0.0, 0.05), disc_rms_K=float(np.sqrt(np.mean(np.square(list(left.values()))))),
                       disc_rms_by=dict(left), signature_by=dict(signature or {}))

    none = with_term("none", {"air": 0.03, "grease": 0.2})
    lid = with_term("contact@bond", {"air": 0.03, "grease": 0.153}, {"grease": 0.41})
    assert not explains_term(lid, none, noise, (lid,))  # 0.153 > 2 x 0.052 and > 0.2 / 2
    bond = with_term("contact@bond", {"air": 0.03, "grease": 0.085}, {"grease": 1.1})
    assert explains_term(bond, none, noise, (bond,))  # within 2 sigmas where it acts
    halved = with_term("contact@bond", {"air": 0.5, "grease": 0.5}, {"grease": 1.1})
    assert explains_term(halved, with_term("none", {"air": 0.5, "grease": 1.2}), noise, (halved,))
    # the air scheme's term is not the bond line's to explain; an effect acting in both must explain both
    both = with_term("power@reg_5v", {"air": 0.5, "grease": 0.05}, {"air": 1.0, "grease": 1.0})
    assert explains_term(with_term("contact@bond", {"air": 0.5, "grease": 0.05}, {"grease": 1.1}),
                         with_term("none", {"air": 0.6, "grease": 0.3}), noise)
    assert not explains_term(both, with_term("none", {"air": 0.6, "grease": 0.3}), noise, (both,))
    # far beyond the term it leaves where it does not explain it, anchored where it does (issue 58): the toy's
    # 0.15 W regulator under a 12 % form error (noise 0.055 K, plain re-tune 0.218 K held out) is named; the slow
    # null case's -0.28 W regulator (noise 0.041 K, plain 0.227 K), explaining the term in neither scheme, is not
    n = 0.0553
    toy = with_term("power@reg_5v", {"air": 0.251, "grease": 0.064}, {"air": 0.862, "grease": 0.491})
    toy_none = with_term("none", {"air": 0.342, "grease": 0.129})
    assert not explains_term(toy, toy_none, n, (toy,))  # the standard alone: air neither halved nor within 2 sigmas
    assert explains_term(toy, toy_none, n, (toy,), plain_gap_K=0.218)
    assert not explains_term(toy, toy_none, n, (toy,), plain_gap_K=0.10)  # the plain re-tune within 2 sigmas
    null = with_term("power@reg_3v3", {"air": 0.241, "grease": 0.105}, {"air": 2.43, "grease": 1.46})
    assert not explains_term(null, with_term("none", {"air": 0.280, "grease": 0.143}), 0.0407, (null,),
                             plain_gap_K=0.227)


def test_the_discrepancy_term_is_not_fitted_on_sparse_files():
    """Files of a few readings (the paper's kind): the term's two coefficients per site would fit them exactly,
    so it is not fitted, and the result says why."""
    from dataclasses import replace

    from _toy_reduced import toy_models, toy_runs
    runs = toy_runs({**_TOY_NUISANCE, "power@reg_5v": 0.3}, np.random.default_rng(1))
    idx = np.array([5, 15, len(runs[0].times_s) - 1])
    sparse = [replace(r, times_s=r.times_s[idx], values_C=r.values_C[idx], lines=tuple(np.array(r.lines)[idx]))
              for r in runs]
    res = correlate(sparse, models=toy_models(), candidates=_TOY_CANDIDATES, rerun=False, discrepancy=True)
    assert res.discrepancy is None and "discrepancy term not fitted" in res.timings["reason"]


def test_a_smooth_residual_under_the_none_standard_is_still_asked_of_the_term():
    """Toy null cases (the default, discrepancy 'auto'): where nothing is named and the re-tuned model predicts
    held-out data within 2 noise sigmas, the term is still fitted. On data of the model's own form it is not
    supported (evidence gain ~0-2) and the verdict stays 'none', with the re-tune as the corrected model; with a
    transient bump the re-tune cannot follow (0.16 K at its peak, ~3 noise sigmas, held-out still within 2)
    it is supported and predicts better: 'discrepancy', not 'none' (the mild campaign's lid heat load)."""
    from _toy_reduced import toy_models, toy_runs
    models = toy_models()

    def bump(s, t):
        return 0.3 * np.linspace(1.0, 0.4, 6) * (np.exp(-t / 300.0) - np.exp(-t / 60.0))[:, None] * (1 if s == "air" else 0.5)

    for seed in (1, 2):
        clean = correlate(toy_runs(dict(_TOY_NUISANCE), np.random.default_rng(seed)), models=models,
                          candidates=_TOY_CANDIDATES, rerun=False)
        assert clean.verdict == "none" and clean.named_effects == (), clean.timings["reason"]
        assert clean.discrepancy is not None and not clean.discrepancy["supported"]
        assert clean.after is clean.retune_plain and not clean.after.disc  # the re-tune stands, without the term
        bumped = correlate(toy_runs(dict(_TOY_NUISANCE), np.random.default_rng(seed), bump), models=models,
                           candidates=_TOY_CANDIDATES, rerun=False)
        assert bumped.retune_plain.heldout_rms_K <= 2 * bumped.noise_K  # 'none' by the held-out standard alone
        assert bumped.verdict == "discrepancy" and bumped.named_effects == (), bumped.timings["reason"]
        assert "but the data support a smooth discrepancy" in bumped.timings["reason"]
        assert bumped.retune.heldout_rms_K < bumped.retune_plain.heldout_rms_K


def test_sparse_files_get_the_cavity_laws_form_as_a_prior_band():
    """Sparse files (three readings per site): the term is not fitted, but the result states the model's form
    uncertainty at each reading, the change the cavity law's blend (s2s -> effective) makes at the fitted
    values, beside what the fit leaves. Toy whose reduced models carry the blend (a gain change, 2 K per unit in
    air, 0.4 K in grease, at tp1): data with the blend at 0.6 leave a residual within the band; data 2.5 K off in
    alternate directions at neighbouring sites (no knob's pattern) leave one beyond it; a 0.8 W regulator error,
    named, changes the readings by more than the band (an effect within it could be the model's form). Toy models without the blend (the effective law): no band."""
    from dataclasses import replace

    import _toy_reduced as toy
    from imutherm.studies.correlation import Models
    from imutherm.unit import knobs

    blend_pattern = {"air": -2.0 * np.linspace(1.0, 0.5, 6), "grease": -0.4 * np.linspace(1.0, 0.5, 6)}

    class WithBlend(toy.ToyReduced):
        def __init__(self, scheme):
            super().__init__(scheme)
            self.knobs["cavity_law_blend"] = knobs.effect_knob("cavity_law_blend")

        def gain_tau(self, values):
            g, tau = super().gain_tau(values)
            return g + blend_pattern[self.scheme] * values.get("cavity_law_blend", 0.0), tau

    base = toy.toy_models()
    models = dataclasses.replace(base, roms={k: WithBlend(k[0]) for k in base.roms})

    def sparse_runs(values, extra=None):
        runs = toy.toy_runs(values, np.random.default_rng(1), extra)
        real = [WithBlend(r.scheme) for r in runs]
        idx = np.array([5, 15, len(runs[0].times_s) - 1])
        out = []
        for r, m in zip(runs, real):
            v = 70.0 + m.rise(values, r.times_s[idx]) + (extra(r.scheme, r.times_s[idx]) if extra else 0.0)
            out.append(replace(r, times_s=r.times_s[idx], values_C=v, lines=tuple(np.array(r.lines)[idx])))
        return out

    inside = correlate(sparse_runs({**_TOY_NUISANCE, "cavity_law_blend": 0.6}), models=models,
                       candidates=_TOY_CANDIDATES, rerun=False)
    band = inside.form_band
    assert band is not None and "discrepancy term not fitted" in inside.timings["reason"]
    assert len(band["readings"]) == 2 * 3 * 6 and band["within"], band["words"]
    air = [r for r in band["readings"] if r["scheme"] == "air" and r["site"] == "tp1" and r["steady"] is False]
    assert air and all(r["form_span_K"] == pytest.approx(-2.0 * (1 - math.exp(-r["time_s"] / 90.0)), rel=0.3)
                       for r in air[-1:])
    assert "too few readings to fit the model's own error" in inside.words
    assert result_json(inside)["form_band"]["within"] is True
    assert inside.named_effects == () and inside.form_band["effect_change_rms_K"] is None
    zigzag = np.array([2.5, -2.5, 2.5, -2.5, 2.5, -2.5])  # no knob or effect makes neighbours differ so
    far = correlate(sparse_runs(dict(_TOY_NUISANCE), lambda sch, t: np.tile(zigzag, (len(t), 1))), models=models,
                    candidates=_TOY_CANDIDATES, rerun=False)
    assert far.form_band is not None and not far.form_band["within"], far.form_band["words"]
    assert "beyond that band" in far.words
    named = correlate(sparse_runs({**_TOY_NUISANCE, "power@reg_5v": 0.8}), models=models, candidates=_TOY_CANDIDATES,
                      rerun=False)
    assert named.named_effects == ("power@reg_5v",), named.timings["reason"]   # 0.8 W: ~11 K at tp1 in air
    assert named.form_band["effect_change_rms_K"] > 3 * named.form_band["form_span_rms_K"]
    assert "the named effect changes them by" in named.words and "more than the law's form does" in named.words
    plain = correlate(sparse_runs(dict(_TOY_NUISANCE)), models=base, candidates=_TOY_CANDIDATES, rerun=False)
    assert plain.form_band is None


@pytest.mark.slow
def test_forward_selection_names_two_hidden_effects_and_stops_at_two(tmp_path, models_effective):
    """0.35 W more at the 5 V regulator and a poor bond line (h = 120 W/m^2 K: grease scheme only) hidden
    together, generated on a finer mesh with ±10 % nuisance and noise: the bond line named first, the regulator
    second or, where the data cannot tell it from a neighbour, ranked first of a tie the words name; nothing
    wrong named.

    Why a tie is allowed: with the fill's gaps resolved (the mesh of 2026-12-05) the second step ranks
    power@reg_5v (0.29 W fitted, the re-tune's power scale at 1.01) 4.0 in AICc ahead of power@reg_1v8 (-0.10 W,
    the power scale at its 1.15 bound), both predicting the held-out readings to 0.067 / 0.066 K: under the
    ΔAICc 6 runner-up margin, which the selection does not lower for one case (before that mesh: named)."""
    case = make_case(tmp_path / "case", "power@reg_5v", np.random.default_rng(5), mesh_size_mm=GEN_MM, min_cells=1,
                     value=0.35, samples=30, also={"contact@bond": 120.0}, options=models_effective.options)
    res = correlate([read_measured(f) for f in case.files], models=models_effective, rerun=False)
    assert res.verdict == "effect", (res.verdict, res.timings["reason"])
    assert res.named_effects[0] == "contact@bond", res.timings["reason"]
    assert set(res.named_effects) <= {"power@reg_5v", "contact@bond"}, res.timings["reason"]  # nothing not hidden
    j = json.loads(json.dumps(result_json(res)))
    assert [e["name"] for e in j["named_effects"]] == list(res.named_effects)
    assert j["named_effect"] == res.named_effects[0]
    assert all(e["heldout_gain_K"] > 0 for e in j["named_effects"])
    assert j["heldout_rms_after_K"] <= 0.3 * j["heldout_rms_before_K"]
    if "power@reg_5v" in res.named_effects:
        assert len(res.steps) == 3 and res.steps[2]["verdict"] != "effect"  # a third step was tried, named nothing
        lo, hi = j["named_effects"][[e["name"] for e in j["named_effects"]].index("power@reg_5v")]["parameters"][
            "power@reg_5v"]["ci95"]
        assert lo <= 0.35 * 1.3 and hi >= 0.35 * 0.7
    else:   # the second step's tie: the hidden regulator first, its fitted power within 30 %, named in the words
        second = res.steps[1]
        assert second["verdict"] == "ambiguous", second["reason"]
        best = second["ranking"][0]
        assert best.name == "contact@bond+power@reg_5v", [f.name for f in second["ranking"][:3]]
        assert 0.35 * 0.7 <= best.values["power@reg_5v"] <= 0.35 * 1.3
        assert "contact@bond+power@reg_5v" in res.timings["reason"]


@pytest.mark.slow
def test_a_model_form_null_case_names_no_library_effect(tmp_path, models_effective):
    """Null case generated with the other cavity law (s2s view factors and radiosity; the inversion has the
    effective conductivity) on a finer mesh: the model's form is off by kelvins (the nominal model misses the
    held-out data by > 10 noise sigmas). The cavity's emissivity is a form knob (re-tuned, not named): the
    re-tune takes it down (s2s couples the boards to the housing more weakly than the effective law at one
    emissivity), the discrepancy term what is left, and no library effect is named (before the model-form term
    and the re-tuned cavity emissivity, this case was named cavity_emissivity)."""
    from imutherm.studies.correlation.hidden_effect import model_form_options
    case = make_case(tmp_path / "case", "none", np.random.default_rng(11), mesh_size_mm=MF_GEN_MM, min_cells=1,
                     samples=30, options=model_form_options(models_effective.options))
    runs = [read_measured(f) for f in case.files]
    res = correlate(runs, models=models_effective, rerun=False, discrepancy=True)
    assert res.verdict != "effect" and res.named_effects == (), (res.named_effects, res.timings["reason"])
    assert res.before["heldout_rms_K"] > 10 * res.noise_K  # a real form mismatch
    assert res.retune.values["cavity_emissivity"] < 0.5  # re-tuned from 0.77 towards the s2s coupling
    assert res.retune.heldout_rms_K < 3 * res.noise_K  # and with it the gap closes to the noise
    assert result_json(res)["retuned_parameters"]["cavity_emissivity"]["kind"] == "retune"


@pytest.mark.slow
def test_an_effect_hidden_under_the_other_cavity_law_is_named_once_the_law_is_in_doubt(tmp_path, models):
    """The gross model-form case: data made with the effective cavity law on a finer mesh (~40 % of the air
    rise below the s2s model's), a poor bond line (h 250 W/m^2 K) hidden; inverted with s2s. The library does
    not explain the data, so the term path opens the cavity law's blend (knobs.FORM_IN_DOUBT) beside the
    discrepancy: the blend goes towards the effective law, the bond line is named first within 1.5x of the
    hidden value and the term it leaves is within 3 noise sigmas. Before the blend the shared re-tune knobs sat
    at their bounds under the air scheme's law error and this case was `discrepancy` (the bench's gross path:
    2/6 strong effects named). The null case of the same generator names no library effect."""
    from imutherm.studies.correlation.hidden_effect import model_form_options
    gen = model_form_options(models.options)
    assert gen.cavity_law == "effective"
    case = make_case(tmp_path / "bond", "contact@bond", np.random.default_rng(7), mesh_size_mm=MF_GEN_MM,
                     min_cells=1, samples=30, value=250.0, options=gen)
    res = correlate([read_measured(f) for f in case.files], models=models, rerun=False)
    assert res.named_effects[:1] == ("contact@bond",), (res.named_effects, res.timings["reason"])
    assert 250.0 / 1.5 <= res.after.values["contact@bond"] <= 250.0 * 1.5
    assert res.after.values["cavity_law_blend"] > 0.5  # towards the law that made the data
    assert res.after.disc_rms_K < 3 * res.noise_K
    p = result_json(res)["retuned_parameters"]["cavity_law_blend"]
    assert p["kind"] == "retune" and "blend" in p["source"]
    assert "cavity_law_blend" in updated_model_toml(res).split("[retune]")[1].split("[effects]")[0]
    null = make_case(tmp_path / "none", "none", np.random.default_rng(8), mesh_size_mm=MF_GEN_MM, min_cells=1,
                     samples=30, options=gen)
    res0 = correlate([read_measured(f) for f in null.files], models=models, rerun=False)
    assert res0.named_effects == (), (res0.named_effects, res0.timings["reason"])


# --------------------------------------------------------------------------- the selection logic on a toy model

#: the toy's candidates as ``correlate`` offers them by default: the cavity's emissivity is re-tuned, not a
#: candidate (correlation.FORM_RETUNE)
_TOY_CANDIDATES = ("power@reg_5v", "power@processor", "contact@bond")
_TOY_NUISANCE = {"k_board_W_mK": 18.5, "mount_h_W_m2K": 470.0, "convection_scale": 1.05}


def _toy_form(amp):
    """A smooth model-form error: the measured gain amp (air) or amp / 2.4 (grease) above the model, at
    every site in proportion to its rise, with a 150 s response (not a library effect's pattern)."""
    return lambda s, t: (amp if s == "air" else amp / 2.4) * np.linspace(17, 8, 6) * (1 - np.exp(-t / 150))[:, None]


def test_forward_selection_on_a_toy_model_names_two_effects_and_stops():
    """Toy reduced models (tests/_toy_reduced.py: closed-form rises, each effect a fixed site pattern): 0.3 W
    at the 5 V regulator and a poor bond line (h 150 W/m^2 K) hidden together; both named, in order of
    evidence, the third step names nothing."""
    from _toy_reduced import toy_models, toy_runs
    runs = toy_runs({**_TOY_NUISANCE, "power@reg_5v": 0.3, "contact@bond": 150.0}, np.random.default_rng(1))
    res = correlate(runs, models=toy_models(), candidates=_TOY_CANDIDATES, rerun=False)
    assert res.verdict == "effect" and set(res.named_effects) == {"power@reg_5v", "contact@bond"}, res.timings
    assert len(res.steps) == 3 and res.steps[-1]["verdict"] != "effect"
    assert res.after.values["power@reg_5v"] == pytest.approx(0.3, abs=0.1)
    j = result_json(res)
    assert [e["name"] for e in j["named_effects"]] == list(res.named_effects) and j["named_effect"] == res.named_effects[0]
    toml = updated_model_toml(res)
    assert "[effects]" in toml and all(f'"{n}"' in toml for n in res.named_effects)


def test_the_discrepancy_term_takes_a_smooth_form_error_that_an_effect_would_otherwise_absorb():
    """Toy null case with a 12 % smooth model-form error in air (5 % in grease): without the discrepancy term
    the workflow cannot say what is wrong (``not_in_library``; with the cavity's emissivity offered as a
    candidate it named that: the old workflow's failure); with it, no library effect is named, the verdict is
    'discrepancy' and it says where the model's form is off."""
    from _toy_reduced import toy_models, toy_runs
    runs = toy_runs(dict(_TOY_NUISANCE), np.random.default_rng(2), _toy_form(0.12))
    models = toy_models()
    res = correlate(runs, models=models, candidates=_TOY_CANDIDATES, rerun=False, discrepancy=True)
    assert res.named_effects == () and res.verdict == "discrepancy", res.timings["reason"]
    assert res.discrepancy["supported"] and "not explained by any library effect" in res.words
    assert "too cool" in res.discrepancy["words"] and "air" in res.discrepancy["words"]
    assert res.retune.heldout_rms_K < 0.5 * res.retune_plain.heldout_rms_K
    plain = correlate(runs, models=models, candidates=_TOY_CANDIDATES, rerun=False, discrepancy=False)
    assert plain.verdict == "not_in_library" and plain.named_effects == ()
    # the default ('auto'): the library's choice leaves held-out data above 2 noise sigmas, so the term decides
    assert plain.after.heldout_rms_K > 2 * plain.noise_K
    auto = correlate(runs, models=models, candidates=_TOY_CANDIDATES, rerun=False)
    assert auto.verdict == "discrepancy" and auto.named_effects == (), auto.timings["reason"]
    assert "judged with the discrepancy term" in auto.timings["reason"]


def test_the_cavity_emissivity_is_re_tuned_not_named(tmp_path):
    """The cavity's emissivity is a form knob (correlation.FORM_RETUNE): a weaker cavity radiation hidden in toy
    data is re-tuned to its value (its interval covering it) and reported among the re-tuned parameters, no
    library effect is named, and a power error hidden on top is still named alone; offered as a candidate
    (``form_retune=False``, the CLI's ``--cavity-emissivity-as-effect``) it is named, as before the emissivity
    became a form knob."""
    from _toy_reduced import toy_models, toy_runs
    from imutherm.studies.correlation import FORM_RETUNE
    models = toy_models()
    cands = ("power@reg_5v", "power@processor", "contact@bond")
    runs = toy_runs({**_TOY_NUISANCE, "cavity_emissivity": 0.3}, np.random.default_rng(4))
    res = correlate(runs, models=models, candidates=cands, rerun=False)
    # 0.3 lies far outside the finish's source range (0.63-0.86): since the blind campaign the move is named as the
    # finding (tests/test_correlation_form.py), still no library effect
    assert res.named_effects == () and res.verdict == "finding", res.timings["reason"]
    assert [f.parameter for f in res.findings] == ["cavity_emissivity"]
    assert res.retune.values["cavity_emissivity"] == pytest.approx(0.3, abs=0.05)
    j = result_json(res)
    p = j["retuned_parameters"]["cavity_emissivity"]
    assert p["kind"] == "retune" and p["source"] == FORM_RETUNE["cavity_emissivity"]
    assert p["ci95"][0] <= 0.3 <= p["ci95"][1]
    from imutherm.studies.thermal.fitted_model import fitted_options, load_fitted_model
    path = Path(tmp_path) / "updated_model.toml"
    path.write_text(updated_model_toml(res))
    m = load_fitted_model(path)  # read back into the re-tune, and applied by --model
    assert m.retune["cavity_emissivity"] == pytest.approx(res.retune.values["cavity_emissivity"], rel=1e-5)
    assert m.effects == ()
    from imutherm.geometry.layout import load_layout
    assert fitted_options(m, layout=load_layout(None)).cavity_emissivity == m.retune["cavity_emissivity"]
    both = correlate(toy_runs({**_TOY_NUISANCE, "cavity_emissivity": 0.3, "power@reg_5v": 0.3},
                              np.random.default_rng(5)), models=models, candidates=cands, rerun=False)
    assert both.named_effects == ("power@reg_5v",), both.timings["reason"]
    assert both.after.values["power@reg_5v"] == pytest.approx(0.3, abs=0.1)
    old = correlate(runs, models=models, candidates=cands + ("cavity_emissivity",), rerun=False)
    assert old.named_effects[:1] == ("cavity_emissivity",), old.timings["reason"]
    off = correlate(runs, models=models, candidates=cands, rerun=False, form_retune=False)
    assert "cavity_emissivity" not in off.retune.values and off.verdict != "none"
