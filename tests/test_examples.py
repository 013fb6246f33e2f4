"""The copyable study scripts in examples/ run end to end on a coarse mesh, one per built-in layout."""

import contextlib
import importlib.util
import io
import json
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def load_script(name: str):
    spec = importlib.util.spec_from_file_location(name, EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Each script run steady-only on a coarse mesh (6 mm, 1 cell across): its output folder and stdout."""
    out = {}
    for name in ("study_reference", "study_cardguide"):
        folder = tmp_path_factory.mktemp(name) / "out"
        with contextlib.redirect_stdout(io.StringIO()) as text:
            assert load_script(name).main([str(folder), "--mesh-size", "6", "--min-cells", "1", "--steady-only",
                                           "--quiet"]) == 0
        out[name] = folder, text.getvalue()
    return out


@pytest.mark.slow
@pytest.mark.parametrize("name, layout", [("study_reference", "imu_reference"), ("study_cardguide", "imu_cardguide")])
def test_script_writes_its_outputs_and_the_schemes_order(runs, name, layout):
    folder, _ = runs[name]
    expected = {"compare.json", "layout.png", "report.pdf"} | {f"{k}_{s}.{e}" for s in ("air", "grease", "potted")
                                                               for k, e in (("probes", "csv"), ("map", "npz"))}
    assert expected == {p.name for p in folder.iterdir()}            # and no temporary folder left behind
    data = json.loads((folder / "compare.json").read_text())["schemes"]
    assert {r["layout"] for r in data.values()} == {layout}
    rise = {s: r["max_rise_K"] for s, r in data.items()}
    assert rise["air"] > rise["grease"] > rise["potted"] > 0
    for r in data.values():
        assert r["energy_balance_rel_error"] < 1e-8
        assert sum(r["heat_out_W"].values()) == pytest.approx(r["power_W"], rel=1e-8)
        assert r["hottest_part"] == "reg_5v_die"


@pytest.mark.slow
def test_metal_guides_couple_the_boards_better_than_nylon_standoffs(runs):
    """Same housing, chips and power (coarse mesh): the card-guide unit runs cooler in every scheme,
    its sensors at well under the reference unit's rises; nearly all heat leaves through the fixture."""
    ref, card = ({s: r for s, r in json.loads((runs[n][0] / "compare.json").read_text())["schemes"].items()}
                 for n in ("study_reference", "study_cardguide"))
    assert card["air"]["max_rise_K"] < 0.8 * ref["air"]["max_rise_K"]
    for scheme in ("air", "grease", "potted"):
        assert card[scheme]["max_rise_K"] < ref[scheme]["max_rise_K"], scheme
        assert card[scheme]["heat_out_W"]["zmin"] > 0.9 * card[scheme]["power_W"]
    for site in ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"):
        assert card["air"]["sites"][site]["rise_K"] < 0.6 * ref["air"]["sites"][site]["rise_K"], site


@pytest.mark.slow
def test_script_prints_the_answer_table(runs):
    for name, (folder, text) in runs.items():
        lines = text.splitlines()
        assert lines[0].startswith(name.replace("study_", "imu_") + ":")
        assert lines[1].split()[:3] == ["scheme", "max", "rise"]
        data = json.loads((folder / "compare.json").read_text())["schemes"]
        for line, scheme in zip(lines[2:5], ("air", "grease", "potted")):
            assert line.split()[0] == scheme
            assert float(line.split()[1]) == pytest.approx(data[scheme]["max_rise_K"], abs=0.006)
        assert "wrote" in lines[-1]


def test_script_layout_is_a_builtin_or_an_error(monkeypatch, tmp_path):
    from imutherm import InputError

    script = load_script("study_cardguide")
    monkeypatch.setattr(script, "LAYOUT", "my_unit")
    with pytest.raises(InputError, match="built-in layouts: .*imu_cardguide"):
        script.main([str(tmp_path / "o")])
    assert not (tmp_path / "o").exists()
