"""Geometry: the reference unit, part volumes, the conforming mesh and its thin layers."""

import numpy as np
import pytest

from imutherm.geometry.build import MM, build_geometry
from imutherm.geometry.layout import load_layout
from imutherm.geometry.mesh import BOARD_CELLS_FACTOR, build_mesh, mesh_info, to_skfem

SCHEMES = ("air", "grease", "potted")


@pytest.fixture(scope="module")
def geometries():
    return {s: build_geometry(None, s) for s in SCHEMES}


@pytest.fixture(scope="module")
def meshes(geometries):
    return {s: build_mesh(g) for s, g in geometries.items()}


def test_reference_layout_round_trips_through_the_writer(write_layout):
    # the test helper writes layouts the loader reads back unchanged
    assert load_layout(write_layout()).components == load_layout().components


def test_reference_unit_matches_the_paper(geometries):
    g = geometries["grease"]
    assert np.allclose(g.outer[1], np.array([70.0, 48.0, 25.0]) * MM)
    # paper 000: 95 g (chosen scheme); our parts land within 5 %
    assert g.mass_kg * 1e3 == pytest.approx(95.0, rel=0.05)
    # the layout's power budget: the parts' powers plus the regulators' losses from the electrical design at the
    # assumed 9 V supply (the hand calculation is in the layout's comments and tests/test_electrical.py)
    assert g.total_power_W == pytest.approx(1.9621, abs=1e-9)
    names = {p.name for p in g.parts}
    assert {"gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z", "processor", "adc"} <= names
    assert set(g.sites) == {"gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z", "tp1", "tp2", "tp3"}
    axes = {c.name: c.axis for c in g.layout.components if c.axis}
    assert sorted(v for k, v in axes.items() if k.startswith("gyro")) == ["x", "y", "z"]
    assert sorted(v for k, v in axes.items() if k.startswith("accel")) == ["x", "y", "z"]


def test_boards_are_mutually_orthogonal(geometries):
    normals = [p.normal for p in geometries["air"].parts if p.kind == "board"]
    assert sorted(normals) == ["x", "y", "z"]


def test_schemes_differ_as_the_paper_says(geometries):
    air, grease, potted = (geometries[s] for s in SCHEMES)
    assert air.part("fill").material == "air" and potted.part("fill").material == "potting_compound"
    main = grease.part("main")
    for chip in ("processor", "reg_5v", "reg_3v3", "reg_1v8"):
        # on top of the main board in scheme 1, on its back in scheme 2, bonded to the base by grease
        assert air.part(chip).lo[2] == pytest.approx(air.part("main").hi[2])
        assert grease.part(chip).hi[2] == pytest.approx(main.lo[2])
        bond = grease.part(chip + "_bond")
        assert bond.material == "silicone_grease"
        assert bond.lo[2] == pytest.approx(grease.cavity[0][2]) and bond.hi[2] == pytest.approx(grease.part(chip).lo[2])
        assert 0.5 * MM <= bond.size[2] <= 1.5 * MM  # "about 1 mm from the inner wall"
    assert not any(p.kind == "bond" for p in air.parts + potted.parts)
    # potting adds mass, the bonds a little
    assert potted.mass_kg > grease.mass_kg > air.mass_kg


def test_part_volumes_equal_box_volumes(geometries):
    g = geometries["grease"]
    box = lambda p: np.prod(np.subtract(p.hi, p.lo))  # noqa: E731
    for p in g.parts:
        if p.kind in ("box", "lid", "bond", "die", "pad", "vias"):
            assert g.volumes[p.name] == pytest.approx(box(p), rel=1e-12)
        if p.kind in ("board", "component"):  # minus the via fields / die and pad inside
            inner = sum(box(c) for c in g.parts if c.parent == p.name and c.kind != "bond")
            assert g.volumes[p.name] == pytest.approx(box(p) - inner, rel=1e-12)
    h = g.part("housing")
    ox, oy, oz = 70.0, 48.0, 25.0 - 2.5
    cx, cy, cz = 70.0 - 5.0, 48.0 - 5.0, 25.0 - 2.5 - 3.0
    assert g.volumes[h.name] == pytest.approx((ox * oy * oz - cx * cy * cz) * MM**3, rel=1e-12)
    total = sum(g.volumes.values())
    assert total == pytest.approx(70 * 48 * 25 * MM**3, rel=1e-12)


