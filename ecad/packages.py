"""Package classes: a footprint's body height, material and kind from its library name (``packages.toml``).

The table beside this module is data with a source per height (JEDEC outlines, datasheets, KiCad's footprint
generator's size definitions); the first class whose ``match`` (a case-insensitive regular expression) is
found anywhere in the name wins. A class gives its height as a number, from the name (``height_from_name``),
or by the body's size (``height_by_size``: a crystal's height by its long side, a radial capacitor's by its
diameter). The order in which a part's height is sought (the user's, the footprint's field, the name's own
``_H4.8``, this table, an estimate) is :mod:`imutherm.ecad.heights`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from imutherm import InputError
from imutherm.ecad.name_dims import matched_name, name_dims
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
    height_by_size: tuple = ()
    size: str = "long_side"
    height_offset_mm: float = 0.0

    def height(self, library: str, body_long_mm: float | None = None) -> float | None:
        """The height [mm] of a footprint of this class named ``library`` (None if neither the name nor the
        body's long side ``body_long_mm`` [mm], for a class sized by it, gives it)."""
        if self.height_mm is not None:
            return self.height_mm
        if self.height_by_size:
            dims = name_dims(library)
            size = dims.diameter_mm if self.size == "diameter" else (dims.body_mm[0] if dims.body_mm else None)
            size = size if size is not None else body_long_mm
            if size is None:
                return None
            return next((h for limit, h in self.height_by_size if size <= limit + 1e-9), self.height_by_size[-1][1])
        m = re.search(self.height_from_name, matched_name(library), re.I)
        if m is None:
            return None
        groups = m.groupdict()
        if groups.get("h"):
            return float(groups["h"].replace(",", ".")) + self.height_offset_mm
        if groups.get("h10"):
            return float(groups["h10"]) / 10.0 + self.height_offset_mm
        if groups.get("ss") and groups.get("hh"):   # a vendor's SSHH: size, then height (see _series_code)
            return _series_code(int(groups["ss"]), int(groups["hh"]))
        return None


def _series_code(ss: int, hh: int) -> float:
    """The height [mm] of a power inductor's SSHH series code: the size SS in 0.1 mm from 20 (40 = 4.0 mm), in
    mm below (10 = 10 mm); the height HH in 0.1 mm (XFL4020: 2.0 mm), or in mm when that would make it less
    than a fifth of the size (SRR1005: 5 mm, XAL1010: 10 mm, MWSA0503: 3 mm)."""
    size = ss / 10.0 if ss >= 20 else float(ss)
    h = hh / 10.0
    return float(hh) if h < 0.2 * size else h


@lru_cache(maxsize=None)
def package_classes(path: str | None = None) -> tuple:
    """The classes of ``packages.toml`` (or of the file ``path``), in order, checked."""
    path = Path(path) if path else TABLE_PATH
    with open(path, "rb") as fh:
        data = tomllib.load(fh)
    out = []
    for i, t in enumerate(data.get("class", [])):
        where = f"{path}: class {i} ({t.get('class', '?')})"
        allowed = {"match", "class", "kind", "height_mm", "height_from_name", "height_by_size", "size",
                   "height_offset_mm", "material", "body", "source"}
        if set(t) - allowed or not {"match", "class", "kind", "material", "source"} <= set(t):
            raise InputError(f"{where}: needs match, class, kind, material, source (and height_mm, "
                             f"height_from_name or height_by_size); valid keys: {sorted(allowed)}")
        ways = sum(k in t for k in ("height_mm", "height_from_name", "height_by_size"))
        if t["kind"] not in KINDS or ways != 1:
            raise InputError(f"{where}: kind must be one of {KINDS} and exactly one of height_mm, height_from_name, "
                             f"height_by_size given")
        steps = t.get("height_by_size", [])
        if not all(isinstance(r, list) and len(r) == 2 and 0 < r[1] <= 100 for r in steps) or \
                [r[0] for r in steps] != sorted(r[0] for r in steps) or t.get("size", "long_side") not in \
                ("long_side", "diameter"):
            raise InputError(f"{where}: height_by_size is [[largest size mm, height mm], ...] in rising sizes; "
                             f"size is long_side or diameter")
        get_material(t["material"])
        for rx in (t["match"], t.get("height_from_name")):
            if rx is not None:
                re.compile(rx)
        out.append(PackageClass(t["match"], t["class"], t["kind"], t.get("height_mm"), t.get("height_from_name"),
                                t["material"], t.get("body", "fab"), t["source"],
                                tuple(tuple(r) for r in steps), t.get("size", "long_side"),
                                float(t.get("height_offset_mm", 0.0))))
    return tuple(out)


def package_class(library: str) -> PackageClass | None:
    """The first class whose pattern is found in the footprint's library name, or None."""
    library = matched_name(library)
    for c in package_classes():
        if re.search(c.pattern, library, re.I):
            return c
    return None
