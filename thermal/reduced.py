"""A reduced-order forward model of one scheme for the hundreds of runs a correlation needs.

The full model is a nonlinear FEM of ~2e5 unknowns (6 s steady, tens of seconds per transient).
The correlation varies a dozen one-dimensional *knobs* (a contact conductance, an emissivity, a
power, ...) and asks for site curves at a few times. Here:

1. **Linearise** the exterior laws (natural convection, radiation) about the nominal steady field by
   their secant q / (T - T_amb), so the model in rise variables is M dθ/dt + A θ = b (A = conduction +
   boundary, M heat capacity, b the die powers). The secant reproduces the nominal steady state
   exactly; away from it the neglected curvature is the linearisation error (measured in the tests).
   The surface-to-surface cavity exchange (``cavity_law 's2s'``) gets the same secant between the patch
   temperatures (:func:`exchange_secant`): a dense patch conductance matrix G, kept as the low-rank term
   P^T G P beside the sparse operator (:class:`SparsePlusLowRank`; CG preconditioned by the sparse part's
   AMG, which it hardly slows: 46 iterations against 49 on the sparse part alone), projected as (P V)^T G (P V).
2. **Project** on a basis V built from the nominal operator's block Krylov space
   (A^-1 B, (A^-1 M) A^-1 B, ... for the inputs B: each targeted part's power, the remaining power
   and the ambient coupling A 1, i.e. moment matching at s = 0, which fits step responses) plus the
   steady solutions with each knob at its bounds (the parametric directions, solved as their change from
   the nominal solution, warm-started). Solves are CG preconditioned by one AMG hierarchy of the nominal
   operator, to 1e-4 of the load (the basis only has to span: at the knobs' bounds the reduced model then
   matches the linearised full model to ~1e-5 of the largest rise, far below the interpolation and
   linearisation errors).
3. **Interpolate** each knob's change of the reduced operator, ΔA_r(p) = V^T (A(p) - A_nom) V, by a
   Chebyshev polynomial in the knob's (log) coordinate from a few full assemblies (projected on the rows
   the change touches only), and add the
   knobs' changes (exact when the knobs touch different cells or faces, which they do here).
   Power knobs enter b only and are exact.
4. **Solve** the r x r system in closed form: with A_r Φ = M_r Φ Λ, a power step plus an ambient
   ramp of rate r gives each mode y(t) = g0 (1 - e^{-λt}) / λ + g1 (t/λ - (1 - e^{-λt}) / λ^2),
   g = Φ^T (b + r t A_r 1), so a forward run at any times costs microseconds.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from imutherm import InputError
from imutherm.thermal.assembly import EXCHANGE_FACE, assemble, volume_load
from imutherm.thermal.linear import amg_preconditioner
from imutherm.thermal.probes import probe_matrix
from imutherm.thermal.steady import solve_steady

#: relative CG tolerance of the basis solves
BASIS_RTOL = 1e-4
_STATS = {}
#: Krylov orders per input column
KRYLOV_ORDER = 2
#: singular values below this fraction of the largest are dropped from the basis
SVD_DROP = 1e-9


@dataclass(frozen=True)
class Knob:
    """One scalar parameter of the model the reduced model can vary.

    name : str, unit : str, lo, hi : float bounds [unit], log : bool (interpolate in log p)
    nodes : int, Chebyshev nodes of the interpolation (2 for a law linear in p)
    part : str or None, a power knob: the component whose power changes by p [W] (b only, exact)
    scale_power : bool, a power-scale knob: every power times p [-] (b only, exact)
    """

    name: str
    unit: str
    lo: float
    hi: float
    log: bool = False
    nodes: int = 3
    part: str | None = None
    scale_power: bool = False

    def to_u(self, p):
        f = np.log if self.log else (lambda x: x)
        return (2 * f(np.asarray(p, float)) - f(self.lo) - f(self.hi)) / (f(self.hi) - f(self.lo))

    def from_u(self, u):
        f, g = (np.log, np.exp) if self.log else ((lambda x: x), (lambda x: x))
        return np.clip(g(f(self.lo) + (np.asarray(u, float) + 1) / 2 * (f(self.hi) - f(self.lo))), self.lo, self.hi)

    @property
    def is_load(self) -> bool:
        return self.part is not None or self.scale_power


class SparsePlusLowRank(spla.LinearOperator):
    """A [W/K] = S + P^T G P: a sparse operator plus a low-rank symmetric term on a few nodes, never formed.

    sparse : (n, n) sparse, P : (k, n) sparse (k << n), G : (k, k) dense symmetric. ``A @ V`` for a dense
    (n, r) block costs the sparse product plus P V, a k x k product and P^T; CG takes it as is, and
    :func:`sparse_part` gives the sparse operator the AMG preconditioner is built on.
    """

    def __init__(self, sparse, P, G):
        super().__init__(float, sparse.shape)
        self.sparse, self.P, self.G = sparse, P, G
        self.PT = P.T.tocsr()

    def _matvec(self, x):
        x = np.ravel(x)
        return self.sparse @ x + self.low_rank(x)

    def low_rank(self, x):
        """The low-rank term's product P^T G P x."""
        return self.PT @ (self.G @ (self.P @ x))

    def _matmat(self, X):
        return self.sparse @ X + self.PT @ (self.G @ (self.P @ X))

    def _adjoint(self):
        return self


