"""Option groups shared by the subcommands: each ``add_*`` adds its options to a command's parser (called from
the command's ``add_args``), the helpers below turn the parsed values into the studies' arguments."""

from __future__ import annotations

import argparse

from imutherm import InputError
from imutherm.budget import check_cost, parse_size, thermal_cost

# the thermal modules are imported where used: commands that take only --out or --jobs do not load them


# ------------------------------------------------------------------ memory limit
def memory_type(text: str) -> int:
    """argparse ``type`` of ``--max-memory``."""
    try:
        return parse_size(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_memory_argument(parser) -> None:
    """``--max-memory SIZE`` (default: the machine's available memory)."""
    parser.add_argument("--max-memory", type=memory_type, default=None, metavar="SIZE",
                        help="refuse runs estimated to need more memory than SIZE (e.g. 8G, 500M; "
                             "default: the memory available now, MemAvailable of /proc/meminfo)")


# ------------------------------------------------------------------ layout and mesh
def add_layout_arguments(parser: argparse.ArgumentParser, scheme: bool = True) -> None:
    """LAYOUT, --scheme (unless ``scheme`` is False: ``compare`` takes ``--schemes``), --mesh-size,
    --min-cells, --max-memory: shared by the commands that mesh a layout."""
    from imutherm.geometry.layout import builtin_layouts
    from imutherm.geometry.mesh import DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS

    parser.add_argument("layout", nargs="?", default=None,
                        help="layout: a TOML file or a built-in layout name "
                             f"({', '.join(builtin_layouts())}; default: imu_reference, the paper's unit)")
    if scheme:
        parser.add_argument("--scheme", default=None,
                            help="cooling scheme: air, grease or potted (default: the layout's)")
    parser.add_argument("--mesh-size", type=float, default=DEFAULT_MAX_CELL_MM, metavar="MM",
                        help=f"largest cell edge [mm] (default {DEFAULT_MAX_CELL_MM})")
    parser.add_argument("--min-cells", type=int, default=DEFAULT_MIN_CELLS,
                        help=f"fewest cells across any part's thinnest dimension (default {DEFAULT_MIN_CELLS})")
    add_memory_argument(parser)


def check_thermal_cost(geometry, args, *, steps: int = 0, saved: int = 1, geometry_only: bool = False,
                       refined: bool = False):
    """Estimate the mesh (from its grid lines only) and the run's memory; InputError beyond ``--max-memory``.
    With ``--cavity-law s2s`` the patches are counted too (:func:`check_cavity_cost`); with ``refined``, the
    mesh-error estimate's solve on the mesh refined 2x (:func:`imutherm.budget.refined_cost`)."""
    from imutherm.budget import refined_cost
    from imutherm.geometry.mesh import grid_shape

    shape = grid_shape(geometry, args.mesh_size, args.min_cells)
    what = f"{'geometry' if geometry_only else 'solve'} of {geometry.layout.name} / {geometry.scheme.name}"
    cost = check_cost(thermal_cost(what, shape, steps=steps, saved=saved, geometry_only=geometry_only),
                      args.max_memory)
    if refined:
        check_cost(refined_cost(f"mesh-error estimate of {geometry.layout.name} / {geometry.scheme.name}", shape),
                   args.max_memory, "use --no-mesh-error, a larger --mesh-size or a smaller --min-cells")
    if not geometry_only:
        check_cavity_cost(geometry, args, what, cost.memory_bytes)
    return cost


def check_cavity_cost(geometry, args, what: str, other_bytes: float = 0.0, workers: int = 1):
    """With ``--cavity-law s2s``: count the patches (mesh and faces only; nothing of n^2 size exists yet),
    print the exchange's estimate and refuse it (:func:`imutherm.budget.check_s2s_cost`) beyond its time
    limit or, ``workers`` at once beside ``other_bytes``, beyond ``--max-memory``. Returns the patch count."""
    from imutherm.budget import check_s2s_cost, fmt_bytes
    from imutherm.unit.model import s2s_patch_choice

    options = model_options(args)
    choice = s2s_patch_choice(geometry, options, args.mesh_size, args.min_cells)
    n = 0 if choice is None else choice.patches.n
    if n:
        mem, sec = check_s2s_cost(what, n, options.cavity_rays, args.max_memory and args.max_memory / workers,
                                  other_bytes)
        print(f"{what}: s2s cavity law, {choice.words()}: estimated ~{fmt_bytes(mem)} and ~{sec:.0f} s of CPU for "
              "the exchange", flush=True)
    return n


# ------------------------------------------------------------------ the physical model
def add_model_arguments(parser: argparse.ArgumentParser) -> None:
    """Switches of the physical model (see ``imutherm.unit.model.ModelOptions``)."""
    g = parser.add_argument_group("model")
    g.add_argument("--exterior", choices=("natural", "fixed", "none"), default="natural",
                   help="exterior convection: face-orientation natural convection (default), fixed h, or none")
    g.add_argument("--h", type=float, default=10.0, metavar="W/m2K", help="h of --exterior fixed [W/m^2 K]")
    g.add_argument("--no-radiation", action="store_true", help="switch off exterior radiation")
    g.add_argument("--emissivity", type=float, default=None, help="housing emissivity [-] (default: its material's)")
    g.add_argument("--mount-conductance", type=float, default=None, metavar="W/m2K",
                   help="contact conductance to the mounting fixture [W/m^2 K] (default: the layout's)")
    g.add_argument("--no-cavity-radiation", action="store_true", help="switch off radiation across the cavity air")
    from imutherm.thermal.cavity_radiation import AUTO_MAX_PATCH_MM, AUTO_MAX_PATCHES, DEFAULT_PATCH_MM
    from imutherm.unit.cavity_laws import CAVITY_LAWS, DEFAULT_CAVITY_LAW  # registered before the parser is built
    g.add_argument("--cavity-law", choices=tuple(CAVITY_LAWS), default=DEFAULT_CAVITY_LAW,
                   help=cavity_law_help(CAVITY_LAWS, DEFAULT_CAVITY_LAW))
    g.add_argument("--cavity-patch-mm", type=float, default=None, metavar="MM",
                   help=f"patch edge of --cavity-law s2s [mm], exactly (default: {DEFAULT_PATCH_MM:g} mm, coarsened up to "
                        f"{AUTO_MAX_PATCH_MM:g} mm in a large housing to keep near {AUTO_MAX_PATCHES:,} patches)")


def cavity_law_help(laws: dict, default: str) -> str:
    """The ``--cavity-law`` help: every registered law (:mod:`imutherm.unit.cavity_laws`) with its words, in the
    registry's order, the default marked."""
    return "radiation inside the cavity; " + "; ".join(
        f"{name}{' (default)' if name == default else ''}: {law.words}" for name, law in laws.items())


def model_options(args):
    """The :class:`imutherm.unit.model.ModelOptions` of the options of :func:`add_model_arguments`."""
    from imutherm.thermal.cavity_radiation import AUTO_MAX_PATCHES, DEFAULT_PATCH_MM
    from imutherm.unit.model import ModelOptions

    return ModelOptions(exterior=args.exterior, h_fixed_W_m2K=args.h, radiation=not args.no_radiation,
                        emissivity=args.emissivity, mounting_conductance_W_m2K=args.mount_conductance,
                        cavity_radiation=not args.no_cavity_radiation, cavity_law=args.cavity_law,
                        cavity_patch_mm=DEFAULT_PATCH_MM if args.cavity_patch_mm is None else args.cavity_patch_mm,
                        cavity_max_patches=AUTO_MAX_PATCHES if args.cavity_patch_mm is None else None)


def add_fitted_model_argument(parser: argparse.ArgumentParser) -> None:
    """``--model FILE``: run on the model ``imutherm correlate`` fitted (its ``updated_model.toml``)."""
    parser.add_argument("--model", default=None, metavar="FILE",
                        help="run on the model imutherm correlate fitted (DIR/updated_model.toml): its re-tuned "
                             "values and named effect, on the layout and model switches it was fitted with")


def run_inputs(args) -> tuple:
    """(LayoutSpec, ModelOptions, effects, FittedModel or None) of a run: the CLI's layout and model switches,
    or with ``--model FILE`` the fitted model on them (:func:`imutherm.studies.thermal.fitted_model.apply_fitted`).

    A model file that records the switches it was fitted with fixes them: a different switch given on the
    command line is refused (the fitted values belong to those laws). Without LAYOUT, the model's layout.
    """
    from imutherm.geometry.layout import load_layout
    from imutherm.unit.model import ModelOptions

    cli = model_options(args)
    if getattr(args, "model", None) is None:
        return load_layout(args.layout), cli, (), None
    from imutherm.studies.thermal.fitted_model import apply_fitted, load_fitted_model

    fitted = load_fitted_model(args.model)
    base = cli
    if fitted.options:
        base = ModelOptions(**fitted.options)
        from imutherm.thermal.cavity_radiation import AUTO_MAX_PATCHES

        if cli != ModelOptions(cavity_max_patches=AUTO_MAX_PATCHES) and cli != base:   # the command line's defaults
            raise InputError(f"--model {args.model}: it was fitted with the model switches "
                             f"{', '.join(f'{k}={v}' for k, v in fitted.options.items())}; the command line's "
                             f"differ: drop them (or edit [model] in the file)")
    layout = load_layout(args.layout if args.layout is not None else fitted.layout)
    lay, opts, effects = apply_fitted(fitted, layout, base)
    return lay, opts, effects, fitted


def add_effect_argument(parser: argparse.ArgumentParser) -> None:
    """``--effect``: candidate effects of :mod:`imutherm.unit.effects` switched on."""
    parser.add_argument("--effect", action="append", default=[], metavar="NAME[@TARGET]:PARAM=VALUE",
                        help="switch on a candidate effect of the correlation library (repeatable; "
                             "`--list-effects` lists them), e.g. contact@bond:h_W_m2K=500")


# ------------------------------------------------------------------ time stepping
def add_time_arguments(parser: argparse.ArgumentParser, t_end: float, settle_stop: bool = False) -> None:
    """Time stepping of the power-on transient (shared by ``solve`` and ``compare``)."""
    g = parser.add_argument_group("time stepping")
    g.add_argument("--t-end", type=float, default=None, metavar="SECONDS",
                   help=f"transient end time [s] (default {t_end:g}; the latest end with --until-settled)")
    # None above: time_kwargs fills the default in (time options without a transient: imutherm.cli._ignored)
    parser.set_defaults(t_end_default=t_end)
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


def time_kwargs(args) -> dict:
    """``run_scheme`` time arguments from the options of :func:`add_time_arguments` (checked)."""
    from imutherm.studies.thermal.thermal_study import check_time_arguments

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


# ------------------------------------------------------------------ output and running
def add_out_argument(parser, required: bool = True, help: str = "output directory") -> None:
    """``--out DIR`` (checked and locked by the command with :func:`imutherm.cli._common.check_outdir`)."""
    parser.add_argument("--out", required=required, default=None, help=help)


def add_progress_argument(parser) -> None:
    """``--no-progress``: no progress bar."""
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def add_jobs_argument(parser, default: int | None, help: str) -> None:
    """``--jobs N``: worker processes (its default and meaning per command in ``help``)."""
    parser.add_argument("--jobs", type=int, default=default, metavar="N", help=help)
