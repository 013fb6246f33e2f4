"""The verification suite, one test per case, and the ``imutherm verify`` command in-process."""

import json

import numpy as np
import pytest

from imutherm.cli import verify as verify_cli
from imutherm.thermal import verification
from imutherm.thermal.problem import SIGMA
from imutherm.thermal.verification import board_cavity, record, steady, transient

#: case -> tolerance the suite must state (a change of tolerance is a visible change of this file)
TOLERANCES = {
    "slab_generation": 1e-8,          # nodally exact: round-off [K]
    "composite_wall": 1e-9,           # nodally exact: round-off [-]
    "transient_slab": 5e-4,           # fraction of the driving difference
    "semi_infinite": 5e-4,            # fraction of the driving difference
    "lumped_capacitance": 1e-3,       # relative (rise and t63)
    "nafems_t3": 0.02,                # K against the exact series (36.603 °C)
    "nafems_t4": 0.02,                # K against the NAFEMS 18.25 °C (60x100 mesh error ~0.007 K)
    "radiation_1d": 1e-6,             # K against the brentq root (926.967 K)
    "mms_convergence": 0.1,           # |observed L2 rate − 2|
    "orthotropic_plate": 1e-3,        # relative, centre rise
    "lumped_backward_euler": 3e-3,    # fraction of ΔT∞ at dt = τ/80 (first-order estimate 2.3e-3)
    "natural_convection_1d": 1e-6,    # K against the brentq roots (Newton tolerance)
    "lumped_trbdf2": 3e-5,            # fraction of ΔT∞ at dt = τ/40 (second-order estimate 9.4e-6 + O(Bi))
    "lumped_trbdf2_adaptive": 2.0,    # max error / tol_K (error-per-step control, measured 1.3)
    "refinement_board_cavity": 0.0,   # every effectivity in [1, 3]: the estimate brackets the converged value
}


def test_every_case_has_a_test():
    assert set(TOLERANCES) == set(verification.CASES)


@pytest.mark.parametrize("name", list(TOLERANCES))
def test_case(name):
    rec = verification.run_case(name)
    assert rec.tolerance == TOLERANCES[name]
    assert rec.note and rec.quantity
    assert rec.passed, f"{name}: error {rec.error:.3g} > tolerance {rec.tolerance:.3g}: {rec.note}"


def test_nafems_references():
    """The published targets themselves, besides the exact values the cases compare with."""
    assert verification.nafems_t3_series(0.08, 32.0) == pytest.approx(36.60, abs=0.005)
    assert verification.case_radiation_1d().computed == pytest.approx(927.0, abs=0.5)


def test_backward_euler_is_first_order():
    """θ = 1 must show order ≈ 1 (CN would give 2): computed is the finest-pair order, both pairs in the note."""
    rec = verification.case_lumped_backward_euler()
    assert 0.9 <= rec.computed <= 1.1
    assert "orders" in rec.note and "ORDER CHECK FAILED" not in rec.note
    assert rec.passed


def test_backward_euler_order_check_can_fail(monkeypatch):
    """A first-order error that does not halve with dt (order ~0) fails even if it is below the tolerance."""
    real = transient.solve_transient

    def stuck(pr, t_end, dt, **kw):
        return real(pr, t_end, t_end / 240, **kw)     # t_end = 3τ: always dt = τ/80, whatever is asked

    monkeypatch.setattr(transient, "solve_transient", stuck)
    rec = verification.case_lumped_backward_euler(divisions=(20, 40, 80))
    assert rec.error <= rec.tolerance
    assert not rec.passed and "ORDER CHECK FAILED" in rec.note


def test_trbdf2_is_second_order():
    """TR-BDF2 must show order ≈ 2 against the semi-discrete exact solution (both pairs in [1.9, 2.1])."""
    rec = verification.case_lumped_trbdf2()
    assert 1.9 <= rec.computed <= 2.1
    assert "orders" in rec.note and "ORDER CHECK FAILED" not in rec.note
    assert rec.passed


def test_trbdf2_order_check_can_fail(monkeypatch):
    """Backward Euler in place of TR-BDF2 (order 1) fails the order check."""
    real = transient.solve_transient

    def first_order(pr, t_end, dt, **kw):
        kw.pop("scheme", None)
        return real(pr, t_end, dt, scheme="theta", theta=1.0, **kw)

    monkeypatch.setattr(transient, "solve_transient", first_order)
    rec = verification.case_lumped_trbdf2()
    assert not rec.passed and "ORDER CHECK FAILED" in rec.note


def test_semi_discrete_exact_is_the_closed_form_to_lumped_model_accuracy():
    pr, tau, rise_inf, Tinf, centre, Bi = verification.lumped_block()
    t = np.linspace(0, 3 * tau, 7)
    sd = verification.semi_discrete_exact(pr, [centre])(t)[:, 0]
    assert np.abs(sd - Tinf - rise_inf * (1 - np.exp(-t / tau))).max() < 10 * Bi * rise_inf


def test_natural_convection_reference():
    """The exact end temperature satisfies the scalar balance with Holman's C = 1.32 (heated face up) and ε = 0.85."""
    k, L, T0, Ta = 0.5, 0.01, 80.0, 20.0
    rec = verification.case_natural_convection_1d()
    Ts = rec.exact
    dT = Ts - Ta
    q = 1.32 * (dT / 0.05) ** 0.25 * dT + 0.85 * SIGMA * ((Ts + 273.15) ** 4 - (Ta + 273.15) ** 4)
    assert k * (T0 - Ts) / L == pytest.approx(q, rel=1e-10)
    assert 20.0 < rec.computed < 80.0


