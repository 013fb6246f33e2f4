"""``imutherm compare``: the main job. The end-to-end study of the cooling schemes: thermal (steady +
power-on transient), calibration of the assembled unit in the oven, IMU and attitude error in degrees.

Writes in ``--out DIR``: ``report.pdf`` (the design-review document: the answer table on page 1),
``summary.json`` (every figure, with the paper's beside ours), per scheme ``curves_<s>.csv`` (site
temperatures [°C] over the power-on transient), ``residuals_<s>.csv`` (residual sensor errors over the
warm-up), ``attitude_<s>.csv`` (attitude error of each filter over the warm-up), ``steady_<s>.vtu``
(ParaView), ``maps_<s>.npz`` and ``layout_<s>.png``.

``--thermal-only`` (or ``--steady-only``) runs the thermal comparison alone, the schemes side by side in
``--jobs`` processes, and writes the earlier files: ``report.pdf``, ``compare.json``, ``probes_<s>.csv``,
``map_<s>.npz``, ``layout.png``.

``--uncertainty`` propagates the model's uncertain inputs (each with its range and source) through each
scheme's reduced model to the sensor-die rises, the settle time and the differences between schemes
(:mod:`imutherm.studies.uncertainty.uncertainty`): 5-95 % intervals and Sobol' indices in ``uncertainty.json``
(and ``summary.json``), pages in ``report.pdf`` (``uncertainty.pdf`` with ``--thermal-only``), checked
against the full FEM at ``--uncertainty-checks`` drawn points per scheme; in the end-to-end study,
``--uncertainty-imu-draws`` of the draws also go through the full IMU chain to the residual sensor errors
and the attitude error (:mod:`imutherm.studies.uncertainty.uncertainty_imu`; the study's seeds fixed).

Transients: on a reduced model of each scheme's steady field that checks itself against the full model
(every site within 0.05 K, every t95 within 1 %; :mod:`imutherm.thermal.reduced_transient`), the full
adaptive TR-BDF2 where the check fails or with ``--full`` (``--time-tol``, default 0.01 K at the sites);
each ending once every site has settled, past its t95 (``--full-length``: run to ``--t-end``). Given steps
(``--dt``, ``--theta``) always run the full FEM.
"""

from __future__ import annotations

from pathlib import Path

from imutherm import InputError
from imutherm.budget import refined_cost
from imutherm.studies.cost import (check_jobs, check_schemes_side_by_side, check_study_cost, check_transient_cost,
                                   transient_steps)
from imutherm.cli import run_command
from imutherm.cli._common import atomic_outdir, check_outdir, in_background
from imutherm.cli._options import (add_fitted_model_argument, add_jobs_argument, add_layout_arguments,
                                   add_model_arguments, add_out_argument, add_progress_argument, add_time_arguments,
                                   check_thermal_cost, run_inputs, time_kwargs)
from imutherm.geometry.build import build_geometry
from imutherm.geometry.mesh import grid_shape
from imutherm.studies.compare import compare_schemes, write_comparison


