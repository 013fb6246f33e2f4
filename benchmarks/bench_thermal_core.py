"""Benchmark of the thermal core: assembly and steady solve at ~100k and ~300k unknowns.

Usage::

    python benchmarks/bench_thermal_core.py [--sizes 100000 300000] [--layout]

Synthetic grid: a 70 x 48 x 25 mm aluminium box (2 mm walls) around air, with
three orthotropic FR4 boards (k 30/0.4) on 0.1 mm grease lines and a powered
chip, graded grid; convection + radiation outside (nonlinear Newton) and a
mounting contact on the bottom. ``--layout`` also runs the reference layout's
mesh (``imutherm.geometry``), if available. Prints unknowns, assembly [s],
solve [s], Newton/CG iterations and the peak resident memory [MB].
"""

from __future__ import annotations

import argparse
import resource
import time

import numpy as np

from imutherm.geometry.grid import TensorGrid
from imutherm.thermal import (Contact, NaturalConvection, Radiation, ThermalProblem, assemble, solve_steady,
                              solve_transient)


def _axis(length, n, walls):
    pts = set(np.round(np.linspace(0, length, n + 1), 12))
    for w in walls:
        pts.add(round(w, 12))
    return np.array(sorted(pts))


def synthetic(n_target: int):
    Lx, Ly, Lz = 0.070, 0.048, 0.025
    s = (n_target / (70 * 48 * 25)) ** (1 / 3)
    nx, ny, nz = (max(4, int(round(d * s))) for d in (70, 48, 25))
    walls = [0.002, 0.068]
    xs = _axis(Lx, nx, walls + [0.010, 0.0101, 0.0117])
    ys = _axis(Ly, ny, [0.002, 0.046])
    zs = _axis(Lz, nz, [0.002, 0.023, 0.008, 0.0081, 0.0097, 0.0127])
    X, Y, Z = np.meshgrid(0.5 * (xs[1:] + xs[:-1]), 0.5 * (ys[1:] + ys[:-1]), 0.5 * (zs[1:] + zs[:-1]),
                          indexing="ij")
    part = np.full(X.shape, 1)                         # air
    shell = (X < 0.002) | (X > 0.068) | (Y < 0.002) | (Y > 0.046) | (Z < 0.002) | (Z > 0.023)
    part[shell] = 0
    inner = ~shell
    part[inner & (Z > 0.008) & (Z < 0.0081)] = 2      # grease under the main board
    part[inner & (Z > 0.0081) & (Z < 0.0097)] = 3     # main board (normal z)
    part[inner & (X > 0.010) & (X < 0.0101) & (Z > 0.0097)] = 2
    part[inner & (X > 0.0101) & (X < 0.0117) & (Z > 0.0097)] = 4   # side board (normal x)
    chip = inner & (X > 0.03) & (X < 0.04) & (Y > 0.02) & (Y < 0.03) & (Z > 0.0097) & (Z < 0.0127)
    part[chip] = 5
    names = ("housing", "air", "grease", "board_z", "board_x", "chip")
    k = np.array([[167, 167, 167], [0.03, 0.03, 0.03], [1.0, 1.0, 1.0], [30, 30, 0.4], [0.4, 30, 30],
                  [20, 20, 20]], dtype=float)
    rc = np.array([2.4e6, 1.2e3, 2e6, 2e6, 2e6, 1.7e6])
    g = TensorGrid(xs, ys, zs, part, names, {})
    vol = g.cell_volumes()
    q = np.where(part == 5, 1.0 / vol[part == 5].sum(), 0.0)
    return g, k[part.ravel()], rc[part.ravel()], q.ravel()


def run(g, k, rc, q, label):
    bnd = {f: (NaturalConvection("vertical", 0.048), Radiation(0.85)) for f in ("xmin", "xmax", "ymin", "ymax")}
    bnd["zmax"] = (NaturalConvection("up", 0.03), Radiation(0.85))
    bnd["zmin"] = (Contact(500.0, 25.0),)
    pr = ThermalProblem(g, k, rc, q, 25.0, bnd)
    t = time.perf_counter()
    asm = assemble(pr)
    ta = time.perf_counter() - t
    r = solve_steady(pr, assembly=asm)
    rt = solve_transient(pr, 600.0, 60.0, assembly=asm)
    rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{label:<22} unknowns {r.unknowns:>8d}  assembly {ta:6.2f} s  steady {r.solve_s:6.2f} s "
          f"({r.newton_iterations} Newton, {r.linear_iterations} CG, {r.solver})  "
          f"transient 10 steps {rt.solve_s:6.2f} s "
          f"({rt.linear_iterations} CG)  max rise {r.T_C.max() - 25:6.2f} K  ebal {r.energy_balance_rel_error:.1e}  "
          f"peak RSS {rss:6.0f} MB")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", type=int, nargs="+", default=[100_000, 300_000])
    ap.add_argument("--layout", action="store_true", help="also mesh the reference layout")
    args = ap.parse_args()
    for n in args.sizes:
        run(*synthetic(n), label=f"synthetic ~{n // 1000}k")
    if args.layout:
        from imutherm.geometry.build import build_geometry
        from imutherm.geometry.mesh import build_mesh

        geo = build_geometry()
        for size in (2.0, 1.0):
            g = build_mesh(geo, size)
            k = np.zeros((g.n_cells, 3))
            rc = np.zeros(g.n_cells)
            q = np.zeros(g.n_cells)
            cp = np.asarray(g.cell_part).ravel()
            vol = g.cell_volumes().ravel()
            for i, name in enumerate(g.part_names):
                part = next(p for p in geo.parts if p.name == name)
                m = geo.material(name)
                kk = np.full(3, m.k_in_plane)
                if part.normal is not None:
                    kk["xyz".index(part.normal)] = m.k_through
                sel = cp == i
                k[sel] = kk
                rc[sel] = m.rho_c
                if part.power_W and sel.any():
                    q[sel] = part.power_W / vol[sel].sum()
            run(g, k, rc, q, label=f"layout {size} mm")


if __name__ == "__main__":
    main()
