"""``imutherm sweep``: a parameter sweep of one cooling scheme, resumable, local or on a Dask cluster.

Each ``--set KEY=VALUES`` names an input by a dotted key into the layout
(``components.reg_5v.power_W``, ``mounting.contact_conductance_W_m2K``,
``environment.ambient_C``, ``boards.main.min_mm.2``), a material of the scheme
(``materials.silicone_grease.k``) or the model options (``options.emissivity``),
and its values: a list ``0.5,1,2`` or a range ``lo:hi:n`` (grid), ``lo:hi``
(lhs, morris, sobol). Every key and every case is checked before the first case runs.

When every key is a knob of the scheme's reduced model (powers, conductivities,
contact and mounting conductances, convection factor, emissivities) the cases
run on it (``--surrogate reduced``, the default then; ``--surrogate none``: the
full FEM) and ``--verify N`` (default 5) random cases are re-run on the full FEM:
their largest site error is in the summary, ``sweep.json`` and the PDF, and a
sweep whose check exceeds ``--verify-tol`` (0.1 K) says so and exits 3.

Writes in ``--out DIR``: ``results.csv`` (one row per case: case id, inputs,
``max_rise_K``, ``t95_s`` with ``--transient``, ``rise_<site>_K``, attitude RMS
errors with ``--attitude``, ``status``,
``message``, ``seconds``; appended as cases finish, so ``--resume`` after a
kill runs only the missing cases), ``sweep.json`` (design, sensitivity ranking,
timing) and ``sweep.pdf`` (each output against each input, ranking of the
inputs' influence).
"""

from __future__ import annotations

from imutherm import InputError
from imutherm.budget import BASE_BYTES, BYTES_PER_UNKNOWN_SOLVE, check_memory
from imutherm.cli import run_command
from imutherm.cli._common import check_outdir
from imutherm.cli._options import (add_fitted_model_argument, add_jobs_argument, add_layout_arguments,
                                   add_model_arguments, add_out_argument, add_progress_argument, check_cavity_cost,
                                   run_inputs)
from imutherm.workers import usable_workers
from imutherm.studies.sweep import METHODS, estimate_cost, plan_sweep, run_sweep
from imutherm.studies.sweep.keys import SURROGATES, VERIFY_DEFAULT, VERIFY_TOL_K
from imutherm.studies.sweep.surrogate import verify_words


def _duration(seconds: float) -> str:
    return f"{seconds:.0f} s" if seconds < 120 else f"{seconds / 60:.1f} min"


def add_args(parser) -> None:
    """The options of ``imutherm sweep``."""
    add_layout_arguments(parser)
    parser.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUES",
                        help="an input and its values (repeatable): KEY=0.5,1,2 or KEY=lo:hi:n (grid), KEY=lo:hi (lhs, morris)")
    parser.add_argument("--method", choices=METHODS, default="grid",
                        help="grid: every combination; lhs: SALib Latin hypercube of --samples cases; "
                             "morris: SALib Morris design of --samples trajectories ((inputs + 1) cases each); "
                             "sobol: SALib Saltelli design, first and total order Sobol' indices "
                             "(--samples N, a power of 2: N x (inputs + 2) cases)")
    parser.add_argument("--samples", type=int, default=None, metavar="N", help="design size of lhs / morris / sobol")
    parser.add_argument("--seed", type=int, default=None, metavar="N", help="seed of the lhs / morris / sobol design")
    parser.add_argument("--surrogate", choices=SURROGATES, default="auto",
                        help="reduced: every case on the scheme's reduced model (every key must be one of its "
                             "knobs); none: every case on the full FEM; auto (default): reduced when it can")
    parser.add_argument("--verify", type=int, default=VERIFY_DEFAULT, metavar="N",
                        help=f"reduced model: cases re-run on the full FEM as its proof (default {VERIFY_DEFAULT})")
    parser.add_argument("--verify-tol", type=float, default=VERIFY_TOL_K, metavar="K",
                        help=f"reduced model: largest site error a verified case may show [K] (default "
                             f"{VERIFY_TOL_K:g}); above it the sweep exits 3")
    parser.add_argument("--transient", action="store_true",
                        help="also run the power-on transient: adds t95_s of the hottest site")
    parser.add_argument("--t-end", type=float, default=1200.0, metavar="SECONDS", help="transient end time [s]")
    parser.add_argument("--attitude", action="store_true",
                        help="add attitude RMS error columns per case (improved compensation, unit calibrated in the "
                             "oven, gated and kf filters, flight; warm-up phase with --transient)")
    parser.add_argument("--attitude-seeds", type=int, default=1, metavar="N",
                        help="IMU units / noise draws averaged per case, the same in every case (default 1)")
    where = parser.add_mutually_exclusive_group()
    add_jobs_argument(where, default=1, help="local worker processes (default 1)")
    where.add_argument("--dask", default=None, metavar="ADDRESS", help="run the cases on a Dask scheduler, tcp://host:port")
    parser.add_argument("--max-cpu-hours", type=float, default=None, metavar="H",
                        help="refuse a sweep estimated to need more CPU time than H hours of one core (default "
                             "168, a week; counted before the design is expanded)")
    parser.add_argument("--resume", action="store_true", help="continue the sweep in --out: run only the missing cases")
    add_progress_argument(parser)
    add_model_arguments(parser)
    add_fitted_model_argument(parser)
    add_out_argument(parser)


