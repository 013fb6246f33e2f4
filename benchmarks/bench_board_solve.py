"""Benchmark: the steady solve of real shared boards, as they are, against the reference unit's, paired.

Each board of ``examples/boards/`` named by ``--boards`` (default: cube-main, 244 footprints, a 150 x 120 mm
4-layer KiCad 5 board, the largest shared one; proves-fc-v4c, 151 footprints, 88 x 94.5 mm with slots and
notches in its outline) is imported as a user imports it (``imutherm import BOARD --powers P.csv --site
REF=KIND``, no heights given: each part's height comes from the board file, the package tables or the stated
estimate), so its true outline, measured copper and via fields are in the model (issue 55 item 4). Then ``imutherm solve --scheme air`` (steady) runs on the
reference unit and on each board, interleaved (reference, boards, ``--repeat`` times) so a drift of the
machine's speed hits both sides alike; ratios are of the medians. Target (issue 55): within 3x the reference
unit's wall time and CPU seconds.

    python benchmarks/bench_board_solve.py                     # ~5 min on 2 idle cores
    python benchmarks/bench_board_solve.py --boards cube-main --repeat 2
"""

from __future__ import annotations

import argparse
import gzip
import json
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BOARDS = ROOT / "examples" / "boards"
sys.path.insert(0, str(Path(__file__).resolve().parent))
import _record  # noqa: E402  (benchmarks/_record.py)
from bench_import import run  # noqa: E402

SOLVE_RATIO = 3.0
#: each board's sensor site, as tests/test_import_boards.py imports it
SITES = {"cube-main": "U9=probe", "proves-fc-v4c": "U7=imu", "proves-radio-stick": "U18=probe",
         "unl-core-board": "U5=imu"}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--boards", nargs="+", default=["cube-main", "proves-fc-v4c"], choices=sorted(SITES))
    ap.add_argument("--repeat", type=int, default=1, help="interleaved runs of each solve (medians reported)")
    args = ap.parse_args(argv)
    work = Path(tempfile.mkdtemp(prefix="bench_board_solve_"))
    imu = [sys.executable, "-m", "imutherm.cli"]
    layouts = {"reference": "imu_reference"}
    for name in args.boards:
        (work / f"{name}.kicad_pcb").write_bytes(gzip.decompress((BOARDS / f"{name}.kicad_pcb.gz").read_bytes()))
        cmd = imu + ["import", f"{name}.kicad_pcb", "--powers", str(BOARDS / f"{name}_powers.csv"),
                     "--site", SITES[name], "--out", f"{name}.toml"]
        r = run(cmd, work)
        layouts[name] = str(work / f"{name}.toml")
        lines = r["out"].splitlines()
        summary = next((line for line in lines if "footprints:" in line), "")
        copper = next((line for line in lines if "copper coverage measured" in line), "")
        print(f"import {name}: {r['wall']:.2f} s wall, {r['cpu']:.2f} CPU-s; {summary.strip()}")
        if copper:
            print(f"  {copper.strip()[:200]}")
    results = {}
    for i in range(args.repeat):
        for name in layouts:
            r = run(imu + ["solve", layouts[name], "--scheme", "air", "--out", f"solve_{name}_{i}"], work)
            results.setdefault(name, []).append(r)
            print(f"[{i + 1}/{args.repeat}] solve {name}: {r['wall']:.1f} s wall, {r['cpu']:.1f} CPU-s, "
                  f"{r['mb']:.0f} MB peak", flush=True)
    ok = True
    print(f"\n{'unit':<16} {'wall [s]':>9} {'CPU [s]':>8} {'peak [MB]':>10} {'x ref wall':>10} {'x ref CPU':>9} "
          f"{'x ref MB':>8}  target  mesh")
    for name, runs in results.items():
        med, ratios = _record.paired(runs, results["reference"])
        passed = name == "reference" or (ratios[0] <= SOLVE_RATIO and ratios[1] <= SOLVE_RATIO)
        ok &= passed
        mesh = json.loads((work / f"solve_{name}_0" / "result.json").read_text())["mesh"]
        verdict = "" if name == "reference" else f"<= {SOLVE_RATIO:g}x {'PASS' if passed else 'FAIL'}"
        print(f"{name:<16} {med['wall']:9.1f} {med['cpu']:8.1f} {med['mb']:10.0f} {ratios[0]:10.2f} {ratios[1]:9.2f} "
              f"{ratios[2]:8.2f}  {verdict:<11} {mesh['cells']:,} cells")
    print(f"\n{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} at the end; work folder {work}")
    return 0 if ok else 1


if __name__ == "__main__":
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "board_solve",
                         "real shared boards as they are: steady solves against the reference unit's, paired"))
