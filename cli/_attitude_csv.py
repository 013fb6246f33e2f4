"""``imutherm attitude --imu-csv FILE``: every filter on a user's recorded log (options and the run).

Outputs in ``--out DIR``: ``attitude.json`` (:meth:`RecordedResult.to_json`: per filter roll / pitch RMS and
max against the log's reference, null without one, the share of samples on which the accelerometer
corrected the attitude, runtime, whether it integrated the true time steps; the units, axes, rate, platform,
lever arm, turn radius used; ``samples``: repeats and repeated time stamps dropped, the step spread, resampled
or not; ``warnings``: a z axis reading up at rest, also printed before the scores; per filter ``resets_s``,
``rest_off_deg`` and ``motion_check``, the divergence checks, each also a ``warning:`` line when it fires),
``attitude_series.npz`` (every filter's roll / pitch, the reference) and, with a reference,
``attitude.png``.
"""

from __future__ import annotations

import numpy as np

from imutherm import InputError
from imutherm.cli._common import atomic_outdir, write_json


def add_arguments(p) -> None:
    """The recorded-log options of ``imutherm attitude``."""
    from imutherm.imu.imu_log import ACCEL_UNITS, AXES, GYRO_UNITS
    from imutherm.studies.attitude.recorded import PLATFORMS

    g = p.add_argument_group("recorded log (--imu-csv)")
    g.add_argument("--imu-csv", default=None,
                   help="recorded log: time_s,gyro_x..z,accel_x..z[,roll_deg,pitch_deg] (replaces --profile)")
    g.add_argument("--gyro-units", default=None, help=f"{' | '.join(GYRO_UNITS)} (default: header, else rad/s)")
    g.add_argument("--accel-units", default=None, help=f"{' | '.join(ACCEL_UNITS)} (default: header, else m/s2)")
    g.add_argument("--axes", default=None, help=f"{' | '.join(AXES)} body axes of the log (default: header, else FRD)")
    g.add_argument("--gyro-sample", default=None, help="interval | point: a gyro sample is the mean rate over the "
                   "step ending at it, or the rate at its instant (default: header, else interval)")
    g.add_argument("--platform", default="handheld", help=f"{' | '.join(PLATFORMS)}: lever arm and turn radius "
                   "defaults of the gates (default handheld)")
    g.add_argument("--lever-arm", default=None, help="sensor position from the rotation centre x,y,z [m] (FRD)")
    g.add_argument("--turn-radius", type=float, default=None, help="turn radius L of the rate gate [m]")
    g.add_argument("--max-gap", type=float, default=None, metavar="S",
                   help="longest gap in the time column (or one sample held) bridged by linear interpolation [s] "
                        "(default 0.5; longer gaps are refused, naming the row)")
    g.add_argument("--init-s", type=float, default=None,
                   help="rest window at the start of the log [s] (default 8; 1 for a ';'-separated reference log)")
    g.add_argument("--align", default="none", metavar="none|auto|R,P,Y",
                   help="rotation from the reference's body frame to the IMU's: none (default, the same frame), auto "
                        "(estimated from quasi-static moments; the angle is printed) or the IMU's roll,pitch,yaw "
                        "[deg] in the reference body frame")
    g.add_argument("--gyro-range", type=float, default=None, metavar="DPS",
                   help="the gyro's full scale [deg/s] for the fusion peer's over-range recovery (default: not "
                        "declared, the recovery off; never taken from the log's peak, which a log that never "
                        "reached its range underestimates)")


def _align(text):
    if text in ("none", "auto"):
        return text
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        v = []
    if len(v) != 3 or not all(np.isfinite(v)):
        raise InputError(f"--align: {text!r} is invalid; valid: none, auto, or roll,pitch,yaw [deg], e.g. 0,0,180")
    return tuple(v)


def _lever(text):
    if text is None:
        return None
    try:
        v = [float(x) for x in text.split(",")]
    except ValueError:
        v = []
    if len(v) != 3 or not all(np.isfinite(v)):
        raise InputError(f"--lever-arm: {text!r} is invalid; valid: three lengths x,y,z [m], e.g. 0.1,0,0")
    return tuple(v)


