"""The copyable study script in studies/ (the reference unit) and the study script with ``--layout`` (the card-guide
unit) run end to end on a coarse mesh."""

import contextlib
import importlib.util
import io
import json
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "studies"
SCHEMES = ("air", "grease", "potted")
SENSORS = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
#: coarse and short: 6 mm cells, one cell across thin parts, one seed, a 600 s power-on transient
COARSE = ["--mesh-size", "6", "--min-cells", "1", "--seeds", "1", "--t-end", "600", "--quiet"]


def load_script(name: str):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Each script run once on the coarse settings: its output folder, stdout and summary.json."""
    out = {}
    from imutherm.studies import study

    for name, main in (("study_reference", load_script("study_reference").main),
                       ("study_cardguide", lambda argv: study.main(argv + ["--layout", "imu_cardguide"]))):
        folder = tmp_path_factory.mktemp(name) / "out"
        with contextlib.redirect_stdout(io.StringIO()) as text:
            assert main([str(folder)] + COARSE) == 0
        out[name] = folder, text.getvalue(), json.loads((folder / "summary.json").read_text())
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name, layout", [("study_reference", "imu_reference"), ("study_cardguide", "imu_cardguide")])
def test_script_writes_its_outputs_and_the_schemes_order(runs, name, layout):
    folder, _, summary = runs[name]
    expected = {"summary.json", "report.pdf"} | {f"{k}_{s}.{e}" for s in SCHEMES for k, e in (
        ("curves", "csv"), ("residuals", "csv"), ("attitude", "csv"), ("steady", "vtu"), ("maps", "npz"),
        ("layout", "png"))}
    assert expected == {p.name for p in folder.iterdir()}            # and no temporary folder left behind
    assert summary["layout"] == layout and summary["seeds"] == [0]
    data = summary["schemes"]
    rise = {s: data[s]["max_rise_K"] for s in SCHEMES}
    assert rise["air"] > rise["grease"] > rise["potted"] > 0
    for s in SCHEMES:
        th = data[s]["thermal"]
        assert th["steady_energy_balance_rel_error"] < 1e-8
        assert sum(th["heat_out_W"].values()) == pytest.approx(th["power_W"], rel=1e-8)
        assert th["hottest_part"] == "reg_5v_die"
        assert data[s]["t95_s"] is None or 0 < data[s]["t95_s"] <= 600   # None: not settled by 600 s
        att = data[s]["attitude"]["warmup"]["improved"]["gated"]["flight"]["roll_rms_deg"]["mean"]
        assert 0 < att < 5


@pytest.mark.slow
def test_script_prints_the_answer_table(runs):
    for name, (_, text, summary) in runs.items():
        lines = text.splitlines()
        assert lines[0].startswith(summary["layout"] + ":")
        assert lines[1].split()[:3] == ["scheme", "max", "rise"]
        for line, scheme in zip(lines[2:5], SCHEMES):
            assert line.split()[0] == scheme
            assert float(line.split()[1]) == pytest.approx(summary["schemes"][scheme]["max_rise_K"], abs=0.006)
        assert [ln.split(":")[0] for ln in lines[5:8]] == list(SCHEMES)   # one answer sentence per scheme
        assert lines[-1].startswith("wrote")


@pytest.mark.slow
def test_metal_guides_couple_the_boards_better_than_nylon_standoffs(runs):
    """Same housing, chips and power (coarse mesh): the card-guide unit runs cooler in every scheme,
    its sensors at well under the reference unit's rises; nearly all heat leaves through the fixture."""
    ref, card = (runs[n][2]["schemes"] for n in ("study_reference", "study_cardguide"))
    assert card["air"]["max_rise_K"] < 0.8 * ref["air"]["max_rise_K"]
    for scheme in SCHEMES:
        assert card[scheme]["max_rise_K"] < ref[scheme]["max_rise_K"], scheme
        th = card[scheme]["thermal"]
        assert th["heat_out_W"]["zmin"] > 0.9 * th["power_W"]
    for site in SENSORS:
        assert card["air"]["sites"][site]["rise_K"] < 0.6 * ref["air"]["sites"][site]["rise_K"], site


def test_script_layout_is_a_builtin_or_an_error(monkeypatch, tmp_path):
    from imutherm import InputError

    script = load_script("study_reference")
    monkeypatch.setattr(script, "LAYOUT", "my_unit")
    with pytest.raises(InputError, match="built-in layouts: .*imu_cardguide"):
        script.main([str(tmp_path / "o")])
    assert not (tmp_path / "o").exists()


def test_one_study_script_serves_every_layout(monkeypatch, tmp_path):
    """studies/study_reference.py (and a copy of it with LAYOUT set) is imutherm.studies.study with the layout fixed;
    --layout picks it there."""
    from imutherm.studies import study

    seen = []

    class Stop(Exception):
        pass

    def fake_run_study(layout, schemes, **kw):
        seen.append((layout.name, schemes, kw["mesh_size_mm"]))
        raise Stop

    monkeypatch.setattr(study, "run_study", fake_run_study)
    copied = load_script("study_reference")              # the template copied, LAYOUT set to another layout
    monkeypatch.setattr(copied, "LAYOUT", "imu_cardguide")
    calls = [lambda: load_script("study_reference").main([str(tmp_path / "a"), "--mesh-size", "6"]),
             lambda: copied.main([str(tmp_path / "b"), "--mesh-size", "6"]),
             lambda: study.main([str(tmp_path / "c"), "--mesh-size", "6"]),
             lambda: study.main([str(tmp_path / "d"), "--layout", "imu_cardguide", "--mesh-size", "6"])]
    for call in calls:
        with pytest.raises(Stop):
            call()
    assert seen == [(n, ("air", "grease", "potted"), 6.0)
                    for n in ("imu_reference", "imu_cardguide", "imu_reference", "imu_cardguide")]
    with pytest.raises(SystemExit):      # the fixed-layout scripts take no --layout
        load_script("study_reference").main([str(tmp_path / "e"), "--layout", "imu_cardguide"])
