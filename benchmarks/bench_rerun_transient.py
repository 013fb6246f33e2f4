"""Benchmark of the correlation's re-run of a corrected model: the checked reduced transient
(``studies.thermal.forward.checked_rise``, the default of ``imutherm correlate``) against the full adaptive TR-BDF2
at the library's tolerance (``full_rise``, ``correlate --full``), both against a reference: the full
TR-BDF2 ten times tighter (1e-3 K per step at the sites, CG at 1e-8).

The corrected models are those of the correlation benchmark (``bench_correlation_speed.py``): air, grease
and potted at 70 degC with a poor board joint (h = 300 W/m^2 K), the s2s cavity law, the default mesh, six
sites, 40 readings over 1500 s and the steady reading. Reports per scheme the wall and CPU seconds of each
run (one process, the steady solve included), the reduced run's basis, full solves and estimated error, and
the largest site error of each run against the reference (targets: the checked run within the study's
0.05 K, and no less accurate than the full run at the library's tolerance).

    python benchmarks/bench_rerun_transient.py                    # default mesh, three schemes (~10 min)
    python benchmarks/bench_rerun_transient.py --schemes air --mesh-size 6 --min-cells 1
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np

#: the correlation benchmark's reading times: 40 over 1500 s and the steady reading [s]
TIMES = np.append(np.linspace(0.0, 1500.0, 40), np.inf)
SITES = ("tp1", "tp2", "tp3", "gyro_x", "gyro_y", "gyro_z")


def _tight(variant, grid, probes) -> np.ndarray:
    """Site rises [K] of the full TR-BDF2 at 1e-3 K per step, CG at 1e-8."""
    from imutherm.thermal.assembly import assemble
    from imutherm.thermal.steady import solve_steady
    from imutherm.thermal.transient import solve_transient
    from imutherm.unit.effects import effect_problem

    pb = effect_problem(variant, grid)
    asm = assemble(pb)
    st = solve_steady(pb, probes=probes, assembly=asm)
    tr = solve_transient(pb, float(TIMES[-2]), scheme="trbdf2", probes=probes, assembly=asm,
                         error_control="probes", tol_K=1e-3, rtol=1e-8)
    out = np.empty((len(TIMES), len(probes)))
    fin = np.isfinite(TIMES)
    out[fin] = np.column_stack([np.interp(TIMES[fin], tr.times, tr.probe_C[:, j] - pb.ambient_C)
                                for j in range(len(probes))])
    out[~fin] = np.asarray(st.probe_C) - pb.ambient_C
    return out


def _timed(fn):
    w, c = time.perf_counter(), time.process_time()
    r = fn()
    return r, round(time.perf_counter() - w, 1), round(time.process_time() - c, 1)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--schemes", default="air,grease,potted")
    ap.add_argument("--mesh-size", type=float, default=None, help="largest cell [mm] (default: the library's)")
    ap.add_argument("--min-cells", type=int, default=None)
    args = ap.parse_args(argv)
    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.layout import load_layout
    from imutherm.geometry.mesh import DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS, build_mesh
    from imutherm.studies.thermal.forward import checked_rise, full_rise
    from imutherm.thermal.reduced_transient import CHECK_TOL_K
    from imutherm.unit import knobs
    from imutherm.unit.model import ModelOptions

    layout, ok = load_layout(None), True
    for scheme in args.schemes.split(","):
        geo = build_geometry(layout, scheme)
        variant = knobs.variant(geo, ModelOptions(cavity_law="s2s"), {"contact@board": 300.0})
        grid = build_mesh(variant.geometry, args.mesh_size or DEFAULT_MAX_CELL_MM, args.min_cells or DEFAULT_MIN_CELLS)
        probes = {s: geo.sites[s] for s in SITES}
        (checked, info), w_c, c_c = _timed(lambda: checked_rise(variant, grid, probes, TIMES))
        full, w_f, c_f = _timed(lambda: full_rise(variant, grid, probes, TIMES))
        ref, w_t, c_t = _timed(lambda: _tight(variant, grid, probes))
        e_c, e_f = float(np.abs(checked - ref).max()), float(np.abs(full - ref).max())
        if info["estimated_error_K"] is not None:
            info["estimated_error_K"] = round(info["estimated_error_K"], 4)
        row = {"scheme": scheme, "nodes": grid.n_nodes, **info,
               "checked_wall_s": w_c, "checked_cpu_s": c_c, "full_wall_s": w_f, "full_cpu_s": c_f,
               "tight_wall_s": w_t, "tight_cpu_s": c_t, "max_rise_K": round(float(ref.max()), 2),
               "checked_error_K": round(e_c, 4), "full_error_K": round(e_f, 4),
               "checked_vs_full_K": round(float(np.abs(checked - full).max()), 4)}
        row["pass"] = e_c <= CHECK_TOL_K and e_c <= max(e_f, 0.01)
        ok &= row["pass"]
        print(json.dumps(row), flush=True)
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
