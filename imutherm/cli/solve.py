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

import argparse
import math

import numpy as np

from imutherm import InputError
from imutherm.cli._common import (FIELD_FILES, _test_pause, atomic_outdir, check_outdir, help_text, run_guarded,
                                  write_json)
from imutherm.budget import MAX_SAVED_FIELDS, transient_steps
from imutherm.cli.geometry import add_layout_arguments, check_thermal_cost
from imutherm.geometry.build import build_geometry
from imutherm.geometry.layout import load_layout
from imutherm.studies.thermal_study import check_time_arguments, probe_table, result_summary, run_scheme
from imutherm.thermal.effects import list_effects, parse_effect
from imutherm.thermal.cavity_radiation import DEFAULT_PATCH_MM
from imutherm.thermal.model import CAVITY_LAWS, ModelOptions
from imutherm.site_table import write_site_table
from imutherm.thermal.output import write_result


def add_model_arguments(parser: argparse.ArgumentParser) -> None:
    """Switches of the physical model (see ``imutherm.thermal.model.ModelOptions``)."""
    g = parser.add_argument_group("model")
    g.add_argument("--exterior", choices=("natural", "fixed", "none"), default="natural",
                   help="exterior convection: face-orientation natural convection (default), fixed h, or none")
    g.add_argument("--h", type=float, default=10.0, metavar="W/m2K", help="h of --exterior fixed [W/m^2 K]")
    g.add_argument("--no-radiation", action="store_true", help="switch off exterior radiation")
    g.add_argument("--emissivity", type=float, default=None, help="housing emissivity [-] (default: its material's)")
    g.add_argument("--mount-conductance", type=float, default=None, metavar="W/m2K",
                   help="contact conductance to the mounting fixture [W/m^2 K] (default: the layout's)")
    g.add_argument("--no-cavity-radiation", action="store_true", help="switch off radiation across the cavity air")
    g.add_argument("--cavity-law", choices=CAVITY_LAWS, default="effective",
                   help="radiation inside the cavity: an effective conductivity of the air (default), s2s "
                        "(surface-to-surface exchange: view factors and radiosity) or none")
    g.add_argument("--cavity-patch-mm", type=float, default=DEFAULT_PATCH_MM, metavar="MM",
                   help=f"patch edge of --cavity-law s2s [mm] (default {DEFAULT_PATCH_MM:g})")


def add_effect_argument(parser: argparse.ArgumentParser) -> None:
    """``--effect``: candidate effects of :mod:`imutherm.thermal.effects` switched on."""
    parser.add_argument("--effect", action="append", default=[], metavar="NAME[@TARGET]:PARAM=VALUE",
                        help="switch on a candidate effect of the correlation library (repeatable; "
                             "`--list-effects` lists them), e.g. contact@bond:h_W_m2K=500")


def add_time_arguments(parser: argparse.ArgumentParser, t_end: float, settle_stop: bool = False) -> None:
    """Time stepping of the power-on transient (shared by ``solve`` and ``compare``)."""
    g = parser.add_argument_group("time stepping")
    g.add_argument("--t-end", type=float, default=None, metavar="SECONDS",
                   help=f"transient end time [s] (default {t_end:g}; the latest end with --until-settled)")
    # None above tells "not given" from the default (see reject_time_options); time_kwargs fills it in
    parser.set_defaults(t_end_default=t_end, settle_flag="--full-length" if settle_stop else "--until-settled")
    g.add_argument("--time-tol", type=float, default=None, metavar="K",
                   help="local error tolerance of the adaptive TR-BDF2 steps at the sites [K] (default 0.01)")
    g.add_argument("--dt", type=float, default=None, metavar="SECONDS",
                   help="given steps instead of error control: first step [s], constant, or growing by 1.2 "
                        "up to --dt-max (theta scheme default: 2 s up to 60 s)")
    g.add_argument("--dt-max", type=float, default=None, metavar="SECONDS",
                   help="largest step [s] (adaptive default 300)")
    g.add_argument("--theta", type=float, default=None,
                   help="use the theta scheme with given steps instead of TR-BDF2: 1 backward Euler, "
                        "0.5 Crank-Nicolson (in [0.5, 1]; needs --transient)")
    if settle_stop:
        g.add_argument("--full-length", dest="until_settled", action="store_false",
                       help="run every transient to --t-end (default: stop once every site is within 0.5 %% "
                            "of its steady rise, past its t95)")
    else:
        g.add_argument("--until-settled", action="store_true",
                       help="stop once every site is within 0.5 %% of its steady rise (past its t95)")


