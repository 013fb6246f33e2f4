"""Benchmark (not a test): our filters on the simulated profiles with realistic disturbances, defaults.

Usage::

    python benchmarks/bench_attitude_profiles.py [--seeds 3] [--filters A,B,...] [--json FILE]

``--filters`` default: ours without GNSS (the registry's kind 'ours': gated, kf, ungated, aekf). Each of
``flight``, ``swing``, ``vehicle``, ``handheld`` (their default durations, adis16355, ``improved``
compensation, 25 °C, ``--disturbances realistic``), seeds 0..seeds-1, through :func:`run_attitude_study`:
the whole-record roll and pitch RMS [deg], mean over the seeds. The guard: after the filters were
changed for real motion, no profile may be worse than before by more than 10 %.
"""

from __future__ import annotations

import argparse
import json
import time


def main() -> None:
    from imutherm.imu.filters.registry import filter_names
    from imutherm.studies.attitude.attitude_study import run_attitude_study

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--filters", default=",".join(filter_names(gnss=False, kind="ours")))
    ap.add_argument("--profiles", default="flight,swing,vehicle,handheld")
    ap.add_argument("--json", default=None, help="write the table here")
    a = ap.parse_args()
    names = tuple(a.filters.split(","))
    out = {}
    print(f"{'profile':9s} " + " ".join(f"{n:>15s}" for n in names) + "   (roll / pitch RMS [deg], mean over seeds)")
    for prof in a.profiles.split(","):
        t0 = time.perf_counter()
        r = run_attitude_study(prof, seeds=a.seeds, names=names, disturbances=True)
        out[prof] = {n: {k: r.metrics[n]["overall"][k]["mean"] for k in ("roll_rms_deg", "pitch_rms_deg")}
                     for n in names}
        cells = [f"{out[prof][n]['roll_rms_deg']:6.3f} /{out[prof][n]['pitch_rms_deg']:6.3f}" for n in names]
        print(f"{prof:9s} " + " ".join(f"{c:>15s}" for c in cells) + f"   ({time.perf_counter() - t0:.0f} s)",
              flush=True)
    if a.json:
        with open(a.json, "w", encoding="utf-8") as fh:
            json.dump({"seeds": a.seeds, "table": out}, fh, indent=1)


if __name__ == "__main__":
    main()
