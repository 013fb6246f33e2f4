"""The fixture-capacity estimate (benchmarks/rig_heat_capacity.py, the helper of bench_fixture_capacity.py; no package
module uses it) against the analytic lumped solutions."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from imutherm import InputError

_SPEC = importlib.util.spec_from_file_location(
    "rig_heat_capacity", Path(__file__).resolve().parents[1] / "benchmarks" / "rig_heat_capacity.py")
rig = sys.modules.setdefault("rig_heat_capacity", importlib.util.module_from_spec(_SPEC))   # dataclasses need it
_SPEC.loader.exec_module(rig)
fixture_response, fixture_theta, t95 = rig.fixture_response, rig.fixture_theta, rig.t95


def test_step_response_is_the_first_order_exponential():
    """u = 1: theta = Q/G (1 - exp(-t G/C)) exactly, on any grid (G = G_b + G_f)."""
    t = np.concatenate([[0.0], np.geomspace(0.1, 20000.0, 60)])
    Q, Gb, Gf, C = 1.5, 1.2, 0.5, 800.0
    theta = fixture_theta(t, np.ones_like(t), Q, Gb, C, Gf)
    exact = Q / (Gb + Gf) * (1 - np.exp(-t * (Gb + Gf) / C))
    assert np.max(np.abs(theta - exact)) < 1e-12


def test_ramp_response_is_exact_for_piecewise_linear_forcing():
    """u = t/T up to T then 1: theta' = b u - a theta solved by hand, on a coarse uneven grid."""
    T, Q, G, C = 300.0, 2.0, 0.8, 500.0
    a, b = G / C, Q / C
    t = np.array([0.0, 37.0, 150.0, 300.0, 1000.0, 4000.0])
    u = np.minimum(t / T, 1.0)
    ramp = lambda x: b / T * (x / a - (1 - np.exp(-a * x)) / a**2)          # noqa: E731
    exact = np.where(t <= T, ramp(t), ramp(T) * np.exp(-a * (t - T)) + b / a * (1 - np.exp(-a * (t - T))))
    assert np.max(np.abs(fixture_theta(t, u, Q, 0.0, C, G) - exact)) < 1e-12


def test_sites_add_their_sensitivity_times_the_fixture_rise():
    t = np.linspace(0.0, 5000.0, 501)
    fast = 20.0 * (1 - np.exp(-t / 100.0))
    r = fixture_response(t, {"tp1": fast}, 1 - np.exp(-t / 100.0), 1.5, 1.0, {"tp1": 0.9}, 1000.0, 0.5)
    assert r.theta_steady_K == pytest.approx(1.0) and r.rise_steady_K["tp1"] == pytest.approx(fast[-1] + 0.9)
    assert r.tau_s == pytest.approx(1000.0 / 1.5)
    assert np.allclose(r.rise_K["tp1"], fast + 0.9 * r.theta_K)
    # the slow mode moves t95 far past the unit's own (300 s for the 100 s exponential)
    assert t95(t, fast, 20.0) == pytest.approx(-100.0 * np.log(0.05), rel=1e-3)
    assert t95(t, r.rise_K["tp1"], r.rise_steady_K["tp1"]) > t95(t, fast, 20.0) + 50.0   # 380 s


def test_bad_grid_is_refused():
    with pytest.raises(InputError, match="times must start at 0"):
        fixture_theta([1.0, 2.0], [0.0, 1.0], 1.0, 1.0, 1.0, 1.0)
    with pytest.raises(InputError, match="C_f"):
        fixture_theta([0.0, 1.0], [0.0, 1.0], 1.0, 1.0, 0.0, 1.0)
