"""``imutherm compare``: the main job. The end-to-end study of the cooling schemes: thermal (steady +
power-on transient), calibration of the assembled unit in the oven, IMU and attitude error in degrees.

Writes in ``--out DIR``: ``report.pdf`` (the design-review document: the answer table on page 1),
``summary.json`` (every figure, with the paper's beside ours), per scheme ``curves_<s>.csv`` (site
temperatures [°C] over the power-on transient), ``residuals_<s>.csv`` (residual sensor errors over the
warm-up), ``attitude_<s>.csv`` (attitude error of each filter over the warm-up), ``steady_<s>.vtu``
(ParaView), ``maps_<s>.npz`` and ``layout_<s>.png``.

``--thermal-only`` (or ``--steady-only``) runs the thermal comparison alone and writes the earlier
files: ``report.pdf``, ``compare.json``, ``probes_<s>.csv``, ``map_<s>.npz``, ``layout.png``.

Transients: adaptive TR-BDF2 (``--time-tol``, default 0.01 K at the sites), each ending once
every site has settled, past its t95 (``--full-length``: run to ``--t-end``).
"""

from __future__ import annotations

from pathlib import Path

from imutherm import InputError
from imutherm.budget import check_study_cost, transient_steps
from imutherm.cli import run_command
from imutherm.cli._common import atomic_outdir, check_outdir
from imutherm.cli._options import (add_jobs_argument, add_layout_arguments, add_model_arguments, add_out_argument,
                                   add_progress_argument, add_time_arguments, check_thermal_cost, model_options,
                                   reject_time_options, time_kwargs)
from imutherm.geometry.build import build_geometry
from imutherm.geometry.layout import load_layout
from imutherm.studies.compare import compare_schemes, write_comparison


def add_args(parser) -> None:
    """The options of ``imutherm compare``."""
    add_layout_arguments(parser, scheme=False)
    parser.add_argument("--schemes", default="air,grease,potted", help="comma-separated schemes (default all three)")
    add_time_arguments(parser, t_end=2400.0, settle_stop=True)
    parser.add_argument("--steady-only", action="store_true", help="thermal steady states only (implies --thermal-only)")
    parser.add_argument("--thermal-only", action="store_true", help="thermal comparison only, no IMU / attitude")
    g = parser.add_argument_group("IMU and attitude (the end-to-end study)")
    g.add_argument("--grade", default="adis16355", help="sensor grade (default adis16355)")
    g.add_argument("--seeds", type=int, default=3, metavar="N",
                   help="units / noise draws, the same in every scheme (default 3)")
    g.add_argument("--seed", type=int, default=0, metavar="N", help="first seed (default 0)")
    g.add_argument("--profiles", default="flight,swing", help="motion profiles (default flight,swing)")
    g.add_argument("--filters", default="gated,kf,ungated,fusion,vqf",
                   help="attitude filters (default gated,kf,ungated,fusion,vqf)")
    g.add_argument("--filter-defaults", action="store_true",
                   help="run the filters at their defaults, not at the tuned settings of "
                        "studies/filter_settings.toml (benchmarks/tune_study_filters.py)")
    g.add_argument("--out-of-range", default="linear", choices=("error", "hold", "linear"),
                   help="compensation beyond the calibrated range: linear (default: extrapolate the "
                        "calibration's temperature trend), hold (clamp), error (refuse)")
    add_jobs_argument(g, default=None,
                      help="processes (default: min(2, CPUs)); the IMU side runs beside the thermal solves")
    add_progress_argument(parser)
    add_model_arguments(parser)
    add_out_argument(parser)


def main(argv=None) -> int:
    """``imutherm compare ARGV...``; returns the exit status."""
    return run_command("compare", argv)


