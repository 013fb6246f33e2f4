"""The steady Newton operator of a refined grid, applied without assembling it (matrix-free).

:func:`imutherm.thermal.refinement.refined_steady` assembles the refined problem's 27-point matrix: on the
reference unit's 2x refined mesh (1.5e6 nodes) ~500 MB of indices and data, the study's memory peak, and ~2 CPU-s.
:class:`FineOperator` applies the same operator from the cells' conductivity and 1-D sizes (each cell's
coefficients formed as it is visited, none stored) and the outer faces' laws: the conduction of each Q1 box
cell by its closed form (``K_e = cx KX + cy KY + cz KZ``,
:mod:`imutherm.thermal.assembly`; the tensor structure ``KX = k1 ⊗ m1 ⊗ m1`` applied as a difference along x and
a 2x2 face mass across it), the linear laws' consistent face mass, the nonlinear laws' lumped nodal flux and its
diagonal slope, each surface-to-surface exchange's symmetric Jacobian (as the steady solve linearises it,
:func:`imutherm.thermal.steady.with_exchanges`), fixed-temperature nodes as identity rows. It equals the
assembled matrix to rounding (``tests/test_mesh_estimate.py``). The conduction is one numba pass over the cells
(:func:`_volume_kernel`), no temporary array.
"""

from __future__ import annotations

import numpy as np

from imutherm import InputError
from imutherm.geometry.grid import FACE_NAMES
from imutherm.lazy_jit import njit
from imutherm.thermal.assembly import (EXCHANGE_FACE, FACE_M_REF, NodalBC, faces, volume_load)
from imutherm.thermal.problem import LINEAR_LAWS, NONLINEAR_LAWS, FixedTemperature, HeatFlux

_PAIRS = [(0, 0), (0, 1), (1, 0), (1, 1)]


def _mass4(c, d00, d01, d10, d11):
    """36 (m1 ⊗ m1) applied to four corner values, times ``c``/36: the unit face mass across an axis."""
    c = c / 36.0
    return (c * (4.0 * d00 + 2.0 * d01 + 2.0 * d10 + d11), c * (2.0 * d00 + 4.0 * d01 + d10 + 2.0 * d11),
            c * (2.0 * d00 + d01 + 4.0 * d10 + 2.0 * d11), c * (d00 + 2.0 * d01 + 2.0 * d10 + 4.0 * d11))


def _volume_kernel(x, kc, hx, hy, hz, y):
    """y (Nx, Ny, Nz) += K x: each box cell's ``cx KX + cy KY + cz KZ`` (:mod:`imutherm.thermal.assembly`; ``cx =
    k_x hy hz / hx`` from the cells' conductivity ``kc`` (nx, ny, nz, 3) and the 1-D cell sizes, formed per cell: no
    coefficient arrays kept) as a difference along each axis and the 2x2 face mass across it; cells in C order, one
    pass (numba). Along z the cell's upper corners' values and sums are carried to the next cell in registers
    (each node of a (i, j) column read and written once, no division in the inner loop)."""
    nx, ny, nz = kc.shape[0], kc.shape[1], kc.shape[2]
    rz = np.empty(nz)
    for k in range(nz):
        rz[k] = 1.0 / hz[k]
    for i in range(nx):
        for j in range(ny):
            gx = hy[j] / hx[i]          # cx = k_x gx hz, cy = k_y gy hz, cz = k_z gz / hz
            gy = hx[i] / hy[j]
            gz = hx[i] * hy[j]
            u000, u010, u100, u110 = x[i, j, 0], x[i, j + 1, 0], x[i + 1, j, 0], x[i + 1, j + 1, 0]
            a00 = a01 = a10 = a11 = 0.0   # sums carried to the nodes (i|i+1, j|j+1, k) from the cell below
            for k in range(nz):
                cxi = kc[i, j, k, 0] * gx * hz[k]
                cyi = kc[i, j, k, 1] * gy * hz[k]
                czi = kc[i, j, k, 2] * gz * rz[k]
                u001, u011, u101, u111 = x[i, j, k + 1], x[i, j + 1, k + 1], x[i + 1, j, k + 1], x[i + 1, j + 1, k + 1]
                # y_abc: the cell's contribution to its corner (a, b, c)
                t00, t01, t10, t11 = _mass4_jit(cxi, u100 - u000, u101 - u001, u110 - u010, u111 - u011)
                y000, y001, y010, y011 = -t00, -t01, -t10, -t11
                y100, y101, y110, y111 = t00, t01, t10, t11
                t00, t01, t10, t11 = _mass4_jit(cyi, u010 - u000, u011 - u001, u110 - u100, u111 - u101)
                y010 += t00
                y000 -= t00
                y011 += t01
                y001 -= t01
                y110 += t10
                y100 -= t10
                y111 += t11
                y101 -= t11
                t00, t01, t10, t11 = _mass4_jit(czi, u001 - u000, u011 - u010, u101 - u100, u111 - u110)
                y001 += t00
                y000 -= t00
                y011 += t01
                y010 -= t01
                y101 += t10
                y100 -= t10
                y111 += t11
                y110 -= t11
                y[i, j, k] += a00 + y000
                y[i, j + 1, k] += a01 + y010
                y[i + 1, j, k] += a10 + y100
                y[i + 1, j + 1, k] += a11 + y110
                a00, a01, a10, a11 = y001, y011, y101, y111
                u000, u010, u100, u110 = u001, u011, u101, u111
            y[i, j, nz] += a00
            y[i, j + 1, nz] += a01
            y[i + 1, j, nz] += a10
            y[i + 1, j + 1, nz] += a11


