"""Benchmark (not a test): the attitude filters on the stress set of issue 57 (:mod:`imutherm.studies.attitude.filter_stress`),
judged by their worst record as well as their mean.

Usage::

    python benchmarks/bench_filter_stress.py [--quick] [--filters a,b,...] [--write]

Records: simulated slow tumbles (5-20 °/s through upside down, both verticals, on the side, full turns; rests of
0.5-10 min; 100-1000 Hz; the adis16355 and adis16488 grades of imu/grades.py and the bmi160 and icm42688p parts of
its sensor library; one with a 1 % gyro scale-factor / misalignment error and a 0.5 °/s bias step, one with ten
times its grade's accelerometer bias, one at 30 °/s without rests, above the rate gate's 25.6 °/s) and the three BROAD development trials transformed (mounted upside down / on
a side / nose up and started there, forward-then-reversed twice: 12 min, re-cut to 100 and 1000 Hz). Every
filter at the handheld settings of ``imutherm attitude --imu-csv`` (studies/attitude/real_settings.toml, tuned on the nine
development files); in a git worktree away from ../shared/data set IMUTHERM_SHARED_DATA to that folder. Prints
inclination RMS [deg] per record and filter, the aekf's reported NIS resets, each filter's mean x VQF and worst
file x VQF, and the in-motion divergence check's flagged windows (imu/filters/motion_check.py). The BROAD records are
development data (the settings were tuned on these trials, untransformed); the simulated ones were not tuned on;
the held-out family (hand-held tours about random axes, studies/attitude/filter_stress.py HELDOUT_CASES) was defined before
any of it was run and first run by this benchmark (issue 57). Each group is summarised on its own.
Data: Laidig, Caruso, Cereatti, Seel, Data 6 (7), 72, 2021, doi:10.3390/data6070072 (BROAD, CC BY 4.0).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import _record  # noqa: E402
import numpy as np  # noqa: E402
from imutherm.studies.attitude.filter_stress import (DEV_CASES, HELDOUT_CASES, STRESS_FILTERS,  # noqa: E402
                                                     format_stress_table, stress_records, stress_table)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one simulated and two transformed records")
    ap.add_argument("--filters", default=",".join(STRESS_FILTERS), help="filters (VQF is always added)")
    a = ap.parse_args()
    t0 = time.perf_counter()
    recs = stress_records(quick=a.quick, heldout=True)
    t = stress_table(recs, tuple(a.filters.split(",")))
    print(format_stress_table(t))
    dev = {c[0] for c in DEV_CASES}
    held = {c[0] for c in HELDOUT_CASES}
    groups = (("simulated, never tuned on", [i for i, x in enumerate(t.labels) if x not in dev | held]),
              ("BROAD development trials transformed (development)", [i for i, x in enumerate(t.labels) if x in dev]),
              ("held-out family (first run here)", [i for i, x in enumerate(t.labels) if x in held]),
              ("all", list(range(len(t.labels)))))
    for title, idx in groups:
        if not idx:
            continue
        print(f"\n{title}: {len(idx)} records")
        ref = np.array([t.rms["vqf"][i] for i in idx])
        for n in t.rms:
            r = np.array([t.rms[n][i] for i in idx])
            k = int(np.argmax(r / ref))
            flags = sum(t.motion[n][i][0] for i in idx)
            wins = sum(t.motion[n][i][1] for i in idx)
            print(f"  {n}: mean {r.mean() / ref.mean():.2f}x VQF, worst {r[k] / ref[k]:.2f}x VQF "
                  f"({t.labels[idx[k]]}); motion check: {flags} of {wins} windows flagged on "
                  f"{sum(1 for i in idx if t.motion[n][i][0])} record(s)")
    print(f"\n{len(recs)} records, {time.perf_counter() - t0:.0f} s wall, load {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(_record.run(main, "filter_stress", "the attitude filters on the stress set (issue 57)"))