def sparse_part(A):
    """The sparse operator of ``A`` (itself, or the sparse part of a :class:`SparsePlusLowRank`)."""
    return A.sparse if isinstance(A, SparsePlusLowRank) else A


def low_rank_change(Ak, A0, sparse_change):
    """Ak - A0 given its sparse part ``sparse_change``: with an exchange, the change of its G is kept beside
    (a knob that does not touch the exchange leaves G unchanged: then the sparse change alone)."""
    if not isinstance(Ak, SparsePlusLowRank):
        return sparse_change
    dG = Ak.G - A0.G
    return SparsePlusLowRank(sparse_change, Ak.P, dG) if np.any(dG) else sparse_change


def exchange_projection(A, V):
    """(P V)^T G (P V) [W/K]: the low-rank term of ``A`` projected on the basis V (0 for a sparse A)."""
    if not isinstance(A, SparsePlusLowRank):
        return 0.0
    PV = np.asarray(A.P @ V)
    return PV.T @ (A.G @ PV)


def exchange_secant(exchange, T_C: np.ndarray) -> tuple:
    """(P, G): the secant of a surface-to-surface exchange about the field ``T_C`` [°C], exact there.

    With the patch temperatures T_i [K] of the field, sigma (T_i^4 - T_j^4) = h_ij (T_i - T_j),
    h_ij = sigma (T_i^2 + T_j^2)(T_i + T_j), so the net heat leaving the patches Q = X sigma T^4 (X:
    zero row sums) is Q = G T_p with G_ij = X_ij h_ij (i != j) and zero row sums [W/K]: symmetric,
    positive semi-definite (X_ij <= 0 off the diagonal: a weighted graph Laplacian), and it carries
    no heat to the ambient, so it holds in rise variables. P (patches, n) [-] is the patch averaging
    on all nodes; the nodal heat leaving is P^T G P T.
    """
    from imutherm.thermal.problem import SIGMA, ZERO_C_K
    P = exchange.patches.P.tocsr()
    Tp = P @ np.asarray(T_C, float) + ZERO_C_K
    h = SIGMA * (Tp[:, None] ** 2 + Tp[None, :] ** 2) * (Tp[:, None] + Tp[None, :])
    G = np.minimum(exchange.X, 0.0) * h  # off-diagonal couplings (round-off positives dropped)
    np.fill_diagonal(G, 0.0)
    G = 0.5 * (G + G.T)
    G[np.diag_indices_from(G)] = -G.sum(axis=1)
    return P, G


