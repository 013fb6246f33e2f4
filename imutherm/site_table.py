"""Site-temperature tables: the one hand-off from the thermal stage to the IMU stage, written and read here.

A table is a CSV file: a header ``time_s`` then one column per site (the
layout's site names: the six sensor dies :data:`SITES` and any others, e.g.
the paper's test points ``tp1..tp3``), one row per time [s], temperatures
[°C]. A steady result is one row at time ``inf``. Every table the package
writes (``imutherm solve``'s ``probes.csv``, ``compare --thermal-only``'s
``probes_<scheme>.csv``, ``compare``'s ``curves_<scheme>.csv``) comes from
:func:`write_site_table`; ``imutherm attitude --temperature-csv`` and the
reports read them with :func:`read_site_table`, which also takes a user's own
file (strict UTF-8, BOM accepted, size-capped, one-line errors naming the file
and the column).
"""

from __future__ import annotations

import csv
import io
import os
from pathlib import Path

import numpy as np

from imutherm import InputError

#: the sensor-die sites of the IMU, in the order of every (N, 6) temperature array of :mod:`imutherm.imu`
SITES = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")
GYRO_SITES = SITES[:3]
ACCEL_SITES = SITES[3:]
#: the time column [s]
TIME = "time_s"
#: formats: times to 9 significant digits (a 1e5 s run to 1e-4 s), temperatures to 1e-6 K
TIME_FORMAT = "{:.9g}"
TEMPERATURE_FORMAT = "{:.6f}"


def write_site_table(path: str | os.PathLike, times_s, names, temps_C) -> Path:
    """Write a site-temperature table.

    Parameters
    ----------
    path : str or Path
    times_s : array_like (M,) [s]  (``inf`` for a steady state)
    names : sequence of str, the site names (columns after ``time_s``)
    temps_C : array_like (M, len(names)) [°C]
    """
    t = np.asarray(times_s, float).reshape(-1)
    T = np.asarray(temps_C, float).reshape(len(t), -1)
    names = [str(n) for n in names]
    if T.shape[1] != len(names) or len(set(names)) != len(names) or TIME in names:
        raise InputError(f"site table {path}: {len(names)} unique site names other than {TIME!r} needed for "
                         f"{T.shape[1]} columns, got {names}")
    path = Path(path)
    with open(path, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow([TIME] + names)
        for ti, row in zip(t, T):
            w.writerow([TIME_FORMAT.format(ti)] + [TEMPERATURE_FORMAT.format(v) for v in row])
    return path


def read_site_table(path: str | os.PathLike, sites=SITES) -> tuple[np.ndarray, np.ndarray, tuple]:
    """Read a site-temperature table.

    Parameters
    ----------
    path : str or Path
    sites : sequence of str or None
        Columns required, returned in this order (default :data:`SITES`; other columns are ignored);
        None: every column after ``time_s``, in the file's order.

    Returns
    -------
    (times [s] (M,), temperatures [°C] (M, len(sites)), site names). Several rows: ``time_s`` finite
    and strictly increasing. A single row is a constant temperature and its ``time_s`` may be any
    number, ``inf`` included (a steady run). Temperatures must be finite. Lines starting with ``#``
    are comments. InputError names the file and the missing or bad column.
    """
    from imutherm.textio import read_text  # strict UTF-8 (BOM dropped), size cap, one-line errors

    path = Path(path)
    try:
        rows = list(csv.reader(io.StringIO(read_text(path, "temperature CSV"), newline="")))
    except csv.Error as exc:
        raise InputError(f"{path}: not a valid CSV file ({exc})") from None
    rows = [r for r in rows if r and not r[0].lstrip().startswith("#")]
    if len(rows) < 2:
        raise InputError(f"{path}: temperature CSV needs a header and at least one row")
    header = [h.strip() for h in rows[0]]
    if sites is None:
        if TIME not in header:
            raise InputError(f"{path}: column {TIME!r} is missing")
        sites = [h for h in header if h != TIME]
    need = (TIME,) + tuple(sites)
    for col in need:
        if col not in header:
            raise InputError(f"{path}: column {col!r} is missing; valid header: {', '.join(need)}")
    idx = [header.index(c) for c in need]
    try:
        data = np.array([[float(r[i]) for i in idx] for r in rows[1:]], float)
    except (ValueError, IndexError) as exc:
        raise InputError(f"{path}: non-numeric or short row in temperature CSV ({exc})") from None
    if not np.all(np.isfinite(data[:, 1:])):
        raise InputError(f"{path}: temperature CSV contains NaN or inf temperatures")
    if len(data) > 1 and not np.all(np.isfinite(data[:, 0])):
        raise InputError(f"{path}: column {TIME!r} contains NaN or inf; only a single-row (constant, e.g. "
                         "steady-state) file may have a non-finite time")
    t = data[:, 0]
    if len(t) > 1 and np.any(np.diff(t) <= 0):
        raise InputError(f"{path}: column {TIME!r} must be strictly increasing")
    return t, data[:, 1:], tuple(sites)
