"""The signal effects of the library, one entry each: what a sensor reports, not the field. A first-order
probe lag (:func:`first_order_lag`) and an ambient that drifts during the test (:func:`ambient_drift_rise`);
their ``order`` says which acts first (the surroundings change the temperature before a probe reads it)."""

from __future__ import annotations

import math

import numpy as np

from imutherm import InputError
from imutherm.unit.effects.registry import EffectSetting, Param, register_effect


def first_order_lag(times, values, tau_s: float, initial=None) -> np.ndarray:
    """The reading of a first-order sensor (time constant ``tau_s`` [s]) of a signal.

    tau dy/dt = x - y, y(t0) = ``initial`` (default x(t0)), with x linear between the samples
    (exact for piecewise-linear x). ``times`` [s] increasing, ``values`` (n,) or (n, m).
    """
    t = np.asarray(times, float)
    x = np.asarray(values, float)
    y = np.empty_like(x)
    y[0] = x[0] if initial is None else initial
    for i in range(1, len(t)):
        h = t[i] - t[i - 1]
        a = math.exp(-h / tau_s)
        # exact step for x linear on [t_{i-1}, t_i]
        slope = (x[i] - x[i - 1]) / h if h > 0 else 0.0 * x[i]
        y[i] = a * y[i - 1] + (1 - a) * x[i - 1] + slope * (h - tau_s * (1 - a))
    return y


@register_effect("probe_lag", "signal", (Param("tau_s", "s", 2.0, 300.0, True,
                                               "first-order sensor lag: an IR thermometer or thermocouple "
                                               "taped on a board responds in seconds to a few minutes"),),
                 "the probe reads late: a first-order lag with time constant tau between the site and the "
                 "reading", order=1,
                 # its rises are computed on a dense time grid and filtered: ~3x the CPU of any other candidate's
                 # fits (measured: 3.0-3.8 s against 0.3-1.5 s per candidate, 2026-12-02)
                 fit_cost=3.0)
def _probe_lag(times, rise_K, s: EffectSetting, lag_s=None) -> np.ndarray:
    if len(times) > 1:
        return first_order_lag(times, rise_K, s.value("tau_s"))
    return rise_K


def ambient_drift_rise(times, lag_s, rate_K_per_s: float) -> np.ndarray:
    """Temperature change [K] of sites whose surroundings drift at ``rate_K_per_s`` [K/s] from t = 0.

    ``lag_s`` (m,) [s]: each site's lag behind a ramp of the surroundings, the field
    tau = A^-1 M 1 of the linear(ised) model (A conduction + boundary, M heat capacity). The response
    r (t - tau (1 - exp(-t / tau))) is exact at t -> 0 (to first order) and on the settled ramp,
    and one-mode in between. Returns (n, m).
    """
    t = np.asarray(times, float)[:, None]
    tau = np.maximum(np.asarray(lag_s, float)[None, :], 1e-9)
    return rate_K_per_s * (t - tau * (1.0 - np.exp(-t / tau)))


@register_effect("ambient_drift", "signal", (Param("rate_K_per_h", "K/h", -20.0, 20.0, False,
                                                   "a lab room or an oven without closed-loop control drifts "
                                                   "by up to ~20 K per hour"),),
                 "the surroundings (air and fixture) warm or cool at a steady rate during the test, so the "
                 "reading keeps moving after the unit has settled", order=0,
                 ambient_rate=lambda s: s.value("rate_K_per_h") / 3600.0,
                 # hidden in the generated cases: 4 K/h up to the bound, either way
                 draw=lambda rng, p: float(rng.choice([-1, 1]) * rng.uniform(4.0, p.hi)))
def _ambient_drift(times, rise_K, s: EffectSetting, lag_s=None) -> np.ndarray:
    if lag_s is None:
        raise InputError("effect ambient_drift needs the sites' lag field (lag_s)")
    return rise_K + ambient_drift_rise(times, lag_s, s.value("rate_K_per_h") / 3600.0)
