"""Benchmark of the reference unit: each scheme at the default mesh, and the same mesh in CalculiX.

Reports, per scheme: unknowns, assembly [s], steady solve [s], a 1200 s power-on
transient (backward Euler, steps growing from 2 s to 60 s by 1.2, the former default of `imutherm solve`; the adaptive TR-BDF2 default is measured by bench_transient_accuracy.py) [s], the peak resident memory of the process
[MB], and the max rise; then CalculiX 2.20 on the same mesh with the linear
version of the boundary conditions (fixed h instead of natural convection and
radiation, the cavity's radiation as its effective conductivity: a deck has no s2s exchange), its wall time and
the largest nodal difference, and the whole-process CPU time (user + sys) of each on that deck: the ccx process
against a fresh ``python`` that imports imutherm, meshes the layout, builds the problem and solves it. Each scheme
runs in its own process so that the memory figure is its own.

    python benchmarks/bench_reference.py                 # all schemes + CalculiX
    python benchmarks/bench_reference.py --no-ccx        # imutherm only
    python benchmarks/bench_reference.py --convergence   # also the mesh-convergence check
    python benchmarks/bench_reference.py --convergence --write   # and record docs/benchmarks/tables/reference.txt
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time


#: the deck both codes solve: the unit's model with linear laws (fixed exterior h, no radiation; the cavity's
#: radiation as the effective conductivity, as a CalculiX deck can carry it: no s2s exchange)
def _linear():
    from imutherm.unit.model import ModelOptions

    return ModelOptions(exterior="fixed", h_fixed_W_m2K=10.0, radiation=False, cavity_law="effective")


#: a user's process as it is: no thread limit of its own (one set here, before numpy and scipy load their OpenBLAS,
#: limited nothing: their 2 default threads spun through CG's dots, 5.1-5.6 CPU-s of this process; the package's
#: solves now run on one BLAS thread themselves, ``imutherm.thermal.linear.one_blas_thread``: 3.3-4.1 CPU-s)
WHOLE_PROCESS = r"""
import sys
from imutherm.geometry.build import build_geometry
from imutherm.geometry.mesh import build_mesh
from imutherm.thermal.steady import solve_steady
from imutherm.unit.model import ModelOptions, build_problem
g = build_geometry(None, sys.argv[1])
grid = build_mesh(g, float(sys.argv[2]), int(sys.argv[3]))
solve_steady(build_problem(g, grid, ModelOptions(exterior="fixed", h_fixed_W_m2K=10.0, radiation=False,
                                                 cavity_law="effective")), tol=1e-12)
