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
    """The DDA of :func:`march_numpy`, one ray at a time in scalars: ``hit`` (R,) filled with the patch hit (-1:
    none); returns the cells crossed by all rays together."""
    nx, ny, nz = air.shape
    crossed = 0
    for r in range(pos.shape[0]):
        hit[r] = -1
        cx, cy, cz = cell[r, 0], cell[r, 1], cell[r, 2]
        dx, dy, dz = dirs[r, 0], dirs[r, 1], dirs[r, 2]
        px, py, pz = pos[r, 0], pos[r, 1], pos[r, 2]
        sx = 1 if dx > 0 else -1
        sy = 1 if dy > 0 else -1
        sz = 1 if dz > 0 else -1
        ox = 1 if dx > 0 else 0   # the next node line is the cell's upper one
        oy = 1 if dy > 0 else 0
        oz = 1 if dz > 0 else 0
        ix = 1.0 / dx if dx != 0 else np.inf
        iy = 1.0 / dy if dy != 0 else np.inf
        iz = 1.0 / dz if dz != 0 else np.inf
        tx = (xs[cx + ox] - px) * ix if dx != 0 else np.inf
        ty = (ys[cy + oy] - py) * iy if dy != 0 else np.inf
        tz = (zs[cz + oz] - pz) * iz if dz != 0 else np.inf
        while True:
            crossed += 1
            # the axis of the smallest tmax, the first on a tie (numpy's argmin)
            if ty < tx:
                a = 2 if tz < ty else 1
            elif tz < tx:
                a = 2
            else:
                a = 0
            if a == 0:
                cx += sx
                if cx < 0 or cx >= nx:
                    break   # left the grid: no hit
                if not air[cx, cy, cz]:
                    hit[r] = fpx[cx + 1 - ox, cy, cz]   # the node plane of the face crossed
                    break
                tx = (xs[cx + ox] - px) * ix
            elif a == 1:
                cy += sy
                if cy < 0 or cy >= ny:
                    break
                if not air[cx, cy, cz]:
                    hit[r] = fpy[cx, cy + 1 - oy, cz]
                    break
                ty = (ys[cy + oy] - py) * iy
            else:
                cz += sz
                if cz < 0 or cz >= nz:
                    break
                if not air[cx, cy, cz]:
                    hit[r] = fpz[cx, cy, cz + 1 - oz]
                    break
                tz = (zs[cz + oz] - pz) * iz
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


# ---------------------------------------------------------------- where the rays start
def place_rays_numpy(grid, patches, order, starts, cum, base, rays: int, u, w, local):
    """Origins (R, 3) [m], directions (R, 3) and start air cells (R, 3) of ``rays`` rays per patch, vectorised
    with numpy (the reference of :func:`place_rays`; the random numbers drawn by the caller,
    :func:`imutherm.thermal.cavity_radiation._emit`).

    patches : Patches; order : face cells in patch order; starts (n+1,) : each patch's first place in ``order``;
    cum (F,), base (F+1,) [m^2] : cumulative face-cell areas in that order (``base`` with a leading 0);
    u (R,) in [0, 1) : the stratified area coordinate of each ray in its patch; w (R, 2) in [0, 1) : its point
    on the face cell; local (R, 3) : its direction's two tangential components and its normal one.
    """
    lines = (grid.xs, grid.ys, grid.zs)
    n = patches.n
    src = np.repeat(np.arange(n), rays)
    lo, hi = base[starts[src]], base[starts[src + 1]]
    target = lo + u * (hi - lo)
    fc_sorted = np.clip(np.searchsorted(cum, target, side="right"), starts[src], starts[src + 1] - 1)
    fci = order[fc_sorted]
    ax = patches.fc_axis[fci]
    sign = patches.sign[src]
    pos = np.empty((n * rays, 3))
    cell = np.empty((n * rays, 3), dtype=np.int64)
    t1, t2, nn = local[:, 0], local[:, 1], local[:, 2]
    dirs = np.zeros((n * rays, 3))
    for a in range(3):
        m = ax == a
        u_ax, v_ax = [d for d in range(3) if d != a]
        pl, iu, iv = patches.fc_plane[fci[m]], patches.fc_u[fci[m]], patches.fc_v[fci[m]]
        pos[m, a] = lines[a][pl]
        pos[m, u_ax] = lines[u_ax][iu] + w[m, 0] * (lines[u_ax][iu + 1] - lines[u_ax][iu])
        pos[m, v_ax] = lines[v_ax][iv] + w[m, 1] * (lines[v_ax][iv + 1] - lines[v_ax][iv])
        cell[m, a] = np.where(sign[m] > 0, pl, pl - 1)
        cell[m, u_ax], cell[m, v_ax] = iu, iv
        dirs[m, a] = sign[m] * nn[m]
        dirs[m, u_ax], dirs[m, v_ax] = t1[m], t2[m]
    return pos, dirs, cell


