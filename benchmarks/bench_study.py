"""Benchmark of the main job: ``imutherm compare`` end to end at the default mesh.

Runs the command as a user does (a subprocess: thermal + oven self-heating + calibration + IMU and
attitude, three schemes, default seeds) and reports its wall time and the peak resident memory of the
whole process tree (the command and its worker processes, summed, sampled every 0.2 s from /proc), the
stage times from ``summary.json``, the CPU seconds of the command and its workers (the load-independent
cost), and PASS/FAIL against the targets (<= 20 s, the anchor set with the reduced transients (40 s before
them), with checked reduced transients and each scheme's mesh-error estimate; peak memory <= 2 GB). Run it on
an otherwise idle machine: the figures are the machine's.

    python benchmarks/bench_study.py                # default settings of `imutherm compare`
    python benchmarks/bench_study.py -- --seeds 6   # extra arguments for imutherm compare
    python benchmarks/bench_study.py -- --full      # the transients on the full adaptive FEM (as before)
    python benchmarks/bench_study.py -- --no-mesh-error   # without the mesh-error estimates
    python benchmarks/bench_study.py -- --thermal-only    # the thermal comparison alone (wall, CPU, memory)
    python benchmarks/bench_study.py --write        # and record the answer and the timing (defaults only)
    python benchmarks/bench_study.py --rerun        # and the same command again: its thermal cases from the cache

The command runs with a fresh, empty disk cache (``IMUTHERM_CACHE_DIR``, :mod:`imutherm.cache`; ``--cache-dir`` to
keep one), so it solves every thermal case; ``--rerun`` runs it a second time on the same cache (what a user's
second ``compare`` of an unchanged unit costs). The machine is shared, so the figures are also given as paired
ratios in the same run: against a fixed single-thread yardstick (:func:`yardstick_s`: sparse matrix-vector
products, the thermal solves' kernel; timed just before and just after the command, their mean) and against the
run's own steady solve (the longest scheme's ``timings_s.steady_solve``).

``--write`` records, each with the date and the commit, (1) the answer the command printed (its table, the
real-motion lines and the sentences) in ``docs/benchmarks/tables/compare_answer.txt`` and (2) this run's timing
table (wall, CPU-seconds, peak memory, the stages per scheme) in ``docs/benchmarks/tables/study.txt`` and (3)
the sensor dies' self-heating in the calibration oven in ``docs/benchmarks/tables/oven_self_heating.txt``: the
one copy of each, which the documentation includes and ``tests/test_docs_figures.py`` holds the README's copies
to.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

TARGET_S = 20.0
TARGET_MB = 2048.0
#: the answer's discretisation error at a sensor die, the corrected answer's bound [K] (issue 45)
ANSWER_TARGET_K = 0.1
TABLES = Path(__file__).resolve().parents[1] / "docs" / "benchmarks" / "tables"
ANSWER = TABLES / "compare_answer.txt"
TIMING = TABLES / "study.txt"
OVEN = TABLES / "oven_self_heating.txt"


def yardstick_s(repeats: int = 3) -> float:
    """Wall time [s] of a fixed single-thread workload (the fastest of ``repeats``): 200 products of a 7-point
    Laplacian on a 48^3 grid (110,592 unknowns, the thermal solves' kernel: memory-bound sparse products) with a
    vector. The yardstick against which the command's time is given as a ratio."""
    import numpy as np
    import scipy.sparse as sp
    from threadpoolctl import threadpool_limits

    n = 48
    d1 = sp.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(n, n))
    eye = sp.identity(n)
    A = (sp.kron(sp.kron(d1, eye), eye) + sp.kron(sp.kron(eye, d1), eye) + sp.kron(sp.kron(eye, eye), d1)).tocsr()
    x = np.ones(A.shape[0])
    best = float("inf")
    with threadpool_limits(1):
        for _ in range(repeats):
            t0 = time.perf_counter()
            y = x
            for _ in range(200):
                y = A @ x + 1e-3 * y
            best = min(best, time.perf_counter() - t0)
    return best