def reject_time_options(args, why: str) -> None:
    """InputError naming the options of :func:`add_time_arguments` (and ``--save-every``) that were given
    although no transient runs (``why``): they would be silently ignored."""
    given = [opt for opt, dest in (("--t-end", "t_end"), ("--time-tol", "time_tol"), ("--dt", "dt"),
                                   ("--dt-max", "dt_max"), ("--theta", "theta"), ("--save-every", "save_every"))
             if getattr(args, dest, None) is not None]
    if args.until_settled == (args.settle_flag == "--until-settled"):
        given.append(args.settle_flag)
    if given:
        raise InputError(f"{', '.join(given)}: time stepping given {why}; a steady solve has no time steps, "
                         f"so drop {'it' if len(given) == 1 else 'them'} or run the transient")


def time_kwargs(args) -> dict:
    """``run_scheme`` time arguments from the options of :func:`add_time_arguments` (checked)."""
    if args.t_end is None:
        args.t_end = args.t_end_default
    if args.theta is not None and not 0.5 <= args.theta <= 1.0:
        raise InputError(f"--theta must be in [0.5, 1] (1 backward Euler, 0.5 Crank-Nicolson), got {args.theta}")
    if args.time_tol is not None and (args.dt is not None or args.theta is not None):
        raise InputError("--time-tol sets the error-controlled TR-BDF2 steps: not with --dt or --theta")
    scheme = "trbdf2" if args.theta is None else "theta"
    check_time_arguments(args.t_end, args.dt, args.dt_max, args.time_tol, scheme)
    kw = dict(t_end=args.t_end, time_scheme=scheme, tol_K=args.time_tol, dt=args.dt, dt_max=args.dt_max,
              until_settled=args.until_settled)
    if args.theta is not None:
        kw["theta"] = args.theta
    return kw


def model_options(args) -> ModelOptions:
    return ModelOptions(exterior=args.exterior, h_fixed_W_m2K=args.h, radiation=not args.no_radiation,
                        emissivity=args.emissivity, mounting_conductance_W_m2K=args.mount_conductance,
                        cavity_radiation=not args.no_cavity_radiation, cavity_law=args.cavity_law,
                        cavity_patch_mm=args.cavity_patch_mm)


@run_guarded("imutherm solve")
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="imutherm solve", description=help_text(__doc__),
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    add_layout_arguments(parser)
    parser.add_argument("--transient", action="store_true", help="power-on transient from ambient")
    add_time_arguments(parser, t_end=1200.0)
    parser.add_argument("--save-every", type=float, default=None, metavar="SECONDS",
                        help="keep the whole field every SECONDS for the PVD series (default: t_end/10)")
    parser.add_argument("--site", action="append", default=None, metavar="NAME",
                        help="report only these sites (repeatable; default all)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_model_arguments(parser)
    add_effect_argument(parser)
    parser.add_argument("--list-effects", action="store_true",
                        help="print the library of candidate effects (parameters, bounds, sources) and exit")
    parser.add_argument("--out", default=None, help="output directory (required unless --list-effects)")
    args = parser.parse_args(argv)
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
    else:
        reject_time_options(args, "without --transient")
        tkw = {}
    options = model_options(args)
    effects = tuple(parse_effect(e) for e in args.effect)
    if len({e.name for e in effects}) != len(effects):
        raise InputError("--effect: an effect is given twice")
    layout = load_layout(args.layout)
    geometry = build_geometry(layout, args.scheme)
    check_thermal_cost(geometry, args, steps=transient_steps(tkw) if args.transient else 0,
                       saved=len(save_times) if save_times is not None else 1)
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
