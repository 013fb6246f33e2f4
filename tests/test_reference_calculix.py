"""Independent cross-check on the reference unit: CalculiX on the same (coarse) mesh, linear laws.

The unit's mesh, materials (orthotropic boards, via fields, lid joint, cavity
radiation as conductivity: the ``effective`` law, since the s2s exchange is not
exported to CalculiX), die powers, fixed-h exterior convection and the
fixture contact are exported as a ``*HEAT TRANSFER`` deck; nodal temperatures
must agree within 0.01 K. Runs in CI (fails rather than skips there when
``ccx`` is missing).
"""

import os

import numpy as np
import pytest

from imutherm.geometry.build import build_geometry
from imutherm.geometry.mesh import build_mesh
from imutherm.thermal.calculix import ccx_executable, run_ccx
from imutherm.unit.model import ModelOptions, build_problem
from imutherm.thermal.solve import solve_steady


def test_reference_unit_agrees_with_calculix():
    if ccx_executable() is None:
        if os.environ.get("CI"):
            pytest.fail("CalculiX 'ccx' is required in CI (apt-get install calculix-ccx)")
        pytest.skip("CalculiX 'ccx' not installed")
    g = build_geometry(None, "grease")
    grid = build_mesh(g, max_cell_mm=6.0, min_cells=1)
    problem = build_problem(g, grid, ModelOptions(exterior="fixed", h_fixed_W_m2K=10.0, radiation=False,
                                                   cavity_law="effective"))
    ours = solve_steady(problem, tol=1e-12, rtol=1e-12)
    theirs = run_ccx(problem)
    assert theirs.shape == ours.T_C.shape
    rise = ours.T_C.max() - problem.ambient_C
    assert rise > 5.0  # a real problem, not a flat field
    assert np.max(np.abs(theirs - ours.T_C)) < 0.01
