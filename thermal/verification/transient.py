"""The transient cases of the verification suite: a convective plane wall and a semi-infinite solid (series and
erfc), a lumped block with the three time schemes (order checks, the adaptive control) and NAFEMS T3.
"""

from __future__ import annotations

import math
import time
from dataclasses import replace

import numpy as np
from scipy.optimize import brentq
from scipy.special import erfc, erfcx

from imutherm.thermal.metrics import T63_FRACTION, settle_time
from imutherm.thermal.problem import Convection, FixedTemperature, ThermalProblem
from imutherm.thermal.transient import solve_transient
from imutherm.thermal.verification.record import NAFEMS_T3_TARGET_C, VerificationRecord, checked, box_grid, graded


def slab_convection_series(x_over_L, Fo, Bi, terms: int = 80) -> np.ndarray:
    """θ = (T − T∞)/(Ti − T∞) of a plane wall (half-thickness L, convection Bi) [-].

    θ = Σ C_n exp(−ζ_n² Fo) cos(ζ_n x/L), C_n = 4 sin ζ_n / (2 ζ_n + sin 2ζ_n),
    ζ_n tan ζ_n = Bi (roots by brentq in ((n−1)π, (n−1)π + π/2)).
    """
    f = lambda z: z * math.tan(z) - Bi  # noqa: E731
    zeta = np.array([brentq(f, (n - 1) * math.pi + 1e-12, (n - 1) * math.pi + math.pi / 2 - 1e-12, xtol=1e-15)
                     for n in range(1, terms + 1)])
    C = 4 * np.sin(zeta) / (2 * zeta + np.sin(2 * zeta))
    xl = np.asarray(x_over_L, dtype=float)
    return np.sum(C[:, None] * np.exp(-zeta[:, None] ** 2 * Fo) * np.cos(zeta[:, None] * xl.reshape(1, -1)),
                  axis=0).reshape(xl.shape)


def case_transient_slab() -> VerificationRecord:
    """Plane wall (half-thickness L, adiabatic mid-plane) suddenly exposed to convection."""
    t0 = time.perf_counter()
    L, k, rc, h, Ti, Tinf = 0.02, 15.0, 4e6, 500.0, 20.0, 100.0
    Bi, alpha = h * L / k, k / rc
    g = box_grid(np.linspace(0, L, 41))
    pr = ThermalProblem(g, k, rc, 0.0, Ti, {"xmax": Convection(h, Tinf)})
    tau = L ** 2 / alpha
    Fos = np.array([0.05, 0.2, 1.0])
    dFo, terms, tol = 1e-3, 80, 5e-4
    r = solve_transient(pr, Fos[-1] * tau, dFo * tau, theta=0.5, save_times=Fos * tau)
    x = g.node_coordinates()[:, 0]
    err = 0.0
    for Fo, T in zip(Fos, r.saved_C):
        exact = Tinf + (Ti - Tinf) * slab_convection_series(x / L, Fo, Bi, terms)
        err = max(err, np.abs(T - exact).max() / (Tinf - Ti))
    surf = Tinf + (Ti - Tinf) * slab_convection_series(1.0, Fos[-1], Bi, terms)
    return checked("transient_slab", "max nodal |ΔT|/(T∞ − Ti) at Fo = 0.05, 0.2, 1 [-]; computed/exact = "
                   "surface T at Fo = 1 [°C]", r.saved_C[-1][np.argmax(x)], surf, err, tol,
                   f"Bi = {Bi:.3f}, {terms}-term series. {g.shape[0]} cells, Crank–Nicolson with Fo-step {dFo:g}: "
                   f"observed {err:.1e} (O(h^2 + dt^2)); {tol:g} tolerance. Energy balance "
                   f"{r.energy_balance_rel_error:.1e}.", t0)


def semi_infinite_convection(x, t, k, alpha, h):
    """(T − Ti)/(T∞ − Ti) in a semi-infinite solid with surface convection [-].

    erfc(η) − exp(h x/k + h² α t/k²) erfc(η + h √(α t)/k), η = x / (2 √(α t));
    evaluated with erfcx for stability.
    """
    x = np.asarray(x, dtype=float)
    s = math.sqrt(alpha * t)
    eta = x / (2 * s)
    b = h * s / k
    # exp(hx/k + b^2) erfc(eta + b) = exp(hx/k + b^2 - (eta+b)^2) erfcx(eta + b) = exp(-eta^2) erfcx(eta+b)
    return erfc(eta) - np.exp(-eta ** 2) * erfcx(eta + b)


