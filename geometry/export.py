"""Files a person opens elsewhere: the parts as STL / GLB (trimesh), the mesh as VTU (meshio).

Coordinates in the STL/GLB are in millimetres (the unit CAD viewers assume);
the VTU is in metres, like every result field, with ``part`` and ``material``
as integer cell data (ParaView: colour by ``part``; the names are listed in
``geometry.json``).
"""

from __future__ import annotations

import os

import numpy as np

from imutherm.geometry.build import MM, Geometry
from imutherm.geometry.grid import TensorGrid

#: RGBA colours by part kind, for the GLB scene
KIND_COLOURS = {"housing": (170, 175, 185, 60), "lid": (170, 175, 185, 40), "board": (30, 120, 60, 255), "vias": (140, 190, 140, 255),
                "box": (230, 230, 220, 255), "component": (40, 40, 40, 255), "die": (200, 60, 40, 255),
                "pad": (200, 130, 50, 255), "bond": (120, 170, 230, 255)}


def _boxes(geometry: Geometry, part) -> list:
    """(lo, hi) boxes [m] that make up a part (the housing: base and four walls)."""
    if part.kind != "housing":
        return [(np.asarray(part.lo), np.asarray(part.hi))]
    (x0, y0, z0), (x1, y1, z1) = part.lo, part.hi
    (cx0, cy0, cz0), (cx1, cy1, _) = geometry.cavity
    return [(np.array([x0, y0, z0]), np.array([x1, y1, cz0])),           # base
            (np.array([x0, y0, cz0]), np.array([cx0, y1, z1])),          # wall x-
            (np.array([cx1, y0, cz0]), np.array([x1, y1, z1])),          # wall x+
            (np.array([cx0, y0, cz0]), np.array([cx1, cy0, z1])),        # wall y-
            (np.array([cx0, cy1, cz0]), np.array([cx1, y1, z1]))]        # wall y+


def part_meshes(geometry: Geometry) -> dict:
    """Part name -> ``trimesh.Trimesh`` in millimetres (the fill is left out)."""
    import trimesh

    out = {}
    for p in geometry.parts:
        if p.kind == "fill":
            continue
        pieces = []
        for lo, hi in _boxes(geometry, p):
            box = trimesh.creation.box(extents=(hi - lo) / MM)
            box.apply_translation((lo + hi) / 2 / MM)
            pieces.append(box)
        mesh = trimesh.util.concatenate(pieces)
        mesh.visual.face_colors = KIND_COLOURS.get(p.kind, (128, 128, 128, 255))
        out[p.name] = mesh
    return out


def write_stl(geometry: Geometry, path: str | os.PathLike) -> None:
    """All solid parts, merged, as one binary STL [mm]."""
    import trimesh

    trimesh.util.concatenate(list(part_meshes(geometry).values())).export(str(path), file_type="stl")


def write_glb(geometry: Geometry, path: str | os.PathLike) -> None:
    """A GLB scene [mm] with one named, coloured node per part."""
    import trimesh

    scene = trimesh.Scene()
    for name, mesh in part_meshes(geometry).items():
        scene.add_geometry(mesh, geom_name=name, node_name=name)
    scene.export(str(path), file_type="glb")


def write_vtu(grid: TensorGrid, geometry: Geometry, path: str | os.PathLike, point_data: dict | None = None) -> None:
    """The mesh as VTU [m] with cell data ``part`` and ``material`` (indices) for ParaView."""
    import meshio

    flat = grid.cell_part.ravel()
    materials = sorted({p.material for p in geometry.parts})
    mat_of_part = np.array([materials.index(p.material) for p in geometry.parts])
    mesh = meshio.Mesh(grid.node_coordinates(), [("hexahedron", grid.hex_connectivity())],
                       point_data=point_data or {},
                       cell_data={"part": [flat.astype(np.int32)], "material": [mat_of_part[flat].astype(np.int32)]})
    meshio.write(str(path), mesh, file_format="vtu")


def material_names(geometry: Geometry) -> list:
    """Material names in the order of the VTU ``material`` index."""
    return sorted({p.material for p in geometry.parts})