"""


def one_scheme(scheme: str, mesh_mm: float, min_cells: int, transient: bool, ccx: bool) -> dict:
    import numpy as np

    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.mesh import build_mesh
    from imutherm.thermal.assembly import assemble
    from imutherm.thermal.metrics import thermal_metrics
    from imutherm.unit.model import ModelOptions, build_problem
    from imutherm.thermal.solve import solve_steady, solve_transient, time_steps

    g = build_geometry(None, scheme)
    t0 = time.perf_counter()
    grid = build_mesh(g, mesh_mm, min_cells)
    problem = build_problem(g, grid)
    t_model = time.perf_counter() - t0
    t0 = time.perf_counter()
    asm = assemble(problem)
    t_asm = time.perf_counter() - t0
    t0 = time.perf_counter()
    st = solve_steady(problem, probes=g.sites, assembly=asm)
    t_steady = time.perf_counter() - t0
    m = thermal_metrics(st)
    out = {"scheme": scheme, "mesh_mm": mesh_mm, "min_cells": min_cells, "unknowns": st.unknowns,
           "mesh_and_model_s": t_model, "assembly_s": t_asm, "steady_s": t_steady,
           "newton_iterations": st.newton_iterations,
           "max_rise_K": m.max_rise_K, "hottest_part": m.max_part,
           "steady_energy_balance": st.energy_balance_rel_error}
    if transient:
        t0 = time.perf_counter()
        tr = solve_transient(problem, 1200.0, time_steps(1200.0, 2.0, 60.0, 1.2), probes=g.sites, assembly=asm)
        out.update({"transient_1200s_s": time.perf_counter() - t0, "transient_steps": tr.steps,
                    "transient_energy_balance": tr.energy_balance_rel_error})
    out["peak_rss_MB"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    if ccx:
        from imutherm.thermal.calculix import run_ccx

        LINEAR = _linear()
        lin = build_problem(g, grid, LINEAR)
        ours = solve_steady(lin, tol=1e-12)
        info = {}
        T_ccx = run_ccx(lin, timeout=3600, threads=os.cpu_count() or 1, info=info)
        # the whole process of ours on the same deck, in a fresh interpreter: imports, layout, mesh, problem,
        # assembly, solve (CPU time, user + sys, all threads), against the ccx process's CPU time
        ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        subprocess.run([sys.executable, "-c", WHOLE_PROCESS, scheme, str(mesh_mm), str(min_cells)], check=True)
        ru = resource.getrusage(resource.RUSAGE_CHILDREN)
        ours_cpu = (ru.ru_utime - ru0.ru_utime) + (ru.ru_stime - ru0.ru_stime)
        out.update({"ccx_s": info["ccx_s"], "ccx_cpu_s": info["ccx_cpu_s"], "ccx_peak_MB": info["ccx_peak_MB"],
                    "linear_steady_s": ours.solve_s + ours.assembly_s, "ours_process_cpu_s": ours_cpu,
                    "ccx_max_abs_diff_K": float(np.max(np.abs(T_ccx - ours.T_C)))})
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scheme", help=argparse.SUPPRESS)  # worker mode
    ap.add_argument("--schemes", default="air,grease,potted")
    ap.add_argument("--mesh-size", type=float, default=2.0)
    ap.add_argument("--min-cells", type=int, default=2)
    ap.add_argument("--no-transient", action="store_true")
    ap.add_argument("--no-ccx", action="store_true")
    ap.add_argument("--convergence", action="store_true",
                    help="also solve each scheme with half the cell size and twice the cells across thin parts")
    args = ap.parse_args(argv)
    if args.scheme:  # worker
        print(json.dumps(one_scheme(args.scheme, args.mesh_size, args.min_cells, not args.no_transient,
                                    not args.no_ccx)))
        return 0
    rows = []
    for s in args.schemes.split(","):
        cmd = [sys.executable, __file__, "--scheme", s, "--mesh-size", str(args.mesh_size),
               "--min-cells", str(args.min_cells)] + (["--no-transient"] if args.no_transient else []) \
              + (["--no-ccx"] if args.no_ccx else [])
        rows.append(json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout))
        r = rows[-1]
        print(f"{s:<7} {r['unknowns']:>7} unknowns  assembly {r['assembly_s']:5.2f} s  steady {r['steady_s']:5.2f} s"
              + (f"  transient 1200 s {r['transient_1200s_s']:6.1f} s" if "transient_1200s_s" in r else "")
              + f"  peak {r['peak_rss_MB']:6.0f} MB  max rise {r['max_rise_K']:.2f} K ({r['hottest_part']})"
              + (f"  | CalculiX {r['ccx_s']:6.1f} s ({r['ccx_peak_MB']:.0f} MB) vs ours {r['linear_steady_s']:.2f} s "
                 f"({r['ccx_s'] / r['linear_steady_s']:.0f}x); whole-process CPU: CalculiX {r['ccx_cpu_s']:.1f} s, "
                 f"ours {r['ours_process_cpu_s']:.1f} s ({r['ccx_cpu_s'] / r['ours_process_cpu_s']:.1f}x); max |dT| "
                 f"{r['ccx_max_abs_diff_K']:.1e} K" if "ccx_s" in r else ""), flush=True)
        if args.convergence:
            cmd = [sys.executable, __file__, "--scheme", s, "--mesh-size", str(args.mesh_size / 2),
                   "--min-cells", str(2 * args.min_cells), "--no-transient", "--no-ccx"]
            f = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
            r["fine"] = f
            print(f"        fine mesh {f['unknowns']} unknowns: max rise {f['max_rise_K']:.3f} K vs "
                  f"{r['max_rise_K']:.3f} K ({100 * (r['max_rise_K'] / f['max_rise_K'] - 1):+.2f} %), "
                  f"steady {f['steady_s']:.1f} s, peak {f['peak_rss_MB']:.0f} MB", flush=True)
    print(json.dumps(rows, indent=1), file=sys.stderr)
    failed = check_targets(rows)
    return 1 if failed else 0


#: the thermal solver's targets on a 2-core machine
TARGETS = {"steady_s": 5.0, "transient_1200s_s": 60.0, "peak_rss_MB": 2048.0, "ccx_speedup": 10.0,
           "ccx_process_cpu_speedup": 20.0, "convergence_pct": 2.0}


def check_targets(rows: list) -> int:
    """Print each target with the measured value and PASS/FAIL; return the number of failures."""
    checks = []
    for r in rows:
        s = r["scheme"]
        checks.append((f"{s}: steady solve <= {TARGETS['steady_s']:g} s", r["steady_s"], r["steady_s"] <= TARGETS["steady_s"]))
        if "transient_1200s_s" in r:
            v = r["transient_1200s_s"]
            checks.append((f"{s}: 1200 s transient <= {TARGETS['transient_1200s_s']:g} s", v,
                           v <= TARGETS["transient_1200s_s"]))
        checks.append((f"{s}: peak memory <= {TARGETS['peak_rss_MB']:g} MB", r["peak_rss_MB"],
                       r["peak_rss_MB"] <= TARGETS["peak_rss_MB"]))
        if "ccx_s" in r:
            v = r["ccx_s"] / r["linear_steady_s"]
            checks.append((f"{s}: >= {TARGETS['ccx_speedup']:g}x faster than CalculiX", v, v >= TARGETS["ccx_speedup"]))
            v = r["ccx_cpu_s"] / r["ours_process_cpu_s"]
            checks.append((f"{s}: >= {TARGETS['ccx_process_cpu_speedup']:g}x less whole-process CPU than CalculiX", v,
                           v >= TARGETS["ccx_process_cpu_speedup"]))
        if "fine" in r:
            v = abs(100 * (r["max_rise_K"] / r["fine"]["max_rise_K"] - 1))
            checks.append((f"{s}: half-size mesh changes max rise < {TARGETS['convergence_pct']:g} %", v,
                           v < TARGETS["convergence_pct"]))
    print("\ntargets:")
    for label, value, ok in checks:
        print(f"  {'PASS' if ok else 'FAIL'}  {label:<48} measured {value:.3g}")
    return sum(not ok for _, _, ok in checks)


if __name__ == "__main__":
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "reference", "the reference unit against CalculiX"))