def add_args(parser) -> None:
    """The options of ``imutherm compare``."""
    add_layout_arguments(parser, scheme=False)
    parser.add_argument("--schemes", default=None,
                        help="comma-separated schemes (default: every scheme the layout has; the reference unit's "
                             "air,grease,potted)")
    add_time_arguments(parser, t_end=2400.0, settle_stop=True)
    parser.add_argument("--full", action="store_true",
                        help="power-on transients on the full adaptive FEM and the oven self-heating by the full "
                             "Newton solve (default: on reduced models checked against the full model, the full "
                             "FEM where a check fails)")
    parser.add_argument("--no-mesh-error", action="store_true",
                        help="skip the estimate of each scheme's discretisation error and the answer's correction "
                             "by it (default: the steady solve again on the mesh with every interval split in two, "
                             "Richardson's extrapolation; the site curves, oven rises and hot spot corrected to the "
                             "midpoint between the refined value and the extrapolation; ~8x the steady solve's "
                             "memory, one scheme at a time)")
    parser.add_argument("--steady-only", action="store_true", help="thermal steady states only (implies --thermal-only)")
    parser.add_argument("--thermal-only", action="store_true", help="thermal comparison only, no IMU / attitude")
    g = parser.add_argument_group("IMU and attitude (the end-to-end study)")
    g.add_argument("--grade", default=None, help="sensor grade (default: the grade the layout's sites name, their "
                                                 "chip's, e.g. icm42688p; else adis16355; GYRO+ACCEL for two)")
    g.add_argument("--seeds", type=int, default=3, metavar="N",
                   help="units / noise draws, the same in every scheme (default 3)")
    g.add_argument("--seed", type=int, default=0, metavar="N", help="first seed (default 0)")
    g.add_argument("--profiles", default="flight,swing", help="motion profiles (default flight,swing)")
    from imutherm.imu.filters.registry import study_filters

    g.add_argument("--filters", default=None, metavar="A,B,...",
                   help=f"attitude filters (default: the registry's study filters, {','.join(study_filters())})")
    g.add_argument("--filter-defaults", action="store_true",
                   help="run the filters at their defaults, not at the tuned settings of "
                        "studies/attitude/filter_settings.toml (benchmarks/tune_study_filters.py)")
    g.add_argument("--out-of-range", default="linear", choices=("error", "hold", "linear"),
                   help="compensation beyond the calibrated range: linear (default: extrapolate the "
                        "calibration's temperature trend), hold (clamp), error (refuse)")
    add_jobs_argument(g, default=None,
                      help="processes (default: min(2, CPUs)); the schemes' thermal solves run side by side (the "
                           "mesh-error estimates' refined solves one at a time), the IMU side beside them")
    u = parser.add_argument_group("uncertainty of the answer")
    u.add_argument("--uncertainty", action="store_true",
                   help="propagate the model's uncertain inputs (ranges and sources in the report) to each scheme's "
                        "die rises, t95 and the differences between schemes, on the reduced models")
    u.add_argument("--uncertainty-samples", type=int, default=256, metavar="N",
                   help="Saltelli base samples N, a power of 2: N x (inputs + 2) draws (default 256)")
    u.add_argument("--uncertainty-checks", type=int, default=2, metavar="N",
                   help="drawn points per scheme re-run on the full FEM (the first with the transient; default 2)")
    u.add_argument("--uncertainty-imu-draws", type=int, default=None, metavar="N",
                   help="draws per scheme also run through the full IMU chain to the residual sensor errors and the "
                        "attitude error, the study's seeds fixed (default min(16, --uncertainty-samples); 0: none)")
    parser.add_argument("--no-cache", action="store_true",
                        help="solve every scheme's thermal case again and build --uncertainty's reduced models "
                             "again (default: read them from the disk cache when ones of the same content are "
                             "there, and keep them there: layout, scheme, model options, mesh, time settings, code; "
                             "not the IMU side; $IMUTHERM_CACHE_DIR, $IMUTHERM_CACHE=off)")
    add_progress_argument(parser)
    add_model_arguments(parser)
    add_fitted_model_argument(parser)
    add_out_argument(parser)


def main(argv=None) -> int:
    """``imutherm compare ARGV...``; returns the exit status."""
    return run_command("compare", argv)


