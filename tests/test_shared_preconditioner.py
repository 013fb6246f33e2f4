"""One preconditioner per unit (issue 59 item 1): the steady solve's is reused by the reduced transient's basis,
the oven's reduced steady check and the mesh-error estimate's coarse level, instead of a new setup each; the
answers those solves give are the same to their solves' tolerances."""

import numpy as np
import pytest

from imutherm.geometry.layout import load_layout
from imutherm.studies.end_to_end import thermal as thermal_mod
from imutherm.studies.thermal.thermal_study import mesh_error, run_scheme
from imutherm.thermal import linear, reduced_steady, reduced_transient
from imutherm.unit.model import ModelOptions

KW = dict(mesh_size_mm=6.0, min_cells=1, t_end=300.0, transient_model="reduced")


@pytest.fixture
def setups(monkeypatch):
    """Counts of new AMG hierarchies by the module that sets them up (``linear``: the steady solve's own and the
    mesh-error estimate's coarse level, which imports it from there when it runs)."""
    counts = {}
    real = linear.amg_preconditioner

    def counting(name):
        def amg(A):
            counts[name] = counts.get(name, 0) + 1
            return real(A)
        return amg
    for mod in (reduced_steady, reduced_transient, linear):
        monkeypatch.setattr(mod, "amg_preconditioner", counting(mod.__name__.rsplit(".", 1)[1]))
    return counts


def test_the_thermal_case_sets_up_once(setups):
    # without the sharing: linear 2 (the steady solve's and the estimate's coarse level), reduced_steady 1,
    # reduced_transient 2
    res, _, _, oven = thermal_mod.thermal_case(load_layout(None), "potted", ModelOptions(), (-40.0, 70.0),
                                               estimate_mesh_error=True, **KW)
    assert res.steady.solver == "amg" and oven[0]["model"] == "reduced" and res.mesh_error is not None
    # left: the steady solve's own (the reduced transient's shifted one, A + M / 0.3 s, on its aggregates: amg_like)
    assert setups.get("reduced_steady", 0) == 0 and setups.get("linear", 0) == 1
    assert setups.get("reduced_transient", 0) == 0


def test_the_shared_preconditioner_gives_the_same_answers():
    kept = {}
    res = run_scheme(load_layout(None), "potted", transient=True, keep=kept, **KW)
    pc = kept["preconditioner"]
    assert pc is not None
    own, shared = mesh_error(res), mesh_error(res, coarse_pc=pc)
    # the refined CG stops at 1e-3 of the prolonged field's residual: ~1e-3 K at the sites
    assert np.abs(own.fine_C - shared.fine_C).max() < 2e-3
    assert np.abs(own.answer_error_K - shared.answer_error_K).max() < 2e-3
    plain = run_scheme(load_layout(None), "potted", transient=True, **KW)
    assert np.abs(np.asarray(plain.transient.probe_C) - np.asarray(res.transient.probe_C)).max() < 5e-3


def test_the_oven_takes_the_volume_assembly():
    """The unit at another ambient (the calibration oven) on the same grid: only the boundary is assembled, and
    the assembly is the one made from scratch, bit for bit."""
    from dataclasses import replace

    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.mesh import build_mesh
    from imutherm.thermal.assembly import assemble
    from imutherm.unit.model import build_problem

    geo = build_geometry(load_layout(None), "potted")
    grid = build_mesh(geo, 6.0, 1)
    asm = assemble(build_problem(geo, grid, ModelOptions()))
    lay = geo.layout
    cold = replace(lay, ambient_C=-40.0, mounting=replace(lay.mounting, temperature_C=-40.0))
    pb = build_problem(replace(geo, layout=cold), grid, ModelOptions())
    own, shared = assemble(pb), assemble(pb, like=asm)
    assert shared.K_data is asm.K_data and shared.M_data is asm.M_data
    for name in ("K_data", "H_data", "M_data", "F_q", "F_bc"):
        assert np.array_equal(getattr(own, name), getattr(shared, name)), name
    assert [bc.T_ref for bc in own.nonlinear] == [bc.T_ref for bc in shared.nonlinear]
    # another material is another volume: assembled from scratch
    other = build_problem(geo, grid, ModelOptions(cavity_law="effective"))
    hot = replace(other, k=other.k * 1.5)
    assert assemble(hot, like=asm).K_data is not asm.K_data
