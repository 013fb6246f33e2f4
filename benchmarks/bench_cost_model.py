"""The cost model of the s2s cavity law against its measured cost (the figures behind ``imutherm.budget``).

For a few patch sizes on the reference unit (grease, a coarse mesh), each in a fresh subprocess: the
patches are counted (:func:`imutherm.thermal.cavity_radiation.find_patches`, cheap), then the exchange is
built (:func:`cavity_exchange`: ray-cast view factors and the dense radiosity solve) and its CPU time and
the rise of the peak resident memory (``ru_maxrss``) over the mesh and the patches are read. Fits

    memory ~ S2S_BASE_BYTES + BYTES_PER_PATCH_PAIR x n^2,
    CPU ~ SECONDS_PER_RAY x n x rays + SECONDS_PER_PATCH_PAIR x n^2 + SECONDS_PER_PATCH_CUBE x n^3

and prints predicted (``imutherm.budget.s2s_cost``, the constants as they are) beside measured, so a
drift of today's speed shows. The machine may be shared: the CPU time (user + sys) is the figure.

    python benchmarks/bench_cost_model.py [--mesh-size 3] [--patch-mm 8 5 3 2 1.5] [--rays 400]
"""

import argparse
import json
import subprocess
import sys

import numpy as np

CHILD = r"""
import json, resource, sys, time
import numpy as np
from imutherm.geometry.build import build_geometry
from imutherm.geometry.layout import load_layout
from imutherm.geometry.mesh import build_mesh
from imutherm.thermal.cavity_radiation import cavity_exchange, find_patches
mesh, patch, rays = float(sys.argv[1]), float(sys.argv[2]), int(sys.argv[3])
geo = build_geometry(load_layout(None), "grease")
grid = build_mesh(geo, mesh, 1)
air = grid.cell_part == grid.part_names.index("fill")
n = find_patches(grid, air, patch).n
rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
t0 = time.process_time()
cavity_exchange(grid, air, [0.9] * len(grid.part_names), patch_mm=patch, rays=rays)
cpu = time.process_time() - t0
print(json.dumps({"n": n, "cpu_s": cpu, "mem": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024 - rss0}))
"""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--mesh-size", type=float, default=3.0)
    ap.add_argument("--patch-mm", type=float, nargs="+", default=[8.0, 5.0, 3.0, 2.0, 1.5])
    ap.add_argument("--rays", type=int, default=400)
    args = ap.parse_args()
    from imutherm.budget import s2s_cost

    rows = []
    for p in args.patch_mm:
        out = subprocess.run([sys.executable, "-c", CHILD, str(args.mesh_size), str(p), str(args.rays)],
                             capture_output=True, text=True, check=True, env={"OMP_NUM_THREADS": "1",
                                                                              "OPENBLAS_NUM_THREADS": "1",
                                                                              "PATH": "/usr/bin:/bin"})
        r = json.loads(out.stdout.strip().splitlines()[-1])
        r["patch_mm"] = p
        rows.append(r)
        mem, sec = s2s_cost(r["n"], args.rays)
        print(f"patch {p:5.2f} mm: {r['n']:6d} patches; CPU {r['cpu_s']:7.2f} s (predicted {sec:7.2f} s); "
              f"memory +{r['mem'] / 2**20:7.1f} MiB (predicted {mem / 2**20:7.1f} MiB)", flush=True)
    n = np.array([r["n"] for r in rows], float)
    cpu = np.array([r["cpu_s"] for r in rows])
    mem = np.array([r["mem"] for r in rows], float)
    from scipy.optimize import nnls

    a = nnls(np.column_stack([n * args.rays, n**2, n**3]) / cpu[:, None], np.ones(len(n)))[0]  # relative error
    b0, b = np.linalg.lstsq(np.column_stack([np.ones(len(n)), n**2]), mem, rcond=None)[0]
    print(f"fit: SECONDS_PER_RAY {a[0]:.3g}, SECONDS_PER_PATCH_PAIR {a[1]:.3g}, SECONDS_PER_PATCH_CUBE {a[2]:.3g}; "
          f"BYTES_PER_PATCH_PAIR {b:.3g} + S2S_BASE_BYTES {b0 / 2**20:.3g} MiB")


if __name__ == "__main__":
    main()
