"""Benchmark (not a test): every attitude filter and peer on the six RepoIMU pendulum recordings.

Usage::

    python benchmarks/bench_repoimu.py [--filters a,b,...] [--data DIR] [--json FILE]

Scoring (:mod:`imutherm.studies.real_benchmark`): inclination error (the angle between the estimated and
the optical vertical) after the first 5 s, the fixed reference-to-IMU rotation estimated from the reference
and the raw sensor, sample-and-hold repeats dropped and the true samples put on a uniform grid. Prints the
RMS [deg] per file and the mean; issue 24's target: gated, kf, aekf each <= 1.3x VQF's mean and <= 2x VQF on
every file. Data: Szczęsna et al., ICCVG 2016, LNCS 9972, pp. 509-520, doi:10.1007/978-3-319-46418-3_45.
"""

from __future__ import annotations

import argparse
import json
import time


def main() -> None:
    from imutherm.studies import real_benchmark as rb
    from imutherm.studies.recorded import LOG_FILTERS

    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--filters", default=",".join(LOG_FILTERS))
    ap.add_argument("--data", default=str(rb.DATA_DIR))
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    names = a.filters.split(",")
    t0 = time.perf_counter()
    recs = rb.load_all(a.data)
    for r in recs:
        print(f"{r.name}: {r.n_rows} rows, {r.n_repeats} sample-and-hold repeats, {r.n_dup_time} repeated times; "
              f"true step median {1e3 * r.step_median_true:.1f} ms, grid {1e3 * r.dt:.1f} ms; reference->IMU "
              f"{r.align.angle_deg:.1f}° (fit residuals: rate {r.align.rate_resid_deg:.1f}°, "
              f"vertical {r.align.up_resid_deg:.2f}°)")
    tab = rb.table(names, recs)
    short = [r.name.replace("Pendulum_Test", "").replace("_Trial1_Segment_", "/") for r in recs]
    print("\ninclination RMS after 5 s [deg]")
    print(f"{'filter':9s} " + " ".join(f"{s:>7s}" for s in short) + f" {'mean':>7s} {'x VQF':>6s} {'worst':>6s}"
          f" {'acc used':>8s}")
    vq = tab.get("vqf")
    for n in names:
        f = tab[n]["files"]
        rms = [f[r.name]["rms_deg"] for r in recs]
        ratio = worst = float("nan")
        if vq:
            ratio = tab[n]["mean_rms_deg"] / vq["mean_rms_deg"]
            worst = max(f[r.name]["rms_deg"] / vq["files"][r.name]["rms_deg"] for r in recs)
        used = sum(f[r.name]["accel_used_fraction"] for r in recs) / len(recs)
        print(f"{n:9s} " + " ".join(f"{v:7.2f}" for v in rms) + f" {tab[n]['mean_rms_deg']:7.2f} {ratio:6.2f} "
              f"{worst:6.2f} {100 * used:7.1f}%")
    print(f"wall {time.perf_counter() - t0:.1f} s")
    if a.json:
        with open(a.json, "w", encoding="utf-8") as fh:
            json.dump(tab, fh, indent=1)


if __name__ == "__main__":
    main()
