"""The forward model of a correlation: site rises of every measured run from knob values, through the runs'
reduced models, and the residuals (model minus measured) the fits minimise.
"""

from __future__ import annotations


import numpy as np

from imutherm.unit import knobs
from imutherm.unit.effects import ambient_rate_K_s, apply_signal_effects, effect_of, is_signal, setting
from imutherm.unit.model import ModelOptions


#: the form knobs: re-tuned, never named (:data:`imutherm.unit.knobs.FORM_RETUNE`), and each one's value at
#: which the model is nominal (geometry, options) -> value
FORM_RETUNE = knobs.FORM_RETUNE


#: the form knobs opened where the model's form is in doubt (with the discrepancy term,
#: :data:`imutherm.unit.knobs.FORM_IN_DOUBT`): re-tuned then, never candidates
FORM_IN_DOUBT = knobs.FORM_IN_DOUBT


FORM_KNOBS = {**FORM_RETUNE, **FORM_IN_DOUBT}


_FORM_NOMINAL = {"cavity_emissivity": knobs.cavity_pair_nominal,
                 "cavity_law_blend": lambda geometry, options: float(options.cavity_law_blend)}


#: the times at which the model curve is evaluated for an effect on the reading, e.g. a probe lag (plus the
#: measured ones) [s]
_DENSE = np.concatenate([[0.0], np.geomspace(0.5, 2.0e4, 240)])


class ForwardModel:
    """Site rises of every run from knob values, through the runs' reduced models."""

    def __init__(self, runs, roms, geometries, options: ModelOptions | None = None, form=tuple(FORM_RETUNE)):
        self.runs, self.roms, self.geometries, self.options = runs, roms, geometries, options or ModelOptions()
        geo = next(iter(geometries.values())) if geometries else None
        #: the re-tune knobs' nominal values, from the layout and materials (every scheme shares them)
        self.nominal = knobs.nominal_values(geo, self.options) if geo is not None else {}
        #: the form knobs of ``form`` (:data:`FORM_RETUNE`) the reduced models carry, re-tuned beside the others
        self.form = tuple(n for n in form if roms and all(n in rom.knobs for rom in roms.values()))
        for n in self.form:
            self.nominal[n] = _FORM_NOMINAL[n](geo, self.options)

    def rise(self, i: int, values: dict, times=None) -> np.ndarray:
        """Model rise [K] of run ``i`` at its times (or ``times``), its sites (n, m)."""
        run = self.runs[i]
        rom = self.roms[(run.scheme, run.ambient_C)]
        t = run.times_s if times is None else np.asarray(times, float)
        # the signal effects act outside the reduced model: a moving ambient as its ramp, the rest on the reading
        model_vals = {k: v for k, v in values.items() if not is_signal(k) and k in rom.knobs}
        model_vals["power_scale"] = values.get("power_scale", 1.0) * run.power_scale
        effects = [setting(k, **{effect_of(k).params[0].name: v}) for k, v in values.items() if is_signal(k)]
        cols = [rom.site_names.index(s) for s in run.sites]
        drift = ambient_rate_K_s(effects)
        reading = [s for s in effects if effect_of(s.name).ambient_rate is None]
        if not reading:
            return rom.rise(model_vals, t, drift)[:, cols]
        fin = np.isfinite(t)
        dense = np.union1d(_DENSE[_DENSE <= (t[fin].max() if fin.any() else 0.0)], t[fin])
        y = rom.rise(model_vals, dense, drift)[:, cols]
        y = apply_signal_effects(dense, y, reading)
        out = np.empty((len(t), len(cols)))
        for j in range(len(cols)):
            out[fin, j] = np.interp(t[fin], dense, y[:, j])
        if (~fin).any():
            out[~fin] = rom.rise(model_vals, [np.inf])[:, cols]
        return out


def model_residuals(fwd: ForwardModel, values: dict, mask: dict) -> np.ndarray:
    """Model minus measured rise [K] over the selected points (mask: run index -> bool (n, m))."""
    out = []
    for i, m in mask.items():
        if not m.any():
            continue
        r = fwd.rise(i, values) - fwd.runs[i].rise_K
        out.append(r[m])
    return np.concatenate(out) if out else np.zeros(0)


def residual_series(fwd: ForwardModel, values: dict, mask: dict):
    """(run i, site j, rows of run i with data in ``mask``, residual model - measured [K] of site j at every
    reading of run i) for every series with data."""
    for i, m in mask.items():
        if not m.any():
            continue
        r = fwd.rise(i, values) - fwd.runs[i].rise_K
        for j in range(r.shape[1]):
            if m[:, j].any():
                yield i, j, m[:, j], r[:, j]