def case_semi_infinite() -> VerificationRecord:
    """Semi-infinite solid with surface convection at short times (erfc solution)."""
    t0 = time.perf_counter()
    k, rc, h, Ti, Tinf = 1.4, 2e6, 200.0, 20.0, 120.0
    alpha = k / rc
    depth = 0.04                       # >> 2 sqrt(alpha t_end) = 0.013 m: effectively infinite
    n_cells, ratio, dt, tol = 80, 1.04, 0.05, 5e-4
    g = box_grid(graded(0.0, depth, n_cells, ratio))   # fine cells (0.07 mm) at the surface x = 0
    pr = ThermalProblem(g, k, rc, 0.0, Ti, {"xmin": Convection(h, Tinf)})
    times = np.array([5.0, 20.0, 60.0])
    r = solve_transient(pr, times[-1], dt, theta=0.5, save_times=times)
    x = g.node_coordinates()[:, 0]
    err = 0.0
    for t, T in zip(times, r.saved_C):
        exact = Ti + (Tinf - Ti) * semi_infinite_convection(x, t, k, alpha, h)
        err = max(err, np.abs(T - exact).max() / (Tinf - Ti))
    surf = Ti + (Tinf - Ti) * semi_infinite_convection(0.0, times[-1], k, alpha, h)
    far = float(semi_infinite_convection(depth, times[-1], k, alpha, h))
    return checked("semi_infinite", "max nodal |ΔT|/(T∞ − Ti) at t = 5, 20, 60 s [-]; computed/exact = surface "
                   "T at 60 s [°C]", r.saved_C[-1][np.argmin(x)], float(surf), err, tol,
                   f"Depth {depth:g} m = {depth / math.sqrt(alpha * times[-1]):.1f} sqrt(α t_end) (the "
                   f"semi-infinite solution there, the order of the adiabatic end's effect: {far:.1e} of the "
                   f"driving difference); {n_cells} graded cells from {(g.xs[1] - g.xs[0]) * 1e3:.2f} mm (ratio "
                   f"{ratio:g}); CN dt = {dt:g} s. Observed {err:.1e} (spatial error dominates, O(h^2)); "
                   f"{tol:g} = {100 * tol:g} % of the driving difference.", t0)


