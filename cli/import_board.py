"""``imutherm import BOARD``: your own board (KiCad ``.kicad_pcb`` or IDF ``.emn``) into a layout file.

Writes a complete single-board unit (``--out my_unit.toml``, default: the board file's name with ``.toml``):
the board with its stack-up's conductivity and true outline, every footprint modelled, merged into the board
or skipped (each with its reason, printed), standoffs under the mounting holes, a housing around it and the
three cooling schemes. ``--into LAYOUT --board NAME`` replaces one board of an existing layout instead (its
place in the unit kept), so a unit of several boards is assembled from several files.

Powers: a footprint field ``Power_W``, ``--powers FILE`` (CSV ``reference,power_W[,source]``), ``--power
REF=W``, or ``--electrical FILE`` (the supply and rails, regulators and loads by reference). Heights: the
footprint field ``Height_mm``, ``--heights FILE`` (CSV ``reference,height_mm[,source]``) or ``--height REF=MM``,
else the footprint name's own sizes and the package tables (``imutherm.ecad.heights``), else an estimate by a
stated rule, listed as ESTIMATED (``--strict-heights`` refuses instead; ``--heights-template FILE`` writes the
estimated parts to fill in). Sensor sites: ``--site U3=imu`` (a 6-axis chip: every
gyro and accelerometer site), ``--site U5=gyro``, ``--site U6=accel``, ``--site U7=gyro_z``, ``--site U2=probe``.

Prints what it did (each part's power with the file or field it came from, and every note on what was
unusual) and the estimated mesh of the result before anything is meshed; a bad board or option ends in one
line (exit 2) and nothing is written. The output file is locked while it is written (a second import into it
is refused); a temporary left beside it by a killed import is removed by the next; ``--force`` keeps the
replaced file's permissions.
"""

from __future__ import annotations

import math
import re
from collections import defaultdict
from pathlib import Path

from imutherm import InputError
from imutherm.cli import run_command


