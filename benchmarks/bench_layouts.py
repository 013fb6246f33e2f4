"""Steady rises of the two built-in units, every scheme, at the default mesh and model options.

    python benchmarks/bench_layouts.py [--write]

Runs ``imutherm solve LAYOUT --scheme S --out DIR`` for ``imu_reference`` and ``imu_cardguide`` in each of
``air``, ``grease`` and ``potted`` (six fresh processes, one after the other) and prints, from each run's
``result.json``, the nodes, the power, the maximum rise over the ambient and where it is, the rise of ``tp1``
(the main board under the 5 V regulator), the six sensor dies' rises (lowest and highest), the spread inside
the gyro and the accelerometer triads, and the command's wall and CPU seconds. With ``--write`` the printout is
``docs/benchmarks/tables/layouts.txt``, included by ``docs/reference/layouts.md`` (its one copy).
"""

import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

LAYOUTS = ("imu_reference", "imu_cardguide")
SCHEMES = ("air", "grease", "potted")
SENSORS = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
CODE = "import sys; from imutherm.cli import main; sys.exit(main(sys.argv[1:]))"


def _cpu_children() -> float:
    use = resource.getrusage(resource.RUSAGE_CHILDREN)
    return use.ru_utime + use.ru_stime


def solve(layout: str, scheme: str, out: Path) -> tuple:
    """One ``imutherm solve`` in a fresh process: (result.json as a dict, wall s, CPU s)."""
    t, cpu = time.perf_counter(), _cpu_children()
    subprocess.run([sys.executable, "-c", CODE, "solve", layout, "--scheme", scheme, "--out", str(out)],
                   check=True, stdout=subprocess.DEVNULL)
    wall, cpu = time.perf_counter() - t, _cpu_children() - cpu
    return json.loads((out / "result.json").read_text(encoding="utf-8")), wall, cpu


def row(layout: str, scheme: str, res: dict, wall: float, cpu: float) -> str:
    sensors = [res["sites"][s]["rise_K"] for s in SENSORS]
    return (f"| {layout} | {scheme} | {res['unknowns']:,} | {res['power_W']:.2f} | {res['max_rise_K']:.2f} "
            f"({res['hottest_part']}) | {res['sites']['tp1']['rise_K']:.2f} | {min(sensors):.2f}-{max(sensors):.2f} "
            f"| {res['gyro_spread_K']:.2f} / {res['accel_spread_K']:.2f} | {wall:.0f} / {cpu:.0f} |")


def main() -> int:
    print("Steady rises over the ambient [K], default mesh and model options (`imutherm solve LAYOUT --scheme S`)")
    print()
    print("| layout | scheme | nodes | power [W] | max rise (where) | tp1 | six sensor dies | gyro / accel spread "
          "| wall / CPU [s] |")
    print("|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        for layout in LAYOUTS:
            for scheme in SCHEMES:
                res, wall, cpu = solve(layout, scheme, Path(tmp) / f"{layout}_{scheme}")
                print(row(layout, scheme, res, wall, cpu), flush=True)
    return 0


if __name__ == "__main__":
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "layouts", "steady rises of the two built-in units"))