def _line(xs, ys, zs, a):
    if a == 0:
        return xs
    return ys if a == 1 else zs


def _place_kernel(xs, ys, zs, fc_axis, fc_plane, fc_u, fc_v, psign, order, starts, cum, base, rays, u, w, local,
                  pos, dirs, cell):
    """:func:`place_rays_numpy` one ray at a time (the same operations on each ray's numbers)."""
    for r in range(u.shape[0]):
        p = r // rays
        s0, s1 = starts[p], starts[p + 1]
        lo, hi = base[s0], base[s1]
        target = lo + u[r] * (hi - lo)
        k = np.searchsorted(cum, target, side="right")   # as numpy's: the first place with cum > target
        f = order[min(max(k, s0), s1 - 1)]
        a = fc_axis[f]
        ua = 1 if a == 0 else 0   # the two other axes in increasing order
        va = 1 if a == 2 else 2
        pl, iu, iv = fc_plane[f], fc_u[f], fc_v[f]
        la, lu, lv = _line(xs, ys, zs, a), _line(xs, ys, zs, ua), _line(xs, ys, zs, va)
        sg = psign[p]
        pos[r, a] = la[pl]
        pos[r, ua] = lu[iu] + w[r, 0] * (lu[iu + 1] - lu[iu])
        pos[r, va] = lv[iv] + w[r, 1] * (lv[iv + 1] - lv[iv])
        cell[r, a] = pl if sg > 0 else pl - 1
        cell[r, ua], cell[r, va] = iu, iv
        dirs[r, a] = sg * local[r, 2]
        dirs[r, ua], dirs[r, va] = local[r, 0], local[r, 1]


_line = njit(inline="always", cache=True)(_line)
_place_kernel = njit(cache=True)(_place_kernel)


def place_rays(grid, patches, order, starts, cum, base, rays: int, u, w, local):
    """:func:`place_rays_numpy` compiled, one loop over the rays (the same origins, directions and cells)."""
    R = patches.n * rays
    u, w, local = (np.ascontiguousarray(x, float) for x in (u, w, local))
    if u.shape != (R,) or w.shape != (R, 2) or local.shape != (R, 3):
        raise ValueError(f"ray placement: u, w, local must be ({R},), ({R}, 2), ({R}, 3) for {patches.n} patches "
                         f"x {rays} rays, got {u.shape}, {w.shape}, {local.shape}")
    pos, dirs = np.empty((R, 3)), np.zeros((R, 3))
    cell = np.empty((R, 3), dtype=np.int64)
    i64 = (lambda x: np.ascontiguousarray(x, np.int64))
    _place_kernel(np.ascontiguousarray(grid.xs, float), np.ascontiguousarray(grid.ys, float),
                  np.ascontiguousarray(grid.zs, float), i64(patches.fc_axis), i64(patches.fc_plane),
                  i64(patches.fc_u), i64(patches.fc_v), i64(patches.sign), i64(order), i64(starts),
                  np.ascontiguousarray(cum, float), np.ascontiguousarray(base, float), int(rays), u, w, local,
                  pos, dirs, cell)
    return pos, dirs, cell
