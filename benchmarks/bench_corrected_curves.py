"""The study's mesh-corrected site curves against the 2x mesh's own power-on transient.

``imutherm compare`` corrects each site's power-on curve for the discretisation error by scaling its rise with one
factor, the steady answer over the default mesh's steady value
(``imutherm.studies.thermal.thermal_study.mesh_corrected``). That assumes the error of a curve is proportional to its rise
at every time. Here the assumption meets a transient of another discretisation: each scheme's reduced power-on
transient (checked against the full model) is solved on the default mesh and on the same mesh with every interval
split in 2 (1.5 million nodes, its own AMG hierarchies, basis and check), and per sensor die and test point the
script prints the largest difference over the whole transient between the 2x curve and

- the default mesh's curve as it is, and
- the default mesh's curve scaled to the 2x mesh's steady rise (the study's correction, with the 2x value as the
  target, so that only the curves' shapes are compared).

The two reduced transients carry their own errors (each checked to 0.05 K, estimated ~0.03 K), so differences
below ~0.05 K are within them; a difference at the same sites and times in both schemes, larger than that, is the
meshes' (the warm-up's own discretisation error, which one steady factor cannot follow). ~3 min and ~5 GB a
scheme on the 2-core machine; each scheme in its own process.

    python benchmarks/bench_corrected_curves.py                  # air, grease
    python benchmarks/bench_corrected_curves.py --schemes air
    python benchmarks/bench_corrected_curves.py --write          # and record tables/corrected_curves.txt
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time

from imutherm.thermal.reduced_transient import CHECK_TOL_K

#: the largest shape difference [K] the study's correction may leave at a sensor die: the two reduced transients'
#: accepted check errors added (below that the two reduced models cannot tell the meshes apart)
SHAPE_TOL_K = 2 * CHECK_TOL_K


def one_scheme(scheme: str) -> dict:
    """Both meshes' reduced transients of ``scheme`` and their differences (JSON-able)."""
    from dataclasses import replace

    import numpy as np
    from threadpoolctl import threadpool_limits

    from imutherm.geometry.mesh import prolongation, refine_grid
    from imutherm.studies.thermal.thermal_study import run_scheme
    from imutherm.thermal.assembly import assemble
    from imutherm.thermal.reduced_transient import reduced_power_on
    from imutherm.thermal.steady import solve_steady
    from imutherm.unit.model import build_problem, cavity_exchange_law

    t0 = time.perf_counter()
    with threadpool_limits(1):
        res = run_scheme(None, scheme, transient=True, transient_model="reduced", until_settled=True, t_end=3000.0)
        st, grid = res.steady, res.grid
        fine = refine_grid(grid, 2)
        ex = (cavity_exchange_law(res.geometry, grid, res.options).refined(fine, 2) if st.problem.exchanges
              else None)
        pf = replace(build_problem(res.geometry, fine, res.options, exchange=ex), boundary=st.problem.boundary)
        asm = assemble(pf)
        probes = {n: res.geometry.sites[n] for n in st.probe_names}
        st2 = solve_steady(pf, probes=probes, assembly=asm, initial_C=prolongation(grid, fine) @ np.asarray(st.T_C))
        tr2, check2 = reduced_power_on(pf, asm, st2, probes, float(res.transient.times[-1]))
    if tr2 is None:
        raise SystemExit(f"{scheme}: the 2x mesh's reduced transient failed its check ({check2.reason})")
    tr1, amb = res.transient, st.problem.ambient_C
    t = np.asarray(tr1.times)
    rows = {}
    for i, name in enumerate(tr1.probe_names):
        c1 = np.asarray(tr1.probe_C)[:, i]
        c2 = np.interp(t, tr2.times, np.asarray(tr2.probe_C)[:, tr2.probe_names.index(name)])
        r1, r2 = float(st.probe_C[i]) - amb, float(st2.probe_C[i]) - amb
        scaled = amb + (c1 - amb) * (r2 / r1)
        k_raw, k_scaled = int(np.argmax(np.abs(c2 - c1))), int(np.argmax(np.abs(c2 - scaled)))
        rows[name] = {"rise_1x": r1, "rise_2x": r2, "raw": float((c2 - c1)[k_raw]), "raw_at_s": float(t[k_raw]),
                      "scaled": float((c2 - scaled)[k_scaled]), "scaled_at_s": float(t[k_scaled])}
    return {"scheme": scheme, "nodes": [grid.n_nodes, fine.n_nodes], "t_end_s": float(t[-1]),
            "check_K": [res.transient_check.max_site_error_K, check2.max_site_error_K], "sites": rows,
            "seconds": time.perf_counter() - t0, "peak_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def report(r: dict, dies) -> float:
    """Print one scheme's table; returns the largest scaled difference at a die [K]."""
    print(f"{r['scheme']}: nodes {r['nodes'][0]:,} / {r['nodes'][1]:,}; curves to {r['t_end_s']:.0f} s; the reduced "
          f"transients' estimated errors {r['check_K'][0]:.3f} / {r['check_K'][1]:.3f} K; {r['seconds']:.0f} s wall, "
          f"peak {r['peak_MB'] / 1024:.1f} GB")
    print(f"  {'site':<8} {'steady rise 1x -> 2x [K]':<25} {'2x - 1x, largest [K] (at)':>27} "
          f"{'2x - 1x scaled, largest [K] (at)':>34}")
    worst = 0.0
    for name, v in r["sites"].items():
        print(f"  {name:<8} {v['rise_1x']:8.3f} -> {v['rise_2x']:<13.3f} {v['raw']:+12.3f} ({v['raw_at_s']:6.0f} s)"
              f"{'':6} {v['scaled']:+12.3f} ({v['scaled_at_s']:6.0f} s)")
        if name in dies:
            worst = max(worst, abs(v["scaled"]))
    return worst


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scheme", help=argparse.SUPPRESS)  # worker mode
    ap.add_argument("--schemes", default="air,grease")
    args = ap.parse_args(argv)
    if args.scheme:
        print(json.dumps(one_scheme(args.scheme)))
        return 0
    import _record  # benchmarks/_record.py
    from imutherm.imu.sensor_model import SITES

    print("reference unit, the study's laws, reduced power-on transients on the default mesh (1x) and on it "
          "refined 2x; the largest difference over the transient between the 2x curve and the 1x curve, as it is "
          "and scaled to the 2x steady rise (the study's correction: the curves' shapes compared)")
    t0, ok = time.perf_counter(), True
    for s in args.schemes.split(","):
        worst = report(_record.scheme_in_process(__file__, s), SITES)
        print(f"  sensor dies: the scaled curves within {worst:.3f} K of the 2x mesh's at every time")
        ok &= worst <= SHAPE_TOL_K
    print(f"total {time.perf_counter() - t0:.0f} s")
    print(f"  {'PASS' if ok else 'FAIL'}  at every sensor die the scaled default-mesh curve is within "
          f"{SHAPE_TOL_K:g} K "
          "of the 2x mesh's own transient at every time")
    return 0 if ok else 1


if __name__ == "__main__":
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "corrected_curves", "the mesh-corrected site curves against the 2x mesh's transient"))
