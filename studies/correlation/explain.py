"""One list of explanations: library effects and moved re-tune knobs as candidates of the same kind.

Issue 58: a re-tune that found the hidden value (a cavity emissivity of 0.228 for 0.25) sat in ``parameters``
while the verdict named two wrong library effects. Here every explanation the correlation has (each named
effect, each member of an ambiguous set, each finding: a knob that moved far) is scored on **one** basis, the
corrected physics fitted without the discrepancy term (:attr:`CorrelationResult.physics`), by the same
evidence a library effect meets in :func:`imutherm.studies.correlation.verdict`:

- ΔAICc of the model with the explanation against the model without it (an effect removed / a knob held at its
  nominal value / an ambiguous candidate added, everything else re-fitted);
- the held-out gain [K] (pooled hold-out folds), and the RMS it explains [K].

``qualifies``: ΔAICc >= :data:`MARGIN_NONE`, explains >= :data:`EXPLAIN_MIN_NOISE` noise sigmas and predicts
held-out data better. Ranked by ΔAICc, best first. A knob at a bound is not in the list (a symptom of the model's
form, :class:`imutherm.studies.correlation.findings.Symptom`).
"""

from __future__ import annotations

import math

from imutherm.unit.effects import effect_of
from imutherm.studies.correlation.fit import Fit, fit_candidate
from imutherm.studies.correlation.holdout import with_heldout, pooled_heldout
from imutherm.studies.correlation.verdict import EXPLAIN_MIN_NOISE, MARGIN_NONE, effect_words


def _entry(kind, name, value, unit, ci95, d_crit, gain, explained, noise, words, **more) -> dict:
    ok = (math.isfinite(d_crit) and d_crit >= MARGIN_NONE and explained >= EXPLAIN_MIN_NOISE * noise
          and not (math.isfinite(gain) and gain <= 0.0))
    return {"kind": kind, "name": name, "value": value, "unit": unit, "ci95": list(ci95) if ci95 else None,
            "delta_criterion": d_crit, "heldout_gain_K": gain, "explained_K": explained, "qualifies": bool(ok),
            "in_words": words, **more}


def knob_entry(s, noise: float) -> dict:
    """The explanation entry of a knob at its bound in an ambiguous set (``s`` its
    :class:`~imutherm.studies.correlation.findings.Symptom`): its value at the bound, the direction it wants, no
    criterion (it cannot be fitted past the bound)."""
    from imutherm.studies.correlation.in_place import direction_words
    return _entry("parameter", s.parameter, s.value, s.unit, None, math.nan, math.nan, math.nan, noise,
                  f"{direction_words(s)}: {s.words()}", ambiguous=True, at_bound=s.bound)


def _fitted(fwd, effects: tuple, free: Fit, full, folds, ratio: float, noise: float) -> Fit:
    return with_heldout(fit_candidate(fwd, effects, full, None, ratio, noise, None, free.values),
                        pooled_heldout(fwd, effects, folds, ratio, noise, None, free.values))


def explanations(fwd, free: Fit, found: tuple, ambiguous: tuple, full: dict, folds, ratio: float,
                 noise: float, symptoms: tuple = ()) -> list:
    """The ranked list of explanations (see the module docstring): one dict per named effect of ``free``, per
    finding of ``found`` and per effect of ``ambiguous`` not in ``free``: kind ('effect' | 'parameter'), name,
    value, unit, ci95, delta_criterion [-], heldout_gain_K, explained_K, qualifies, in_words; an ambiguous
    candidate also its predicted change at the readings (``change_K``). A re-tune knob in ``ambiguous`` (one at
    its bound, :mod:`imutherm.studies.correlation.in_place`) is a 'parameter' entry from its symptom (of
    ``symptoms``): its value at the bound, the direction it wants, and no criterion (it cannot be fitted past
    the bound)."""
    out = [knob_entry(s, noise) for s in symptoms if s.parameter in ambiguous]
    ambiguous = tuple(e for e in ambiguous if e not in {s.parameter for s in symptoms})
    for f in found:
        out.append(_entry("parameter", f.parameter, f.value, f.unit, f.ci95, f.delta_criterion,
                          f.heldout_fixed_K - f.heldout_free_K, f.explained_K, noise, f.words(), nominal=f.nominal,
                          ci95_from="profile"))
    for e in free.effects:
        without = _fitted(fwd, tuple(x for x in free.effects if x != e), free, full, folds, ratio, noise)
        p = effect_of(e).params[0]
        out.append(_entry("effect", e, free.values.get(e), p.unit, free.ci.get(e), without.aicc - free.aicc,
                          without.heldout_rms_K - free.heldout_rms_K,
                          math.sqrt(max(without.rms_K**2 - free.rms_K**2, 0.0)), noise, effect_words(e, free.values)))
    for e in ambiguous:
        if e in free.effects:
            continue
        alt = _fitted(fwd, free.effects + (e,), free, full, folds, ratio, noise)
        p = effect_of(e).params[0]
        rest = {k: v for k, v in alt.values.items() if k != e}
        change = max((float(abs(fwd.rise(i, alt.values) - fwd.rise(i, rest))[m].max()) for i, m in full.items()
                      if m.any()), default=math.nan)
        out.append(_entry("effect", e, alt.values.get(e), p.unit, alt.ci.get(e), free.aicc - alt.aicc,
                          free.heldout_rms_K - alt.heldout_rms_K,
                          math.sqrt(max(free.rms_K**2 - alt.rms_K**2, 0.0)), noise, effect_words(e, alt.values),
                          change_K=change, ambiguous=True, values=dict(alt.values)))
    return sorted(out, key=lambda x: -(x["delta_criterion"] if math.isfinite(x["delta_criterion"]) else -math.inf))