def linearised(asm, T_C: np.ndarray):
    """(A, b): the secant linearisation of an assembled problem about the field ``T_C`` [°C].

    A [W/K] = K + H + diag(secant conductances of the nonlinear laws), b [W] = nodal power; valid
    in rise variables θ = T - T_amb when every law's reference temperature is the ambient. With a
    surface-to-surface cavity exchange (``cavity_law 's2s'``) A is a :class:`SparsePlusLowRank`
    (its secant, :func:`exchange_secant`, is the low-rank term), else a sparse matrix.
    """
    pb = asm.problem
    if asm.dirichlet:
        raise InputError("reduced model: fixed-temperature faces are not supported (use a contact law)")
    exchanges = tuple(getattr(pb, "exchanges", ()))
    if len(exchanges) > 1:
        raise InputError("reduced model: more than one interior exchange law is not supported")
    for bc in list(asm.linear) + list(asm.nonlinear):
        if bc.face != EXCHANGE_FACE and abs(bc.T_ref - pb.ambient_C) > 1e-9:
            raise InputError(f"reduced model: a law on face {bc.face!r} refers to {bc.T_ref:g} C, not the ambient "
                             f"{pb.ambient_C:g} C (a fixture away from ambient is not supported)")
    D = secant_slopes(asm, T_C)
    data = asm.K_data + asm.H_data   # one pattern: the sum of the data arrays is the sum of the matrices
    data[asm.pattern.diag_pos] += D
    A = asm.pattern.csr(data)
    if exchanges:
        A = SparsePlusLowRank(A, *exchange_secant(exchanges[0], T_C))
    return A, asm.F_q.copy()


def secant_slopes(asm, T_C: np.ndarray) -> np.ndarray:
    """(n,) [W/K] the nodal secant conductances q / (T - T_ref) of the nonlinear laws to the surroundings about
    ``T_C`` [°C] (the slope where |T - T_ref| < 1 mK): the diagonal :func:`linearised` adds to K + H (the s2s
    exchange is its low-rank term, not in here)."""
    D = np.zeros(asm.n)
    for bc in asm.nonlinear:
        if bc.face == EXCHANGE_FACE:  # between surfaces, not to the ambient: the low-rank term
            continue
        dT = T_C[bc.nodes] - bc.T_ref
        q, dq = bc.law.flux_out(T_C[bc.nodes], bc.T_ref)
        small = np.abs(dT) < 1e-3
        sec = np.where(small, dq, q / np.where(small, 1.0, dT))
        np.add.at(D, bc.nodes, bc.weights * sec)
    return D


def lag_field(A, M, pc=None, rtol: float = BASIS_RTOL) -> np.ndarray:
    """tau = A^-1 M 1 [s]: each node's lag behind a ramp of the surroundings (linear model)."""
    pc = pc if pc is not None else amg_preconditioner(sparse_part(A))
    x, info = spla.cg(A, M @ np.ones(A.shape[0]), rtol=rtol, M=pc, maxiter=5000)
    if info:
        raise InputError(f"lag field: CG did not converge (info {info})")
    return x


