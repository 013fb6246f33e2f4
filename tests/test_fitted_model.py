"""``--model DIR/updated_model.toml``: solve, compare and sweep run on the model correlate fitted.

The fitted model acts through the layout (powers) and the model options; the correlation defines its corrected
model through :func:`imutherm.unit.knobs.variant`. The two must be the same model: same mesh, same problem,
the same site rises to round-off. The round trip from hidden-effect data through ``correlate`` is slow."""

import json
from pathlib import Path

import numpy as np
import pytest

from imutherm.cli import main
from imutherm.geometry.build import build_geometry
from imutherm.geometry.layout import load_layout
from imutherm.geometry.mesh import build_mesh
from imutherm.studies.thermal.fitted_model import apply_fitted, fitted_options, load_fitted_model
from imutherm.studies.thermal.thermal_study import run_scheme
from imutherm.unit import knobs
from imutherm.unit.effects import effect_problem
from imutherm.unit.model import ModelOptions
from imutherm.thermal.solve import solve_steady

MESH = ["--mesh-size", "8", "--min-cells", "1"]

#: every re-tune knob off its nominal value, and one effect of each kind the layout/options carry
VALUES = {"power_scale": 0.9, "mount_h_W_m2K": 1500.0, "convection_scale": 1.2, "emissivity_ext": 0.8,
          "k_board_W_mK": 20.0, "power@reg_5v": -0.4, "contact@bond": 2000.0}
MODEL_TOML = """# written by hand in the form imutherm correlate writes
[model]
cavity_law = "effective"
[correlation]
verdict = "effect"
rms_before_K = 2.5
rms_after_K = 0.4
[retune]
power_scale = 0.9
mount_h_W_m2K = 1500.0
convection_scale = 1.2
emissivity_ext = 0.8
k_board_W_mK = 20.0
[effects]
"power@reg_5v" = { extra_W = -0.4 }
"contact@bond" = { h_W_m2K = 2000.0 }
"probe_lag" = { tau_s = 30.0 }
"""


def _variant_rises(scheme, values, options, mesh_mm=8.0):
    """Steady site rises [K] of the correlation's corrected model (knobs.variant), the reference unit."""
    geo = build_geometry(None, scheme)
    grid = build_mesh(geo, mesh_mm, 1)
    v = knobs.variant(geo, options, values)
    st = solve_steady(effect_problem(v, grid), probes=dict(v.geometry.sites))
    return dict(zip(st.probe_names, np.asarray(st.probe_C) - geo.layout.ambient_C))


@pytest.fixture
def model_file(tmp_path):
    path = tmp_path / "updated_model.toml"
    path.write_text(MODEL_TOML)
    return path


def test_fitted_model_is_the_correlations_corrected_model(model_file):
    fitted = load_fitted_model(model_file)
    assert fitted.options == {"cavity_law": "effective"} and fitted.skipped == ("probe_lag:tau_s=30",)
    lay, opts, effects = apply_fitted(fitted, load_layout(None), ModelOptions(**fitted.options))
    assert effects == ()
    reg = next(c for c in lay.components if c.name == "reg_5v")
    assert reg.power_W == pytest.approx(0.8974 * 0.9 - 0.4, abs=1e-4) and "fitted" in reg.power_source
    res = run_scheme(lay, "grease", options=opts, mesh_size_mm=8.0, min_cells=1)
    ours = dict(zip(res.steady.probe_names, np.asarray(res.steady.probe_C) - 70.0))
    want = _variant_rises("grease", VALUES, ModelOptions(cavity_law="effective"))
    for site, rise in want.items():
        assert ours[site] == pytest.approx(rise, rel=1e-9, abs=1e-9), site
    # and the fitted values moved it: the nominal model differs by far more than round-off
    nominal = _variant_rises("grease", {}, ModelOptions(cavity_law="effective"))
    assert abs(nominal["tp1"] - ours["tp1"]) > 0.3