def run_command(cmd: list, env: dict | None = None) -> dict:
    """Run ``cmd`` (a subprocess, stdout and stderr together) sampling its process tree's memory every 0.2 s:
    dict(text, returncode, wall_s, cpu_s (user+sys of it and its workers), peak_mb (summed VmRSS), pss_mb)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    peak = peak_pss = 0.0
    while proc.poll() is None:
        rss, pss = _tree_memory_mb(proc.pid)
        peak, peak_pss = max(peak, rss), max(peak_pss, pss)
        time.sleep(0.2)
    wall = time.perf_counter() - t0
    ru = resource.getrusage(resource.RUSAGE_CHILDREN)   # the command and its workers (waited for)
    cpu = ru.ru_utime + ru.ru_stime - before.ru_utime - before.ru_stime
    return dict(text=proc.stdout.read(), returncode=proc.returncode, wall_s=wall, cpu_s=cpu, peak_mb=peak,
                pss_mb=peak_pss)


def _tree_memory_mb(pid: int) -> tuple:
    """(resident, proportional) memory of ``pid`` and all its descendants [MB] (Linux /proc): the sum of their
    VmRSS, which counts the pages the forked workers share with the command once per process, and the sum of
    their Pss (``smaps_rollup``: a shared page split between its sharers), what the tree takes of the machine."""
    rss, pss, todo = 0.0, 0.0, [pid]
    while todo:
        p = todo.pop()
        try:
            for line in Path(f"/proc/{p}/status").read_text().splitlines():
                if line.startswith("VmRSS:"):
                    rss += float(line.split()[1]) / 1024.0
            for line in Path(f"/proc/{p}/smaps_rollup").read_text().splitlines():
                if line.startswith("Pss:"):
                    pss += float(line.split()[1]) / 1024.0
            for task in Path(f"/proc/{p}/task").iterdir():
                todo += [int(c) for c in (task / "children").read_text().split()]
        except (FileNotFoundError, ProcessLookupError, PermissionError):
            continue
    return rss, pss


def answer_lines(stdout: str) -> list:
    """The answer of ``imutherm compare``'s printout: from the table's header to the last sentence (the cavity
    law's notes before it and the closing ``wrote ...`` line left out)."""
    lines = stdout.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("scheme "))
    end = max(i for i, line in enumerate(lines) if line.startswith("wrote "))
    return lines[start:end]


def _commit() -> str:
    return subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                          cwd=Path(__file__).resolve().parent).stdout.strip()


def _write(path: Path, lines: list) -> None:
    """Write ``lines`` to ``path`` whole or not at all."""
    tmp = path.with_suffix(".tmp")
    tmp.write_text("\n".join(lines) + "\n", encoding="utf-8")
    tmp.replace(path)


def write_answer(stdout: str, path: Path = ANSWER) -> None:
    """Record the printed answer of the default ``imutherm compare`` with the date and the commit."""
    rev = _commit()
    head = ["# imutherm compare at its defaults: the answer it prints (reference unit, default mesh, s2s cavity law,",
            "# 3 seeds, the power-on transients on reduced models checked against the full FEM); progress lines, the",
            "# cavity law's notes and the closing 'wrote ...' line left out. The one copy of this answer: the docs",
            "# include this file and tests/test_docs_figures.py holds the README's copy to it.",
            f"# Written by `python benchmarks/bench_study.py --write` on {datetime.date.today().isoformat()} at commit "
            f"{rev}; do not edit, rerun the command."]
    _write(path, head + answer_lines(stdout))


def _per_scheme(summary: dict, value, fmt: str, unit: str = "") -> str:
    """``value(scheme summary)`` of each scheme, formatted and joined by ' / ' (nan where it is missing)."""
    out = []
    for sch in summary["schemes"].values():
        v = value(sch)
        out.append(format(float("nan") if v is None else v, fmt))
    return " / ".join(out) + unit


def _thermal(sch: dict, key: str) -> dict:
    return sch["thermal"].get(key) or {}


