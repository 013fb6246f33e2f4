"""Benchmark of the attitude filters (not a test): accuracy targets and the 1-hour runtime target.

Usage::

    python benchmarks/bench_attitude.py [--seeds 6] [--skip-accuracy] [--skip-speed] [--profiles flight,...]

1. Accuracy: ``flight`` profile, adis16355 grade, improved compensation, constant
   25 °C, seeds 0..N-1 (the same chain as ``imutherm attitude``): roll / pitch RMS
   overall, stable, manoeuvre per filter, mean ± std over seeds, and the max
   over seeds. Targets: gated ≤ 1.0° overall and ≤ 0.5° stable, better than
   ``ungated`` and ``fusion``.
2. Speed: a 3600 s flight at 100 Hz (360 000 samples) through every filter;
   target ≤ 10 s for all filters together (the peer's time reported beside).
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def accuracy(profile: str, seeds: int) -> None:
    from imutherm.studies.attitude_study import run_attitude_study

    t0 = time.perf_counter()
    res = run_attitude_study(profile, grade="adis16355", temperature_C=25.0, compensation="improved", seeds=seeds)
    print(f"\n== accuracy: profile={profile}, adis16355, improved, 25 °C, seeds 0..{seeds - 1} "
          f"({res.duration_s:.0f} s each; {time.perf_counter() - t0:.1f} s wall)")
    print(f"{'filter':8s} {'segment':10s} {'roll rms':>16s} {'pitch rms':>16s} {'roll max':>9s} {'pitch max':>9s}")
    for name, m in res.metrics.items():
        for seg in ("overall", "stable", "manoeuvre"):
            v = m[seg]
            if v["roll_rms_deg"] is None:
                continue
            print(f"{name:8s} {seg:10s} {v['roll_rms_deg']['mean']:7.3f} ±{v['roll_rms_deg']['std']:6.3f}  "
                  f"{v['pitch_rms_deg']['mean']:7.3f} ±{v['pitch_rms_deg']['std']:6.3f}  "
                  f"{v['roll_max_deg']['mean']:8.2f} {v['pitch_max_deg']['mean']:8.2f}")


def speed(duration: float = 3600.0) -> None:
    from imutherm.imu import motion
    from imutherm.imu.calibration import calibrate_unit
    from imutherm.imu.compensation import compensate
    from imutherm.imu.sensor_model import draw_unit, simulate_imu
    from imutherm.studies.attitude_study import DEFAULT_LEVER_ARM, run_filters

    t0 = time.perf_counter()
    d = DEFAULT_LEVER_ARM["flight"]
    tr = motion.flight_profile(duration, 100.0, lever_arm=d)
    t_traj = time.perf_counter() - t0
    rng = np.random.default_rng(0)
    unit = draw_unit("adis16355", rng)
    cal = calibrate_unit(unit, rng)
    s = compensate(simulate_imu(unit, tr.t, tr.omega_b, tr.f_b, np.full((tr.t.size, 6), 25.0), rng), cal, "improved")
    est, _ = run_filters(s.gyro, s.accel, 0.01, d)
    print(f"\n== speed: {duration:.0f} s flight at 100 Hz = {tr.t.size} samples "
          f"(trajectory built in {t_traj:.2f} s)")
    own = 0.0
    for name, e in est.items():
        err_r = np.degrees(np.sqrt(np.mean((e.roll - tr.roll) ** 2)))
        err_p = np.degrees(np.sqrt(np.mean((e.pitch - tr.pitch) ** 2)))
        print(f"{name:8s} {e.runtime_s:6.2f} s   (roll rms {err_r:.2f}°, pitch rms {err_p:.2f}°)")
        own += e.runtime_s
    print(f"all four filters: {own:.2f} s (target <= 10 s)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=6)
    ap.add_argument("--profiles", default="flight")
    ap.add_argument("--skip-accuracy", action="store_true")
    ap.add_argument("--skip-speed", action="store_true")
    a = ap.parse_args()
    if not a.skip_accuracy:
        for p in a.profiles.split(","):
            accuracy(p, a.seeds)
    if not a.skip_speed:
        speed()


if __name__ == "__main__":
    main()