def add_args(parser) -> None:
    """The options of ``imutherm import``."""
    from imutherm.ecad.read import formats   # the registered readers
    from imutherm.ecad.to_layout import SITE_KINDS, HousingOptions

    parser.add_argument("board_file", metavar="BOARD", help=f"the board file: {formats()}")
    parser.add_argument("--out", default=None, metavar="FILE",
                        help="the layout file to write (default: the board file's name with .toml, here)")
    parser.add_argument("--force", action="store_true", help="overwrite --out if it exists")
    parser.add_argument("--into", default=None, metavar="LAYOUT",
                        help="replace board --board of this layout (a file or a built-in name) instead of writing a "
                             "single-board unit")
    parser.add_argument("--board", default="main", metavar="NAME",
                        help="the board's name in the layout (with --into: the board it replaces; default main)")
    parser.add_argument("--name", default=None, help="the layout's name (default: the board file's name)")
    parser.add_argument("--copper-layers", type=int, default=None, metavar="N",
                        help="an IDF board's copper layers of 35 um (IDF carries no stack-up; default 4, assumed)")
    g = parser.add_argument_group("powers, heights and sites")
    g.add_argument("--powers", default=None, metavar="FILE", help="CSV reference,power_W[,source] [W]")
    g.add_argument("--power", action="append", metavar="REF=W", help="one part's power [W] (repeatable)")
    g.add_argument("--electrical", default=None, metavar="FILE",
                   help="TOML with [electrical] and [[rails]] naming references as regulators and loads: the "
                        "regulators' losses follow from the supply")
    g.add_argument("--heights", default=None, metavar="FILE", help="CSV reference,height_mm[,source] [mm]")
    g.add_argument("--height", action="append", metavar="REF=MM", help="one part's body height [mm] (repeatable)")
    g.add_argument("--strict-heights", action="store_true",
                   help="refuse the board if any part's height would be estimated, listing every such part "
                        "(by default they are estimated by a stated rule and listed)")
    g.add_argument("--heights-template", default=None, metavar="FILE",
                   help="write the parts whose height is estimated to FILE (CSV reference,height_mm,source with "
                        "each footprint and rule), to fill in and pass back with --heights")
    g.add_argument("--site", action="append", metavar="REF=KIND",
                   help=f"a sensor site on part REF; KIND: {', '.join(SITE_KINDS)} (repeatable)")
    g.add_argument("--grade", action="append", metavar="[REF=]NAME",
                   help="the sensor grade of every site (NAME) or of part REF's sites (REF=NAME), instead of the "
                        "grade of the chip its value or footprint names (imutherm.imu.sensor_library; repeatable)")
    g.add_argument("--keep", action="append", metavar="REF[,REF]",
                   help="model these parts even if small and unpowered (repeatable)")
    g.add_argument("--merge-area", type=float, default=None, metavar="MM2",
                   help="largest body area of an unpowered part merged into the board [mm^2] (default 10)")
    g.add_argument("--exact", action="store_true",
                   help="keep every modelled part's exact outline (by default a part without a die has its edges "
                        "snapped by up to 1 mm to its neighbours' lines, so it adds few mesh lines)")
    g.add_argument("--grease", default=None, metavar="REF[,REF]",
                   help="the parts the grease scheme bonds to the base, top-side ones moved to the back, bottom-side "
                        "ones where they are (default: the parts supplying 20 %% or more of the hot spot's or a "
                        "sensor site's rise in a coarse steady solve of the air scheme, whatever their power)")
    d = HousingOptions()
    h = parser.add_argument_group("the unit around a single board (lengths [mm])")
    h.add_argument("--clearance", type=float, default=d.clearance_mm, metavar="MM",
                   help=f"board edges to the walls, tallest part to the lid and base (default {d.clearance_mm:g})")
    h.add_argument("--wall", type=float, default=d.wall_mm, metavar="MM", help=f"wall (default {d.wall_mm:g})")
    h.add_argument("--base", type=float, default=d.base_mm, metavar="MM", help=f"base (default {d.base_mm:g})")
    h.add_argument("--lid", type=float, default=d.lid_mm, metavar="MM", help=f"lid (default {d.lid_mm:g})")
    h.add_argument("--housing-material", default=d.material, help=f"(default {d.material})")
    h.add_argument("--standoff-material", default=d.standoff_material, help=f"(default {d.standoff_material})")
    h.add_argument("--mounting", choices=("fixture", "free"), default=d.mounting,
                   help="the base bolted to a fixture at the ambient (default) or free-standing")
    h.add_argument("--mounting-face", choices=("bottom", "top"), default=d.mounting_face,
                   help="the housing face on the fixture (default bottom: the base)")
    h.add_argument("--mount-conductance", type=float, default=d.contact_conductance_W_m2K, metavar="W/m2K",
                   help=f"base-to-fixture contact conductance [W/m^2 K] (default {d.contact_conductance_W_m2K:g})")
    h.add_argument("--ambient", type=float, default=d.ambient_C, metavar="C",
                   help=f"ambient and fixture temperature [degC] (default {d.ambient_C:g})")


def main(argv=None) -> int:
    """``imutherm import ARGV...``; returns the exit status."""
    return run_command("import", argv)


#: a board name (``--board``): a layout name part, as the layout's boards are named
BOARD_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_-]{0,63}$")
#: the numeric options and their valid ranges (lo, hi, unit, lo exclusive)
NUMERIC_OPTIONS = {"clearance": (0.0, 100.0, "mm", True), "wall": (0.0, 100.0, "mm", True),
                   "base": (0.0, 100.0, "mm", True), "lid": (0.0, 100.0, "mm", True),
                   "ambient": (-60.0, 150.0, "degC", False), "mount_conductance": (0.0, 1e6, "W/m^2 K", True),
                   "merge_area": (0.0, 1e4, "mm^2", False)}


def _check_numbers(args) -> None:
    """Every numeric option finite and in its range (the layout's own bounds), in one line each."""
    for key, (lo, hi, unit, open_lo) in NUMERIC_OPTIONS.items():
        value = getattr(args, key)
        if value is None:
            continue
        if not (math.isfinite(value) and (lo < value if open_lo else lo <= value) and value <= hi):
            raise InputError(f"--{key.replace('_', '-')} {value!r}: valid: a number in {lo:g}..{hi:g} {unit}"
                             + (f" (exclusive of {lo:g})" if open_lo else ""))
    if args.copper_layers is not None and not 1 <= args.copper_layers <= 64:
        raise InputError(f"--copper-layers {args.copper_layers}: valid: 1..64")
    if not BOARD_NAME.match(args.board):
        raise InputError(f"--board {args.board!r}: valid: a name of letters, digits, '_' and '-' starting with a "
                         f"letter (at most 64 characters), as the layout's boards are named")
    if args.name is not None and (not args.name.strip() or len(args.name) > 100
                                  or re.search(r"[\x00-\x1f\x7f/\\]", args.name)):
        raise InputError(f"--name {args.name!r}: valid: a layout name of printable characters without '/' or '\\' "
                         f"(at most 100)")