def run(args) -> int:
    """Check everything, run the study of ``args`` and write its outputs; returns 0."""
    check_outdir(args.out)
    args.time_kwargs = {} if args.steady_only else time_kwargs(args)
    if args.full and args.steady_only:
        raise InputError("--full chooses how the transients are computed: not with --steady-only")
    if not args.steady_only:
        args.time_kwargs["transient_model"] = "full" if args.full else "reduced"
    if args.schemes is not None and not [s for s in args.schemes.split(",") if s.strip()]:
        raise InputError(f"--schemes {args.schemes!r}: give at least one scheme, e.g. air,grease,potted")
    if args.seeds < 1:
        raise InputError(f"--seeds: {args.seeds} is invalid; valid: an integer >= 1")
    if args.seed < 0:
        raise InputError(f"--seed must be an integer >= 0 (numpy seeds are non-negative), got {args.seed}")
    layout, options, effects, fitted = run_inputs(args)
    from imutherm.studies.paper import check_bench

    check_bench(layout)  # a bad bench file of the layout's [reference_data] refused before any solve
    args.run_model = (layout, options, effects, fitted)
    if args.uncertainty:
        from imutherm.studies.uncertainty.uncertainty import UncertainInput, design, imu_draw_rows

        if args.uncertainty_checks < 0:
            raise InputError(f"--uncertainty-checks must be an integer >= 0, got {args.uncertainty_checks}")
        # a bad sample or draw count is refused before any solve
        design((UncertainInput("x", "-", 0.0, 1.0, False, "-"),), args.uncertainty_samples, 0)
        imu_draw_rows(args.uncertainty_imu_draws, args.uncertainty_samples, 1)
    schemes = chosen_schemes(args.schemes, layout)
    steps = transient_steps(args.time_kwargs) if args.time_kwargs else 0
    solve_bytes, refined_bytes = [], []
    for s in schemes:  # every scheme's mesh and memory estimated before the first is solved
        geometry = build_geometry(layout, s)
        cost = check_thermal_cost(geometry, args, steps=steps, refined=not args.no_mesh_error)
        solve_bytes.append(cost.memory_bytes)
        if not args.no_mesh_error:
            refined_bytes.append(refined_cost("", grid_shape(geometry, args.mesh_size, args.min_cells)).memory_bytes)
        full = args.time_kwargs and (args.full or args.time_kwargs.get("dt") is not None
                                     or args.time_kwargs.get("time_scheme") == "theta")
        if full:   # the full-FEM transients' time, printed (refused past the limit) before anything is solved
            check_transient_cost(f"compare / {s}", args.time_kwargs, cost.unknowns)
    args.time_kwargs["estimate_mesh_error"] = not args.no_mesh_error
    if not (args.thermal_only or args.steady_only):
        config = _study_config(args)
        check_study_cost(config, len(schemes), args.jobs, args.max_memory)  # the IMU side, before any solve
        check_schemes_side_by_side(solve_bytes, refined_bytes, args.jobs, args.max_memory)  # the thermal workers
        return _end_to_end(args, schemes, config)
    check_schemes_side_by_side(solve_bytes, refined_bytes, args.jobs, args.max_memory)
    comp = compare_schemes(layout, schemes, progress=not args.no_progress, jobs=args.jobs,
                           transient=not args.steady_only, mesh_size_mm=args.mesh_size, min_cells=args.min_cells,
                           options=options, use_cache=not args.no_cache,
                           **args.time_kwargs, **({"effects": effects} if effects else {}))
    from imutherm.reports.compare_report import write_compare_report
    from imutherm.reports.layout_plot import plot_layout

    unc = _uncertainty(args, layout, schemes, options)
    with atomic_outdir(args.out) as tmp:
        if unc is not None:
            from imutherm.io import write_json
            from imutherm.reports.uncertainty_report import write_uncertainty_pdf

            write_json(tmp / "uncertainty.json", unc)
            write_uncertainty_pdf(unc, tmp / "uncertainty.pdf")
        write_comparison(comp, tmp, fitted.summary() if fitted is not None else None)
        plot_layout(next(iter(comp.runs.values())).geometry if "grease" not in comp.runs
                    else comp.runs["grease"].geometry, tmp / "layout.png")
        write_compare_report(tmp, tmp / "report.pdf")
    import json

    from imutherm.studies.compare import thermal_table
    from imutherm.studies.paper import bench_lines

    written = json.loads((Path(args.out) / "compare.json").read_text())
    cols, rows = thermal_table(written)
    cols = [c.replace("\n", " ") for c in cols]
    widths = [max(len(c), *(len(r[i]) for r in rows)) for i, c in enumerate(cols)]
    for line in [cols] + rows:
        print("  ".join(v.ljust(w) if i in (0, 3) else v.rjust(w) for i, (v, w) in enumerate(zip(line, widths))))
    if written.get("paper"):
        print(f"paper: {written['paper']['source']} (the layout's [reference_data])")
    for line in bench_lines(written.get("reference")):
        print(line)
    for line in _left_out(written["schemes"], "scheme_description"):
        print(line)
    from imutherm.imu.sensor_model import SITES
    from imutherm.thermal.refinement import fmt_error

    for s, res in comp.runs.items():
        if res.mesh_error is not None:
            print(f"numerical error, {s}: {fmt_error(res.mesh_error, SITES)}")
    if fitted is not None:
        print(fitted.line())
    print(f"wrote {args.out}/report.pdf compare.json probes_*.csv map_*.npz layout.png"
          + (" uncertainty.json uncertainty.pdf" if unc is not None else ""))
    return 0