def test_failing_case_is_recorded_not_raised(monkeypatch):
    def boom():
        raise RuntimeError("solver exploded")

    monkeypatch.setitem(verification.CASES, "slab_generation", boom)
    rec = verification.run_case("slab_generation")
    assert not rec.passed and "solver exploded" in rec.note


def test_cli_verify_writes_json_and_exits_zero(tmp_path, capsys):
    out = tmp_path / "v"
    rc = verify_cli.main(["--out", str(out), "--case", "radiation_1d", "--case", "composite_wall"])
    assert rc == 0
    text = capsys.readouterr().out
    assert "radiation_1d" in text and "PASS" in text and "2/2 cases passed" in text
    records = json.loads((out / "verify.json").read_text())
    assert [r["case"] for r in records] == ["radiation_1d", "composite_wall"]
    assert set(records[0]) >= {"case", "computed", "exact", "error", "tolerance", "pass", "note"}
    assert all(r["pass"] is True for r in records)


def test_cli_verify_exits_nonzero_on_failure(tmp_path, monkeypatch, capsys):
    def bad():
        return verification.checked("slab_generation", "x", 1.0, 2.0, 1.0, 0.1, "forced failure", 0.0)

    monkeypatch.setitem(verification.CASES, "slab_generation", bad)
    rc = verify_cli.main(["--out", str(tmp_path / "v"), "--case", "slab_generation"])
    assert rc == 1
    assert "FAIL" in capsys.readouterr().out
    assert json.loads((tmp_path / "v" / "verify.json").read_text())[0]["pass"] is False


def test_cli_verify_bad_case_is_input_error(capsys):
    assert verify_cli.main(["--case", "nope"]) == 2
    assert "unknown case" in capsys.readouterr().err


def test_cli_dispatcher_knows_verify(capsys):
    from imutherm.cli import main

    assert main(["verify", "--list"]) == 0
    assert "nafems_t4" in capsys.readouterr().out


def test_notes_state_the_figures_of_this_run():
    """A note quotes what this run computed, not figures observed once when it was written."""
    from imutherm.thermal.verification import CASES

    t3, t4, semi = CASES["nafems_t3"](), CASES["nafems_t4"](), CASES["semi_infinite"]()
    assert f"error {t3.error:.4f} K" in t3.note
    assert f"give {t4.computed:.4f} °C" in t4.note and "18.214" not in t4.note
    assert f"Observed {semi.error:.1e}" in semi.note


#: notation that carries digits but states no figure (element names, dimensions, powers, exponents)
_NOTATION = (r"Q1", r"\bL2\b", r"TR-BDF2", r"\b[123]-D\b", r"\^\(?[0-9/]+\)?", r"\(5/4\)", r"O\(1\)", r"m\^2K",
             r"\bt63\b", r"\bt95\b",
             r"\(dt/τ\)", r"dt/\(2eτ\)", r"\(dt/2τ\)")


def _note_literals():
    """(case function, literal text) of every note written in the verification package: the parts of the note
    arguments that are not formatted from a value at run time."""
    import ast
    import inspect

    tree = ast.parse("\n".join(inspect.getsource(m) for m in (verification, record, steady, transient, board_cavity)))
    out = []
    for fn in ast.walk(tree):
        if not isinstance(fn, ast.FunctionDef):
            continue
        for call in ast.walk(fn):
            if not (isinstance(call, ast.Call) and getattr(call.func, "id", None) in ("checked", "VerificationRecord")):
                continue
            note = call.args[6] if len(call.args) > 6 else next(k.value for k in call.keywords if k.arg == "note")
            out += [(fn.name, text) for text in _literal_parts(note)]
    return out


def _literal_parts(node):
    """The string constants of an expression, f-strings' format specs (``.3f``) left out."""
    import ast

    if isinstance(node, ast.Constant):
        return [node.value] if isinstance(node.value, str) else []
    if isinstance(node, ast.FormattedValue):
        return _literal_parts(node.value)
    return [t for child in ast.iter_child_nodes(node) for t in _literal_parts(child)]


def test_no_note_types_in_a_figure():
    """Every figure in a note is formatted from the run (computed, or an input the case used),
    so verify.json cannot carry a stale one. Checked on the source: the literal text of every note holds no
    digit but notation."""
    import re

    lits = _note_literals()
    assert {f for f, _ in lits} >= {f.__name__ for f in verification.CASES.values()} | {"run_case"}
    bad = []
    for fn, text in lits:
        stripped = text
        for pat in _NOTATION:
            stripped = re.sub(pat, "", stripped)
        if re.search(r"\d", stripped):
            bad.append((fn, text))
    assert not bad, f"figures typed into notes: {bad}"


def test_the_note_check_catches_a_typed_figure():
    """The check above is not vacuous: the phrases it exists for are caught."""
    import re

    for phrase in ("gives 18.214, 18.244, 18.251", "error 0.0075 K", "~30 % for"):
        stripped = phrase
        for pat in _NOTATION:
            stripped = re.sub(pat, "", stripped)
        assert re.search(r"\d", stripped), phrase
