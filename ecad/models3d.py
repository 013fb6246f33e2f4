"""A part's height from its 3D model (VRML ``.wrl`` or STEP ``.step`` / ``.stp``) when the file is on the disk.

A KiCad footprint names its 3D models (``(model "${KICAD8_3DMODEL_DIR}/Package_SO.3dshapes/SOIC-8.wrl"
(offset (xyz x y z)) (scale (xyz sx sy sz)) (rotate (xyz rx ry rz)))``; KiCad 4/5 write ``(at (xyz ...))`` in
inches instead of ``offset`` in mm). :func:`model_height` resolves the path as KiCad does, reads the model's
points and returns the top of the model above the board [mm]: the largest z of its points once scaled,
turned and offset. Where the file is not found (KiCad's libraries are not installed, another machine's
path), nothing is said and the height comes from the next source (the package table).

Paths: ``${VAR}`` (or KiCad 4's ``$(VAR)``) from the environment; ``${KIPRJMOD}`` is the board file's folder;
a 3D-model variable the environment does not set (``KICAD6_3DMODEL_DIR`` ... ``KICAD9_3DMODEL_DIR``,
``KISYS3DMOD``) is tried as each of the others that is set and as KiCad's usual install folders
(:data:`INSTALL_DIRS`), since the libraries keep their model names from release to release; a relative path
is the board folder's; a ``.wrl`` that is missing is looked for as ``.step`` / ``.stp`` beside it (KiCad's
libraries ship both).

Units and transform (KiCad's, recalled from its 3D viewer, not checked against its source): a VRML unit is
0.1 inch (2.54 mm, the convention of KiCad's ``.wrl`` libraries); a STEP file's length unit is read from the
file (millimetre, metre or inch); a point p becomes ``offset + Rz(-rz) Ry(-ry) Rx(-rx) (scale * p)``. A VRML
file's own ``Transform`` nodes and a STEP assembly's placements are not composed: the points are taken as
written (KiCad's library models are flat; a vendor's assembly can come out off).
"""

from __future__ import annotations

import math
import os
import re
from functools import lru_cache
from pathlib import Path

import numpy as np

from imutherm.ecad.sexpr import child, children

#: KiCad's 3D-model path variables, newest first
MODEL_VARS = ("KICAD9_3DMODEL_DIR", "KICAD8_3DMODEL_DIR", "KICAD7_3DMODEL_DIR", "KICAD6_3DMODEL_DIR", "KISYS3DMOD")
#: where KiCad installs its 3D models (Linux packages, KiCad 5's packages3d, macOS, Windows)
INSTALL_DIRS = ("/usr/share/kicad/3dmodels", "/usr/local/share/kicad/3dmodels", "/usr/share/kicad/modules/packages3d",
                "/Applications/KiCad/KiCad.app/Contents/SharedSupport/3dmodels",
                *(f"C:/Program Files/KiCad/{v}/share/kicad/3dmodels" for v in ("9.0", "8.0", "7.0", "6.0")))
#: largest model file read [bytes] (KiCad's largest library STEP models are a few MB)
MAX_MODEL_BYTES = 64 * 2**20
#: a VRML unit [mm] in KiCad's convention
WRL_UNIT_MM = 2.54
#: a model height beyond this [mm] is not a part's (a wrong unit or a misplaced model): ignored
MAX_HEIGHT_MM = 100.0

_VAR = re.compile(r"\$[{(]([A-Za-z0-9_]+)[})]")
_WRL_POINTS = re.compile(r"Coordinate\s*\{\s*point\s*\[([^\]]*)\]", re.S)
_STEP_POINT = re.compile(r"CARTESIAN_POINT\s*\(\s*'[^']*'\s*,\s*\(([^()]*)\)\s*\)", re.I)
_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def resolve(path_text: str, board_dir: Path) -> Path | None:
    """The model file ``path_text`` names (see the module docstring), None if it is not on the disk."""
    candidates = [path_text]
    for var in dict.fromkeys(_VAR.findall(path_text)):
        if var == "KIPRJMOD":
            values = [str(board_dir)]
        else:
            values = [os.environ[var]] if os.environ.get(var) else []
            if var in MODEL_VARS:
                values += [os.environ[v] for v in MODEL_VARS if v != var and os.environ.get(v)] + list(INSTALL_DIRS)
        if not values:
            return None
        pattern = re.compile(r"\$[{(]" + re.escape(var) + r"[})]")
        candidates = [pattern.sub(lambda _, v=v: v.replace("\\", "/"), c) for c in candidates for v in values]
    paths = []
    for c in candidates:
        p = Path(c)
        p = p if p.is_absolute() else board_dir / p
        paths.append(p)
        if p.suffix.lower() == ".wrl":
            paths += [p.with_suffix(".step"), p.with_suffix(".stp")]
    for p in paths:
        try:
            if p.is_file():
                return p
        except OSError:
            continue
    return None


