"""The files of a sweep: the resumable ``results.csv`` and the ``sweep.json`` record.

``results.csv`` is appended one complete line per finished case (flushed and fsynced, ``RowWriter``), so a
killed sweep loses only the cases in flight; :func:`read_results` reads it back checked line by line for a
resume. Whole files are replaced through :func:`imutherm.io.atomic_write` (``write_text_synced``).
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from imutherm import InputError
from imutherm.io import atomic_write

if TYPE_CHECKING:  # pragma: no cover
    from imutherm.studies.sweep.plan import SweepPlan

RESULTS_CSV = "results.csv"
SWEEP_JSON = "sweep.json"


def _fmt(v) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if not math.isfinite(v) else repr(v)
    return str(v)


def row_line(plan: SweepPlan, row: dict) -> str:
    values = dict(zip(plan.keys, plan.cases[row["case"]].values))
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerow(
        [_fmt(row.get(c, values.get(c))) for c in plan.columns])
    return buf.getvalue()


def _parse_cell(column: str, text: str):
    if column in ("status", "message"):
        return text
    if column == "case":
        return int(text)
    return float(text) if text != "" else None


def _damaged(path: Path, lineno: int, what: str) -> InputError:
    return InputError(f"{path}:{lineno}: {what}; the file is damaged: delete that line to run its case again "
                      "with --resume (or start a new --out)")


def read_results(path: Path, columns, cases=None, keys=()) -> list:
    """Rows of a ``results.csv``, checked line by line; a damaged line is refused naming it.

    A partial last line (no newline: a kill mid-write cut it) is the one repair made, as it is provably
    safe: it is dropped from the file and its case runs again. Every other line must decode as UTF-8, have
    the header's fields, an integer case id of the design (``cases``: the plan's cases, None: not checked),
    numbers in the numeric columns, status ok or failed, and inputs (``keys``: the plan's input columns) equal
    to its case's in the design.
    """
    data = path.read_bytes()
    if data and not data.endswith(b"\n"):
        cut = data.rfind(b"\n") + 1
        with open(path, "r+b") as fh:
            fh.truncate(cut)
        data = data[:cut]
    lines = data.split(b"\n")[:-1] if data else []
    if not lines:
        return []
    texts = []
    for i, raw in enumerate(lines, start=1):
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise _damaged(path, i, f"not UTF-8 text (byte {exc.start + 1})") from None
        if "\0" in text:
            raise _damaged(path, i, "a NUL byte")
        texts.append(text)
    try:
        parsed = [next(csv.reader([t])) if t else [] for t in texts]
    except csv.Error as exc:
        raise InputError(f"{path}: not a valid CSV: {exc}") from None
    header = parsed[0]
    if tuple(header) != tuple(columns):
        raise _damaged(path, 1, f"its columns {header} are not this sweep's {list(columns)}")
    rows, seen = [], set()
    for i, line in enumerate(parsed[1:], start=2):
        if len(line) != len(columns):
            raise _damaged(path, i, f"{len(line)} fields, the header has {len(columns)}")
        row = {}
        for c, t in zip(columns, line):
            try:
                row[c] = _parse_cell(c, t)
            except ValueError:
                what = "an integer case id" if c == "case" else "a number"
                raise _damaged(path, i, f"column {c!r} holds {t[:40]!r}, not {what}") from None
        if row["status"] not in ("ok", "failed"):
            raise _damaged(path, i, f"status {row['status'][:40]!r} is neither ok nor failed")
        if row["case"] in seen:
            raise _damaged(path, i, f"case {row['case']} is recorded twice")
        if cases is not None:
            if not 0 <= row["case"] < len(cases):
                raise _damaged(path, i, f"case id {row['case']} is not in this design (0..{len(cases) - 1})")
            design = dict(zip(keys, cases[row["case"]].values))
            off = [k for k, v in design.items() if k in row and row[k] != v]
            if off:
                raise _damaged(path, i, f"case {row['case']}'s {off[0]} = {row[off[0]]!r} is not the design's "
                                        f"{design[off[0]]!r}")
        seen.add(row["case"])
        rows.append(row)
    return rows


class RowWriter:
    """Appends one complete line per call, flushed and fsynced."""

    def __init__(self, path: Path, plan: SweepPlan):
        self.plan = plan
        new = not path.exists() or path.stat().st_size == 0
        self.fh = open(path, "a", newline="")
        if new:
            self._write(",".join(plan.columns) + "\n")

    def _write(self, text: str) -> None:
        self.fh.write(text)
        self.fh.flush()
        os.fsync(self.fh.fileno())

    def append(self, row: dict) -> None:
        self._write(row_line(self.plan, row))

    def close(self) -> None:
        self.fh.close()


def write_text_synced(path: Path, text: str) -> None:
    """Replace ``path`` by ``text`` atomically, fsynced before the rename (:func:`imutherm.io.atomic_write`)."""
    atomic_write(path, lambda tmp: Path(tmp).write_text(text, newline=""), sync=True)


def json_text(data) -> str:
    def default(obj):
        if isinstance(obj, np.generic):
            return obj.item()
        if isinstance(obj, np.ndarray):
            return obj.tolist()
        if isinstance(obj, Path):
            return str(obj)
        raise TypeError(f"not JSON serialisable: {type(obj).__name__}")

    return json.dumps(data, indent=2, default=default) + "\n"


def design_mismatch(old: dict, new: dict) -> list:
    return [k for k in sorted(set(old) | set(new)) if old.get(k) != new.get(k)]



def row_values(plan: SweepPlan, row: dict) -> list:
    """The row's value for each column, inputs filled from the design (as read back from the CSV)."""
    values = dict(zip(plan.keys, plan.cases[row["case"]].values))
    return [_parse_cell(c, _fmt(row.get(c, values.get(c)))) for c in plan.columns]
