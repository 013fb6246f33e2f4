"""``imutherm calibrate``: simulate the calibration rig on one drawn unit, fit both models, evaluate.

Outputs in ``--out DIR``:

* ``calibration.json``: ``grade``, ``seed``, ``accel_max_residual_mg`` and
  ``gyro_max_residual_dps`` (each ``{uncompensated, conventional, improved}``),
  ``ratio_conventional_over_improved``, the paper's figures, per-segment fit
  summaries (``segments``), the per-run test residuals (``evaluation``), the
  reusable ``calibration`` (load it with
  ``imutherm.imu.calibration.Calibration.load_json(DIR/'calibration.json')``)
  and the drawn ``unit`` truth.
* ``calibration_residuals.png``: residual vs temperature for the three cases.
"""

from __future__ import annotations

import argparse

from imutherm import InputError
from imutherm.cli._common import atomic_outdir, check_outdir, run_guarded, write_json
from imutherm.imu.calibration import RigConfig
from imutherm.imu.compensation import INTERPS
from imutherm.imu.grades import GRADES
from imutherm.studies.calibration_study import run_calibration


@run_guarded("imutherm calibrate")
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="imutherm calibrate", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--grade", default="adis16355", help=f"sensor grade: {', '.join(GRADES)} (default adis16355)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (unit draw, rig, noise); default 0")
    parser.add_argument("--oven-mount-deg", type=float, default=None, metavar="DEG",
                        help=f"unknown oven-mounting rotation [deg] (default {RigConfig().oven_mount_deg})")
    parser.add_argument("--interp", default="segment", choices=INTERPS,
                        help="temperature lookup at compensation (default segment)")
    parser.add_argument("--out", required=True, help="output directory")
    args = parser.parse_args(argv)
    check_outdir(args.out)
    if args.seed < 0:
        raise InputError(f"--seed must be an integer >= 0 (numpy seeds are non-negative), got {args.seed}")
    from imutherm.imu.sensor_model import load_grade

    load_grade(args.grade)  # an unknown grade is refused before the rig simulation starts
    result = run_calibration(args.grade, args.seed, oven_mount_deg=args.oven_mount_deg, interp=args.interp)
    from imutherm.reports.calibration_plots import plot_calibration_residuals

    with atomic_outdir(args.out) as tmp:
        write_json(tmp / "calibration.json", result)
        plot_calibration_residuals(result, tmp / "calibration_residuals.png")
    a, g = result["accel_max_residual_mg"], result["gyro_max_residual_dps"]
    print(f"imutherm calibrate: grade {result['grade']} seed {result['seed']}: accel max residual [mg] "
          f"none {a['uncompensated']:.2f} / conventional {a['conventional']:.2f} / improved {a['improved']:.2f}; "
          f"gyro [deg/s] {g['uncompensated']:.3f} / {g['conventional']:.3f} / {g['improved']:.3f} -> {args.out}")
    return 0
