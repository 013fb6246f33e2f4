"""Package classes: a footprint's body height, material and kind from its library name (``packages.toml``).

The table beside this module is data with a source per height (JEDEC outlines, datasheets); the first class
whose ``match`` (a case-insensitive regular expression) is found in the name wins. A footprint field
``Height_mm`` or the user's ``--height`` overrides the table; a part of no class and no given height is
refused by the importer when it has to be modelled (:mod:`imutherm.ecad.classify`).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from imutherm import InputError
from imutherm.geometry.materials import get_material

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

TABLE_PATH = Path(__file__).with_name("packages.toml")
KINDS = ("passive", "discrete", "ic", "inductor", "connector", "electromechanical")


@dataclass(frozen=True)
class PackageClass:
    """One class of the table: its name, kind, height [mm] (or how the name gives it), body material,
    how the body outline is taken (``fab`` or ``fab+pads``) and the height's source."""

    pattern: str
    name: str
    kind: str
    height_mm: float | None
    height_from_name: str | None
    material: str
    body: str
    source: str

    def height(self, library: str) -> float | None:
        """The height [mm] of a footprint of this class named ``library`` (None if the name does not give it)."""
        if self.height_mm is not None:
            return self.height_mm
        m = re.search(self.height_from_name, library, re.I)
        if m is None:
            return None
        groups = m.groupdict()
        if groups.get("h"):
            return float(groups["h"])
        if groups.get("h10"):
            return float(groups["h10"]) / 10.0
        return None


@lru_cache(maxsize=None)
def package_classes(path: str | None = None) -> tuple:
    """The classes of ``packages.toml`` (or of the file ``path``), in order, checked."""
    path = Path(path) if path else TABLE_PATH
    with open(path, "rb") as fh:
        data = tomllib.load(fh)
    out = []
    for i, t in enumerate(data.get("class", [])):
        where = f"{path}: class {i} ({t.get('class', '?')})"
        allowed = {"match", "class", "kind", "height_mm", "height_from_name", "material", "body", "source"}
        if set(t) - allowed or not {"match", "class", "kind", "material", "source"} <= set(t):
            raise InputError(f"{where}: needs match, class, kind, material, source (and height_mm or "
                             f"height_from_name); valid keys: {sorted(allowed)}")
        if t["kind"] not in KINDS or ("height_mm" in t) == ("height_from_name" in t):
            raise InputError(f"{where}: kind must be one of {KINDS} and exactly one of height_mm, height_from_name given")
        get_material(t["material"])
        for rx in (t["match"], t.get("height_from_name")):
            if rx is not None:
                re.compile(rx)
        out.append(PackageClass(t["match"], t["class"], t["kind"], t.get("height_mm"), t.get("height_from_name"),
                                t["material"], t.get("body", "fab"), t["source"]))
    return tuple(out)


def package_class(library: str) -> PackageClass | None:
    """The first class whose pattern is found in the footprint's library name, or None."""
    for c in package_classes():
        if re.search(c.pattern, library, re.I):
            return c
    return None
