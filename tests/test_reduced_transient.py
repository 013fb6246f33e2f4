"""The study's power-on transient on a reduced model that checks itself (thermal/reduced_transient.py).

Against the full adaptive TR-BDF2 FEM on a coarse mesh (6 mm, 1 cell across: 6.5e4 unknowns), under both
cavity laws named explicitly: every site curve within 0.05 K, every t95 within 1 % (the study's targets for
the reduced model), the check's estimate against the true error, and the fall-back to the full FEM when the check fails.
"""

import numpy as np
import pytest

from imutherm.studies.thermal.thermal_study import run_scheme
from imutherm.thermal import reduced_transient
from imutherm.unit.model import ModelOptions

COARSE = dict(mesh_size_mm=6.0, min_cells=1)


def _curve_error(red, full) -> np.ndarray:
    """Largest |reduced - full| [K] per site at the full run's step times (the reduced curve interpolated)."""
    ra = np.column_stack([np.interp(full.times, red.times, red.probe_C[:, j]) for j in range(red.probe_C.shape[1])])
    return np.abs(ra - np.asarray(full.probe_C)).max(axis=0)


def _pair(law: str, **kw):
    opts = ModelOptions(cavity_law=law)
    red = run_scheme(None, "air", options=opts, transient=True, transient_model="reduced", **COARSE, **kw)
    full = run_scheme(None, "air", options=opts, transient=True, transient_model="full", **COARSE, **kw)
    return red, full


@pytest.fixture(scope="module")
def short_effective():
    """The first 120 s (where the curves bend most) under the effective cavity law."""
    return _pair("effective", t_end=120.0)


def test_reduced_first_minutes_match_the_full_fem_effective_law(short_effective):
    red, full = short_effective
    chk = red.transient_check
    assert chk is not None and chk.accepted and red.transient.scheme == "reduced"
    assert full.transient.scheme == "trbdf2" and full.transient_check is None
    err = _curve_error(red.transient, full.transient)
    assert err.max() <= 0.05, err
    assert chk.max_site_error_K <= reduced_transient.CHECK_TOL_K
    # a tenth of the full model's linear solves
    assert chk.full_solves < full.transient.linear_solves / 2


def test_reduced_result_reads_like_a_transient(short_effective):
    red, _ = short_effective
    tr = red.transient
    assert tr.times[0] == 0.0 and np.all(np.diff(tr.times) > 0) and tr.times[-1] == pytest.approx(120.0)
    assert tr.probe_C.shape == (len(tr.times), len(tr.probe_names))
    assert np.allclose(tr.probe_C[0], red.steady.problem.ambient_C)   # power-on from the ambient
    assert tr.energy_balance_rel_error < 1e-3
    from imutherm.studies.thermal.thermal_study import result_summary
    s = result_summary(red)
    assert s["transient_model"] == "reduced" and s["transient_check"]["accepted"]


def test_a_failed_check_returns_nothing():
    """A tolerance the basis cannot meet, no enrichment: the check says so (and the caller runs the full FEM)."""
    res = run_scheme(None, "air", options=ModelOptions(cavity_law="effective"), **COARSE)
    from imutherm.thermal.assembly import assemble
    pb = res.steady.problem
    tr, chk = reduced_transient.reduced_power_on(pb, assemble(pb), res.steady, dict(res.geometry.sites), 120.0,
                                                 tol_K=1e-9, max_rounds=0)
    assert tr is None and not chk.accepted and "estimated site error" in chk.reason
    assert chk.max_site_error_K > 1e-9 and chk.rounds == 1


@pytest.mark.slow
def test_a_heat_flux_law_is_accounted_on_its_face_nodes():
    """A radiant load on the lid (a HeatFlux law, the correlation campaign's out-of-library kind): the reduced
    transient's energy account scatters each flux law's nodal loads to its face's nodes (it multiplied them into a
    vector of all the nodes and failed on the shapes) and balances."""
    from dataclasses import replace
    from imutherm.thermal.assembly import assemble
    from imutherm.thermal.problem import HeatFlux
    from imutherm.thermal.steady import solve_steady
    res = run_scheme(None, "air", options=ModelOptions(cavity_law="effective"), **COARSE)
    pb = res.steady.problem
    pb = replace(pb, boundary={**pb.boundary, "zmax": tuple(pb.boundary["zmax"]) + (HeatFlux(300.0),)})
    asm = assemble(pb)
    sites = dict(res.geometry.sites)
    st = solve_steady(pb, probes=sites, assembly=asm)
    tr, chk = reduced_transient.reduced_power_on(pb, asm, st, sites, 120.0)
    assert chk.accepted and tr is not None, chk.reason
    assert asm.flux_in_W > 0 and tr.energy_balance_rel_error < 1e-3