def timing_table(summary: dict, wall_s: float, cpu_s: float, peak_mb: float, pss_mb: float | None = None) -> list:
    """The run's timing as a Markdown table: end to end against the targets, then the stages per scheme (from
    ``summary.json``). ``peak_mb``: the tree's peak summed VmRSS (the target's measure); ``pss_mb``: its peak summed
    Pss (shared pages counted once), shown beside it."""
    names = " / ".join(summary["schemes"])
    checks = [_thermal(s, "transient_check") for s in summary["schemes"].values()]
    rows = [("wall, end to end", f"{wall_s:.1f} s", f"<= {TARGET_S:.0f} s: {'PASS' if wall_s <= TARGET_S else 'FAIL'}"),
            ("of which the study", f"{summary['wall_s']:.1f} s", ""),
            ("CPU, all processes (user+sys)", f"{cpu_s:.1f} s", ""),
            ("peak memory, the command and its workers", f"{peak_mb:.0f} MB",
             f"<= {TARGET_MB:.0f} MB: {'PASS' if peak_mb <= TARGET_MB else 'FAIL'}")]
    if pss_mb is not None:
        rows.append(("the same, proportional (Pss: the pages the workers share with the command counted once)",
                     f"{pss_mb:.0f} MB", ""))
    rows += [(f"nodes ({names})", _per_scheme(summary, lambda s: s["thermal"]["mesh"]["nodes"], ",d"), ""),
            ("steady solve per scheme",
             _per_scheme(summary, lambda s: _thermal(s, "timings_s")["steady_solve"], ".1f", " s"), ""),
            ("power-on transient per scheme (reduced model + its check)",
             _per_scheme(summary, lambda s: _thermal(s, "timings_s").get("transient_solve"), ".1f", " s"), ""),
            ("reduced transient's check against the full model",
             _per_scheme(summary, lambda s: _thermal(s, "transient_check").get("max_site_error_K"), ".3f", " K"),
             "accepted: " + " / ".join("yes" if c.get("accepted") else "no" for c in checks)),
            ("mesh-error estimate, largest at a sensor die",
             _per_scheme(summary, lambda s: s.get("numerical_error", {}).get("mesh", {}).get("sensor_die_max_K"),
                         ".3f", " K"), ""),
            ("mesh-error estimate, the corrected answer's bound, largest at a sensor die",
             _per_scheme(summary, lambda s: s.get("numerical_error", {}).get("mesh", {}).get("answer_sensor_die_max_K"),
                         ".3f", " K"), _answer_target(summary)),
            ("mesh-error estimate's refined solve",
             _per_scheme(summary, lambda s: _thermal(s, "discretisation_error").get("timings_s", {}).get("wall"),
                         ".1f", " s"), ""),
            ("max rise", _per_scheme(summary, lambda s: s["max_rise_K"], ".2f", " K"), "")]
    return ["| figure | measured | target |", "|---|---|---|"] + [f"| {a} | {b} | {c} |" for a, b, c in rows]


def _answer_target(summary: dict) -> str:
    """The target column of the corrected answer's bound: <= :data:`ANSWER_TARGET_K` at every scheme's dies."""
    bounds = [s.get("numerical_error", {}).get("mesh", {}).get("answer_sensor_die_max_K")
              for s in summary["schemes"].values()]
    ok = all(b is not None and b <= ANSWER_TARGET_K for b in bounds)
    return f"<= {ANSWER_TARGET_K:g} K: {'PASS' if ok else 'FAIL'}"


def write_timing(summary: dict, wall_s: float, cpu_s: float, peak_mb: float, load: str, path: Path = TIMING,
                 note: tuple = (), commit: str | None = None, pss_mb: float | None = None) -> None:
    """Record this run's timing table with the date, the commit (default: the checkout's), the machine's CPUs and
    its load; ``note``: extra header lines."""
    head = ["# imutherm compare end to end at its defaults (reference unit, default mesh, s2s cavity law, 3 seeds,",
            "# reduced transients with their check, each scheme's mesh-error estimate): one run's timing. The one copy",
            "# of these figures: docs/benchmarks/study.md includes this file and tests/test_docs_figures.py holds the",
            "# README's copy to it. Time-based figures are the machine's: re-run the command to measure yours.",
            f"# Written by `python benchmarks/bench_study.py --write` on {datetime.date.today().isoformat()} at commit "
            f"{commit or _commit()};", f"# {os.cpu_count()} CPUs, load average {load}; do not edit, rerun the command."]
    _write(path, head + [f"# {line}" for line in note] + [""] + timing_table(summary, wall_s, cpu_s, peak_mb, pss_mb))