def chosen_schemes(option: str | None, layout) -> tuple:
    """The schemes ``--schemes`` names, or (None) every scheme of the layout: an imported board has only the
    schemes its importer could make (no grease scheme without a chip to bond to the wall)."""
    if option is None:
        return tuple(layout.schemes)
    schemes = tuple(s.strip() for s in option.split(",") if s.strip())
    unknown = [s for s in schemes if s not in layout.schemes]
    if unknown:
        raise InputError(f"{layout.path}: unknown scheme(s) {unknown}; valid: {', '.join(layout.schemes)}")
    return schemes


def _left_out(schemes: dict, key: str) -> list:
    """An imported unit's scheme whose description says a part could not be bonded (and names --grease)."""
    return [f"{name} scheme: {s[key]}" for name, s in schemes.items() if "--grease" in (s.get(key) or "")]


def _study_config(args):
    from imutherm.studies.end_to_end import StudyConfig

    def names(text):
        return tuple(v.strip() for v in text.split(",") if v.strip())

    filters = {} if args.filters is None else {"filters": names(args.filters)}  # None: the registry's
    from imutherm.imu.site_grades import study_grade

    model = getattr(args, "run_model", None) or run_inputs(args)  # (layout, options, effects, fitted)
    grade, lines = study_grade(model[0], args.grade)  # each site group's grade and its source, printed
    print("\n".join(lines), flush=True)
    return StudyConfig(grade=grade, seeds=args.seeds, seed0=args.seed, out_of_range=args.out_of_range,
                       profiles=names(args.profiles), tuned=not args.filter_defaults, **filters)


def _scheme_files(res, folder) -> None:
    """Each scheme's files (curves, residuals, attitude CSV; VTU; maps), its ``layout_<s>.png`` and, for a board
    imported from a board file, ``board_<name>.png``."""
    from imutherm.reports.layout_plot import plot_layout
    from imutherm.studies.end_to_end import write_scheme_files

    from imutherm.reports.board_plot import imported_boards, plot_board

    write_scheme_files(res, folder)
    for name, st in res.schemes.items():
        plot_layout(st.thermal.geometry, folder / f"layout_{name}.png")
    first = next(iter(res.schemes.values())).thermal.geometry
    for board in imported_boards(first):  # an imported board over its true outline, every part named
        plot_board(first, board, folder / f"board_{board}.png")


def _end_to_end(args, schemes, config) -> int:
    from imutherm.imu.site_grades import grades_summary
    from imutherm.io import write_json
    from imutherm.studies.end_to_end import run_study, study_summary

    layout, options, effects, fitted = args.run_model
    extra = {"effects": effects} if effects else {}
    res = run_study(layout, schemes, config=config, options=options, jobs=args.jobs,
                    progress=not args.no_progress, mesh_size_mm=args.mesh_size, min_cells=args.min_cells,
                    use_cache=not args.no_cache, while_imu=_report_imports, **args.time_kwargs, **extra)
    from imutherm.reports.study_report import write_study_report

    unc = _uncertainty(args, res.layout, schemes, options, study=res)
    with atomic_outdir(args.out) as tmp:
        summary = study_summary(res)
        summary["sensor_grade"] = grades_summary(layout, config.grade)  # named on the report's first page
        if fitted is not None:
            summary["model"] = fitted.summary()
        if unc is not None:
            summary["uncertainty"] = unc
            write_json(tmp / "uncertainty.json", unc)
        write_json(tmp / "summary.json", summary)
        # with more than one job, the schemes' files and layout drawings are written in a second process while
        # this one draws the report's first pages (from summary.json alone): ~2.5 s of the ~6 s after the study
        jobs = check_jobs(args.jobs)
        if jobs > 1:
            files_ready = in_background(_scheme_files, res, tmp)
        else:
            _scheme_files(res, tmp)
            files_ready = None
        drawn = False
        try:
            write_study_report(tmp, tmp / "report.pdf", files_ready=files_ready)
            drawn = True
        finally:   # the files' process has finished before the folder is moved in (or removed)
            if files_ready is not None:
                try:
                    files_ready()
                except OSError:
                    if drawn:
                        raise
    print_answer(summary)
    if fitted is not None:
        print(fitted.line())
    print(f"wrote {args.out}/report.pdf summary.json curves_*.csv residuals_*.csv attitude_*.csv steady_*.vtu "
          + ("uncertainty.json " if unc is not None else "") + f"({res.wall_s:.0f} s)")
    return 0