@pytest.mark.parametrize("scheme", SCHEMES)
def test_mesh_volume_per_part_equals_part_volume(geometries, meshes, scheme):
    g, m = geometries[scheme], meshes[scheme]
    vol = np.bincount(m.cell_part.ravel(), weights=m.cell_volumes().ravel(), minlength=len(m.part_names))
    for i, name in enumerate(m.part_names):
        assert vol[i] == pytest.approx(g.volumes[name], rel=1e-9), name
    assert set(m.part_names) == {p.name for p in g.parts}


def test_mesh_lines_fall_on_every_part_face(geometries, meshes):
    g, m = geometries["grease"], meshes["grease"]
    for p in g.parts:
        for axis, lines in enumerate((m.xs, m.ys, m.zs)):
            for v in (p.lo[axis], p.hi[axis]):
                assert np.min(np.abs(lines - v)) < 1e-12, (p.name, axis, v)


def test_max_cell_size_and_thin_layers(geometries):
    g = geometries["grease"]
    for h, n in ((2.0, 2), (1.0, 3)):
        m = build_mesh(g, max_cell_mm=h, min_cells=n)
        info = mesh_info(m)
        assert info.max_cell_mm <= h + 1e-9
        for p in g.parts:
            if p.kind != "fill":
                assert info.cells_across[p.name] >= n, p.name
        # the ~1 mm grease lines get n cells through their thickness, not the whole unit refined
        bond = g.part("processor_bond")
        k0, k1 = np.searchsorted(m.zs, [bond.lo[2] - 1e-12, bond.hi[2] - 1e-12])
        assert k1 - k0 >= n
        # boards get BOARD_CELLS_FACTOR x n cells through their thickness (main board: z)
        board = g.part("main")
        k0, k1 = np.searchsorted(m.zs, [board.lo[2] - 1e-12, board.hi[2] - 1e-12])
        assert k1 - k0 == BOARD_CELLS_FACTOR * n


def test_a_thin_bond_line_is_resolved_without_refining_everything(write_layout):
    def thin(d):  # main board 0.1 mm lower: back-side chips 0.1 mm from the base
        d["boards"][0]["min_mm"][2] -= 0.9
        for s in d["parts"]:
            if s["name"].startswith("standoff"):
                s["size_mm"][2] -= 0.9
        for b in d["boards"][1:]:
            b["min_mm"][2] -= 0.9
    g = build_geometry(write_layout(thin), "grease")
    bond = g.part("reg_5v_bond")  # SOT-223, 1.7 mm high: a 0.1 mm grease line
    assert bond.size[2] == pytest.approx(0.1 * MM)
    m = build_mesh(g, max_cell_mm=2.0, min_cells=2)
    k0, k1 = np.searchsorted(m.zs, [bond.lo[2] - 1e-12, bond.hi[2] - 1e-12])
    assert k1 - k0 == 2 and np.allclose(np.diff(m.zs[k0:k1 + 1]), 0.05 * MM)
    assert mesh_info(m).n_cells < 2.0e5  # the rest keeps its coarse cells


def test_every_cell_belongs_to_one_part_and_faces_are_named(geometries):
    m = build_mesh(geometries["air"], max_cell_mm=8.0, min_cells=1)  # coarse: scikit-fem's basis is slow
    assert m.cell_part.min() >= 0 and m.cell_part.max() < len(m.part_names)
    sk = to_skfem(m)
    assert set(sk.subdomains) == set(m.part_names)
    assert sum(len(v) for v in sk.subdomains.values()) == m.n_cells
    assert set(sk.boundaries) == {"side_xmin", "side_xmax", "side_ymin", "side_ymax", "bottom", "top"}
    nx, ny, nz = m.shape
    assert len(sk.boundaries["bottom"]) == nx * ny
    # scikit-fem sees the same volume
    import skfem
    basis = skfem.Basis(sk, skfem.ElementHex1())
    vol = skfem.Functional(lambda w: 1.0 + 0 * w.x[0]).assemble(basis)
    assert vol == pytest.approx(70 * 48 * 25 * MM**3, rel=1e-10)


def test_sites_sit_on_their_parts(geometries):
    g = geometries["grease"]
    for name in ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"):
        assert np.allclose(g.sites[name], g.part(name + "_die").centroid)
    assert g.sites["tp1"][2] == pytest.approx(g.part("main").hi[2])