def test_solve_and_compare_name_the_model(model_file, tmp_path, capsys):
    out = tmp_path / "s"
    assert main(["solve", "--scheme", "grease", "--model", str(model_file), "--out", str(out)] + MESH) == 0
    r = json.loads((out / "result.json").read_text())
    assert r["model"]["file"] == str(model_file) and r["model"]["rms_after_K"] == 0.4
    assert r["model"]["not_applied"] == ["probe_lag:tau_s=30"] and r["model_options"]["cavity_law"] == "effective"
    want = _variant_rises("grease", VALUES, ModelOptions(cavity_law="effective"))
    assert r["sites"]["tp1"]["rise_K"] == pytest.approx(want["tp1"], rel=1e-9)
    assert "correlation RMS 2.50 -> 0.40 K" in capsys.readouterr().out
    out = tmp_path / "c"
    assert main(["compare", "--schemes", "grease", "--steady-only", "--model", str(model_file),
                 "--no-mesh-error", "--out", str(out)] + MESH) == 0   # the model's own mesh's rises
    c = json.loads((out / "compare.json").read_text())
    assert c["model"]["file"] == str(model_file)
    assert c["schemes"]["grease"]["sites"]["tp1"]["rise_K"] == pytest.approx(want["tp1"], rel=1e-9)


def test_bad_model_files_are_refused(model_file, tmp_path, capsys):
    # the file fixes the laws it was fitted with: a different one on the command line is refused
    assert main(["solve", "--model", str(model_file), "--cavity-law", "none", "--out", str(tmp_path / "a")]
                + MESH) == 2
    assert "fitted with the model switches cavity_law=effective" in capsys.readouterr().err
    bad = tmp_path / "bad.toml"
    bad.write_text(MODEL_TOML.replace("power_scale = 0.9", "power_scale = 3.0"))
    assert main(["solve", "--model", str(bad), "--out", str(tmp_path / "b")] + MESH) == 2
    err = capsys.readouterr().err
    assert "power_scale = 3.0 is outside its source's range 0.85..1.15" in err and str(bad) in err
    assert main(["solve", "--model", str(tmp_path / "missing.toml"), "--out", str(tmp_path / "c")] + MESH) == 2
    assert "no such file" in capsys.readouterr().err


@pytest.mark.slow
def test_round_trip_correlate_then_solve_and_compare_on_the_fitted_model(tmp_path):
    """0.35 W hidden at the 5 V regulator (full-model data, ±10 % nuisance, noise) on a coarse mesh ->
    ``correlate`` -> ``solve --model`` and ``compare --model`` give the corrected model's rises and name it."""
    from imutherm.studies.correlation.hidden_effect import make_case

    case = make_case(tmp_path / "case", "power@reg_5v", np.random.default_rng(3), mesh_size_mm=6.0, min_cells=1,
                     value=0.35, samples=30)
    out = tmp_path / "corr"
    mesh = ["--mesh-size", "6", "--min-cells", "1"]
    assert main(["correlate", "--measured", *map(str, case.files), "--no-report", "--jobs", "1",
                 "--out", str(out)] + mesh) == 0
    data = json.loads((out / "correlation.json").read_text())
    model_path = out / "updated_model.toml"
    fitted = load_fitted_model(model_path)
    assert fitted.options["cavity_law"] == "s2s" and Path(fitted.layout) == Path(load_layout(None).path).resolve()
    assert fitted.correlation["rms_after_K"] == pytest.approx(data["rms_after_K"], rel=1e-5)
    if data["verdict"] == "effect":
        assert [e.name for e in fitted.effects] == [data["named_effect"]]
    for name, p in data["parameters"].items():  # the file holds the fit's values (6 significant digits)
        v = fitted.retune.get(name) if p["kind"] == "retune" else fitted.effects[0].values[0][1]
        assert v == pytest.approx(p["value"], rel=1e-5), name
    values = dict(fitted.retune, **{e.name: e.values[0][1] for e in fitted.effects})
    want = {s: _variant_rises(s, values, ModelOptions(), 6.0) for s in ("air", "grease")}
    assert main(["solve", "--scheme", "air", "--model", str(model_path), "--out", str(tmp_path / "s")] + mesh) == 0
    r = json.loads((tmp_path / "s" / "result.json").read_text())
    assert r["model"]["file"] == str(model_path)
    for site, rise in want["air"].items():
        assert r["sites"][site]["rise_K"] == pytest.approx(rise, rel=1e-7), site
    assert main(["compare", "--steady-only", "--schemes", "air,grease", "--model", str(model_path),
                 "--no-mesh-error", "--out", str(tmp_path / "c")] + mesh) == 0   # the model's own mesh's rises
    c = json.loads((tmp_path / "c" / "compare.json").read_text())
    for s in ("air", "grease"):
        assert c["schemes"][s]["sites"]["tp1"]["rise_K"] == pytest.approx(want[s]["tp1"], rel=1e-7)
    assert c["model"]["rms_before_K"] == pytest.approx(data["rms_before_K"], rel=1e-5)
    # the nominal model is off by the hidden 0.35 W: the fitted one is a different model
    assert abs(_variant_rises("air", {}, ModelOptions(), 6.0)["tp1"] - want["air"]["tp1"]) > 0.5