@dataclass(frozen=True)
class ReducedModel:
    """The reduced model of one scheme (see the module docstring).

    site_names : tuple, P : (m, r) sites of the basis, M, A0 : (r, r) [J/K], [W/K]
    b0 : (r,) nominal power [W], c0 : (r,) ambient coupling A 1 [W/K]
    part_b : dict component -> (r,) load of 1 W in its die
    knobs : dict name -> Knob; cheb : dict name -> ((N, r, r) ΔA, (N, r) Δc) Chebyshev coefficients
    cheb2 : coupled pairs (two knobs changing the same conductances, e.g. the board's conductivity and
        a contact on the board: their changes do not add), interpolated jointly on a tensor grid
    nominal_rise_K : (m,) steady site rises of the full nonlinear nominal model [K]
    basis_size : int, unknowns : int, build_s : float [s], solves : int
    P_max : (k, r) or None, the basis at every node where the largest rise can be (the powered parts'
        nodes, ``max_nodes`` of :func:`build_reduced`): :meth:`max_rise` is the maximum over them, so a hot
        spot that moves inside a die when the powers change is followed (a fixed probe at the nominal hot
        node missed 0.09 K of it: grease scheme, 5 V regulator at 0.25 W, the hot spot one node over)
    """

    site_names: tuple
    P: np.ndarray
    M: np.ndarray
    A0: np.ndarray
    b0: np.ndarray
    c0: np.ndarray
    part_b: dict
    knobs: dict
    cheb: dict
    nominal_rise_K: np.ndarray
    basis_size: int
    unknowns: int
    build_s: float
    solves: int
    M1: np.ndarray
    ambient_C: float = 0.0
    timings: dict = field(default_factory=dict)
    #: (a, b) -> (N_a, N_b, r, r) ΔA and (N_a, N_b, r) Δc 2-D Chebyshev coefficients of coupled knob pairs
    cheb2: dict = field(default_factory=dict)
    P_max: np.ndarray | None = None

    def max_rise(self, x: np.ndarray) -> float:
        """The largest steady rise [K] of the reduced solution ``x`` (r,): over the sites and, with
        ``P_max``, over every node it covers."""
        top = float(np.max(self.P @ x))
        return top if self.P_max is None else max(top, float(np.max(self.P_max @ x)))

    def operators(self, values: dict) -> tuple:
        """(A_r, c_r, b_r) with the knobs of ``values`` (name -> value [unit]); others nominal."""
        A, c, b = self.A0.copy(), self.c0.copy(), self.b0.copy()
        scale = 1.0
        extra = 0.0 * b
        for name in values:
            if name not in self.knobs:
                raise InputError(f"reduced model: unknown knob {name!r}; valid: {', '.join(self.knobs)}")
        joint = set()
        for (a, bb), (dA, dc) in self.cheb2.items():
            if a in values and bb in values:
                Ta, Tb = (self._cheb_row(k, values[k]) for k in (a, bb))
                A += np.einsum("i,j,ijkl->kl", Ta, Tb, dA)
                c += np.einsum("i,j,ijk->k", Ta, Tb, dc)
                joint |= {a, bb}
        for name, v in values.items():
            k = self.knobs[name]
            if k.scale_power:
                scale = v
            elif k.part is not None:
                extra = extra + v * self.part_b[k.part]
            elif name not in joint:
                T = self._cheb_row(name, v)
                dA, dc = self.cheb[name]
                A += (T @ dA.reshape(len(T), -1)).reshape(A.shape)
                c += T @ dc
        return A, c, scale * b + extra

    def _cheb_row(self, name: str, v: float) -> np.ndarray:
        """T_0(u) .. T_{N-1}(u) at the knob's coordinate u of ``v`` (the recurrence of ``chebvander``)."""
        k = self.knobs[name]
        u = min(max(float(k.to_u(v)), -1.0), 1.0)
        T = [1.0, u]
        for _ in range(2, k.nodes):
            T.append(2.0 * u * T[-1] - T[-2])
        return np.array(T[:k.nodes])

    @functools.cached_property
    def _M_chol_inv(self) -> np.ndarray:
        """L^-1 of the heat capacity's Cholesky factor M = L L^T: the modes of (A, M) from a standard
        symmetric eigenproblem of L^-1 A L^-T (cheaper than the generalized one, the same modes)."""
        return sla.solve_triangular(np.linalg.cholesky(self.M), np.eye(len(self.M)), lower=True)

    def modes(self, A: np.ndarray) -> tuple:
        """(λ [1/s], Φ): A Φ = M Φ diag(λ), Φ^T M Φ = I, for the symmetric part of A."""
        Li = self._M_chol_inv
        lam, Q = np.linalg.eigh(Li @ (0.5 * (A + A.T)) @ Li.T)
        return lam, Li.T @ Q

    def rise(self, values: dict, times, drift_K_s: float = 0.0) -> np.ndarray:
        """Site rises [K] (len(times), m) after power-on at t = 0 (time inf: steady, no drift)."""
        A, c, b = self.operators(values)
        lam, Phi = self.modes(A)
        lam = np.maximum(lam, 1e-12)
        g0 = Phi.T @ b
        g1 = drift_K_s * (Phi.T @ c)
        t = np.asarray(times, float)
        out = np.empty((len(t), len(self.site_names)))
        fin = np.isfinite(t)
        PP = self.P @ Phi
        if fin.any():
            tt = t[fin][:, None]
            e = -np.expm1(-lam[None, :] * tt)
            y = g0 * e / lam + g1 * (tt / lam - e / lam**2)
            out[fin] = y @ PP.T
        if (~fin).any():
            out[~fin] = PP @ (g0 / lam)
        return out

    def lag_s(self, values: dict) -> np.ndarray:
        """Sites' lag behind an ambient ramp [s]: the reduced A^-1 M 1 at the sites."""
        A, _, _ = self.operators(values)
        return self.P @ np.linalg.solve(A, self.M1)


