"""``imutherm compare``: the main job. Solve the three cooling schemes (steady + power-on transient)
and write the comparison report.

Writes in ``--out DIR``: ``report.pdf`` (summary table against the paper, rises,
power-on curves, board temperature maps, the layout), ``compare.json``
(each scheme's ``result.json`` content), ``probes_<scheme>.csv`` and
``map_<scheme>.npz`` (the files the report is drawn from) and ``layout.png``.
"""

from __future__ import annotations

import argparse

from imutherm.cli._common import atomic_outdir, check_outdir, run_guarded
from imutherm import InputError
from imutherm.budget import count_time_steps
from imutherm.cli.geometry import add_layout_arguments, check_thermal_cost
from imutherm.geometry.build import build_geometry
from imutherm.geometry.layout import load_layout
from imutherm.cli.solve import add_model_arguments, model_options
from imutherm.studies.compare import compare_schemes, write_comparison
from imutherm.studies.thermal_study import check_time_arguments


@run_guarded("imutherm compare")
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="imutherm compare", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    add_layout_arguments(parser)
    parser.add_argument("--schemes", default="air,grease,potted", help="comma-separated schemes (default all three)")
    parser.add_argument("--t-end", type=float, default=2400.0, metavar="SECONDS",
                        help="power-on transient length [s] (default 2400: the paper's air scheme settles in ~800 s)")
    parser.add_argument("--dt", type=float, default=2.0, metavar="SECONDS",
                        help="first time step [s]; steps grow by 1.2 up to --dt-max (default 2)")
    parser.add_argument("--dt-max", type=float, default=60.0, metavar="SECONDS", help="largest time step [s] (default 60)")
    parser.add_argument("--steady-only", action="store_true", help="skip the transients")
    parser.add_argument("--no-progress", action="store_true")
    add_model_arguments(parser)
    parser.add_argument("--out", required=True, help="output directory")
    args = parser.parse_args(argv)
    check_outdir(args.out)
    if args.scheme:
        parser.error("use --schemes with compare")
    if not args.steady_only:
        check_time_arguments(args.t_end, args.dt, args.dt_max)
    schemes = tuple(s.strip() for s in args.schemes.split(",") if s.strip())
    if not schemes:
        raise InputError(f"--schemes {args.schemes!r} names no scheme; valid: comma-separated air, grease, potted")
    layout = load_layout(args.layout)
    steps = 0 if args.steady_only else count_time_steps(args.t_end, args.dt, args.dt_max)
    for s in schemes:  # every scheme's mesh and memory estimated before the first is solved
        check_thermal_cost(build_geometry(layout, s), args, steps=steps)
    comp = compare_schemes(layout, schemes, progress=not args.no_progress, transient=not args.steady_only,
                           t_end=args.t_end, dt=args.dt, dt_max=args.dt_max, mesh_size_mm=args.mesh_size, min_cells=args.min_cells,
                           options=model_options(args))
    from imutherm.reports.compare_report import write_compare_report
    from imutherm.reports.layout_plot import plot_layout

    with atomic_outdir(args.out) as tmp:
        write_comparison(comp, tmp)
        plot_layout(next(iter(comp.runs.values())).geometry if "grease" not in comp.runs
                    else comp.runs["grease"].geometry, tmp / "layout.png")
        write_compare_report(tmp, tmp / "report.pdf")
    from imutherm.studies.compare import PAPER
    print(f"{'scheme':<8} {'steady max rise [K]':>19} {'paper sim. [K]':>14} {'hottest part':<14} "
          f"{'tp1 rise [K]':>12} {'t95 tp1 [s]':>11} {'paper settle [s]':>16}")
    for s, r in comp.summaries.items():
        tp1 = r["sites"].get("tp1", {})
        t95 = tp1.get("t95_s")
        meas = PAPER["measured"].get(s, {})
        settle = meas.get("near_steady_s", meas.get("steady_s"))
        print(f"{s:<8} {r['steady_max_rise_K']:19.2f} {PAPER['simulated_max_rise_K'].get(s, float('nan')):14.1f} "
              f"{r['hottest_part']:<14} {tp1.get('rise_K', float('nan')):12.2f} "
              f"{'-' if t95 is None else f'{t95:.0f}':>11} {'-' if settle is None else f'{settle:.0f}':>16}")
    print(f"wrote {args.out}/report.pdf compare.json probes_*.csv map_*.npz layout.png")
    return 0
