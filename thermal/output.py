"""Field output: VTU files (meshio) and a PVD series for transients.

Point data ``temperature_C`` [°C]; cell data ``part`` (index into
``grid.part_names``, listed in the file's field data as ``part:<name>``).
Files are written under a temporary name and renamed, so a failed write
leaves nothing half-written.
"""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from imutherm import InputError
from imutherm.io import atomic_write


def _mesh(grid, T_C):
    import meshio

    T = np.asarray(T_C, dtype=float).reshape(-1)
    if T.shape != (grid.n_nodes,):
        raise InputError(f"write_vtu: temperature field has {T.size} values, the grid has {grid.n_nodes} nodes")
    field_data = {f"part:{name}": np.array([i, 3]) for i, name in enumerate(grid.part_names)}
    return meshio.Mesh(grid.node_coordinates(), [("hexahedron", grid.hex_connectivity())],
                       point_data={"temperature_C": T},
                       cell_data={"part": [np.asarray(grid.cell_part).reshape(-1).astype(np.int32)]},
                       field_data=field_data)


def write_vtu(path, grid, T_C) -> Path:
    """Write one temperature field as a VTU file.

    Parameters
    ----------
    path : str or Path
        Target ``.vtu`` file.
    grid : TensorGrid
    T_C : ndarray (n_nodes,) [°C]

    Returns
    -------
    Path of the written file.
    """
    import meshio

    path = Path(path)
    mesh = _mesh(grid, T_C)
    atomic_write(path, lambda tmp: meshio.write(tmp, mesh, file_format="vtu"))
    return path


def write_pvd(path, grid, times, fields) -> Path:
    """Write a transient series: one VTU per time plus a ParaView ``.pvd`` collection.

    Parameters
    ----------
    path : str or Path
        Target ``.pvd`` file; the VTUs are written next to it as ``<stem>_0000.vtu`` ...
    grid : TensorGrid
    times : sequence of float [s]
    fields : ndarray (n_times, n_nodes) [°C]

    Returns
    -------
    Path of the ``.pvd`` file.
    """
    path = Path(path)
    times = np.asarray(times, dtype=float).reshape(-1)
    fields = np.asarray(fields, dtype=float)
    if fields.shape != (times.size, grid.n_nodes):
        raise InputError(f"write_pvd: fields must have shape ({times.size}, {grid.n_nodes}), got {fields.shape}")
    lines = ['<?xml version="1.0"?>',
             '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
             "  <Collection>"]
    for i, (t, T) in enumerate(zip(times, fields)):
        name = f"{path.stem}_{i:04d}.vtu"
        write_vtu(path.parent / name, grid, T)
        lines.append(f'    <DataSet timestep="{t:.9g}" group="" part="0" file={quoteattr(name)}/>')
    lines += ["  </Collection>", "</VTKFile>", ""]
    atomic_write(path, lambda tmp: Path(tmp).write_text("\n".join(lines)))
    return path


def write_result(path, result) -> Path:
    """Write a steady result as ``<path>.vtu`` or a transient's saved fields as ``<path>.pvd`` series.

    Parameters
    ----------
    path : str or Path
        Target without or with suffix (``.vtu`` steady, ``.pvd`` transient).
    result : SteadyResult or TransientResult
        A transient writes its ``saved_times`` fields (or, if none, the final field).
    """
    path = Path(path)
    if hasattr(result, "times"):
        if len(result.saved_times):
            return write_pvd(path.with_suffix(".pvd"), result.grid, result.saved_times, result.saved_C)
        return write_pvd(path.with_suffix(".pvd"), result.grid, [result.times[-1]], [result.T_C])
    return write_vtu(path.with_suffix(".vtu"), result.grid, result.T_C)
