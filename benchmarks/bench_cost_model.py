"""The cost model of the s2s cavity law against its measured cost (the figures behind ``imutherm.budget``).

For a few patch sizes on the reference unit (grease, a coarse mesh), each in a fresh subprocess: the
patches are counted (:func:`imutherm.thermal.cavity_radiation.find_patches`, cheap), then the exchange is
built (:func:`cavity_exchange`: ray-cast view factors and the dense radiosity solve) and its CPU time and
the rise of the peak resident memory (``ru_maxrss``) over the mesh and the patches are read. Fits

    memory ~ S2S_BASE_BYTES + BYTES_PER_PATCH_PAIR x n^2,
    CPU ~ SECONDS_PER_RAY x n x rays + SECONDS_PER_PATCH_PAIR x n^2 + SECONDS_PER_PATCH_CUBE x n^3

and prints predicted (``imutherm.budget.s2s_cost``, the constants as they are) beside measured, so a
drift of today's speed shows. The machine may be shared: the CPU time (user + sys) is the figure.

``--transient``: instead, a full-FEM transient of given steps on the reference unit (grease, default mesh:
``--t-end 50 --dt 5``, 10 steps) in a fresh subprocess, its CPU time per step against
``imutherm.studies.cost.SECONDS_PER_STEP_UNKNOWN`` x unknowns (the estimate ``solve`` prints before a transient).

    python benchmarks/bench_cost_model.py [--mesh-size 3] [--patch-mm 8 5 3 2 1.5] [--rays 400]
    python benchmarks/bench_cost_model.py --transient [--steps 10]
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


TRANSIENT_CHILD = r"""
import json, sys
from threadpoolctl import threadpool_limits
threadpool_limits(1)
from imutherm.studies.thermal.thermal_study import run_scheme
steps = int(sys.argv[1])
res = run_scheme(None, "grease", transient=steps > 0, t_end=5.0 * max(steps, 1), dt=5.0 if steps else None)
print(json.dumps({"unknowns": res.steady.unknowns, "steps": res.transient.steps if steps else 0}))
"""


def _child_cpu(steps: int) -> tuple:
    """(CPU time [s] of a fresh process solving the grease scheme steady, then ``steps`` steps of 5 s; its JSON)."""
    import resource

    ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    run = subprocess.run([sys.executable, "-c", TRANSIENT_CHILD, str(steps)], capture_output=True, text=True,
                         check=True)
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (ru.ru_utime - ru0.ru_utime) + (ru.ru_stime - ru0.ru_stime), json.loads(run.stdout.strip().splitlines()[-1])


def transient(steps: int) -> None:
    """The per-step CPU time of a given-step transient against the cost model's (``--transient``): a steady-only
    process subtracted from one that also steps."""
    from imutherm.studies.cost import SECONDS_PER_STEP_UNKNOWN

    steady_cpu, _ = _child_cpu(0)
    total_cpu, r = _child_cpu(steps)
    per = (total_cpu - steady_cpu) / r["steps"]
    print(f"grease, {r['unknowns']:,} unknowns, {r['steps']} steps of 5 s: {per:.2f} s of CPU a step (the process "
          f"less a steady-only one: {total_cpu:.1f} - {steady_cpu:.1f} s); the cost model: "
          f"{SECONDS_PER_STEP_UNKNOWN * r['unknowns']:.2f} s ({per / r['unknowns']:.2e} s per step and unknown "
          f"measured, {SECONDS_PER_STEP_UNKNOWN:.2e} in imutherm.studies.cost)")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--transient", action="store_true", help="the transient's step cost instead of the s2s law's")
    ap.add_argument("--steps", type=int, default=10)
    ap.add_argument("--mesh-size", type=float, default=3.0)
    ap.add_argument("--patch-mm", type=float, nargs="+", default=[8.0, 5.0, 3.0, 2.0, 1.5])
    ap.add_argument("--rays", type=int, default=400)
    args = ap.parse_args()
    if args.transient:
        return transient(args.steps)
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