def _sgs_kernel(rd, ex, ey, ez, b, x):
    """One symmetric Gauss-Seidel sweep (forward in C order, then backward) on the 7-point matrix with diagonal
    ``1 / rd`` (Nx, Ny, Nz) and couplings ``-ex`` (Nx-1, Ny, Nz), ``-ey``, ``-ez`` between neighbours: ``x`` (Nx, Ny,
    Nz) updated in place for the right-hand side ``b`` (numba; pyamg's ``gauss_seidel(..., sweep='symmetric')`` on
    :meth:`FineOperator.seven_point` to rounding, without its CSR matrix). The node just updated along z is carried in
    a register and added last, and the diagonal's reciprocal multiplies: the sweep's sequential chain is a
    multiply-add and a multiply, not a division."""
    Nx, Ny, Nz = rd.shape
    for sweep in range(2):
        for ii in range(Nx):
            i = ii if sweep == 0 else Nx - 1 - ii
            for jj in range(Ny):
                j = jj if sweep == 0 else Ny - 1 - jj
                xl = 0.0     # the z-neighbour updated just before (none at the first node)
                for kk in range(Nz):
                    k = kk if sweep == 0 else Nz - 1 - kk
                    s = b[i, j, k]
                    if i > 0:
                        s += ex[i - 1, j, k] * x[i - 1, j, k]
                    if i < Nx - 1:
                        s += ex[i, j, k] * x[i + 1, j, k]
                    if j > 0:
                        s += ey[i, j - 1, k] * x[i, j - 1, k]
                    if j < Ny - 1:
                        s += ey[i, j, k] * x[i, j + 1, k]
                    if sweep == 0:
                        if k < Nz - 1:
                            s += ez[i, j, k] * x[i, j, k + 1]
                        if k > 0:
                            s += ez[i, j, k - 1] * xl
                    else:
                        if k > 0:
                            s += ez[i, j, k - 1] * x[i, j, k - 1]
                        if k < Nz - 1:
                            s += ez[i, j, k] * xl
                    xl = s * rd[i, j, k]
                    x[i, j, k] = xl


def _zline_factor_kernel(d, ez, m, g):
    """The tridiagonal factors of each z line of the 7-point matrix (diagonal ``d``, couplings ``-ez``): ``m`` the
    reciprocal pivots, ``g = ez m`` (Thomas algorithm; numba), for :func:`_zline_sgs_kernel`."""
    Nx, Ny, Nz = d.shape
    for i in range(Nx):
        for j in range(Ny):
            gl = 0.0
            for k in range(Nz):
                piv = d[i, j, k] - (ez[i, j, k - 1] * gl if k > 0 else 0.0)
                mk = 1.0 / piv
                m[i, j, k] = mk
                gl = ez[i, j, k] * mk if k < Nz - 1 else 0.0
                if k < Nz - 1:
                    g[i, j, k] = gl


