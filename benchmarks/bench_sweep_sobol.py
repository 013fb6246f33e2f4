"""Benchmark of a Sobol' sweep on the reduced model: 6 inputs of the grease scheme, default mesh.

``imutherm sweep --method sobol`` through the CLI as a user would run it: SALib's Saltelli design of
``--samples N`` (default 2048, so N x (6 + 2) = 16 384 cases, above the 10 000 of the target), every case on
the scheme's reduced model (``--surrogate reduced``), then ``--verify 5`` random cases re-run on the full
FEM. Inputs and ranges (each one's source in the README's sweep section): the 5 V regulator's loss for a
6-12 V supply ((V - 5 V) x 203 mA), the base-to-fixture contact, the grease conductivity, the housing
emissivity, the board's in-plane conductivity and the board standoff contact. Reports the wall time of
the command, its CPU seconds (the load-independent cost: the machine may be shared), the split between
the reduced-model build, the evaluation and the verification, the verification's largest site error
and the Sobol' indices of the largest rise. Target: a 10 000-case sweep <= 3 min including the build, checked
cases within 0.1 K of the full FEM.

    python benchmarks/bench_sweep_sobol.py                  # default mesh, 16 384 cases
    python benchmarks/bench_sweep_sobol.py --mesh-size 6 --samples 256
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

SETS = ["components.reg_5v.power_W=0.203:1.421", "mounting.contact_conductance_W_m2K=150:3000",
        "materials.silicone_grease.k=0.3:1.5", "options.emissivity=0.75:0.9",
        "materials.pcb_fr4_4layer.k_in_plane=10:40", "options.standoff_contact_W_m2K=300:3000"]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--samples", type=int, default=2048)
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--mesh-size", default=None, help="largest cell [mm] (default: the CLI's default mesh)")
    p.add_argument("--transient", action="store_true", help="also t95 of the hottest site")
    p.add_argument("--cavity-law", default=None, help="effective or s2s (default: the model's default)")
    p.add_argument("--out", default=None, help="sweep directory (default: a temporary one)")
    args = p.parse_args()

    from imutherm.cli import main as cli

    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="bench_sobol_")) / "sweep"
    argv = ["sweep", "--scheme", "grease", "--method", "sobol", "--samples", str(args.samples), "--seed", "1",
            "--surrogate", "reduced", "--verify", "5", "--jobs", str(args.jobs), "--no-progress", "--out", str(out)]
    if args.mesh_size:
        argv += ["--mesh-size", args.mesh_size]
    if args.transient:
        argv += ["--transient"]
    if args.cavity_law:
        argv += ["--cavity-law", args.cavity_law]
    for s in SETS:
        argv += ["--set", s]
    load0 = os.getloadavg()
    t0 = time.perf_counter()
    rc = cli(argv)
    wall = time.perf_counter() - t0
    load1 = os.getloadavg()
    cpu = sum(resource.getrusage(w).ru_utime + resource.getrusage(w).ru_stime
              for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    rec = json.loads((out / "sweep.json").read_text())
    v = rec["verification"]
    by = rec["sensitivity"]["outputs"]["max_rise_K"]["by_key"]
    figures = {"exit": rc, "cases": rec["counts"]["cases"], "ok": rec["counts"]["ok"], "wall_s": round(wall, 1),
               "cpu_s": round(cpu, 1), "build_s": round(rec["timing"]["build_s"], 1),
               "evaluate_s": round(rec["timing"]["evaluate_s"], 1), "verify_s": round(rec["timing"]["verify_s"], 1),
               "unknowns": rec["surrogate"]["unknowns"], "basis": rec["surrogate"]["basis_size"],
               "coupled_pairs": rec["surrogate"]["coupled_pairs"],
               "verified_cases": v["cases"], "max_site_error_K": v["max_site_error_K"],
               "max_rise_error_K": v["max_rise_error_K"], "max_t95_rel_error": v["max_t95_rel_error"],
               "passed": v["passed"], "peak_rss_MB": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024),
               "loadavg_1min_before_after": [round(load0[0], 2), round(load1[0], 2)], "cpus": os.cpu_count(),
               "sobol_max_rise": {k: {m: round(b[m], 3) for m in ("S1", "S1_conf", "ST", "ST_conf")}
                                  for k, b in by.items()},
               "out": str(out)}
    print(json.dumps(figures, indent=2))
    ok = wall <= 180 and v["passed"]
    print(f"target (<= 180 s wall including the build, checked cases within 0.1 K): {'PASS' if ok else 'NOT MET'}"
          f" (wall {wall:.0f} s, CPU {cpu:.0f} s; machine load {load0[0]:.1f} at the start)")
    return rc


if __name__ == "__main__":
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "sweep_sobol",
                         "imutherm sweep --method sobol on the reduced model (6 inputs of the grease scheme)"))
