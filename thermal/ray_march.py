"""The ray march of the cavity's view factors: which patch each ray hits (:func:`march`).

Each ray walks cell by cell through the air cells of a non-uniform tensor grid by the exact 3-D DDA of
Amanatides & Woo (1987, "A fast voxel traversal algorithm for ray tracing", Eurographics '87): the next face
crossed is the axis of the smallest ray parameter ``tmax`` (the first such axis on a tie), and the ray stops at
the first solid cell (its hit: the patch of the face crossed) or where it leaves the grid (no hit, -1).

:func:`march` is one compiled loop per ray (numba, through :mod:`imutherm.lazy_jit`: compiled at its first call,
cached on disk, one process of the machine at a time); :func:`march_numpy` is the same march vectorised over
all rays with numpy, one Python step per cell crossed, kept as the reference the compiled one is tested against
(the same hits, ray for ray: the same floating-point operations in the same order).
On the reference unit's air scheme (1,262 patches x 400 rays, ~100 cells crossed by the longest rays) the numpy
march took 2.2 s of the view factors' 2.7 s (docs/benchmarks/cavity_radiation.md gives the compiled figure).
"""

from __future__ import annotations

import numpy as np

from imutherm.lazy_jit import njit


def _check(pos, dirs, cell):
    pos, dirs = np.ascontiguousarray(pos, float), np.ascontiguousarray(dirs, float)
    cell = np.ascontiguousarray(cell, np.int64)
    if pos.ndim != 2 or pos.shape[1] != 3 or dirs.shape != pos.shape or cell.shape != pos.shape:
        raise ValueError(f"ray march: origins, directions and cells must be (R, 3), got {pos.shape}, "
                         f"{dirs.shape}, {cell.shape}")
    return pos, dirs, cell


def march_numpy(grid, air: np.ndarray, face_patch: tuple, pos, dirs, cell) -> np.ndarray:
    """Patch hit by each ray (-1: none), all rays marched together with numpy (the reference of :func:`march`).

    grid : TensorGrid; air : (nx, ny, nz) bool cell mask; face_patch : the patch of each grid face normal to x,
    y, z (:class:`~imutherm.thermal.cavity_radiation.Patches`); pos (R, 3) [m] ray origins, dirs (R, 3) unit
    directions, cell (R, 3) int the air cell each ray starts in.
    """
    pos, dirs, cell = _check(pos, dirs, cell)
    lines = (grid.xs, grid.ys, grid.zs)
    shape = np.array(grid.shape)
    R = len(pos)
    hit = np.full(R, -1, dtype=np.int64)
    step = np.where(dirs > 0, 1, -1)
    tmax = np.empty((R, 3))
    with np.errstate(divide="ignore", invalid="ignore"):   # a zero component: inv inf, its tmax inf
        inv = np.where(dirs != 0, 1.0 / dirs, np.inf)
        for a in range(3):
            nxt = lines[a][cell[:, a] + (step[:, a] > 0)]
            tmax[:, a] = np.where(dirs[:, a] != 0, (nxt - pos[:, a]) * inv[:, a], np.inf)
    act = np.arange(R)
    cell = cell.copy()
    while len(act):
        tm = tmax[act]
        a = np.argmin(tm, axis=1)
        c = cell[act]
        s = step[act, a]
        c[np.arange(len(act)), a] += s
        out = (c < 0).any(axis=1) | (c >= shape).any(axis=1)
        inside = ~out
        solid = np.zeros(len(act), dtype=bool)
        solid[inside] = ~air[c[inside, 0], c[inside, 1], c[inside, 2]]
        if solid.any():
            ia, aa, cc, ss = act[solid], a[solid], c[solid], s[solid]
            for ax in range(3):
                m = aa == ax
                if not m.any():
                    continue
                ind = [cc[m, 0], cc[m, 1], cc[m, 2]]
                ind[ax] = cc[m, ax] + (ss[m] < 0)  # node plane of the face crossed
                hit[ia[m]] = face_patch[ax][tuple(ind)]
        go = inside & ~solid
        cell[act] = c
        act, a, c = act[go], a[go], c[go]
        if len(act):
            for ax in range(3):
                m = a == ax
                if m.any():
                    i = act[m]
                    nxt = lines[ax][c[m, ax] + (step[i, ax] > 0)]
                    tmax[i, ax] = (nxt - pos[i, ax]) * inv[i, ax]
    return hit


def _march_kernel(xs, ys, zs, air, fpx, fpy, fpz, pos, dirs, cell, hit):
    """The DDA of :func:`march_numpy`, one ray at a time: ``hit`` (R,) filled with the patch hit (-1: none);
    returns the cells crossed by all rays together."""
    nx, ny, nz = air.shape
    shape = (nx, ny, nz)
    crossed = 0
    c = np.empty(3, np.int64)
    st = np.empty(3, np.int64)
    inv = np.empty(3)
    tmax = np.empty(3)
    for r in range(pos.shape[0]):
        hit[r] = -1
        for a in range(3):
            c[a] = cell[r, a]
            d = dirs[r, a]
            st[a] = 1 if d > 0 else -1
            if d != 0:
                inv[a] = 1.0 / d
                line = xs if a == 0 else (ys if a == 1 else zs)
                tmax[a] = (line[c[a] + (1 if st[a] > 0 else 0)] - pos[r, a]) * inv[a]
            else:
                inv[a] = np.inf
                tmax[a] = np.inf
        while True:
            a = 0   # the first smallest, as numpy's argmin
            if tmax[1] < tmax[a]:
                a = 1
            if tmax[2] < tmax[a]:
                a = 2
            c[a] += st[a]
            crossed += 1
            if c[0] < 0 or c[1] < 0 or c[2] < 0 or c[0] >= shape[0] or c[1] >= shape[1] or c[2] >= shape[2]:
                break   # left the grid: no hit
            if not air[c[0], c[1], c[2]]:
                back = 1 if st[a] < 0 else 0   # node plane of the face crossed
                if a == 0:
                    hit[r] = fpx[c[0] + back, c[1], c[2]]
                elif a == 1:
                    hit[r] = fpy[c[0], c[1] + back, c[2]]
                else:
                    hit[r] = fpz[c[0], c[1], c[2] + back]
                break
            line = xs if a == 0 else (ys if a == 1 else zs)
            tmax[a] = (line[c[a] + (1 if st[a] > 0 else 0)] - pos[r, a]) * inv[a]
    return crossed


_march_kernel = njit(cache=True)(_march_kernel)


def march(grid, air: np.ndarray, face_patch: tuple, pos, dirs, cell, *, counts: bool = False):
    """Patch hit by each ray (-1: none): :func:`march_numpy`'s march compiled, one loop per ray (the same hits).

    Arguments as :func:`march_numpy`'s. ``counts`` True: returns (hits, cells crossed by all rays).
    """
    pos, dirs, cell = _check(pos, dirs, cell)
    air = np.ascontiguousarray(air, dtype=np.bool_)
    if air.shape != tuple(grid.shape):
        raise ValueError(f"ray march: air mask shape {air.shape} differs from the grid's {tuple(grid.shape)}")
    fp = [np.ascontiguousarray(f, dtype=np.int64) for f in face_patch]
    hit = np.empty(len(pos), dtype=np.int64)
    crossed = _march_kernel(np.ascontiguousarray(grid.xs, float), np.ascontiguousarray(grid.ys, float),
                            np.ascontiguousarray(grid.zs, float), air, fp[0], fp[1], fp[2], pos, dirs, cell, hit)
    return (hit, int(crossed)) if counts else hit
