"""The small-signal thermal model: the tangent operator about a field, and the unit's periodic response.

:func:`tangent_operator` is the heat balance linearised about a steady field (conduction, the linear laws and
the tangent ``dq/dT`` of each nonlinear law; :func:`imutherm.thermal.reduced.linearised` takes the secant
instead). :func:`periodic_ambient_field` solves the complex system ``(A + i w M) g = A 1`` of surroundings
cycling at one period (GMRES with a real AMG preconditioner), and :func:`periodic_ambient_response` reads
it at the probes. Bad input raises :class:`~imutherm.InputError`; a GMRES that does not converge raises
:class:`~imutherm.ConvergenceError`.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from imutherm import ConvergenceError, InputError
from imutherm.thermal.linear import amg_preconditioner
from imutherm.thermal.probes import probe_matrix


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
        raise ConvergenceError(f"ambient cycle response: GMRES did not reach rtol={rtol:g} in 50 restarts of 60 "
                               f"(info {info}); likely cause: a cycle period far shorter than the mesh resolves")
    return x
