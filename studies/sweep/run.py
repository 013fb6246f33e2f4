"""Running a sweep: the missing cases in this process, in local worker processes or on a Dask cluster.

:func:`run_sweep` runs the cases of a plan not yet in ``results.csv`` (``resume``), or, for a plan on the
reduced model, every case on it and a few re-run on the full FEM as its proof; it writes ``sweep.json``
and returns a frozen :class:`SweepResult`.
"""

from __future__ import annotations

import json
import os
import time
from concurrent.futures import as_completed
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from imutherm import InputError
from imutherm.studies.sweep.case import run_pooled_case, run_case
from imutherm.studies.sweep.plan import SweepPlan, full_case
from imutherm.studies.sweep.results import (RESULTS_CSV, SWEEP_JSON, row_values, design_mismatch, json_text,
                                            row_line, RowWriter, write_text_synced, read_results)
from imutherm.studies.sweep.influence import sensitivity
from imutherm.workers import process_pool, usable_workers


@dataclass(frozen=True)
class SweepResult:
    """The outcome of :func:`run_sweep`.

    out_dir : Path
    plan : SweepPlan
    rows : list of dict, every recorded case sorted by id (values as in ``results.csv``: floats, None when empty)
    ran : int, cases run by this call; skipped : int, cases already recorded (resume)
    failed : int, rows with status ``failed``; lost : tuple of case ids not run (a worker died)
    sensitivity : dict, see :func:`sensitivity`
    wall_s : float [s] of this call
    """

    out_dir: Path
    plan: SweepPlan
    rows: list
    ran: int
    skipped: int
    failed: int
    lost: tuple
    sensitivity: dict
    wall_s: float
    #: the reduced-model sweep's check against the full FEM
    #: (:func:`~imutherm.studies.sweep.surrogate.verification_summary`)
    verification: dict | None = None
    #: timings of the reduced-model sweep [s]: build, evaluation, verification
    timings: dict | None = None


def _progress(total: int, initial: int, enabled: bool):
    from tqdm import tqdm

    return tqdm(total=total, initial=initial, unit="case", desc="sweep", disable=not enabled, dynamic_ncols=True)


