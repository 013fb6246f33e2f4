"""``imutherm compare``: the main job. Solve the three cooling schemes (steady + power-on transient)
and write the comparison report.

Writes in ``--out DIR``: ``report.pdf`` (summary table against the paper, rises,
power-on curves, board temperature maps, the layout), ``compare.json``
(each scheme's ``result.json`` content), ``probes_<scheme>.csv`` and
``map_<scheme>.npz`` (the files the report is drawn from) and ``layout.png``.

Transients: adaptive TR-BDF2 (``--time-tol``, default 0.01 K at the sites), each
ending once every site has settled (``--full-length``: run to ``--t-end``).
"""

from __future__ import annotations

import argparse

from imutherm.cli._common import atomic_outdir, check_outdir, run_guarded
from imutherm.cli.geometry import add_layout_arguments
from imutherm.cli.solve import add_model_arguments, add_time_arguments, model_options, time_kwargs
from imutherm.studies.compare import compare_schemes, write_comparison


@run_guarded("imutherm compare")
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="imutherm compare", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    add_layout_arguments(parser)
    parser.add_argument("--schemes", default="air,grease,potted", help="comma-separated schemes (default all three)")
    add_time_arguments(parser, t_end=2400.0, settle_stop=True)
    parser.add_argument("--steady-only", action="store_true", help="skip the transients")
    parser.add_argument("--no-progress", action="store_true")
    add_model_arguments(parser)
    parser.add_argument("--out", required=True, help="output directory")
    args = parser.parse_args(argv)
    check_outdir(args.out)
    if args.scheme:
        parser.error("use --schemes with compare")
    tkw = {} if args.steady_only else time_kwargs(args)
    schemes = tuple(s.strip() for s in args.schemes.split(",") if s.strip())
    comp = compare_schemes(args.layout, schemes, progress=not args.no_progress, transient=not args.steady_only,
                           mesh_size_mm=args.mesh_size, min_cells=args.min_cells, options=model_options(args), **tkw)
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