def _report_imports() -> None:
    """Import what the report and the scheme files use (matplotlib and the report, the layout drawings, meshio):
    ~0.5 CPU-s, called while the workers run the IMU cases (:func:`run_study`'s ``while_imu``) instead of after them,
    when the report is drawn alone (issue 59). Not before the workers start: it would be in their memory too."""
    import meshio  # noqa: F401  (the VTU files)

    import imutherm.reports.board_plot  # noqa: F401
    import imutherm.reports.layout_plot  # noqa: F401
    import imutherm.reports.study_report  # noqa: F401


def _uncertainty(args, layout, schemes, options, study=None):
    """The propagation of ``--uncertainty`` (None without it; with the end-to-end ``study``, its IMU draws too);
    prints its answer."""
    if not args.uncertainty:
        return None
    from imutherm.studies.uncertainty.uncertainty import run_uncertainty

    say = None if args.no_progress else (lambda m: print(m, flush=True))
    unc = run_uncertainty(layout, schemes, options=options, samples=args.uncertainty_samples,
                          seed=args.seed if hasattr(args, "seed") else 0, checks=args.uncertainty_checks,
                          t_end=args.t_end or args.t_end_default, mesh_size_mm=args.mesh_size,
                          min_cells=args.min_cells, progress=say, study=study,
                          imu_draws=args.uncertainty_imu_draws, jobs=getattr(args, "jobs", None),
                          use_cache=not args.no_cache)
    print(f"uncertainty ({len(unc['inputs'])} inputs, {unc['draws']} draws on the reduced models; checked on the "
          f"full FEM: largest site error {unc['max_check_error_K']:.3f} K):" if unc["max_check_error_K"] is not None
          else f"uncertainty ({len(unc['inputs'])} inputs, {unc['draws']} draws, not checked on the full FEM):")
    for s in schemes:
        r, t = unc["stats"][f"max_die_rise_K:{s}"], unc["stats"][f"t95_s:{s}"]
        print(f"  {s:<8} hottest die rise {r['q50']:.2f} K (5-95 %: {r['q05']:.2f} .. {r['q95']:.2f}), t95 "
              f"{t['q50']:.0f} s ({t['q05']:.0f} .. {t['q95']:.0f})" if t["q05"] is not None else
              f"  {s:<8} hottest die rise {r['q50']:.2f} K (5-95 %: {r['q05']:.2f} .. {r['q95']:.2f})")
    imu = unc.get("imu")
    if imu:
        print(f"  IMU chain: {imu['n']} draws x {len(schemes)} schemes, seeds {imu['seeds'][0]}..{imu['seeds'][-1]} "
              f"fixed (the spread is the thermal model's, not the sensor noise draw); {imu['profile']}, "
              f"{imu['compensation']} compensation, calibrated in the unit"
              + (f"; {len({f['draw'] for f in imu['failed']})} draw(s) failed in the chain" if imu["failed"] else ""))
        f0 = imu["filters"][0]
        for s in schemes:
            a, g, c = (imu["stats"][f"{k}:{s}"] for k in (f"warmup_{f0}_roll_rms_deg", "gyro_rms_dps", "accel_rms_mg"))
            if a["n"]:
                print(f"  {s:<8} {f0} warm-up roll RMS {a['q50']:.3f} deg ({a['interval']}: {a['lo']:.3f} .. "
                      f"{a['hi']:.3f}; study {imu['nominal'][f'warmup_{f0}_roll_rms_deg:{s}']['mean']:.3f}), residual "
                      f"gyro {g['q50']:.4f} deg/s ({g['lo']:.4f} .. {g['hi']:.4f}), accel {c['q50']:.2f} mg "
                      f"({c['lo']:.2f} .. {c['hi']:.2f})")
    for note in unc.get("notes", []):
        print(f"  {note}")
    for line in unc["answer"]:
        print(f"  {line}")
    if unc.get("not_propagated"):
        print(f"  not propagated: {unc['not_propagated']}")
    return unc


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
    from imutherm.studies.attitude.real_settings import real_motion_lines

    for line in real_motion_lines(st["filters"]):
        print(line)
    for name, s in summary["schemes"].items():
        print(s["answer"])
    for line in _left_out(summary["schemes"], "description"):
        print(line)
    from imutherm.studies.end_to_end.summary import numerical_error_lines

    for line in numerical_error_lines(summary):
        print(line)


