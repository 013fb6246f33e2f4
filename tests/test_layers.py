"""The package's layers point one way: base -> geometry -> ecad (board files into layouts), imu -> thermal (the FEM
core) -> unit (the unit model) -> studies -> reports -> cli.

Every ``import`` of every module, at the top or inside a function (a hidden upward import is still a
cycle), is read with :mod:`ast`; nothing is imported or run. A module's layer is its top folder
(``imutherm/`` is the base package). ``thermal/model.py``, ``effects.py`` and ``knobs.py`` are façades
that keep the unit model's old import paths alive (:data:`FACADES`): they are the unit layer's, not the FEM
core's. The study scripts (``studies/study_*.py``, run as ``python -m``) are
entry points like the CLI and may write the report.
"""

import ast
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("imutherm", "geometry", "ecad", "imu", "layouts", "thermal", "unit", "studies", "reports", "cli")
#: what each layer must not import
FORBIDDEN = {
    "imutherm": {"geometry", "ecad", "imu", "thermal", "unit", "studies", "reports", "cli"},
    "geometry": {"ecad", "imu", "thermal", "unit", "studies", "reports", "cli"},
    "ecad": {"imu", "thermal", "unit", "studies", "reports", "cli"},
    "imu": {"geometry", "ecad", "thermal", "unit", "studies", "reports", "cli"},
    "thermal": {"ecad", "imu", "unit", "studies", "reports", "cli"},
    "unit": {"imu", "studies", "reports", "cli"},
    "studies": {"reports", "cli"},
    "reports": {"cli"},
}
ENTRY_POINTS = {"studies/study_reference.py", "studies/study_cardguide.py", "studies/study.py"}
#: the unit model's old homes in thermal/: each only re-exports its module of unit/
FACADES = {"thermal/model.py", "thermal/effects.py", "thermal/knobs.py"}


def imports_of(path: Path):
    """(line, imported layer, module name) of every imutherm import in ``path``."""
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            # ``from imutherm import studies`` imports the layer named after the dot
            names = [f"{node.module}.{a.name}" for a in node.names] if node.module == "imutherm" else [node.module]
        else:
            continue
        for name in names:
            parts = name.split(".")
            if parts[0] == "imutherm":
                yield node.lineno, parts[1] if len(parts) > 1 and parts[1] in LAYERS else "imutherm", name


def violations(layer: str) -> list:
    bad = []
    for path in sorted((ROOT / layer).rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        if rel in ENTRY_POINTS or rel in FACADES:
            continue
        bad += [f"{rel}:{line} imports {name}" for line, target, name in imports_of(path)
                if target in FORBIDDEN[layer]]
    return bad


@pytest.mark.parametrize("layer", sorted(FORBIDDEN))
def test_no_layer_imports_a_layer_above_it(layer):
    assert violations(layer) == []


def test_the_check_sees_an_upward_import(tmp_path):
    """The reader finds a function-level upward import (what the budget's cycle was made of)."""
    f = tmp_path / "m.py"
    f.write_text("def f():\n    from imutherm.studies.thermal_study import run_scheme\n    import imutherm.cli\n"
                 "from imutherm import studies, InputError\n")
    assert sorted((line, target) for line, target, _ in imports_of(f)) == [(2, "studies"), (3, "cli"), (4, "imutherm"),
                                                                      (4, "studies")]


def test_the_facades_only_re_export_the_unit_model():
    """Each façade imports its own module of unit/ and nothing else, so the FEM core stays free of the unit model."""
    for rel in sorted(FACADES):
        names = [name for _, _, name in imports_of(ROOT / rel)]
        assert names == ["imutherm.unit"], (rel, names)  # ``from imutherm.unit import <its module>``
        assert importlib.import_module(f"imutherm.{rel[:-3].replace('/', '.')}") is \
            importlib.import_module(f"imutherm.unit.{Path(rel).stem}")
