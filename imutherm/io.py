"""Result files shared by the studies and the CLI: JSON with numpy values, CSV tables.

One writer per format, so every result file of the package has the same
conventions: JSON indented with NaN/inf written as ``null``; CSV with a header
row, ``time_s`` first where there is a time axis, temperatures in °C (the
site-temperature tables: :mod:`imutherm.site_table`). :func:`atomic_write` is
the one way a single file is replaced (a temporary name beside it, then one
rename); whole result folders are swapped by ``imutherm.cli._common.atomic_outdir``.
"""

from __future__ import annotations

import csv
import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np


def plain(obj, *, finite: bool = True):
    """numpy scalars/arrays -> Python lists and numbers, dict keys -> str; with ``finite`` (default)
    non-finite floats -> None (JSON has no NaN)."""
    if isinstance(obj, dict):
        return {str(k): plain(v, finite=finite) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [plain(v, finite=finite) for v in obj]
    if isinstance(obj, np.ndarray):
        return plain(obj.tolist(), finite=finite)
    if isinstance(obj, np.generic):
        return plain(obj.item(), finite=finite)
    if finite and isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def atomic_write(path: str | os.PathLike, write, *, sync: bool = False) -> Path:
    """Replace ``path`` in one step: ``write(tmp)`` fills a temporary file beside it (same folder, so the
    same file system), which is then renamed over ``path``; on any error the temporary file is removed
    and ``path`` is untouched. With ``sync`` the temporary file is fsynced before the rename (the sweep's
    records, which a resume after a crash reads back). Returns ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        write(tmp)
        if sync:
            fd = os.open(tmp, os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def write_json(path: str | os.PathLike, data, *, indent: int = 2, finite: bool = True) -> Path:
    """Write ``data`` as indented JSON, atomically (numpy values converted; with ``finite`` NaN/inf as
    null, else as JSON's NaN/Infinity extension, which :func:`json.load` reads back)."""
    text = json.dumps(plain(data, finite=finite), indent=indent) + "\n"
    return atomic_write(path, lambda tmp: Path(tmp).write_text(text))


def write_csv(path: str | os.PathLike, header, rows, fmt: str = "{:.6g}") -> None:
    """Write a CSV table: ``header`` (names) then ``rows`` (2-D array-like of numbers, formatted by ``fmt``)."""
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(list(header))
        for row in np.asarray(rows, float):
            w.writerow([fmt.format(v) for v in row])
