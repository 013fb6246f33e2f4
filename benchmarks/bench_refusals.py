"""Wall time of refusing the costliest bad inputs, each as a fresh ``imutherm`` process (start to exit).

    python benchmarks/bench_refusals.py

Prints per case the exit status, the seconds from launch to exit and the message. The
interpreter start and imports alone are timed too (``--help``), so the cost of the
checks themselves is the difference. Every case must be refused within seconds: one that is not refused within
``LIMIT_S`` (it started the work) is stopped with its workers and printed as NOT REFUSED, and the script exits 1.
The memory cases give ``--max-memory`` so that they are refused on any machine, not only on one whose free
memory is below the estimate.
"""

import os
import signal
import subprocess
import sys
import tempfile
import time

from imutherm.geometry.layout import default_layout_path

LIMIT_S = 60.0   # a refusal takes seconds; past this the case is running, not refused


def main():
    ref = default_layout_path().read_text()
    with tempfile.TemporaryDirectory() as d:
        big = os.path.join(d, "keys.toml")  # ~1 MiB of unknown keys: just under the layout cap, parsed in full
        with open(big, "w") as fh:
            fh.write(ref.replace("[environment]", "[environment]\n" + "".join(
                f"k{i}_{'x' * 40} = 1\n" for i in range(19_500))))
        over = os.path.join(d, "over.toml")
        with open(over, "wb") as fh:
            fh.write(b"#" * (17 * 2**20))
        deep = os.path.join(d, "deep.toml")
        with open(deep, "w") as fh:
            fh.write("x = " + "[" * 100_000 + "]" * 100_000)
        power = os.path.join(d, "power.toml")
        with open(power, "w") as fh:
            fh.write(ref.replace("power_W = 0.35", "power_W = 1e30", 1))
        out = os.path.join(d, "out")
        boards = _bad_boards(d)
        unit = os.path.join(d, "unit.toml")
        cases = {
            "imports only (--help)": ["solve", "--help"],
            "solve --mesh-size 0.01": ["solve", "--mesh-size", "0.01", "--out", out],
            "solve --min-cells 1000": ["solve", "--min-cells", "1000", "--out", out],
            "solve --transient --t-end 1e13 --dt 1": ["solve", "--transient", "--t-end", "1e13", "--dt", "1", "--out", out],
            "compare --mesh-size 0.2 (3 schemes estimated)": ["compare", "--mesh-size", "0.2", "--out", out],
            "compare --seeds 1000 (the IMU side's time)": ["compare", "--seeds", "1000", "--out", out],
            "compare --seeds 100 --jobs 1000 --max-memory 4G (299 workers)": [
                "compare", "--seeds", "100", "--jobs", "1000", "--max-memory", "4G", "--out", out],
            "solve --cavity-law s2s --cavity-patch-mm 0.001": [
                "solve", "--cavity-law", "s2s", "--cavity-patch-mm", "0.001", "--out", out],
            "sweep of 1000 x 1000 cases": ["sweep", "--set", "environment.ambient_C=20:60:1000", "--set",
                                           "mounting.temperature_C=20:60:1000", "--out", out],
            "attitude --seeds 1000000000": ["attitude", "--profile", "flight", "--seeds", "1000000000", "--out", out],
            "layout: 1 MiB of unknown keys": ["geometry", big, "--out", out],
            "layout: 17 MiB (over the cap)": ["geometry", over, "--out", out],
            "layout: nested 100000 deep": ["geometry", deep, "--out", out],
            "layout: power_W = 1e30": ["solve", power, "--out", out],
            "--out under /proc": ["solve", "--out", "/proc/x"],
            "import: IDF outline of 1,000,000 points": ["import", boards["million"], "--out", unit],
            "import: KiCad arc of 1e12 degrees": ["import", boards["arc"], "--out", unit],
            "import: (version 1e999)": ["import", boards["version"], "--out", unit],
            "import: --ambient nan": ["import", boards["good"], "--ambient", "nan", "--out", unit],
        }
        code = "import sys; from imutherm.cli import main; sys.exit(main(sys.argv[1:]))"
        failed = 0
        for name, argv in cases.items():
            status, dt, msg = _refuse([sys.executable, "-c", code] + argv)
            failed += status is None or (status != 2 and "--help" not in argv)
            shown = "NOT REFUSED" if status is None else f"exit {status}"
            print(f"{name:<62} {shown}  {dt:5.2f} s  {msg[:260]}")
    return 1 if failed else 0


def _bad_boards(folder: str) -> dict:
    """Board files of the import's costliest bad inputs, written into ``folder``: {name: path}."""
    import math

    edge = "\n".join(f"  (gr_line (start {a} {b}) (end {c} {e}) (layer Edge.Cuts) (width 0.05))"
                      for a, b, c, e in ((0, 0, 40, 0), (40, 0, 40, 30), (40, 30, 0, 30), (0, 30, 0, 0)))
    kicad = ("(kicad_pcb (version 20171130) (host pcbnew 5)\n  (general (thickness 1.6))\n  (layers (0 F.Cu signal) "
             "(31 B.Cu signal) (44 Edge.Cuts user))\n" + edge + "\n  (module Package_SO:SOIC-8 (layer F.Cu) (at 20 15)"
             " (fp_text reference U1 (at 0 0) (layer F.SilkS)) (property Power_W 0.1) (pad 1 smd rect (at 0 0) "
             "(size 1 1) (layers F.Cu)))\n")
    texts = {"good": kicad + ")\n",
             "arc": kicad + "  (gr_arc (start 20 15) (end 25 15) (angle 1e12) (layer Edge.Cuts) (width 0.05))\n)\n",
             "version": kicad.replace("(version 20171130)", "(version 1e999)") + ")\n"}
    paths = {}
    for name, text in texts.items():
        paths[name] = os.path.join(folder, f"{name}.kicad_pcb")
        with open(paths[name], "w") as fh:
            fh.write(text)
    n = 1_000_000
    angles = [2 * math.pi * k / n for k in range(n + 1)]
    points = "".join(f"0 {20 + 15 * math.cos(a):.6f} {15 + 15 * math.sin(a):.6f} 0\n" for a in angles)
    paths["million"] = os.path.join(folder, "million.emn")
    with open(paths["million"], "w") as fh:
        fh.write(".HEADER\nBOARD_FILE 3.0 \"t\" 2026/01/01.00:00:00 1\n\"b\" MM\n.END_HEADER\n"
                 ".BOARD_OUTLINE ECAD\n1.6\n" + points + ".END_BOARD_OUTLINE\n")
    with open(os.path.join(folder, "million.emp"), "w") as fh:
        fh.write(".HEADER\nLIBRARY_FILE 3.0 \"t\" 2026/01/01.00:00:00 1\n.END_HEADER\n")
    return paths


def _refuse(cmd):
    """Run ``cmd`` in its own session: (exit status or None if still running after LIMIT_S, seconds, last line of
    stderr). A case still running is stopped with everything it started (its process group)."""
    t = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, start_new_session=True)
    try:
        _, err = p.communicate(timeout=LIMIT_S)
        status = p.returncode
    except subprocess.TimeoutExpired:
        os.killpg(p.pid, signal.SIGKILL)
        _, err = p.communicate()
        status = None
    return status, time.perf_counter() - t, (err.strip().splitlines() or [""])[-1]


if __name__ == "__main__":
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "refusals", "time to refuse bad input"))
