"""Divergence and step-count guards of the transient (divergence is not a hang: it stops with a
ConvergenceError naming the likely cause), and ConvergenceError's exit status.

:func:`imutherm.thermal.guards.check_step` is tested on its own and, once the
time loops of :mod:`imutherm.thermal.transient` call it, through real runs: a power
of 1e30 W/m^3 stops at the first step with a message naming the power (before
the guard the adaptive run stepped on at ~1e-3 s steps, a hang), and an
error-controlled run whose step stays small stops at the step cap.
"""

import sys
import warnings

import numpy as np
import pytest

from imutherm import ConvergenceError, InputError
from imutherm.thermal import guards
from imutherm.thermal.guards import ABSOLUTE_ZERO_C, DIVERGED_RISE_K, check_step

solve_mod = sys.modules.get("imutherm.thermal.solve") or __import__("imutherm.thermal.solve", fromlist=["x"])
transient_mod = sys.modules.get("imutherm.thermal.transient") or __import__("imutherm.thermal.transient",
                                                                            fromlist=["x"])
WIRED = hasattr(transient_mod, "check_step")
needs_wiring = pytest.mark.skipif(not WIRED, reason="thermal/transient.py does not call guards.check_step yet")

KW = dict(start_C=20.0, t_end=100.0, power_W=2.5)


def _cube(q_w_m3, nonlinear=False):
    """A 10 mm aluminium-like cube (k 200 W/m K, rho c 2.4e6 J/m^3 K) losing heat on every face."""
    from imutherm.geometry.grid import TensorGrid
    from imutherm.thermal.problem import Convection, Radiation, ThermalProblem

    xs = np.linspace(0.0, 0.01, 5)
    grid = TensorGrid(xs, xs, xs, np.zeros((4, 4, 4), np.int32), ("box",), {})
    laws = (Radiation(0.8), Convection(10.0)) if nonlinear else (Convection(10.0),)
    faces = ("xmin", "xmax", "ymin", "ymax", "zmin", "zmax")
    return ThermalProblem(grid, 200.0, 2.4e6, q_w_m3, 20.0, {f: laws for f in faces})


# --------------------------------------------------------------------------- the guard alone
def test_a_sane_step_passes():
    T = np.full(27, 20.0)
    T[5] = 20.0 + 0.99 * DIVERGED_RISE_K
    check_step(T, 50.0, 10, **KW)
    check_step(np.full(3, -40.0), 50.0, 10, **KW)   # a cold start is not divergence
    check_step(np.empty(0), 50.0, 1, **KW)


@pytest.mark.parametrize("bad, expect", [
    (np.nan, "non-finite temperature"),
    (np.inf, "non-finite temperature"),
    (-np.inf, "non-finite temperature"),
    (20.0 + 1.01 * DIVERGED_RISE_K, r"max \|T - T\(0\)\| = 1\.01e\+04 K"),
    (20.0 - 1.01 * DIVERGED_RISE_K, r"max \|T - T\(0\)\| = 1\.01e\+04 K"),
    (ABSOLUTE_ZERO_C - 1.0, "below absolute zero"),
])
def test_divergence_stops_naming_time_step_and_power(bad, expect):
    T = np.full(8, 25.0)
    T[3] = bad
    with pytest.raises(ConvergenceError, match=expect) as info:
        check_step(T, 12.5, 7, start_C=20.0, t_end=100.0, power_W=1e24, h=0.5)
    msg = str(info.value)
    assert "t = 12.5 s (step 7, h = 0.5 s)" in msg and "1e+24 W" in msg and "likely cause" in msg
    assert "\n" not in msg


def test_divergence_is_measured_from_the_start_field():
    start = np.array([20.0, -40.0, 85.0])
    check_step(start + 50.0, 1.0, 1, start_C=start, t_end=10.0, power_W=1.0)
    with pytest.raises(ConvergenceError, match="diverging"):
        check_step(start + np.array([0.0, 0.0, 1.5 * DIVERGED_RISE_K]), 1.0, 1, start_C=start, t_end=10.0,
                   power_W=1.0)


