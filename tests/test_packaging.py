"""The repository's top-level folders are imutherm's subpackages (the layout the design card asks for):
pyproject.toml maps each one into the imutherm namespace and lists every package, so the wheel ships all of
them (CI installs the wheel and runs ``imutherm geometry`` and ``imutherm verify`` from it)."""

from __future__ import annotations

import importlib
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parents[1]
SETUP = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]


def _folder(package: str) -> Path:
    """The source folder of ``package`` by the package-dir mapping (a subpackage lies below its parent's)."""
    mapping = SETUP["package-dir"]
    parts = package.split(".")
    for i in range(len(parts), 0, -1):
        if ".".join(parts[:i]) in mapping:
            return ROOT.joinpath(mapping[".".join(parts[:i])], *parts[i:])
    raise AssertionError(f"{package} is not mapped")


def test_every_source_package_is_listed_and_mapped():
    found = set()
    for name, folder in SETUP["package-dir"].items():
        assert (ROOT / folder / "__init__.py").is_file(), (name, folder)
        for init in (ROOT / folder).rglob("__init__.py"):
            found.add(".".join([name, *init.parent.relative_to(ROOT / folder).parts]))
    assert found == set(SETUP["packages"])
    assert {"imutherm.thermal", "imutherm.geometry", "imutherm.layouts", "imutherm.studies", "imutherm.reports",
            "imutherm.imu", "imutherm.cli"} <= found
    assert not (ROOT / "imutherm" / "thermal").exists()  # the subpackages live at the top only


def test_imported_packages_come_from_their_mapped_folders():
    for package in SETUP["packages"]:
        module = importlib.import_module(package)
        assert Path(module.__file__).resolve().parent == _folder(package).resolve(), package


def test_data_files_are_declared_as_package_data():
    data = SETUP["package-data"]
    for package, patterns in data.items():
        assert package in SETUP["packages"]
        for pattern in patterns:
            assert list(_folder(package).glob(pattern)), (package, pattern)
    tomls = {p.parent for folder in SETUP["package-dir"].values() for p in (ROOT / folder).rglob("*.toml")}
    declared = {_folder(p) for p, pats in data.items() if "*.toml" in pats}
    assert tomls <= declared, sorted(map(str, tomls - declared))