def _zline_sgs_kernel(m, g, ex, ey, ez, b, x):
    """One symmetric z-line Gauss-Seidel sweep on the 7-point matrix (each (i, j) line solved exactly with its
    x and y neighbours' latest values, lines forward in C order, then backward): ``x`` updated in place (numba)."""
    Nx, Ny, Nz = m.shape
    w = np.empty(Nz)
    for sweep in range(2):
        for ii in range(Nx):
            i = ii if sweep == 0 else Nx - 1 - ii
            for jj in range(Ny):
                j = jj if sweep == 0 else Ny - 1 - jj
                wl = 0.0
                for k in range(Nz):
                    s = b[i, j, k]
                    if i > 0:
                        s += ex[i - 1, j, k] * x[i - 1, j, k]
                    if i < Nx - 1:
                        s += ex[i, j, k] * x[i + 1, j, k]
                    if j > 0:
                        s += ey[i, j - 1, k] * x[i, j - 1, k]
                    if j < Ny - 1:
                        s += ey[i, j, k] * x[i, j + 1, k]
                    if k > 0:
                        s += ez[i, j, k - 1] * wl
                    wl = s * m[i, j, k]
                    w[k] = wl
                xl = w[Nz - 1]
                x[i, j, Nz - 1] = xl
                for k in range(Nz - 2, -1, -1):
                    xl = w[k] + g[i, j, k] * xl
                    x[i, j, k] = xl


# The two Gauss-Seidel kernels repeat their x/y neighbour sums on purpose: the same four lines as a shared helper
# (numba ``inline='always'``, or a plain jitted call) gave bit-identical sweeps 3-5x slower on a refined-size grid
# (157 x 139 x 69 nodes, float32 stencil: point sweep 15 -> 77 ms, z-line 23 -> 95 ms; 2026-12-07).
_zline_factor_kernel = njit(cache=True)(_zline_factor_kernel)
_zline_sgs_kernel = njit(cache=True)(_zline_sgs_kernel)
_mass4_jit = njit(inline="always", cache=True)(_mass4)
_volume_kernel = njit(cache=True)(_volume_kernel)
_sgs_kernel = njit(cache=True)(_sgs_kernel)


