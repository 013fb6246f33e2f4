"""Where a layout file is: the built-in layouts shipped in ``layouts/`` and the name or path a command is given
(moved out of :mod:`imutherm.geometry.layout`, which re-exports them)."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

from imutherm import InputError


def default_layout_path() -> Path:
    """Path of the built-in reference layout ``imu_reference.toml``."""
    return Path(str(resources.files("imutherm.layouts") / "imu_reference.toml"))


def builtin_layouts() -> tuple:
    """Names of the layouts shipped in ``layouts/`` (the package ``imutherm.layouts``) (``imu_reference``, ``imu_cardguide``, ...)."""
    folder = resources.files("imutherm.layouts")
    return tuple(sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml")))


def resolve_layout(layout: str | Path | None) -> Path:
    """The layout file meant by ``layout``: a path, or the name of a built-in layout.

    None gives the reference unit. A string that is not an existing file and
    names no file (no ``.toml`` suffix, no directory part) is looked up among
    :func:`builtin_layouts`; an unknown name raises InputError listing them.
    """
    if layout is None or layout == "":
        return default_layout_path()
    path = Path(layout)
    if path.exists() or path.suffix or len(path.parts) > 1:
        return path
    name = str(layout)
    if name not in builtin_layouts():
        raise InputError(f"{name}: no such layout file, nor a built-in layout name; "
                         f"built-in layouts: {', '.join(builtin_layouts())} (or give a path to a .toml file)")
    return Path(str(resources.files("imutherm.layouts") / f"{name}.toml"))
