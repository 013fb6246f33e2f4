"""``imutherm attitude``: run the attitude filters on a motion profile and report roll/pitch errors.

``--imu-csv FILE`` runs every filter on a recorded log instead (:mod:`imutherm.cli._attitude_csv`).

Outputs in ``--out DIR``:

* ``attitude.json``: ``filters.<name>.<segment>.<metric>`` for names ``gated``
  (Liu et al. 2012), ``kf`` (the horizontal-attitude KF paper), ``ungated`` (complementary baseline),
  ``fusion`` (imufusion peer), ``aekf`` / ``aekf_gnss`` (Wang et al.'s adaptive
  EKF without / with simulated GNSS velocity, ``--gnss-rate``, ``--gnss-vel-std``;
  these two also carry ``heading`` ``{rms_deg, max_deg}``); segments ``overall``, ``stable``, ``manoeuvre``;
  metrics ``roll_rms_deg``, ``pitch_rms_deg``, ``roll_max_deg``,
  ``pitch_max_deg``, each ``{"mean", "std"}`` over the seeds (null if the
  phase is empty); ``filters.<name>.runtime_s`` ``{"mean", "std"}`` [s]; the
  gate configuration and thresholds; the inputs.
* ``attitude_series.npz``: the first seed's time series (truth and estimates).
* ``attitude.png``: roll / pitch error vs time per filter, manoeuvres shaded
  (drawn from ``attitude_series.npz`` by :mod:`imutherm.reports.attitude_plots`).
"""

from __future__ import annotations

import numpy as np

from imutherm import InputError
from imutherm.budget import check_attitude_cost
from imutherm.cli import run_command
from imutherm.cli._common import atomic_outdir, check_outdir, write_json
from imutherm.cli._options import add_memory_argument, add_out_argument
from imutherm.imu.motion import PROFILES


def add_args(p) -> None:
    """The options of ``imutherm attitude`` (those of a recorded log: :mod:`imutherm.cli._attitude_csv`)."""
    p.add_argument("--profile", default=None, help=f"motion profile: {', '.join(PROFILES)} (or --imu-csv)")
    p.add_argument("--grade", default="adis16355", help="sensor grade (default adis16355)")
    t = p.add_mutually_exclusive_group()
    t.add_argument("--temperature", type=float, default=None, help="constant die temperature [°C] (default 25)")
    t.add_argument("--temperature-csv", default=None,
                   help="CSV with time_s and one column per site (gyro_x..accel_z) [°C]")
    p.add_argument("--compensation", default="improved", help="none | conventional | improved (default)")
    p.add_argument("--out-of-range", default="error", choices=("error", "hold", "linear"),
                   help="reported temperatures outside the calibrated range: error (default), hold (clamp "
                        "to the range end) or linear (extrapolate the calibration's temperature trend)")
    p.add_argument("--seeds", type=int, default=1, help="number of seeds (units / noise draws), default 1")
    p.add_argument("--seed0", type=int, default=0, help="first seed (default 0)")
    p.add_argument("--duration", type=float, default=None, help="profile duration [s] (default: profile's)")
    p.add_argument("--gnss-rate", type=float, default=5.0, metavar="HZ",
                   help="simulated GNSS velocity rate for aekf_gnss [Hz] (default 5)")
    p.add_argument("--gnss-vel-std", type=float, default=0.05, metavar="MPS",
                   help="simulated GNSS velocity noise per axis, 1 sigma [m/s] (default 0.05)")
    p.add_argument("--no-plot", action="store_true", help="skip attitude.png")
    p.add_argument("--filters", default=None, metavar="A,B,...",
                   help="filters to run (imutherm.imu.filters.registry; default all that apply: every registered "
                        "filter on a profile, all but those needing GNSS on a log)")
    p.add_argument("--filter-defaults", action="store_true",
                   help="run the filters at their defaults, not at the tuned settings of "
                        "studies/attitude/filter_settings.toml for the profile (every motion profile; static, at rest, "
                        "runs the defaults either way)")
    p.add_argument("--disturbances", default="none", choices=("none", "realistic"),
                   help="realistic: the profile's vibration, turbulence, wind, sync error and jitter "
                        "(imutherm.imu.disturbances.PRESETS); default none")
    add_memory_argument(p)
    add_out_argument(p)
    from imutherm.cli import _attitude_csv

    _attitude_csv.add_arguments(p)