def run(args) -> int:
    """Run the filters on ``args.imu_csv`` and write the outputs; returns 0."""
    from imutherm.imu.imu_log import read_imu_csv
    from imutherm.studies.attitude.recorded import run_recorded

    if args.profile is not None:
        raise InputError("--imu-csv and --profile: give one (a recorded log or a simulated profile)")
    if args.gyro_range is not None and not (np.isfinite(args.gyro_range) and args.gyro_range > 0):
        raise InputError(f"--gyro-range must be the gyro's full scale in deg/s (> 0), got {args.gyro_range}")
    if _is_reference_layout(args.imu_csv):
        return _run_reference(args)
    if args.init_s is None:
        args.init_s = 8.0
    if not (np.isfinite(args.init_s) and args.init_s > 0):
        raise InputError(f"--init-s must be a positive number of seconds, got {args.init_s}")
    lever = _lever(args.lever_arm)
    log = read_imu_csv(args.imu_csv, gyro_units=args.gyro_units, accel_units=args.accel_units, axes=args.axes,
                       init_s=args.init_s, gyro_sample=args.gyro_sample,
                       **({} if args.max_gap is None else {"max_gap_s": args.max_gap}))
    from imutherm.imu.filters import FusionParams

    from imutherm.imu.filters.registry import parse_filters

    res = run_recorded(log, platform=args.platform, lever_arm=lever, turn_radius_m=args.turn_radius,
                       init_s=args.init_s, fusion=FusionParams(gyroscope_range=args.gyro_range),
                       names=parse_filters(args.filters, gnss=False), align=_align(args.align))
    with atomic_outdir(args.out) as tmp:
        write_json(tmp / "attitude.json", res.to_json())
        np.savez_compressed(tmp / "attitude_series.npz", **res.series)
        if res.has_reference and not args.no_plot:
            from imutherm.reports.attitude_plots import plot_attitude

            plot_attitude(tmp / "attitude_series.npz", tmp / "attitude.png")
    print(f"{log.path}: {res.n_samples} samples at {res.rate_hz:.4g} Hz ({res.duration_s:.1f} s), "
          f"gyro {log.units['gyro']}, accel {log.units['accel']}, axes {log.units['axes']}; |f| at rest "
          f"{res.g_rest_mps2:.4f} m/s²; platform {res.platform}, lever arm {list(res.lever_arm)} m, "
          f"turn radius {res.turn_radius_m:g} m")
    for w in res.warnings:
        print(f"warning: {w}")
    sm = res.samples
    if sm["n_repeats"] or sm["n_dup_time"] or sm["resampled"] or sm.get("true_steps") is not None:
        print(f"samples: {sm['n_rows']} rows; {sm['n_repeats']} sample-and-hold repeats kept as the time base (held "
              f"samples interpolated, longest hold {1e3 * sm['longest_hold_s']:.1f} ms) and {sm['n_dup_time']} "
              "repeated time stamps dropped"
              + (f"; {len(sm['gaps'])} gap(s) bridged" if sm["gaps"] else "")
              + (f"; resampled onto a uniform {1e3 * sm['step_median_s']:.2f} ms grid (true steps vary by up to "
                 f"{100 * sm['step_spread']:.0f} % of it)" if sm["resampled"] else "")
              + (f"; true steps {1e3 * sm['step_min_s']:.2f}-{1e3 * sm['step_max_s']:.2f} ms (median "
                 f"{1e3 * sm['step_median_s']:.2f} ms, spread {100 * sm['step_spread']:.0f} %): "
                 f"{', '.join(sm['true_steps']) or 'no filter'} integrate the true steps"
                 + (f", {', '.join(sm['median_step'])} at the median step (one sample period)" if sm["median_step"]
                    else "") if sm.get("true_steps") is not None else ""))
    first = next(iter(res.metrics.values()), {})
    al = first.get("alignment")
    if al and al["mode"] == "declared":
        print(f"reference -> IMU rotation (declared): {al['angle_deg']:.2f}°")
    elif al and al["mode"] == "auto":
        print(f"reference -> IMU rotation (auto): {al['why']}")
    elif al and not al.get("mounting") and al.get("applied"):
        print(f"note: {al['why']}; --align auto would apply it (below {al['fitted_angle_deg']:.0f}°: not a mounting "
              "error)")
    from imutherm.imu.filters.registry import gyro_range_filters

    if gyro_range_filters(res.metrics):
        _print_fusion_range(res.fusion)
    if first.get("reference_samples_dropped"):
        print(f"reference: {first['reference_samples_dropped']} samples without a value (empty / NaN) left out of "
              "the scores")
    for name, m in res.metrics.items():
        if m.get("not_scored"):
            score = "not scored (mounting error: see the warning)"
        elif res.has_reference:
            score = (f"roll rms {m['roll_rms_deg']:.3f} deg  pitch rms {m['pitch_rms_deg']:.3f} deg  inclination rms "
                     f"{m['inclination_rms_deg']:.3f} deg")
        else:
            score = "no reference"
        print(f"{name:8s} {score}  accelerometer used on {100 * m['accel_used_fraction']:.1f} % of samples  "
              f"runtime {m['runtime_s']:.2f} s")
        print_divergence(name, m.get("resets_s"), m.get("rest_off_deg"), m.get("motion_check"))
    return 0