def test_step_cap_counts_rejected_steps():
    T = np.full(4, 30.0)
    check_step(T, 1.0, 8, rejected=2, max_steps=10, **KW)              # 10 steps: at the cap, not beyond
    with pytest.raises(ConvergenceError, match=r"8 steps \(3 rejected\) reached the limit of 10 .*raise tol_K"):
        check_step(T, 1.0, 8, rejected=3, max_steps=10, **KW)
    check_step(T, 100.0, 8, rejected=3, max_steps=10, **KW)            # the step that lands on t_end
    check_step(T, 1.0, 10**9, max_steps=None, **KW)                    # fixed steps: no cap
    assert guards.MAX_STEPS == 100_000


def test_convergence_error_is_not_bad_input():
    """A solve that fails is not bad input (an error that says what it means): its own class, caught apart
    from InputError."""
    assert not issubclass(ConvergenceError, InputError)
    assert solve_mod.ConvergenceError is ConvergenceError


# --------------------------------------------------------------------------- through the solver
@needs_wiring
@pytest.mark.parametrize("nonlinear", [False, True])
@pytest.mark.parametrize("kw", [dict(scheme="trbdf2"), dict(scheme="trbdf2", dt=1.0), dict(scheme="theta", dt=1.0),
                                dict(scheme="theta", dt=1.0, theta=0.5)], ids=["adaptive", "trbdf2", "be", "cn"])
def test_transient_of_a_power_past_physical_sense_stops_at_the_first_step(nonlinear, kw):
    from imutherm.thermal.solve import solve_transient

    sane = solve_transient(_cube(1e6, nonlinear), 60.0, **kw)   # 1 W: runs (rise ~ 1 K/min)
    assert np.isfinite(sane.T_C).all() and sane.T_C.max() > 20.0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        with pytest.raises(ConvergenceError, match=r"diverging at t = .*\(step 1, .*total 1e\+24 W"):
            solve_transient(_cube(1e30, nonlinear), 1e4, **kw)


@needs_wiring
def test_exploding_power_profile_stops_where_it_explodes():
    """A power_profile jumping to 1e24 at t = 30 s: the run stops at the first step past 30 s."""
    from imutherm.thermal.solve import solve_transient

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        with pytest.raises(ConvergenceError, match="diverging at t = .*power_profile") as info:
            solve_transient(_cube(1e6), 600.0, scheme="trbdf2", power_profile=lambda t: 1.0 if t < 30.0 else 1e24)
    t = float(str(info.value).split("at t = ")[1].split(" s")[0])
    assert 30.0 <= t < 600.0   # the first step whose end sees the jump


@needs_wiring
def test_adaptive_run_stops_at_the_step_cap(monkeypatch):
    """A power switching every 0.1 s under a 1e-6 K tolerance keeps the step small: with the cap set to
    40 steps the run stops there, naming the count, instead of taking ~1e4 steps to reach t_end."""
    from imutherm.thermal import transient

    monkeypatch.setattr(transient, "MAX_STEPS", 40)
    with pytest.raises(ConvergenceError, match=r"reached the limit of 40 .*t_end = 1000 s"):
        transient.solve_transient(_cube(1e6), 1000.0, scheme="trbdf2", tol_K=1e-6,
                          power_profile=lambda t: float(int(t / 0.1) % 2))
    monkeypatch.setattr(transient, "MAX_STEPS", 10_000)   # the same run with room: the guard is not in its way
    r = transient.solve_transient(_cube(1e6), 10.0, scheme="trbdf2", tol_K=1e-3)
    assert r.times[-1] == pytest.approx(10.0) and r.steps < 10_000


# --------------------------------------------------------------------------- the CLI's exit status
def test_cli_exit_status_of_a_solve_that_does_not_converge(capsys):
    """run_guarded: ConvergenceError -> exit status 3 and one line saying 'not converged'; InputError stays 2."""
    from imutherm.cli._common import EXIT_BAD_INPUT, EXIT_NOT_CONVERGED, run_guarded
    from imutherm.thermal.solve import solve_steady

    @run_guarded("imutherm test")
    def main(argv=None):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            solve_steady(_cube(1e30, nonlinear=True))
        return 0

    @run_guarded("imutherm test")
    def bad(argv=None):
        raise InputError("--x: bad")

    assert (EXIT_BAD_INPUT, EXIT_NOT_CONVERGED) == (2, 3)
    assert main() == 3
    err = capsys.readouterr().err
    assert err.startswith("imutherm test: not converged: solve_steady: diverging") and err.count("\n") == 1
    assert "Traceback" not in err
    assert bad() == 2
    assert capsys.readouterr().err == "imutherm test: error: --x: bad\n"
