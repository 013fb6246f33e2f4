"""Profile-likelihood intervals of one re-tuned parameter, at a residual floor that is the model's stated form error.

A Jacobian interval of a fit in which other knobs (or a discrepancy term) can take over what the knob does
spreads to the knob's whole source range (blind campaign of issue 58: a cavity emissivity re-tuned to 0.228 for
0.25 hidden, "95 %: 0.02-0.9"; a mount re-tuned to 196 for 216 W/m² K, "150-3000"), and the finding rule (the
nominal outside the interval) cannot fire. The profile instead holds the knob at each value, re-fits every other
knob and named effect (no discrepancy term), and keeps the values whose objective lies within the χ²(1) 95 %
point of the best (Venzon & Moolgavkar 1988; Pawitan 2001, *In All Likelihood*, ch. 3):

    { x : (n_eff / n) (J(x) - J_min) / σ² <= 3.841 },

J the fit's objective [K²] (residual sum of squares and the knobs' weak prior), σ² the residual variance,
**not below the model's stated form error**: σ² = max(J_min / (n - k), noise² + band²) (band: the known form
error at the readings, :func:`imutherm.studies.correlation.form_error.band_K`), so a model whose form is off by more
than the noise does not claim the noise's precision. For a linear model with Gaussian noise of known σ the profile
interval is the analytic one, x̂ ± 1.96 σ sqrt((XᵀX)⁻¹ⱼⱼ) (tests/test_correlation_explain.py).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.optimize import brentq

#: χ²(1) 95 % point: the profile's threshold for a 95 % interval of one parameter
CHI2_95 = 3.841458820694124


def residual_floor_K2(cost_K2: float, n: int, k: int, noise_K: float, band_K: float) -> float:
    """σ² [K²] of the profile: the fit's residual variance J / (n - k), not below noise² + band² (the model's
    stated form error at the readings, ``band_K``; NaN counts as 0)."""
    band = band_K if math.isfinite(band_K) else 0.0
    return max(cost_K2 / max(n - k, 1), noise_K**2 + band**2)


def profile_interval(cost, x_hat: float, lo: float, hi: float, sigma2_K2: float, ratio: float = 1.0,
                     log: bool = False, level: float = CHI2_95, rel_tol: float = 1e-4) -> dict:
    """The profile interval of one parameter within [lo, hi].

    cost : callable x -> the objective [K²] with the parameter held at x, every other parameter re-fitted
    x_hat : the fitted value; sigma2_K2 : residual variance [K²] (:func:`residual_floor_K2`); ratio : n_eff / n
    log : search in log(x) (a log-scaled knob); level : the threshold of Δ = ratio ΔJ / σ² (default χ²(1) 95 %)

    Returns {'ci95': (lo, hi), 'open': (bool, bool)} (an end at the range's bound that the data do not close: the
    profile stays within the threshold there), 'delta': callable x -> Δ (cached), 'cost_min' [K²]."""
    if not (lo <= x_hat <= hi) or not (sigma2_K2 > 0 and math.isfinite(sigma2_K2)):
        raise ValueError(f"profile_interval: x_hat {x_hat} outside [{lo}, {hi}] or sigma² {sigma2_K2} not positive")
    to_z = (lambda x: math.log(x)) if log else (lambda x: x)
    to_x = (lambda z: math.exp(z)) if log else (lambda z: z)
    cache = {}

    def J(x):
        if x not in cache:
            cache[x] = float(cost(x))
        return cache[x]

    c_min = J(x_hat)

    def delta(x):
        return ratio * (J(x) - c_min) / sigma2_K2

    def end(bound):
        z0, zb = to_z(x_hat), to_z(bound)
        if zb == z0:
            return bound, True
        inside, step = z0, (zb - z0) / 64.0
        while True:
            z = z0 + step if abs(step) < abs(zb - z0) else zb
            if delta(to_x(z)) > level:
                break
            if z == zb:
                return bound, True
            inside, step = z, 2.0 * step
        z_out = z
        zc = brentq(lambda q: delta(to_x(q)) - level, inside, z_out, xtol=rel_tol * abs(z_out - z0), maxiter=50)
        return to_x(zc), False

    (a, open_a), (b, open_b) = end(lo), end(hi)
    return {"ci95": (float(a), float(b)), "open": (open_a, open_b), "delta": delta, "cost_min": c_min}

