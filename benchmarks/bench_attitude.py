"""Benchmark of the attitude filters (not a test): held-out accuracy of every filter, defaults and tuned.

Usage::

    python benchmarks/bench_attitude.py [--tuned FILE] [--out DIR] [--skip-speed] [--clean] [--ablation] [--lever-comp]

1. Records: adis16355 units (one per seed, two-step calibration, ``improved``
   compensation, 25 °C) on the training set (flight + shake, seeds 100-101) and
   the held-out set (flight, swing, vehicle, handheld; seeds 0-5), each profile with its realistic
   disturbances (``--clean``: idealised; ``--lever-comp``: every gravity-referenced filter gets the
   accelerometer with its lever-arm term removed, as ``aekf`` does itself): see :mod:`imutherm.studies.attitude.filter_benchmark` and
   :mod:`imutherm.imu.disturbances`.
2. Tuning (skipped with ``--tuned FILE`` from an earlier run): each filter by the study's one procedure
   (:mod:`imutherm.studies.attitude.filter_tuning`: the registry's tuning axes on one x3.16 ladder, an axis grown while
   the best lies on its open edge, the published defaults a candidate too) on the training records; written
   to ``DIR/tuned.json``. A filter without tuning axes (``aekf_gnss``) has no tuned row.
3. Table: filter × profile × {defaults, tuned}: roll / pitch RMS and max over
   the whole record [deg], mean ± std over the six held-out seeds; written to
   ``DIR/table.json``. Target: the table (steps 1 and 3) in <= 2 min.
4. Speed: a 3600 s flight at 100 Hz (360 000 samples) through every filter.
5. ``--ablation``: gated, kf and the tuned peers on the flight (seeds 0-5) with no disturbance, each
   disturbance alone, and all of them: what each one costs.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np


def main() -> None:
    from imutherm.imu.filters.registry import filter_names, tuned_filters
    from imutherm.studies.attitude import filter_benchmark as fb

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tuned", help="tuned.json of an earlier run (skips the tuning)")
    ap.add_argument("--out", default="out/bench_attitude")
    ap.add_argument("--filters", default=",".join(filter_names()), help="registered filters (default: every one)")
    ap.add_argument("--skip-speed", action="store_true")
    ap.add_argument("--clean", action="store_true", help="idealised records (no disturbances)")
    ap.add_argument("--lever-comp", action="store_true",
                    help="every gravity-referenced filter gets the accelerometer with its lever-arm term removed")
    ap.add_argument("--ablation", action="store_true", help="flight: each disturbance alone (after the table)")
    a = ap.parse_args()
    dist = not a.clean
    names = a.filters.split(",")
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    fb.check_split()
    t_all = time.perf_counter()
    if a.tuned:
        tuned = json.loads(Path(a.tuned).read_text())["values"]
        print(f"tuned settings from {a.tuned}")
    else:
        t0 = time.perf_counter()
        train = fb.make_records(fb.TRAIN, disturbances=dist, lever_comp=a.lever_comp)
        print(f"== tuning on {[(p, list(s)) for p, s in fb.TRAIN]} ({time.perf_counter() - t0:.1f} s to build)")
        tuned, info = {}, {}
        for n in names:
            if n not in tuned_filters():
                print(f"{n:9s} not tuned (the registry declares no tuning axes): defaults only")
                continue
            r = fb.tune(n, train)
            tuned[n] = r.values
            info[n] = {"objective_deg": r.objective, "default_objective_deg": r.default_objective,
                       "n_eval": r.n_eval, "runtime_s": r.runtime_s, "grid": r.grid, "at_bound": list(r.at_bound),
                       "chosen": r.chosen}
            vals = ", ".join(f"{k}={v:.4g}" for k, v in r.values.items())
            print(f"{n:9s} {vals:60s} train {r.default_objective:6.3f} -> {r.objective:6.3f} deg "
                  f"({r.chosen}; {r.n_eval} evals, {r.runtime_s:5.1f} s)"
                  + (f"; at bound {', '.join(r.at_bound)}" if r.at_bound else ""))
        (out / "tuned.json").write_text(json.dumps({"values": tuned, "info": info, "train": fb.TRAIN}, indent=1))
        t_all = time.perf_counter()
    t0 = time.perf_counter()
    recs = fb.make_records(fb.HELD_OUT, disturbances=dist, lever_comp=a.lever_comp)
    t_rec = time.perf_counter() - t0
    tab = fb.table(names, recs, tuned)
    t_tab = time.perf_counter() - t0
    (out / "table.json").write_text(json.dumps({"held_out": fb.HELD_OUT, "tuned": tuned, "table": tab,
                                                "disturbances": dist}, indent=1))
    print(f"\n== held-out table: {[(p, list(s)) for p, s in fb.HELD_OUT]}, adis16355, improved, 25 °C, "
          f"{'realistic disturbances' if dist else 'idealised'} "
          f"(records {t_rec:.1f} s, table {t_tab:.1f} s wall)")
    print("whole-record error [deg], mean ± std over seeds")
    print(f"{'filter':9s} {'profile':7s} {'setting':8s} {'roll rms':>14s} {'pitch rms':>14s} {'roll max':>14s} "
          f"{'pitch max':>14s}")
    for n in names:
        for prof in [p for p, _ in fb.HELD_OUT]:
            for setting, m in tab[n].get(prof, {}).items():
                row = " ".join(f"{m[k]['mean']:6.2f} ±{m[k]['std']:5.2f}" for k in
                               ("roll_rms_deg", "pitch_rms_deg", "roll_max_deg", "pitch_max_deg"))
                print(f"{n:9s} {prof:7s} {setting:8s} {row}")
    print(f"table wall time (records + filters): {time.perf_counter() - t_all:.1f} s (target <= 120 s)")
    if a.ablation:
        ablation(names, tuned)
    if not a.skip_speed:
        speed(names)


def ablation(names, tuned, seeds=tuple(range(6))) -> None:
    """Flight, held-out seeds: whole-record RMS of each filter with no / each / all disturbances."""
    from imutherm.imu import disturbances
    from imutherm.studies.attitude import filter_benchmark as fb

    P = disturbances.PRESETS["flight"]
    cases = {"none": None, "vibration": disturbances.Disturbances(vibration=P.vibration),
             "turbulence": disturbances.Disturbances(turbulence=P.turbulence),
             "wind shear + gusts": disturbances.Disturbances(wind=P.wind),
             "sync 5 ms": disturbances.Disturbances(sync_s=P.sync_s),
             "jitter 0.2 ms": disturbances.Disturbances(jitter_s=P.jitter_s),
             "all": P}
    print(f"\n== ablation: flight, seeds {list(seeds)}, roll / pitch RMS [deg] mean over seeds (tuned settings)")
    print(f"{'disturbance':20s} " + " ".join(f"{n:>13s}" for n in names))
    for label, d in cases.items():
        recs = fb.make_records([("flight", seeds)], disturbances={"flight": d} if d else False)
        cells = []
        for n in names:
            ms = [fb.score(fb.run_one(n, r, tuned.get(n)), r) for r in recs]
            cells.append(f"{np.mean([m['roll_rms_deg'] for m in ms]):5.2f} /{np.mean([m['pitch_rms_deg'] for m in ms]):5.2f}")
        print(f"{label:20s} " + " ".join(f"{c:>13s}" for c in cells), flush=True)


def speed(names, duration: float = 3600.0) -> None:
    from imutherm.imu import motion
    from imutherm.imu.calibration import calibrate_unit
    from imutherm.imu.compensation import compensate
    from imutherm.imu.sensor_model import draw_unit, simulate_imu
    from imutherm.imu.filters.run import run_filters
    from imutherm.imu.motion import DEFAULT_LEVER_ARM

    d = DEFAULT_LEVER_ARM["flight"]
    tr = motion.flight_profile(duration, 100.0, lever_arm=d)
    rng = np.random.default_rng(0)
    unit = draw_unit("adis16355", rng)
    cal = calibrate_unit(unit, rng)
    s = compensate(simulate_imu(unit, tr.t, tr.omega_b, tr.f_b, np.full((tr.t.size, 6), 25.0), rng), cal, "improved")
    est, _ = run_filters(s.gyro, s.accel, 0.01, d, names=names)
    print(f"\n== speed: {duration:.0f} s flight at 100 Hz = {tr.t.size} samples")
    for name, e in est.items():
        print(f"{name:9s} {e.runtime_s:6.2f} s")
    print(f"all: {sum(e.runtime_s for e in est.values()):.2f} s")


if __name__ == "__main__":
    import sys

    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "attitude", "the attitude filters, fairly"))
