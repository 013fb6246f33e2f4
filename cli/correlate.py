"""``imutherm correlate``: find where the model and measured site temperatures disagree and name the missing effect.

Reads one or more measured CSV files (``time_s`` then one column per site in degC, metadata as
``# key = value`` lines: ``scheme``, ``ambient_C``; optional ``power_scale``, ``t_power_on_s``,
``probe``; see ``imutherm.measured``), localises the residuals, re-tunes the model's uncertain
parameters within their sources' ranges, fits every candidate effect of the library
(``--list-effects``) on top, ranks them by held-out prediction and AICc with an effective sample
size, and writes in ``--out DIR``: ``correlation.json`` (verdict, named effect, parameters with
95 % intervals, ranking, RMS/max before and after, held-out RMS before and after, per-site
residuals, fingerprints), ``updated_model.toml`` (the fitted re-tune values and effect, as
``imutherm solve --effect`` takes them), ``readings.csv`` (every reading side by side: measured, nominal,
corrected, as rises [K]) and ``correlation.pdf``.
"""

from __future__ import annotations

import argparse
import os

from imutherm import InputError
from imutherm.studies.cost import check_jobs
from imutherm.cli import run_command
from imutherm.cli._common import atomic_outdir, check_outdir
from imutherm.cli._options import (add_jobs_argument, add_layout_arguments, add_model_arguments, add_out_argument,
                                   model_options)
from imutherm.io import write_json


def add_args(parser) -> None:
    """The options of ``imutherm correlate``."""
    add_layout_arguments(parser, scheme=False)  # the schemes come from the measured files
    parser.add_argument("--measured", nargs="+", default=None, metavar="CSV", help="measured files (one per experiment)")
    parser.add_argument("--holdout", default="auto", metavar="auto|FILE",
                        help="held-out data: auto (each file's first 60 %% of its time fitted, the rest predicted; "
                             "sparse files: one reading left out at a time) or a file to leave out whole")
    parser.add_argument("--list-effects", action="store_true", help="print the library of candidate effects and exit")
    parser.add_argument("--no-rerun", action="store_true",
                        help="report the corrected model from the reduced model's fit only (default: re-run it on "
                             "the full FEM, one transient per file)")
    parser.add_argument("--full", action="store_true",
                        help="the re-run's transients on the full adaptive FEM (default: the full steady solve and "
                             "the transient on a reduced model checked against the full model, the full FEM where "
                             "the check fails, as compare does)")
    add_jobs_argument(parser, None, "worker processes for the reduced models and the re-runs "
                                    "(default: 2, or 1 on one core)")
    parser.add_argument("--discrepancy", action=argparse.BooleanOptionalAction, default=None,
                        help="the model-discrepancy term (the model's own error: a smooth gain and time-constant "
                             "correction per file and site, its scale estimated from the data), verdict "
                             "'discrepancy' when the model's form is off and no effect explains it. Default: used "
                             "only where the library's effects leave held-out data more than 2 noise sigmas off; "
                             "--discrepancy always, --no-discrepancy never; not fitted on sparse files "
                             "(docs: correlation.md)")
    parser.add_argument("--max-effects", type=int, default=None, metavar="N",
                        help="forward selection names at most N library effects (default 3; 1: one effect)")
    parser.add_argument("--cavity-emissivity-as-effect", action="store_true",
                        help="offer the cavity's emissivity as a candidate effect to be named (default: re-tuned "
                             "beside the other uncertain parameters, since the cavity radiation's law is itself "
                             "uncertain and a model-form mismatch looks like a change of it)")
    parser.add_argument("--no-report", action="store_true", help="no correlation.pdf")
    parser.add_argument("--no-cache", action="store_true",
                        help="neither read nor keep the reduced models and the re-run in the disk cache "
                             "($IMUTHERM_CACHE_DIR, default the user cache folder; size limit $IMUTHERM_CACHE_MB)")
    add_out_argument(parser, required=False, help="output directory (required unless --list-effects)")
    add_model_arguments(parser)


#: peak memory of one reduced-model build per mesh unknown [bytes]: 1.0 GB per worker at 1.75e5 unknowns
#: (benchmarks/bench_correlation_speed.py, as :func:`imutherm.studies.correlation.build_models` says), rounded up
BYTES_PER_UNKNOWN_BUILD = 1.1e9 / 175e3
#: CPU time of one build per mesh unknown [s]: ~56 s each at 1.75e5 unknowns (the same benchmark), rounded up
SECONDS_PER_UNKNOWN_BUILD = 60.0 / 175e3
#: most estimated wall time of the builds [s]: 6 h, as the other commands' limits
MAX_BUILD_S = 6 * 3600.0


def _check_build_cost(layout, runs, args, jobs: int) -> None:
    """The reduced models' builds (one per scheme and ambient, ``jobs`` at once; time limit :data:`MAX_BUILD_S`)
    and, with the s2s law, their patches against ``--max-memory``, before any is built."""
    from imutherm.budget import BASE_BYTES, check_cost, check_memory, thermal_cost
    from imutherm.cli._options import check_cavity_cost
    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.mesh import grid_shape

    keys = sorted({(r.scheme, r.ambient_C) for r in runs})
    workers = max(1, min(jobs, len(keys)))
    for scheme in sorted({k[0] for k in keys}):
        geo = build_geometry(layout, scheme)
        shape = grid_shape(geo, args.mesh_size, args.min_cells)
        # the mesh's own limits (cells) and one solve's memory first, then the builds'
        nodes = check_cost(thermal_cost(f"correlate: the reduced model of {scheme}", shape), args.max_memory).unknowns
        each = BASE_BYTES + BYTES_PER_UNKNOWN_BUILD * nodes
        what = f"correlate: {len(keys)} reduced model(s) of {nodes:,} unknowns, {workers} at once"
        hours = len(keys) * SECONDS_PER_UNKNOWN_BUILD * nodes / workers / 3600
        if hours > MAX_BUILD_S / 3600:
            raise InputError(f"{what}: estimated ~{hours:,.3g} h, more than the limit of {MAX_BUILD_S / 3600:g} h; "
                             "use a larger --mesh-size")
        check_memory(what, workers * each, args.max_memory, "use a larger --mesh-size or a smaller --jobs")
        check_cavity_cost(geo, args, f"correlate: the reduced model of {scheme}", each, workers)