class FineOperator:
    """The Newton operator and residual of a steady :class:`~imutherm.thermal.problem.ThermalProblem`, matrix-free.

    ``residual(T)`` [W]: F - (K + H) T - N(T), zero at fixed nodes; ``linearise(T)`` sets the nonlinear laws'
    slopes and the exchanges' Jacobians at ``T`` [°C]; then ``apply(v)`` [W] is the Newton matrix times ``v`` [K]
    (SPD, fixed rows identity) and ``diagonal()`` its diagonal."""

    def __init__(self, problem):
        g = problem.grid
        self.problem, self.grid = problem, g
        self.cells = g.shape
        self.node_shape = tuple(s + 1 for s in g.shape)
        self.n = int(np.prod(self.node_shape))
        self.h = tuple(np.ascontiguousarray(h, float) for h in g.cell_sizes())   # 1-D cell sizes [m]
        self.kc = np.ascontiguousarray(problem.k, float).reshape(g.shape + (3,))  # a view of the problem's k
        self.linear, self.nonlinear, dirichlet = [], [], []
        F_bc = np.zeros(self.n)
        fcs = faces(g)
        for name in FACE_NAMES:
            for law in problem.boundary.get(name, ()):
                face = fcs[name]
                mask = face.mask(law.region)
                if isinstance(law, FixedTemperature):
                    dirichlet.append((np.unique(face.corner_nodes(mask)), law.value(None)))
                elif isinstance(law, LINEAR_LAWS):
                    coef = np.where(mask, law.coefficient, 0.0)
                    w = face.nodal_weights(coef)
                    F_bc[face.nodes.reshape(-1)] += (w * problem.law_T_C(law)).reshape(-1)
                    self.linear.append((face, coef * face.area))
                elif isinstance(law, (HeatFlux,) + NONLINEAR_LAWS):
                    w = face.nodal_weights(mask.astype(float)).reshape(-1)
                    nodes, keep = face.nodes.reshape(-1), w > 0
                    if isinstance(law, HeatFlux):
                        F_bc[nodes[keep]] += law.q * w[keep]
                    else:
                        self.nonlinear.append(NodalBC(name, law, problem.law_T_C(law), nodes[keep], w[keep]))
                else:  # pragma: no cover - ThermalProblem validates the laws
                    raise InputError(f"face {name!r}: unsupported law {law!r}")
        for ex in problem.exchanges:
            self.nonlinear.append(NodalBC(EXCHANGE_FACE, ex, problem.ambient_C, np.asarray(ex.nodes),
                                          np.asarray(ex.weights)))
        self.F = volume_load(problem) + F_bc
        self.fixed = np.zeros(self.n, bool)
        self.fixed_values = np.zeros(self.n)
        for nodes, value in dirichlet:   # later laws win on shared nodes, as the assembly's
            self.fixed[nodes] = True
            self.fixed_values[nodes] = value
        self.any_fixed = bool(self.fixed.any())
        self.slope = np.zeros(self.n)    # the nonlinear laws' diagonal slopes [W/K] (exchanges': replaced)
        self._exchanges = []

    def coef(self, axis: int) -> np.ndarray:
        """The cells' conduction coefficient along ``axis`` (nx, ny, nz) [W/K]: ``k_x hy hz / hx`` for x (formed on
        request, not kept)."""
        hx, hy, hz = self.h[0][:, None, None], self.h[1][None, :, None], self.h[2][None, None, :]
        geo = (hy * hz / hx, hx * hz / hy, hx * hy / hz)[axis]
        return self.kc[..., axis] * geo

    # -- the linear part: conduction and the linear laws ------------------------------------------------------
    def _volume(self, x: np.ndarray) -> np.ndarray:
        """Conduction stiffness times a nodal field ``x`` [K] -> [W] (:func:`_volume_kernel`)."""
        y3 = np.zeros(self.node_shape)
        _volume_kernel(np.ascontiguousarray(x, float).reshape(self.node_shape), self.kc, *self.h, y3)
        return y3.reshape(-1)

    def _faces(self, x: np.ndarray, y: np.ndarray) -> None:
        """Add the linear laws' consistent face mass times ``x`` into ``y`` [W]."""
        for face, ca in self.linear:
            nu, nv = ca.shape
            xf = x[face.nodes]
            X = {(a, b): xf[a:a + nu, b:b + nv] for a, b in _PAIRS}
            yf = np.zeros(face.nodes.shape)
            for l1, (a1, b1) in enumerate(_PAIRS):
                yf[a1:a1 + nu, b1:b1 + nv] += ca * sum(FACE_M_REF[l1, l2] * X[p] for l2, p in enumerate(_PAIRS))
            y[face.nodes.reshape(-1)] += yf.reshape(-1)   # a face's nodes are distinct: no np.add.at needed

    def linear_apply(self, x: np.ndarray) -> np.ndarray:
        """(K + H) x [W] for a nodal field ``x`` [K] (no fixed rows)."""
        y = self._volume(np.asarray(x, float))
        self._faces(x, y)
        return y

    def diagonal_linear(self) -> np.ndarray:
        """The diagonal of K + H [W/K]."""
        nx, ny, nz = self.cells
        d3 = np.zeros(self.node_shape)
        c = sum(self.coef(a) for a in range(3)) / 9.0   # every corner: (cx + cy + cz) * (1/3)^2
        for a in (0, 1):
            for b in (0, 1):
                for e in (0, 1):
                    d3[a:a + nx, b:b + ny, e:e + nz] += c
        d = d3.reshape(-1)
        for face, ca in self.linear:
            nu, nv = ca.shape
            w = np.zeros(face.nodes.shape)
            for a, b in _PAIRS:
                w[a:a + nu, b:b + nv] += ca / 9.0
            np.add.at(d, face.nodes.reshape(-1), w.reshape(-1))
        return d

    # -- the nonlinear laws ---------------------------------------------------------------------------------
    def nonlinear_flux(self, T: np.ndarray) -> tuple:
        """(N, J): lumped nodal heat out through the nonlinear laws [W] and its diagonal slope [W/K]."""
        N, J = np.zeros(self.n), np.zeros(self.n)
        for bc in self.nonlinear:
            qv, dq = bc.law.flux_out(T[bc.nodes], bc.T_ref)
            np.add.at(N, bc.nodes, bc.weights * qv)
            np.add.at(J, bc.nodes, bc.weights * dq)
        return N, J

    def residual(self, T: np.ndarray) -> np.ndarray:
        """F - (K + H) T - N(T) [W] at ``T`` [°C], zero at fixed nodes."""
        N, _ = self.nonlinear_flux(T)
        r = self.F - self.linear_apply(T) - N
        r[self.fixed] = 0.0
        return r

    def linearise(self, T: np.ndarray) -> None:
        """The Newton matrix at ``T`` [°C]: the laws' diagonal slopes, each exchange's symmetric Jacobian."""
        _, self.slope = self.nonlinear_flux(T)
        self._exchanges = []
        for bc in self.nonlinear:
            if bc.face == EXCHANGE_FACE and hasattr(bc.law, "symmetric_jacobian"):
                s, D = bc.law.symmetric_jacobian(T[bc.law.nodes])
                self._exchanges.append((bc.law, s, D))

    def apply(self, v: np.ndarray) -> np.ndarray:
        """The Newton matrix (set by :meth:`linearise`) times ``v`` [K] -> [W]; fixed rows identity."""
        v = np.ravel(np.asarray(v, float))
        w = np.where(self.fixed, 0.0, v) if self.any_fixed else v
        out = self.linear_apply(w)
        out += self.slope * w
        for law, s, D in self._exchanges:
            u = w[law.nodes]
            out[law.nodes] += law.PnT @ (s * (law.X @ (s * (law.Pn @ u)))) - D * u
        if self.any_fixed:
            out[self.fixed] = v[self.fixed]
        return out

    def diagonal(self) -> np.ndarray:
        """The Newton matrix's diagonal [W/K] for a smoother: K + H and the laws' diagonal slopes (an exchange's
        own slope standing for its coupling's diagonal); fixed rows 1."""
        d = self.diagonal_linear() + self.slope
        d[self.fixed] = 1.0
        return d

    def seven_point_stencil(self) -> tuple:
        """The 7-point SPD matrix of :meth:`seven_point` as a stencil: ``(d, ex, ey, ez)``, its diagonal (Nx, Ny, Nz)
        [W/K] and its couplings, ``-ex[i, j, k]`` (Nx-1, Ny, Nz) between nodes (i, j, k) and (i+1, j, k), likewise
        ``ey``, ``ez``; fixed nodes' couplings 0 and diagonal 1. Four nodal arrays, where the CSR matrix holds
        nine (~0.14 GB on the reference unit's refined mesh)."""
        d = np.zeros(self.node_shape)
        edges = []
        for axis in range(3):
            c = self.coef(axis)
            # the edge between node i and i+1 along ``axis``: a quarter of each of the 4 cells around it
            e = np.zeros(tuple(N - 1 if a == axis else N for a, N in enumerate(self.node_shape)))
            others = [a for a in range(3) if a != axis]
            for p in (0, 1):
                for q in (0, 1):
                    idx = [slice(None)] * 3
                    idx[others[0]] = slice(p, p + self.cells[others[0]])
                    idx[others[1]] = slice(q, q + self.cells[others[1]])
                    e[tuple(idx)] += 0.25 * c
            del c
            lo, hi = [slice(None)] * 3, [slice(None)] * 3
            lo[axis], hi[axis] = slice(0, -1), slice(1, None)
            d[tuple(lo)] += e
            d[tuple(hi)] += e
            edges.append(e)
        d = d.reshape(-1)
        for face, ca in self.linear:
            nu, nv = ca.shape
            w = np.zeros(face.nodes.shape)
            for a, b in _PAIRS:
                w[a:a + nu, b:b + nv] += ca / 4.0
            np.add.at(d, face.nodes.reshape(-1), w.reshape(-1))
        d += self.slope
        if self.any_fixed:
            f3 = self.fixed.reshape(self.node_shape)
            for axis, e in enumerate(edges):
                lo, hi = [slice(None)] * 3, [slice(None)] * 3
                lo[axis], hi[axis] = slice(0, -1), slice(1, None)
                e[f3[tuple(lo)] | f3[tuple(hi)]] = 0.0
            d[self.fixed] = 1.0
        return (d.reshape(self.node_shape), *edges)

    def smoother(self, dtype=np.float64, lines: bool = False):
        """``smooth(x, b)``: one symmetric Gauss-Seidel sweep on the 7-point matrix (:meth:`seven_point_stencil`,
        set up now, at the current linearisation) for ``b`` [W], updating the nodal field ``x`` [K] in place.
        ``dtype``: the stencil's storage (``np.float32`` halves it; the sweep's sums stay in double precision, and
        the sweep is still a symmetric Gauss-Seidel, of the stencil rounded to single precision). ``lines``: a
        z-line sweep instead (each line of nodes along z solved exactly, :func:`_zline_sgs_kernel`: a block
        Gauss-Seidel, its blocks the z lines; stronger on the thin layers' cells, ~1.5x a point sweep's cost)."""
        d, ex, ey, ez = (a.astype(dtype, copy=False) for a in self.seven_point_stencil())
        shape = self.node_shape
        if lines:
            m = np.empty(shape, dtype)
            g = np.zeros((shape[0], shape[1], shape[2] - 1), dtype)
            _zline_factor_kernel(d.astype(float), ez.astype(float), m, g)
            del d

            def smooth(x: np.ndarray, b: np.ndarray) -> None:
                _zline_sgs_kernel(m, g, ex, ey, ez, np.ascontiguousarray(b, float).reshape(shape), x.reshape(shape))

            return smooth
        rd = (1.0 / d.astype(float)).astype(dtype)   # the diagonal's reciprocal (of the stored diagonal)
        del d

        def smooth(x: np.ndarray, b: np.ndarray) -> None:
            _sgs_kernel(rd, ex, ey, ez, np.ascontiguousarray(b, float).reshape(shape), x.reshape(shape))

        return smooth

    def seven_point(self):
        """A 7-point SPD matrix (CSR) spectrally equivalent to the Newton matrix, for a smoother: each cell's
        conduction with its 1-D masses across lumped (``k1 ⊗ diag(1/2, 1/2) ⊗ diag(1/2, 1/2)``: the lumped 1-D mass
        lies between 1x and 3x the consistent one, so each term between 1x and 9x its consistent one), the linear
        laws' lumped face mass and the laws' slopes on the diagonal; fixed rows identity, their couplings dropped.
        7 entries a row (a neighbour outside the grid: a zero entry on the opposite one). The refined solve smooths
        with its stencil (:meth:`smoother`) and does not form this matrix; kept as the stencil's reference."""
        import scipy.sparse as sp

        d, *edges = self.seven_point_stencil()
        n = self.n
        strides = (self.node_shape[1] * self.node_shape[2], self.node_shape[2], 1)
        data = np.zeros((n, 7))
        data[:, 3] = d.reshape(-1)
        for axis, e in enumerate(edges):
            lo, hi = [slice(None)] * 3, [slice(None)] * 3
            lo[axis], hi[axis] = slice(0, -1), slice(1, None)
            minus, plus = np.zeros(self.node_shape), np.zeros(self.node_shape)
            minus[tuple(hi)] = -e    # row at i+1, column i
            plus[tuple(lo)] = -e     # row at i, column i+1
            data[:, 2 - axis] = minus.reshape(-1)
            data[:, 4 + axis] = plus.reshape(-1)
        rows = np.arange(n, dtype=np.int32)
        ijk = np.unravel_index(rows, self.node_shape)
        cols = np.empty((n, 7), np.int32)
        cols[:, 3] = rows
        for axis, st in enumerate(strides):
            first, last = ijk[axis] == 0, ijk[axis] == self.node_shape[axis] - 1
            cols[:, 2 - axis] = np.where(first, rows + st, rows - st)   # outside: the opposite one, value 0
            cols[:, 4 + axis] = np.where(last, rows - st, rows + st)
        return sp.csr_matrix((data.reshape(-1), cols.reshape(-1), np.arange(0, 7 * n + 1, 7, dtype=np.int64)),
                             shape=(n, n))
