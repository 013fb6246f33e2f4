"""``imutherm geometry``: build one scheme's parts and mesh; write JSON, STL/GLB, VTU and a picture.

Outputs in ``--out DIR``: ``geometry.json`` (mass, power, parts, mesh summary),
``geometry.stl`` and ``geometry.glb`` (parts in mm), ``mesh.vtu`` (ParaView:
cell data ``part`` / ``material``), ``layout.png`` and, for each board imported from a board file
(``imutherm import``), ``board_<name>.png``: the board over its true outline, every part with its reference.
"""

from __future__ import annotations

import math

from imutherm import InputError
from imutherm.cli import run_command
from imutherm.cli._common import atomic_outdir, check_outdir, write_json
from imutherm.cli._options import add_layout_arguments, add_out_argument, check_thermal_cost
from imutherm.geometry.build import MM, build_geometry
from imutherm.geometry.export import material_names, write_glb, write_stl, write_vtu
from imutherm.geometry.layout import load_layout
from imutherm.geometry.mesh import build_mesh, mesh_info
from imutherm.reports.board_plot import imported_boards


def geometry_summary(geometry, grid) -> dict:
    """The content of ``geometry.json`` (SI units, named in the keys)."""
    info = mesh_info(grid)
    lay = geometry.layout
    return {
        "layout": lay.name, "layout_file": lay.path, "scheme": geometry.scheme.name,
        "scheme_description": geometry.scheme.description,
        "mass_g": geometry.mass_kg * 1e3, "total_power_W": geometry.total_power_W,
        "ambient_C": lay.ambient_C,
        "mounting": {"kind": lay.mounting.kind, "face": lay.mounting.face,
                     "contact_conductance_W_m2K": lay.mounting.contact_conductance_W_m2K,
                     "temperature_C": lay.mounting.temperature_C},
        "outer_mm": [v / MM for v in geometry.outer[1]],
        "cavity_mm": [[v / MM for v in geometry.cavity[0]], [v / MM for v in geometry.cavity[1]]],
        "parts": [{"name": p.name, "kind": p.kind, "material": p.material, "volume_mm3": geometry.volumes[p.name] / MM**3,
                   "mass_g": geometry.volumes[p.name] * geometry.material(p.name).density * 1e3,
                   "power_W": p.power_W, "min_mm": [v / MM for v in p.lo], "max_mm": [v / MM for v in p.hi],
                   "cells_across": info.cells_across[p.name]} for p in geometry.parts],
        "sites_mm": {k: [v / MM for v in pos] for k, pos in geometry.sites.items()},
        "mesh": {"cells": info.n_cells, "nodes": info.n_nodes, "min_cell_mm": info.min_cell_mm,
                 "max_cell_mm": info.max_cell_mm, "thinnest_gap_mm": info.thinnest_gap_mm,
                 "thinnest_gap_cells": info.thinnest_gap_cells, "thinnest_gap_axis": info.thinnest_gap_axis,
                 "thinnest_gap_at_mm": info.thinnest_gap_at_mm, "fewest_gap_cells": info.fewest_gap_cells,
                 "shape": list(grid.shape), "part_index": list(grid.part_names),
                 "material_index": material_names(geometry), "faces": grid.face_names},
    }


def add_args(parser) -> None:
    """The options of ``imutherm geometry``."""
    add_layout_arguments(parser)
    add_out_argument(parser)
    parser.add_argument("--no-png", action="store_true", help="skip layout.png (and board_<name>.png)")


def main(argv=None) -> int:
    """``imutherm geometry ARGV...``; returns the exit status."""
    return run_command("geometry", argv)


def run(args) -> int:
    """Build, mesh and write the outputs of ``args``; returns 0."""
    check_outdir(args.out)
    if not math.isfinite(args.mesh_size) or args.mesh_size <= 0:
        raise InputError(f"--mesh-size must be a finite number > 0 [mm], got {args.mesh_size}")
    layout = load_layout(args.layout)
    geometry = build_geometry(layout, args.scheme)
    check_thermal_cost(geometry, args, geometry_only=True)
    grid = build_mesh(geometry, args.mesh_size, args.min_cells)
    summary = geometry_summary(geometry, grid)
    with atomic_outdir(args.out) as tmp:
        write_json(tmp / "geometry.json", summary)
        write_stl(geometry, tmp / "geometry.stl")
        write_glb(geometry, tmp / "geometry.glb")
        write_vtu(grid, geometry, tmp / "mesh.vtu")
        if not args.no_png:
            from imutherm.reports.board_plot import plot_board
            from imutherm.reports.layout_plot import plot_layout
            plot_layout(geometry, tmp / "layout.png")
            for name in imported_boards(geometry):  # an imported board over its true outline, every reference
                plot_board(geometry, name, tmp / f"board_{name}.png")
    m = summary["mesh"]
    print(f"{layout.name} / {geometry.scheme.name}: mass {summary['mass_g']:.1f} g, power {summary['total_power_W']:.3f} W, "
          f"{len(geometry.parts)} parts; mesh {m['cells']} cells, {m['nodes']} nodes, "
          f"cell edge {m['min_cell_mm']:.3g}..{m['max_cell_mm']:.3g} mm; {mesh_info(grid).gap_line()}")
    boards = "" if args.no_png else "".join(f" board_{b}.png" for b in imported_boards(geometry))
    print(f"wrote {args.out}/geometry.json geometry.stl geometry.glb mesh.vtu" + ("" if args.no_png else " layout.png")
          + boards)
    return 0
