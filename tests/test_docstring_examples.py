"""The API's ``Examples`` sections run: every ``>>>`` line in the package's docstrings is a doctest (as numpy's
and scikit-fem's are), run here from the repository's root (some read ``examples/boards/``) on coarse meshes
and tiny inputs, so that the reference cannot show a call or a figure the code no longer gives. The main
public functions each have one (:data:`MAIN`, the ones the "API at a glance" page lists first).

A module's docstrings are found by reading its file (nothing is imported to look); a module with a ``>>>``
line is imported and :mod:`doctest` runs its examples with ``ELLIPSIS`` and ``NORMALIZE_WHITESPACE``.
"""

import doctest
import importlib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: the repository's folders that are subpackages of imutherm (pyproject.toml's package-dir)
LAYERS = ("imutherm", "geometry", "ecad", "imu", "layouts", "thermal", "unit", "studies", "reports", "cli")
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE

#: the main public functions, each with an Examples section of ``>>>`` lines
MAIN = (
    "imutherm.geometry.layout.load_layout",
    "imutherm.geometry.build.build_geometry",
    "imutherm.geometry.mesh.build_mesh",
    "imutherm.unit.model.build_problem",
    "imutherm.thermal.steady.solve_steady",
    "imutherm.thermal.transient.solve_transient",
    "imutherm.studies.thermal.thermal_study.run_scheme",
    "imutherm.ecad.read.read_board",
    "imutherm.ecad.to_layout.import_board",
    "imutherm.imu.sensor_model.draw_unit",
    "imutherm.imu.sensor_model.simulate_imu",
    "imutherm.imu.calibration.calibrate_unit",
    "imutherm.imu.compensation.compensate",
    "imutherm.imu.filters.run.run_filters",
)


def module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts) if parts[0] == "imutherm" else "imutherm." + ".".join(parts)


def modules_with_examples() -> list:
    found = []
    for layer in LAYERS:
        for path in sorted((ROOT / layer).rglob("*.py")):
            if ">>> " in path.read_text(encoding="utf-8"):
                found.append(module_name(path))
    return found


MODULES = modules_with_examples()


def test_the_main_functions_have_examples():
    for dotted in MAIN:
        module, name = dotted.rsplit(".", 1)
        doc = getattr(importlib.import_module(module), name).__doc__ or ""
        assert "\n    Examples\n    --------\n" in doc and "\n    >>> " in doc, f"{dotted}: no Examples section"
        assert module in MODULES, module


@pytest.mark.parametrize("module", MODULES)
def test_docstring_examples_run(module, monkeypatch):
    monkeypatch.chdir(ROOT)
    mod = importlib.import_module(module)
    tests = [t for t in doctest.DocTestFinder(exclude_empty=True).find(mod, module) if t.examples]
    assert tests, f"{module}: '>>> ' in the file but no doctest found"
    out = []
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    for t in tests:
        runner.run(t, out=out.append)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, "".join(out)
