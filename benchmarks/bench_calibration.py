"""Benchmark of ``imutherm calibrate``: residual table over seeds, a mounting-angle sweep, and runtime.

    python benchmarks/bench_calibration.py [--grade adis16355] [--seeds 0 1 2 3 4] [--interp segment]
                                           [--sweep 0 0.2 0.5 1.0 1.4] [--sweep-seed 0]

Prints, per seed, the accelerometer max residual [mg] and the gyro max residual [°/s] for the
uncompensated / conventional / improved cases (test data not used in the fits), the conventional/improved
ratio and the runtime; then the same for one seed over oven-mounting angles (the mechanism: the
conventional residual grows about g·θ = 17.5 mg per degree, the improved one does not move).
Paper (seed 000): conventional 30 mg, improved 5 mg.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from imutherm.cli.calibrate import run_calibration  # noqa: E402

HEAD = (f"{'case':>12} | {'acc none':>8} {'acc conv':>8} {'acc impr':>8} {'ratio':>5} | "
        f"{'gyr none':>8} {'gyr conv':>8} {'gyr impr':>8} | {'time s':>6}")


def _row(label: str, d: dict, dt: float) -> str:
    a, g = d["accel_max_residual_mg"], d["gyro_max_residual_dps"]
    return (f"{label:>12} | {a['uncompensated']:8.2f} {a['conventional']:8.2f} {a['improved']:8.2f} "
            f"{a['conventional'] / a['improved']:5.1f} | {g['uncompensated']:8.3f} {g['conventional']:8.3f} "
            f"{g['improved']:8.3f} | {dt:6.1f}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--grade", default="adis16355")
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2, 3, 4])
    p.add_argument("--interp", default="segment", choices=("segment", "linear"))
    p.add_argument("--sweep", type=float, nargs="*", default=[0.0, 0.2, 0.5, 1.0, 1.4],
                   help="oven-mounting angles [deg] for the mechanism sweep (empty: skip)")
    p.add_argument("--sweep-seed", type=int, default=0)
    args = p.parse_args(argv)

    print(f"grade {args.grade}, interp {args.interp}; accel [mg], gyro [deg/s]; paper: conventional 30 mg, "
          f"improved 5 mg")
    print(HEAD)
    ratios, t_all = [], time.perf_counter()
    for seed in args.seeds:
        t0 = time.perf_counter()
        d = run_calibration(args.grade, seed, interp=args.interp)
        print(_row(f"seed {seed}", d, time.perf_counter() - t0), flush=True)
        ratios.append(d["accel_max_residual_mg"]["conventional"] / d["accel_max_residual_mg"]["improved"])
    print(f"accel ratio conventional/improved: min {min(ratios):.1f}, median {np.median(ratios):.1f}; "
          f"total {time.perf_counter() - t_all:.1f} s for {len(args.seeds)} seeds")
    if args.sweep:
        print(f"\noven-mounting sweep, seed {args.sweep_seed} (unit and test identical, only the angle changes)")
        print(HEAD)
        for deg in args.sweep:
            t0 = time.perf_counter()
            d = run_calibration(args.grade, args.sweep_seed, oven_mount_deg=deg, interp=args.interp)
            print(_row(f"{deg:.2f} deg", d, time.perf_counter() - t0), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
