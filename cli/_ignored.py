"""Options that the given combination would ignore: refused, by one rule, in one place.

:data:`IGNORED` is a table: each row names the commands, the options, when those options would be
ignored (a predicate of the parsed arguments) and what to do instead. :func:`refuse_ignored` is called
by :func:`imutherm.cli.run_command` for every command after parsing and before the command runs; an
option counts as *given* when it appears on the command line (whatever its value, even its default),
found by parsing the command line a second time with every default suppressed.

Adding a rule is one row, e.g. for a new ``solve --uncertainty N`` that only a transient uses::

    Ignored(("solve",), ("--uncertainty",), lambda a: not a.transient, "without --transient",
            "drop it or add --transient"),

The predicate reads the parsed ``args`` (``args.<dest>``, defaults filled in); the message is
``"<the given options of the row>: [<what>] given <why>, they would be ignored; <fix>"``.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from typing import Callable

from imutherm import InputError
from imutherm.unit.cavity_laws import cavity_law

THERMAL = ("solve", "compare", "correlate", "sweep")  # the commands with the model options
TIME_OPTIONS = ("--t-end", "--time-tol", "--dt", "--dt-max", "--theta")


def _signal_effects(args) -> bool:
    from imutherm.unit.effects import EFFECTS

    names = [str(e).partition(":")[0].partition("@")[0].strip() for e in args.effect]
    return any(n in EFFECTS and EFFECTS[n].kind == "signal" for n in names)


@dataclass(frozen=True)
class Ignored:
    """One row: ``options`` of ``commands`` would be ignored when ``ignored(args)`` is true (``why``)."""

    commands: tuple
    options: tuple
    ignored: Callable
    why: str
    fix: str
    what: str = ""  # what the options are, in the message ("time stepping")


IGNORED = (
    Ignored(("solve",), TIME_OPTIONS + ("--save-every", "--until-settled"), lambda a: not a.transient,
            "without --transient", "a steady solve has no time steps, so drop them or run the transient",
            "time stepping"),
    Ignored(("compare",), TIME_OPTIONS + ("--full-length",), lambda a: a.steady_only, "with --steady-only",
            "a steady solve has no time steps, so drop them or run the transient", "time stepping"),
    Ignored(("compare",), ("--grade", "--seeds", "--seed", "--profiles", "--filters", "--filter-defaults",
                           "--out-of-range"),
            lambda a: a.thermal_only or a.steady_only, "with --thermal-only or --steady-only",
            "the thermal comparison has no IMU side; drop them or run the end-to-end study"),
    Ignored(("solve",), ("--effect",), lambda a: not a.transient and _signal_effects(a), "without --transient",
            "a signal effect (probe_lag, ambient_drift) changes the transient's site curves, and a steady "
            "solve has none; drop it or add --transient"),
    Ignored(("compare",), ("--uncertainty-samples", "--uncertainty-checks", "--uncertainty-imu-draws"),
            lambda a: not a.uncertainty,
            "without --uncertainty", "they size the uncertainty propagation; drop them or add --uncertainty"),
    Ignored(("compare",), ("--uncertainty-imu-draws",), lambda a: a.thermal_only or a.steady_only,
            "with --thermal-only or --steady-only", "the thermal comparison has no IMU chain to run the draws "
            "through; drop it or run the end-to-end study"),
    Ignored(("sweep",), ("--verify", "--verify-tol"), lambda a: a.surrogate == "none", "with --surrogate none",
            "they check a reduced-model sweep against the full FEM, and every case of this one runs on the full "
            "FEM; drop them or use --surrogate auto|reduced"),
    Ignored(("correlate",), ("--full",), lambda a: a.no_rerun, "with --no-rerun",
            "it chooses how the re-run's transients are computed, and --no-rerun skips the re-run; drop one"),
    Ignored(("sweep",), ("--t-end",), lambda a: not a.transient, "without --transient",
            "drop it or add --transient"),
    Ignored(("sweep",), ("--attitude-seeds",), lambda a: not a.attitude, "without --attitude",
            "drop it or add --attitude"),
    Ignored(THERMAL, ("--cavity-law", "--cavity-patch-mm"), lambda a: a.no_cavity_radiation,
            "with --no-cavity-radiation", "give one of them (--cavity-law none switches the cavity radiation off too)"),
    Ignored(THERMAL, ("--cavity-patch-mm",), lambda a: not cavity_law(a.cavity_law).patches, "without --cavity-law s2s",
            "only the s2s cavity law has patches; drop it or add --cavity-law s2s"),
    Ignored(THERMAL, ("--h",), lambda a: a.exterior != "fixed", "without --exterior fixed",
            "--h is the fixed exterior coefficient; drop it or add --exterior fixed"),
    Ignored(THERMAL, ("--emissivity",), lambda a: a.no_radiation, "with --no-radiation",
            "--emissivity is the housing's exterior radiation; drop one of them"),
    Ignored(("calibrate",), ("--load-dependence",), lambda a: a.procedure != "overload",
            "without --procedure overload", "only the overload table has a load; drop it or add --procedure overload"),
    Ignored(("calibrate",), ("--oven-mount-deg", "--interp"), lambda a: a.procedure != "temperature",
            "with another --procedure than temperature", "they belong to the temperature rig; drop them"),
    Ignored(("attitude",), ("--profile", "--grade", "--temperature", "--temperature-csv", "--compensation",
                            "--out-of-range", "--seeds", "--seed0", "--duration", "--gnss-rate", "--gnss-vel-std",
                            "--disturbances", "--max-memory"),
            lambda a: a.imu_csv is not None, "with --imu-csv",
            "a recorded log is run as recorded, with no simulated sensor or motion; drop them or --imu-csv"),
    Ignored(("attitude",), ("--gyro-units", "--accel-units", "--axes", "--platform", "--lever-arm", "--turn-radius",
                            "--init-s", "--max-gap", "--gyro-sample"),
            lambda a: a.imu_csv is None, "without --imu-csv", "they describe a recorded log; drop them or give --imu-csv"),
)


def given_options(parser: argparse.ArgumentParser, argv) -> set:
    """The option strings of ``parser`` that ``argv`` gives (abbreviations and ``--opt=value`` resolved).

    Parses ``argv`` again with every default suppressed, so only what the command line set is in the
    namespace; ``parser`` is left as it was."""
    saved = [(a, a.default) for a in parser._actions]
    defaults = dict(parser._defaults)
    try:
        for a, _ in saved:
            a.default = argparse.SUPPRESS
        parser._defaults.clear()
        dests = set(vars(parser.parse_args(list(argv))))
    finally:
        for a, d in saved:
            a.default = d
        parser._defaults.update(defaults)
    return {s for a in parser._actions if a.dest in dests for s in a.option_strings}


def refuse_ignored(command: str, parser: argparse.ArgumentParser, argv, args) -> None:
    """InputError naming the options ``argv`` gives that ``command`` would ignore with the other options
    (the first row of :data:`IGNORED` that applies)."""
    rows = [r for r in IGNORED if command in r.commands]
    if not rows:
        return
    given = given_options(parser, argv)
    for r in rows:
        hit = [o for o in r.options if o in given]
        if hit and r.ignored(args):
            they = "it would be" if len(hit) == 1 else "they would be"
            raise InputError(f"{', '.join(hit)}: {r.what + ' ' if r.what else ''}given {r.why}, {they} ignored; {r.fix}")
