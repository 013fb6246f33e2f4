"""Which model ``updated_model.toml`` carries: the corrected one only if it is no worse than the nominal one.

The corrected model a correlation writes is its physics alone (re-tuned values and named effects): the
discrepancy term is a statistical term of the fit, not a model input. A fit that leans on the term can leave
physics that predicts the data *worse* than the nominal model once the term is taken away (the blind
campaign's two null cases, 0.59 against 0.41 K and 0.76 against 0.32 K, the board conductivity at its bound).
:func:`choose` takes, of the corrected model's physics, the same effects re-fitted without the term, and the
nominal model, the first that predicts the held-out readings no worse than the nominal model, and says so.
"""

from __future__ import annotations

import math

import numpy as np

#: the corrected model's physics may predict held-out data this fraction worse than the nominal model and still
#: be written (the two are then the same within the estimate's own scatter: none)
TOLERANCE = 0.0


def heldout_rms(fwd, values: dict, test: dict) -> float:
    """RMS [K] of the model at ``values`` (no discrepancy term) minus the measured rise over ``test``'s readings."""
    errs = [(fwd.rise(i, values) - fwd.runs[i].rise_K)[m] for i, m in test.items() if m.any()]
    if not errs:
        return math.nan
    e = np.concatenate(errs)
    return float(np.sqrt(np.mean(e**2))) if len(e) else math.nan


def choose(fwd, nominal: dict, corrected: dict, plain: dict | None, test: dict) -> dict:
    """{'model': 'corrected' | 'corrected without the term' | 'nominal', 'values', 'heldout_rms_K',
    'nominal_heldout_rms_K', 'corrected_heldout_rms_K', 'reason'}: the model to write (see the module
    docstring). ``corrected``: the corrected model's values (fitted with the term where there was one);
    ``plain``: its effects re-fitted without the term (None: no term was fitted); ``test``: the held-out readings."""
    h_nom = heldout_rms(fwd, nominal, test)
    h_cor = heldout_rms(fwd, corrected, test)
    out = {"nominal_heldout_rms_K": h_nom, "corrected_heldout_rms_K": h_cor}
    if not math.isfinite(h_nom) or not math.isfinite(h_cor) or h_cor <= h_nom * (1 + TOLERANCE):
        return {**out, "model": "corrected", "values": dict(corrected), "heldout_rms_K": h_cor,
                "reason": "" if math.isfinite(h_nom) else "no held-out readings to compare the models on"}
    why = (f"the corrected model's physics (without the discrepancy term) predicts the held-out readings worse than "
           f"the nominal model ({h_cor:.3f} against {h_nom:.3f} K)")
    if plain is not None:
        h_pl = heldout_rms(fwd, plain, test)
        if math.isfinite(h_pl) and h_pl <= h_nom * (1 + TOLERANCE):
            return {**out, "model": "corrected without the term", "values": dict(plain), "heldout_rms_K": h_pl,
                    "reason": why + f"; written: the same effects re-fitted without the term ({h_pl:.3f} K)"}
    return {**out, "model": "nominal", "values": dict(nominal), "heldout_rms_K": h_nom,
            "reason": why + "; written: the nominal model, not a corrected one"}