def test_run_scheme_falls_back_to_the_full_fem(monkeypatch):
    calls = []
    real = reduced_transient.reduced_power_on

    def failing(*a, **kw):
        calls.append(1)
        return real(*a, **dict(kw, tol_K=1e-9, max_rounds=0))
    monkeypatch.setattr(reduced_transient, "reduced_power_on", failing)
    res = run_scheme(None, "air", options=ModelOptions(cavity_law="effective"), transient=True, t_end=30.0,
                     transient_model="reduced", **COARSE)
    assert calls and res.transient.scheme == "trbdf2" and not res.transient_check.accepted


def test_given_steps_always_run_the_full_fem():
    res = run_scheme(None, "air", options=ModelOptions(cavity_law="effective"), transient=True, t_end=4.0, dt=2.0,
                     transient_model="reduced", **COARSE)
    assert res.transient.scheme == "trbdf2" and res.transient.steps == 2 and res.transient_check is None


def test_unknown_transient_model_is_refused():
    from imutherm import InputError
    with pytest.raises(InputError, match="transient model must be one of full, reduced"):
        run_scheme(None, "air", transient=True, transient_model="fast", **COARSE)


def test_compare_full_flag(monkeypatch, tmp_path):
    """``imutherm compare --thermal-only``: reduced transients by default, ``--full`` the full FEM."""
    from imutherm.cli import compare
    seen = []

    def fake(layout, schemes, **kw):
        seen.append(kw.get("transient_model"))
        raise SystemExit(0)
    monkeypatch.setattr(compare, "compare_schemes", fake)
    for extra, want in (([], "reduced"), (["--full"], "full")):
        with pytest.raises(SystemExit):
            compare.main(["--thermal-only", "--schemes", "air", "--mesh-size", "6", "--out", str(tmp_path / want)]
                         + extra)
        assert seen[-1] == want
    assert compare.main(["--steady-only", "--full", "--out", str(tmp_path / "s")]) == 2


@pytest.mark.slow
@pytest.mark.parametrize("law", ["effective", "s2s"])
def test_reduced_power_on_to_settled_matches_the_full_fem(law):
    """The whole power-on transient, settled, under each cavity law: curves within 0.05 K, t95 within 1 %, the
    curves end on the full steady state, and the check's estimate is not below the true error by more than 2x."""
    red, full = _pair(law, t_end=2400.0, until_settled=True)
    chk = red.transient_check
    assert chk.accepted, chk.reason
    err = _curve_error(red.transient, full.transient)
    assert err.max() <= 0.05, err
    for n in red.transient.probe_names:
        a, b = red.metrics.t95_s[n], full.metrics.t95_s[n]
        assert abs(a - b) <= 0.01 * b, (n, a, b)
    end = red.transient.probe_C[-1]
    steady = np.asarray(red.steady.probe_C)
    assert np.abs(end - steady).max() <= 0.005 * np.abs(steady - red.steady.problem.ambient_C).max()
    assert err.max() <= 2 * chk.max_site_error_K + 0.02   # the full run's own time error is ~0.01-0.02 K


def test_the_shifted_operator_is_a_plus_s_m():
    """A + s M formed once on the shared pattern (s2s: sparse plus the exchange's low-rank term) is the same
    operator as its terms applied one by one, for the shifts of the basis and of the check."""
    from imutherm.thermal.assembly import assemble
    from imutherm.thermal.reduced import SparsePlusLowRank, linearised

    run = run_scheme(None, "air", **COARSE)
    asm = assemble(run.steady.problem)
    A, _ = linearised(asm, np.asarray(run.steady.T_C))
    assert isinstance(A, SparsePlusLowRank)
    x = np.random.default_rng(3).standard_normal(asm.n)
    for s in (1.0 / 0.1, 1.0 / 50.0, 1e-3):
        op = reduced_transient._Shifted(A, asm.M, s)
        assert op.sparse is not None
        ref = A @ x + s * (asm.M @ x)
        assert np.abs(op @ x - ref).max() <= 1e-12 * np.abs(ref).max()
