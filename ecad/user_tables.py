"""The user's additions to a board file: powers and heights (CSV or ``REF=VALUE``), sites, an electrical design.

Every reader here fails with one line naming the file (or option), the line and what would be valid.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

from imutherm import InputError
from imutherm.textio import quote, read_text

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

#: largest value file read [bytes] (a 270-part board's powers are ~10 kB)
MAX_TABLE_BYTES = 4 * 2**20
#: physical bounds: a part dissipating more than 100 W is not on a small IMU board; a part taller than
#: 100 mm is not on a board in a small housing
BOUNDS = {"power_W": (0.0, 100.0, "W"), "height_mm": (1e-3, 100.0, "mm")}


def read_value_csv(path: str | Path, column: str) -> dict:
    """``reference,<column>[,source]`` lines -> ``{ref: (value, source)}``.

    A header line naming the columns is required; ``#`` lines are comments. ``source`` (optional) says where a
    value comes from (a datasheet); the source kept is the file and its line, then that text.
    """
    path = Path(path)
    text = read_text(path, f"{column} CSV", MAX_TABLE_BYTES)
    lo, hi, unit = BOUNDS[column]
    rows = [(i + 1, line) for i, line in enumerate(text.splitlines()) if line.strip() and not line.lstrip().startswith("#")]
    if not rows:
        raise InputError(f"{path}: empty; valid: a header 'reference,{column}[,source]' and one line per part")
    header = [h.strip() for h in next(csv.reader([rows[0][1]]))]
    if header[:2] != ["reference", column] or len(header) > 3 or (len(header) == 3 and header[2] != "source"):
        raise InputError(f"{path}: line {rows[0][0]}: header {quote(rows[0][1], 80)}; valid: 'reference,{column}' or "
                         f"'reference,{column},source'")
    out = {}
    for number, line in rows[1:]:
        cells = [c.strip() for c in next(csv.reader(io.StringIO(line)))]
        if len(cells) < 2 or len(cells) > len(header) or not cells[0]:
            raise InputError(f"{path}: line {number}: {quote(line, 80)}; valid: reference,{column}[,source]")
        ref = cells[0]
        try:
            value = float(cells[1])
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and lo <= value <= hi):
            raise InputError(f"{path}: line {number}: {ref}: {column} {quote(cells[1], 40)} is not a number in "
                             f"{lo:g}..{hi:g} {unit}")
        if ref in out:
            raise InputError(f"{path}: line {number}: {ref} is given twice")
        source = f"{path.name} line {number}" + (f": {cells[2]}" if len(cells) == 3 and cells[2] else "")
        out[ref] = (value, source)
    return out


def parse_assignments(values, column: str, option: str) -> dict:
    """``REF=VALUE`` options (repeatable) -> ``{ref: (value, option)}``."""
    lo, hi, unit = BOUNDS[column]
    out = {}
    for text in values or ():
        ref, sep, raw = str(text).partition("=")
        try:
            value = float(raw)
        except ValueError:
            value = math.nan
        if not sep or not ref.strip() or not (math.isfinite(value) and lo <= value <= hi):
            raise InputError(f"{option} {quote(text, 60)}: valid: {option} REF=VALUE with VALUE in {lo:g}..{hi:g} {unit}")
        out[ref.strip()] = (value, f"{option} {ref.strip()}={raw}")
    return out


def parse_sites(values, kinds) -> dict:
    """``--site REF=KIND`` options -> ``{ref: kind}``."""
    out = {}
    for text in values or ():
        ref, sep, kind = str(text).partition("=")
        if not sep or not ref.strip() or kind.strip() not in kinds:
            raise InputError(f"--site {quote(text, 60)}: valid: --site REF=KIND with KIND one of {', '.join(kinds)} "
                             f"(imu: a 6-axis chip gives every gyro and accelerometer site)")
        if ref.strip() in out:
            raise InputError(f"--site: {ref.strip()} is given twice")
        out[ref.strip()] = kind.strip()
    return out


def parse_refs(values) -> tuple:
    """``REF,REF`` options (repeatable) -> the references, in order, without repeats."""
    out = []
    for text in values or ():
        for ref in str(text).split(","):
            if ref.strip() and ref.strip() not in out:
                out.append(ref.strip())
    return tuple(out)


def read_electrical(path: str | Path) -> dict:
    """An electrical design file: ``[electrical]`` (the supply) and ``[[rails]]`` naming the board's references
    as regulators and loads, as in a layout (``imutherm.geometry.electrical``); checked once it is in the layout."""
    path = Path(path)
    text = read_text(path, "electrical design", MAX_TABLE_BYTES)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
    extra = sorted(set(data) - {"electrical", "rails"})
    if extra or "electrical" not in data or "rails" not in data:
        raise InputError(f"{path}: an electrical design holds [electrical] (supply_V, supply_range_V) and [[rails]] "
                         f"(regulator and loads_A by reference designator), nothing else"
                         + (f"; unknown: {', '.join(extra)}" if extra else ""))
    if not isinstance(data["rails"], list) or not all(isinstance(r, dict) for r in data["rails"]):
        raise InputError(f"{path}: rails must be [[rails]] tables")
    return data