def print_divergence(name: str, resets_s, rest_off=None, motion=None) -> None:
    """One line when a filter's innovations said it diverged (its monitor reset it; aekf's NIS monitor), one when
    its vertical was off the accelerometer's at rest (:func:`imutherm.imu.filters.rest_check.rest_disagreement`),
    one when it was off the accelerometer averaged over windows of motion
    (:func:`imutherm.imu.filters.motion_check.motion_disagreement`, ``motion`` its JSON dict)."""
    if motion and motion["flagged"]:
        t, worst = max(motion["flagged"], key=lambda x: x[1])
        print(f"warning: {name} off the vertical in motion: the specific force averaged over {motion['window_s']:g} s "
              f"in its attitude leans {worst:.1f}° from its vertical (at t = {t:.1f} s) on {len(motion['flagged'])} of "
              f"{motion['n_windows']} windows, more than the {motion['bound_deg']:.2f}° that the accelerometer's noise, "
              f"a {1e3 * motion['accel_bias_mps2'] / 9.80665:.0f} mg bias and a velocity change of "
              f"{motion['dv_max_mps']:g} m/s across a window allow; its attitude is off by about that much there")
    if rest_off:
        worst = max(a for _, a in rest_off)
        print(f"warning: {name} lost the vertical: at rest it was off the accelerometer's by more than 3° on "
              f"{len(rest_off)} stretch(es) of 5 s (worst {worst:.1f}° at t = "
              f"{next(t for t, a in rest_off if a == worst):.1f} s); its answer is not to be trusted there")
    if resets_s:
        at = ", ".join(f"{t:.1f}" for t in resets_s[:5]) + (", ..." if len(resets_s) > 5 else "")
        print(f"warning: {name} diverged: its innovations failed the consistency test {len(resets_s)} time(s) and it "
              f"was reset at t = {at} s; its attitude near those times is not to be trusted")


def _print_fusion_range(info: dict) -> None:
    """One line on the fusion peer's gyro range: declared, or not (and the fix when the log looks saturated)."""
    if info["gyroscope_range_dps"] > 0:
        print(f"fusion: gyro range {info['gyroscope_range_dps']:g} °/s (--gyro-range)")
    else:
        print("fusion: gyro range not declared, its over-range recovery off (declare --gyro-range DPS)")
    sat = info.get("looks_saturated_at_dps")
    if sat is not None and info["gyroscope_range_dps"] != sat:
        print(f"warning: the gyro looks clipped at {sat:g} °/s (its peak value repeated on separate peaks, within "
              f"5 % of that common full scale): declare --gyro-range {sat:g} if that is the sensor's range")


