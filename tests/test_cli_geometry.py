"""``imutherm geometry`` in-process: files written, round-trips through meshio and trimesh, clean errors."""

import json

import meshio
import numpy as np
import pytest
import trimesh

from imutherm.cli import main


@pytest.fixture(scope="module")
def out(tmp_path_factory):
    d = tmp_path_factory.mktemp("geom") / "OUT"
    assert main(["geometry", "--scheme", "grease", "--out", str(d)]) == 0
    return d


def test_geometry_json(out):
    g = json.loads((out / "geometry.json").read_text())
    assert g["scheme"] == "grease"
    assert g["mass_g"] == pytest.approx(95.0, rel=0.05)
    assert g["total_power_W"] == pytest.approx(sum(p["power_W"] for p in g["parts"]))
    for key in ("cells", "nodes", "min_cell_mm", "max_cell_mm"):
        assert g["mesh"][key] > 0
    assert g["mesh"]["max_cell_mm"] <= 2.0 + 1e-9
    names = [p["name"] for p in g["parts"]]
    assert len(names) == len(set(names)) and "processor_bond" in names
    for p in g["parts"]:
        assert {"name", "material", "volume_mm3", "power_W"} <= set(p)


def test_vtu_round_trip(out):
    g = json.loads((out / "geometry.json").read_text())
    mesh = meshio.read(out / "mesh.vtu")
    assert len(mesh.points) == g["mesh"]["nodes"]
    assert mesh.cells[0].type == "hexahedron" and len(mesh.cells[0].data) == g["mesh"]["cells"]
    part = mesh.cell_data["part"][0]
    names = g["mesh"]["part_index"]
    assert set(np.unique(part)) == set(range(len(names)))
    # the VTU's cell volumes per part reproduce the geometry's volumes
    pts = mesh.points[mesh.cells[0].data]
    vol = np.prod(pts.max(axis=1) - pts.min(axis=1), axis=1)
    per_part = np.bincount(part, weights=vol)
    for p in g["parts"]:
        assert per_part[names.index(p["name"])] * 1e9 == pytest.approx(p["volume_mm3"], rel=1e-9)


def test_stl_and_glb_round_trip(out):
    stl = trimesh.load(out / "geometry.stl")
    assert np.allclose(stl.bounds, [[0, 0, 0], [70, 48, 25]])  # millimetres
    scene = trimesh.load(out / "geometry.glb")
    g = json.loads((out / "geometry.json").read_text())
    solid = {p["name"] for p in g["parts"] if p["kind"] != "fill"}
    assert set(scene.geometry) == solid
    # every box part's mesh encloses its volume
    for p in g["parts"]:
        if p["kind"] in ("board", "component", "bond", "lid"):
            assert scene.geometry[p["name"]].volume == pytest.approx(
                np.prod(np.subtract(p["max_mm"], p["min_mm"])), rel=1e-5)  # GLB stores float32 coordinates


def test_layout_png_written(out):
    png = (out / "layout.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 20_000


def test_bad_layout_gives_one_line_and_no_output(tmp_path, write_layout, capsys):
    path = write_layout(lambda d: d["components"][0].__setitem__("power_W", -1.0))
    target = tmp_path / "never"
    assert main(["geometry", str(path), "--out", str(target)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    assert "component 'processor'" in err and "'power_W'" in err
    assert not target.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".never")]


def test_unknown_scheme_and_command(tmp_path, capsys):
    assert main(["geometry", "--scheme", "foam", "--out", str(tmp_path / "x")]) == 2
    assert "unknown scheme 'foam'" in capsys.readouterr().err
    assert main(["nonsense"]) == 2
    assert main([]) == 0


@pytest.mark.parametrize("scheme", ["air", "grease"])
def test_layout_figure_names_every_board_component_and_site(scheme):
    import matplotlib.pyplot as plt

    from imutherm.geometry.build import build_geometry
    from imutherm.reports.layout_plot import ALPHA, layout_figure

    g = build_geometry(None, scheme)
    fig = layout_figure(g)
    try:
        texts = {t.get_text() for ax in fig.axes for t in ax.texts}
        lay = g.layout
        for name in [b.name for b in lay.boards] + [c.name for c in lay.components] + [s.name for s in lay.sites]:
            assert name in texts, (name, sorted(texts))
        # every board is named in each of the three views
        for ax in fig.axes:
            assert {b.name for b in lay.boards} <= {t.get_text() for t in ax.texts}, ax.get_title()
        # legend swatches are drawn with the patches' alpha
        legend = fig.legends[0]
        swatch = dict(zip([t.get_text() for t in legend.get_texts()], legend.legend_handles))
        assert swatch["board"].get_alpha() == pytest.approx(ALPHA["board"])
        drawn = {p.get_alpha() for ax in fig.axes for p in ax.patches
                 if p.get_facecolor()[:3] == swatch["board"].get_facecolor()[:3]}
        assert drawn == {swatch["board"].get_alpha()}
    finally:
        plt.close(fig)


def test_version_and_unknown_command(capsys):
    import imutherm
    from imutherm.cli import main

    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"imutherm {imutherm.__version__}"
    assert main(["nonsense"]) == 2
    assert "valid: compare" in capsys.readouterr().err