def _cg(A, b, pc, rtol=BASIS_RTOL, atol=0.0):
    its = [0]

    def count(_):
        its[0] += 1
    x, info = spla.cg(A, b, rtol=rtol, atol=atol, M=pc, maxiter=5000, callback=count)
    _STATS["cg_its"] = _STATS.get("cg_its", 0) + its[0]
    if info:
        raise InputError(f"reduced model: CG did not converge (info {info})")
    return x


def _part_load(variant, grid, component: str) -> np.ndarray:
    """Nodal load [W] of 1 W spread over the die (or body) of ``component``."""
    g = variant.geometry
    part = variant.power_part(component)
    pb = variant.problem(grid)
    q = np.where(grid.cell_part.ravel() == grid.part_names.index(part.name), 1.0 / g.volumes[part.name], 0.0)
    from dataclasses import replace
    return volume_load(replace(pb, q=q))


def build_reduced(variant_fn, grid, knobs, sites: dict, *, order: int = KRYLOV_ORDER, pairs=(),
                  progress=None, load_directions: bool = False, max_nodes=None) -> ReducedModel:
    """Build the :class:`ReducedModel` of a scheme.

    variant_fn : callable, ``variant_fn(values: dict) -> variant`` (values: knob name -> value;
        {} is the nominal model); a variant has ``.geometry`` (the parts' volumes), ``.problem(grid)``
        (its ThermalProblem) and ``.power_part(component)`` (the part carrying a power knob's load), as the
        unit model's :class:`~imutherm.unit.effects.ModelVariant` has: the FEM core does not import the
        unit model, its caller hands the variants in
    grid : TensorGrid of the variants' geometry
    knobs : sequence of Knob
    sites : dict name -> point [m]
    pairs : (a, b) knob names whose changes do not add (they change the same conductances): each pair
        is interpolated jointly on the tensor grid of their Chebyshev nodes
    load_directions : bool, also put in the basis each power knob's steady response at every other knob's
        bounds (one more warm-started solve per power knob and bound): a sweep that varies a power far
        from the layout's together with a conductance needs it (grease scheme, 5 V regulator at 1.4 W with
        the board at 10 W/m K: 0.09 K site error without, the nominal load's bound solutions only)
    max_nodes : int array or None, node indices whose rows of the basis are kept (``P_max``) so that
        :meth:`ReducedModel.max_rise` is the maximum over them
    """
    carried = {k.name for k in knobs}
    for a, b in pairs:
        absent = [n for n in (a, b) if n not in carried]
        if absent:
            raise ValueError(f"coupled pair ({a!r}, {b!r}): {', '.join(absent)} is not among the reduced model's "
                             "knobs (pass only pairs of knobs it carries: unit.knobs.coupled_pairs)")
    t0 = time.perf_counter()
    timings = {}
    nominal = variant_fn({})
    pb = nominal.problem(grid)
    asm = assemble(pb)
    st = solve_steady(pb, probes=sites, assembly=asm)
    timings["steady_s"] = time.perf_counter() - t0
    A0, b0 = linearised(asm, st.T_C)
    M = asm.M
    pc = amg_preconditioner(sparse_part(A0))
    solves = 0
    parts = [k.part for k in knobs if k.part is not None]
    B = [_part_load(nominal, grid, p) for p in parts]
    rest = b0 - sum(pw * Bi for pw, Bi in zip([_power_part_W(nominal, p) for p in parts], B)) if B else b0
    B.append(rest)
    one = np.ones(A0.shape[0])
    B.append(A0 @ one)
    cols = []
    first = {}
    for Bi in B:
        x = Bi
        for i in range(order):
            if i == 0 and Bi is B[-1]:
                x = one   # A0^-1 (A0 1): the ambient input's first Krylov vector is known, no solve
            else:
                x = _cg(A0, x if x is Bi else M @ x, pc)
                solves += 1
                if progress:
                    progress(f"basis solve {solves}")
            if i == 0 and Bi is not B[-1]:
                first[id(Bi)] = x   # A0^-1 B_i: the warm start of its bound solutions (load_directions)
            cols.append(x / (np.linalg.norm(x) or 1.0))
    timings["krylov_s"] = time.perf_counter() - t0 - timings["steady_s"]
    # parametric directions: the steady solution with each knob at its bounds, solved as its change from the
    # nominal solution x_nom (A0 x_nom = b0: the secant reproduces the nominal field), whose right-hand side
    # -(A_k - A0) x_nom is local to the cells and faces the knob touches; the absolute tolerance is the one a
    # solve of A_k x = b0 from zero would stop at (the same accuracy of x_nom + d, fewer CG iterations)
    x_nom = st.T_C - pb.ambient_C
    cols.append(x_nom / (np.linalg.norm(x_nom) or 1.0))
    atol = BASIS_RTOL * np.linalg.norm(b0)

    part_loads = [Bi for Bi in B[:len(parts)]] if load_directions else []

    def change(Ak):
        nonlocal solves
        solves += 1
        d = _cg(Ak, b0 - Ak @ x_nom, pc, rtol=0.0, atol=atol)
        for Bi in part_loads:  # the part's response at this bound, as its change from A0^-1 B_i
            y0 = first[id(Bi)]
            solves += 1
            dy = _cg(Ak, Bi - Ak @ y0, pc, rtol=0.0, atol=BASIS_RTOL * np.linalg.norm(Bi))
            cols.append((y0 + dy) / (np.linalg.norm(y0 + dy) or 1.0))
        return d / (np.linalg.norm(d) or 1.0)
    pattern = asm.pattern

    def knob_operator(values: dict):
        """A_k, the secant operator with the knobs of ``values`` (no heat capacity: it does not change)."""
        return linearised(assemble(variant_fn(values).problem(grid), mass=False), st.T_C)[0]

    def delta(Ak):
        """A_k - A0 with only its nonzero entries (the cells and faces the knob touches): both share the
        grid's pattern, so their data arrays align."""
        dd = sparse_part(Ak).data - sparse_part(A0).data
        nz = np.flatnonzero(dd)
        d = sp.csr_matrix((dd[nz], (pattern.rows[nz], pattern.indices[nz])), shape=A0.shape)
        return low_rank_change(Ak, A0, d)

    ops = {}
    t1 = time.perf_counter()
    for k in knobs:
        if k.is_load:
            continue
        us = -np.cos(np.pi * np.arange(k.nodes) / (k.nodes - 1))  # Chebyshev-Lobatto points, -1..1
        deltas = []
        for i, u in enumerate(us):
            Ak = knob_operator({k.name: float(k.from_u(u))})
            if i in (0, len(us) - 1):
                cols.append(change(Ak))
            deltas.append(delta(Ak))
        ops[k.name] = (us, deltas)
    pair_ops = {}
    by_name = {k.name: k for k in knobs}

    def pair_operator(a, b, x, y):
        return knob_operator({a: float(by_name[a].from_u(x)), b: float(by_name[b].from_u(y))})

    for a, b in pairs:
        ua = -np.cos(np.pi * np.arange(by_name[a].nodes) / (by_name[a].nodes - 1))
        ub = -np.cos(np.pi * np.arange(by_name[b].nodes) / (by_name[b].nodes - 1))
        pair_ops[(a, b)] = (ua, ub)
        for x, y in ((-1, -1), (-1, 1), (1, -1), (1, 1)):  # the corners' steady solutions join the basis
            cols.append(change(pair_operator(a, b, x, y)))
    timings["parametric_s"] = time.perf_counter() - t1
    X = np.column_stack(cols)
    U, s, _ = np.linalg.svd(X, full_matrices=False)
    V = U[:, s > SVD_DROP * s[0]]
    A0r = V.T @ (A0 @ V)
    c0 = V.T @ (A0 @ one)

    def project(dA):
        """(V^T dA V, V^T dA 1) on the rows dA touches only."""
        S = sparse_part(dA)
        rows = np.flatnonzero(np.diff(S.indptr))
        Vr, dAr = V[rows], S[rows]
        return Vr.T @ (dAr @ V) + exchange_projection(dA, V), Vr.T @ np.asarray(dAr.sum(axis=1)).ravel()

    cheb = {}
    for name, (us, deltas) in ops.items():
        dA, dc = (np.stack(x) for x in zip(*map(project, deltas)))
        van = np.polynomial.chebyshev.chebvander(us, len(us) - 1)
        coef = np.linalg.solve(van, dA.reshape(len(us), -1)).reshape(dA.shape)
        coefc = np.linalg.solve(van, dc)
        cheb[name] = (coef, coefc)
    cheb2 = {}
    for (a, b), (ua, ub) in pair_ops.items():  # assembled now and projected at once: not kept in memory
        dA = np.empty((len(ua), len(ub)) + A0r.shape)
        dc = np.empty((len(ua), len(ub), len(c0)))
        for i, x in enumerate(ua):
            for j, y in enumerate(ub):
                dA[i, j], dc[i, j] = project(delta(pair_operator(a, b, x, y)))
        Va = np.linalg.inv(np.polynomial.chebyshev.chebvander(ua, len(ua) - 1))
        Vb = np.linalg.inv(np.polynomial.chebyshev.chebvander(ub, len(ub) - 1))
        cheb2[(a, b)] = (np.einsum("ia,jb,abkl->ijkl", Va, Vb, dA), np.einsum("ia,jb,abk->ijk", Va, Vb, dc))
    names = tuple(sites)
    P = probe_matrix(grid, np.array([sites[n] for n in names]))
    part_b = {p: V.T @ Bi for p, Bi in zip(parts, B)}
    rom = ReducedModel(names, np.asarray(P @ V), V.T @ (M @ V), A0r, V.T @ b0, c0, part_b,
                       {k.name: k for k in knobs}, cheb, np.asarray(st.probe_C) - pb.ambient_C,
                       V.shape[1], A0.shape[0], time.perf_counter() - t0, solves, V.T @ (M @ one), pb.ambient_C,
                       timings, cheb2, None if max_nodes is None else V[np.asarray(max_nodes, int)])
    return rom


def _power_part_W(variant, component: str) -> float:
    return variant.power_part(component).power_W
