"""Extension by attribute, not by name: no package module compares an effect's, a cavity law's or a filter's
name to a string literal outside the module that registers it.

An effect's role is read from its :class:`~imutherm.unit.effects.Effect` fields (``kind``, ``ambient_rate``,
``carried``, ...), a cavity law's from its :class:`~imutherm.unit.cavity_laws.CavityLaw` capabilities, a filter's
from its :class:`~imutherm.imu.filters.registry.FilterSpec`; so adding one is one entry beside its code. Every
module of the package is read with :mod:`ast` (nothing is run): a comparison (``==``, ``!=``, ``in``, ``not in``)
or a ``startswith`` with a registered name as a string literal (alone or in a tuple, list or set) is a
violation, unless the module is one of the registries (:data:`REGISTRIES`).
"""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ("imutherm", "geometry", "ecad", "imu", "layouts", "thermal", "unit", "studies", "reports", "cli")
#: the modules that register effects, cavity laws and filters: each may name its own entries
REGISTRIES = {"unit/effects/model_effects.py", "unit/effects/signal_effects.py",
              "unit/cavity_laws.py", "imu/filters/registry.py", "imu/filters/gated.py",
              "imu/filters/gravity_kf.py", "imu/filters/fusion_peer.py", "imu/filters/aekf.py",
              "imu/filters/peers.py"}
#: (module, literal) pairs where the literal is another thing that happens to share a registered name
NOT_A_NAME = {
    ("ecad/classify.py", "power"): "a footprint's class (a power part), not the power effect",
    ("studies/sweep/keys.py", "emissivity"): "part of a model option's field name (its unit is '-')",
    ("studies/sweep/keys.py", "power"): "a sweep key's kind in a reduced model (its transform), not the effect",
    ("studies/sweep/keys.py", "contact"): "a sweep key's kind in a reduced model (its transform), not the effect",
    ("studies/sweep/surrogate.py", "power"): "a sweep key's kind (keys.key_kind), not the effect",
    ("studies/sweep/surrogate.py", "contact"): "a sweep key's kind (keys.key_kind), not the effect",
}


def registered_names() -> dict:
    """kind -> the registered names (effects with their ``name@`` prefixes, cavity laws, filters)."""
    from imutherm.imu.filters.registry import REGISTRY
    from imutherm.unit.cavity_laws import CAVITY_LAWS, NO_CAVITY_RADIATION
    from imutherm.unit.effects import EFFECTS

    # 'none' (the law of a cavity without radiation) is also the word for nothing everywhere (a verdict, an
    # option's value): the law is read through cavity_law_of, and no module needs its name
    return {"effect": set(EFFECTS) | {f"{n}@" for n, e in EFFECTS.items() if e.targets},
            "cavity law": set(CAVITY_LAWS) - {NO_CAVITY_RADIATION}, "filter": set(REGISTRY)}


def _literals(node) -> list:
    if isinstance(node, ast.Constant) and isinstance(node.value, str):
        return [node.value]
    if isinstance(node, (ast.Tuple, ast.List, ast.Set)):
        return [x for e in node.elts for x in _literals(e)]
    return []


def name_tests(source: str, names: dict) -> list:
    """(line, kind, literal) of every comparison or ``startswith`` of a registered name as a literal."""
    out = []
    for node in ast.walk(ast.parse(source)):
        lits = []
        if isinstance(node, ast.Compare) and all(isinstance(op, (ast.Eq, ast.NotEq, ast.In, ast.NotIn))
                                                 for op in node.ops):
            sides = [node.left] + node.comparators
            # ``"x" in obj``: the literal is compared; ``obj in ("a", "b")``: each element is
            lits = [x for s in sides for x in _literals(s)]
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
              and node.func.attr in ("startswith", "endswith") and node.args):
            lits = _literals(node.args[0])
        for lit in lits:
            for kind, known in names.items():
                if lit in known:
                    out.append((node.lineno, kind, lit))
    return out


