"""Benchmark: ``imutherm compare`` on a user's imported board against the reference unit, paired in one run.

Imports a shared board of ``examples/boards`` (default drone-fc: KiCad 5, 78 footprints, its powers and heights
files, the ICM-20689 as the site) as a user does, then runs ``imutherm compare`` at its defaults on the reference
unit and on the imported unit, one after the other (``--pairs N`` alternates the order N times), each a
subprocess: wall time, CPU seconds of the command and its workers (the load-independent cost) and the peak
resident memory of the process tree (summed VmRSS, sampled every 0.2 s from /proc, as bench_study.py). Prints
each run, the ratios imported / reference and PASS/FAIL against the target (issue 56: within 2x in time and
memory). The machine is shared: give the load beside the figures (printed).

    python benchmarks/bench_user_unit.py                        # drone-fc, compare at its defaults
    python benchmarks/bench_user_unit.py --board openuav        # another shared board
    python benchmarks/bench_user_unit.py --board proves-fc-v4c  # the 151-footprint one (issue 59's target)
    python benchmarks/bench_user_unit.py -- --seeds 1           # extra arguments for both compare runs
    python benchmarks/bench_user_unit.py --write                # and record docs/benchmarks/tables/user_unit.txt
"""

from __future__ import annotations

import argparse
import gzip
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _record  # noqa: E402
from bench_study import _tree_memory_mb  # noqa: E402

BOARDS = Path(__file__).resolve().parents[1] / "examples" / "boards"
#: the import of each shared board as a user gives it: (extra files, site)
IMPORTS = {"drone-fc": (["--heights", "drone-fc_heights.csv"], "U2=imu"),
           "openuav": (["--heights", "openuav_heights.csv", "--electrical", "openuav_electrical.toml"], "U3=imu"),
           # issue 59's "shared 150-footprint board" (151 footprints, 88 x 94.5 mm; no heights file: the defaults)
           "proves-fc-v4c": ([], "U7=imu")}
TARGET_RATIO = 2.0


def _children_cpu_s() -> float:
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_measured(cmd: list, cwd: Path) -> dict:
    """Run ``cmd``; its wall time [s], CPU seconds (it and its workers) and the tree's peak summed VmRSS [MB]."""
    cpu0, start = _children_cpu_s(), time.perf_counter()
    proc = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    peak = 0.0
    while proc.poll() is None:
        peak = max(peak, _tree_memory_mb(proc.pid)[0])
        time.sleep(0.2)
    out = proc.stdout.read()
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{out[-3000:]}")
    return {"wall_s": time.perf_counter() - start, "cpu_s": _children_cpu_s() - cpu0, "peak_mb": peak, "out": out}


def import_board(name: str, folder: Path) -> tuple:
    """(layout path, footprints, seconds) of the shared board ``name`` imported into ``folder``."""
    extra, site = IMPORTS[name]
    board = folder / f"{name}.kicad_pcb"
    board.write_bytes(gzip.decompress((BOARDS / f"{name}.kicad_pcb.gz").read_bytes()))
    args = [a if not a.endswith((".csv", ".toml")) else str(BOARDS / a) for a in extra]
    cmd = [sys.executable, "-m", "imutherm.cli", "import", str(board), "--powers", str(BOARDS / f"{name}_powers.csv"),
           *args, "--site", site, "--out", str(folder / f"{name}.toml")]
    r = run_measured(cmd, folder)
    footprints = next(int(line.split()[0]) for line in r["out"].splitlines() if " footprints:" in line)
    return folder / f"{name}.toml", footprints, r


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--board", default="drone-fc", choices=sorted(IMPORTS))
    p.add_argument("--pairs", type=int, default=1, help="reference/imported pairs, the order alternating (default 1)")
    p.add_argument("extra", nargs="*", help="after --: extra arguments for both imutherm compare runs")
    args = p.parse_args()
    print(f"load average {' '.join(f'{v:.2f}' for v in os.getloadavg())} on {os.cpu_count()} CPUs at the start")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        layout, footprints, imp = import_board(args.board, folder)
        print(f"import {args.board} ({footprints} footprints): {imp['wall_s']:.1f} s wall, {imp['cpu_s']:.1f} CPU-s, "
              f"{imp['peak_mb']:.0f} MB")
        runs = {"reference": [], "imported": []}
        for i in range(args.pairs):
            order = ("reference", "imported") if i % 2 == 0 else ("imported", "reference")
            for which in order:
                # an imported board runs the schemes its import made (compare's default: the layout's own)
                target = [] if which == "reference" else [str(layout)]
                out = folder / f"out_{which}_{i}"
                r = run_measured([sys.executable, "-m", "imutherm.cli", "compare", *target, "--no-progress",
                                  *args.extra, "--out", str(out)], folder)
                runs[which].append(r)
                print(f"{which:<9} pair {i}: {r['wall_s']:6.1f} s wall, {r['cpu_s']:6.1f} CPU-s, "
                      f"{r['peak_mb']:5.0f} MB peak (load {os.getloadavg()[0]:.2f})")
    ok = True
    for key, label in (("wall_s", "wall time"), ("cpu_s", "CPU seconds"), ("peak_mb", "peak memory")):
        ref = sum(r[key] for r in runs["reference"]) / args.pairs
        imp_ = sum(r[key] for r in runs["imported"]) / args.pairs
        ratio = imp_ / ref
        ok &= ratio <= TARGET_RATIO or key == "wall_s"   # the wall time is the load's; CPU-s is the cost
        print(f"{label:<12} imported / reference = {imp_:.1f} / {ref:.1f} = {ratio:.2f}x  "
              f"(target <= {TARGET_RATIO:g}x: {'PASS' if ratio <= TARGET_RATIO else 'FAIL'})")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(_record.run(main, "user_unit", "imutherm compare on an imported shared board against the reference unit"))
