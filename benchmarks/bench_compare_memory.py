"""Which process holds ``imutherm compare``'s peak memory (issue 59): the command run as a user does, every process of
its tree sampled every 0.2 s from /proc (VmRSS and the proportional Pss of ``smaps_rollup``), and printed: the peak
of the summed RSS (the target's measure, as ``bench_study.py``), the summed Pss then, each process's RSS at that
moment, and each process's own peak. Linux only (/proc).

    python benchmarks/bench_compare_memory.py                      # imutherm compare, default settings
    python benchmarks/bench_compare_memory.py -- --layout FILE     # extra arguments for imutherm compare

Runs with a fresh, empty disk cache (``IMUTHERM_CACHE_DIR``) so every thermal case is solved, its output in a
temporary folder; also prints the command's wall time, its CPU seconds (it and its workers) and the machine's
load before and after (a shared machine: pair a before/after in the same minutes). Which stage a worker is in at
its peak: ``bench_thermal_case_memory.py``.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def tree(root: int) -> list[int]:
    """``root`` and its descendants' process ids (from /proc/<pid>/stat's parent ids)."""
    kids: dict[int, list[int]] = {}
    for p in os.listdir("/proc"):
        if p.isdigit():
            try:
                ppid = int(Path(f"/proc/{p}/stat").read_text().rsplit(")", 1)[1].split()[1])
            except (OSError, IndexError, ValueError):
                continue
            kids.setdefault(ppid, []).append(int(p))
    out, todo = [], [root]
    while todo:
        p = todo.pop()
        out.append(p)
        todo += kids.get(p, [])
    return out


def memory_mb(pid: int) -> tuple[float, float]:
    """(RSS, Pss) [MB] of process ``pid`` (``smaps_rollup``); (0, 0) once it has gone."""
    rss = pss = 0.0
    try:
        for line in Path(f"/proc/{pid}/smaps_rollup").read_text().splitlines():
            if line.startswith("Rss:"):
                rss = float(line.split()[1]) / 1024.0
            elif line.startswith("Pss:"):
                pss = float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return rss, pss


def sample(cmd: list[str], env: dict, period_s: float = 0.2) -> dict:
    """Run ``cmd``, sampling its tree: dict(returncode, wall_s, cpu_s, peak_mb, pss_mb (at the peak), at_s, split
    (pid -> RSS at the peak), own (pid -> its own peak RSS), main (the command's pid), stdout (with stderr))."""
    ru0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = tempfile.TemporaryFile("w+")
    proc = subprocess.Popen(cmd, env=env, stdout=out, stderr=subprocess.STDOUT, text=True)
    peak, own = dict(peak_mb=0.0, pss_mb=0.0, at_s=0.0, split={}), {}
    while proc.poll() is None:
        mem = {p: memory_mb(p) for p in tree(proc.pid)}
        rss = sum(m[0] for m in mem.values())
        for p, m in mem.items():
            own[p] = max(own.get(p, 0.0), m[0])
        if rss > peak["peak_mb"]:
            peak = dict(peak_mb=rss, pss_mb=sum(m[1] for m in mem.values()), at_s=time.perf_counter() - t0,
                        split={p: m[0] for p, m in mem.items()})
        time.sleep(period_s)
    out.seek(0)
    text = out.read()
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = ru.ru_utime + ru.ru_stime - ru0.ru_utime - ru0.ru_stime
    return dict(returncode=proc.returncode, wall_s=time.perf_counter() - t0, cpu_s=cpu, own=own, main=proc.pid,
                stdout=text, **peak)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", help="the command's output folder, kept (default: a temporary one), and its printout "
                    "in out/printout.txt: to compare the answers of two runs")
    ap.add_argument("extra", nargs="*", help="arguments for imutherm compare (after --)")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="imutherm-mem-") as tmp:
        env = dict(os.environ, IMUTHERM_CACHE_DIR=str(Path(tmp) / "cache"))
        out = Path(args.out) if args.out else Path(tmp) / "out"
        cmd = [sys.executable, "-m", "imutherm.cli", "compare", "--no-progress", "--out", str(out), *args.extra]
        r = sample(cmd, env)
        if args.out:
            (out / "printout.txt").write_text(r["stdout"])
    if r["returncode"] != 0:
        print(r["stdout"][-2000:], file=sys.stderr)
        print(f"imutherm compare failed (exit {r['returncode']})", file=sys.stderr)
        return 1
    name = lambda p: "command" if p == r["main"] else f"worker {p}"   # noqa: E731
    split = ", ".join(f"{name(p)} {v:.0f}" for p, v in sorted(r["split"].items(), key=lambda kv: -kv[1]) if v > 1)
    own = ", ".join(f"{name(p)} {v:.0f}" for p, v in sorted(r["own"].items(), key=lambda kv: -kv[1]) if v > 1)
    print(f"imutherm compare {' '.join(args.extra)}: {r['wall_s']:.1f} s wall, {r['cpu_s']:.1f} CPU-s, load "
          f"{load0[0]:.1f} -> {os.getloadavg()[0]:.1f}")
    print(f"peak {r['peak_mb']:.0f} MB summed RSS ({r['pss_mb']:.0f} MB Pss) at {r['at_s']:.1f} s: {split}")
    print(f"each process's own peak [MB]: {own}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