@lru_cache(maxsize=256)
def _points_mm(path: str, mtime: float) -> np.ndarray:
    """The model's points [mm], shape (n, 3) (cached per file and modification time)."""
    data = Path(path).read_bytes()[:MAX_MODEL_BYTES].decode("latin-1")
    if path.lower().endswith(".wrl"):
        values = [float(v) for block in _WRL_POINTS.findall(data) for v in _NUMBER.findall(block)]
        unit = WRL_UNIT_MM
    else:
        values = []
        for m in _STEP_POINT.finditer(data):
            xyz = _NUMBER.findall(m.group(1))
            if len(xyz) == 3:
                values += [float(v) for v in xyz]
        unit = _step_unit_mm(data)
    pts = np.asarray(values[:len(values) // 3 * 3], float).reshape(-1, 3) * unit
    return pts[np.all(np.isfinite(pts), axis=1)]


def _step_unit_mm(text: str) -> float:
    """A STEP file's length unit [mm]: millimetre unless it says metre or inch."""
    if re.search(r"CONVERSION_BASED_UNIT\s*\(\s*'INCH'", text, re.I):
        return 25.4
    if re.search(r"SI_UNIT\s*\(\s*\.MILLI\.\s*,\s*\.METRE\.", text, re.I):
        return 1.0
    if re.search(r"SI_UNIT\s*\(\s*\$\s*,\s*\.METRE\.", text, re.I):
        return 1000.0
    return 1.0


def _rotation(rx: float, ry: float, rz: float) -> np.ndarray:
    def rot(axis, deg):
        a = math.radians(-deg)
        c, s = math.cos(a), math.sin(a)
        i, j = [k for k in range(3) if k != axis]
        m = np.eye(3)
        m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
        return m
    return rot(2, rz) @ rot(1, ry) @ rot(0, rx)


def model_height(path: Path, scale=(1.0, 1.0, 1.0), rotate=(0.0, 0.0, 0.0), offset_mm=(0.0, 0.0, 0.0)):
    """The top of the model at ``path`` above the board [mm] (its points scaled, turned [deg] and offset [mm]
    as KiCad places them), None when it has no points or lies outside 0..:data:`MAX_HEIGHT_MM`."""
    try:
        pts = _points_mm(str(path), path.stat().st_mtime)
    except (OSError, ValueError):
        return None
    if not len(pts):
        return None
    z = (pts * np.asarray(scale, float)) @ _rotation(*rotate)[2] + float(offset_mm[2])
    top = float(z.max())
    return top if 0.0 < top <= MAX_HEIGHT_MM else None


def _xyz(node, key: str):
    n = child(node, key) if node is not None else None
    xyz = child(n, "xyz") if n is not None else None
    if xyz is None or len(xyz) < 4 or not all(isinstance(v, float) and math.isfinite(v) for v in xyz[1:4]):
        return None
    return tuple(xyz[1:4])


def footprint_model_height(fp_node, board_dir: Path) -> tuple:
    """(height [mm], source) of a footprint node's tallest visible 3D model found on the disk, (None, "")
    without one."""
    best = (None, "")
    for m in children(fp_node, "model"):
        hide = child(m, "hide")   # KiCad 6-7 write a bare ``hide``, KiCad 8+ ``(hide yes)``
        if (len(m) < 2 or isinstance(m[1], list) or any(isinstance(v, str) and v == "hide" for v in m[2:])
                or (hide is not None and len(hide) > 1 and str(hide[1]) == "yes")):
            continue
        path = resolve(str(m[1]), board_dir)
        if path is None:
            continue
        offset = _xyz(m, "offset")
        if offset is None:
            at = _xyz(m, "at")   # KiCad 4/5: inches
            offset = tuple(25.4 * v for v in at) if at else (0.0, 0.0, 0.0)
        h = model_height(path, _xyz(m, "scale") or (1.0, 1.0, 1.0), _xyz(m, "rotate") or (0.0, 0.0, 0.0), offset)
        if h is not None and (best[0] is None or h > best[0]):
            best = (round(h, 3), f"its 3D model {path} (top of the model's points, as KiCad places it)")
    return best
