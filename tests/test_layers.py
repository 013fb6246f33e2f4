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
ENTRY_POINTS = {"studies/study_reference.py", "studies/study.py"}
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
    f.write_text("def f():\n    from imutherm.studies.thermal.thermal_study import run_scheme\n    import imutherm.cli\n"
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


# ------------------------------------------------------------------ import cycles stay inside one folder
#: cycles that still cross a folder, each with where it goes (the list shrinks; a stale entry fails)
CROSSING: dict = {}


def module_of(path: Path, root: Path = ROOT) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    parts = parts[:-1] if parts[-1] == "__init__" else parts
    return ".".join(parts) if parts[0] == "imutherm" else ".".join(["imutherm"] + parts)


def import_graph(root: Path = ROOT) -> dict:
    """module -> the package modules it imports (at the top or in a function; importing ``a.b.c`` also imports
    the packages ``a.b`` and ``a``, as Python does)."""
    files = {module_of(p, root): p for layer in LAYERS for p in (root / layer).rglob("*.py")}
    graph = {}
    for mod, path in files.items():
        deps = set()
        for _, _, name in imports_of(path):
            while name and name not in files:   # ``from a.b import name``: the module a.b
                name = name.rpartition(".")[0]
            parts = name.split(".")
            deps |= {q for q in (".".join(parts[:i]) for i in range(2, len(parts) + 1)) if q in files and q != mod}
        graph[mod] = deps
    return graph


def cycles(graph: dict) -> list:
    """The import cycles of ``graph``: its strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while not comp or v not in comp:
                comp.add(stack.pop())
            on.difference_update(comp)
            if len(comp) > 1:
                out.append(comp)

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def folder(mod: str, graph: dict) -> str:
    """The package ``mod`` is in: itself for a package (its ``__init__``), else its parent."""
    return mod if any(m.startswith(mod + ".") for m in graph) else mod.rpartition(".")[0]


def test_import_cycles_stay_inside_one_folder():
    """A package's ``__init__`` and its modules may import each other; a cycle between folders (``compare`` ->
    ``cost`` -> ``end_to_end`` -> ``compare``, before the workers had one home) may not."""
    graph = import_graph()
    crossing = [sorted(c) for c in cycles(graph) if len({folder(m, graph) for m in c}) > 1]
    assert [c for c in crossing if not set(c) & set(CROSSING)] == []
    assert sorted(m for m in CROSSING if any(m in c for c in crossing)) == sorted(CROSSING)


def test_the_cycle_check_sees_a_lazy_cycle_across_folders(tmp_path):
    """The check finds a cycle made of function-level imports between two folders."""
    for rel, body in {"imutherm/__init__.py": "", "studies/__init__.py": "", "studies/a.py":
                      "def f():\n    from imutherm.studies.b.c import g\n", "studies/b/__init__.py": "",
                      "studies/b/c.py": "def g():\n    import imutherm.studies.a\n"}.items():
        (tmp_path / rel).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / rel).write_text(body)
    graph = import_graph(tmp_path)
    assert cycles(graph) == [{"imutherm.studies.a", "imutherm.studies.b.c"}]
    assert {folder(m, graph) for m in cycles(graph)[0]} == {"imutherm.studies", "imutherm.studies.b"}


def test_the_workers_module_imports_only_the_base():
    """``imutherm.workers`` is started first in a spawned worker: it imports nothing of the package but its base
    (and no numpy at import, so the thread limits it sets apply when BLAS loads)."""
    tree = ast.parse((ROOT / "imutherm/workers.py").read_text(encoding="utf-8"))
    top = {a.name.split(".")[0] for n in tree.body if isinstance(n, ast.Import) for a in n.names}
    top |= {n.module.split(".")[0] for n in tree.body if isinstance(n, ast.ImportFrom) and n.module}
    assert {name for _, _, name in imports_of(ROOT / "imutherm/workers.py")} <= {"imutherm.InputError"}
    assert top <= {"__future__", "contextlib", "os", "imutherm"}


# ------------------------------------------------------------------ public seams
#: the folders whose modules import no underscore name of another module (issue 60 item 2)
PUBLIC_SEAMS = ("ecad", "geometry", "imu", "imutherm", "layouts", "unit", "reports", "studies", "thermal")


def private_imports(path: Path) -> list:
    """(line, module, name) of each ``from imutherm.x import _name`` (or from a private module ``imutherm.x._m``)."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").startswith("imutherm"):
            private_module = any(p.startswith("_") and not p.startswith("__") for p in node.module.split("."))
            out += [(node.lineno, node.module, a.name) for a in node.names
                    if private_module or (a.name.startswith("_") and not a.name.startswith("__"))]
    return out


def test_no_underscore_name_is_imported_across_modules():
    bad = [f"{p.relative_to(ROOT).as_posix()}:{line} imports {name} from {mod}"
           for layer in PUBLIC_SEAMS for p in sorted((ROOT / layer).rglob("*.py"))
           for line, mod, name in private_imports(p)]
    assert bad == []


def test_the_seam_check_sees_a_private_name_and_a_private_module(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("from imutherm.imu.motion import Jet, _assemble\nfrom imutherm.cli._common import run\n"
                 "from imutherm import __version__\n")
    assert private_imports(f) == [(1, "imutherm.imu.motion", "_assemble"), (2, "imutherm.cli._common", "run")]


# ------------------------------------------------------------------ results built by keyword
def positional_results(paths, names) -> list:
    """(path, line, class) of each call of a result class in ``names`` given positional arguments."""
    out = []
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and node.args:
                f = node.func
                name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else None
                if name in names:
                    out.append((path, node.lineno, name))
    return out


def test_the_studies_results_are_built_by_keyword():
    """Every ``*Result`` record of studies/ (``CorrelationResult``'s 28 fields among them) is built by keyword, in
    the package and its tests, so a field added or moved cannot shift the others."""
    studies = sorted((ROOT / "studies").rglob("*.py"))
    names = {n.name for p in studies for n in ast.walk(ast.parse(p.read_text(encoding="utf-8")))
             if isinstance(n, ast.ClassDef) and n.name.endswith("Result")}
    assert {"CorrelationResult", "SchemeResult", "SweepResult"} <= names
    paths = [p for layer in LAYERS + ("tests",) for p in sorted((ROOT / layer).rglob("*.py"))]
    assert [f"{p.relative_to(ROOT).as_posix()}:{line} {name}" for p, line, name in positional_results(paths, names)] == []


def test_the_keyword_check_sees_a_positional_result(tmp_path):
    f = tmp_path / "m.py"
    f.write_text("r = SchemeResult(geometry=1)\ns = studies.SweepResult(1, plan=2)\n")
    assert [(line, name) for _, line, name in positional_results([f], {"SchemeResult", "SweepResult"})] == \
        [(2, "SweepResult")]