def _options(args):
    from imutherm.ecad.to_layout import SITE_KINDS, HousingOptions, ImportOptions
    from imutherm.ecad.user_tables import (parse_assignments, parse_refs, parse_sites, read_electrical,
                                           read_value_csv)

    _check_numbers(args)
    powers = read_value_csv(args.powers, "power_W") if args.powers else {}
    powers.update(parse_assignments(args.power, "power_W", "--power"))
    heights = read_value_csv(args.heights, "height_mm") if args.heights else {}
    heights.update(parse_assignments(args.height, "height_mm", "--height"))
    housing = HousingOptions(args.clearance, args.wall, args.base, args.lid, material=args.housing_material,
                             standoff_material=args.standoff_material, mounting=args.mounting,
                             mounting_face=args.mounting_face,
                             contact_conductance_W_m2K=args.mount_conductance, ambient_C=args.ambient)
    from imutherm.imu.site_grades import parse_grade_options, site_grades

    return ImportOptions(powers=powers, heights=heights, sites=parse_sites(args.site, SITE_KINDS),
                         grades=parse_grade_options(args.grade), grade_rule=site_grades,
                         keep=frozenset(parse_refs(args.keep)),
                         electrical=read_electrical(args.electrical) if args.electrical else None,
                         electrical_source=args.electrical or "",
                         grease=parse_refs([args.grease]) if args.grease is not None else None,
                         grease_rule=_grease_rule(), board_name=args.board, layout_name=args.name, housing=housing,
                         merge_area_mm2=args.merge_area, exact=args.exact, strict_heights=args.strict_heights)


def _grease_rule():
    """The grease scheme's choice by the thermal model: the parts that set the hot spot and the sensors' rise."""
    from imutherm.unit.grease_choice import choose

    return choose


def _print_report(result, out: Path) -> None:
    from imutherm.ecad.heights import is_estimated
    from imutherm.ecad.to_layout import natural_order

    b = result.board
    print(f"{b.source}: {b.format}, {b.width_mm:.2f} x {b.height_mm:.2f} mm, {b.thickness_mm:g} mm, "
          f"{b.copper_layers} copper layers ({b.stackup_source})")
    print(f"{len(result.decisions)} footprints: {result.count('modelled')} modelled, {result.count('merged')} merged "
          f"into the board, {result.count('skipped')} skipped")
    comps = {c.name: c for c in result.spec.components}
    sources = defaultdict(lambda: [0.0, 0])
    modelled = [d for d in result.decisions if d.fate == "modelled"]
    for d in sorted(modelled, key=lambda d: natural_order(d.footprint.ref)):
        fp, body = d.footprint, d.body
        c = comps[result.names[fp.ref]]
        source = "the electrical design" if c.power_source.startswith("electrical") else d.power_source
        power = f"{c.power_W:.3g} W ({source[:70]}{'...' if len(source) > 70 else ''})" if c.power_W else "unpowered"
        if c.power_W:
            origin = re.sub(r" line \d+.*", "", source) if " line " in source else source
            sources[origin][0] += c.power_W
            sources[origin][1] += 1
        est = " [height ESTIMATED]" if is_estimated(d.height_source) else ""
        print(f"  modelled {fp.ref:<6} {fp.value[:22]:<22} {body.width:5.2f} x {body.height:5.2f} x {d.height_mm:4.2f} mm "
              f"{fp.side:<6} {power}{est}")
    merged = sorted((d.footprint.ref for d in result.decisions if d.fate == "merged"), key=natural_order)
    if merged:
        print(f"  merged ({len(merged)}, mass and heat capacity smeared into the board): {', '.join(merged)}")
    by_reason = defaultdict(list)
    for d in result.decisions:
        if d.fate == "skipped":
            by_reason[d.reason].append(d.footprint.ref)
    for reason, refs in by_reason.items():
        print(f"  skipped ({len(refs)}) {', '.join(sorted(refs, key=natural_order))}: {reason}")
    print(height_counts(result.decisions))
    if sources:
        print(f"powers: {sum(w for w, _ in sources.values()):.3g} W in all: " + "; ".join(
            f"{w:.3g} W from {origin} ({n} part{'s' if n > 1 else ''})" for origin, (w, n) in sources.items()))
    for note in result.notes:
        print(f"note: {note}")