def main(argv=None) -> int:
    """``imutherm sweep ARGV...``; returns the exit status."""
    return run_command("sweep", argv)


def run(args) -> int:
    """Plan, run (or resume) the sweep of ``args`` and write its outputs; returns 0, 1 if cases were lost."""
    check_outdir(args.out)
    if args.jobs < 1:
        raise InputError(f"--jobs must be >= 1, got {args.jobs}")
    layout, options, _, fitted = run_inputs(args)  # the layout is re-read per case (plan_sweep)
    plan = plan_sweep(layout.path, args.scheme, args.sets, method=args.method, samples=args.samples,
                      seed=args.seed, options=options, mesh_size_mm=args.mesh_size, min_cells=args.min_cells,
                      transient=args.transient, t_end=args.t_end, attitude=args.attitude,
                      attitude_seeds=args.attitude_seeds, max_cpu_hours=args.max_cpu_hours, fitted=fitted,
                      surrogate=args.surrogate, verify=args.verify, verify_tol_K=args.verify_tol)
    if fitted is not None:
        print(fitted.line())
    # each local worker solves one case at a time: no more workers than cases are started, or counted
    workers = 1 if args.dask else usable_workers(args.jobs, len(plan.cases))
    cost = estimate_cost(plan, workers)
    largest = int(plan.unknowns.max())
    one = BASE_BYTES + BYTES_PER_UNKNOWN_SOLVE * largest
    check_memory(f"sweep: {workers} worker(s) x the largest case ({largest:,} unknowns)", workers * one,
                 args.max_memory, "use a larger --mesh-size or a smaller --jobs")
    from imutherm.geometry.build import build_geometry

    # the s2s patches of the first case (the cases' geometries differ by the swept values only)
    check_cavity_cost(build_geometry(plan.cases[0].layout, plan.settings.scheme), args, "sweep: a case", one, workers)
    d = plan.design
    runner = f"{workers} local process{'es' if workers > 1 else ''}" + (
        f" (--jobs {args.jobs}: {len(plan.cases)} cases)" if workers < args.jobs else "")
    where = (f"{_duration(cost.total_s)} of one core, divided over the cluster's workers" if args.dask
             else f"{_duration(cost.total_s)} on {runner}")
    if plan.surrogate == "reduced":
        print(f"sweep of {d['scheme']} ({d['method']}): {cost.cases} cases of {', '.join(plan.keys)} on the "
              f"reduced model of {cost.unknowns} unknowns (--surrogate reduced), {d['verify']} verified on the "
              f"full FEM; estimate {where}", flush=True)
    else:
        print(f"sweep of {d['scheme']} ({d['method']}): {cost.cases} cases of {', '.join(plan.keys)}; "
              f"~{cost.unknowns} unknowns each, ~{cost.case_s:.0f} s per case on an idle core; estimate {where}",
              flush=True)
    res = run_sweep(plan, args.out, jobs=workers, dask_address=args.dask, resume=args.resume,
                    progress=not args.no_progress)

    from imutherm.reports.sweep_report import write_sweep_pdf

    write_sweep_pdf(res, res.out_dir / "sweep.pdf")
    ok = len(res.rows) - res.failed
    print(f"{len(res.rows)}/{len(plan.cases)} cases recorded ({ok} ok, {res.failed} failed; {res.ran} run now, "
          f"{res.skipped} already recorded) in {_duration(res.wall_s)}")
    for r in res.rows:
        if r["status"] == "failed":
            print(f"  case {r['case']} failed: {r['message']}")
    sens = res.sensitivity
    if sens["ranking"] and sens["measure"] == "sobol":
        by = sens["outputs"]["max_rise_K"]["by_key"]
        print("influence on max_rise_K (Sobol' first-order S1 and total ST, ± 95 % confidence):")
        for k in sens["ranking"]:
            b = by[k]
            print(f"  {k:<40} S1 {b['S1']:6.3f} ± {b['S1_conf']:.3f}   ST {b['ST']:6.3f} ± {b['ST_conf']:.3f}")
    elif sens["ranking"]:
        metric = "mu_star" if sens["measure"] == "morris_mu_star" else "src"
        name = {"mu_star": "Morris mu*", "src": "standardised regression coefficient"}[metric]
        by = sens["outputs"]["max_rise_K"]["by_key"]
        extra = f", R^2 {sens['outputs']['max_rise_K']['r2']:.2f}" if metric == "src" else ""
        print(f"influence on max_rise_K ({name}{extra}):")
        for k in sens["ranking"]:
            print(f"  {k:<40} {by[k][metric]:+.3g}")
    if sens["note"]:
        print(f"note: {sens['note']}")
    if res.verification is not None:
        t = res.timings
        print(f"reduced model: built in {t['build_s']:.1f} s, {len(res.rows)} cases evaluated in "
              f"{t['evaluate_s']:.1f} s, verification {t['verify_s']:.1f} s")
        print(f"verification: {verify_words(res.verification)}")
    print(f"wrote {args.out}/results.csv sweep.json sweep.pdf")
    if res.verification is not None and not res.verification["passed"]:
        print("imutherm sweep: the reduced model's check against the full FEM exceeds its tolerance; its rows "
              "are not to be trusted: rerun with --surrogate none")
        return 3
    if res.lost:
        print(f"imutherm sweep: {len(res.lost)} case(s) not run (a worker process was lost): rerun with --resume")
        return 1
    return 0