def oven_table(summary: dict) -> list:
    """Each scheme's self-heating in the calibration oven (``summary.json``'s ``self_heating_in_oven_K``): every
    sensor die's rise over the chamber at each chamber temperature, and how the cold solves ran."""
    out = []
    for name, sch in summary["schemes"].items():
        heat = sch["self_heating_in_oven_K"]
        chambers = heat["chamber_C"]
        sites = [k for k in heat if k != "chamber_C"]
        out += [f"{name}: rise of each sensor die over the chamber [K]",
                "| chamber | " + " | ".join(sites) + " |", "|---" * (len(sites) + 1) + "|"]
        out += [f"| {c:g} °C | " + " | ".join(f"{heat[s][i]:.2f}" for s in sites) + " |"
                for i, c in enumerate(chambers)]
        for chamber, solve in sch.get("self_heating_solves", {}).items():
            chk = solve.get("check") or {}
            out.append(f"the {chamber} °C solve: {solve['model']} model" + (
                f", {chk['rounds']} round(s), {chk['full_solves']} full CG solve(s) "
                f"({chk['cg_iterations']} iterations), "
                f"estimated error {chk['max_site_error_K']:.4f} K at a sensor die (tolerance {chk['tol_K']:g} K)"
                if chk else ""))
        out.append("")
    return out[:-1]


