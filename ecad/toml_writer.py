"""Write a layout dict as TOML a person reads and edits: values with their sources as comments.

Only what layouts use: strings, numbers, booleans, lists of those (nested lists for outlines), inline tables
(``{ part = "U3_die" }``), tables and arrays of tables. A value wrapped in :class:`Note` is written with its
comment at the end of the line; a table's key ``NOTE`` (a string) is written as comment lines above it.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

#: a table's comment lines (written above its header)
NOTE = "__note__"
#: a table written inline ({ a = 1 }) rather than as a [section]
_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


@dataclass(frozen=True)
class Note:
    """A value with a comment written beside it."""

    value: object
    comment: str


@dataclass(frozen=True)
class Inline:
    """A table written inline: ``{ key = value, ... }``."""

    table: dict


def _key(k: str) -> str:
    return k if _BARE.match(k) else _string(k)


def _string(s: str) -> str:
    out = s.replace("\\", "\\\\").replace('"', '\\"').replace("\n", "\\n").replace("\t", "\\t")
    out = "".join(c if 32 <= ord(c) != 127 else f"\\u{ord(c):04x}" for c in out)
    return f'"{out}"'


def _number(v: float) -> str:
    if not math.isfinite(v):
        raise ValueError(f"TOML has no value for {v!r}")
    if float(v).is_integer() and abs(v) < 1e15:
        return f"{v:.1f}"
    return repr(round(float(v), 9))


def value_text(v) -> str:
    """The TOML text of one value."""
    if isinstance(v, Note):
        return value_text(v.value)
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return _number(v)
    if isinstance(v, str):
        return _string(v)
    if isinstance(v, Inline):
        return "{ " + ", ".join(f"{_key(k)} = {value_text(x)}" for k, x in v.table.items()) + " }"
    if isinstance(v, dict):
        return value_text(Inline(v))
    if isinstance(v, (list, tuple)):
        if len(v) > 1 and all(isinstance(x, Inline) for x in v):  # one inline table a line
            return "[\n" + "".join(f"    {value_text(x)},\n" for x in v) + "]"
        return "[" + ", ".join(value_text(x) for x in v) + "]"
    raise TypeError(f"no TOML form for {type(v).__name__}")


def _comment_lines(text: str) -> list:
    """Comment lines of ``text``; a control character (which TOML forbids in comments) shown as U+FFFD."""
    clean = "".join(c if c in "\n\t" or 32 <= ord(c) != 127 else "\ufffd" for c in str(text))
    return [f"# {line}".rstrip() for line in clean.splitlines()]


def _is_table(v) -> bool:
    return isinstance(v, dict) and not isinstance(v, Inline)


def _is_table_array(v) -> bool:
    return isinstance(v, (list, tuple)) and bool(v) and all(_is_table(x) for x in v)


def _pairs(table: dict) -> list:
    out = []
    for k, v in table.items():
        if k == NOTE or _is_table(v) or _is_table_array(v):
            continue
        line = f"{_key(k)} = {value_text(v)}"
        if isinstance(v, Note) and v.comment:
            line += f"   {' '.join(_comment_lines(' '.join(str(v.comment).split())))}"
        out.append(line)
    return out


def _sections(table: dict, prefix: str) -> list:
    lines = []
    for k, v in table.items():
        if k == NOTE:
            continue
        name = f"{prefix}{_key(k)}"
        if _is_table(v):
            pairs = _pairs(v)
            if pairs or NOTE in v or not v:  # a table of sub-tables alone needs no header of its own
                lines.append("")
                if NOTE in v:
                    lines += _comment_lines(v[NOTE])
                lines.append(f"[{name}]")
                lines += pairs
            lines += _sections(v, name + ".")
        elif _is_table_array(v):
            for item in v:
                lines.append("")
                if NOTE in item:
                    lines += _comment_lines(item[NOTE])
                lines.append(f"[[{name}]]")
                lines += _pairs(item)
                lines += _sections(item, name + ".")
    return lines


def dumps(doc: dict, header: str = "") -> str:
    """The TOML text of ``doc`` (see the module docstring), ``header`` as comment lines at the top."""
    lines = _comment_lines(header) if header else []
    if NOTE in doc:
        lines += _comment_lines(doc[NOTE])
    if lines:
        lines.append("")
    lines += _pairs(doc)
    lines += _sections(doc, "")
    return "\n".join(lines) + "\n"
