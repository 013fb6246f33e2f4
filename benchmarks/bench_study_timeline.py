"""A timeline of one ``imutherm compare``: what each process does when, and where a core is idle.

Runs the command (a child process: ``imutherm.cli`` called in it, with timing wrappers around its stages, nothing
else changed) and samples its process tree's CPU every 0.1 s from /proc. Writes into ``--out DIR``:

* ``spans.csv``: one row per stage of a process (pid, role, stage, start and end [s from the command's start],
  the process's CPU-seconds in it): the command's own stages (inputs and cost checks, the cache lookup, the
  workers' start, the full cases read back, the summary, the report, the scheme files' process) and every worker
  task (a scheme's thermal case with its build, steady, transient, oven and refined-solve stages, the wait for
  the refined solves' lock, the cache write; a bare calibration; an IMU case);
* ``cpu.csv``: the tree's busy cores per 0.1 s sample, per process;
* ``timeline.png``: the spans as bars, one lane per process, over the busy cores.

and the peak of the tree's summed VmRSS (every 0.1 s; ``bench_study.py`` samples every 0.2 s).

It prints the serial phases (the command alone before the first worker task, after the last), the core-seconds
left idle on the machine's CPUs (``--cores``, default min(2, CPUs)) while the command ran, and each worker's
tasks. The wrappers cost a few ms a run; the figures are the machine's, at its load (printed):

    python benchmarks/bench_study_timeline.py                       # imutherm compare at its defaults
    python benchmarks/bench_study_timeline.py --out /tmp/tl -- --seeds 1
    python benchmarks/bench_study_timeline.py --cache-dir DIR       # a disk cache kept (run twice: the cached rerun)
"""

from __future__ import annotations