def _is_semicolon(path) -> bool:
    """True if the log's first line is ';'-separated (the two-header-line layout of
    :func:`imutherm.imu.reference_log.read_semicolon_log`). Only the first bytes are looked at, undecoded: a file
    that is not UTF-8 (UTF-16, binary) is not ';'-separated here and is refused by the comma reader, in one line."""
    import gzip
    from pathlib import Path

    p = Path(path)
    try:
        with (gzip.open(p, "rb") if p.suffix == ".gz" else p.open("rb")) as fh:
            head = fh.read(4096)
    except (OSError, EOFError) as exc:
        raise InputError(f"{path}: cannot be read ({getattr(exc, 'strerror', None) or exc})") from None
    if b"\0" in head:  # UTF-16/32 text or binary: not this layout
        return False
    return b";" in head.split(b"\n", 1)[0]


def _is_reference_layout(path) -> bool:
    """A reference log with its own reader: a BROAD HDF5 trial (``.hdf5`` / ``.h5``) or the ';' layout."""
    from pathlib import Path

    return Path(path).suffix.lower() in (".hdf5", ".h5") or _is_semicolon(path)


def _run_reference(args) -> int:
    """A reference log (';'-separated RepoIMU layout or a BROAD HDF5 trial): repeats and true times, the
    reference-to-IMU rotation (estimated for RepoIMU, the data set's for BROAD), inclination scores."""
    from imutherm.imu.filters import FusionParams
    from imutherm.studies.attitude.real_benchmark import run_reference_log
    from imutherm.imu.filters.registry import parse_filters

    if args.init_s is not None and not (np.isfinite(args.init_s) and args.init_s > 0):
        raise InputError(f"--init-s must be a positive number of seconds, got {args.init_s}")
    if args.platform != "handheld" or args.lever_arm or args.turn_radius or args.axes or args.gyro_units \
            or args.accel_units or args.align not in ("none", "auto") or args.gyro_sample or args.max_gap:
        raise InputError("a reference log (';'-separated or BROAD HDF5) is read in its own units (m/s², rad/s) and "
                         "run as --platform handheld; valid: drop --platform/--lever-arm/--turn-radius/--axes/"
                         "--*-units/--gyro-sample/--max-gap/--align (its rotation is estimated or the data set's)")
    res = run_reference_log(args.imu_csv, names=parse_filters(args.filters, gnss=False), init_s=args.init_s,
                            fusion=FusionParams(gyroscope_range=args.gyro_range))
    with atomic_outdir(args.out) as tmp:
        write_json(tmp / "attitude.json", res)
    al = res["alignment"]
    rot = (f"reference->IMU rotation ({al['mode']}) {al['angle_deg']:.1f}°"
           + (f" (residuals: rate {al['rate_resid_deg']:.1f}°, vertical {al['vertical_resid_deg']:.2f}°)"
              if al["rate_resid_deg"] is not None else ""))
    print(f"{res['source']} ({res['layout']}): {res['rows']} rows, {res['sample_and_hold_repeats']} sample-and-hold "
          f"repeats kept as the time base (held samples interpolated) and {res['repeated_times']} repeated times "
          f"dropped (true step median {1e3 * res['true_step_median_s']:.1f} ms; filters on a "
          f"{1e3 * res['grid_step_s']:.1f} ms grid from the true times); rest window {res['init_s']:g} s; reference "
          f"rows missing {res['reference_rows_missing']}, scored {res['reference_rows_scored']} ({res['scored']}); "
          f"{rot}")
    from imutherm.imu.filters.registry import gyro_range_filters

    if gyro_range_filters(res["filters"]):
        _print_fusion_range(res["fusion"])
    for name, m in res["filters"].items():
        here = "" if m["x_vqf"] is None else f" ({m['x_vqf']:.2f}x VQF)"
        dev = ("" if m["dev_cv_worst_x_vqf"] is None else
               f"  development files (cross-validated): mean {m['dev_cv_mean_x_vqf']:.2f}x VQF, worst file "
               f"{m['dev_cv_worst_x_vqf']:.2f}x")
        print(f"{name:8s} inclination rms {m['inclination_rms_deg']:.3f} deg{here}  max {m['inclination_max_deg']:.2f} "
              f"deg  accelerometer used on {100 * m['accel_used_fraction']:.1f} % of samples  runtime "
              f"{m['runtime_s']:.2f} s{dev}")
        print_divergence(name, m["resets_s"], m["rest_off_deg"], m["motion_check"])
    return 0
