"""Readings no unit of this kind can produce, refused before any fit.

A correlation fits whatever it is given: a 300 K rise or a powered sensor colder than the chamber would be
taken up by the re-tune's bounds and then by the model-form term, and reported as the model's error. They are
the file's error (a thermocouple type mixed up, a column of the wrong unit, ambient and site swapped), so
:func:`check_plausible` refuses them with the file and line, before any model is built:

- **too hot**: a reading above :data:`MAX_READING_C`; no part of a unit of this kind survives it (lead-free
  solder SAC305 melts at 217 °C; MEMS IMUs and regulators are rated to 85-150 °C), so the figure is not a
  temperature of the unit;
- **colder than ambient under power**: a reading, once the site has had time to warm (after the first
  :data:`WARM_FRACTION` of the record, or a steady row), more than :data:`COLD_MARGIN_K` below the file's
  ambient. Powered, every point of the unit is at or above its surroundings (no cooler, no evaporation); the
  margin covers probe offsets (±0.1-0.5 K for a thermocouple after calibration, more before) and noise.
"""

from __future__ import annotations

import numpy as np

from imutherm import InputError

#: the hottest reading [degC] a unit of this kind can give: above SAC305's melting point (217 degC), with margin
MAX_READING_C = 250.0
#: a powered site may read at most this much below the file's ambient [K] once warm (probe offsets and noise)
COLD_MARGIN_K = 2.0
#: readings after this fraction of the record (or steady rows) count as warm
WARM_FRACTION = 0.25


def check_plausible(runs) -> None:
    """Refuse (InputError, one line naming the file and line) readings no unit of this kind can produce."""
    for run in runs:
        v = np.asarray(run.values_C, float)
        t = np.asarray(run.times_s, float)
        fin = np.isfinite(t)
        last = float(t[fin].max()) if fin.any() else 0.0
        hot = np.argwhere(np.isfinite(v) & (v > MAX_READING_C))
        if len(hot):
            k, j = hot[0]
            raise InputError(f"{run.path}:{run.lines[k]}: {run.sites[j]} reads {v[k, j]:.1f} °C, above "
                             f"{MAX_READING_C:g} °C: no unit of this kind survives that (solder melts at 217 °C); "
                             f"check the column's unit and sensor type")
        if run.power_scale <= 0:
            continue
        warm = (~fin | (t >= WARM_FRACTION * last))[:, None]
        cold = np.argwhere(np.isfinite(v) & warm & (v < run.ambient_C - COLD_MARGIN_K))
        if len(cold):
            k, j = cold[0]
            raise InputError(f"{run.path}:{run.lines[k]}: {run.sites[j]} reads {v[k, j]:.2f} °C, "
                             f"{run.ambient_C - v[k, j]:.1f} K below the ambient {run.ambient_C:g} °C under power: a "
                             f"powered unit is nowhere colder than its surroundings (more than {COLD_MARGIN_K:g} K "
                             f"of probe offset); check the ambient and the site columns")