def test_no_module_tests_a_registered_name():
    names = registered_names()
    bad = []
    for layer in PACKAGE:
        for path in sorted((ROOT / layer).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if rel in REGISTRIES:
                continue
            bad += [f"{rel}:{line} compares the {kind} name {lit!r}"
                    for line, kind, lit in name_tests(path.read_text(encoding="utf-8"), names)
                    if (rel, lit) not in NOT_A_NAME]
    assert bad == []


def test_the_check_sees_a_name_test():
    """The reader finds each form of a name test, and passes over a name that is only a key or an argument."""
    names = {"effect": {"ambient_drift", "power@"}, "cavity law": {"s2s"}, "filter": {"kf"}}
    src = ("a = e.base == 'ambient_drift'\nb = law in ('effective', 's2s')\nc = n.startswith('power@')\n"
           "d = 'kf' not in chosen\ne = {'s2s': 1}\nf = run('kf')\n")
    assert name_tests(src, names) == [(1, "effect", "ambient_drift"), (2, "cavity law", "s2s"),
                                      (3, "effect", "power@"), (4, "filter", "kf")]


def test_each_cavity_law_does_what_its_entry_says(tmp_path):
    """The capabilities of every registered law, against what the model does with it (reference unit, air, a
    10 mm mesh): ``patches`` <-> the problem has an interior exchange <-> the CalculiX export refuses the
    problem; ``blendable`` <-> ``cavity_law_blend`` is accepted; ``conductivity_share`` > 0 <-> the
    air conducts more than without cavity radiation (a linear exterior, as the export needs)."""
    import numpy as np
    import pytest

    from imutherm import InputError
    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.layout import load_layout
    from imutherm.geometry.mesh import build_mesh
    from imutherm.thermal.calculix import write_ccx_deck
    from imutherm.unit.cavity_laws import CAVITY_LAWS
    from imutherm.unit.model import ModelOptions, build_problem

    geo = build_geometry(load_layout(None), "air")
    grid = build_mesh(geo, 10.0, 1)
    air = (grid.cell_part == grid.part_names.index("fill")).ravel()
    linear = dict(exterior="fixed", h_fixed_W_m2K=10.0, radiation=False)  # what CalculiX takes outside
    k_off = build_problem(geo, grid, ModelOptions(cavity_radiation=False, **linear)).k[air]
    for name, law in CAVITY_LAWS.items():
        pb = build_problem(geo, grid, ModelOptions(cavity_law=name, **linear))
        assert bool(pb.exchanges) == law.patches, name
        assert bool(np.any(pb.k[air] > k_off)) == (law.conductivity_share > 0), name
        if not law.patches:
            write_ccx_deck(pb, tmp_path / f"{name}.inp")
        else:
            with pytest.raises(InputError):
                write_ccx_deck(pb, tmp_path / f"{name}.inp")
        if law.blendable:
            ModelOptions(cavity_law=name, cavity_law_blend=0.5)
        else:
            with pytest.raises(InputError, match="cavity_law_blend"):
                ModelOptions(cavity_law=name, cavity_law_blend=0.5)


def test_a_law_registered_here_is_built_by_the_model_through_its_hook():
    """A new cavity law is one registration: its build hook is what the unit model applies (reference unit, air,
    a 10 mm mesh): a law adding half the effective conductivity and half the patch exchange gives the air half
    the effective law's extra conductivity and the s2s exchange at half its X; a cavity not of air calls no hook."""
    import numpy as np

    from imutherm.geometry.build import build_geometry
    from imutherm.geometry.layout import load_layout
    from imutherm.geometry.mesh import build_mesh
    from imutherm.unit.cavity_laws import CAVITY_LAWS, CavityTerms, register_cavity_law
    from imutherm.unit.model import ModelOptions, build_problem

    seen = []

    def half_of_each(law, setting):
        seen.append((law.name, setting.options.cavity_law, setting.blend))
        return CavityTerms(0.5, (setting.exchange().scaled(0.5),))

    geo = build_geometry(load_layout(None), "air")
    grid = build_mesh(geo, 10.0, 1)
    air = (grid.cell_part == grid.part_names.index("fill")).ravel()
    register_cavity_law("test_half", "half the effective law and half the s2s exchange (this test's)",
                        build=half_of_each)
    try:
        pb = build_problem(geo, grid, ModelOptions(cavity_law="test_half"))
        potted = build_problem(build_geometry(load_layout(None), "potted"), grid, ModelOptions(cavity_law="test_half"))
    finally:
        CAVITY_LAWS.pop("test_half")
    off = build_problem(geo, grid, ModelOptions(cavity_radiation=False))
    eff = build_problem(geo, grid, ModelOptions(cavity_law="effective"))
    s2s = build_problem(geo, grid, ModelOptions(cavity_law="s2s"))
    assert seen == [("test_half", "test_half", 0.0)]   # called once, for the air scheme only
    assert potted.exchanges == ()
    assert np.any(eff.k[air] > off.k[air])
    np.testing.assert_allclose(pb.k[air] - off.k[air], 0.5 * (eff.k[air] - off.k[air]), rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(pb.k[~air], off.k[~air])
    (ex,), (ex_s2s,) = pb.exchanges, s2s.exchanges
    np.testing.assert_allclose(ex.X, 0.5 * ex_s2s.X, rtol=1e-12)


def test_the_cavity_law_help_is_read_from_the_registry(monkeypatch):
    """``--cavity-law``'s choices and help come from the registry when the parser is built: a law registered
    beside its code is offered with its words, and the default is the one ``ModelOptions`` applies."""
    import argparse

    from imutherm.cli._options import add_model_arguments
    from imutherm.unit import cavity_laws
    from imutherm.unit.model import ModelOptions

    monkeypatch.setattr(cavity_laws, "CAVITY_LAWS", dict(cavity_laws.CAVITY_LAWS))
    cavity_laws.register_cavity_law("test_law", "a law registered by this test (no physics)")
    parser = argparse.ArgumentParser()
    add_model_arguments(parser)
    action = next(a for a in parser._actions if "--cavity-law" in a.option_strings)
    assert action.choices == tuple(cavity_laws.CAVITY_LAWS) and "test_law" in action.choices
    assert action.default == ModelOptions().cavity_law == cavity_laws.DEFAULT_CAVITY_LAW
    for name, law in cavity_laws.CAVITY_LAWS.items():
        marked = f"{name} (default): " if name == action.default else f"{name}: "
        assert f"{marked}{law.words}" in action.help, name
    assert action.help.count("(default)") == 1
