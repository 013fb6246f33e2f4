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
        }
        code = "import sys; from imutherm.cli import main; sys.exit(main(sys.argv[1:]))"
        failed = 0
        for name, argv in cases.items():
            status, dt, msg = _refuse([sys.executable, "-c", code] + argv)
            failed += status is None or (status != 2 and "--help" not in argv)
            shown = "NOT REFUSED" if status is None else f"exit {status}"
            print(f"{name:<62} {shown}  {dt:5.2f} s  {msg[:260]}")
    return 1 if failed else 0


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
