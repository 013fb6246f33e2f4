"""The small-signal operator and the periodic response to cycling surroundings, with and without the s2s
exchange, against finite differences of the nonlinear model and against time stepping."""

import dataclasses

import numpy as np
import pytest
from scipy.linalg import lu_factor, lu_solve

from imutherm import InputError
from imutherm.geometry.grid import TensorGrid
from imutherm.thermal.assembly import assemble, node_ids
from imutherm.thermal.cavity_radiation import cavity_exchange
from imutherm.thermal.problem import Contact, FixedTemperature, NaturalConvection, Radiation, ThermalProblem
from imutherm.thermal.small_signal import periodic_ambient_field, tangent_operator
from imutherm.thermal.solve import solve_steady


def _box(exchange=True):
    """A 0.4 W block in a 30 x 30 x 15 mm air box of 2 mm aluminium walls: natural convection and
    radiation (eps 0.85) on the sides and the top, the base on a fixture at 70 C through 500 W/m^2 K
    (the reference unit's laws, on a box small enough to solve densely)."""
    def axis(L, k):
        return np.concatenate([[0.0], 0.002 + np.linspace(0.0, L, k + 1), [L + 0.004]])
    xs, ys, zs = axis(0.03, 6), axis(0.03, 6), axis(0.015, 6)
    cp = np.zeros((len(xs) - 1, len(ys) - 1, len(zs) - 1), int)
    cp[1:-1, 1:-1, 1:-1] = 1
    cp[3:5, 3:5, 3:5] = 2
    g = TensorGrid(xs, ys, zs, cp, ("wall", "air", "block"), {})
    air = g.cell_part == 1
    k = np.array([167.0, 0.03, 20.0])[g.cell_part]
    rc = np.array([2.4e6, 1.2e3, 2.0e6])[g.cell_part]
    vol = g.cell_volumes()
    q = np.where(g.cell_part == 2, 0.4 / vol[g.cell_part == 2].sum(), 0.0)
    side = (NaturalConvection("vertical", 0.019), Radiation(0.85))
    bnd = {f: side for f in ("xmin", "xmax", "ymin", "ymax")}
    bnd["zmax"] = (NaturalConvection("up", 0.0085), Radiation(0.85))
    bnd["zmin"] = (Contact(500.0, 70.0),)
    ex = (cavity_exchange(g, air, [0.84, 0.9, 0.9], patch_mm=5.0, rays=128, rng=np.random.default_rng(4)),)
    return ThermalProblem(g, k, rc, q, 70.0, bnd, ex if exchange else ())


def _shifted(pb, d):
    """The problem with the ambient and every law's own reference temperature moved by ``d`` [K]."""
    bnd = {f: tuple(dataclasses.replace(law, T_C=law.T_C + d) if getattr(law, "T_C", None) is not None else law
                    for law in laws) for f, laws in pb.boundary.items()}
    return dataclasses.replace(pb, ambient_C=pb.ambient_C + d, boundary=bnd)


@pytest.fixture(scope="module", params=[True, False], ids=["s2s", "no-exchange"])
def case(request):
    pb = _box(request.param)
    asm = assemble(pb)
    return pb, asm, solve_steady(pb, assembly=asm, tol=1e-12).T_C


def test_tangent_is_the_derivative_of_the_heat_balance(case):
    """A v equals the central difference of the nonlinear heat balance K T + H T + N(T) (convection,
    radiation, the s2s exchange's sigma T^4) to 1e-7: the exchange's dense Jacobian is exact."""
    pb, asm, T = case
    A = tangent_operator(asm, T)
    L = asm.K + asm.H

    def balance(x):
        return L @ x + asm.nonlinear_flux(x)[0]

    v = np.random.default_rng(0).standard_normal(asm.n)
    eps = 1e-3
    fd = (balance(T + eps * v) - balance(T - eps * v)) / (2 * eps)
    Av = A @ v
    assert np.linalg.norm(Av - fd) < 1e-7 * np.linalg.norm(Av)
    assert bool(A.exchanges) == bool(pb.exchanges)
    # the complex product is the real one on each part
    w = v + 1j * np.roll(v, 1)
    assert np.allclose(A @ w, (A @ v) + 1j * (A @ np.roll(v, 1)), rtol=0, atol=1e-12 * np.abs(Av).max())


def test_slow_cycle_response_is_the_steady_sensitivity_to_the_surroundings(case):
    """At a very long period the unit's gain is d T_steady / d T_surroundings, from two nonlinear steady
    solves with the ambient and the fixture moved by +-0.5 K (agreement 1e-6). Under s2s the block
    follows by less than 1 K per K: a warmer enclosure radiates its internal rise away more easily
    (sigma T^4), which a shift-invariant operator (g = 1) would miss."""
    pb, asm, T = case
    g = periodic_ambient_field(asm, T, 1e10)
    d = 0.5
    fd = (solve_steady(_shifted(pb, d), tol=1e-12).T_C - solve_steady(_shifted(pb, -d), tol=1e-12).T_C) / (2 * d)
    assert np.max(np.abs(g - fd)) < 1e-6
    block = node_ids(pb.grid)[3:6, 3:6, 3:6].ravel()   # the block's nodes
    if pb.exchanges:
        assert 1.0 - np.real(g[block]).mean() > 2e-3      # the T^4 effect, of the size the FD gives
    assert np.all(np.real(g) < 1.0 + 1e-9)


def test_periodic_response_matches_time_stepping(case):
    """Started on its own orbit, Crank-Nicolson time stepping of the linearised model (the tangent,
    solved densely) stays on Re[g e^{i w t}] over one 300 s period within 0.5 % of the amplitude."""
    pb, asm, T = case
    period = 300.0
    x = periodic_ambient_field(asm, T, period, rtol=1e-12)
    A = tangent_operator(asm, T)
    n = asm.n
    Ad = np.column_stack([A @ e for e in np.eye(n)])
    M = asm.M.toarray()
    c = A.coupling
    w = 2 * np.pi / period
    n_steps = 300
    dt = period / n_steps
    lu, rhs_m = lu_factor(M / dt + Ad / 2), M / dt - Ad / 2
    y = np.real(x).copy()
    err = 0.0
    for k in range(n_steps):
        t0, t1 = k * dt, (k + 1) * dt
        y = lu_solve(lu, rhs_m @ y + c * (np.cos(w * t0) + np.cos(w * t1)) / 2)
        err = max(err, np.max(np.abs(y - np.real(x * np.exp(1j * w * t1)))))
    amp = np.max(np.abs(x))
    assert 0.05 < amp <= 1.0 + 1e-9
    assert err < 5e-3 * amp, (err, amp)


def test_fixed_temperature_faces_are_refused():
    pb = _box(False)
    bnd = dict(pb.boundary, zmin=(FixedTemperature(70.0),))
    pb = dataclasses.replace(pb, boundary=bnd)
    asm = assemble(pb)
    with pytest.raises(InputError, match="fixed-temperature"):
        tangent_operator(asm, np.full(asm.n, 70.0))


def test_a_bad_period_is_refused(case):
    _, asm, T = case
    with pytest.raises(InputError, match="period"):
        periodic_ambient_field(asm, T, 0.0)
