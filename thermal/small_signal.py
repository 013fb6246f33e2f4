"""The small-signal (tangent) operator of the heat balance, and the unit's response to cycling surroundings.

About a field T (a steady state, say) a small change v of the nodal temperatures changes the heat
leaving every node by ``A v``, with

    A = K + H + diag(D) + sum_e P_e^T X_e diag(4 sigma T_p^3) P_e

``K`` conduction, ``H`` the linear face laws, ``D`` the tangent dq/dT of each nonlinear face law at T
(natural convection, exterior radiation), and, for every surface-to-surface exchange of the cavity
(:class:`~imutherm.thermal.cavity_radiation.CavityExchange`: nodal heat ``P^T X sigma (P T)^4``), its
exact Jacobian, a dense patch-by-patch block that couples every patch with every other. The sparse part
is a matrix; the exchange is applied as a product, so ``A`` is a
:class:`scipy.sparse.linalg.LinearOperator` when the cavity has an s2s law.

The reduced model (:func:`imutherm.thermal.reduced.linearised`) takes the secant of the laws instead,
right for the whole rise; the tangent is right for small signals about T: the unit's periodic answer to a
chamber whose air, walls and fixture cycle (:func:`periodic_ambient_field`, the hidden-effect generator's
``chamber_cycling`` kind).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from imutherm import ConvergenceError, InputError
from imutherm.thermal.problem import SIGMA, ZERO_C_K
from imutherm.thermal.linear import amg_preconditioner
from imutherm.thermal.probes import probe_matrix


@dataclass(frozen=True)
class Tangent:
    """The tangent operator of one assembly at one field.

    S : (n, n) csr [W/K], conduction, linear laws and the diagonal tangent of the nonlinear face laws
    exchanges : tuple of (nodes (m,), Pn (p, m) csr [-], J (p, p) [W/K]) per s2s exchange: its nodal
        heat changes by ``Pn^T J Pn v[nodes]``
    exchange_diagonal : (n,) [W/K], the exchanges' diagonal (Jacobi) slope, for a preconditioner
    coupling : (n,) [W/K], the heat a uniform 1 K rise of the surroundings (air, radiative environment,
        fixture: every face law's reference temperature) drives into each node (:func:`_coupling`)
    """

    S: sp.csr_matrix
    exchanges: tuple
    exchange_diagonal: np.ndarray
    coupling: np.ndarray

    @property
    def shape(self) -> tuple:
        return self.S.shape

    def _add_exchanges(self, v, out):
        """``out += (the exchanges' Jacobian) v``; returns ``out``."""
        for nodes, Pn, J in self.exchanges:
            out[nodes] += Pn.T @ (J @ (Pn @ v[nodes]))
        return out

    def __matmul__(self, v):
        """``A v`` for a real or complex vector (n,)."""
        return self._add_exchanges(v, self.S @ v)

    def operator(self, shift=None, dtype=float) -> spla.LinearOperator | sp.csr_matrix:
        """``A + shift`` as a sparse matrix when there is no exchange, else as a LinearOperator.

        shift : sparse (n, n) or None (e.g. ``1j w M``); dtype : of the LinearOperator
        """
        Z = self.S if shift is None else (self.S + shift).tocsr()
        if not self.exchanges:
            return Z
        n = self.S.shape[0]

        def matvec(v):
            v = np.asarray(v).ravel()
            return self._add_exchanges(v, Z @ v)

        return spla.LinearOperator((n, n), matvec=matvec, dtype=dtype)


def tangent_operator(asm, T_C: np.ndarray) -> Tangent:
    """The small-signal operator of the assembly ``asm`` about the nodal field ``T_C`` [°C].

    Fixed-temperature faces are refused (a Dirichlet node has no heat balance of its own; use contact laws).
    """
    if asm.dirichlet:
        raise InputError("small-signal operator: fixed-temperature faces are not supported (use contact laws)")
    T_C = np.asarray(T_C, float)
    D = np.zeros(asm.n)
    D_ex = np.zeros(asm.n)
    exchanges = []
    for bc in asm.nonlinear:
        _, dq = bc.law.flux_out(T_C[bc.nodes], bc.T_ref)
        if hasattr(bc.law, "Pn"):  # an s2s exchange: its exact Jacobian, and its diagonal slope apart
            np.add.at(D_ex, bc.nodes, bc.weights * dq)
            Tk = bc.law.Pn @ T_C[bc.law.nodes] + ZERO_C_K
            exchanges.append((np.asarray(bc.law.nodes), bc.law.Pn, bc.law.X * (4.0 * SIGMA * Tk**3)[None, :]))
        else:
            np.add.at(D, bc.nodes, bc.weights * dq)
    S = (asm.K + asm.H + sp.diags(D)).tocsr()
    return Tangent(S, tuple(exchanges), D_ex, _coupling(asm, T_C))


#: step [K] of the central difference of a nonlinear law's flux in its reference temperature (radiation:
#: cubic in it, so the difference is exact to ~1e-12 of the slope)
_REF_STEP_K = 1e-2


def _coupling(asm, T_C: np.ndarray) -> np.ndarray:
    """-d(heat leaving each node)/d(every law's reference temperature) [W/K] (n,) at ``T_C``.

    Linear laws: their conductance (``H 1``: conduction carries no reference). Nonlinear face laws: the
    derivative in the reference temperature itself, not the slope in T: for convection (a function of
    T - T_ref) the two agree; for radiation, eps sigma (T^4 - T_ref^4), it is 4 eps sigma T_ref^3, not
    4 eps sigma T^3. The s2s exchanges have no reference temperature.
    """
    c = asm.H @ np.ones(asm.n)
    for bc in asm.nonlinear:
        if hasattr(bc.law, "Pn"):
            continue
        T = T_C[bc.nodes]
        up, _ = bc.law.flux_out(T, bc.T_ref + _REF_STEP_K)
        down, _ = bc.law.flux_out(T, bc.T_ref - _REF_STEP_K)
        np.add.at(c, bc.nodes, -bc.weights * (up - down) / (2 * _REF_STEP_K))
    return c


def periodic_ambient_field(asm, T_C: np.ndarray, period_s: float, rtol: float = 1e-8) -> np.ndarray:
    """Complex gain [-] (n_nodes,) of every node to surroundings cycling at ``period_s`` [s].

    The surroundings (air, radiative environment and mounting fixture: every law's reference
    temperature) move by Re[a e^{i w t}]; about the field ``T_C`` the unit answers, once the cycling
    has gone on for a while (a chamber cycles before the test starts), with Re[a g e^{i w t}],
    g = (A + i w M)^-1 c: A the small-signal operator (:func:`tangent_operator`), c its coupling to the
    surroundings, M the heat capacity. |g| -> 1 as the period grows (the unit follows its surroundings),
    and falls, with a growing phase lag, when the period is short against the unit's time constants.
    |g| is not exactly 1 at long periods where a law is not a function of T - T_ref alone: the radiation
    exchanged between surfaces at different temperatures grows with their mean (sigma T^4), so a unit
    warmer all over sheds its internal rise a little more easily (a few % of g at the boards under s2s).
    Superposed on the nonlinear rise: exact for linear laws, to first order in a for the others. Solved by GMRES on the complex system, preconditioned by an AMG cycle of the real
    A + w M (with the s2s exchanges' diagonal slope in place of their dense coupling).
    """
    if not period_s > 0:
        raise InputError(f"ambient cycle period must be > 0 s, got {period_s!r}")
    A = tangent_operator(asm, T_C)
    M = asm.M.tocsr()
    w = 2 * np.pi / period_s
    P = A.S + w * M
    pc = amg_preconditioner((P + sp.diags(A.exchange_diagonal) if A.exchanges else P).tocsr())
    n = A.shape[0]
    pcc = spla.LinearOperator((n, n), matvec=lambda v: pc @ np.real(v) + 1j * (pc @ np.imag(v)), dtype=complex)
    Z = A.operator(1j * w * M, dtype=complex)
    x, info = spla.gmres(Z, A.coupling.astype(complex), rtol=rtol, M=pcc, restart=60, maxiter=50)
    if info:
        raise ConvergenceError(f"ambient cycle response: GMRES did not converge to rtol {rtol:g} "
                               f"(info {info}; period {period_s:g} s)")
    return x


def periodic_ambient_response(asm, T_C: np.ndarray, grid, probes: dict, period_s: float,
                              rtol: float = 1e-8) -> np.ndarray:
    """Complex gain [-] (m,) of each probe (dict site -> point [m] on ``grid``) to surroundings cycling at
    ``period_s`` [s]: :func:`periodic_ambient_field` at the probes."""
    x = periodic_ambient_field(asm, T_C, period_s, rtol)
    return probe_matrix(grid, np.array(list(probes.values()))) @ x
