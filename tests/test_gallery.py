"""The examples gallery (examples/plot_*.py) runs, each script in a fresh interpreter as a user runs it (as
scikit-fem's tests/test_examples.py does), on the coarse meshes the scripts set, and its files say what the
example shows. The documentation build runs the same scripts through sphinx-gallery.

(The copyable study scripts of studies/ are tested in tests/test_examples.py.)"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def run_example(name: str, tmp_path: Path) -> tuple[Path, str]:
    """Run examples/<name>.py in a subprocess writing under tmp_path; its output folder and stdout."""
    env = dict(os.environ, MPLBACKEND="Agg", IMUTHERM_EXAMPLES_OUT=str(tmp_path))
    proc = subprocess.run([sys.executable, str(EXAMPLES / f"{name}.py")], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return tmp_path / "imutherm-examples", proc.stdout


def test_every_example_is_in_the_gallery_format():
    """A title in the docstring header, ``# %%`` cells, a picture, and nothing written into the repository."""
    scripts = sorted(EXAMPLES.glob("plot_*.py"))
    assert len(scripts) >= 6
    for p in scripts:
        text = p.read_text(encoding="utf-8")
        assert text.startswith('"""\n') and "\n===" in text.split('"""')[1], p.name
        assert text.count("# %%") >= 2 and "plt.show()" in text, p.name
        assert "IMUTHERM_EXAMPLES_OUT" in text and "tempfile.gettempdir()" in text, p.name


def test_steady_field_writes_the_vtu(tmp_path):
    import meshio

    out, text = run_example("plot_steady_field", tmp_path)
    mesh = meshio.read(out / "steady_field" / "field.vtu")
    res = json.loads((out / "steady_field" / "result.json").read_text())
    t = mesh.point_data["temperature_C"]
    assert t.max() == pytest.approx(res["max_temperature_C"], abs=1e-6)
    assert t.min() >= res["ambient_C"] - 1e-9              # heat sources only: nothing below the ambient
    assert "part" in mesh.cell_data and "max rise" in text


def test_transient_settle_times(tmp_path):
    out, text = run_example("plot_transient_settle", tmp_path)
    res = json.loads((out / "transient" / "air" / "result.json").read_text())
    for site, r in res["sites"].items():
        assert 0 < r["t63_s"] < r["t95_s"] < 1500, site     # settled, and 63 % before 95 %
    assert "gyro_x" in text


def test_custom_layout_lower_regulator_loss_runs_cooler(tmp_path):
    out, _ = run_example("plot_custom_layout", tmp_path)
    ref = json.loads((out / "custom_layout" / "solve_imu_reference" / "result.json").read_text())
    mine = json.loads((out / "custom_layout" / "solve_imu_6v_supply" / "result.json").read_text())
    assert mine["layout"] == "imu_6v_supply"
    assert mine["power_W"] == pytest.approx(ref["power_W"] - (9.0 - 6.5) * (0.2131 + 0.005), abs=1e-9)  # reg_5v only
    for site in ref["sites"]:
        assert mine["sites"][site]["rise_K"] < ref["sites"][site]["rise_K"], site
    assert (out / "custom_layout" / "geometry" / "layout.png").stat().st_size > 10_000


def test_sweep_ranks_the_regulator_power_first(tmp_path):
    out, text = run_example("plot_sweep_sensitivity", tmp_path)
    sweep = json.loads((out / "sweep" / "sweep.json").read_text())
    hot = sweep["sensitivity"]["outputs"]["max_rise_K"]
    assert sweep["sensitivity"]["ranking"][0] == "components.reg_5v.power_W"
    assert hot["by_key"]["components.reg_5v.power_W"]["src"] > 0 > hot["by_key"]["materials.silicone_grease.k"]["src"]
    assert hot["r2"] > 0.9 and "influence on max_rise_K" in text


def test_attitude_on_the_shared_real_log(tmp_path):
    out, text = run_example("plot_attitude_real_log", tmp_path)
    if text.startswith("skipped:"):
        pytest.skip(text.strip())
    incl = json.loads((out / "attitude_log" / "inclination.json").read_text())
    assert {"gated", "kf", "vqf", "fusion"} <= set(incl)
    for name, e in incl.items():
        assert 0 < e["rms_deg"] < 5, (name, e)   # a working filter on a pendulum: degrees, not tens of degrees


@pytest.mark.slow
def test_correlation_names_the_hidden_effect(tmp_path):
    out, _ = run_example("plot_correlation_hidden_effect", tmp_path)
    res = json.loads((out / "correlation" / "corr" / "correlation.json").read_text())
    assert res["verdict"] == "effect" and res["named_effect"] == "power@reg_5v"
    lo, hi = res["parameters"]["power@reg_5v"]["ci95"]
    assert lo <= 0.35 * 1.3 and hi >= 0.35 * 0.7


def test_import_board_example(tmp_path):
    out, text = run_example("plot_import_board", tmp_path)
    assert "{'skipped': 4, 'merged': 59, 'modelled': 15}" in text
    rises = {line.split()[0]: float(line.split("IMU die +")[1].split()[0]) for line in text.splitlines()
             if "IMU die +" in line}
    assert rises["potted"] < rises["grease"] < rises["air"]   # the schemes rank as the paper's on this board too
    assert (out / "import_board" / "drone_fc_unit.toml").read_text().startswith("# Imported by `imutherm import`")
