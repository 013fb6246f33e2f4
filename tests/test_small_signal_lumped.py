"""The small-signal model of :mod:`imutherm.thermal.small_signal`: a lumped body's periodic response, and its errors.

A 10 mm cube of k = 200 W/m K (Biot number h L / k = 5e-4: lumped) losing heat by convection
h = 10 W/m^2 K on every face follows surroundings cycling at angular frequency w with the gain
g = 1 / (1 + i w tau), tau = rho c V / (h A) = 400 s (first-order lumped capacitance).
"""

import numpy as np
import pytest

from imutherm import ConvergenceError, InputError
from imutherm.thermal.assembly import assemble
from imutherm.thermal.steady import solve_steady
from imutherm.thermal.small_signal import periodic_ambient_field, tangent_operator

TAU_S = 2.4e6 * 1e-6 / (10.0 * 6e-4)   # rho c V / (h A) [s]


def _cube_assembly():
    from imutherm.geometry.grid import TensorGrid
    from imutherm.thermal.problem import Convection, ThermalProblem

    xs = np.linspace(0.0, 0.01, 5)
    grid = TensorGrid(xs, xs, xs, np.zeros((4, 4, 4), np.int32), ("box",), {})
    faces = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")
    pb = ThermalProblem(grid, 200.0, 2.4e6, 1e3, 20.0, {f: (Convection(10.0),) for f in faces})
    asm = assemble(pb)
    return asm, solve_steady(pb, assembly=asm).T_C


@pytest.mark.parametrize("period_s", [2 * TAU_S, 2 * np.pi * TAU_S, 100 * TAU_S])
def test_lumped_cube_follows_first_order_gain(period_s):
    asm, T = _cube_assembly()
    g = periodic_ambient_field(asm, T, period_s)
    exact = 1.0 / (1.0 + 1j * (2 * np.pi / period_s) * TAU_S)
    # lumped while Bi w tau << 1 (here <= 1.6e-3; at w tau = 63 the faces lead the core by ~1.5 %)
    assert np.max(np.abs(g - exact)) < 2e-3 * abs(exact)


def test_tangent_operator_conserves_heat_in_conduction():
    """A 1 is the coupling to the surroundings alone: the convection conductance h A [W/K] in total."""
    asm, T = _cube_assembly()
    A = tangent_operator(asm, T)
    assert (A @ np.ones(A.shape[0])).sum() == pytest.approx(10.0 * 6e-4, rel=1e-9)


def test_bad_period_is_input_and_no_convergence_is_convergence_error():
    asm, T = _cube_assembly()
    with pytest.raises(InputError, match="period must be > 0"):
        periodic_ambient_field(asm, T, 0.0)
    with pytest.raises(ConvergenceError, match="GMRES did not converge to rtol 1e-300"):
        periodic_ambient_field(asm, T, 400.0, rtol=1e-300)   # beyond round-off: GMRES runs out of restarts
