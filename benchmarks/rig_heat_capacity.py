"""A test rig's heat capacity under the unit (a fixture plate): what it does to the power-on curve (an estimate).

The unit model bolts the base to a fixture *held at* ``mounting.temperature_C``. A real test fixture (an
adapter plate on an oven shelf, a bench plate) has a heat capacity C_f [J/K] and loses heat to the chamber
through a conductance G_f [W/K] (convection and radiation from its free faces), so it warms up under the
unit's power. With the fixture's rise theta(t) slow against the unit's own response, the linear two-port

    Q_m(t) = Q_m0 u(t) - G_b theta(t)       heat into the fixture [W]
    r_i(t) = r_i,fixed(t) + S_i theta(t)    rise of site i [K]
    C_f dtheta/dt = Q_m(t) - G_f theta

holds, where r_i,fixed(t) and u(t) (the mount heat flow over its steady value Q_m0) come from the unit's
transient with the fixture held, and G_b [W/K] (the drop in Q_m per kelvin of fixture rise) and S_i [-]
(the site's rise per kelvin of fixture rise) from two steady solves. It is a quasi-static estimate (the
unit's response to the fixture's temperature is taken as instantaneous, the laws as linear about the
operating point), not a model of the fixture in the FEM: ``benchmarks/bench_fixture_capacity.py``
computes its inputs and states the result.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from imutherm import InputError


@dataclass(frozen=True)
class FixtureResponse:
    """The fixture's rise and the sites' curves with it.

    times : (n,) [s]; theta_K : (n,) fixture rise over the chamber [K]; rise_K : dict site -> (n,) [K]
    theta_steady_K : float [K]; rise_steady_K : dict site -> float [K]; tau_s : float [s] the fixture's
    own time constant C_f / (G_b + G_f)
    """

    times: np.ndarray
    theta_K: np.ndarray
    rise_K: dict
    theta_steady_K: float
    rise_steady_K: dict
    tau_s: float


def fixture_theta(times, u, Q_m0: float, G_b: float, C_f: float, G_f: float) -> np.ndarray:
    """Fixture rise theta(t) [K] of C_f dtheta/dt = Q_m0 u(t) - (G_b + G_f) theta, theta(0) = 0, with u
    piecewise linear between ``times`` [s] (exact exponential integration on each interval).

    Q_m0 [W], G_b, G_f [W/K], C_f [J/K] > 0.
    """
    t = np.asarray(times, float)
    u = np.asarray(u, float)
    if t.ndim != 1 or t.shape != u.shape or t.size < 2 or np.any(np.diff(t) <= 0) or t[0] != 0.0:
        raise InputError("fixture_theta: times must start at 0 and increase, u the same length")
    for name, v in (("C_f", C_f), ("G_b + G_f", G_b + G_f)):
        if not (np.isfinite(v) and v > 0):
            raise InputError(f"fixture_theta: {name} must be a finite number > 0, got {v!r}")
    a = (G_b + G_f) / C_f                  # [1/s]
    b = Q_m0 / C_f                         # [K/s] per unit of u
    theta = np.zeros_like(t)
    for k in range(t.size - 1):
        h = t[k + 1] - t[k]
        e = np.exp(-a * h)
        s = (u[k + 1] - u[k]) / h          # slope of u on the interval
        # theta' = b (u_k + s tau) - a theta on [0, h]: exact solution at tau = h
        theta[k + 1] = theta[k] * e + b * (u[k] * (1 - e) / a + s * (h / a - (1 - e) / a**2))
    return theta


def fixture_response(times, rise_fixed: dict, u, Q_m0: float, G_b: float, S: dict, C_f: float,
                     G_f: float) -> FixtureResponse:
    """Sites' curves with a fixture of capacity C_f [J/K] and loss G_f [W/K] (see the module docstring).

    rise_fixed : site -> (n,) rise [K] with the fixture held; u : (n,) mount heat flow / its steady value;
    Q_m0 [W] that steady value; G_b [W/K]; S : site -> rise per kelvin of fixture rise [-]. The curves'
    last value is taken as the fixed-mount steady rise.
    """
    theta = fixture_theta(times, u, Q_m0, G_b, C_f, G_f)
    th_inf = Q_m0 / (G_b + G_f)
    rise = {s: np.asarray(r, float) + S[s] * theta for s, r in rise_fixed.items()}
    steady = {s: float(np.asarray(r, float)[-1] + S[s] * th_inf) for s, r in rise_fixed.items()}
    return FixtureResponse(np.asarray(times, float), theta, rise, float(th_inf), steady, C_f / (G_b + G_f))


def t95(times, rise, final: float) -> float:
    """First time [s] the curve ``rise`` [K] reaches 95 % of ``final`` [K] (linear interpolation); NaN if never."""
    t, r = np.asarray(times, float), np.asarray(rise, float)
    target = 0.95 * final
    idx = np.nonzero(r >= target)[0]
    if not idx.size:
        return float("nan")
    k = idx[0]
    if k == 0:
        return float(t[0])
    return float(t[k - 1] + (target - r[k - 1]) * (t[k] - t[k - 1]) / (r[k] - r[k - 1]))
