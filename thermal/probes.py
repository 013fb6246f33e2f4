"""Probes: temperatures at points, by trilinear interpolation of the nodal field.

:func:`probe_matrix` is the sparse operator (n_points, n_nodes) that both solves, the reduced models and
the studies apply to a field; :func:`named_probes` reads the ``probes`` argument of the solves (a dict or
pairs of name and point [m]) into names and that operator.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from imutherm import InputError

def probe_matrix(grid, points) -> sp.csr_matrix:
    """Trilinear interpolation operator (n_points, n_nodes) for points [m] inside the grid."""
    pts = np.atleast_2d(np.asarray(points, dtype=float))
    if pts.size == 0:
        return sp.csr_matrix((0, grid.n_nodes))
    if pts.shape[1] != 3 or not np.all(np.isfinite(pts)):
        raise InputError(f"probe points must be finite (x, y, z) [m], got shape {pts.shape}")
    axes = (grid.xs, grid.ys, grid.zs)
    Nx, Ny, Nz = (len(a) for a in axes)
    idx, xi = [], []
    for d, a in enumerate(axes):
        p = pts[:, d]
        tol = 1e-9 * (a[-1] - a[0])
        out = (p < a[0] - tol) | (p > a[-1] + tol)
        if out.any():
            bad = pts[np.flatnonzero(out)[0]].tolist()
            raise InputError(f"probe point {bad} [m] lies outside the grid "
                             f"({'xyz'[d]} in [{a[0]:.6g}, {a[-1]:.6g}] m)")
        i = np.clip(np.searchsorted(a, p, side="right") - 1, 0, len(a) - 2)
        idx.append(i)
        xi.append(np.clip((p - a[i]) / (a[i + 1] - a[i]), 0.0, 1.0))
    rows, cols, vals = [], [], []
    for da in (0, 1):
        for db in (0, 1):
            for dc in (0, 1):
                w = (xi[0] if da else 1 - xi[0]) * (xi[1] if db else 1 - xi[1]) * (xi[2] if dc else 1 - xi[2])
                node = ((idx[0] + da) * Ny + (idx[1] + db)) * Nz + (idx[2] + dc)
                rows.append(np.arange(len(pts)))
                cols.append(node)
                vals.append(w)
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(len(pts), grid.n_nodes))


def named_probes(grid, probes) -> tuple:
    """(names, probe operator (n_probes, n_nodes)) of the solves' ``probes`` argument: None, a dict or pairs of
    name and point (x, y, z) [m]; names must be unique."""
    if probes is None:
        return (), sp.csr_matrix((0, grid.n_nodes))
    items = list(probes.items()) if isinstance(probes, dict) else list(probes)
    names = tuple(str(n) for n, _ in items)
    if len(set(names)) != len(names):
        raise InputError(f"probe names must be unique, got {names}")
    pts = np.array([np.asarray(p, dtype=float).reshape(3) for _, p in items]) if items else np.zeros((0, 3))
    return names, probe_matrix(grid, pts)

