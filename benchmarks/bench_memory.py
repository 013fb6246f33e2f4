"""Peak memory per unknown of ``imutherm solve`` / ``geometry`` (the figure behind the cost estimate).

Runs each command in a fresh subprocess at a few mesh sizes and reads its peak
resident memory (``ru_maxrss`` of the child) and the unknowns (mesh nodes) it
reports. Prints bytes per unknown above the interpreter's base; the largest
figure is ``imutherm.budget.BYTES_PER_UNKNOWN``.

    python benchmarks/bench_memory.py [--sizes 3 2 1.5]
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=float, nargs="+", default=[3.0, 2.0, 1.5])
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        # the interpreter and imports alone: a refused run
        p = subprocess.run([sys.executable, "-c", "import resource, imutherm.cli.solve, skfem, pyamg, meshio;"
                            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024)"],
                           capture_output=True, text=True, check=True)
        base = int(p.stdout)
        print(f"base (interpreter + imports): {base / 2**20:.0f} MiB")
        for cmd in ("solve", "geometry"):
            for h in args.sizes:
                out = os.path.join(d, f"{cmd}{h}")
                argv = [cmd, "--mesh-size", str(h), "--out", out, "--max-memory", "1e12"]
                p = subprocess.run([sys.executable, "-c",
                                    "import resource, sys, runpy; sys.argv=['imutherm']+sys.argv[1:];"
                                    "from imutherm.cli import main; rc = main(sys.argv[1:]);"
                                    "print('RSS', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024); sys.exit(rc)"]
                                   + argv, capture_output=True, text=True)
                if p.returncode:
                    print(p.stderr)
                    continue
                rss = int(p.stdout.split("RSS")[-1])
                info = json.load(open(os.path.join(out, "result.json" if cmd == "solve" else "geometry.json")))
                n = info["unknowns"] if cmd == "solve" else info["mesh"]["nodes"]
                print(f"{cmd:8s} mesh {h:4.1f} mm: {n:8d} unknowns, peak {rss / 2**20:7.0f} MiB, "
                      f"{(rss - base) / n:6.0f} bytes/unknown above base")


if __name__ == "__main__":
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "memory", "peak memory per unknown"))
