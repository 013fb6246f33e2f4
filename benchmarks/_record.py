"""``--write`` for the benchmark scripts: what a script printed becomes its table under ``docs/benchmarks/tables/``.

A benchmark's figures have one source: the file its own run writes. ``python benchmarks/bench_X.py ... --write``
runs the script as without the flag, prints the same, and then records everything it printed in
``docs/benchmarks/tables/<name>.txt`` after a ``#`` header that says what it is, the command, the date, the
commit, the machine's CPUs and load, and the run's wall and CPU seconds. The docs pages include the file
(MyST ``literalinclude``) instead of copying its figures. ``bench_study.py`` and ``bench_real_motion.py`` write
tables of their own shape with their own ``--write``.

    if __name__ == "__main__":
        sys.exit(_record.run(main, "calibration", "conventional vs improved calibration"))
"""

from __future__ import annotations

import datetime
import io
import os
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

TABLES = Path(__file__).resolve().parents[1] / "docs" / "benchmarks" / "tables"


class _Tee(io.TextIOBase):
    """Writes to the terminal and keeps a copy."""

    def __init__(self, out):
        self.out, self.kept = out, io.StringIO()

    def write(self, text):
        self.kept.write(text)
        return self.out.write(text)

    def flush(self):
        self.out.flush()


def _commit() -> str:
    return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                          cwd=Path(__file__).resolve().parent).stdout.strip() or "unknown"


def _cpu_s() -> float:
    own, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def header(title: str, command: str, *, wall_s: float, cpu_s: float, load: str, commit: str | None = None,
           date: str | None = None) -> list:
    """The ``#`` lines above a recorded printout."""
    return [f"# {title}", f"# command: {command}",
            f"# Written by `{command} --write` on {date or datetime.date.today().isoformat()} at commit "
            f"{commit or _commit()};",
            f"# {os.cpu_count()} CPUs, load average {load}; {wall_s:.0f} s wall, {cpu_s:.0f} CPU-s (user+sys, the "
            "script and the processes it waited for).",
            "# Time-based figures are the machine's; do not edit, rerun the command."]


def write(path: Path, head: list, printed: str) -> None:
    """Write the header and the printout to ``path`` whole or not at all."""
    tmp = path.with_suffix(".tmp")
    tmp.write_text("\n".join(head + [""] + [line.rstrip() for line in printed.strip("\n").splitlines()]) + "\n",
                   encoding="utf-8")
    tmp.replace(path)


def run(main, name, title: str, argv=None, tables: Path = TABLES) -> int:
    """Run ``main()`` (which parses ``sys.argv``) without ``--write`` in the arguments; with it, record what it
    printed in ``tables/<name>.txt`` (``name``: a string, or a function of the arguments). Returns main's
    exit status (None: 0)."""
    args = list(sys.argv[1:] if argv is None else argv)
    record = "--write" in args
    args = [a for a in args if a != "--write"]
    script = Path(sys.argv[0]).name
    sys.argv = [sys.argv[0]] + args
    tee, stdout = _Tee(sys.stdout), sys.stdout
    load0, t0, cpu0 = os.getloadavg()[0], time.perf_counter(), _cpu_s()
    sys.stdout = tee
    try:
        status = main()
    finally:
        sys.stdout = stdout
    status = 0 if status is None else status
    if record:
        table = name(args) if callable(name) else name
        command = " ".join(["python", f"benchmarks/{script}"] + args)
        head = header(title, command, wall_s=time.perf_counter() - t0, cpu_s=_cpu_s() - cpu0,
                      load=f"{load0:.1f} before, {os.getloadavg()[0]:.1f} after")
        write(tables / f"{table}.txt", head, tee.kept.getvalue())
        print(f"wrote {tables / f'{table}.txt'}")
    return status


def paired(runs: list, ref_runs: list) -> tuple[dict, list]:
    """Medians of repeated runs (``wall`` s, ``cpu`` s, ``mb`` peak) and their ratios to the reference's, in that order."""
    med = {k: statistics.median(r[k] for r in runs) for k in ("wall", "cpu", "mb")}
    ref = {k: statistics.median(r[k] for r in ref_runs) for k in ("wall", "cpu", "mb")}
    return med, [med[k] / ref[k] for k in ("wall", "cpu", "mb")]


def scheme_in_process(script: str, scheme: str) -> dict:
    """Run ``script --scheme scheme`` in a process of its own (so its wall time and peak memory are its own) and
    return the JSON object it printed last: the per-scheme worker mode of the mesh benchmarks."""
    import json

    out = subprocess.run([sys.executable, script, "--scheme", scheme], check=True, capture_output=True, text=True)
    return json.loads(out.stdout.splitlines()[-1])