def write_oven(summary: dict, path: Path = OVEN, commit: str | None = None, note: tuple = ()) -> None:
    """Record the oven self-heating of the run with the date and the commit."""
    head = ["# imutherm compare at its defaults: the self-heating of each scheme's sensor dies in the calibration",
            "# oven (the unit bolted to the oven table at the chamber temperature; interpolated linearly between the",
            "# chambers), from the run's summary.json. The one copy of these figures: docs/reference/study.md",
            f"# includes this file. Written by `python benchmarks/bench_study.py --write` on "
            f"{datetime.date.today().isoformat()} at commit {commit or _commit()};",
            "# do not edit, rerun the command."]
    _write(path, head + [f"# {line}" for line in note] + [""] + oven_table(summary))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("extra", nargs="*", help="arguments passed to imutherm compare (after --)")
    ap.add_argument("--write", action="store_true", help=f"record the printed answer in {ANSWER.name} "
                    "(the command at its defaults only)")
    ap.add_argument("--rerun", action="store_true",
                    help="run the command a second time on the same disk cache: its thermal cases read, not solved")
    ap.add_argument("--cache-dir", default=None, metavar="DIR",
                    help="the disk cache folder the command uses (default: a fresh, empty one)")
    args = ap.parse_args(argv)
    if args.write and args.extra:
        ap.error("--write records the answer of the defaults: no extra arguments to imutherm compare")
    out = Path(tempfile.mkdtemp(prefix="bench_study_")) / "out"
    env = dict(os.environ, IMUTHERM_CACHE_DIR=args.cache_dir or tempfile.mkdtemp(prefix="bench_study_cache_"))
    env.pop("IMUTHERM_CACHE", None)
    cmd = [sys.executable, "-m", "imutherm.cli", "compare", "--no-progress", "--out", str(out)] + args.extra
    load0 = os.getloadavg()[0]
    yard0 = yardstick_s()
    r = run_command(cmd, env)
    yard1 = yardstick_s()
    yard = 0.5 * (yard0 + yard1)
    wall, cpu, peak, peak_pss, text = r["wall_s"], r["cpu_s"], r["peak_mb"], r["pss_mb"], r["text"]
    print(text)
    if r["returncode"] != 0:
        print(f"imutherm compare failed with status {r['returncode']}")
        return 1
    load = f"{load0:.1f} before, {os.getloadavg()[0]:.1f} after"
    again = None
    if args.rerun:
        out2 = out.parent / "out2"
        again = run_command(cmd[:cmd.index("--out") + 1] + [str(out2)] + cmd[cmd.index("--out") + 2:], env)
        if again["returncode"] != 0:
            print(again["text"] + f"\nthe second imutherm compare failed with status {again['returncode']}")
            return 1
        load += f", {os.getloadavg()[0]:.1f} after the second run"
    yard_line = (f"yardstick (fixed single-thread work, {yard0:.3f} s before / {yard1:.3f} s after): the command "
                 f"{wall / yard:.0f} yardsticks wall, {cpu / yard:.0f} CPU")
    if not (out / "summary.json").exists():   # --thermal-only / --steady-only: the thermal comparison alone
        print(f"\nimutherm compare {' '.join(args.extra)}: {wall:.1f} s wall, peak memory {peak:.0f} MB (process "
              f"tree; {peak_pss:.0f} MB proportional), {os.cpu_count()} CPUs; CPU {cpu:.1f} s (user+sys, all "
              f"processes); load average {load}")
        print(yard_line)
        return 0
    s = json.loads((out / "summary.json").read_text())
    if args.write:
        write_answer(text)
        write_timing(s, wall, cpu, peak, load, pss_mb=peak_pss)
        write_oven(s)
        print(f"wrote {ANSWER}, {TIMING} and {OVEN}")
    print(f"{'scheme':<8} {'nodes':>8} {'steady [s]':>10} {'transient [s]':>13} {'steps':>6} {'max rise [K]':>12} "
          f"{'model':>8} {'check [K]':>9} {'mesh err, dies [K]':>18} {'refined [s]':>11}")
    for name, sch in s["schemes"].items():
        th = sch["thermal"]
        tm = th["timings_s"]
        print(f"{name:<8} {th['mesh']['nodes']:8d} {tm['steady_solve']:10.1f} {tm.get('transient_solve', 0):13.1f} "
              f"{th.get('steps', 0):6d} {sch['max_rise_K']:12.2f} {th.get('transient_model', 'full'):>8} "
              f"{th.get('transient_check', {}).get('max_site_error_K', float('nan')):9.3f} "
              f"{sch.get('numerical_error', {}).get('mesh', {}).get('sensor_die_max_K', float('nan')):18.3f} "
              f"{th.get('discretisation_error', {}).get('timings_s', {}).get('wall', float('nan')):11.1f}")
    print(f"\nimutherm compare end to end: {wall:.1f} s wall (study {s['wall_s']:.1f} s), peak memory {peak:.0f} MB "
          f"(process tree; {peak_pss:.0f} MB proportional), {len(s['seeds'])} seeds, {os.cpu_count()} CPUs; CPU {cpu:.1f} s (user+sys, all "
          f"processes); load average {load}")
    steady = max(sch["thermal"]["timings_s"]["steady_solve"] for sch in s["schemes"].values())
    print(f"{yard_line}; {wall / steady:.1f} of the run's longest steady solve ({steady:.1f} s)")
    if again is not None:
        w2 = again["wall_s"]
        cached = sum(line.split(": thermal: ")[-1].startswith("cached") for line in again["text"].splitlines())
        print(f"second run, same cache: {w2:.1f} s wall, CPU {again['cpu_s']:.1f} s, peak {again['peak_mb']:.0f} MB "
              f"({again['pss_mb']:.0f} MB proportional); {cached} of {len(s['schemes'])} thermal cases from the cache; "
              f"{w2 / yard:.0f} yardsticks, {w2 / wall:.2f} of the first run, {w2 / steady:.1f} steady solves")
    ok_t, ok_m = wall <= TARGET_S, peak <= TARGET_MB
    print(f"  wall <= {TARGET_S:.0f} s: {'PASS' if ok_t else 'FAIL'}")
    print(f"  peak <= {TARGET_MB:.0f} MB: {'PASS' if ok_m else 'FAIL'}")
    return 0 if ok_t and ok_m else 1


if __name__ == "__main__":
    sys.exit(main())
