"""Benchmark of ``imutherm compare --uncertainty`` with its IMU draws, through the CLI as a user runs it.

The end-to-end study of the three schemes, then the propagation: SALib's Saltelli design of
``--samples N`` base samples (N x (inputs + 2) draws on each scheme's reduced model), ``--checks`` drawn
points per scheme on the full FEM, and ``--imu-draws`` of the draws through the full IMU chain (the
study's seeds fixed). Prints the wall time and the CPU seconds (user + sys of this process and its
workers: the load-independent cost, the machine may be shared), the split of the propagation (reduced
models, full-FEM checks, IMU draws, from ``uncertainty.json``'s timings), the check errors, and the
attitude and residual intervals per scheme and of each difference between schemes.

    python benchmarks/bench_uncertainty.py --mesh-size 6          # coarse mesh
    python benchmarks/bench_uncertainty.py --samples 256 --imu-draws 16
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


def _cpu() -> float:
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime + c.ru_utime + c.ru_stime


def main() -> int:
    os.environ["IMUTHERM_CACHE"] = "off"   # the models built and the cases solved, not read from the disk cache
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--samples", type=int, default=256)
    p.add_argument("--checks", type=int, default=2)
    p.add_argument("--imu-draws", type=int, default=16)
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--schemes", default="air,grease,potted")
    p.add_argument("--jobs", type=int, default=1)
    p.add_argument("--mesh-size", default=None, help="largest cell [mm] (default: the CLI's default mesh)")
    p.add_argument("--out", default=None, help="output directory (default: a temporary one)")
    args = p.parse_args()

    from imutherm.cli import main as cli

    out = Path(args.out) if args.out else Path(tempfile.mkdtemp(prefix="bench_unc_")) / "compare"
    argv = ["compare", "--schemes", args.schemes, "--seeds", str(args.seeds), "--jobs", str(args.jobs),
            "--uncertainty", "--uncertainty-samples", str(args.samples), "--uncertainty-checks", str(args.checks),
            "--uncertainty-imu-draws", str(args.imu_draws), "--no-progress", "--out", str(out)]
    if args.mesh_size:
        argv += ["--mesh-size", args.mesh_size, "--min-cells", "1"]
    load0 = os.getloadavg()
    c0, t0 = _cpu(), time.perf_counter()
    rc = cli(argv)
    wall, cpu = time.perf_counter() - t0, _cpu() - c0
    if rc:
        return rc
    unc = json.loads((out / "uncertainty.json").read_text())
    tm = unc["timings"]
    schemes = args.schemes.split(",")
    build = sum(tm[s]["build_s"] for s in schemes)
    check = sum(tm[s]["check_s"] for s in schemes)
    print(f"\nbench_uncertainty: mesh {args.mesh_size or 'default'}, {unc['draws']} draws, {args.checks} checks and "
          f"{unc['imu']['n']} IMU draws per scheme, {args.seeds} seeds, jobs {args.jobs}; load average "
          f"{load0[0]:.1f} -> {os.getloadavg()[0]:.1f} (shared machine)")
    print(f"  whole command: wall {wall:.0f} s, CPU {cpu:.0f} s (user + sys, with workers)")
    print(f"  propagation (wall): {tm['total_s']:.0f} s = reduced models {build:.0f} s + full-FEM checks {check:.0f} s "
          f"+ IMU draws {tm['imu_wall_s']:.0f} s (CPU {tm['imu_cpu_s']:.0f} s)")
    print(f"  checks: steady site error {unc['max_check_error_K']:.3f} K, t95 "
          f"{100 * (unc['max_check_t95_rel_error'] or 0):.2f} %, oven self-heating map {unc['max_check_oven_error_K']:.3f} K")
    imu = unc["imu"]
    for key, st in imu["stats"].items():
        if key.split(":")[0].replace("diff_", "") in (f"warmup_{imu['filters'][0]}_roll_rms_deg", "gyro_rms_dps",
                                                       "accel_rms_mg"):
            print(f"  {key:<48} {st['interval']:>8}: {st['lo']:+.4f} .. {st['q50']:+.4f} .. {st['hi']:+.4f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
