"""The ``imutherm`` command: one module per subcommand, each with ``main(argv=None)``.

``imutherm SUBCOMMAND ...`` dispatches to ``imutherm.cli.<subcommand>.main``.
Every subcommand turns :class:`imutherm.InputError` and OSError into a one-line message on
stderr and exit status 2 (Ctrl-C: one line, status 130); no traceback for bad input.
"""

from __future__ import annotations

import importlib
import sys

#: subcommand -> one-line help
COMMANDS = {
    "compare": "the main job: the cooling schemes end to end (thermal, calibration, attitude error) and the report PDF",
    "geometry": "build the layout's parts and mesh; write geometry.json, STL, VTU, layout.png",
    "solve": "steady or transient thermal solve of one scheme; write result.json, probes.csv, VTU",
    "verify": "run the thermal verification suite against analytic solutions and benchmarks",
    "calibrate": "simulate the IMU calibration rig and fit conventional / improved models",
    "attitude": "run the attitude filters on a motion profile and report roll/pitch errors",
    "correlate": "compare measured site temperatures with the model: localise, re-tune, name the missing effect, correlation.pdf",
    "sweep": "parameter sweep of one scheme (grid, LHS, Morris): results.csv, sensitivity ranking, sweep.pdf",
}


def _usage() -> str:
    lines = ["usage: imutherm COMMAND [options]   (imutherm COMMAND --help for more; imutherm --version)", "",
             "commands:"]
    lines += [f"  {name:<10} {text}" for name, text in COMMANDS.items()]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``imutherm`` console script; returns the exit status."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help"):
        print(_usage())
        return 0
    if argv[0] in ("-V", "--version"):
        from imutherm import __version__

        print(f"imutherm {__version__}")
        return 0
    name, rest = argv[0], argv[1:]
    if name not in COMMANDS:
        print(f"imutherm: unknown command {name!r}; valid: {', '.join(COMMANDS)}", file=sys.stderr)
        return 2
    module = importlib.import_module(f"imutherm.cli.{name}")
    return int(module.main(rest) or 0)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
