"""Peak resident memory of each stage of one scheme's thermal case, as a study worker runs it (issue 59 item 3).

``imutherm compare``'s peak is the sum over its processes (``bench_study.py``); this says which stage of a worker
holds it. One scheme's :func:`~imutherm.studies.end_to_end.thermal.thermal_case` (steady Newton solve, reduced
power-on transient, oven self-heating, mesh-error estimate's refined solve) runs in this process while a thread reads
its VmRSS from /proc every 0.05 s; each stage's peak is printed [MB]. Linux only (/proc).

    python benchmarks/bench_thermal_case_memory.py                 # air (the s2s cavity), default mesh
    python benchmarks/bench_thermal_case_memory.py --scheme potted
"""

from __future__ import annotations

import argparse
import os
import sys
import threading
import time


def rss_mb() -> float:
    """This process's resident memory [MB] (VmRSS of /proc/self/status)."""
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    raise OSError("no VmRSS in /proc/self/status")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--scheme", default="air")
    args = ap.parse_args(argv)
    import imutherm.studies.end_to_end.thermal as case_mod
    import imutherm.studies.thermal.thermal_study as study_mod
    from imutherm.geometry.layout import load_layout
    from imutherm.studies.end_to_end.config import StudyConfig
    from imutherm.unit.model import ModelOptions

    stage, peaks, order = ["set-up (geometry, mesh, view factors, assembly)"], {}, []

    def record():
        r, s = rss_mb(), stage[-1]
        if s not in peaks:
            order.append(s)
        peaks[s] = max(peaks.get(s, 0.0), r)

    def sample():
        while True:
            record()
            time.sleep(0.05)

    def labelled(mod, name, label):   # the stage functions as thermal_case calls them, with a label; also read at
        f = getattr(mod, name)        # each stage's start and end (a long call that holds the GIL starves the thread)

        def g(*a, **kw):
            stage.append(label)
            record()
            try:
                return f(*a, **kw)
            finally:
                record()
                stage.append(f"(after {label})")
        setattr(mod, name, g)
    labelled(study_mod, "solve_steady", "steady Newton solve")
    labelled(study_mod, "_reduced_transient", "reduced power-on transient")
    labelled(case_mod, "self_heating_table", "oven self-heating")
    labelled(case_mod, "with_mesh_error", "mesh-error estimate (refined solve)")
    threading.Thread(target=sample, daemon=True).start()
    time.sleep(0.1)
    t0, load0 = time.perf_counter(), os.getloadavg()[0]
    case_mod.thermal_case(load_layout(None), args.scheme, ModelOptions(), StudyConfig().chamber_C, t_end=2400.0,
                          until_settled=True, transient_model="reduced", estimate_mesh_error=True)
    stage.append("done (result kept)")
    time.sleep(0.2)
    print(f"thermal case of the reference unit's {args.scheme} scheme: {time.perf_counter() - t0:.1f} s wall, load "
          f"{load0:.1f} -> {os.getloadavg()[0]:.1f}; peak resident memory per stage [MB]:")
    for s in order:
        print(f"  {s:<42} {peaks[s]:7.0f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
