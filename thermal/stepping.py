"""The time-stepping schemes of a transient, each a generator of accepted steps.

``theta_steps`` (θ-scheme with given steps, one solve per step) and ``trbdf2_steps`` (TR-BDF2 as an
ESDIRK, given or error-controlled steps) yield one ``AcceptedStep`` per accepted step; what they share is set
up once in ``StepContext`` (fixed nodes, linear solver, power scale, solve counters), and the step matrix with
its cache and preconditioner policy is ``_StepMatrix``. :func:`imutherm.thermal.transient.solve_transient`
drives them and hands each step to the observers (:mod:`imutherm.thermal.observers`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from imutherm.thermal.assembly import Assembly
from imutherm.thermal.linear import choose_solver, Dirichlet, initial_field, LinSolver

# TR-BDF2 as an ESDIRK (Bank et al. 1985; Hosea & Shampine 1996, Appl. Numer. Math. 20, 21-37):
# stage 1 trapezoidal rule to t + γh, stage 2 BDF2 to t + h, both with the matrix M + d h L.
TRBDF2_GAMMA = 2.0 - math.sqrt(2.0)
_D = TRBDF2_GAMMA / 2                      # diagonal coefficient d = γ/2 = 1 − √2/2
_W = math.sqrt(2.0) / 4                    # weights b = (w, w, d), w = (1 − d)/2 = √2/4
#: b − b̂ with b̂ = ((1 − w)/3, (3w + 1)/3, d/3) the embedded third-order weights (Hosea & Shampine 1996)
_E = ((4 * _W - 1) / 3, -1.0 / 3, 2 * _D / 3)
#: relative CG residual of the error-estimate solve: the estimate only sizes the next step, through a cube
#: root, so 10 % is ample (reference unit: the same steps and t95 as 1e-2, a third fewer iterations)
ESTIMATE_CG_RTOL = 1e-1
#: step-size controller: safety factor, largest growth and largest cut per step
_SAFETY, _GROW_MAX, _CUT_MIN = 0.9, 2.0, 0.2


# The transient is a step generator (one per scheme: :func:`theta_steps`, :func:`trbdf2_steps`) whose
# accepted steps (:class:`AcceptedStep`) are handed to observers (probe history, saved fields, energy account,
# settle stop), as scikit-fem's example 19 does; the schemes share the set-up (:class:`StepContext`), the step
# matrix with its cache and preconditioner policy (:class:`_StepMatrix`), the linearisation of the
# nonlinear laws and the elimination of the fixed nodes.

@dataclass
class StepContext:
    """What both schemes share (set up once by :func:`solve_transient`), and the solve counters."""

    asm: Assembly
    P: sp.csr_matrix
    D: Dirichlet
    dnodes: np.ndarray
    free: np.ndarray
    method: str
    lin: LinSolver
    T0: np.ndarray
    scale: object
    t_end: float
    L_data: np.ndarray
    L: sp.csr_matrix
    its: int = 0          # linear iterations, all solves
    solves: int = 0       # linear solves, rejected steps and error estimates included
    rejected: int = 0     # adaptive steps redone with a smaller step
    res_max: float = 0.0  # largest relative linear residual of the accepted steps

    @classmethod
    def start(cls, problem, asm, P, solver, rtol, initial_C, power_profile, t_end):
        dnodes, g0 = asm.dirichlet_values(0.0)
        D = Dirichlet(asm, dnodes)
        free = ~D.mask
        method = choose_solver(solver, int(free.sum()))
        T = initial_field(problem, initial_C, asm.n)
        T[dnodes] = g0
        L_data = asm.K_data + asm.H_data
        return cls(asm=asm, P=P, D=D, dnodes=dnodes, free=free, method=method, lin=LinSolver(method, rtol=rtol), T0=T,
                   scale=(lambda t: 1.0) if power_profile is None else (lambda t: float(power_profile(t))),
                   t_end=t_end, L_data=L_data, L=asm.pattern.csr(L_data))

    @property
    def nonlinear(self) -> bool:
        return bool(self.asm.nonlinear)

    @property
    def power_W(self) -> float:
        """Total power at full scale [W] (volumetric plus boundary heat flux)."""
        return float(self.asm.F_q.sum()) + self.asm.flux_in_W

    def linearise(self, T):
        """``(N(T), N'(T))`` of the nonlinear laws (Jacobian zero on fixed nodes); ``(0.0, None)`` if none."""
        if not self.nonlinear:
            return 0.0, None
        N0, J0 = self.asm.nonlinear_flux(T)
        return N0, np.where(self.D.mask, 0.0, J0)

    def fixed_increment(self, t, T):
        """Increment of the fixed-node temperatures from ``T`` to their values at ``t`` [K] (None: no fixed nodes)."""
        return self.asm.dirichlet_values(t)[1] - T[self.dnodes] if len(self.dnodes) else None

    def eliminated_rhs(self, A_full, rhs, dd, x0=None):
        """Right-hand side (and predictor) of the eliminated system for increments ``dd`` on the fixed nodes."""
        if not len(self.dnodes):
            return rhs, x0
        b = rhs.copy()
        if np.any(dd != 0):
            dfull = np.zeros(len(rhs))
            dfull[self.dnodes] = dd
            b -= A_full @ dfull
        b[self.dnodes] = dd
        if x0 is not None:
            x0 = x0.copy()
            x0[self.dnodes] = dd
        return b, x0


class _StepMatrix:
    """A scheme's step matrix ``form(h) + jac(h) diag(J)`` for step size ``h`` (J: the Jacobian of the
    nonlinear laws), full and with the fixed nodes eliminated.

    Linear problems keep the last four step sizes' matrices. The preconditioner (AMG) is rebuilt when the
    step leaves [0.5, 2] x the step it was built for; otherwise the linear solver reuses it, rebuilding
    only when CG slows down (:class:`LinSolver`).
    """

    def __init__(self, ctx: StepContext, form, jac):
        self.ctx, self.form, self.jac = ctx, form, jac
        self.cache = {}
        self.h_pc = None

    def __call__(self, h: float, J):
        ctx = self.ctx
        key = float(h)
        if not ctx.nonlinear and key in self.cache:
            A_full, A = self.cache[key]
        else:
            pat = ctx.asm.pattern
            full = self.form(h)
            if ctx.nonlinear:
                full[pat.diag_pos] += self.jac(h) * J
            A_full = pat.csr(full)
            A = pat.csr(ctx.D.eliminate(full)) if len(ctx.dnodes) else A_full
            if not ctx.nonlinear:
                if len(self.cache) >= 4:
                    self.cache.pop(next(iter(self.cache)))
                self.cache[key] = (A_full, A)
        if self.h_pc is None:
            self.h_pc = h
        elif ctx.method == "amg" and not (0.5 <= h / self.h_pc <= 2.0):
            ctx.lin.prepare(A)
            self.h_pc = h
        return A_full, A


@dataclass(frozen=True)
class AcceptedStep:
    """One accepted step as the observers see it."""

    k: int                 # steps accepted so far, this one included
    ta: float              # [s]
    tb: float              # [s]
    h: float               # [s] the step size the scheme integrated with
    T_prev: np.ndarray     # [°C] field at ta
    T: np.ndarray          # [°C] field at tb
    power_mean: float      # [-] the scheme's weighted mean of the power profile s(t) over the step
    heat_out_W: float      # [W] the scheme's weighted mean heat leaving through the boundary laws
    #                        (θ-scheme: and through the fixed nodes)
    fixed_in_J: float | None = None   # [J] heat entering through the fixed nodes (TR-BDF2)


def _linear_heat_out(asm, T) -> float:
    """Heat leaving through the linear laws [W] (consistent face integral: mean of the face-cell corners)."""
    return sum(float(np.dot(bc.hA, T[bc.corners].mean(axis=1) - bc.T_ref)) for bc in asm.linear)


def theta_steps(ctx: StepContext, steps, theta):
    """θ-scheme steps in increment form, one solve each; see :func:`solve_transient`."""
    asm, lin, dnodes, L = ctx.asm, ctx.lin, ctx.dnodes, ctx.L
    Fq, Fbc = asm.F_q, asm.F_bc
    matrix = _StepMatrix(ctx, lambda h: asm.M_data / h + theta * ctx.L_data, lambda h: theta)
    times = np.concatenate([[0.0], np.cumsum(steps)])
    times[-1] = ctx.t_end
    T = ctx.T0.copy()
    dT_prev = h_prev = None
    for s_i in range(len(steps)):
        h = float(steps[s_i])
        ta, tb = times[s_i], times[s_i + 1]
        N0, J0 = ctx.linearise(T)
        A_full, A = matrix(h, J0)
        sa, sb = ctx.scale(ta), ctx.scale(tb)
        rhs = (theta * sb + (1 - theta) * sa) * Fq + Fbc - L @ T - N0
        dd = ctx.fixed_increment(tb, T)
        x0 = None
        if dT_prev is not None and ctx.method == "amg":
            x0 = dT_prev * (h / h_prev)      # the last increment, rescaled: a cheap predictor
        b, x0 = ctx.eliminated_rhs(A_full, rhs, dd, x0)
        dT, its, rel = lin.solve(A, b, x0=x0)
        dT_prev, h_prev = dT, h
        ctx.its += its
        ctx.solves += 1
        ctx.res_max = max(ctx.res_max, rel)
        if len(dnodes):
            dT[dnodes] = dd
        # heat leaving, θ-weighted on the fluxes the step used (fixed nodes: the residual of their rows)
        q_out = theta * _linear_heat_out(asm, T + dT) + (1 - theta) * _linear_heat_out(asm, T)
        if ctx.nonlinear:
            q_out += float(np.sum(N0 + theta * J0 * dT))
        if len(dnodes):
            q_out += float(np.sum((rhs - A_full @ dT)[dnodes]))
        T_prev, T = T, T + dT
        yield AcceptedStep(s_i + 1, ta, tb, h, T_prev, T, theta * sb + (1 - theta) * sa, q_out)


def trbdf2_steps(ctx: StepContext, steps, tol_K, dt_first, dt_max, control):
    """TR-BDF2 steps (fixed ``steps``, or adaptive when ``steps`` is None); see :func:`solve_transient`."""
    asm, lin, dnodes, free, L = ctx.asm, ctx.lin, ctx.dnodes, ctx.free, ctx.L
    M = asm.pattern.csr(asm.M_data)
    Fq, Fbc = asm.F_q, asm.F_bc
    adaptive = steps is None
    g_, d_, w_ = TRBDF2_GAMMA, _D, _W
    matrix = _StepMatrix(ctx, lambda h: asm.M_data + (d_ * h) * ctx.L_data, lambda h: d_ * h)
    T = ctx.T0.copy()
    t_end = ctx.t_end
    X2_prev = h_prev = None
    t = 0.0
    k = 0
    h = dt_first if adaptive else None
    while t < t_end * (1 - 1e-12) and (adaptive or k < len(steps)):
        if adaptive:
            h = min(h, dt_max)
            if t + h > t_end * (1 - 1e-9) or t_end - (t + h) < 0.05 * h:
                h = t_end - t                      # land on t_end without leaving a sliver
        else:
            h = float(steps[k])
        ta, tg, tb = t, t + g_ * h, (t + h if adaptive or k < len(steps) - 1 else t_end)
        h = tb - ta
        N0, J0 = ctx.linearise(T)
        A_full, A = matrix(h, J0)
        sa, sg, sb = ctx.scale(ta), ctx.scale(tg), ctx.scale(tb)
        LT = L @ T
        fn = sa * Fq + Fbc - LT - N0
        # stage 1: trapezoidal rule over [t, t + γh]
        rhs1 = (d_ * h) * (2 * fn + (sg - sa) * Fq)
        x0 = X2_prev * (g_ * h / h_prev) if X2_prev is not None and ctx.method == "amg" else None
        dd1 = ctx.fixed_increment(tg, T)
        b, x0 = ctx.eliminated_rhs(A_full, rhs1, dd1, x0)
        X1, its, rel = lin.solve(A, b, x0=x0)
        ctx.its += its
        res1 = rel
        if len(dnodes):
            X1[dnodes] = dd1
        Tg = T + X1
        Ng = asm.nonlinear_flux(Tg)[0] if ctx.nonlinear else 0.0
        fg = sg * Fq + Fbc - L @ Tg - Ng
        # stage 2: BDF2 from t, t + γh to t + h; f(t+h) ≈ g − L T1 − Ng − J0 (T1 − Tg)
        c2 = sb * Fq + Fbc - LT - Ng
        if ctx.nonlinear:
            c2 = c2 + J0 * X1
        rhs2 = h * (w_ * fn + w_ * fg + d_ * c2)
        dd2 = ctx.fixed_increment(tb, T)
        b, x0 = ctx.eliminated_rhs(A_full, rhs2, dd2, X1 / g_ if ctx.method == "amg" else None)
        X2, its, rel = lin.solve(A, b, x0=x0)
        ctx.its += its
        ctx.solves += 2
        if len(dnodes):
            X2[dnodes] = dd2
        T1 = T + X2
        f1 = c2 - (L @ X2)
        if ctx.nonlinear:
            f1 -= J0 * X2
        ratio = 0.0
        if adaptive:
            r_e = h * (_E[0] * fn + _E[1] * fg + _E[2] * f1)
            if len(dnodes):
                r_e[dnodes] = 0.0
            est, its, _ = lin.solve(A, r_e, rtol=ESTIMATE_CG_RTOL)
            ctx.its += its
            ctx.solves += 1
            e_c = ctx.P @ est if control == "probes" else est[free]
            err = float(np.abs(e_c).max()) if e_c.size else 0.0
            ratio = err / tol_K
            if ratio > 1.0 and h > 1e-9 * t_end:
                ctx.rejected += 1
                h *= max(_CUT_MIN, _SAFETY * ratio ** (-1.0 / 3.0))
                continue
        ctx.res_max = max(ctx.res_max, res1, rel)
        # heat leaving, with the scheme's weights b = (w, w, d) on the fluxes it used
        q_n = _linear_heat_out(asm, T)
        q_g = _linear_heat_out(asm, Tg)
        q_1 = _linear_heat_out(asm, T1)
        if ctx.nonlinear:
            q_n += float(np.sum(N0))
            q_g += float(np.sum(Ng))
            q_1 += float(np.sum(Ng + J0 * (X2 - X1)))
        fixed_in = None
        if len(dnodes):   # heat entering through the fixed nodes: the residual of their rows
            fixed_in = float((M @ X2 - h * (w_ * fn + w_ * fg + d_ * f1))[dnodes].sum())
        X2_prev, h_prev = X2, h
        T_prev, T = T, T1
        t = tb
        k += 1
        yield AcceptedStep(k, ta, tb, h, T_prev, T, w_ * sa + w_ * sg + d_ * sb, w_ * q_n + w_ * q_g + d_ * q_1,
                           fixed_in)
        if adaptive:
            grow = _GROW_MAX if ratio == 0 else min(_GROW_MAX, max(_CUT_MIN, _SAFETY * ratio ** (-1.0 / 3.0)))
            h *= grow
