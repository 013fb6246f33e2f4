"""The steady cases of the verification suite: slabs, a composite wall, NAFEMS T4, a radiating end, a
manufactured solution, an orthotropic plate and a natural-convection end.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.optimize import brentq

from imutherm.geometry.grid import TensorGrid
from imutherm.thermal.problem import (NATURAL_CONVECTION_C, SIGMA, ZERO_C_K, Convection, FixedTemperature,
                                      NaturalConvection, Radiation, ThermalProblem, contact_layer_conductivity,
                                      natural_convection_h)
from imutherm.thermal.steady import solve_steady
from imutherm.thermal.verification.record import (NAFEMS_T4_ROUNDING_K, NAFEMS_T4_TARGET_C, RADIATION_1D_PUBLISHED_K,
                                                   VerificationRecord, checked, box_grid, graded)


def case_slab_generation() -> VerificationRecord:
    """1-D slab with uniform generation between two fixed temperatures.

    T(x) = T0 + (T1 − T0) x/L + q x (L − x) / (2k). Linear 1-D elements with the
    consistent load are nodally exact (the Green's function is piecewise
    linear), so on any grid, uniform or not, the nodal error is round-off.
    """
    t0 = time.perf_counter()
    L, k, q, Ta, Tb = 0.05, 15.0, 4e6, 20.0, 60.0
    ratio, tol = 1.1, 1e-8
    g = box_grid(graded(0.0, L, 30, ratio))
    pr = ThermalProblem(g, k, 4e6, q, Ta, {"xmin": FixedTemperature(Ta), "xmax": FixedTemperature(Tb)})
    r = solve_steady(pr)
    x = g.node_coordinates()[:, 0]
    exact = Ta + (Tb - Ta) * x / L + q * x * (L - x) / (2 * k)
    err = np.abs(r.T_C - exact).max()
    return checked("slab_generation", "max nodal |T − T_exact| [K]; computed/exact = peak T [°C]",
                   r.T_C.max(), exact.max(), err, tol,
                   f"Q1 in 1-D with consistent load is nodally exact: only round-off ({tol:g} K on a "
                   f"{exact.max() - exact.min():.0f} K range; observed {err:.1e} K). Non-uniform grid (ratio "
                   f"{ratio:g}). Energy balance {r.energy_balance_rel_error:.1e}.", t0)


def case_composite_wall() -> VerificationRecord:
    """Aluminium | contact layer | FR4 wall with convection on both sides.

    Series resistances per unit area: 1/h1 + L1/k1 + 1/h_c + L2/k2 + 1/h2. The
    contact resistance is a 0.1 mm layer with ``contact_layer_conductivity``.
    Without generation the exact field is piecewise linear: nodally exact.
    """
    t0 = time.perf_counter()
    L1, k1, hc, tc, L2, k2 = 5e-3, 170.0, 2000.0, 1e-4, 1.6e-3, 0.3
    h1, T1, h2, T2 = 50.0, 80.0, 10.0, 20.0
    kc = contact_layer_conductivity(hc, tc)
    xs = np.concatenate([np.linspace(0, L1, 6), L1 + np.linspace(0, tc, 3)[1:],
                         L1 + tc + np.linspace(0, L2, 5)[1:]])
    parts = np.where(xs[:-1] < L1 - 1e-12, 0, np.where(xs[:-1] < L1 + tc - 1e-12, 1, 2))
    g = box_grid(xs, parts=parts.reshape(-1, 1, 1), names=("alu", "contact", "fr4"))
    k_tab = np.array([k1, kc, k2])
    pr = ThermalProblem(g, k_tab[parts], 1e6, 0.0, 20.0,
                        {"xmin": Convection(h1, T1), "xmax": Convection(h2, T2)})
    r = solve_steady(pr)
    R = [1 / h1, L1 / k1, 1 / hc, L2 / k2, 1 / h2]
    qf = (T1 - T2) / sum(R)
    # exact piecewise-linear profile at the nodes
    T_surf = T1 - qf * R[0]
    x = g.node_coordinates()[:, 0]
    bounds = [0.0, L1, L1 + tc, L1 + tc + L2]
    Tb = [T_surf, T_surf - qf * R[1], T_surf - qf * (R[1] + R[2]), T_surf - qf * (R[1] + R[2] + R[3])]
    exact = np.interp(x, bounds, Tb)
    area = 0.01 * 0.01
    q_fem = r.heat_out_W["xmax"] / area
    err = max(np.abs(r.T_C - exact).max() / (T1 - T2), abs(q_fem - qf) / qf)
    return checked("composite_wall", "heat flux [W/m^2]; error = max(nodal |ΔT|/(T1−T2), flux rel. error)",
                   q_fem, qf, err, 1e-9,
                   "Piecewise-linear exact field is in the Q1 space: nodally exact, round-off only (observed "
                   f"{err:.1e}). Contact resistance {1 / hc:g} m^2K/W as a {tc * 1e3:g} mm layer "
                   f"(k = {kc:g} W/mK).", t0)


def case_nafems_t4() -> VerificationRecord:
    """NAFEMS T4: 2-D plate 0.6 x 1.0 m, k = 52; AB (y = 0) 100 °C, DA (x = 0) insulated,
    BC (x = 0.6) and CD (y = 1) convection h = 750 to 0 °C; target 18.25 °C at E (0.6, 0.2).
    Modelled as a one-cell-thick 3-D slab (z faces adiabatic)."""
    t0 = time.perf_counter()
    nx, ny, tol = 60, 100, 0.02
    g = box_grid(np.linspace(0, 0.6, nx + 1), np.linspace(0, 1.0, ny + 1), (0.0, 0.01))
    pr = ThermalProblem(g, 52.0, 1.0, 0.0, 0.0, {"ymin": FixedTemperature(100.0), "xmax": Convection(750.0, 0.0),
                                                 "ymax": Convection(750.0, 0.0)})
    r = solve_steady(pr, probes={"E": (0.6, 0.2, 0.0)})
    T = r.probe_C[0]
    ref = NAFEMS_T4_TARGET_C
    return checked("nafems_t4", "T at E (0.6, 0.2) m [°C]", T, ref, abs(T - ref), tol,
                   f"Reference {ref:.2f} °C (rounding ±{NAFEMS_T4_ROUNDING_K:g} K); {nx}x{ny} Q1 cells "
                   f"give {T:.4f} °C (|T − {ref:.2f}| = {abs(T - ref):.4f} K; O(h^2) despite the corner singularity "
                   f"at B). Tolerance {tol:g} K: the reference's rounding plus this mesh's O(h^2) discretisation "
                   "error.", t0)


def case_radiation_1d() -> VerificationRecord:
    """1-D conduction, k = 55.563, L = 0.1 m, 1000 K at x = 0, ε = 0.98 radiating to 300 K at x = L.

    Exact: k (1000 − T_L)/L = ε σ (T_L^4 − 300^4) (brentq); published 927 K.
    The field is linear, so Q1 is exact and only Newton/round-off errors remain.
    """
    t0 = time.perf_counter()
    k, L, eps, T0, Ts = 55.563, 0.1, 0.98, 1000.0, 300.0
    g = box_grid(np.linspace(0, L, 11))
    pr = ThermalProblem(g, k, 1e6, 0.0, Ts - ZERO_C_K, {"xmin": FixedTemperature(T0 - ZERO_C_K),
                                                          "xmax": Radiation(eps, Ts - ZERO_C_K)})
    newton_tol = 1e-8
    r = solve_steady(pr, probes={"end": (L, 0.005, 0.005)}, tol=newton_tol)
    TL = r.probe_C[0] + ZERO_C_K
    exact = brentq(lambda T: k * (T0 - T) / L - eps * SIGMA * (T ** 4 - Ts ** 4), Ts, T0, xtol=1e-13)
    pub = RADIATION_1D_PUBLISHED_K
    return checked("radiation_1d", "T at the radiating end [K]", TL, exact, abs(TL - exact), 1e-6,
                   f"Linear exact field: Q1 exact, Newton to tol {newton_tol:g} ({r.newton_iterations} iterations): "
                   f"{TL:.6f} K against the root {exact:.6f} K; published {pub:g} K, |T − {pub:g}| = "
                   f"{abs(TL - pub):.2f} K (σ = {SIGMA}).", t0)


def l2_error(g: TensorGrid, T: np.ndarray, exact) -> float:
    """L2 norm of (T_h − exact) over the grid with 2x2x2 Gauss points per cell."""
    gp = np.array([0.5 - 0.5 / math.sqrt(3), 0.5 + 0.5 / math.sqrt(3)])
    nx, ny, nz = g.shape
    Tn = T.reshape(nx + 1, ny + 1, nz + 1)
    hx, hy, hz = g.cell_sizes()
    vol = g.cell_volumes()
    total = 0.0
    for a in gp:
        for b in gp:
            for c in gp:
                uh = sum(((a if i else 1 - a) * (b if j else 1 - b) * (c if kk else 1 - c))
                         * Tn[i:i + nx, j:j + ny, kk:kk + nz]
                         for i in (0, 1) for j in (0, 1) for kk in (0, 1))
                X = (g.xs[:-1] + a * hx)[:, None, None]
                Y = (g.ys[:-1] + b * hy)[None, :, None]
                Z = (g.zs[:-1] + c * hz)[None, None, :]
                total += np.sum((uh - exact(X, Y, Z)) ** 2 * vol / 8.0)
    return math.sqrt(total)


def case_mms_convergence(levels=(4, 8, 16, 32)) -> VerificationRecord:
    """Manufactured solution u = sin(πx) sin(πy) sin(πz) on a smoothly non-uniform grid of the unit cube.

    Anisotropic k = (1, 2, 3): q = (kx + ky + kz) π² u, taken at cell centres
    (piecewise-constant load, which keeps the L2 rate at 2); u = 0 on all faces.
    The observed rate is the least-squares slope of log(L2 error) against log(h).
    """
    t0 = time.perf_counter()
    kv = np.array([1.0, 2.0, 3.0])
    exact = lambda X, Y, Z: np.sin(np.pi * X) * np.sin(np.pi * Y) * np.sin(np.pi * Z)  # noqa: E731
    hs, errs = [], []
    for n in levels:
        s = np.linspace(0, 1, n + 1)
        xs = s + 0.05 * np.sin(2 * np.pi * s)           # smooth non-uniform map, cells ratio up to ~1.9
        ys = s - 0.04 * np.sin(2 * np.pi * s)
        zs = s + 0.03 * np.sin(4 * np.pi * s) / 2
        g = box_grid(xs, ys, zs)
        xc, yc, zc = g.cell_centres()
        q = kv.sum() * np.pi ** 2 * exact(xc[:, None, None], yc[None, :, None], zc[None, None, :])
        pr = ThermalProblem(g, kv, 1.0, q.reshape(-1), 0.0, {f: FixedTemperature(0.0) for f in
                                                              ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")})
        r = solve_steady(pr)
        hs.append(1.0 / n)
        errs.append(l2_error(g, np.asarray(r.T_C), exact))
    rate = float(np.polyfit(np.log(hs), np.log(errs), 1)[0])
    tol = 0.1
    return checked("mms_convergence", "observed L2 convergence rate [-]", rate, 2.0, abs(rate - 2.0), tol,
                   f"Q1 elements converge at O(h^2) in L2; levels {list(levels)}, errors "
                   f"{', '.join(f'{e:.2e}' for e in errs)}, rate {rate:.3f}; like scikit-fem's test_convergence "
                   f"(rate within {tol:g} of the theory).", t0)


def orthotropic_rectangle_centre(a, b, kx, kz, q, terms=200) -> float:
    """Centre temperature rise [K] of an orthotropic rectangle [0, a] x [0, b] with generation q, T = 0 on the edges.

    Scaling z' = z sqrt(kx/kz) gives the isotropic problem −kx ∇²T = q on
    [0, a] x [0, b'] with b' = b sqrt(kx/kz), whose single-series solution is
    T = q x (a − x)/(2 kx) − (4 q a²/(kx π³)) Σ_{n odd} sin(nπx/a)/n³ ·
    cosh(nπ(z' − b'/2)/a)/cosh(nπ b'/(2a)).
    """
    bp = b * math.sqrt(kx / kz)
    x = a / 2
    n = np.arange(1, 2 * terms, 2)
    z = n * math.pi * bp / (2 * a)
    sech = 2 * np.exp(-z) / (1 + np.exp(-2 * z))
    ser = np.sum(np.sin(n * math.pi * x / a) / n ** 3 * sech)
    return q * x * (a - x) / (2 * kx) - 4 * q * a ** 2 / (kx * math.pi ** 3) * ser


def case_orthotropic_plate() -> VerificationRecord:
    """Orthotropic (PCB-like) rectangle in the x–z plane with uniform generation, edges at 0 °C.

    kx = 30 (in plane), kz = 0.5 (through), ky irrelevant (one cell, y faces
    adiabatic) but set to 7 to show it has no effect.
    """
    t0 = time.perf_counter()
    a, b, kx, kz, q = 0.01, 1.6e-3, 30.0, 0.5, 5e6
    nx, nz, tol = 80, 40, 1e-3
    g = box_grid(np.linspace(0, a, nx + 1), (0.0, 1e-3), np.linspace(0, b, nz + 1))
    pr = ThermalProblem(g, (kx, 7.0, kz), 1.0, q, 0.0, {f: FixedTemperature(0.0) for f in
                                                        ("xmin", "xmax", "zmin", "zmax")})
    r = solve_steady(pr, probes={"centre": (a / 2, 5e-4, b / 2)})
    T = r.probe_C[0]
    exact = orthotropic_rectangle_centre(a, b, kx, kz, q)
    iso = orthotropic_rectangle_centre(a, b, kx, kx, q)
    err = abs(T - exact) / exact
    return checked("orthotropic_plate", "centre temperature rise [K]; error relative", T, exact, err, tol,
                   f"Series by anisotropic scaling (b' = b sqrt(kx/kz) = {b * math.sqrt(kx / kz) * 1e3:.2f} mm). "
                   f"{nx}x{nz} Q1 cells; observed {err:.1e} relative (O(h^2)); {tol:g} tolerance. The isotropic "
                   f"k = {kx:g} answer would be {iso:.3g} K, so the test is sensitive to kz.", t0)


def case_natural_convection_1d() -> VerificationRecord:
    """1-D wall (k = 0.5 W/m K, L = 10 mm) at T0 [°C] on x = 0, nonlinear exterior laws on x = L; air 20 °C.

    (a) T0 = 80 °C, NaturalConvection('vertical', 0.05 m); (b) T0 = 80 °C,
    NaturalConvection('up', 0.05 m) + Radiation(ε = 0.85); (c) T0 = 0 °C (cooled
    face looking up, so the 'down' coefficient applies), NaturalConvection('up', 0.05 m).
    Exact end temperature Ts [°C] from k (T0 − Ts)/L = h(Ts − T∞)(Ts − T∞)
    [+ ε σ (Ts^4 − T∞^4), kelvin] by brentq, with h = C (|ΔT|/L_c)^(1/4) from
    :func:`natural_convection_h` (Holman, Heat Transfer, Table 7-2). The field is
    linear, so Q1 is exact and only the Newton tolerance remains.
    """
    t0 = time.perf_counter()
    k, L, Lc, eps, Tair = 0.5, 0.01, 0.05, 0.85, 20.0
    configs = {"a": (80.0, "vertical", None), "b": (80.0, "up", eps), "c": (0.0, "up", None)}
    g = box_grid(np.linspace(0, L, 11))
    area = 0.01 * 0.01
    err, flux_err, iters, Ts_b = 0.0, 0.0, [], (float("nan"), float("nan"))
    newton_tol, tol = 1e-8, 1e-6
    span = max(abs(T0 - Tair) for T0, _, _ in configs.values())
    for name, (T0, orient, e) in configs.items():
        laws = [NaturalConvection(orient, Lc, Tair)] + ([Radiation(e, Tair)] if e is not None else [])
        pr = ThermalProblem(g, k, 1e6, 0.0, Tair, {"xmin": FixedTemperature(T0), "xmax": tuple(laws)})
        r = solve_steady(pr, probes={"end": (L, 0.005, 0.005)}, tol=newton_tol)
        Ts = float(r.probe_C[0])

        def q_out(T, orient=orient, e=e):
            dT = T - Tair
            q = float(natural_convection_h(dT, Lc, orient)) * dT
            if e is not None:
                q += e * SIGMA * ((T + ZERO_C_K) ** 4 - (Tair + ZERO_C_K) ** 4)
            return q

        exact = brentq(lambda T, T0=T0, q_out=q_out: k * (T0 - T) / L - q_out(T), min(T0, Tair), max(T0, Tair),
                       xtol=1e-13)
        err = max(err, abs(Ts - exact))
        flux_err = max(flux_err, abs(r.heat_out_W["xmax"] / area - q_out(exact)) / abs(q_out(exact)))
        iters.append(r.newton_iterations)
        if name == "b":
            Ts_b = (Ts, exact)
    return checked("natural_convection_1d", "end temperature Ts of (b) [°C]; error = max over (a), (b), (c) of "
                   "|Ts − Ts_exact| [K]", Ts_b[0], Ts_b[1], err, tol,
                   "Linear exact field: Q1 exact (uniform face temperature, so the face quadrature of the "
                   f"nonlinear flux is exact too); Newton stops at max|ΔT| <= {newton_tol:g} x {span:g} K = "
                   f"{newton_tol * span:.0e} K and converges quadratically (exact slope (5/4) h), so {tol:g} K "
                   f"({iters} iterations; observed {err:.1e} K). h from "
                   f"natural_convection_h (C = {NATURAL_CONVECTION_C['vertical']:g} vertical, "
                   f"{NATURAL_CONVECTION_C['up']:g} heated-up, {NATURAL_CONVECTION_C['down']:g} cooled-up; "
                   "Holman's table of laminar coefficients); "
                   f"face heat vs exact flux rel. error {flux_err:.1e}.", t0)
