"""The materials library: thermal properties as data, each with its source.

The data live in ``materials.toml`` beside this module; select by name. A layout may define materials of its
own (``[materials.<name>]``, the same fields, a ``source`` required), such as an imported board's stack-up:
:func:`register_materials` adds them beside the library for :func:`get_material`, in every process that
reads or unpickles that layout. A name is defined once per process: a library name cannot be redefined, and
a second layout giving other values to the same name is refused.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from imutherm import InputError

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

LIBRARY_PATH = Path(__file__).with_name("materials.toml")


@dataclass(frozen=True)
class Material:
    """Thermal properties of one material.

    Attributes
    ----------
    name : str
    k_in_plane, k_through : float [W/m K]
        Conductivity; equal for isotropic materials. For boards, ``through``
        is along the board normal.
    density : float [kg/m^3]
    specific_heat : float [J/kg K]
    emissivity : float or None [-]
        Surface emissivity where it applies (housing finish, boards).
    source : str
        Where the numbers come from.
    """

    name: str
    k_in_plane: float
    k_through: float
    density: float
    specific_heat: float
    emissivity: float | None
    source: str

    @property
    def isotropic(self) -> bool:
        return self.k_in_plane == self.k_through

    @property
    def rho_c(self) -> float:
        """Volumetric heat capacity [J/m^3 K]."""
        return self.density * self.specific_heat


def material_from_table(name: str, table: dict, where: str) -> Material:
    """A :class:`Material` from a TOML table (``k`` or ``k_in_plane`` + ``k_through``, ``density``,
    ``specific_heat``, optional ``emissivity``, ``source``); InputError naming ``where`` and the field."""
    return _material_from_table(name, table, where)


def _material_from_table(name: str, table: dict, where: str) -> Material:
    allowed = {"k", "k_in_plane", "k_through", "density", "specific_heat", "emissivity", "source"}
    unknown = sorted(set(table) - allowed)
    if unknown:
        raise InputError(f"{where}: material {name!r}: unknown key(s) {unknown}; valid: {sorted(allowed)}")
    if "k" in table:
        k_in = k_th = table["k"]
    elif "k_in_plane" in table and "k_through" in table:
        k_in, k_th = table["k_in_plane"], table["k_through"]
    else:
        raise InputError(f"{where}: material {name!r}: give 'k' or both 'k_in_plane' and 'k_through' [W/m K]")
    values = {"k": k_in, "k_through": k_th, "density": table.get("density"),
              "specific_heat": table.get("specific_heat")}
    for field, value in values.items():
        if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
            raise InputError(f"{where}: material {name!r}: field {field!r} must be a finite number > 0, got {value!r}")
    eps = table.get("emissivity")
    if eps is not None and not (isinstance(eps, (int, float)) and 0.0 <= eps <= 1.0):
        raise InputError(f"{where}: material {name!r}: emissivity must be in [0, 1], got {eps!r}")
    if not table.get("source"):
        raise InputError(f"{where}: material {name!r}: a 'source' is required (datasheet, handbook, or 'assumed: why')")
    return Material(name, float(k_in), float(k_th), float(table["density"]), float(table["specific_heat"]),
                    None if eps is None else float(eps), str(table["source"]))


@lru_cache(maxsize=None)
def load_library(path: str | None = None) -> dict:
    """Read a materials TOML file (default: the built-in library) into ``{name: Material}``."""
    path = Path(path) if path else LIBRARY_PATH
    with open(path, "rb") as fh:
        data = tomllib.load(fh)
    return {name: _material_from_table(name, table, str(path)) for name, table in data.items()}


#: materials defined by the layouts read in this process (:func:`register_materials`): name -> Material
_LAYOUT_MATERIALS: dict = {}


def register_materials(materials, where: str) -> None:
    """Make a layout's own materials known to :func:`get_material` in this process.

    A name of the library, or one another layout defined with other values, is refused (InputError naming
    ``where``); the same definition again (the layout read twice, or unpickled in a worker) is accepted."""
    lib = load_library()
    for m in materials:
        if m.name in lib:
            raise InputError(f"{where}: material {m.name!r} is already a library material; give yours another name")
        old = _LAYOUT_MATERIALS.get(m.name)
        if old is not None and _values(old) != _values(m):
            raise InputError(f"{where}: material {m.name!r} is defined with other values by another layout read in "
                             f"this process ({old.source[:80]}); give this one another name")
        _LAYOUT_MATERIALS[m.name] = m


def _values(m: Material) -> tuple:
    """The physical values of a material (its source text aside: the same numbers are the same material)."""
    return (m.k_in_plane, m.k_through, m.density, m.specific_heat, m.emissivity)


def material_names() -> tuple:
    """Every material name :func:`get_material` knows: the library's and the layouts' own, sorted."""
    return tuple(sorted({*load_library(), *_LAYOUT_MATERIALS}))


def get_material(name: str) -> Material:
    """The material ``name``: the library's, or a layout's own (:func:`register_materials`); InputError listing
    the valid names otherwise."""
    lib = load_library()
    if name in lib:
        return lib[name]
    if name in _LAYOUT_MATERIALS:
        return _LAYOUT_MATERIALS[name]
    raise InputError(f"unknown material {name!r}; valid: {', '.join(material_names())}")


#: the properties :func:`with_properties` may change: ``k`` (isotropic materials) or ``k_in_plane`` /
#: ``k_through`` (orthotropic ones) [W/m K], ``density`` [kg/m^3], ``specific_heat`` [J/kg K], ``emissivity`` [-]
PROPERTY_UNITS = {"k": "W/m K", "k_in_plane": "W/m K", "k_through": "W/m K", "density": "kg/m^3",
                  "specific_heat": "J/kg K", "emissivity": "-"}


def settable_properties(material: Material) -> tuple:
    """Names of the properties of ``material`` that :func:`with_properties` accepts."""
    k = ("k",) if material.isotropic else ("k_in_plane", "k_through")
    return k + ("density", "specific_heat") + (("emissivity",) if material.emissivity is not None else ())


def with_properties(material: Material, where: str = "override", **changes) -> Material:
    """A copy of ``material`` (same name) with some properties changed, checked like a library entry.

    ``changes``: see :data:`PROPERTY_UNITS`; ``k`` only for isotropic materials. The library itself is
    not touched; pass the result to the model (``ModelOptions.materials``).
    """
    valid = settable_properties(material)
    unknown = sorted(set(changes) - set(valid))
    if unknown:
        raise InputError(f"{where}: material {material.name!r} has no settable property {unknown}; valid: {list(valid)}")
    table = {"density": material.density, "specific_heat": material.specific_heat, "source": material.source}
    if material.isotropic:
        table["k"] = material.k_in_plane
    else:
        table.update(k_in_plane=material.k_in_plane, k_through=material.k_through)
    if material.emissivity is not None:
        table["emissivity"] = material.emissivity
    table.update(changes)
    table["source"] = f"{material.source}; changed ({where}): " + ", ".join(f"{k} = {v!r}" for k, v in changes.items())
    return _material_from_table(material.name, table, where)
