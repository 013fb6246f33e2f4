"""The full model's site rises for one experiment, with the effects of a correlation switched on.

Used twice: to make "measured" data with an effect hidden (:mod:`imutherm.studies.hidden_effect`)
and to re-run the corrected model of a correlation on the full FEM (:mod:`imutherm.studies.correlation`),
so the generator and the check cannot disagree on what an effect means.
"""

from __future__ import annotations

import numpy as np

from imutherm.thermal.assembly import assemble
from imutherm.thermal.effects import ModelVariant, apply_signal_effects, effect_problem
from imutherm.thermal.reduced import lag_field, linearised
from imutherm.thermal.solve import probe_matrix, solve_steady, solve_transient


def full_rise(variant: ModelVariant, grid, probes: dict, times, signal=(), rtol: float | None = None) -> np.ndarray:
    """Site rises [K] (len(times), len(probes)) over the ambient after power-on at t = 0.

    variant : the model (:func:`imutherm.thermal.knobs.variant`), grid : its mesh
    probes : dict site -> point [m]; times : [s], ``inf`` for the steady reading
    signal : ``signal`` effect settings (probe lag, ambient drift) applied to the readings

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
    return out
