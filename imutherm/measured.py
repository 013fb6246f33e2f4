"""Measured site temperatures: the CSV files a correlation reads.

Format (one file = one experiment)::

    # scheme = air              (required: a scheme of the layout)
    # ambient_C = 70            (required [degC]: ambient and fixture at power-on)
    # power_scale = 1.0         (optional [-]: the unit ran at this fraction of its nominal power)
    # t_power_on_s = 0          (optional [s]: power-on time on the file's clock)
    # probe = die               (optional: die | surface_ir, how the sites were read; recorded)
    time_s,tp1,gyro_x
    0,70.0,70.1
    300,85.2,
    inf,90.0,81.0

``time_s`` first, then one column per site in degC (site names as in the layout; a subset is
fine). Cells may be empty (sparse data: a paper's few figures); ``inf`` as the last time is the
steady reading. Every refusal names the file and line.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from imutherm import InputError
from imutherm.constants import ZERO_C_K
from imutherm.textio import read_text

REQUIRED = ("scheme", "ambient_C")
OPTIONAL = {"power_scale": 1.0, "t_power_on_s": 0.0, "probe": "die"}
PROBES = ("die", "surface_ir")


@dataclass(frozen=True)
class MeasuredRun:
    """One measured experiment.

    path : str, scheme : str, ambient_C : float [degC], power_scale : float [-],
    t_power_on_s : float [s], probe : str
    sites : tuple of str, times_s : (n,) [s] since power-on (inf: steady),
    values_C : (n, m) [degC], NaN where the file has no value, lines : (n,) file line numbers
    """

    path: str
    scheme: str
    ambient_C: float
    power_scale: float
    t_power_on_s: float
    probe: str
    sites: tuple
    times_s: np.ndarray
    values_C: np.ndarray
    lines: tuple

    @property
    def rise_K(self) -> np.ndarray:
        """Measured rise over the ambient at power-on [K] (n, m), NaN where missing."""
        return self.values_C - self.ambient_C

    @property
    def n_values(self) -> int:
        return int(np.isfinite(self.values_C).sum())

    @property
    def name(self) -> str:
        return Path(self.path).stem


def _number(text: str, where: str, what: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"{where}: {what} {text.strip()!r} is not a number") from None
    return v


#: most a power-on reading (time_s <= 0) may differ from ambient_C [K]: the unit starts at its ambient (probe
#: offsets and an ambient cycle are a few K at most); beyond it the file's unit or ambient_C is wrong
POWER_ON_TOLERANCE_K = 15.0
#: most the smallest reading of a file may exceed ambient_C [K]: 150 K above the ambient at every reading is
#: past what a powered unit within the layout limits reaches at all its sites (components are refused past
#: 150 degC); such a file is in another unit or has the wrong ambient_C
MAX_LOWEST_RISE_K = 150.0


def _likely_unit(reading: float, ambient_C: float, tol: float) -> str:
    """' (they look like kelvin: ...)' or Fahrenheit, if converting ``reading`` puts it near ``ambient_C``."""
    for unit, to_c in (("kelvin", lambda v: v - ZERO_C_K), ("degF", lambda v: (v - 32.0) / 1.8)):
        if abs(to_c(reading) - ambient_C) <= tol:
            return f"; the readings look like {unit} ({reading:g} {unit} = {to_c(reading):.1f} degC): convert them to degC"
    return "; give the readings in degC and the ambient at power-on as ambient_C"


def _check_unit(path: str, ambient_C: float, amb_line: int, times, arr, lines) -> None:
    """InputError if the readings cannot be degC under ``ambient_C`` (a file in kelvin or degF, or the
    wrong ambient): a power-on reading far from the ambient, or every reading far above it."""
    on = np.isfinite(times) & (times <= 0.0)
    for r in np.nonzero(on)[0]:
        row = arr[r][np.isfinite(arr[r])]
        if len(row) and np.abs(row - ambient_C).max() > POWER_ON_TOLERANCE_K:
            v = float(row[np.argmax(np.abs(row - ambient_C))])
            raise InputError(f"{path}:{lines[r]}: reading {v:g} at power-on (time_s <= 0) is more than "
                             f"{POWER_ON_TOLERANCE_K:g} K from ambient_C = {ambient_C:g} (line {amb_line})"
                             + _likely_unit(v, ambient_C, POWER_ON_TOLERANCE_K))
    lowest = float(np.nanmin(arr))
    if lowest - ambient_C > MAX_LOWEST_RISE_K:
        r = int(np.argwhere(arr == lowest)[0][0])
        raise InputError(f"{path}:{lines[r]}: every reading is more than {MAX_LOWEST_RISE_K:g} K above ambient_C = "
                         f"{ambient_C:g} (line {amb_line}; the lowest is {lowest:g})"
                         + _likely_unit(lowest, ambient_C, MAX_LOWEST_RISE_K))


def read_measured(path, sites=None, schemes=None) -> MeasuredRun:
    """Read and check one measured CSV file (see the module docstring).

    sites : iterable of valid site names (None: not checked); schemes : valid scheme names.
    """
    path = str(path)
    text = read_text(path, "measured file")
    meta, meta_line = {}, {}
    header, rows = None, []
    for i, raw in enumerate(text.splitlines(), start=1):
        line = raw.strip()
        if not line:
            continue
        if line.startswith("#"):
            body = line[1:].strip()
            k, eq, v = body.partition("=")
            k = k.strip()
            if header is None and eq and re.fullmatch(r"[A-Za-z_]\w*", k):  # '# key = value'; else a comment
                if k not in REQUIRED and k not in OPTIONAL:
                    raise InputError(f"{path}:{i}: unknown metadata key {k!r}; valid: "
                                     f"{', '.join(REQUIRED + tuple(OPTIONAL))}")
                meta[k], meta_line[k] = v.split("#", 1)[0].strip(), i
            continue
        cells = [c.strip() for c in line.split(",")]
        if header is None:
            header = (cells, i)
            continue
        rows.append((cells, i))
    for k in REQUIRED:
        if k not in meta:
            raise InputError(f"{path}: metadata '# {k} = ...' is missing (required: {', '.join(REQUIRED)})")
    scheme = meta["scheme"]
    if schemes is not None and scheme not in schemes:
        raise InputError(f"{path}:{meta_line['scheme']}: scheme {scheme!r} is not in the layout; "
                         f"valid: {', '.join(schemes)}")
    vals = {}
    for k in ("ambient_C", "power_scale", "t_power_on_s"):
        if k in meta:
            v = _number(meta[k], f"{path}:{meta_line[k]}", k)
            if not math.isfinite(v):
                raise InputError(f"{path}:{meta_line[k]}: {k} must be finite, got {meta[k]!r}")
            vals[k] = v
        else:
            vals[k] = OPTIONAL[k]
    if not -60.0 <= vals["ambient_C"] <= 150.0:
        raise InputError(f"{path}:{meta_line['ambient_C']}: ambient_C = {vals['ambient_C']:g} is outside -60..150 degC")
    if not 0.0 < vals["power_scale"] <= 3.0:
        raise InputError(f"{path}:{meta_line['power_scale']}: power_scale must be in (0, 3], got {vals['power_scale']:g}")
    probe = meta.get("probe", OPTIONAL["probe"])
    if probe not in PROBES:
        raise InputError(f"{path}:{meta_line['probe']}: probe {probe!r} unknown; valid: {', '.join(PROBES)}")
    if header is None:
        raise InputError(f"{path}: no header line 'time_s,<site>,...'")
    cols, hline = header
    if cols[0] != "time_s":
        raise InputError(f"{path}:{hline}: the first column must be 'time_s', got {cols[0]!r}")
    names = cols[1:]
    if not names or any(not n for n in names):
        raise InputError(f"{path}:{hline}: expected one named column per site after time_s")
    if len(set(names)) != len(names):
        raise InputError(f"{path}:{hline}: a site column appears twice")
    if sites is not None:
        bad = [n for n in names if n not in sites]
        if bad:
            raise InputError(f"{path}:{hline}: unknown site column {bad[0]!r}; valid: {', '.join(sites)}")
    if not rows:
        raise InputError(f"{path}: no data rows after the header (line {hline})")
    times, values, lines = [], [], []
    for cells, i in rows:
        if len(cells) != len(cols):
            raise InputError(f"{path}:{i}: {len(cells)} cells, the header has {len(cols)}")
        t = _number(cells[0], f"{path}:{i}", "time_s")
        if math.isnan(t) or t == -math.inf:
            raise InputError(f"{path}:{i}: time_s must be a number (inf for the steady reading), got {cells[0]!r}")
        t -= vals["t_power_on_s"]
        if times and not t > times[-1]:
            raise InputError(f"{path}:{i}: time_s is not increasing ({cells[0]} after "
                             f"{times[-1] + vals['t_power_on_s']:g})")
        if times and math.isinf(times[-1]):
            raise InputError(f"{path}:{i}: only the last row may be the steady reading (time inf)")
        row = []
        for name, c in zip(names, cells[1:]):
            if c == "":
                row.append(math.nan)
                continue
            v = _number(c, f"{path}:{i}", f"column {name!r}:")
            if not math.isfinite(v):
                raise InputError(f"{path}:{i}: column {name!r} holds {c!r}; leave the cell empty where there is "
                                 f"no reading")
            if not -60.0 <= v <= 400.0:
                raise InputError(f"{path}:{i}: column {name!r} = {v:g} degC is outside -60..400")
            row.append(v)
        times.append(t)
        values.append(row)
        lines.append(i)
    arr = np.array(values, float)
    if not np.isfinite(arr).any():
        raise InputError(f"{path}: no readings (every site cell is empty)")
    if len(times) < 2:
        raise InputError(f"{path}:{lines[0]}: one row of readings; a correlation compares the rise over time: give "
                         "two or more rows (e.g. a reading during the warm-up and the steady one, time_s = inf)")
    _check_unit(path, vals["ambient_C"], meta_line["ambient_C"], np.array(times, float), arr, lines)
    return MeasuredRun(path, scheme, vals["ambient_C"], vals["power_scale"], vals["t_power_on_s"], probe,
                       tuple(names), np.array(times, float), arr, tuple(lines))


def write_measured(path, run_meta: dict, sites, times, values_C) -> None:
    """Write a measured file (the generator's output): metadata, header, rows (NaN -> empty cell)."""
    lines = [f"# {k} = {v}" for k, v in run_meta.items()]
    lines.append(",".join(["time_s"] + list(sites)))
    for t, row in zip(times, np.atleast_2d(values_C)):
        cells = ["inf" if math.isinf(t) else f"{t:.6g}"] + ["" if not math.isfinite(v) else f"{v:.4f}" for v in row]
        lines.append(",".join(cells))
    Path(path).write_text("\n".join(lines) + "\n")
