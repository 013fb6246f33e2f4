"""The full model's site rises for one experiment, with the effects of a correlation switched on.

Used twice: to make "measured" data with an effect hidden (:mod:`imutherm.studies.hidden_effect`)
and to re-run the corrected model of a correlation on the full FEM (:mod:`imutherm.studies.correlation`),
so the generator and the check cannot disagree on what an effect means.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from imutherm import InputError
from imutherm.thermal.assembly import assemble
from imutherm.thermal.effects import ModelVariant, apply_signal_effects, effect_problem
from imutherm.thermal.reduced import lag_field, linearised
from imutherm.thermal.linear import amg_preconditioner
from imutherm.thermal.probes import probe_matrix
from imutherm.thermal.steady import solve_steady
from imutherm.thermal.transient import solve_transient


def full_rise(variant: ModelVariant, grid, probes: dict, times, signal=(), rtol: float | None = None,
              ambient_cycle=None) -> np.ndarray:
    """Site rises [K] (len(times), len(probes)) over the ambient after power-on at t = 0.

    variant : the model (:func:`imutherm.thermal.knobs.variant`), grid : its mesh
    probes : dict site -> point [m]; times : [s], ``inf`` for the steady reading
    signal : ``signal`` effect settings (probe lag, ambient drift) applied to the readings
    ambient_cycle : (amplitude [K], period [s], phase [rad]) or None: surroundings cycling as
        ``a cos(2 pi t / period + phase)`` around the ambient, added as the unit's periodic response
        (:func:`periodic_ambient_response`; not a library effect, the generator's out-of-library kind)

    Steady: the nonlinear steady solve; transient: adaptive TR-BDF2 with error control on the probes
    (the library default tolerance) to the last finite time; ``rtol``: the CG tolerance of its stage
    solves (default: the library's).
    """
    t = np.asarray(times, float)
    fin = np.isfinite(t)
    pb = effect_problem(variant, grid)
    amb = pb.ambient_C
    asm = assemble(pb)
    st = solve_steady(pb, probes=probes, assembly=asm)
    m = len(probes)
    out = np.empty((len(t), m))
    out[~fin] = np.asarray(st.probe_C) - amb
    cyc = None
    if ambient_cycle is not None:
        a, period, phase = ambient_cycle
        g = periodic_ambient_response(asm, st.T_C, grid, probes, period)
        out[~fin] = np.nan  # a cycling chamber has no steady reading
        cyc = lambda tt: a * np.real(g[None, :] * np.exp(1j * (2 * np.pi * np.asarray(tt)[:, None] / period + phase)))
    if not fin.any():
        return out
    t_end = float(t[fin].max())
    kw = {} if rtol is None else {"rtol": rtol}
    tr = solve_transient(pb, max(t_end, 1.0), scheme="trbdf2", probes=probes, assembly=asm, error_control="probes",
                         **kw)
    fine = np.union1d(np.asarray(tr.times), t[fin])
    rf = np.column_stack([np.interp(fine, tr.times, tr.probe_C[:, j] - amb) for j in range(m)])
    if signal:
        lag = None
        if any(s.base == "ambient_drift" for s in signal):
            A, _ = linearised(asm, st.T_C)
            lag = probe_matrix(grid, np.array(list(probes.values()))) @ lag_field(A, asm.M)
        rf = apply_signal_effects(fine, rf, list(signal), lag)
    out[fin] = np.column_stack([np.interp(t[fin], fine, rf[:, j]) for j in range(m)])
    if cyc is not None:
        out[fin] += cyc(t[fin])
    return out


def tangent_operator(asm, T_C: np.ndarray):
    """A [W/K]: conduction + linear laws + the tangent dq/dT of every nonlinear law at the field ``T_C`` [°C].

    The small-signal operator of the heat balance about ``T_C`` (the reduced model's
    :func:`~imutherm.thermal.reduced.linearised` takes the secant instead, right for the whole rise).
    """
    if getattr(asm.problem, "exchanges", ()) or asm.dirichlet:
        raise InputError("small-signal operator: surface-to-surface exchange and fixed-temperature faces are "
                         "not supported (use the 'effective' cavity law and contact laws)")
    D = np.zeros(asm.n)
    for bc in asm.nonlinear:
        _, dq = bc.law.flux_out(T_C[bc.nodes], bc.T_ref)
        np.add.at(D, bc.nodes, bc.weights * dq)
    return (asm.K + asm.H + sp.diags(D)).tocsr()


def periodic_ambient_response(asm, T_C: np.ndarray, grid, probes: dict, period_s: float,
                              rtol: float = 1e-8) -> np.ndarray:
    """Complex gain [-] (m,) of each probe to surroundings cycling at ``period_s`` [s]
    (:func:`periodic_ambient_field` at the probes)."""
    x = periodic_ambient_field(asm, T_C, period_s, rtol)
    return probe_matrix(grid, np.array(list(probes.values()))) @ x


def periodic_ambient_field(asm, T_C: np.ndarray, period_s: float, rtol: float = 1e-8) -> np.ndarray:
    """Complex gain [-] (n_nodes,) of every node to surroundings cycling at ``period_s`` [s].

    The surroundings (air, radiative environment and mounting fixture: every law's reference
    temperature) move by Re[a e^{i w t}]; about the field ``T_C`` the unit answers, once the cycling
    has gone on for a while (a chamber cycles before the test starts), with Re[a g e^{i w t}],
    g = (A + i w M)^-1 A 1: A the small-signal operator (:func:`tangent_operator`; A 1 is the
    coupling to the surroundings, conduction conserves heat), M the heat capacity.
    |g| -> 1 as the period grows (the unit follows its surroundings), and falls, with a growing
    phase lag, when the period is short against the unit's time constants. Superposed on the
    nonlinear rise: exact for linear laws, to first order in a for the convection and radiation laws.
    Solved by GMRES on the complex system, preconditioned by an AMG cycle of A + w M (real).
    """
    if not period_s > 0:
        raise InputError(f"ambient cycle period must be > 0 s, got {period_s!r}")
    A = tangent_operator(asm, T_C)
    M = asm.M.tocsr()
    w = 2 * np.pi / period_s
    c = A @ np.ones(A.shape[0])
    pc = amg_preconditioner((A + w * M).tocsr())
    n = A.shape[0]
    pcc = spla.LinearOperator((n, n), matvec=lambda v: pc @ np.real(v) + 1j * (pc @ np.imag(v)), dtype=complex)
    Z = (A + 1j * w * M).tocsr()
    x, info = spla.gmres(Z, c.astype(complex), rtol=rtol, M=pcc, restart=60, maxiter=50)
    if info:
        raise InputError(f"ambient cycle response: GMRES did not converge (info {info})")
    return x


def switched_rise(before: ModelVariant, after: ModelVariant, t_switch: float, grid, probes: dict, times,
                  rtol: float | None = None) -> np.ndarray:
    """Site rises [K] (len(times), len(probes)) of a unit whose model changes at ``t_switch`` [s].

    ``before`` from power-on at t = 0 to ``t_switch``, then ``after`` from the field reached then
    (both variants on the same ``grid``: a power-mode change, say); each leg is the full nonlinear
    adaptive transient of :func:`full_rise`. ``times`` [s]: finite readings in [0, t_end].
    """
    t = np.asarray(times, float)
    if not np.all(np.isfinite(t)):
        raise InputError("switched_rise: a model that changes during the test has no steady reading (time inf)")
    t_end = float(t.max())
    if not 0.0 < t_switch < t_end:
        raise InputError(f"switched_rise: t_switch = {t_switch} s must lie inside the record (0, {t_end:g}) s")
    kw = {} if rtol is None else {"rtol": rtol}
    legs, start = [], None
    for var, t0, t1 in ((before, 0.0, t_switch), (after, t_switch, t_end)):
        pb = effect_problem(var, grid)
        asm = assemble(pb)
        tr = solve_transient(pb, t1 - t0, scheme="trbdf2", probes=probes, assembly=asm, error_control="probes",
                             save_times=[t1 - t0], initial_C=start, **kw)
        start = np.asarray(tr.saved_C[-1])
        amb = pb.ambient_C
        legs.append((np.asarray(tr.times) + t0, np.asarray(tr.probe_C) - amb))
    tt = np.concatenate([legs[0][0], legs[1][0][1:]])
    rr = np.vstack([legs[0][1], legs[1][1][1:]])
    return np.column_stack([np.interp(t, tt, rr[:, j]) for j in range(rr.shape[1])])
