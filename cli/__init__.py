"""The ``imutherm`` command: one parser with a subparser per subcommand.

Each subcommand is a module ``imutherm.cli.<name>`` with ``add_args(parser)`` (adds its options, the shared
groups from :mod:`imutherm.cli._options`), ``run(args)`` (does the work, returns the exit status) and
``main(argv=None)`` (the command alone, as ``imutherm <name> ...``; the tests call it). A new subcommand is
one line in :data:`COMMANDS` and its module.

Every subcommand turns :class:`imutherm.InputError` and OSError into a one-line message on stderr and exit
status 2, ConvergenceError into status 3, Ctrl-C into status 130 (:func:`imutherm.cli._common.run_guarded`);
no traceback for bad input. An option the given combination would ignore is refused before the command runs
(the table :data:`imutherm.cli._ignored.IGNORED`).
"""

from __future__ import annotations

import argparse
import importlib
import sys

#: subcommand -> its one-line help in ``imutherm --help``; the module is ``imutherm.cli.<subcommand>``
COMMANDS = {
    "compare": "the main job: the cooling schemes end to end (thermal, calibration, attitude error) and the report PDF",
    "geometry": "build the layout's parts and mesh; write geometry.json, STL, VTU, layout.png",
    "solve": "steady or transient thermal solve of one scheme; write result.json, probes.csv, VTU",
    "verify": "run the thermal verification suite against analytic solutions and benchmarks",
    "calibrate": "simulate the IMU calibration rig and fit conventional / improved models",
    "attitude": "run the attitude filters on a motion profile and report roll/pitch errors",
    "correlate": "compare measured site temperatures with the model: localise, re-tune, name the missing effect, correlation.pdf",
    "sweep": "parameter sweep of one scheme (grid, LHS, Morris): results.csv, sensitivity ranking, sweep.pdf",
    "import": "your own board (KiCad .kicad_pcb, IDF .emn) into a layout file: parts, stack-up, housing, schemes",
}
#: a subcommand whose module is not named after it (``import`` is a Python keyword)
MODULES = {"import": "import_board"}


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``imutherm`` parser: a subparser per entry of :data:`COMMANDS`, each listed with its one-line help.

    Only ``command``'s module is imported and its options added (``add_args``), so ``imutherm --help`` and a
    command's start do not import every command's dependencies; ``None`` adds none."""
    from imutherm.cli._common import help_text

    parser = argparse.ArgumentParser(
        prog="imutherm", formatter_class=argparse.RawDescriptionHelpFormatter,
        description="Thermal FEM design studies of small MEMS IMUs, end to end to attitude error.",
        epilog="imutherm COMMAND --help describes a command's options and outputs.")
    parser.add_argument("-V", "--version", action="store_true", help="print the version and exit")
    sub = parser.add_subparsers(title="commands", dest="command", metavar="COMMAND")
    for name, text in COMMANDS.items():
        if name != command:
            sub.add_parser(name, help=text)
            continue
        module = importlib.import_module(f"{__name__}.{MODULES.get(name, name)}")
        p = sub.add_parser(name, help=text, description=help_text(module.__doc__),
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        module.add_args(p)
        p.set_defaults(run=module.run)
    return parser


def run_command(name: str, argv: list[str] | None = None) -> int:
    """``imutherm NAME ARGV...``: parse with NAME's options and run it, guarded (one-line errors, exit statuses
    2 / 3 / 130); ``argv`` None: ``sys.argv[1:]``. argparse's own refusals exit with status 2 (SystemExit)."""
    from imutherm.cli._common import run_guarded

    argv = list(sys.argv[1:] if argv is None else argv)

    @run_guarded(f"imutherm {name}")
    def guarded(argv):
        from imutherm.cli._ignored import refuse_ignored

        parser = build_parser(name)
        args = parser.parse_args([name, *argv])
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices[name]
        refuse_ignored(name, sub, argv, args)  # an option the combination would ignore: one rule, one place
        return int(args.run(args) or 0)

    return guarded(argv)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``imutherm`` console script; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(build_parser().format_help(), end="")
        return 0
    if argv[0] in ("-V", "--version"):
        from imutherm import __version__

        print(f"imutherm {__version__}")
        return 0
    name, rest = argv[0], argv[1:]
    if name not in COMMANDS:
        print(f"imutherm: unknown command {name!r}; valid: {', '.join(COMMANDS)}", file=sys.stderr)
        return 2
    return run_command(name, rest)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