def height_counts(decisions) -> str:
    """One line: how many placed parts took their height from where (``imutherm.ecad.heights``)."""
    from imutherm.ecad.heights import is_estimated

    counts = defaultdict(int)
    for d in decisions:
        if d.fate != "skipped":
            s = d.height_source
            counts["ESTIMATED" if is_estimated(s) else "the footprint names" if s.startswith("the footprint name")
                   else "the user" if re.match(r"(--height|.* line \d+)", s) else "fields or the board file"
                   if s.startswith("the ") else "the package tables"] += 1
    return "heights of the modelled and merged parts: " + ", ".join(f"{n} from {k}" if k != "ESTIMATED" else
                                                                     f"{n} ESTIMATED" for k, n in counts.items())


def _estimate(spec) -> str:
    from imutherm.budget import fmt_bytes
    from imutherm.studies.cost import solve_memory

    parts = []
    for scheme in spec.schemes:  # the mesh's and the cavity's radiation exchange's (s2s), which lives beside it
        m = solve_memory(spec, scheme)
        parts.append(f"{scheme} {m['cells']:,} cells (~{fmt_bytes(m['bytes'])} to solve"
                     + (f", ~{fmt_bytes(m['exchange_bytes'])} of it the cavity exchange, {m['patches']:,} patches)"
                        if m["patches"] else ")"))
    return "estimated mesh at the default --mesh-size: " + "; ".join(parts)


def _template_path(args, board_path: Path, out: Path) -> Path | None:
    """``--heights-template FILE`` checked: a new file (or ``--force``) in an existing folder, not an input
    or ``--out``."""
    if args.heights_template is None:
        return None
    t = Path(args.heights_template)
    inputs = [board_path, out] + [Path(p) for p in (args.heights, args.powers, args.electrical) if p]
    if any(t.resolve() == p.resolve() for p in inputs):
        raise InputError(f"--heights-template {t}: is an input or --out; give a new file")
    if t.exists() and (t.is_dir() or not args.force):
        raise InputError(f"--heights-template {t}: exists; give another file or --force to overwrite it")
    if not t.parent.exists():
        raise InputError(f"--heights-template {t}: its folder {t.parent} does not exist")
    return t


def run(args) -> int:
    """Read, decide, check and write (see the module docstring); returns 0."""
    from dataclasses import replace

    from imutherm.cli._common import lock_output_file, pause_for_test
    from imutherm.ecad.heights import estimated_parts, strict_refusal, template_csv
    from imutherm.ecad.read import read_board
    from imutherm.ecad.to_layout import import_board, replace_board
    from imutherm.io import atomic_write, stale_temporaries

    board_path = Path(args.board_file)
    out = Path(args.out) if args.out else Path(board_path.name).with_suffix(".toml")
    if out.suffix.lower() != ".toml":
        raise InputError(f"--out {out}: a layout file ends in .toml")
    if out.exists() and not args.force:
        raise InputError(f"--out {out}: exists; give another --out or --force to overwrite it")
    if out.exists() and out.is_dir():
        raise InputError(f"--out {out}: is a directory; give a .toml file")
    if not out.parent.exists():
        raise InputError(f"--out {out}: its folder {out.parent} does not exist")
    opts = _options(args)
    template = _template_path(args, board_path, out)
    lock_output_file(out)
    for stale in stale_temporaries(out):   # left by a killed import into the same file (we hold its lock)
        stale.unlink(missing_ok=True)
        print(f"removed {stale.name}, the temporary of an earlier import into {out} that was killed")
    board = read_board(board_path, copper_layers=args.copper_layers)
    build = replace(opts, strict_heights=opts.strict_heights and template is None)  # the template first
    if args.into:
        result = replace_board(args.into, args.board, board, build)
    else:
        result = import_board(board, build)
    if template is not None:
        parts = estimated_parts(result.decisions)
        atomic_write(template, lambda tmp: Path(tmp).write_text(template_csv(parts), encoding="utf-8"))
        print(f"wrote {template}: {len(parts)} estimated height{'s' if len(parts) != 1 else ''} to fill in (then "
              f"import again with --heights {template})")
        if opts.strict_heights and parts:
            raise strict_refusal(result.board.source, parts)
    _print_report(result, out)
    print(_estimate(result.spec), flush=True)
    def write(tmp):
        Path(tmp).write_text(result.text, encoding="utf-8")
        pause_for_test("import-written")

    atomic_write(out, write)
    print(f"wrote {out} (layout {result.spec.name!r}; next: imutherm geometry {out}, imutherm compare {out})")
    return 0
