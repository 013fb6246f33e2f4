"""Scalar metrics of a thermal result: rises, hot spot, per-part maxima, settle times."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from imutherm import InputError

#: Fraction of the final rise that defines t63 (one time constant of a first-order system).
T63_FRACTION = 1.0 - math.exp(-1.0)
#: Fraction that defines t95.
T95_FRACTION = 0.95


@dataclass(frozen=True)
class ThermalMetrics:
    """Summary of a steady or transient result (transient: the field at ``t_end``).

    Attributes
    ----------
    ambient_C : float [°C]
    max_C : float [°C]
        Hottest node temperature.
    max_rise_K : float [K]
        Hottest node minus ambient.
    max_at_m : tuple (x, y, z) [m]
        Hottest node.
    max_part : str
        Part of a cell touching the hottest node (a powered part if one touches it).
    probe_rise_K : dict [K]
        Probe name -> probe temperature minus ambient.
    t63_s, t95_s : dict or None [s]
        Probe name -> time to reach 63.2 % (1 − 1/e) / 95 % of the final rise
        (rise measured from the probe's t = 0 value; crossing interpolated in the log of
        the remaining gap, see :func:`settle_time`; NaN if never reached or the final rise is zero). ``None`` for steady results.
    part_max_C : dict [°C]
        Part name -> hottest node of the part's cells.
    part_max_rise_K : dict [K]
        Part name -> ``part_max_C`` minus ambient.
    """

    ambient_C: float
    max_C: float
    max_rise_K: float
    max_at_m: tuple
    max_part: str
    probe_rise_K: dict
    t63_s: dict | None
    t95_s: dict | None
    part_max_C: dict
    part_max_rise_K: dict


def settle_time(times, values, fraction: float, final=None, *, interpolation: str = "log") -> float:
    """First time [s] at which ``values − values[0]`` reaches ``fraction`` of the final rise.

    Parameters
    ----------
    times : array_like [s]
    values : array_like [°C]
    fraction : float [-]
        E.g. 0.632 or 0.95.
    final : float, optional [K]
        Final rise over ``values[0]``; default ``values[-1] − values[0]``.
    interpolation : {'log', 'linear'}
        How the crossing is located between the two bracketing steps. ``'log'``
        (default): linear in time in the logarithm of the remaining gap
        ``1 − rise/final``, exact for an exponential approach
        ``gap = exp(−t/τ)`` whatever the step; linear interpolation of such a curve
        is late by up to ~(Δt/τ)² τ/8 (about 1.5 % of t95 with 60 s steps at τ = 100 s).
        Falls back to linear where the gap does not shrink monotonically to a
        positive value across the bracket (overshoot, or the last point defines the final value).

    Returns
    -------
    float [s]; NaN if never reached.
    """
    if interpolation not in ("log", "linear"):
        raise InputError(f"settle_time: interpolation must be 'log' or 'linear', got {interpolation!r}")
    t = np.asarray(times, dtype=float)
    v = np.asarray(values, dtype=float)
    rise = v - v[0]
    fin = rise[-1] if final is None else float(final)
    if fin == 0 or not np.isfinite(fin):
        return float("nan")
    s = rise / fin          # normalised: the target is `fraction`
    hit = np.flatnonzero(s >= fraction)
    if hit.size == 0:
        return float("nan")
    i = int(hit[0])
    if i == 0:
        return float(t[0])
    s0, s1 = s[i - 1], s[i]
    g0, g1, gt = 1.0 - s0, 1.0 - s1, 1.0 - fraction
    if interpolation == "log" and g1 > 0 and g0 > g1 and gt > 0:
        w = math.log(g0 / gt) / math.log(g0 / g1)
    else:
        w = (fraction - s0) / (s1 - s0) if s1 != s0 else 1.0
    return float(t[i - 1] + w * (t[i] - t[i - 1]))


def thermal_metrics(result, *, final_rise_K: dict | None = None) -> ThermalMetrics:
    """Metrics of a :class:`SteadyResult` or :class:`TransientResult`.

    Parameters
    ----------
    result : SteadyResult or TransientResult
    final_rise_K : dict, optional [K]
        Probe name -> final rise over the t = 0 value to use for t63/t95
        (e.g. from a steady solve); default: the rise at ``t_end``.

    Returns
    -------
    ThermalMetrics
    """
    prob = result.problem
    g = prob.grid
    T = np.asarray(result.T_C)
    amb = prob.ambient_C
    imax = int(np.argmax(T))
    coords = g.node_coordinates()[imax]
    # cells touching node imax
    Nx, Ny, Nz = (len(a) for a in (g.xs, g.ys, g.zs))
    i, rem = divmod(imax, Ny * Nz)
    j, k = divmod(rem, Nz)
    nx, ny, nz = g.shape
    parts = np.asarray(g.cell_part)
    best, best_q = None, -np.inf
    qc = prob.q.reshape(g.shape)
    for ci in (i - 1, i):
        for cj in (j - 1, j):
            for ck in (k - 1, k):
                if 0 <= ci < nx and 0 <= cj < ny and 0 <= ck < nz:
                    if qc[ci, cj, ck] > best_q:
                        best, best_q = int(parts[ci, cj, ck]), qc[ci, cj, ck]
    max_part = g.part_names[best] if best is not None and len(g.part_names) else ""
    conn = g.hex_connectivity()
    cell_max = T[conn].max(axis=1)
    pm = np.full(len(g.part_names), -np.inf)
    np.maximum.at(pm, parts.reshape(-1), cell_max)
    part_max = {name: float(pm[p]) for p, name in enumerate(g.part_names) if np.isfinite(pm[p])}
    names = tuple(result.probe_names)
    if hasattr(result, "times"):
        final_probe = np.asarray(result.probe_C)[-1] if len(names) else np.zeros(0)
        fr = final_rise_K or {}
        unknown = [p for p in fr if p not in names]
        if unknown:
            raise InputError(f"thermal_metrics: final_rise_K names unknown probes {unknown}; valid: {list(names)}")
        t63, t95 = {}, {}
        for p, name in enumerate(names):
            curve = np.asarray(result.probe_C)[:, p]
            t63[name] = settle_time(result.times, curve, T63_FRACTION, fr.get(name))
            t95[name] = settle_time(result.times, curve, T95_FRACTION, fr.get(name))
    else:
        final_probe = np.asarray(result.probe_C)
        t63 = t95 = None
    return ThermalMetrics(ambient_C=amb, max_C=float(T[imax]), max_rise_K=float(T[imax] - amb),
                          max_at_m=tuple(float(c) for c in coords), max_part=max_part,
                          probe_rise_K={n: float(v - amb) for n, v in zip(names, final_probe)},
                          t63_s=t63, t95_s=t95, part_max_C=part_max,
                          part_max_rise_K={n: v - amb for n, v in part_max.items()})
