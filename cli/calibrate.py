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

``--procedure roll-coupling`` (Wang et al., :mod:`imutherm.imu.roll_coupling`) writes
``roll_coupling.json`` instead: gyro RMSE over 29 test roll rates after the
least-squares rate-table calibration alone (``linear``) and with the high-rate
roll coupling compensated by a cubic (``poly``) or a 30-node network (``mlp``),
beside Wang et al.'s figures, the fitted and true coefficients.

``--procedure overload`` (Lin et al., :mod:`imutherm.studies.attitude.overload_study`) writes
``overload.json``: Ka, K2, D1 per load (1..10 g) and power-on, the joint
values and the unit's truth, and the attitude filters on the ``shake`` profile
(1.2 g and 5 g) with and without the recovered terms compensated. With
``--load-dependence`` the unit's Ka, K2, D1 follow Lin et al.'s findings
(:class:`imutherm.imu.overload.LoadDependence`) and ``overload.json`` adds
``load_dependence`` (the truth per load and the recovered vs true trends).
"""

from __future__ import annotations

import numpy as np

from imutherm import InputError
from imutherm.cli import run_command
from imutherm.cli._common import atomic_outdir, check_outdir, write_json
from imutherm.cli._options import add_out_argument
from imutherm.imu.calibration import RigConfig
from imutherm.imu.compensation import INTERPS
from imutherm.imu.grades import GRADES
from imutherm.studies.attitude.calibration_study import run_calibration


PROCEDURES = ("temperature", "roll-coupling", "overload")


def _roll_coupling(args) -> int:
    from imutherm.imu.roll_coupling import calibrate_roll_coupling
    from imutherm.imu.sensor_model import draw_unit

    rng = np.random.default_rng(args.seed)
    unit = draw_unit(args.grade, rng)
    res = calibrate_roll_coupling(unit, rng)
    with atomic_outdir(args.out) as tmp:
        write_json(tmp / "roll_coupling.json", {"grade": unit.grade.name, "seed": int(args.seed), **res.to_json()})
    r = res.rmse_dps
    print("imutherm calibrate --procedure roll-coupling: gyro RMSE over 29 test roll rates [deg/s] x/y/z: "
          + "; ".join(f"{k} " + "/".join(f"{v:.4f}" for v in r[k]) for k in ("linear", "poly", "mlp"))
          + f" (Wang et al.: {'/'.join(str(v) for v in res.to_json()['paper_rmse_dps'])}) -> {args.out}")
    return 0


def _overload(args) -> int:
    from imutherm.studies.attitude.overload_study import run_overload_study

    from imutherm.imu.overload import LoadDependence

    res = run_overload_study(args.grade, args.seed, dependence=LoadDependence() if args.load_dependence else None)
    d = res.to_json()
    with atomic_outdir(args.out) as tmp:
        write_json(tmp / "overload.json", d)
    j, t = d["joint"], d["truth"]

    def row(key, fmt):
        return "/".join(fmt.format(v) for v in j[key]) + " (truth " + "/".join(fmt.format(v) for v in t[key]) + ")"

    print(f"imutherm calibrate --procedure overload: Ka [ppm] {row('asym_ppm', '{:.0f}')}; "
          f"K2 [mg/g^2] {row('k2_mg_per_g2', '{:.3f}')}; D1 diag [deg/s/g] "
          + "/".join(f"{j['D1_dps_per_g'][i][i]:.4f}" for i in range(3)) + " (truth "
          + "/".join(f"{t['D1_dps_per_g'][i][i]:.4f}" for i in range(3)) + f") -> {args.out}")
    if args.load_dependence:
        tr = d["load_dependence"]["trends"]
        print("load trend [%/g of the 1 g value] recovered (truth) x/y/z: "
              + "; ".join(f"{k} " + "/".join(f"{100 * a:+.1f} ({100 * b:+.1f})" for a, b in
                                             zip(tr[k]["recovered_rel_per_g"], tr[k]["truth_rel_per_g"]))
                          for k in ("asym", "k2", "D1")))
    return 0


def add_args(parser) -> None:
    """The options of ``imutherm calibrate``."""
    parser.add_argument("--grade", default="adis16355", help=f"sensor grade: {', '.join(GRADES)} (default adis16355)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (unit draw, rig, noise); default 0")
    parser.add_argument("--oven-mount-deg", type=float, default=None, metavar="DEG",
                        help=f"unknown oven-mounting rotation [deg] (default {RigConfig().oven_mount_deg})")
    parser.add_argument("--interp", default="segment", choices=INTERPS,
                        help="temperature lookup at compensation (default segment)")
    parser.add_argument("--procedure", default="temperature", choices=PROCEDURES,
                        help="temperature: Liu et al. 2012 two-step rig (default); roll-coupling: Wang et al. rate table "
                             "and roll-coupling compensation; overload: Lin et al. sinusoidal overload table")
    parser.add_argument("--load-dependence", action="store_true",
                        help="overload: Ka grows and K2, D1 shrink with load and change per power-on (Lin et al.'s "
                             "findings as the truth model)")
    add_out_argument(parser)


def main(argv=None) -> int:
    """``imutherm calibrate ARGV...``; returns the exit status."""
    return run_command("calibrate", argv)


def run(args) -> int:
    """Run the procedure of ``args`` and write its outputs; returns 0."""
    check_outdir(args.out)
    if args.seed < 0:
        raise InputError(f"--seed must be an integer >= 0 (numpy seeds are non-negative), got {args.seed}")
    from imutherm.imu.sensor_model import load_grade

    load_grade(args.grade)  # an unknown grade is refused before the rig simulation starts
    if args.procedure == "roll-coupling":
        return _roll_coupling(args)
    if args.procedure == "overload":
        return _overload(args)
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
