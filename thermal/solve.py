"""The thermal solves' former single module, kept as a façade: it re-exports their public names.

The solves live in modules with one purpose each; import from there in new code:

* :mod:`imutherm.thermal.results`: :class:`ThermalResult`, :class:`SteadyResult`, :class:`TransientResult`
* :mod:`imutherm.thermal.probes`: :func:`probe_matrix` (trilinear interpolation at points)
* :mod:`imutherm.thermal.linear`: :func:`amg_preconditioner`, the linear-solver wrapper, fixed-node elimination
* :mod:`imutherm.thermal.steady`: :func:`solve_steady` (Newton with a line search)
* :mod:`imutherm.thermal.transient`: :func:`solve_transient`, :func:`time_steps`
* :mod:`imutherm.thermal.stepping`: the θ-scheme and TR-BDF2 step generators
* :mod:`imutherm.thermal.observers`: probe history, saved fields, energy account, settle stop

``from imutherm.thermal.solve import solve_steady`` (users' scripts) keeps working. No ``__all__``: the API
reference documents each name once, in its home.
"""

from imutherm import ConvergenceError, InputError  # noqa: F401  (re-exported, as all below)
from imutherm.thermal.linear import CG_RTOL, DIRECT_LIMIT, amg_preconditioner
from imutherm.thermal.probes import probe_matrix
from imutherm.thermal.results import SteadyResult, ThermalResult, TransientResult
from imutherm.thermal.stepping import ESTIMATE_CG_RTOL, TRBDF2_GAMMA
from imutherm.thermal.steady import DIVERGED_RISE_K, NEWTON_CG_RTOL, solve_steady
from imutherm.thermal.transient import (DEFAULT_DT_FIRST, DEFAULT_DT_MAX, DEFAULT_TOL_K, SCHEMES, SETTLE_FRACTION,
                                        TRANSIENT_CG_RTOL, solve_transient, time_steps)