def test_updated_model_toml_reads_back(tmp_path):
    """What correlate writes (updated_model_toml) is what --model reads: layout, switches, RMS, values."""
    from imutherm.studies.correlation import CorrelationResult, Fit, updated_model_toml

    vals = {"power_scale": 0.9, "mount_h_W_m2K": 1234.5, "power@reg_5v": -0.3, "cavity_law_blend": 0.8}
    after = Fit("power@reg_5v", vals, 0.2, 0.3, 4, 4.0, 3, float("nan"), 0.25, 0.3, effects=("power@reg_5v",))
    retune = Fit("none", {"power_scale": 0.95}, 1.1, 1.5, 4, 4.0, 2, float("nan"), 1.3, 1.6)
    res = CorrelationResult(verdict="effect", named_effect="power@reg_5v", ambiguous_set=(),
                            before={"rms_K": 2.0, "max_K": 3.0, "heldout_rms_K": 2.1}, after=after, retune=retune,
                            ranking=(after,), localise={}, fingerprints={}, noise_K=0.5, curves={}, runs=(),
                            reduced={}, timings={"reason": "test", "total_s": 1.0}, words="a test",
                            full={"rms_K": 0.22, "max_K": 0.31}, named_effects=("power@reg_5v",),
                            steps=({"verdict": "effect", "named": "power@reg_5v", "base": retune, "ranking": (after,),
                                    "ambiguous_set": (), "reason": "test"},))
    opts = ModelOptions(cavity_law="s2s", mounting_conductance_W_m2K=800.0)
    path = tmp_path / "updated_model.toml"
    path.write_text(updated_model_toml(res, load_layout(None).path, opts))
    m = load_fitted_model(path)
    assert Path(m.layout) == Path(load_layout(None).path).resolve()
    assert m.options["cavity_law"] == "s2s" and m.options["mounting_conductance_W_m2K"] == 800.0
    # the cavity law's blend (a form knob opened where the model's form was in doubt) is re-tuned, and applied
    assert m.retune == {"power_scale": 0.9, "mount_h_W_m2K": 1234.5, "cavity_law_blend": 0.8}
    assert fitted_options(m, layout=load_layout(None)).cavity_law_blend == 0.8
    assert [e.text() for e in m.effects] == ["power@reg_5v:extra_W=-0.3"]
    assert m.correlation["verdict"] == "effect" and m.correlation["rms_before_K"] == 2.0
    assert m.correlation["rms_after_K"] == 0.22 and m.correlation["after_from"] == "full model re-run"
    assert "correlation RMS 2.00 -> 0.22 K" in m.line()


