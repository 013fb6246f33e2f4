"""``imutherm solve``: steady or power-on transient thermal solve of one cooling scheme.

The transient is TR-BDF2 (second order, L-stable) with error-controlled
steps (``--time-tol``, default 0.01 K at the sites), or given steps
(``--dt``/``--dt-max``), or the theta scheme (``--theta``);
``--until-settled`` ends it once every site has settled.

Writes in ``--out DIR``: ``result.json`` (rises, hot spot, per-site rise and
t63/t95, energy balance, unknowns, timings), ``probes.csv`` (``time_s`` then
one column per site, degC; a steady run has one row at time ``inf``) and the
field for ParaView: ``field.vtu`` (steady) or ``field.pvd`` + ``field_*.vtu``
(transient, at ``--save-every`` intervals and the end). Field files of an
earlier run in DIR are removed, so DIR holds only this run's field.
"""

from __future__ import annotations

import math

import numpy as np

from imutherm import InputError
from imutherm.budget import MAX_SAVED_FIELDS
from imutherm.studies.cost import check_transient_cost, transient_steps
from imutherm.cli import run_command
from imutherm.cli._common import FIELD_FILES, _test_pause, atomic_outdir, check_outdir, write_json
from imutherm.cli._options import (add_effect_argument, add_fitted_model_argument, add_layout_arguments,
                                   add_model_arguments, add_out_argument, add_progress_argument, add_time_arguments,
                                   check_thermal_cost, run_inputs, time_kwargs)
from imutherm.geometry.build import build_geometry
from imutherm.site_table import write_site_table
from imutherm.studies.thermal.thermal_study import probe_table, result_summary, run_scheme
from imutherm.unit.effects import list_effects, parse_effect
from imutherm.thermal.output import write_result


def add_args(parser) -> None:
    """The options of ``imutherm solve``."""
    add_layout_arguments(parser)
    parser.add_argument("--transient", action="store_true", help="power-on transient from ambient")
    add_time_arguments(parser, t_end=1200.0)
    parser.add_argument("--save-every", type=float, default=None, metavar="SECONDS",
                        help="keep the whole field every SECONDS for the PVD series (default: t_end/10)")
    parser.add_argument("--site", action="append", default=None, metavar="NAME",
                        help="report only these sites (repeatable; default all)")
    add_progress_argument(parser)
    add_model_arguments(parser)
    add_effect_argument(parser)
    add_fitted_model_argument(parser)
    parser.add_argument("--list-effects", action="store_true",
                        help="print the library of candidate effects (parameters, bounds, sources) and exit")
    add_out_argument(parser, required=False, help="output directory (required unless --list-effects)")


def main(argv=None) -> int:
    """``imutherm solve ARGV...``; returns the exit status."""
    return run_command("solve", argv)


def run(args) -> int:
    """Check everything, solve and write the outputs of ``args``; returns 0."""
    if args.list_effects:
        print(list_effects())
        return 0
    if args.out is None:
        raise InputError("--out: give the output directory")

    # everything that can be checked is checked before meshing and solving
    check_outdir(args.out)
    save_times = None
    if args.transient:
        tkw = time_kwargs(args)
        if args.save_every is not None and not (math.isfinite(args.save_every) and args.save_every > 0):
            raise InputError(f"--save-every must be a finite number > 0 [s], got {args.save_every}")
        every = args.save_every if args.save_every is not None else args.t_end / 10
        if args.t_end / every > MAX_SAVED_FIELDS:
            raise InputError(f"--save-every {every:g} s keeps {args.t_end / every:.3g} fields of a {args.t_end:g} s "
                             f"run, more than the limit of {MAX_SAVED_FIELDS}; use a larger --save-every")
        save_times = np.unique(np.append(np.arange(0.0, args.t_end, every), args.t_end))
    else:  # time options without --transient are refused by imutherm.cli._ignored
        tkw = {}
    layout, options, fitted_effects, fitted = run_inputs(args)
    effects = fitted_effects + tuple(parse_effect(e) for e in args.effect)
    if len({e.name for e in effects}) != len(effects):
        raise InputError("--effect: an effect is given twice (or again beside the --model file's)")
    geometry = build_geometry(layout, args.scheme)
    cost = check_thermal_cost(geometry, args, steps=transient_steps(tkw) if args.transient else 0,
                              saved=len(save_times) if save_times is not None else 1)
    if args.transient:   # the time it will take, printed (and refused past the limit) before anything is solved
        check_transient_cost(f"solve of {geometry.layout.name} / {geometry.scheme.name}", tkw, cost.unknowns)
    sites = list(geometry.sites)
    if args.site:
        unknown = [s for s in args.site if s not in sites]
        if unknown:
            raise InputError(f"--site: unknown site(s) {', '.join(unknown)}; valid: {', '.join(sites)}")

    _test_pause("solving")
    res = run_scheme(layout, args.scheme, mesh_size_mm=args.mesh_size, min_cells=args.min_cells,
                     options=options, transient=args.transient, save_times=save_times,
                     progress=args.transient and not args.no_progress, effects=effects, **tkw)
    summary = result_summary(res)
    summary["effects"] = [e.text() for e in effects]
    if fitted is not None:
        summary["model"] = fitted.summary()
    header, rows = probe_table(res)
    if args.site:
        keep = [0] + [header.index(s) for s in args.site]
        header, rows = [header[i] for i in keep], rows[:, keep]
        summary["sites"] = {s: summary["sites"][s] for s in args.site}
    with atomic_outdir(args.out, stale=FIELD_FILES) as tmp:
        write_json(tmp / "result.json", summary)
        write_site_table(tmp / "probes.csv", rows[:, 0], header[1:], rows[:, 1:])
        write_result(tmp / "field", res.transient if res.transient is not None else res.steady)
    print(f"{summary['layout']} / {summary['scheme']} ({summary['mode']}): max rise {summary['max_rise_K']:.2f} K "
          f"({summary['max_temperature_C']:.2f} C) in {summary['hottest_part']}; "
          f"energy balance {summary['energy_balance_rel_error']:.1e}; {summary['unknowns']} unknowns; "
          f"{summary['timings_s']['wall']:.1f} s")
    if fitted is not None:
        print(f"  {fitted.line()}")
    if args.transient:
        how = (f"theta {summary['theta']:g}" if summary["time_scheme"] == "theta" else
               "TR-BDF2" + (f", tol {summary['time_tol_K']:g} K" if summary["time_tol_K"] is not None else ""))
        print(f"  {how}: {summary['steps']} steps ({summary['rejected_steps']} rejected), "
              f"{summary['linear_solves']} linear solves, to {summary['t_end_s']:.0f} s"
              + (" (settled)" if summary["settled"] else ""))
    for name, s in summary["sites"].items():
        extra = f", t63 {s['t63_s']:.0f} s, t95 {s['t95_s']:.0f} s" if s.get("t95_s") is not None else ""
        print(f"  {name:<8} rise {s['rise_K']:6.2f} K{extra}")
    print(f"wrote {args.out}/result.json probes.csv field.{'pvd' if args.transient else 'vtu'}")
    return 0
