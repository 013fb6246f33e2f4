"""Benchmark of ``imutherm correlate``: three measured files at the default mesh, end to end, cold and warm.

The three files are made once (kept in ``--data``) by the hidden-effect generator: air, grease and potted
at 70 degC, a poor board-joint contact hidden (h = 300 W/m^2 K), ±10 % nuisance, 0.05 K noise, six sites,
40 readings over 1500 s, from the full model at the default mesh (this benchmark times the workflow; the
campaign, ``bench_correlation.py``, measures its accuracy on data from a finer mesh). Then the command is
run as a user would, through the CLI with ``--jobs 2``: three reduced models, the re-tune, 15 candidates,
the hold-out fits, the full-model re-run of the corrected model (three transients) and the PDF. Reports
the wall time, the time of each stage, the CPU seconds of all processes (the load-independent cost), the
peak memory and the load average before and after (the machine may be shared). The command runs twice on
a fresh cache folder (``IMUTHERM_CACHE_DIR``; ``--cache-dir`` to keep one): the first run builds the
reduced models and the re-run and keeps them (target cold <= 150 s), the second is the next
correlation of the same unit and reads them (target <= 20 s).

    python benchmarks/bench_correlation_speed.py
    python benchmarks/bench_correlation_speed.py --cavity-law effective   # the reduced models without the s2s exchange
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

import numpy as np


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--data", default=str(Path(tempfile.gettempdir()) / "imutherm_bench_correlation_data"))
    p.add_argument("--out", default=None)
    p.add_argument("--cache-dir", default=None, help="cache folder (default: a fresh temporary one: a cold start)")
    p.add_argument("--runs", type=int, default=2, help="runs of the command on the same cache (default 2)")
    p.add_argument("--cavity-law", default=None, choices=("effective", "s2s", "none"),
                   help="the correlation model's cavity law (default: the model's, s2s; the data are the same, "
                        "made with the effective law)")
    args = p.parse_args()
    from imutherm.cli import main as cli
    from imutherm.studies.correlation.hidden_effect import make_case

    data = Path(args.data)
    files = sorted(data.glob("*.csv"))
    if len(files) != 3:
        t0 = time.perf_counter()
        case = make_case(data, "contact@board", np.random.default_rng(2026), value=300.0,
                         experiments=(("air", 70.0), ("grease", 70.0), ("potted", 70.0)), mesh_size_mm=2.0)
        files = [Path(f) for f in case.files]
        print(f"generated {len(files)} files in {time.perf_counter() - t0:.0f} s (kept in {data})", flush=True)
    os.environ["IMUTHERM_CACHE_DIR"] = args.cache_dir or tempfile.mkdtemp(prefix="bench_corr_cache_")
    base = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="bench_corr_"))
    targets = {0: 150.0, 1: 20.0}
    ok = True
    for k in range(args.runs):
        out = base / f"corr{k}"
        load0 = os.getloadavg()[0]
        cpu0 = sum(resource.getrusage(w).ru_utime + resource.getrusage(w).ru_stime
                   for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))
        t0 = time.perf_counter()
        law = ["--cavity-law", args.cavity_law] if args.cavity_law else []
        rc = cli(["correlate", "--measured", *map(str, files), "--jobs", str(args.jobs), "--out", str(out), *law])
        wall = time.perf_counter() - t0
        cpu = sum(resource.getrusage(w).ru_utime + resource.getrusage(w).ru_stime
                  for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)) - cpu0
        peak = max(resource.getrusage(w).ru_maxrss for w in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)) / 1024
        j = json.loads((out / "correlation.json").read_text())
        target = targets.get(min(k, 1))
        ok &= rc == 0 and wall <= target
        print(json.dumps({"run": "cold" if k == 0 else "warm", "exit": rc, "wall_s": round(wall, 1),
                          "target_s": target, "cpu_s": round(cpu, 1),
                          "peak_rss_MB_one_process": round(peak), "load_before": load0,
                          "load_after": os.getloadavg()[0], "cavity_law": args.cavity_law or "default (s2s)",
                          "stages_s": j["timings_s"], "verdict": j["verdict"], "named_effect": j["named_effect"],
                          "rms_before_K": j["rms_before_K"], "rms_after_K": j["rms_after_K"]}, indent=1), flush=True)
        if rc != 0:
            return 1
    return 0 if ok else 1


if __name__ == "__main__":
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "correlation_speed", "imutherm correlate, three files"))