def main(argv=None) -> int:
    """``imutherm correlate ARGV...``; returns the exit status."""
    return run_command("correlate", argv)


def run(args) -> int:
    """Correlate the measured files of ``args`` with the model and write the outputs; returns 0."""
    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.layout import load_layout
    from imutherm.measured import read_measured
    from imutherm.unit.effects import list_effects
    if args.list_effects:
        print(list_effects())
        from imutherm.studies.correlation import FORM_RETUNE
        for name, why in FORM_RETUNE.items():
            print(f"\nnote: {name} is re-tuned, not named, unless --cavity-emissivity-as-effect: {why}")
        return 0
    if not args.measured:
        raise InputError("--measured: give at least one measured CSV file")
    if not args.out:
        raise InputError("--out: give the output directory")
    jobs = check_jobs(args.jobs)
    from imutherm.studies.correlation import MAX_EFFECTS
    max_effects = MAX_EFFECTS if args.max_effects is None else args.max_effects
    if max_effects < 1:
        raise InputError(f"--max-effects: {max_effects} is invalid; valid: an integer >= 1")
    check_outdir(args.out)
    layout = load_layout(args.layout)
    sites = tuple(build_geometry(layout, None).sites)
    runs = [read_measured(p, sites=sites, schemes=tuple(layout.schemes)) for p in args.measured]
    _check_build_cost(layout, runs, args, jobs)
    from imutherm.studies.correlation import correlate, reading_rows, result_json, updated_model_toml
    res = correlate(runs, layout, holdout=args.holdout, mesh_size_mm=args.mesh_size, min_cells=args.min_cells,
                    options=model_options(args), rerun=not args.no_rerun, jobs=jobs, use_cache=not args.no_cache,
                    progress=lambda s: print(f"  {s}", flush=True),
                    discrepancy="auto" if args.discrepancy is None else args.discrepancy,
                    max_effects=max_effects, form_retune=not args.cavity_emissivity_as_effect,
                    rerun_transient="full" if args.full else "reduced")
    data = result_json(res)
    with atomic_outdir(args.out) as tmp:
        write_json(tmp / "correlation.json", data)
        (tmp / "updated_model.toml").write_text(updated_model_toml(res, layout.path, model_options(args)))
        _write_readings(tmp / "readings.csv", reading_rows(res))
        if not args.no_report:
            from imutherm.reports.correlation_report import write_report
            write_report(tmp / "correlation.pdf", res)
    print(f"verdict: {res.verdict}" + (f" ({' + '.join(res.named_effects)})" if res.named_effects else "")
          + (f" {', '.join(res.ambiguous_set)}" if res.ambiguous_set else ""))
    print(f"  {res.words}")
    for f in res.findings:
        print(f"  finding: {f.words()}")
    for x in res.symptoms:
        print(f"  symptom: {x.words()}")
    if res.next_experiment:
        print(f"  {res.next_experiment['in_words']}")
    if res.written and res.written["model"] != "corrected":
        print(f"  written: {res.written['model']}: {res.written['reason']}")
    print(f"  RMS {data['rms_before_K']:.2f} -> {data['rms_after_K']:.2f} K, max {data['max_before_K']:.2f} -> "
          f"{data['max_after_K']:.2f} K ({data['after_from']}), held-out RMS {data['heldout_rms_before_K'] or float('nan'):.2f} -> "
          f"{data['heldout_rms_after_K'] or float('nan'):.2f} K; noise {res.noise_K:.2f} K")
    for tr in data["rerun_transients"] or ():
        est = tr["estimated_error_K"]
        how = (f"reduced transient, estimated error {est:.3f} K" if tr["transient"] == "reduced" else
               "steady readings only" if tr["transient"] is None else
               "full adaptive transient" + (f" ({tr['reason']})" if tr["reason"] else ""))
        print(f"  re-run of {os.path.basename(tr['file'])}: {how}")
    for f in data["ranking"][:6]:
        print(f"  {f['name']:<22} dAICc {f['delta_aicc_vs_none']:8.1f}  RMS {f['rms_K']:.3f} K  "
              f"held-out {f['heldout_rms_K'] if f['heldout_rms_K'] is not None else float('nan'):.3f} K")
    print(f"  {res.timings['total_s']:.0f} s; wrote {args.out}/correlation.json updated_model.toml readings.csv"
          + ("" if args.no_report else " correlation.pdf"))
    return 0


#: the columns of ``readings.csv`` (rises over the file's ambient [K]; time_s inf: the steady reading)
READING_COLUMNS = ("file", "scheme", "ambient_C", "site", "time_s", "measured_K", "nominal_K", "corrected_K",
                   "corrected_with_term_K", "corrected_full_K")


def _write_readings(path, rows) -> None:
    """``readings.csv``: one line per reading, a column left empty where the fit has no such figure."""
    import csv

    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(READING_COLUMNS)
        for r in rows:
            w.writerow([("" if r.get(k) is None else r[k] if isinstance(r[k], str) else f"{r[k]:.6g}")
                        for k in READING_COLUMNS])
