"""``imutherm verify``: run the thermal verification suite (analytic solutions, NAFEMS T3/T4).

Prints one line per case (computed, reference, error, tolerance, PASS/FAIL)
and, with ``--out DIR``, writes ``DIR/verify.json``: a list of records with
the keys case, quantity, computed, exact, error, tolerance, pass, note,
seconds. Exit status 0 only if every case passes, 1 otherwise (2 for bad input).
"""

from __future__ import annotations

import math

from imutherm import InputError
from imutherm.cli import run_command
from imutherm.cli._common import atomic_outdir, check_outdir, write_json
from imutherm.cli._options import add_out_argument


def _clean(value):
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def add_args(parser) -> None:
    """The options of ``imutherm verify``."""
    add_out_argument(parser, required=False, help="output directory for verify.json")
    parser.add_argument("--case", action="append", default=None, metavar="NAME",
                        help=f"run only this case (repeatable); one of: {', '.join(all_cases())}")
    parser.add_argument("--list", action="store_true", help="list the cases and exit")


def all_cases() -> dict:
    """The thermal core's cases (:mod:`imutherm.thermal.verification`) and the reference unit's mesh-refinement
    study (:func:`imutherm.studies.thermal.mesh_convergence.case_reference_unit_refinement`, ~1 min and ~2 GB)."""
    from imutherm.studies.thermal.mesh_convergence import case_reference_unit_refinement
    from imutherm.thermal.verification import CASES

    return {**CASES, "refinement_reference_unit": case_reference_unit_refinement}


def main(argv=None) -> int:
    """``imutherm verify ARGV...``; returns the exit status."""
    return run_command("verify", argv)


def run(args) -> int:
    """Run the cases of ``args`` and print / write their records; returns 0 if all pass, else 1."""
    from imutherm.thermal.verification import run_all

    CASES = all_cases()
    if args.out is not None:
        check_outdir(args.out)
    if args.list:
        for name, func in CASES.items():
            print(f"{name:<26} {(func.__doc__ or '').strip().splitlines()[0]}")
        return 0
    if args.case:
        unknown = [c for c in args.case if c not in CASES]
        if unknown:
            raise InputError(f"--case: unknown case(s) {', '.join(unknown)}; valid: {', '.join(CASES)}")
    records = run_all(args.case or list(CASES), CASES)
    header = f"{'case':<26} {'computed':>13} {'reference':>13} {'error':>10} {'tolerance':>10}  result"
    print(header)
    print("-" * len(header))
    for r in records:
        print(f"{r.case:<26} {r.computed:>13.6g} {r.exact:>13.6g} {r.error:>10.2e} {r.tolerance:>10.1e}  "
              f"{'PASS' if r.passed else 'FAIL'}")
    failed = [r for r in records if not r.passed]
    for r in failed:
        print(f"  {r.case}: {r.note}")
    print(f"{len(records) - len(failed)}/{len(records)} cases passed")
    if args.out is not None:
        data = [{k: _clean(v) for k, v in r.as_dict().items()} for r in records]
        with atomic_outdir(args.out) as tmp:
            write_json(tmp / "verify.json", data)
        print(f"wrote {args.out}/verify.json")
    return 0 if not failed else 1