import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: the span file of a run (the child's processes append to it), set by the parent for the child
SPAN_ENV = "IMUTHERM_TIMELINE_SPANS"
_TICK = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
_SPAN_FD = None
_SCHEME = {"now": "?"}   # the scheme whose IMU cases the command is queueing (the child's main process)


# ---- the child: the command with its stages timed -------------------------------------------------------------

def _record(name: str, t0: float, t1: float, c0: float, c1: float) -> None:
    """Append one span (this process's) to the span file: one write of a short line, O_APPEND (atomic)."""
    line = json.dumps([os.getpid(), os.getppid(), name, t0, t1, c1 - c0]) + "\n"
    os.write(_SPAN_FD, line.encode())


def _timed(fn, label):
    """``fn`` recording a span ``label`` (a string, or a function of the call's arguments) per call."""
    def wrapper(*args, **kwargs):
        t0, c0 = time.time(), time.process_time()
        try:
            return fn(*args, **kwargs)
        finally:
            name = label(*args, **kwargs) if callable(label) else label
            _record(name, t0, time.time(), c0, time.process_time())
    wrapper.__wrapped__ = fn
    return wrapper


def _patch(module: str, attr: str, label) -> None:
    import importlib

    mod = importlib.import_module(module)
    setattr(mod, attr, _timed(getattr(mod, attr), label))


def _scheme_of(res) -> str:
    sch = res.geometry.scheme
    return getattr(sch, "name", str(sch))


class _Task:
    """A pool task recorded as one span (picklable: the workers are forked from this module's process)."""

    def __init__(self, fn, label: str):
        self.fn, self.label = fn, label

    def __call__(self, *args, **kwargs):
        return _timed(self.fn, self.label)(*args, **kwargs)


def _task_label(fn, args) -> str:
    name = getattr(fn, "__name__", str(fn))
    if name == "stored_thermal_case":
        return f"thermal case {args[2]}"
    if name == "bare_calibration":
        return f"bare calibration seed {args[1]}"
    if name == "imu_case":
        return f"IMU case {_SCHEME['now']} seed {args[1]}"
    return name


def _install() -> None:
    """Timing wrappers around the command's stages and a span per pool task (the module attributes the callers
    look up at call time; the functions submitted to the pool are wrapped at submission, not patched, so they
    pickle)."""
    from concurrent.futures import ProcessPoolExecutor
    from contextlib import contextmanager

    global _SPAN_FD
    _SPAN_FD = os.open(os.environ[SPAN_ENV], os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    submit = ProcessPoolExecutor.submit

    def timed_submit(self, fn, *args, **kwargs):
        return submit(self, _Task(fn, _task_label(fn, args)), *args, **kwargs)
    ProcessPoolExecutor.submit = timed_submit

    cli = "imutherm.cli.compare"
    _patch(cli, "run_inputs", "inputs (layout, options)")
    _patch(cli, "build_geometry", lambda layout, s, *a, **k: f"cost check: geometry {s}")
    _patch(cli, "check_thermal_cost", "cost check: mesh and memory")
    _patch(cli, "refined_cost", "cost check: refined mesh")
    _patch(cli, "_study_config", "study config (grades)")
    _patch(cli, "_scheme_files", "scheme files and layout drawings")
    _patch(cli, "print_answer", "print answer")
    _patch("imutherm.studies.end_to_end", "run_study", "run_study")
    _patch("imutherm.studies.end_to_end", "study_summary", "summary")
    _patch("imutherm.reports.study_report", "write_study_report", "report PDF")
    run = "imutherm.studies.end_to_end.run"
    _patch(run, "_cache_lookup", "cache lookup")
    _patch(run, "process_pool", "start the pool")
    _patch(run, "full_case", lambda v, key, layout, sch, *a, **k: f"full case read back {sch}")
    import imutherm.studies.end_to_end.run as run_mod
    curves = run_mod.site_curves

    def site_curves(res):
        _SCHEME["now"] = _scheme_of(res)
        return curves(res)
    run_mod.site_curves = site_curves
    # in the workers (forked after this): a thermal case's stages
    th = "imutherm.studies.thermal.thermal_study"
    _patch(th, "build_geometry", "build geometry")
    _patch(th, "build_mesh", "mesh")
    _patch(th, "build_problem", "problem (view factors)")
    _patch(th, "assemble", "assemble")
    _patch(th, "solve_steady", "steady solve")
    _patch(th, "_reduced_transient", "reduced transient + check")
    _patch(th, "solve_transient", "full transient")
    _patch(th, "mesh_error", "refined solve (mesh error)")
    e2e = "imutherm.studies.end_to_end.thermal"
    _patch(e2e, "self_heating_table", "oven self-heating")
    _patch(e2e, "with_mesh_error", "mesh-error estimate (lock + refined solve)")
    _patch("imutherm.cache", "store", "cache write")
    import imutherm.workers as workers
    lock = workers.one_at_a_time

    @contextmanager
    def one_at_a_time():
        t0, c0 = time.time(), time.process_time()
        with lock():
            _record("wait for the refined solves' lock", t0, time.time(), c0, time.process_time())
            yield
    workers.one_at_a_time = one_at_a_time


def _child(argv: list) -> int:
    t_launch = float(os.environ.get(SPAN_ENV + "_T0", time.time()))
    _install()
    _record("interpreter start and imports", t_launch, time.time(), 0.0, time.process_time())
    from imutherm.cli import main

    t0, c0 = time.time(), time.process_time()
    try:
        return main(["compare", *argv])
    finally:
        _record("command (after imports)", t0, time.time(), c0, time.process_time())


# ---- the parent: the run, the /proc samples, the tables and the figure ----------------------------------------

def _tree(pid: int) -> list:
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        try:
            for task in Path(f"/proc/{p}/task").iterdir():
                todo += [int(c) for c in (task / "children").read_text().split()]
        except (FileNotFoundError, ProcessLookupError, PermissionError):
            continue
    return out


def _rss_mb(pid: int) -> float:
    try:
        return int(Path(f"/proc/{pid}/statm").read_text().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except (FileNotFoundError, ProcessLookupError):
        return 0.0


def _cpu_ticks(pid: int) -> int | None:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (FileNotFoundError, ProcessLookupError):
        return None
    return int(fields[11]) + int(fields[12])   # utime, stime


def run_timeline(extra: list, out: Path, cache_dir: str | None, dt: float = 0.1) -> dict:
    """Run ``imutherm compare --no-progress --out OUT/run EXTRA`` timed; returns the spans, samples and figures."""
    spans_file = out / "spans.jsonl"
    spans_file.unlink(missing_ok=True)
    env = dict(os.environ, **{SPAN_ENV: str(spans_file)},
               IMUTHERM_CACHE_DIR=cache_dir or tempfile.mkdtemp(prefix="timeline_cache_"))
    env.pop("IMUTHERM_CACHE", None)
    cmd = [sys.executable, str(Path(__file__).resolve()), "--child", "--", "--no-progress", "--out",
           str(out / "run"), *extra]
    load0 = os.getloadavg()[0]
    t_start = time.time()
    env[SPAN_ENV + "_T0"] = repr(t_start)
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    last, samples, peak = {}, [], 0.0
    while proc.poll() is None:
        t = time.time()
        tree = _tree(proc.pid)
        peak = max(peak, sum(_rss_mb(p) for p in tree))
        for p in tree:
            ticks = _cpu_ticks(p)
            if ticks is None:
                continue
            if p in last:
                t_prev, k_prev = last[p]
                samples.append((p, t_prev - t_start, t - t_start, (ticks - k_prev) / _TICK))
            last[p] = (t, ticks)
        time.sleep(dt)
    wall = time.time() - t_start
    text = proc.stdout.read()
    if proc.returncode != 0:
        raise SystemExit(text + f"\nimutherm compare failed with status {proc.returncode}")
    spans = []
    for line in spans_file.read_text().splitlines():
        pid, ppid, name, t0, t1, cpu = json.loads(line)
        spans.append(dict(pid=pid, ppid=ppid, stage=name, start_s=t0 - t_start, end_s=t1 - t_start, cpu_s=cpu))
    return dict(text=text, wall_s=wall, spans=spans, samples=samples, main=proc.pid, peak_mb=peak,
                load=f"{load0:.1f} before, {os.getloadavg()[0]:.1f} after")


def _roles(spans: list, main: int) -> dict:
    """pid -> role: the command, a worker (numbered in order of its first task), the scheme files' process."""
    roles, workers = {main: "command"}, []
    for s in sorted(spans, key=lambda s: s["start_s"]):
        p = s["pid"]
        if p in roles:
            continue
        if s["stage"] == "scheme files and layout drawings":
            roles[p] = "files (forked)"
        else:
            workers.append(p)
            roles[p] = f"worker {len(workers)}"
    return roles


def summarise(run: dict, cores: int) -> dict:
    """The serial phases, the idle core-seconds and each process's busy CPU from a :func:`run_timeline` run."""
    spans, roles = run["spans"], _roles(run["spans"], run["main"])
    tasks = [s for s in spans if roles.get(s["pid"], "").startswith("worker") and s["pid"] != run["main"]
             and s["ppid"] == run["main"] and _is_task(s)]
    first = min(s["start_s"] for s in tasks) if tasks else float("nan")
    last = max(s["end_s"] for s in tasks) if tasks else float("nan")
    # busy cores in each sample interval, all processes of the tree; idle core-seconds = (cores - busy)+ dt
    bins = {}
    for pid, t0, t1, cpu in run["samples"]:
        key = round(t0, 2)
        b = bins.setdefault(key, [t0, t1, 0.0])
        b[2] += cpu
    idle = before = after = 0.0
    for t0, t1, cpu in bins.values():
        gap = max(0.0, cores * (t1 - t0) - cpu)
        idle += gap
        if t1 <= first:
            before += gap
        elif t0 >= last:
            after += gap
    cpu_by = {}
    for pid, t0, t1, cpu in run["samples"]:
        cpu_by[roles.get(pid, f"pid {pid}")] = cpu_by.get(roles.get(pid, f"pid {pid}"), 0.0) + cpu
    return dict(wall_s=run["wall_s"], first_task_s=first, last_task_end_s=last, idle_core_s=idle,
                idle_before_s=before, idle_after_s=after, cpu_s=cpu_by, roles=roles, tasks=tasks)


def _is_task(span: dict) -> bool:
    return span["stage"].startswith(("thermal case", "bare calibration", "IMU case"))


def write_outputs(run: dict, summ: dict, out: Path, cores: int) -> None:
    roles = summ["roles"]
    with open(out / "spans.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["pid", "role", "stage", "start_s", "end_s", "duration_s", "cpu_s"])
        for s in sorted(run["spans"], key=lambda s: (roles.get(s["pid"], ""), s["start_s"])):
            w.writerow([s["pid"], roles.get(s["pid"], "?"), s["stage"], f"{s['start_s']:.3f}", f"{s['end_s']:.3f}",
                        f"{s['end_s'] - s['start_s']:.3f}", f"{s['cpu_s']:.3f}"])
    with open(out / "cpu.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["pid", "role", "start_s", "end_s", "cpu_s"])
        for pid, t0, t1, cpu in run["samples"]:
            w.writerow([pid, roles.get(pid, "?"), f"{t0:.3f}", f"{t1:.3f}", f"{cpu:.3f}"])
    _figure(run, summ, out / "timeline.png", cores)


def _figure(run: dict, summ: dict, path: Path, cores: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    roles = summ["roles"]
    lanes = sorted(set(roles.values()), key=lambda r: (r != "command", r))
    fig, (ax, ax2) = plt.subplots(2, 1, figsize=(14, 2.0 + 1.4 * len(lanes)), sharex=True,
                                  gridspec_kw={"height_ratios": [3, 1]})
    colors = {}
    cmap = plt.get_cmap("tab20")
    for lane_i, lane in enumerate(lanes):
        mine = sorted((s for s in run["spans"] if roles.get(s["pid"]) == lane),
                      key=lambda s: (s["start_s"], -s["end_s"]))
        stack = []
        for s in mine:
            while stack and stack[-1] <= s["start_s"]:
                stack.pop()
            depth = len(stack)
            stack.append(s["end_s"])
            key = s["stage"].split(" seed")[0]
            colors.setdefault(key, cmap(len(colors) % 20))
            y = lane_i + depth * 0.22
            ax.barh(y, s["end_s"] - s["start_s"], left=s["start_s"], height=0.2, color=colors[key],
                    edgecolor="k", linewidth=0.3)
            if s["end_s"] - s["start_s"] > 0.02 * summ["wall_s"]:
                ax.text(s["start_s"] + 0.05, y, s["stage"], fontsize=5, va="center", clip_on=True)
    ax.set_yticks(range(len(lanes)), lanes)
    ax.invert_yaxis()
    ax.set_title(f"imutherm compare: {summ['wall_s']:.1f} s wall, {sum(summ['cpu_s'].values()):.1f} CPU-s, "
                 f"{summ['idle_core_s']:.1f} core-s idle of {cores} cores (load {run['load']})", fontsize=9)
    width = max(0.5, summ["wall_s"] / 300)   # [s] bins of the busy cores (the /proc ticks are 10 ms)
    busy = {}
    for pid, t0, t1, cpu in run["samples"]:
        lane = roles.get(pid, "?")
        row = busy.setdefault(lane, {})
        k = int(t0 // width)
        row[k] = row.get(k, 0.0) + cpu / width
    n = int(summ["wall_s"] // width) + 1
    x = [k * width for k in range(n)]
    ax2.stackplot(x, *[[busy.get(lane, {}).get(k, 0.0) for k in range(n)] for lane in lanes], labels=lanes,
                  step="post")
    ax2.legend(fontsize=6, loc="upper right", ncol=len(lanes))
    ax2.axhline(cores, color="r", lw=0.5)
    ax2.set_ylabel("busy cores")
    ax2.set_xlabel("time from the command's start [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] == "--child":
        return _child(argv[2:] if len(argv) > 1 and argv[1] == "--" else argv[1:])
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("extra", nargs="*", help="arguments passed to imutherm compare (after --)")
    ap.add_argument("--out", default=None, help="folder of spans.csv, cpu.csv, timeline.png (default: a new one)")
    ap.add_argument("--cache-dir", default=None, metavar="DIR", help="the disk cache (default: a fresh, empty one)")
    ap.add_argument("--cores", type=int, default=min(2, os.cpu_count() or 1), help="cores counted as available")
    args = ap.parse_args(argv)
    out = Path(args.out or tempfile.mkdtemp(prefix="timeline_"))
    out.mkdir(parents=True, exist_ok=True)
    run = run_timeline(args.extra, out, args.cache_dir)
    summ = summarise(run, args.cores)
    write_outputs(run, summ, out, args.cores)
    roles = summ["roles"]
    print(f"imutherm compare {' '.join(args.extra)}: {summ['wall_s']:.1f} s wall, "
          f"{sum(summ['cpu_s'].values()):.1f} CPU-s (sampled), peak {run['peak_mb']:.0f} MB (summed VmRSS), "
          f"load average {run['load']}")
    print(f"  the command alone before the first worker task: {summ['first_task_s']:.1f} s; after the last one: "
          f"{summ['wall_s'] - summ['last_task_end_s']:.1f} s")
    print(f"  idle core-seconds of {args.cores} cores: {summ['idle_core_s']:.1f} (before the first task "
          f"{summ['idle_before_s']:.1f}, after the last {summ['idle_after_s']:.1f})")
    print("  CPU-s per process: " + ", ".join(f"{r} {c:.1f}" for r, c in sorted(summ["cpu_s"].items())))
    for s in sorted(run["spans"], key=lambda s: (roles.get(s["pid"], ""), s["start_s"])):
        print(f"  {roles.get(s['pid'], '?'):<15} {s['start_s']:7.2f} {s['end_s']:7.2f} {s['end_s'] - s['start_s']:6.2f} s"
              f"  cpu {s['cpu_s']:6.2f}  {s['stage']}")
    print(f"wrote {out}/spans.csv cpu.csv timeline.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
