"""Result files shared by the studies and the CLI: JSON with numpy values, CSV tables.

One writer per format, so every result file of the package has the same
conventions: JSON indented with NaN/inf written as ``null``; CSV with a header
row, ``time_s`` first where there is a time axis, temperatures in °C.
"""

from __future__ import annotations

import csv
import json
import math
import os
from pathlib import Path

import numpy as np


def _plain(obj):
    """numpy scalars/arrays -> Python; non-finite floats -> None (JSON has no NaN)."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, np.generic):
        return _plain(obj.item())
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def write_json(path: str | os.PathLike, data) -> None:
    """Write ``data`` as indented JSON (numpy values converted, NaN/inf as null)."""
    Path(path).write_text(json.dumps(_plain(data), indent=2) + "\n")


def write_csv(path: str | os.PathLike, header, rows, fmt: str = "{:.6g}") -> None:
    """Write a CSV table: ``header`` (names) then ``rows`` (2-D array-like of numbers, formatted by ``fmt``)."""
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(header))
        for row in np.asarray(rows, float):
            w.writerow([fmt.format(v) for v in row])
