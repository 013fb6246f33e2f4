"""Benchmark of the study's checked reduced transient against the full adaptive FEM (targets: every site
curve within 0.05 K, every t95 within 1 %).

Per scheme and cavity law: ``run_scheme`` with ``transient_model='reduced'`` and with ``'full'`` (power-on
from the ambient until settled, as ``imutherm compare`` runs it, but the full run's step control at ``--full-tol-K``,
default 0.001 K: at the study's 0.01 K the full run's own t95 is up to 1.2 % off one at 0.001 K on the potted scheme,
default mesh, 2026-12-07, where the reduced run's is within 0.4 %), and reports each one's wall and CPU time,
the reduced run's basis, full solves and estimated error, the largest |reduced - full| of every site curve
(at the full run's step times) and every site's t95 difference, against the targets (0.05 K, 1 %).

    python benchmarks/bench_reduced_transient.py                          # default mesh, 3 schemes, both laws
    python benchmarks/bench_reduced_transient.py --mesh-size 6 --min-cells 1 --schemes air --laws effective
"""

from __future__ import annotations

import argparse
import json
import sys
import time

import numpy as np


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--schemes", default="air,grease,potted")
    ap.add_argument("--laws", default="effective,s2s")
    ap.add_argument("--mesh-size", type=float, default=None)
    ap.add_argument("--min-cells", type=int, default=None)
    ap.add_argument("--full-tol-K", type=float, default=0.001,
                    help="the full run's step control at the sites [K] (the study's default: 0.01)")
    args = ap.parse_args(argv)
    from imutherm.geometry.mesh import DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS
    from imutherm.studies.thermal.thermal_study import run_scheme
    from imutherm.unit.model import ModelOptions

    mesh = dict(mesh_size_mm=args.mesh_size or DEFAULT_MAX_CELL_MM, min_cells=args.min_cells or DEFAULT_MIN_CELLS)
    rows, ok = [], True
    for law in args.laws.split(","):
        for scheme in args.schemes.split(","):
            runs = {}
            for model in ("reduced", "full"):
                w, c = time.perf_counter(), time.process_time()
                tol = dict(tol_K=args.full_tol_K) if model == "full" else {}
                r = run_scheme(None, scheme, options=ModelOptions(cavity_law=law), transient=True, t_end=2400.0,
                               until_settled=True, transient_model=model, **tol, **mesh)
                runs[model] = (r, time.perf_counter() - w, time.process_time() - c)
            (red, w_r, c_r), (full, w_f, c_f) = runs["reduced"], runs["full"]
            rt, ft = red.transient, full.transient
            ra = np.column_stack([np.interp(ft.times, rt.times, rt.probe_C[:, j]) for j in range(len(rt.probe_names))])
            err = np.abs(ra - ft.probe_C).max(axis=0)
            d95 = {n: (red.metrics.t95_s[n] - full.metrics.t95_s[n]) / full.metrics.t95_s[n] for n in rt.probe_names}
            chk = red.transient_check
            row = {"law": law, "scheme": scheme, "nodes": red.grid.n_nodes, "accepted": chk.accepted,
                   "basis": chk.basis_size, "rounds": chk.rounds, "full_solves": chk.full_solves,
                   "full_run_linear_solves": ft.linear_solves, "full_tol_K": args.full_tol_K,
                   "estimated_error_K": round(chk.max_site_error_K, 4),
                   "max_curve_error_K": round(float(err.max()), 4),
                   "max_t95_error_pct": round(100 * max(abs(v) for v in d95.values()), 3),
                   "reduced_wall_s": round(w_r, 1), "reduced_cpu_s": round(c_r, 1),
                   "full_wall_s": round(w_f, 1), "full_cpu_s": round(c_f, 1),
                   "steady_solve_s": round(red.steady.solve_s, 1)}
            row["pass"] = chk.accepted and row["max_curve_error_K"] <= 0.05 and row["max_t95_error_pct"] <= 1.0
            ok &= row["pass"]
            rows.append(row)
            print(json.dumps(row), flush=True)
    print("targets (every site curve within 0.05 K, every t95 within 1 % of the full adaptive FEM): "
          + ("PASS" if ok else "FAIL"))
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