def lumped_block():
    """The lumped-capacitance block: 20 x 20 x 10 mm, k = 1e4 W/m K, ρc = 2.4e6 J/m^3 K, P = 1 W,
    h = 10 W/m^2 K on all faces to T∞ = 25 °C (Bi = 1e-5).

    Returns (problem, τ [s], ΔT∞ = P/(hA) [K], T∞ [°C], centre (x, y, z) [m], Bi [-]).
    """
    a, b, c = 0.02, 0.02, 0.01
    k, rc, h, P, Tinf = 1e4, 2.4e6, 10.0, 1.0, 25.0
    g = box_grid(np.linspace(0, a, 5), np.linspace(0, b, 5), np.linspace(0, c, 3))
    V, A = a * b * c, 2 * (a * b + a * c + b * c)
    faces = {f: Convection(h) for f in ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")}
    pr = ThermalProblem(g, k, rc, P / V, Tinf, faces)
    return pr, rc * V / (h * A), P / (h * A), Tinf, (a / 2, b / 2, c / 2), h * c / k


def case_lumped_capacitance() -> VerificationRecord:
    """High-conductivity block with internal power and convection on all faces (Bi ~ 1e-5).

    T − T∞ = P/(hA) (1 − exp(−t/τ)) [K], τ = ρcV/(hA) [s]. Also checks ``settle_time``:
    t63 of the rise reached at t_end = 5τ.
    """
    t0 = time.perf_counter()
    pr, tau, rise_inf, Tinf, centre, Bi = lumped_block()
    m = 200
    r = solve_transient(pr, 5 * tau, tau / m, theta=0.5, probes={"centre": centre})
    exact = rise_inf * (1 - np.exp(-r.times / tau))
    err_T = np.abs(r.probe_C[:, 0] - Tinf - exact).max() / rise_inf
    t63 = settle_time(r.times, r.probe_C[:, 0], T63_FRACTION)
    t63_exact = -tau * math.log(1 - T63_FRACTION * (1 - math.exp(-5)))
    err = max(err_T, abs(t63 - t63_exact) / t63_exact)
    return checked("lumped_capacitance", "max |ΔT|/ΔT∞ over time and t63 rel. error [-]; computed/exact = t63 [s]",
                   t63, t63_exact, err, 1e-3,
                   f"Bi = hL/k = {Bi:.0e} (lumped model exact to O(Bi)); CN with dt = τ/{m}: O((dt/τ)^2) "
                   f"error, observed {err_T:.1e} in ΔT and {abs(t63 - t63_exact) / t63_exact:.1e} in t63 (interpolated "
                   "in the log of the remaining gap, exact for this curve). "
                   f"Energy balance {r.energy_balance_rel_error:.1e}.", t0)


def nafems_t3_series(x, t, L=0.1, k=35.0, rho=7200.0, c=440.5, terms=4000) -> float:
    """Exact NAFEMS T3 temperature [°C]: T(0) = 0, T(L) = 100 sin(π t/40), T(x, 0) = 0.

    With s = L − x the distance from the driven end, T = f(t)(1 − s/L) + Σ a_n(t) sin(nπ s/L),
    a_n = −b_n f0 ω [λ cos ωt + ω sin ωt − λ e^{−λ t}]/(λ² + ω²), b_n = 2/(nπ), λ = α (nπ/L)².
    """
    alpha, w = k / (rho * c), math.pi / 40
    s = L - x
    n = np.arange(1, terms + 1)
    lam = alpha * (n * math.pi / L) ** 2
    bn = 2 / (n * math.pi)
    an = -bn * 100 * w * (lam * math.cos(w * t) + w * math.sin(w * t) - lam * np.exp(-lam * t)) / (lam ** 2 + w ** 2)
    return float(100 * math.sin(w * t) * (1 - s / L) + np.sum(an * np.sin(n * math.pi * s / L)))


def case_nafems_t3() -> VerificationRecord:
    """NAFEMS T3: 1-D transient, bar 0.1 m, k 35, ρ 7200, c 440.5.

    Definition (NAFEMS 'Standard Benchmarks' 1990; code_aster V4.21.301, Altair
    OS-V 0110): point A (x = 0) held at 0 °C, point B (x = 0.1 m) at
    100 sin(π t/40) °C, T = 0 initially; target 36.60 °C at x = 0.08 m
    (0.02 m from the driven end), t = 32 s. (With the ends swapped the exact
    answer at x = 0.08 m would be 0.09 °C.)
    """
    t0 = time.perf_counter()
    L = 0.1
    n_cells, dt, tol, T_A = 100, 0.05, 0.02, 0.0
    g = box_grid(np.linspace(0, L, n_cells + 1))
    pr = ThermalProblem(g, 35.0, 7200 * 440.5, 0.0, 0.0,
                        {"xmin": FixedTemperature(T_A),
                         "xmax": FixedTemperature(lambda t: 100 * math.sin(math.pi * t / 40))})
    r = solve_transient(pr, 32.0, dt, theta=0.5, probes={"C": (0.08, 0.005, 0.005)})
    T = r.probe_C[-1, 0]
    exact = nafems_t3_series(0.08, 32.0)
    err = abs(T - exact)
    ref = NAFEMS_T3_TARGET_C
    return checked("nafems_t3", "T at x = 0.08 m, t = 32 s [°C]", T, exact, err, tol,
                   f"Exact series {exact:.3f} °C (NAFEMS target {ref:.2f}). {n_cells} Q1 cells, CN dt = {dt:g} s: "
                   f"error {err:.4f} K (O(h^2 + dt^2)); {tol:g} K tolerance. "
                   f"|T − {ref:.2f}| = {abs(T - ref):.3f} K. End A fixed at {T_A:g} °C, "
                   f"end B (x = {L:g} m) driven.", t0)


def case_lumped_backward_euler(divisions=(20, 40, 80)) -> VerificationRecord:
    """Lumped-capacitance block of case 5 with backward Euler (θ = 1, the production default): order 1 in time.

    Rise ΔT(t) = P/(hA) (1 − exp(−t/τ)) [K], τ = ρcV/(hA) = 600 s. Run to 3τ
    with dt = τ/20, τ/40, τ/80 [s]; error e(dt) = max over the steps of
    |ΔT − ΔT_exact|/ΔT∞ [-]. Backward Euler gives 1 − y_n = (1 + dt/τ)^(−n),
    whose leading error is (dt/2τ)(t/τ) exp(−t/τ), largest dt/(2eτ) at t = τ.
    The observed order p = log2(e(dt)/e(dt/2)) of both pairs must lie in [0.9, 1.1].
    """
    t0 = time.perf_counter()
    pr, tau, rise_inf, Tinf, centre, Bi = lumped_block()
    errs = []
    theta, tol = 1.0, 3e-3
    for m in divisions:
        r = solve_transient(pr, 3 * tau, tau / m, theta=theta, probes={"centre": centre})
        exact = rise_inf * (1 - np.exp(-r.times / tau))
        errs.append(float(np.abs(r.probe_C[:, 0] - Tinf - exact).max() / rise_inf))
    orders = [math.log(errs[i] / errs[i + 1]) / math.log(divisions[i + 1] / divisions[i])
              for i in range(len(errs) - 1)]
    lo, hi = 0.9, 1.1
    order_ok = all(lo <= p <= hi for p in orders)
    estimate = 1 / (2 * math.e * divisions[-1])
    rec = checked("lumped_backward_euler", "max |ΔT|/ΔT∞ over 0..3τ at the finest dt [-]; computed/exact = "
                  "observed temporal order of backward Euler (finest pair) [-]", orders[-1], 1.0, errs[-1], tol,
                  f"θ = {theta:g}, dt = τ/{', τ/'.join(str(m) for m in divisions)}: errors "
                  f"{', '.join(f'{e:.3e}' for e in errs)}, observed orders {', '.join(f'{p:.3f}' for p in orders)} "
                  f"(each must lie in [{lo}, {hi}]{'' if order_ok else ': ORDER CHECK FAILED'}). Tolerance from "
                  f"the first-order estimate max_t (dt/2τ)(t/τ)e^(−t/τ) = dt/(2eτ) = {estimate:.2e} at dt = "
                  f"τ/{divisions[-1]}: {tol:g} leaves {100 * (1 - estimate / tol):.0f} % for the O(dt^2) term and "
                  f"the O(Bi = {Bi:.0e}) spatial error; an O(1) defect or another θ (Crank–Nicolson is second "
                  "order) fails.", t0)
    return replace(rec, passed=rec.passed and order_ok)


def semi_discrete_exact(problem, points):
    """Exact solution of the semi-discrete (space-discretised, time-exact) linear system M T' = F − L T.

    For a small linear problem: generalised eigenpairs of (L, M) [dense]. Returns
    ``f(times [s]) -> (n_times, n_points)`` [°C] from the uniform ``ambient_C`` start;
    the reference for temporal orders, free of the spatial error.
    """
    import scipy.linalg as sla

    from imutherm.thermal.assembly import assemble
    from imutherm.thermal.probes import probe_matrix

    asm = assemble(problem)
    L = asm.pattern.csr(asm.K_data + asm.H_data).toarray()
    M = asm.pattern.csr(asm.M_data).toarray()
    F = asm.F_q + asm.F_bc
    T_ss = np.linalg.solve(L, F)
    lam, V = sla.eigh(L, M)
    a = V.T @ M @ (np.full(len(F), problem.ambient_C) - T_ss)
    P = probe_matrix(problem.grid, points)
    PV, PT = P @ V, P @ T_ss

    def at(times):
        t = np.atleast_1d(np.asarray(times, dtype=float))
        return PT[None, :] + (np.exp(-np.outer(t, lam)) * a[None, :]) @ PV.T

    return at


def case_lumped_trbdf2(divisions=(10, 20, 40)) -> VerificationRecord:
    """Lumped-capacitance block of case 5 with TR-BDF2 (γ = 2 − √2) and fixed steps: order 2 in time.

    dt = τ/10, τ/20, τ/40 to 3τ (τ = 600 s). Observed order p = log2(e(dt)/e(dt/2))
    with e the max probe error over the steps against the exact solution of the
    semi-discrete system (eigenpairs of (L, M): no spatial error, so the rate is the
    scheme's alone); both pairs must lie in [1.9, 2.1]. The error against the
    closed form P/(hA)(1 − exp(−t/τ)) at the finest step is the compared error.
    """
    t0 = time.perf_counter()
    pr, tau, rise_inf, Tinf, centre, Bi = lumped_block()
    exact_sd = semi_discrete_exact(pr, [centre])
    errs, errs_a = [], []
    ebal = 0.0
    for m in divisions:
        r = solve_transient(pr, 3 * tau, tau / m, scheme="trbdf2", probes={"centre": centre})
        errs.append(float(np.abs(r.probe_C[:, 0] - exact_sd(r.times)[:, 0]).max() / rise_inf))
        exact = rise_inf * (1 - np.exp(-r.times / tau))
        errs_a.append(float(np.abs(r.probe_C[:, 0] - Tinf - exact).max() / rise_inf))
        ebal = max(ebal, r.energy_balance_rel_error)
    orders = [math.log(errs[i] / errs[i + 1]) / math.log(divisions[i + 1] / divisions[i])
              for i in range(len(errs) - 1)]
    lo, hi = 1.9, 2.1
    order_ok = all(lo <= p <= hi for p in orders)
    tol, m = 3e-5, divisions[-1]
    c2 = errs[-1] * m ** 2           # the observed second-order constant: e ≈ c2 (dt/τ)^2
    rec = checked("lumped_trbdf2", "max |ΔT|/ΔT∞ over 0..3τ against the closed form at the finest dt [-]; "
                  "computed/exact = observed temporal order of TR-BDF2 (finest pair) [-]", orders[-1], 2.0,
                  errs_a[-1], tol,
                  f"TR-BDF2, dt = τ/{', τ/'.join(str(m) for m in divisions)}: errors against the semi-discrete "
                  f"exact solution {', '.join(f'{e:.3e}' for e in errs)}, observed orders "
                  f"{', '.join(f'{p:.3f}' for p in orders)} (each must lie in [{lo}, {hi}]"
                  f"{'' if order_ok else ': ORDER CHECK FAILED'}); against the closed form "
                  f"{', '.join(f'{e:.3e}' for e in errs_a)}. Tolerance {tol:g} at τ/{m}: the observed "
                  f"second-order error {c2:.3f} (dt/τ)^2 = {c2 / m ** 2:.1e} plus the O(Bi = {Bi:.0e}) "
                  f"lumped-model error, with a {tol / (c2 / m ** 2 + Bi):.1f}x margin. "
                  f"Energy balance {ebal:.1e}.", t0)
    return replace(rec, passed=rec.passed and order_ok)


def case_lumped_trbdf2_adaptive(tol_fraction: float = 1e-3) -> VerificationRecord:
    """Lumped block of case 5, adaptive TR-BDF2 with tol_K = 1e-3 ΔT∞ to 6τ: the error control meets its target.

    Compared: the max over the steps of |ΔT − ΔT_exact|/tol_K (tolerance 2: the
    controlled local errors, ≤ tol_K each, accumulate damped over the ~5 steps of a
    time constant; the record states the measured value), and t63, t95 (log-gap interpolation, final rise
    ΔT∞) against −τ ln(1 − f), each within 1 %. 1e-3 of the
    rise is the ratio of the default 0.01 K to the reference unit's ~10 K site rises.
    """
    t0 = time.perf_counter()
    pr, tau, rise_inf, Tinf, centre, Bi = lumped_block()
    tol = tol_fraction * rise_inf
    r = solve_transient(pr, 6 * tau, None, scheme="trbdf2", tol_K=tol, probes={"centre": centre})
    exact = rise_inf * (1 - np.exp(-r.times / tau))
    err = float(np.abs(r.probe_C[:, 0] - Tinf - exact).max()) / tol
    t63 = settle_time(r.times, r.probe_C[:, 0], T63_FRACTION, rise_inf)
    t95 = settle_time(r.times, r.probe_C[:, 0], 0.95, rise_inf)
    e63, e95 = t63 / tau - 1, t95 / (tau * math.log(20)) - 1
    settle_tol, tol_ratio = 0.01, 2.0
    settle_ok = abs(e63) <= settle_tol and abs(e95) <= settle_tol
    rec = checked("lumped_trbdf2_adaptive", "max |ΔT − ΔT_exact| / tol_K over 0..6τ [-]; computed/exact = t95 [s]",
                  t95, tau * math.log(20), err, tol_ratio,
                  f"tol_K = {tol:.4g} K ({tol_fraction:g} ΔT∞), {r.steps} steps ({r.rejected_steps} rejected), "
                  f"largest {np.diff(r.times).max():.0f} s = {np.diff(r.times).max() / tau:.2f} τ; t63 error "
                  f"{100 * e63:+.2f} %, t95 error {100 * e95:+.2f} % (each must be within {100 * settle_tol:g} %"
                  f"{'' if settle_ok else ': SETTLE CHECK FAILED'}). Error-per-step control: the global error "
                  f"is the damped sum of the local ones (here {err:.2f} tol_K), hence up to {tol_ratio:g} tol_K. "
                  "Energy balance "
                  f"{r.energy_balance_rel_error:.1e}.", t0)
    return replace(rec, passed=rec.passed and settle_ok)
