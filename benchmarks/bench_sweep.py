"""Benchmark of ``imutherm sweep``: a 50-case steady sweep of the reference unit at the default mesh.

A Latin hypercube (SALib, seed 1) of 50 cases over four inputs of the grease
scheme, run with ``--jobs 2`` through the CLI as a user would: the 5 V
regulator's power, the mounting contact conductance, the grease conductivity
and the housing emissivity. Reports the wall time of the whole command (design
checks, worker start-up, 50 solves, PDF), the mean and max per-case time the
workers measured, the CPU seconds of all processes (the load-independent cost), the load average of the machine before and after (it is
shared), and the ranking the sweep found. Target: <= 5 minutes.

    python benchmarks/bench_sweep.py                # 50 cases, --jobs 2, default mesh
    python benchmarks/bench_sweep.py --jobs 1 --samples 10
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

SETS = ["components.reg_5v.power_W=0.4:1.2", "mounting.contact_conductance_W_m2K=200:2000",
        "materials.silicone_grease.k=0.3:1.5", "options.emissivity=0.05:0.9"]


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--samples", type=int, default=50)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--out", default=None, help="sweep directory (default: a temporary one)")
    args = p.parse_args()

    from imutherm.cli import main as cli

    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="bench_sweep_")) / "sweep"
    argv = ["sweep", "--scheme", "grease", "--method", "lhs", "--samples", str(args.samples), "--seed", "1",
            "--jobs", str(args.jobs), "--out", str(out)]
    for s in SETS:
        argv += ["--set", s]
    load0 = os.getloadavg()
    t0 = time.perf_counter()
    rc = cli(argv)
    wall = time.perf_counter() - t0
    load1 = os.getloadavg()
    # CPU seconds of this process and of the (joined) worker processes: the load-independent cost;
    # on an idle machine the wall time is about cpu_s / min(jobs, cores) plus worker start-up
    cpu = sum(resource.getrusage(w).ru_utime + resource.getrusage(w).ru_stime
              for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
    rec = json.loads((out / "sweep.json").read_text())
    figures = {"cases": rec["counts"]["cases"], "ok": rec["counts"]["ok"], "jobs": args.jobs,
               "wall_s": round(wall, 1), "wall_per_case_s": round(wall / rec["counts"]["cases"], 2),
               "case_s_mean": round(rec["timing"]["case_s_mean"], 2), "case_s_max": round(rec["timing"]["case_s_max"], 2),
               "cpu_s_total": round(cpu, 1), "cpu_s_per_case": round(cpu / rec["counts"]["cases"], 2),
               "idle_machine_wall_estimate_s": round(cpu / min(args.jobs, os.cpu_count() or 1), 1),
               "loadavg_1min_before_after": [round(load0[0], 2), round(load1[0], 2)], "cpus": os.cpu_count(),
               "ranking_max_rise": rec["sensitivity"]["ranking"], "out": str(out)}
    print(json.dumps(figures, indent=2))
    return rc


if __name__ == "__main__":
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "sweep", "imutherm sweep, 50 cases"))
