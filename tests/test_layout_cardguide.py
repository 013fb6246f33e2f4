"""The second built-in layout (imu_cardguide): name lookup, build, mesh, contacts."""

from pathlib import Path

import numpy as np
import pytest

from imutherm import InputError
from imutherm.cli import main
from imutherm.geometry.build import MM, build_geometry
from imutherm.geometry.layout import builtin_layouts, default_layout_path, load_layout, resolve_layout
from imutherm.geometry.materials import get_material
from imutherm.geometry.mesh import build_mesh, mesh_info
from imutherm.unit.model import AL_AL_AIR_JOINT_W_M2K, ModelOptions, build_problem, unit_interfaces

GUIDES = [f"guide_{s}_{p}" for s in "sn" for p in ("lower", "slot", "upper")]
STANDOFFS = ["xstandoff_1", "xstandoff_2", "ystandoff_1", "ystandoff_2"]
SCHEMES = ("air", "grease", "potted")


@pytest.fixture(scope="module")
def layout():
    return load_layout("imu_cardguide")


@pytest.fixture(scope="module")
def geometries(layout):
    return {s: build_geometry(layout, s) for s in SCHEMES}


# ------------------------------------------------------------------ names
def test_builtin_names_resolve_to_the_packaged_files():
    assert {"imu_reference", "imu_cardguide"} <= set(builtin_layouts())
    assert resolve_layout("imu_reference") == default_layout_path()
    assert resolve_layout(None) == default_layout_path()
    lay = load_layout("imu_cardguide")
    assert lay.name == "imu_cardguide" and lay.path.endswith("layouts/imu_cardguide.toml")
    assert Path(lay.path).parent == default_layout_path().parent  # beside the reference unit, installed or not
    assert load_layout(lay.path).name == "imu_cardguide"          # a path still works


def test_unknown_name_lists_the_builtin_layouts(tmp_path):
    with pytest.raises(InputError) as info:
        load_layout("imu_cardgiude")
    msg = str(info.value)
    assert "imu_cardgiude" in msg and "built-in layouts: " in msg and "imu_cardguide" in msg and "imu_reference" in msg
    with pytest.raises(InputError, match="layout file not found; built-in layouts: .*imu_cardguide"):
        load_layout(tmp_path / "nope.toml")                       # a path is never taken for a name


def test_a_local_file_wins_over_a_builtin_name(tmp_path, monkeypatch, reference_dict):
    from conftest import dump_toml

    monkeypatch.chdir(tmp_path)
    (tmp_path / "imu_cardguide").write_text(dump_toml(dict(reference_dict, name="mine")))
    assert load_layout("imu_cardguide").name == "mine"


def test_cli_takes_a_builtin_name(tmp_path, capsys):
    assert main(["geometry", "imu_cardguide", "--scheme", "air", "--mesh-size", "6", "--min-cells", "1",
                 "--no-png", "--out", str(tmp_path / "g")]) == 0
    assert "imu_cardguide / air" in capsys.readouterr().out
    assert main(["geometry", "no_such_unit", "--out", str(tmp_path / "h")]) == 2
    err = capsys.readouterr().err
    assert "no_such_unit" in err and "imu_cardguide" in err and err.count("\n") == 1
    assert not (tmp_path / "h").exists()


# ------------------------------------------------------------------ geometry
def test_builds_every_scheme_with_the_reference_power_and_sites(geometries):
    ref = build_geometry(None, "grease")
    for s, g in geometries.items():
        assert g.total_power_W == pytest.approx(ref.total_power_W, rel=1e-12)   # the reference power budget
        assert set(g.sites) == set(ref.sites)
    names = {p.name for p in geometries["grease"].parts}
    assert {"processor_bond", "reg_5v_bond", "reg_3v3_bond", "reg_1v8_bond"} <= names
    assert not any(n.endswith("_bond") for n in (p.name for p in geometries["air"].parts))
    assert geometries["potted"].part("fill").material == "potting_compound"


def test_part_volumes_and_mass(geometries):
    g = geometries["air"]
    for side in "sn":   # each rail: 60 mm long, lower jaw 4 x 2.7, slot bottom 1 x 1.6, upper jaw 4 x 1.6 mm
        for part, area in (("lower", 4 * 2.7), ("slot", 1.0 * 1.6), ("upper", 4 * 1.6)):
            assert g.volumes[f"guide_{side}_{part}"] == pytest.approx(60 * area * MM**3, rel=1e-12)
    assert g.volumes["xstandoff_1"] == pytest.approx(3.9 * 3.5 * 3.5 * MM**3, rel=1e-12)
    metal = sum(g.volumes[n] for n in GUIDES + STANDOFFS) * get_material("aluminium_6061").density
    assert metal * 1e3 == pytest.approx(6.61, abs=0.01)                        # 2448 mm^3 of aluminium
    # the same housing as the reference; mass near the paper's 95 g plus the metal mounting
    assert 0.095 < g.mass_kg < 0.110
    assert geometries["potted"].mass_kg > g.mass_kg + 0.06                     # ~43 cm^3 of potting


