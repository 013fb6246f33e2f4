"""A library effect named merely in the place of a knob held at its bound is not named.

A re-tuned knob that ends at a bound of its source's range while the data pull it on is a symptom of the
model's form, never a finding (:class:`~imutherm.studies.correlation.findings.Symptom`). But the data's pull does
not stop at the bound: what the knob would do past it is left in the residual, and a library effect that changes
the readings the same way takes it and wins on the evidence. Issue 58's held-out seed 62: a cavity emissivity
hidden at 0.025 (the re-tune's lower bound 0.02) ended at the bound on the layered and nuisance forms, and
``contact@standoff`` (not hidden) was named in its place.

:func:`named_in_place` asks of each named effect whether its evidence is shared with such a knob: over the
training readings, the part of the effect's signature s (the change it makes, the rest as fitted) that the
re-tune's knobs can make, linearised at the fit (each knob's sensitivity in its coordinate u, within its source's
range), is taken out by bounded least squares twice, with the at-bound knob **held** at its bound and **freed**
past it in the direction the data pull. The effect is named in the knob's place when what is left of s with the
knob freed is within the level a right model leaves unexplained (RMS at most ``FORM_SIGMAS`` x the stated form
error at the readings or ``EXPLAIN_MIN_NOISE`` noise sigmas, whichever is larger: the level a finding must
explain beyond, :mod:`imutherm.studies.correlation.findings`) **and** at most ``EXPLAIN_FRACTION`` (half) of
what is left with the knob held (the verdict's halving standard): freeing the knob, not the re-tune as it is,
takes the effect's evidence. The two are then reported as ambiguous, the knob with the direction it wants
("cavity_emissivity wants below 0.02"), not the effect's name. A right effect beside a knob at its bound keeps its
name: its signature is not one the knob makes past the bound (toy: a 0.3 W regulator named with power_scale at
its upper bound).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import lsq_linear

#: the step [-, in the knob coordinate u in [-1, 1]] of the knobs' finite-difference sensitivities: 2.5 % of a
#: source range, inward from a bound (a knob's law is smooth over its range: Chebyshev-interpolated, 2-3 nodes)
STEP_U = 0.05
#: how far past its bound a freed knob may go in the linearisation [-, in u]: one whole source range
FREE_U = 2.0


def _signature(fwd, values: dict, effect: str, train: dict) -> np.ndarray:
    rest = {k: v for k, v in values.items() if k != effect}
    return np.concatenate([(fwd.rise(i, values) - fwd.rise(i, rest))[m] for i, m in train.items() if m.any()])


def _rise(fwd, values: dict, train: dict) -> np.ndarray:
    return np.concatenate([fwd.rise(i, values)[m] for i, m in train.items() if m.any()])


def _rms(x: np.ndarray) -> float:
    return float(np.sqrt(np.mean(x**2))) if len(x) else math.nan


def direction_words(s) -> str:
    """'<knob> wants <below|above> <bound> <unit>' of an at-bound symptom ``s``."""
    u = "" if s.unit == "-" else f" {s.unit}"
    return f"{s.parameter} wants {'below' if s.bound == 'lower' else 'above'} {s.value:.3g}{u}"


def named_in_place(fwd, free, symptoms, train: dict, noise_K: float, band_K: float) -> dict:
    """Effect name -> {'knob', 'words', 'left_held_K', 'left_free_K', 'level_K', 'signature_K'} for each
    effect of ``free`` (the corrected physics, fitted without the discrepancy term) named merely in the place
    of a knob at its bound (``symptoms`` with bound 'lower' / 'upper'), see the module docstring. ``train``:
    run index -> bool (n, m) of the readings; ``band_K``: the stated form error there [K]."""
    from imutherm.studies.correlation.findings import knob_of
    from imutherm.studies.correlation.form_error import FORM_SIGMAS
    from imutherm.studies.correlation.verdict import EXPLAIN_FRACTION, EXPLAIN_MIN_NOISE
    at = [s for s in symptoms if s.bound in ("lower", "upper") and s.parameter in free.values]
    if not at or not free.effects:
        return {}
    level = max(FORM_SIGMAS * (band_K if math.isfinite(band_K) else 0.0), EXPLAIN_MIN_NOISE * noise_K)
    v = dict(free.values)
    names = [n for n in v if n in fwd.nominal and n not in free.effects]
    y0 = _rise(fwd, v, train)
    cols, lo, hi, u_at = [], [], [], {}
    for n in names:
        k = knob_of(fwd, n)
        u = float(np.clip(k.to_u(v[n]), -1.0, 1.0))
        h = -STEP_U if u > 0 else STEP_U  # inward from the nearer bound
        cols.append((_rise(fwd, {**v, n: float(k.from_u(u + h))}, train) - y0) / h)
        lo.append(-1.0 - u)
        hi.append(1.0 - u)
        u_at[n] = u
    G = np.column_stack(cols)
    out = {}
    for e in free.effects:
        s_e = _signature(fwd, v, e, train)
        if not np.any(s_e):
            continue
        for sym in at:
            if sym.parameter not in names:
                continue
            j = names.index(sym.parameter)
            lo_f, hi_f = list(lo), list(hi)
            if sym.bound == "lower":
                lo_f[j] = -FREE_U
            else:
                hi_f[j] = FREE_U
            left = []
            for b in ((lo, hi), (lo_f, hi_f)):
                r = lsq_linear(G, s_e, bounds=(np.minimum(b[0], -1e-12), np.maximum(b[1], 1e-12)))
                left.append(_rms(s_e - G @ r.x))
            held, freed = left
            if freed <= level and freed <= EXPLAIN_FRACTION * held:
                out[e] = {"knob": sym.parameter, "bound": sym.bound, "words": direction_words(sym),
                          "left_held_K": held, "left_free_K": freed, "level_K": level, "signature_K": _rms(s_e)}
                break
    return out