def test_the_readings_go_side_by_side_into_the_model_file_the_csv_and_the_report(tmp_path):
    """correlate's readings (the paper's four, say) travel with the fitted model: ``[correlation] readings``
    of updated_model.toml (the steady reading's time inf kept), ``readings.csv``, and the page of the study
    report run on that model, beside this study's own rises; the corrected model is reported without the
    discrepancy term (a statistical term of the fit, not a model input)."""
    from matplotlib.backends.backend_pdf import PdfPages
    from pypdf import PdfReader

    from imutherm.cli.correlate import READING_COLUMNS, _write_readings
    from imutherm.measured import read_measured
    from imutherm.reports import study_report as sr
    from imutherm.studies.correlation import CorrelationResult, Fit, reading_rows, updated_model_toml

    run = read_measured(Path(__file__).parents[1] / "examples" / "measured" / "paper_000_air.csv")
    assert list(run.times_s) == [800.0, float("inf")] and run.sites == ("tp1",)
    col = np.array([[1.0], [2.0]])
    curves = {run.name: {"sites": run.sites, "times_s": run.times_s, "measured_K": run.rise_K,
                         "before_K": 20 + col, "after_K": 17 + col, "discrepancy_K": 0.5 * col,
                         "after_full_K": 17.25 + col}}
    after = Fit("power@reg_5v", {"power@reg_5v": -0.5}, 0.2, 0.3, 2, 2.0, 1, float("nan"), 0.25, 0.3,
                effects=("power@reg_5v",))
    res = CorrelationResult(verdict="effect", named_effect="power@reg_5v", ambiguous_set=(),
                            before={"rms_K": 2.0, "max_K": 3.0, "heldout_rms_K": 2.1}, after=after, retune=after,
                            ranking=(after,), localise={}, fingerprints={}, noise_K=0.5, curves=curves, runs=(run,),
                            reduced={}, timings={"reason": "t", "total_s": 1.0}, words="a test",
                            full={"rms_K": 0.22, "max_K": 0.31}, named_effects=("power@reg_5v",),
                            steps=({"verdict": "effect", "named": "power@reg_5v", "base": after, "ranking": (after,),
                                    "ambiguous_set": (), "reason": "t"},))
    rows = reading_rows(res)
    assert [(r["time_s"], r["measured_K"]) for r in rows] == [(800.0, 19.0), (float("inf"), 20.0)]
    assert [r["corrected_K"] for r in rows] == [17.5, 18.0]            # after minus the term
    assert [r["corrected_with_term_K"] for r in rows] == [18.0, 19.0]
    assert [r["corrected_full_K"] for r in rows] == [17.75, 18.25] and rows[0]["nominal_K"] == 21.0
    path = tmp_path / "updated_model.toml"
    path.write_text(updated_model_toml(res, load_layout(None).path, ModelOptions()))
    m = load_fitted_model(path)
    assert m.correlation["readings"] == rows
    _write_readings(tmp_path / "readings.csv", rows)
    lines = (tmp_path / "readings.csv").read_text().splitlines()
    assert lines[0] == ",".join(READING_COLUMNS)
    assert lines[2] == "paper_000_air,air,70,tp1,inf,20,22,18,19,18.25"
    # the study report's page: the readings beside this study's own tp1 (steady: its rise; 800 s: its curve)
    (tmp_path / "curves_air.csv").write_text("time_s,tp1\n0,70\n1000,90\n")
    data = {"model": m.summary(), "ambient_C": 70.0, "mesh": {"air": {"nodes": 1234}},
            "schemes": {"air": {"max_rise_K": 30.0, "sites": {"tp1": {"rise_K": 24.5}}}},
            "paper": {"figures": {"thermal": {"simulated": {"scheme1_air_max_rise_K": 16,
                                                            "scheme2_grease_max_rise_K": 8}}}}}
    with PdfPages(tmp_path / "r.pdf") as pdf:
        sr._readings_page(pdf, tmp_path, data)
    text = PdfReader(tmp_path / "r.pdf").pages[0].extract_text()
    for want in ("side by side", "steady", "800", "19.0", "21.0", "17.5", "17.8", "16.0", "24.5",
                 "paper's own FEM", "16 K air"):
        assert want in text, want
    # no readings (an older model file, a dense record): no page
    with PdfPages(tmp_path / "e.pdf") as pdf:
        sr._readings_page(pdf, tmp_path, dict(data, model={"file": "x"}))
        assert pdf.get_pagecount() == 0