def main(argv=None) -> int:
    """``imutherm attitude ARGV...``; returns the exit status (2 on bad input)."""
    return run_command("attitude", argv)


def run(args) -> int:
    """Run the filters on the profile (or the recorded log) of ``args`` and write the outputs; returns 0."""
    check_outdir(args.out)
    if args.imu_csv is not None:  # a user's recorded log (imutherm.cli._attitude_csv)
        from imutherm.cli import _attitude_csv

        return _attitude_csv.run(args)
    if args.profile is None:
        raise InputError(f"give --profile ({', '.join(PROFILES)}) or --imu-csv FILE")
    if args.profile not in PROFILES:
        raise InputError(f"--profile: {args.profile!r} is unknown; valid: {', '.join(PROFILES)}")
    if args.seeds < 1:
        raise InputError(f"--seeds must be an integer >= 1, got {args.seeds}")
    if args.seed0 < 0:
        raise InputError(f"--seed0 must be an integer >= 0 (numpy seeds are non-negative), got {args.seed0}")
    if args.duration is not None and not (np.isfinite(args.duration) and args.duration > 0):
        raise InputError(f"--duration must be a finite number > 0 [s], got {args.duration}")
    from imutherm.imu.sensor_model import load_grade

    # samples x seeds before any allocation; no --duration: the longest profile default (flight, 400 s)
    check_attitude_cost(args.duration or 400.0, load_grade(args.grade).sample_rate_hz, args.seeds, args.max_memory)
    if args.temperature_csv is not None:  # the table read and its times checked before the study starts
        import inspect

        from imutherm.imu import motion
        from imutherm.studies.attitude.attitude_study import check_temperature_span, read_temperature_csv

        duration = args.duration or inspect.signature(getattr(motion, f"{args.profile}_profile")).parameters[
            "duration"].default
        check_temperature_span(read_temperature_csv(args.temperature_csv)[0], 0.0, duration, args.temperature_csv)
    from imutherm.imu.gnss import GnssConfig
    from imutherm.studies.attitude.attitude_study import run_attitude_study

    gnss = GnssConfig(rate_hz=args.gnss_rate, vel_std=args.gnss_vel_std)  # InputError names the bad value
    from imutherm.imu.filters.registry import parse_filters

    names = parse_filters(args.filters)

    res = run_attitude_study(args.profile, grade=args.grade, temperature_C=args.temperature,
                             temperature_csv=args.temperature_csv, compensation=args.compensation,
                             seeds=args.seeds, seed0=args.seed0, duration=args.duration,
                             out_of_range=args.out_of_range, disturbances=args.disturbances == "realistic",
                             gnss=gnss, names=names, settings="defaults" if args.filter_defaults else "tuned")
    with atomic_outdir(args.out) as tmp:
        write_json(tmp / "attitude.json", res.to_json())
        np.savez_compressed(tmp / "attitude_series.npz", **res.series)
        if not args.no_plot:
            from imutherm.reports.attitude_plots import plot_attitude

            plot_attitude(tmp / "attitude_series.npz", tmp / "attitude.png")
    fs = res.filter_settings
    print(f"filters at tuned settings ({fs.get('file', '')}): {', '.join(fs['tuned']) or 'none'}; at defaults: "
          f"{', '.join(fs['defaults']) or 'none'}")
    m = res.metrics
    for name in m:
        o = m[name]["overall"]
        print(f"{name:8s} roll rms {o['roll_rms_deg']['mean']:.3f} deg  pitch rms {o['pitch_rms_deg']['mean']:.3f} deg"
              f"  runtime {m[name]['runtime_s']['mean']:.2f} s"
              + (f"  heading rms {m[name]['heading']['rms_deg']['mean']:.2f} deg" if "heading" in m[name] else ""))
    from imutherm.studies.attitude.real_settings import real_motion_lines

    for line in real_motion_lines(list(m)):
        print(line)
    return 0