def test_meshes_every_scheme_conformingly(geometries):
    for s, g in geometries.items():
        grid = build_mesh(g, 6.0, 1)
        vol = grid.cell_volumes()
        for i, name in enumerate(grid.part_names):
            assert vol[grid.cell_part == i].sum() == pytest.approx(g.volumes[name], rel=1e-9), (s, name)
        info = mesh_info(grid)
        for p in g.parts:
            if p.kind in ("box", "board"):
                assert info.cells_across[p.name] >= 2   # BOARD_CELLS_FACTOR x min_cells


# ------------------------------------------------------------------ contacts
def test_guides_touch_board_and_walls_with_their_conductances(geometries):
    pairs = {(i.part_a, i.part_b): i.conductance_W_m2K for i in unit_interfaces(geometries["air"], ModelOptions())}
    for side in "sn":
        for part in ("lower", "slot", "upper"):
            assert pairs[("main", f"guide_{side}_{part}")] == 1000.0           # the layout's board_contact_W_m2K
            assert pairs[("housing", f"guide_{side}_{part}")] == AL_AL_AIR_JOINT_W_M2K
    for s in STANDOFFS:
        assert pairs[("housing", s)] == AL_AL_AIR_JOINT_W_M2K
        assert pairs[(("x" if s[0] == "x" else "y") + "board", s)] == AL_AL_AIR_JOINT_W_M2K
    assert len(pairs) == 1 + 2 * 6 + 2 * 4                                      # lid + guides + standoffs, nothing else
    # model default off: the walls lose their joints, the layout's own board contact stays
    off = {(i.part_a, i.part_b) for i in unit_interfaces(geometries["air"], ModelOptions(standoff_contact_W_m2K=None))}
    assert off == {("housing", "lid")} | {("main", n) for n in GUIDES}


def test_board_contact_is_applied_in_series_to_the_touching_layer(geometries):
    g = geometries["air"]
    grid = build_mesh(g, 6.0, 1)
    opts = ModelOptions(cavity_radiation=False)
    on = build_problem(g, grid, opts).k
    upper = grid.cell_part == grid.part_names.index("guide_s_upper")
    below = np.roll(grid.cell_part, 1, axis=2) == grid.part_names.index("main")
    layer = (upper & below).ravel()
    assert layer.sum() > 0
    w = np.broadcast_to(grid.cell_sizes()[2], grid.shape).ravel()[layer]
    k_al = get_material("aluminium_6061").k_in_plane
    assert np.allclose(on[layer, 2], w / (w / k_al + 1.0 / 1000.0), rtol=1e-12)
    inner = (upper & ~below & (np.roll(grid.cell_part, -1, axis=2) == grid.part_names.index("guide_s_upper"))).ravel()
    assert inner.any() and np.all(on[inner, 2] == k_al)                       # the rest of the jaw: plain aluminium


@pytest.mark.parametrize("value, fragment", [(0.0, "> 0"), (-5.0, "> 0"), ("high", "finite number"),
                                             (float("nan"), "finite number")])
def test_bad_board_contact_is_rejected(tmp_path, value, fragment):
    from conftest import dump_toml, tomllib

    with open(resolve_layout("imu_cardguide"), "rb") as fh:
        data = tomllib.load(fh)
    data["parts"][2]["board_contact_W_m2K"] = value
    path = tmp_path / "bad.toml"
    path.write_text(dump_toml(data))
    with pytest.raises(InputError) as info:
        load_layout(path)
    msg = str(info.value)
    for frag in (str(path), f"part '{data['parts'][2]['name']}'", "'board_contact_W_m2K'", fragment):
        assert frag in msg, (frag, msg)

def test_board_contact_on_a_part_touching_no_board_is_rejected(tmp_path):
    from conftest import dump_toml, tomllib

    with open(resolve_layout("imu_cardguide"), "rb") as fh:
        data = tomllib.load(fh)
    data["parts"][6]["board_contact_W_m2K"] = 2000.0          # xstandoff_1: fine, it touches the x-board
    data["parts"][6]["min_mm"] = [63.7, 10.0, 13.9]             # moved 0.1 mm off the board
    data["parts"][6]["size_mm"] = [3.8, 3.5, 3.5]
    path = tmp_path / "loose.toml"
    path.write_text(dump_toml(data))
    with pytest.raises(InputError) as info:
        build_geometry(load_layout(path), "air")
    msg = str(info.value)
    for frag in (str(path), "part 'xstandoff_1'", "'board_contact_W_m2K'", "touches no board", "xboard"):
        assert frag in msg, (frag, msg)


# The coarse thermal solves of both layouts (energy balance, scheme ordering, card guide vs reference)
# are in tests/test_examples.py, which runs the study scripts once.
