"""The oven self-heating on a reduced model that checks itself (thermal/reduced_steady.py).

Against the full Newton solve on the coarse test mesh (6 mm, 1 cell across), the unit in the calibration oven at
-40 °C (the study's cold end, where the radiation laws differ most from the 70 °C solve the basis starts from)
and at 20 °C: every sensor die within the check's tolerance (0.01 K) of the full solve, the check's estimate
against the true error, and the fall-back to the full solve when the check fails.
"""

from dataclasses import replace

import numpy as np
import pytest

from imutherm.imu.sensor_model import SITES
from imutherm.studies import end_to_end
from imutherm.studies.thermal.thermal_study import run_scheme
from imutherm.thermal import reduced_steady
from imutherm.thermal.assembly import assemble
from imutherm.thermal.steady import solve_steady
from imutherm.unit.model import ModelOptions, build_problem

COARSE = dict(mesh_size_mm=6.0, min_cells=1)


@pytest.fixture(scope="module", params=[("air", "s2s"), ("potted", "s2s"), ("air", "effective")],
                ids=lambda p: f"{p[0]}-{p[1]}")
def scheme(request):
    sch, law = request.param
    return run_scheme(None, sch, options=ModelOptions(cavity_law=law), **COARSE)


def _oven(res, Tc):
    geo = res.geometry
    lay = geo.layout
    lay_c = replace(lay, ambient_C=Tc, mounting=replace(lay.mounting, temperature_C=Tc))
    pb = build_problem(replace(geo, layout=lay_c), res.grid, res.options)
    return pb, assemble(pb), np.asarray(res.steady.T_C) - lay.ambient_C, {s: geo.sites[s] for s in SITES}


@pytest.mark.parametrize("Tc", [-40.0, 20.0])
def test_reduced_oven_solve_matches_the_full_solve(scheme, Tc):
    pb, asm, known, probes = _oven(scheme, Tc)
    red, chk = reduced_steady.reduced_steady(pb, asm, known, probes)
    full = solve_steady(pb, probes=probes, assembly=asm, initial_C=known + Tc)
    assert red is not None and chk.accepted and red.solver == "reduced", chk.reason
    true = np.abs(np.asarray(red.probe_C) - np.asarray(full.probe_C))
    assert true.max() <= reduced_steady.CHECK_TOL_K, true
    # the estimate is the full model's Newton step: measured within a few % of the true error; kept honest at 2x
    assert true.max() <= 2 * chk.max_site_error_K + 1e-6, (true, chk.site_error_K)
    assert np.allclose(np.abs(chk.site_error_K), true, rtol=0.5, atol=2e-4)
    assert chk.full_solves == chk.rounds and chk.full_solves < full.newton_iterations + 1
    assert red.energy_balance_rel_error < 1e-3
    # the cold oven's self-heating differs from the 70 C one by far more than the tolerance: the basis's start
    # alone would not pass
    st = scheme.steady
    warm = np.array([st.probe_C[st.probe_names.index(s)] for s in SITES]) - st.problem.ambient_C
    if Tc == -40.0 and scheme.geometry.scheme.name == "air":   # potted: no cavity radiation, 0.04 K
        assert np.abs((np.asarray(full.probe_C) - Tc) - warm).max() > 10 * reduced_steady.CHECK_TOL_K


def test_a_failed_check_returns_nothing(scheme):
    pb, asm, known, probes = _oven(scheme, -40.0)
    red, chk = reduced_steady.reduced_steady(pb, asm, known, probes, tol_K=1e-12, max_rounds=0)
    assert red is None and not chk.accepted and "estimated site error" in chk.reason and chk.rounds == 1


def test_self_heating_table_reduced_and_its_fall_back(monkeypatch):
    res = run_scheme(None, "potted", **COARSE)   # the plumbing (the accuracy: above)
    solves = []
    ch, rise = end_to_end.self_heating_table(res, (-40.0, 70.0), model="reduced", solves=solves)
    ch_f, rise_f = end_to_end.self_heating_table(res, (-40.0, 70.0), model="full")
    assert np.array_equal(ch, ch_f) and np.abs(rise - rise_f).max() <= reduced_steady.CHECK_TOL_K
    assert np.array_equal(rise[1], rise_f[1])   # 70 C is the layout's ambient: the steady solve itself
    assert [s["model"] for s in solves] == ["reduced"] and solves[0]["check"]["accepted"]
    real = reduced_steady.reduced_steady
    monkeypatch.setattr(reduced_steady, "reduced_steady",
                        lambda *a, **kw: real(*a, **dict(kw, tol_K=1e-12, max_rounds=0)))
    solves = []
    _, rise_b = end_to_end.self_heating_table(res, (-40.0, 70.0), model="reduced", solves=solves)
    assert solves[0]["model"] == "full" and not solves[0]["check"]["accepted"]
    assert np.allclose(rise_b, rise_f, atol=1e-9)