def run(args) -> int:
    """Check everything, run the study of ``args`` and write its outputs; returns 0."""
    check_outdir(args.out)
    if args.steady_only:
        reject_time_options(args, "with --steady-only")
    args.time_kwargs = {} if args.steady_only else time_kwargs(args)
    schemes = tuple(s.strip() for s in args.schemes.split(",") if s.strip())
    if not schemes:
        raise InputError(f"--schemes {args.schemes!r}: give at least one scheme, e.g. air,grease,potted")
    if args.seeds < 1:
        raise InputError(f"--seeds: {args.seeds} is invalid; valid: an integer >= 1")
    if args.seed < 0:
        raise InputError(f"--seed must be an integer >= 0 (numpy seeds are non-negative), got {args.seed}")
    layout = load_layout(args.layout)
    unknown = [s for s in schemes if s not in layout.schemes]
    if unknown:
        raise InputError(f"{layout.path}: unknown scheme(s) {unknown}; valid: {', '.join(layout.schemes)}")
    steps = transient_steps(args.time_kwargs) if args.time_kwargs else 0
    for s in schemes:  # every scheme's mesh and memory estimated before the first is solved
        check_thermal_cost(build_geometry(layout, s), args, steps=steps)
    if not (args.thermal_only or args.steady_only):
        config = _study_config(args)
        check_study_cost(config, len(schemes), args.jobs, args.max_memory)  # the IMU side, before any solve
        return _end_to_end(args, schemes, config)
    comp = compare_schemes(layout, schemes, progress=not args.no_progress, transient=not args.steady_only,
                           mesh_size_mm=args.mesh_size, min_cells=args.min_cells, options=model_options(args),
                           **args.time_kwargs)
    from imutherm.reports.compare_report import write_compare_report
    from imutherm.reports.layout_plot import plot_layout

    with atomic_outdir(args.out) as tmp:
        write_comparison(comp, tmp)
        plot_layout(next(iter(comp.runs.values())).geometry if "grease" not in comp.runs
                    else comp.runs["grease"].geometry, tmp / "layout.png")
        write_compare_report(tmp, tmp / "report.pdf")
    from imutherm.studies.compare import PAPER, PAPER_TABLE_COLUMNS, paper_table

    cols = [c.replace("\n", " ") for c in PAPER_TABLE_COLUMNS]
    rows = paper_table({"paper": PAPER, "schemes": comp.summaries})
    widths = [max(len(c), *(len(r[i]) for r in rows)) for i, c in enumerate(cols)]
    for line in [cols] + rows:
        print("  ".join(v.ljust(w) if i in (0, 3) else v.rjust(w) for i, (v, w) in enumerate(zip(line, widths))))
    print(f"wrote {args.out}/report.pdf compare.json probes_*.csv map_*.npz layout.png")
    return 0


def _study_config(args):
    from imutherm.studies.end_to_end import StudyConfig

    def names(text):
        return tuple(v.strip() for v in text.split(",") if v.strip())

    return StudyConfig(grade=args.grade, seeds=args.seeds, seed0=args.seed, out_of_range=args.out_of_range,
                       profiles=names(args.profiles), filters=names(args.filters),
                       tuned=not args.filter_defaults)


def _end_to_end(args, schemes, config) -> int:
    from imutherm.studies.end_to_end import run_study, write_study

    res = run_study(args.layout, schemes, config=config, options=model_options(args), jobs=args.jobs,
                    progress=not args.no_progress, mesh_size_mm=args.mesh_size, min_cells=args.min_cells,
                    **args.time_kwargs)
    from imutherm.reports.layout_plot import plot_layout
    from imutherm.reports.study_report import write_study_report

    with atomic_outdir(args.out) as tmp:
        summary = write_study(res, tmp)
        for name, st in res.schemes.items():
            plot_layout(st.thermal.geometry, tmp / f"layout_{name}.png")
        write_study_report(tmp, tmp / "report.pdf")
    print_answer(summary)
    print(f"wrote {args.out}/report.pdf summary.json curves_*.csv residuals_*.csv attitude_*.csv steady_*.vtu "
          f"({res.wall_s:.0f} s)")
    return 0


def print_answer(summary: dict) -> None:
    """The answer table on stdout: flight, improved compensation calibrated in the unit, roll/pitch RMS [deg]."""
    from imutherm.studies.end_to_end import ANSWER_COMPENSATION, ANSWER_PROFILE

    st = summary["study"]
    comp = ANSWER_COMPENSATION if ANSWER_COMPENSATION in st["compensations"] else st["compensations"][-1]
    prof = ANSWER_PROFILE if ANSWER_PROFILE in st["profiles"] else st["profiles"][0]
    print(f"{'scheme':<8} {'max rise [K]':>12} {'t95 [s]':>8}  attitude error, {prof}, {comp} compensation, "
          f"roll/pitch RMS [deg] (mean of {len(summary['seeds'])} seeds), warm-up | steady | bare-sensor cal. warm-up")
    for name, s in summary["schemes"].items():
        cells = []
        for f in st["filters"]:
            w = s["attitude"]["warmup"][comp][f][prof]
            d = s["attitude"]["steady"][comp][f][prof]
            b = s["attitude_bare_calibration"]["warmup"][comp][f][prof]
            cells.append(f"{f} {w['roll_rms_deg']['mean']:.2f}/{w['pitch_rms_deg']['mean']:.2f} | "
                         f"{d['roll_rms_deg']['mean']:.2f}/{d['pitch_rms_deg']['mean']:.2f} | "
                         f"{b['roll_rms_deg']['mean']:.2f}/{b['pitch_rms_deg']['mean']:.2f}")
        t95 = s["t95_s"]
        print(f"{name:<8} {s['max_rise_K']:12.2f} {'-' if t95 is None else f'{t95:.0f}':>8}  " + "; ".join(cells[:2]))
        for i in range(2, len(cells), 2):
            print(" " * 32 + "; ".join(cells[i:i + 2]))
    fs = summary.get("filter_settings", {})
    if fs.get("tuned"):
        print(f"filters at their tuned settings ({Path(fs['file']).name}, tuned on seeds "
              f"{', '.join(map(str, fs['meta'].get('seeds', [])))}; --filter-defaults: at defaults)")
    for name, s in summary["schemes"].items():
        print(s["answer"])
