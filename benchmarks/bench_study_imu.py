"""Time and peak memory of the IMU side of ``imutherm compare`` (the figures behind its cost estimate).

Runs :func:`imutherm.studies.end_to_end.imu_case` (one scheme, one seed: two calibrations, every profile
in both phases, every compensation and filter) in a fresh subprocess on site curves shaped like the
reference unit's (a 10 K first-order rise with a 300 s time constant at 70 °C ambient) and reports its wall
time per filter-sample (one attitude filter over one motion sample) and its peak resident memory above
the interpreter's base per motion sample of the longest profile. A line through the wall times of a few
configurations gives the time per filter-sample and the fixed time per case (the calibration) that
``imutherm.studies.cost.SECONDS_PER_FILTER_SAMPLE`` and ``SECONDS_PER_CASE`` are rounded up from, the memory
``BYTES_PER_SAMPLE_STUDY``; each run prints the estimate of :func:`imutherm.studies.cost.check_study_cost` beside.

    python benchmarks/bench_study_imu.py [--profiles flight,swing] [--filters A,B,...]

(``--filters`` default: the registry's study filters, those ``imutherm compare`` runs.)
"""

import argparse
import json
import subprocess
import sys

CHILD = r"""
import json, resource, sys, time
import numpy as np
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
from imutherm.studies.cost import check_study_cost
from imutherm.studies.end_to_end import StudyConfig, bare_calibration, imu_case
cfg = StudyConfig(profiles=tuple(sys.argv[1].split(",")), filters=tuple(sys.argv[2].split(",")), seeds=1)
t = np.linspace(0.0, 3000.0, 301)
T = 70.0 + 10.0 * (1.0 - np.exp(-t / 300.0))[:, None] * np.linspace(0.8, 1.2, 6)[None, :]
steady = T[-1]
chamber = np.array([-40.0, 70.0]); rise = np.array([steady - 70.0 + 3.0, steady - 70.0])
bare = bare_calibration(cfg.grade, 0)
import imutherm.studies.attitude.attitude_study, imutherm.imu.compensation  # imports outside the timing
base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
t0 = time.perf_counter()
imu_case(cfg.grade, 0, t, T, steady, chamber, rise, cfg, bare)
wall = time.perf_counter() - t0
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
work = check_study_cost(cfg, 1, 1, 1e15)
print(json.dumps({"wall_s": wall, "base": base, "peak": peak, **work}))
"""


def main():
    from imutherm.imu.filters.registry import study_filters

    ap = argparse.ArgumentParser()
    ap.add_argument("--profiles", default="flight,swing")
    ap.add_argument("--filters", default=",".join(study_filters()))
    args = ap.parse_args()
    p = subprocess.run([sys.executable, "-c", CHILD, args.profiles, args.filters], capture_output=True, text=True)
    if p.returncode:
        sys.exit(p.stderr)
    r = json.loads(p.stdout.strip().splitlines()[-1])
    print(f"imu_case (1 scheme, 1 seed; profiles {args.profiles}; filters {args.filters}): {r['wall_s']:.1f} s, "
          f"{r['filter_samples']:,} filter-samples -> {r['wall_s'] / r['filter_samples'] * 1e6:.1f} us each")
    print(f"peak {r['peak'] / 2**20:.0f} MiB, {(r['peak'] - r['base']) / 2**20:.0f} MiB above the imports: "
          f"{(r['peak'] - r['base']) / r['longest_samples']:.0f} bytes per sample of the longest profile "
          f"({r['longest_samples']:,} samples)")
    print(f"estimate of imutherm.studies.cost.check_study_cost: {r['seconds']:.1f} s")


if __name__ == "__main__":
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "study_imu", "the IMU side of imutherm compare"))