def _run_local(pending, settings, jobs, record, lost):
    jobs = usable_workers(jobs, len(pending))   # a worker more than the cases would only hold memory
    if jobs == 1:
        for case in pending:
            record(run_case(case, settings))
        return
    from concurrent.futures.process import BrokenProcessPool

    threads = max(1, (os.cpu_count() or 1) // jobs)
    # spawn: workers start without the parent's numpy, and the thread limits are in their environment
    # before the first task imports it, so they apply when BLAS loads
    pool = process_pool(jobs, threads=threads, spawn=True)
    try:
        futures = {pool.submit(run_pooled_case, c, settings): c.case_id for c in pending}
        for fut in as_completed(futures):
            try:
                record(fut.result())
            except BrokenProcessPool:
                lost.append(futures[fut])
    except BaseException:  # Ctrl-C: drop the queued cases instead of waiting for them
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    pool.shutdown()


def _dask_client(address: str):
    try:
        from distributed import Client
    except ImportError:  # pragma: no cover - a declared dependency
        raise InputError("--dask needs the 'distributed' package: pip install 'dask[distributed]'") from None
    try:
        return Client(address, timeout="10s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise InputError(f"--dask: cannot connect to a Dask scheduler at {address!r}: {exc}") from None


def _run_dask(pending, settings, client, record, lost):
    from distributed import as_completed as dask_completed

    tag = time.time_ns()  # unique task keys: a resumed sweep on the same cluster never reuses old results
    futures = [client.submit(run_case, c, settings, pure=False, key=f"imutherm-sweep-{tag}-case-{c.case_id}")
               for c in pending]
    ids = {f.key: c.case_id for f, c in zip(futures, pending)}
    for fut in dask_completed(futures):
        try:
            record(fut.result())
        except Exception:  # noqa: BLE001 - a lost worker: the case is not recorded, a resume reruns it
            lost.append(ids[fut.key])


def run_sweep(plan: SweepPlan, out_dir, *, jobs: int = 1, dask_address: str | None = None,
              resume: bool = False, progress: bool = True) -> SweepResult:
    """Run the cases of ``plan`` not yet in ``out_dir/results.csv``; write ``sweep.json``.

    jobs : int, local worker processes (1: in this process); dask_address : ``tcp://host:port`` of a
    Dask scheduler (instead of ``jobs``); resume : continue a sweep in ``out_dir`` (its recorded
    design must equal ``plan``'s); progress : tqdm bar on stderr.

    Raises InputError if ``out_dir`` already holds a sweep and ``resume`` is False, or if ``resume``
    finds a different design or no sweep.
    """
    start = time.perf_counter()
    if not isinstance(jobs, int) or jobs < 1:
        raise InputError(f"--jobs must be an integer >= 1, got {jobs!r}")
    out = Path(out_dir)
    csv_path, json_path = out / RESULTS_CSV, out / SWEEP_JSON
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {out} exists and is not a directory")
    rows: list = []
    client = _dask_client(dask_address) if dask_address else None  # before anything is written
    try:
        return _run(plan, out, csv_path, json_path, rows, jobs, dask_address, client, resume, progress, start)
    finally:
        if client is not None:
            client.close()


def _run(plan, out, csv_path, json_path, rows, jobs, dask_address, client, resume, progress, start):
    if resume:
        if not json_path.is_file():
            raise InputError(f"--resume: {json_path} not found; start the sweep without --resume")
        try:
            old = json.loads(json_path.read_bytes().decode("utf-8"))["design"]
            if not isinstance(old, dict):
                raise TypeError("its design is not a table")
        except UnicodeDecodeError as exc:
            raise InputError(f"--resume: {json_path} is damaged (not UTF-8 text at byte {exc.start + 1}); "
                             "start the sweep in a new --out") from None
        except (ValueError, KeyError, TypeError) as exc:
            raise InputError(f"--resume: {json_path} is not a sweep record ({type(exc).__name__}: {exc}); "
                             "start the sweep in a new --out") from None
        diff = design_mismatch(old, plan.design)
        if diff:
            raise InputError(f"--resume: this sweep's design differs from the one recorded in {json_path} "
                             f"in {', '.join(diff)}; give the same --set, --method, --samples, --seed, layout, "
                             "scheme, mesh and model options, or a new --out")
        if csv_path.exists():
            rows = read_results(csv_path, plan.columns, plan.cases, plan.keys)
    else:
        if csv_path.exists() or json_path.exists():
            raise InputError(f"--out {out} already holds a sweep ({RESULTS_CSV}/{SWEEP_JSON}); "
                             "add --resume to continue it or give a new directory")
        out.mkdir(parents=True, exist_ok=True)
        write_text_synced(json_path, json_text({"design": plan.design, "status": "running"}))
    if plan.surrogate == "reduced":
        return _run_reduced(plan, out, csv_path, json_path, jobs, dask_address, client, progress, start)
    done = {r["case"] for r in rows}
    pending = [c for c in plan.cases if c.case_id not in done]
    writer = RowWriter(csv_path, plan)
    lost: list = []
    ran = 0
    bar = _progress(len(plan.cases), len(done), progress)

    def record(row):
        nonlocal ran
        writer.append(row)
        rows.append(dict(zip(plan.columns, row_values(plan, row))))  # as a resume would read it back
        ran += 1
        bar.update(1)

    try:
        if client is not None:
            _run_dask(pending, plan.settings, client, record, lost)
        else:
            _run_local(pending, plan.settings, jobs, record, lost)
    finally:
        bar.close()
        writer.close()
    rows.sort(key=lambda r: r["case"])
    # tidy: the appended file rewritten in case order (atomic replace: a kill now loses nothing)
    write_text_synced(csv_path, ",".join(plan.columns) + "\n" + "".join(row_line(plan, r) for r in rows))
    sens = sensitivity(plan, rows)
    failed = sum(r["status"] == "failed" for r in rows)
    wall = time.perf_counter() - start
    ok_s = [r["seconds"] for r in rows if r["status"] == "ok" and r["seconds"] is not None]
    record_json = {
        "design": plan.design,
        "status": "complete" if len(rows) == len(plan.cases) else "incomplete",
        "counts": {"cases": len(plan.cases), "recorded": len(rows), "ok": len(rows) - failed, "failed": failed,
                   "ran_this_call": ran, "lost": len(lost)},
        "sensitivity": sens,
        "timing": {"wall_s_this_call": wall, "runner": f"dask {dask_address}" if dask_address else f"{jobs} local process(es)",
                   "case_s_mean": float(np.mean(ok_s)) if ok_s else None,
                   "case_s_max": float(np.max(ok_s)) if ok_s else None},
    }
    write_text_synced(json_path, json_text(record_json))
    return SweepResult(out_dir=out, plan=plan, rows=rows, ran=ran, skipped=len(done), failed=failed,
                       lost=tuple(sorted(lost)), sensitivity=sens, wall_s=wall)


def _run_reduced(plan, out, csv_path, json_path, jobs, dask_address, client, progress, start):
    """Every case on the reduced model, ``verify`` random cases re-run on the full FEM (local or Dask).

    The rows are written at once (a run of thousands of cases takes seconds; a resume recomputes them all).
    """
    from imutherm.studies.sweep import surrogate

    say = (lambda m: print(m, flush=True)) if progress else (lambda m: None)
    s = plan.settings
    sur = surrogate.build_surrogate(plan, progress=say)
    t1 = time.perf_counter()
    rows = surrogate.evaluate_all(sur, plan.X, s.transient, s.t_end)
    t_eval = time.perf_counter() - t1
    say(f"reduced model: {len(rows)} cases in {t_eval:.1f} s (basis {sur.rom.basis_size}, built in {sur.build_s:.0f} s)")
    rows = [dict(zip(plan.columns, row_values(plan, r))) for r in rows]
    write_text_synced(csv_path, ",".join(plan.columns) + "\n" + "".join(row_line(plan, r) for r in rows))
    ids = surrogate.pick_cases(len(plan.cases), plan.design["verify"], plan.design["seed"])
    full_rows, lost = [], []
    t2 = time.perf_counter()
    if ids:
        say(f"verifying {len(ids)} case(s) on the full FEM: {ids}")
        pending = [full_case(plan, i) for i in ids]
        bar = _progress(len(ids), 0, progress)

        def record(row):
            full_rows.append(row)
            bar.update(1)
        try:
            if client is not None:
                _run_dask(pending, s, client, record, lost)
            else:
                _run_local(pending, s, jobs, record, lost)
        finally:
            bar.close()
    t_verify = time.perf_counter() - t2
    by_id = {r["case"]: r for r in rows}
    checks = [surrogate.compare_rows(by_id[f["case"]], f, s.sites) for f in sorted(full_rows, key=lambda r: r["case"])]
    checks += [{"case": i, "status": "failed", "message": "worker lost"} for i in lost]
    ver = surrogate.verification_summary(checks, plan.design["verify_tol_K"], surrogate.VERIFY_T95_REL, s.transient)
    sens = sensitivity(plan, rows)
    failed = sum(r["status"] == "failed" for r in rows)
    wall = time.perf_counter() - start
    timings = {"build_s": sur.build_s, "evaluate_s": t_eval, "verify_s": t_verify, "wall_s": wall}
    ok_s = [r["seconds"] for r in rows if r["status"] == "ok"]
    record_json = {
        "design": plan.design,
        "status": "complete",
        "counts": {"cases": len(plan.cases), "recorded": len(rows), "ok": len(rows) - failed, "failed": failed,
                   "ran_this_call": len(rows), "lost": len(lost)},
        "sensitivity": sens,
        "surrogate": {"kind": "reduced", "basis_size": sur.rom.basis_size, "unknowns": sur.rom.unknowns,
                      "full_solves": sur.rom.solves, "coupled_pairs": [list(p) for p in sur.pairs],
                      "knobs": [{"key": k.name, "lo": k.lo, "hi": k.hi, "log": k.log, "nodes": k.nodes,
                                 "load": k.is_load} for k in sur.knobs],
                      "hot_spots": [n for n in sur.rom.site_names if n.startswith("hot@")]},
        "verification": ver,
        "timing": {"wall_s_this_call": wall, "runner": f"dask {dask_address}" if dask_address else f"{jobs} local process(es)",
                   "case_s_mean": float(np.mean(ok_s)) if ok_s else None,
                   "case_s_max": float(np.max(ok_s)) if ok_s else None, **timings},
    }
    write_text_synced(json_path, json_text(record_json))
    return SweepResult(out_dir=out, plan=plan, rows=rows, ran=len(rows), skipped=0, failed=failed, lost=(),
                       sensitivity=sens, wall_s=wall, verification=ver, timings=timings)
