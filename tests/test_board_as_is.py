"""The board as it is (issue 55 item 4): its true outline in the mesh, its copper measured, its vias, its
parts' heights from their 3D models. Boards written by the test (``tests/kicad_writer.py``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from imutherm.ecad.read import read_board
from imutherm.ecad.to_layout import ImportOptions, import_board
from imutherm.geometry.build import build_geometry
from imutherm.geometry.materials import get_material
from imutherm.geometry.mesh import build_mesh
from imutherm.geometry.outline import board_loops, outline_area

from kicad_writer import kicad_board, part

SOIC = "Package_SO:SOIC-8_3.9x4.9mm"
POWER = ImportOptions(powers={"U1": (0.1, "test")})


def _import(tmp_path, parts=None, **kw):
    path = tmp_path / "b.kicad_pcb"
    path.write_text(kicad_board(parts or [part("U1", SOIC, (110, 105, 0))], **kw))
    return import_board(read_board(path), POWER)


def _board_cells(grid, name="main"):
    """(board-cell volume [mm^3], cell part array, in-plane cell centres [mm])."""
    dx, dy, dz = grid.cell_sizes()
    cells = grid.cell_part == grid.part_names.index(name)
    vol = float(np.einsum("i,j,k->ijk", dx, dy, dz)[cells].sum()) / 1e-9
    return vol, cells


# ------------------------------------------------------------------ 1: the true outline in the mesh
def test_a_slot_is_not_board_and_the_board_cells_fill_the_outline_exactly(tmp_path):
    """A 40 x 30 mm board with a 20 x 2 mm slot: the board's cells hold 40 x 30 - 20 x 2 = 1160 mm^2 of board
    (grid lines on the slot's edges make it exact), the slot's cells are the cavity's fill, and the board's
    volume (mass) is the outline's."""
    slot = '  (gr_rect (start 110 112) (end 130 114) (layer "Edge.Cuts") (width 0.05))'
    r = _import(tmp_path, extra=slot)
    g = build_geometry(r.spec, "air")
    grid = build_mesh(g)
    vol, cells = _board_cells(grid)
    t = r.board.thickness_mm
    assert vol == pytest.approx((40 * 30 - 20 * 2) * t, rel=1e-9)
    assert g.volumes["main"] / 1e-9 == pytest.approx((40 * 30 - 20 * 2) * t, rel=1e-9)
    xc, yc, zc = (c / 1e-3 for c in grid.cell_centres())
    x0, y0, z0 = r.spec.boards[0].min_mm
    # the slot: board-local u 10..30, v 16..18 (KiCad y 112..114 flipped on a board of y 100..130)
    i = np.flatnonzero((xc > x0 + 10) & (xc < x0 + 30))
    j = np.flatnonzero((yc > y0 + 16) & (yc < y0 + 18))
    k = np.flatnonzero((zc > z0) & (zc < z0 + t))
    block = grid.cell_part[np.ix_(i, j, k)]
    assert len(i) and len(j) and len(k) and (block == grid.part_names.index("fill")).all()
    # beside the slot, still board
    j_near = np.flatnonzero((yc > y0 + 19) & (yc < y0 + 20))
    assert cells[np.ix_(i, j_near, k)].all()


def test_a_round_cut_out_follows_the_outline_within_a_cell(tmp_path):
    """A 10 mm round hole in the board: the board cells' area is the outline's (40 x 30 - 25 pi mm^2) to within
    the staircase of cells along the circle (one cell row round its 31.4 mm circumference)."""
    hole = '  (gr_circle (center 120 115) (end 125 115) (layer "Edge.Cuts") (width 0.05))'
    r = _import(tmp_path, extra=hole)
    g = build_geometry(r.spec, "air")
    grid = build_mesh(g)
    vol, _ = _board_cells(grid)
    t = r.board.thickness_mm
    exact = (40 * 30 - 25 * math.pi) * t
    assert g.volumes["main"] / 1e-9 == pytest.approx(exact, rel=2e-3)   # the 72-gon of the drawn circle
    cell = max(float(np.max(np.diff(grid.xs))), float(np.max(np.diff(grid.ys)))) / 1e-3
    assert abs(vol - exact) < 0.5 * cell * 10 * math.pi * t
    assert vol < 40 * 30 * t - 0.5 * 25 * math.pi * t   # the hole is there, not the rectangle


def test_a_rectangular_outline_leaves_the_mesh_as_it_was(tmp_path):
    """An outline that is the board's rectangle cuts nothing: no board cell becomes fill, the volume is the
    box's."""
    r = _import(tmp_path)
    b = r.spec.boards[0]
    loops = board_loops(b.outline_mm)
    assert outline_area(loops) == pytest.approx(40 * 30)
    g = build_geometry(r.spec, "air")
    vol, _ = _board_cells(build_mesh(g))
    assert vol == pytest.approx(40 * 30 * r.board.thickness_mm, rel=1e-9)


def test_a_notched_board_edge_is_fill(tmp_path):
    """An L-shaped board (a 15 x 10 mm notch out of a 40 x 30 mm rectangle's corner): the notch is fill."""
    pts = [(100, 100), (140, 100), (140, 120), (125, 120), (125, 130), (100, 130), (100, 100)]
    edge = "\n".join(f'  (gr_line (start {a[0]} {a[1]}) (end {b[0]} {b[1]}) (layer "Edge.Cuts") (width 0.05))'
                     for a, b in zip(pts[:-1], pts[1:]))
    r = _import(tmp_path, outline=None, extra=edge)
    g = build_geometry(r.spec, "air")
    vol, _ = _board_cells(build_mesh(g))
    assert vol == pytest.approx((40 * 30 - 15 * 10) * r.board.thickness_mm, rel=1e-9)


# ------------------------------------------------------------------ 2: copper coverage measured
def _zone(layer, pts, filled=True):
    xy = " ".join(f"(xy {x} {y})" for x, y in pts)
    fill = f' (filled_polygon (layer "{layer}") (pts {xy}))' if filled else ""
    return (f'  (zone (net 0) (net_name "") (layer "{layer}") (hatch edge 0.5) (min_thickness 0.25) (fill yes) '
            f"(polygon (pts {xy})){fill})")


def test_copper_coverage_is_measured_against_a_hand_count(tmp_path):
    """A 20 x 20 mm board with a 2 x 10 mm slot (380 mm^2 of board), four copper layers:
    F.Cu: a 10 x 10 mm zone + two 1 x 1 mm pads + a 0.6 mm via = 102.283 mm^2 -> 26.92 %;
    In1.Cu: a zone left unfilled in the file, counted by its 20 x 20 mm outline, clipped to the board -> 100 %;
    In2.Cu: the via alone -> 0.07 %;
    B.Cu: a 0.5 mm track 10 mm long (5 + pi 0.25^2 mm^2 with its round ends) + the via -> 1.44 %.
    The board's conductivity is the rule of mixtures at these coverages, and the printout and the TOML say them.
    (The track lies off the 0.1 mm raster's cell edges, as a routed track does: one whose edges fall on cell
    centres would count a row more or less.)"""
    from imutherm.ecad.kicad_copper import with_coverage
    from imutherm.geometry.board_material import board_material

    pads = [("1", "smd", -1.5, 0, 1.0, 1.0), ("2", "smd", 1.5, 0, 1.0, 1.0)]
    u1 = part("U1", SOIC, (103, 117, 0), fab=(-2, -1, 2, 1), pads=pads)
    square = [(105, 103), (115, 103), (115, 113), (105, 113)]
    extra = "\n".join([
        _zone("F.Cu", square),
        _zone("In1.Cu", [(100, 100), (120, 100), (120, 120), (100, 120)], filled=False),
        '  (segment (start 102 116.03) (end 112 116.03) (width 0.5) (layer "B.Cu") (net 0))',
        '  (gr_rect (start 117 105) (end 119 115) (layer "Edge.Cuts") (width 0.05))'])
    path = tmp_path / "cu.kicad_pcb"
    path.write_text(kicad_board([u1], outline=(100, 100, 120, 120), vias=[(110, 118.5, 0.3)], extra=extra))
    board = read_board(path)
    measured, note = with_coverage(board)
    via = math.pi * 0.3 ** 2
    hand = ((100 + 2 + via) / 380, 1.0, via / 380, (5 + math.pi * 0.25 ** 2 + via) / 380)
    assert measured.coverage == pytest.approx(hand, abs=0.1 / 380)   # within 0.1 mm^2 of the hand count
    assert "F.Cu 27 %, In1.Cu 100 %, In2.Cu 0 %, B.Cu 1 %" in note and "1 zones without a fill" in note

    r = import_board(board, ImportOptions(powers={"U1": (0.1, "test")}))
    assert note in r.notes and "measured coverage 26.9%, 100.0%, 0.1%, 1.4%" in r.text
    expected = board_material("board", board.thickness_mm, board.copper_um, coverage=measured.coverage)
    got = get_material(r.spec.boards[0].material)
    assert got.k_in_plane == pytest.approx(expected.k_in_plane, rel=1e-3)
    assert got.k_through == pytest.approx(expected.k_through, rel=1e-3)


def test_rotated_and_round_pads_cover_their_own_area(tmp_path):
    """A footprint turned 45 degrees with a 2 x 1 mm rectangular pad, a 1 mm round pad and a 2 x 1 mm oval pad,
    on a 20 x 20 mm board: F.Cu covers 2 + pi/4 + (1 + pi/4) mm^2 of 400, to 0.12 mm^2 (a cell row along an
    edge is 0.1 mm wide: a lone pad's area is good to a few %, a board's thousands of pads average out; the part
    stands off the raster's cell edges, as a placed part does)."""
    pads = [("1", "smd", -3, 0, 2.0, 1.0), ("2", "thru_hole", 0, 0, 1.0, 1.0, 0.5), ("3", "smd", 3, 0, 2.0, 1.0)]
    u1 = part("U1", SOIC, (110.013, 110.037, 45), fab=(-4, -1, 4, 1), pads=pads)
    text = kicad_board([u1], outline=(100, 100, 120, 120), copper=2)
    text = text.replace('(pad "3" smd rect', '(pad "3" smd oval')
    path = tmp_path / "pads.kicad_pcb"
    path.write_text(text)
    from imutherm.ecad.kicad_copper import with_coverage

    measured, _ = with_coverage(read_board(path))
    front = (2 + math.pi / 4 + 1 + math.pi / 4) / 400
    back = (math.pi / 4) / 400   # the through-hole pad is on every copper layer
    assert measured.coverage == pytest.approx((front, back), abs=0.12 / 400)


# ------------------------------------------------------------------ 3: via fields from the file's vias
def test_a_via_field_is_made_of_the_files_vias_against_a_hand_computation(tmp_path):
    """A QFN with a 3 x 3 mm exposed pad over four 0.3 mm board vias and one 0.2 mm plated hole of its own (a
    fifth via beside the part does not count): copper barrels of 25 um outside each hole,
    phi = pi 0.025 (4 x 0.325 + 0.225) / 9 = 0.01331, and k_through = phi 398 + (1 - phi) k_board_through;
    in-plane the board's. The via field of the mesh is made of it."""
    from imutherm.geometry.board_material import via_field_material

    ring = [(str(i + 1), "smd", x, y, 0.8, 0.3) for i, (x, y) in enumerate(
        [(-2.2, -0.5), (-2.2, 0.5), (2.2, -0.5), (2.2, 0.5), (-0.5, -2.2), (0.5, -2.2), (-0.5, 2.2), (0.5, 2.2)])]
    pads = ring + [("9", "smd", 0, 0, 3.0, 3.0), ("9", "thru_hole", 0, 0, 0.4, 0.4, 0.2)]
    u1 = part("U1", "Package_DFN_QFN:QFN-16-1EP_5x5mm_P0.8mm_EP3x3mm", (110, 110, 0), fab=(-2.5, -2.5, 2.5, 2.5),
              pads=pads)
    vias = [(109.2, 109.2, 0.3), (110.8, 109.2, 0.3), (109.2, 110.8, 0.3), (110.8, 110.8, 0.3), (115, 115, 0.3)]
    path = tmp_path / "vias.kicad_pcb"
    path.write_text(kicad_board([u1], vias=vias))
    r = import_board(read_board(path), POWER)
    comp = next(c for c in r.spec.components if c.name == "U1")
    assert comp.exposed_pad and comp.vias and comp.pad_mm == (3.0, 3.0)
    field = get_material(comp.vias_material)
    board = get_material(r.spec.boards[0].material)
    phi = math.pi * 0.025 * (4 * 0.325 + 0.225) / 9.0
    assert phi == pytest.approx(0.01331, abs=5e-5)
    assert field.k_through == pytest.approx(phi * 398 + (1 - phi) * board.k_through, rel=1e-4)
    assert field.k_in_plane == board.k_in_plane
    assert field.density == pytest.approx(phi * 8933 + (1 - phi) * board.density, rel=1e-4)
    assert via_field_material("x", board, [0.3] * 4 + [0.2], 9.0).k_through == pytest.approx(field.k_through)
    g = build_geometry(r.spec, "air")
    assert g.part("U1_vias").material == comp.vias_material
    assert "5 vias" in field.source and "5 vias inside the exposed pad" in r.text


def test_a_hand_written_via_field_keeps_the_library_material():
    """A layout's via field without ``vias_material`` is the library's ``pcb_via_field`` (the reference unit)."""
    g = build_geometry("imu_reference", "air")
    fields = [p for p in g.parts if p.kind == "vias"]
    assert fields and all(p.material == "pcb_via_field" for p in fields)


# ------------------------------------------------------------------ 4: the drawing
def test_the_board_drawing_shades_the_outline_and_names_the_measured_coverage(tmp_path):
    """The drawing shades the model's board (the slot left clear, as the mesh has it) and gives each layer's
    measured copper coverage (the layout's ``copper_coverage``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from imutherm.reports.board_plot import board_figure

    slot = '  (gr_rect (start 110 112) (end 130 114) (layer "Edge.Cuts") (width 0.05))'
    r = _import(tmp_path, extra=slot)
    b = r.spec.boards[0]
    assert len(b.copper_coverage) == 4 and b.copper_coverage == pytest.approx(r.board.coverage, abs=1e-4)
    fig = board_figure(build_geometry(r.spec, "air"), "main")
    try:
        image = fig.axes[0].images[0].get_array()
        cell = 40.0 / image.shape[1]
        slot_px = image[int(17 / cell), int(20 / cell)]      # board-local (u, v) = (20, 17): in the slot
        board_px = image[int(5 / cell), int(20 / cell)]
        assert slot_px[3] == 0 and board_px[3] > 0
        front = 100 * b.copper_coverage[0]
        assert f"front copper {front:.0f} %" in fig.axes[0].get_title()
        assert "copper coverage measured, front to back" in fig._suptitle.get_text()
    finally:
        plt.close(fig)


# ------------------------------------------------------------------ 5: heights from the 3D models on the disk
def _box_wrl(z0: float, z1: float) -> str:
    """A VRML box 2 x 1 units in plan from z0 to z1 [VRML units of 0.1 inch], as KiCad's libraries write."""
    pts = ", ".join(f"{x} {y} {z}" for z in (z0, z1) for x, y in ((-1, -0.5), (1, -0.5), (1, 0.5), (-1, 0.5)))
    return ("#VRML V2.0 utf8\nShape { appearance Appearance {}\n geometry IndexedFaceSet {\n"
            f"  coord Coordinate {{ point [ {pts} ] }}\n  coordIndex [ 0, 1, 2, 3, -1 ]\n }}\n}}\n")


def _step(points, unit="SI_UNIT(.MILLI.,.METRE.)") -> str:
    rows = "\n".join(f"#{i + 10}=CARTESIAN_POINT('',({x},{y},{z}));" for i, (x, y, z) in enumerate(points))
    return (f"ISO-10303-21;\nHEADER;\nENDSEC;\nDATA;\n#1=( LENGTH_UNIT() NAMED_UNIT(*) {unit} );\n{rows}\n"
            "ENDSEC;\nEND-ISO-10303-21;\n")


def _model_part(ref, at, model):
    p = part(ref, "Vendor:NoSuchPackage", at, fab=(-1.5, -1.0, 1.5, 1.0))
    p["fields"] = {}
    p["model"] = model
    return p


def test_heights_from_wrl_and_step_models_on_the_disk(tmp_path, monkeypatch):
    """Three parts of no known package, each with a 3D model the board names:
    U1 ``${KIPRJMOD}/models/u1.wrl``: a box up to 0.6 VRML units = 0.6 x 2.54 = 1.524 mm;
    U2 ``${KICAD8_3DMODEL_DIR}/x.3dshapes/u2.wrl`` that exists only as ``u2.step`` (mm, top at z = 2.0 mm),
    offset 0.5 mm up and scaled 1.5 in z: 2.0 x 1.5 + 0.5 = 3.5 mm;
    U3 a STEP in inches (top at 0.1 in) turned 180 degrees about x: its lowest point (-0.02 in = -0.508 mm)
    becomes its top, 0.508 mm.
    A model the disk does not hold (U4) gives no height: the import asks for it, as before."""
    models = tmp_path / "models"
    models.mkdir()
    (models / "u1.wrl").write_text(_box_wrl(0.0, 0.6))
    lib = tmp_path / "lib" / "x.3dshapes"
    lib.mkdir(parents=True)
    (lib / "u2.step").write_text(_step([(0, 0, 0), (1, 1, 2.0), (-1, -1, 0.3)]))
    (lib / "u3.stp").write_text(_step([(0, 0, -0.02), (0.05, 0.05, 0.1)],
                                      "( CONVERSION_BASED_UNIT('INCH',#5) LENGTH_UNIT() NAMED_UNIT(#6) )"))
    for var in ("KICAD9_3DMODEL_DIR", "KICAD7_3DMODEL_DIR", "KICAD6_3DMODEL_DIR", "KISYS3DMOD"):
        monkeypatch.delenv(var, raising=False)
    monkeypatch.setenv("KICAD8_3DMODEL_DIR", str(tmp_path / "lib"))
    parts = [
        _model_part("U1", (105, 105, 0), '(model "${KIPRJMOD}/models/u1.wrl" (offset (xyz 0 0 0)) '
                                         '(scale (xyz 1 1 1)) (rotate (xyz 0 0 0)))'),
        _model_part("U2", (115, 105, 90), '(model "${KICAD8_3DMODEL_DIR}/x.3dshapes/u2.wrl" (offset (xyz 0 0 0.5)) '
                                          '(scale (xyz 1 1 1.5)) (rotate (xyz 0 0 0)))'),
        _model_part("U3", (125, 105, 0), '(model "${KICAD6_3DMODEL_DIR}/x.3dshapes/u3.stp" '
                                         '(scale (xyz 1 1 1)) (rotate (xyz 180 0 0)))'),
        _model_part("U4", (105, 120, 0), '(model "${KICAD8_3DMODEL_DIR}/x.3dshapes/missing.wrl")'),
    ]
    path = tmp_path / "m.kicad_pcb"
    text = kicad_board(parts)
    for p in parts:   # the model inside its footprint, before the footprint closes
        text = text.replace(f'(fp_text reference "{p["ref"]}" (at 0 0) (layer "F.SilkS"))',
                            f'(fp_text reference "{p["ref"]}" (at 0 0) (layer "F.SilkS"))\n    {p["model"]}')
    path.write_text(text)
    fps = {fp.ref: fp for fp in read_board(path).footprints}
    assert fps["U1"].height_mm == pytest.approx(0.6 * 2.54)
    assert fps["U2"].height_mm == pytest.approx(3.5)
    assert fps["U3"].height_mm == pytest.approx(0.508)
    assert fps["U4"].height_mm is None
    assert "u1.wrl" in fps["U1"].height_source and "u2.step" in fps["U2"].height_source
    r = import_board(read_board(path), ImportOptions(powers={"U1": (0.1, "t"), "U2": (0.1, "t"), "U3": (0.1, "t")},
                                                     heights={"U4": (1.0, "test")}))
    comps = {c.name: c for c in r.spec.components}
    assert comps["U1"].size_mm[2] == pytest.approx(1.524) and comps["U2"].size_mm[2] == pytest.approx(3.5)
    assert "its 3D model" in r.text


# ------------------------------------------------------------------ bad input in what this reads
@pytest.mark.parametrize("item, words", [
    ('  (zone (net 0) (layer "F.Cu") (polygon (pts (xy 105 105) (xy nan 105) (xy 110 110))))',
     "a zone's outline point: expected a number"),
    ('  (segment (start 102 116) (end 1e12 116) (width 0.5) (layer "B.Cu") (net 0))', "a track (segment) end"),
    ('  (via (at 110 110) (size inf) (drill 0.3) (layers "F.Cu" "B.Cu"))', "a via size"),
])
def test_damaged_copper_is_refused_in_one_line(tmp_path, item, words):
    from imutherm import InputError

    path = tmp_path / "bad.kicad_pcb"
    path.write_text(kicad_board([part("U1", SOIC, (110, 105, 0))], extra=item))
    with pytest.raises(InputError) as exc:
        read_board(path)
    assert words in str(exc.value) and "\n" not in str(exc.value)


def test_a_via_material_without_a_via_field_is_refused(tmp_path):
    from imutherm import InputError
    from imutherm.geometry.layout import parse_layout

    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover
        import tomli as tomllib
    r = _import(tmp_path)
    text = r.text.replace('material = "mould_compound"',
                          'material = "mould_compound"\nvias_material = "pcb_via_field"', 1)
    with pytest.raises(InputError, match="vias_material.*needs vias = true"):
        parse_layout(tomllib.loads(text), "t")


def test_a_copper_shape_beyond_any_board_is_refused_in_one_line(tmp_path, monkeypatch):
    """A zone fill zig-zagging 4,000 times across the board crosses the raster's rows beyond the limit (lowered
    here to 1e6 to keep the test small; a board's whole copper layer crosses them a few hundred thousand
    times): refused naming the file and the layer, before the raster is filled."""
    from imutherm import InputError
    from imutherm.ecad.kicad_copper import with_coverage
    from imutherm.geometry import raster

    monkeypatch.setattr(raster, "MAX_CROSSINGS", 1_000_000)
    pts = [(100 + 40 * k / 4000, 100.0 if k % 2 else 130.0) for k in range(4001)] + [(140, 135), (100, 135)]
    path = tmp_path / "zigzag.kicad_pcb"
    path.write_text(kicad_board([part("U1", SOIC, (110, 105, 0))], extra=_zone("In1.Cu", pts)))
    board = read_board(path)
    with pytest.raises(InputError) as exc:
        with_coverage(board)
    msg = str(exc.value)
    assert "zigzag.kicad_pcb: a copper shape on In1.Cu" in msg and "not a board's copper" in msg and "\n" not in msg
