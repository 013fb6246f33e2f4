"""Benchmark of ``imutherm calibrate``: conventional vs improved over the oven-mounting rotation, and runtime.

    python benchmarks/bench_calibration.py [--grade adis16355] [--seeds 0 1 2]
                                           [--angles 0 0.5 1 1.4 2 3] [--tempco 0 1 3]

Each case draws the unit of a seed, runs the two-step rig with the given oven-mounting rotation and
thermal-misalignment scale (1 = the grade's estimate, 2e-3 °/K per element; the rest of the rig and the
test data are identical across cases of a seed), and evaluates on a new power-on at random temperatures,
orientations and rates. Printed: the accelerometer max residual [mg] and gyro max residual [°/s] for
uncompensated / conventional / improved, mean and range over the seeds.
Paper (Liu et al. 2012): conventional 30 mg, improved 5 mg.
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from imutherm.imu.calibration import calibrate_unit, evaluate_calibration  # noqa: E402
from imutherm.imu.sensor_model import draw_unit  # noqa: E402




def case(grade: str, seed: int, angle: float, tempco: float) -> tuple[dict, dict]:
    rng = np.random.default_rng(seed)
    unit = draw_unit(grade, rng)
    unit = replace(unit, gyro=replace(unit.gyro, dM_dT=unit.gyro.dM_dT * tempco),
                   accel=replace(unit.accel, dM_dT=unit.accel.dM_dT * tempco))
    cal = calibrate_unit(unit, rng, oven_mount_deg=angle)
    ev = evaluate_calibration(unit, cal, rng)
    return ev.accel_max_residual_mg, ev.gyro_max_residual_dps


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--grade", default="adis16355")
    p.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    p.add_argument("--angles", type=float, nargs="+", default=[0.0, 0.5, 1.0, 1.4, 2.0, 3.0])
    p.add_argument("--tempco", type=float, nargs="+", default=[0.0, 1.0, 3.0],
                   help="thermal-misalignment scales; the full angle sweep runs at 1, the others at 0 and 1.4 deg")
    a = p.parse_args(argv)
    cases = [(ang, 1.0) for ang in a.angles] + [(ang, tc) for tc in a.tempco if tc != 1.0 for ang in (0.0, 1.4)]
    print(f"grade {a.grade}, seeds {a.seeds}; max residual over the test runs, mean [min..max] over seeds; "
          "accel [mg], gyro [deg/s]")
    print(f"{'oven deg':>8} {'tempco':>6} | {'acc none':>17} {'acc conv':>17} {'acc impr':>17} | "
          f"{'gyr conv':>17} {'gyr impr':>17} | {'conv/impr':>9}")
    t_all = time.perf_counter()
    for ang, tc in cases:
        acc, gyr = zip(*(case(a.grade, s, ang, tc) for s in a.seeds))

        def cell(d, m, f="6.2f"):
            v = np.array([x[m] for x in d])
            return f"{v.mean():{f}} [{v.min():{f}}..{v.max():{f}}]".replace(" [", "[")

        ratio = np.mean([x["conventional"] / x["improved"] for x in acc])
        print(f"{ang:8.2f} {tc:6.1f} | {cell(acc, 'none'):>17} {cell(acc, 'conventional'):>17} "
              f"{cell(acc, 'improved'):>17} | {cell(gyr, 'conventional', '5.3f'):>17} "
              f"{cell(gyr, 'improved', '5.3f'):>17} | {ratio:9.2f}", flush=True)
    print(f"total {time.perf_counter() - t_all:.1f} s for {len(cases) * len(a.seeds)} calibrations")
    return 0


if __name__ == "__main__":
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "calibration", "conventional vs improved calibration"))
