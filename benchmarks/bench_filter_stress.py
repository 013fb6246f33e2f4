"""Benchmark (not a test): the attitude filters on the stress set of issue 57 (:mod:`imutherm.studies.attitude.filter_stress`),
judged by their worst record as well as their mean.

Usage::

    python benchmarks/bench_filter_stress.py [--quick] [--filters a,b,...] [--write]

Records: simulated slow tumbles (5-20 °/s through upside down, both verticals, on the side, full turns; rests of
0.5-10 min; 100-1000 Hz; the adis16355 and adis16488 grades of imu/grades.py and the bmi160 and icm42688p parts of
its sensor library; one with a 1 % gyro scale-factor / misalignment error and a 0.5 °/s bias step, one with ten
times its grade's accelerometer bias) and the three BROAD development trials transformed (mounted upside down / on
a side / nose up and started there, forward-then-reversed twice: 12 min, re-cut to 100 and 1000 Hz). Every
filter at the handheld settings of ``imutherm attitude --imu-csv`` (studies/attitude/real_settings.toml, tuned on the nine
development files); in a git worktree away from ../shared/data set IMUTHERM_SHARED_DATA to that folder. Prints
inclination RMS [deg] per record and filter, the aekf's reported NIS resets, each filter's mean x VQF and worst
file x VQF. The BROAD records are
development data (the settings were tuned on these trials, untransformed); the simulated ones were not tuned on.
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
from imutherm.studies.attitude.filter_stress import (STRESS_FILTERS, format_stress_table, stress_records,  # noqa: E402
                                            stress_table)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one simulated and two transformed records")
    ap.add_argument("--filters", default=",".join(STRESS_FILTERS), help="filters (VQF is always added)")
    a = ap.parse_args()
    t0 = time.perf_counter()
    recs = stress_records(quick=a.quick)
    t = stress_table(recs, tuple(a.filters.split(",")))
    print(format_stress_table(t))
    print()
    for n in t.rms:
        print(f"{n}: mean {t.mean_x_ref[n]:.2f}x VQF, worst {t.worst_x_ref[n]:.2f}x VQF ({t.worst_file[n]})")
    print(f"\n{len(recs)} records, {time.perf_counter() - t0:.0f} s wall, load {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(_record.run(main, "filter_stress", "the attitude filters on the stress set (issue 57)"))
