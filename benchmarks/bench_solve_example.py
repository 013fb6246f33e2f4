"""The example printout of ``imutherm solve`` in docs/reference/commands.md: one scheme's power-on transient.

    python benchmarks/bench_solve_example.py [--write]

Runs ``imutherm solve --scheme grease --transient --t-end 1200 --out DIR`` (reference unit, default mesh and
model options, the full FEM with its default error-controlled TR-BDF2 steps) in a fresh process and prints
the command and what it printed (its output folder shown as ``out/grease``; the progress bar's redrawn
lines left out). With ``--write`` that is
``docs/benchmarks/tables/solve_example.txt``, which the commands page includes: the example is what the code
prints today, not a copy.
"""

import re
import subprocess
import sys
import tempfile
from pathlib import Path

ARGS = ["solve", "--scheme", "grease", "--transient", "--t-end", "1200"]
BAR = re.compile(r"^\w+: +\d+%\|")   # tqdm's progress bar
CODE = "import sys; from imutherm.cli import main; sys.exit(main(sys.argv[1:]))"


def main() -> int:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "grease"
        p = subprocess.run([sys.executable, "-c", CODE] + ARGS + ["--out", str(out)], capture_output=True,
                           text=True)
        print("$ imutherm " + " ".join(ARGS + ["--out", "out/grease"]))
        lines = re.split(r"[\r\n]+", (p.stderr + p.stdout).replace(str(out), "out/grease"))
        print("\n".join(line for line in lines if line.strip() and not BAR.match(line)))
    return p.returncode


if __name__ == "__main__":
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, "solve_example", "the example printout of imutherm solve (docs/reference/commands.md)"))
