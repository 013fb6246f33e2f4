"""The full model's site rises for one experiment, with the effects of a correlation switched on.

Used twice: to make "measured" data with an effect hidden (:mod:`imutherm.studies.correlation.hidden_effect`)
and to re-run the corrected model of a correlation on the full FEM (:mod:`imutherm.studies.correlation`),
so the generator and the check cannot disagree on what an effect means.
"""

from __future__ import annotations

import numpy as np

from imutherm import InputError
from imutherm.thermal.assembly import assemble
from imutherm.unit.effects import ModelVariant, apply_signal_effects, effect_problem, moves_ambient
from imutherm.thermal.probes import probe_matrix
from imutherm.thermal.reduced import lag_field, linearised
from imutherm.thermal.small_signal import periodic_ambient_response
from imutherm.thermal.steady import solve_steady
from imutherm.thermal.transient import solve_transient


def full_rise(variant: ModelVariant, grid, probes: dict, times, signal=(), rtol: float | None = None,
              ambient_cycle=None) -> np.ndarray:
    """Site rises [K] (len(times), len(probes)) over the ambient after power-on at t = 0.

    variant : the model (:func:`imutherm.unit.knobs.variant`), grid : its mesh
    probes : dict site -> point [m]; times : [s], ``inf`` for the steady reading
    signal : ``signal`` effect settings (probe lag, ambient drift) applied to the readings
    ambient_cycle : (amplitude [K], period [s], phase [rad]) or None: surroundings cycling as
        ``a cos(2 pi t / period + phase)`` around the ambient, added as the unit's periodic response
        (:func:`imutherm.thermal.small_signal.periodic_ambient_response`; not a library effect, the generator's out-of-library kind)

    Steady: the nonlinear steady solve; transient: adaptive TR-BDF2 with error control on the probes
    (the library default tolerance) to the last finite time; ``rtol``: the CG tolerance of its stage
    solves (default: the library's).
    """
    return _rise(variant, grid, probes, times, signal, rtol, ambient_cycle, reduced=False)[0]


def checked_rise(variant: ModelVariant, grid, probes: dict, times, signal=(), rtol: float | None = None,
                 full: bool = False) -> tuple:
    """(site rises [K] (len(times), len(probes)), how the transient was computed: dict) as :func:`full_rise`,
    the transient on the checked reduced model of the study
    (:func:`imutherm.thermal.reduced_transient.reduced_power_on`: the full steady field, a Krylov basis about
    it, the full model's residual at a few times as the error estimate, every site within
    :data:`~imutherm.thermal.reduced_transient.CHECK_TOL_K`), the full adaptive TR-BDF2 where the check fails or
    the model is one the reduced transient does not cover.

    On the reference unit's corrected models (air, grease, potted with a poor board joint, 1500 s, default
    mesh) its curves are within 0.010 K of a full TR-BDF2 run at 1e-3 K per step, where the full run at the
    library's 1e-2 K is up to 0.055 K off, in 33-41 % of its time (``benchmarks/bench_rerun_transient.py``;
    figures in docs/benchmarks/correlation_speed.md).

    ``rtol``: the CG tolerance of the full transient's stage solves where it runs; ``full``: run the full
    adaptive TR-BDF2 without trying the reduced model (``imutherm correlate --full``).
    The dict: ``transient`` 'reduced' or 'full' (None: steady readings only), ``estimated_error_K`` (the
    check's largest site estimate, None without one), ``basis``, ``full_solves``, ``reason`` (why the full
    FEM ran; '' if it did not).
    """
    return _rise(variant, grid, probes, times, signal, rtol, None, reduced=not full)


def _rise(variant, grid, probes, times, signal, rtol, ambient_cycle, reduced: bool) -> tuple:
    """(rises [K], transient info dict) of :func:`full_rise` (``reduced`` False) or :func:`checked_rise`."""
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
        return out, _info(None, "steady readings only")
    t_end = float(t[fin].max())
    kw = {} if rtol is None else {"rtol": rtol}
    tr, info = None, _info("full", "asked for")
    if reduced:
        tr, info = _reduced(pb, asm, st, probes, max(t_end, 1.0))
    if tr is None:
        tr = solve_transient(pb, max(t_end, 1.0), scheme="trbdf2", probes=probes, assembly=asm,
                             error_control="probes", **kw)
    fine = np.union1d(np.asarray(tr.times), t[fin])
    rf = np.column_stack([np.interp(fine, tr.times, tr.probe_C[:, j] - amb) for j in range(m)])
    if signal:
        lag = None
        if moves_ambient(signal):
            A, _ = linearised(asm, st.T_C)
            lag = probe_matrix(grid, np.array(list(probes.values()))) @ lag_field(A, asm.M)
        rf = apply_signal_effects(fine, rf, list(signal), lag)
    out[fin] = np.column_stack([np.interp(t[fin], fine, rf[:, j]) for j in range(m)])
    if cyc is not None:
        out[fin] += cyc(t[fin])
    return out, info


def _reduced(pb, asm, steady, probes: dict, t_end: float) -> tuple:
    """(TransientResult or None, info dict) of the checked reduced transient; None: run the full FEM."""
    from imutherm.thermal.reduced_transient import reduced_power_on
    try:
        tr, check = reduced_power_on(pb, asm, steady, probes, t_end)
    except InputError as e:   # e.g. a fixed-temperature face, a fixture away from ambient
        return None, _info("full", f"reduced transient not applicable ({e})")
    return tr, _info("reduced" if tr is not None else "full", check.reason, float(check.max_site_error_K),
                     int(check.basis_size), int(check.full_solves))


def _info(transient, reason: str, estimated_error_K=None, basis=None, full_solves=None) -> dict:
    """How a rise's transient was computed (:func:`checked_rise`)."""
    return {"transient": transient, "estimated_error_K": estimated_error_K, "basis": basis,
            "full_solves": full_solves, "reason": reason}


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
