"""The inputs a sweep may vary: dotted keys into the layout, the materials and the model options.

:func:`valid_keys` lists every numeric key of a layout file's dict for one scheme (with its unit), and
:func:`parse_values` reads a ``--set KEY=VALUES`` value list or range; :func:`key_unit` gives the unit of a
key or output column from its name. See :mod:`imutherm.studies.sweep` for the key forms.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import fields

import numpy as np

from imutherm import InputError
from imutherm.geometry.build import build_geometry
from imutherm.geometry.materials import PROPERTY_UNITS, get_material, settable_properties
from imutherm.unit.model import ModelOptions

#: optional numeric fields a layout table may leave out (their defaults apply) but a sweep may set
_OPTIONAL_FIELDS = {"components": ("power_W", "die_base_mm"), "parts": ("power_W",),
                    "mounting": ("temperature_C",), "schemes": ("max_bond_gap_mm",)}


def key_unit(key: str) -> str:
    """Unit of a sweep key or output column from its name (``_W_m2K`` -> ``W/m^2 K``, ``_mm`` -> ``mm`` ...)."""
    parts = key.split(".")
    if parts[0] == "materials" and len(parts) == 3:
        return PROPERTY_UNITS.get(parts[2], "-")
    name = parts[-2] if parts[-1].isdigit() and len(parts) > 1 else parts[-1]
    for suffix, unit in (("_W_m2K", "W/m^2 K"), ("_mm", "mm"), ("_C", "degC"), ("_W", "W"), ("_K", "K"),
                         ("_s", "s"), ("_deg", "deg"), ("_V", "V"), ("_A", "A")):
        if name.endswith(suffix):
            return unit
    return "-"


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _layout_keys(raw: dict, scheme: str) -> dict:
    """Settable numeric leaves of a layout dict: dotted key -> unit."""
    keys = {}

    def leaf(prefix, name, value):
        if _is_number(value):
            keys[f"{prefix}.{name}"] = key_unit(name)
        elif isinstance(value, list) and value and all(_is_number(v) for v in value):
            for i in range(len(value)):
                keys[f"{prefix}.{name}.{i}"] = key_unit(name)

    def table(prefix, t, kind):
        for name, value in t.items():
            leaf(prefix, name, value)
        for name in _OPTIONAL_FIELDS.get(kind, ()):
            keys.setdefault(f"{prefix}.{name}", key_unit(name))

    for top, value in raw.items():
        if top == "schemes" and isinstance(value, dict):
            if isinstance(value.get(scheme), dict):
                table(f"schemes.{scheme}", value[scheme], "schemes")
        elif isinstance(value, dict):
            if all(isinstance(v, dict) for v in value.values()) and value:  # [sites]: named inline tables
                for name, t in value.items():
                    table(f"{top}.{name}", t, top)
            else:
                table(top, value, top)
        elif isinstance(value, list) and value and all(isinstance(t, dict) for t in value):
            for t in value:
                if isinstance(t.get("name"), str):
                    table(f"{top}.{t['name']}", t, top)
    return keys


def _options_keys() -> dict:
    """Numeric ModelOptions fields: ``options.<field>`` -> unit."""
    out = {}
    for f in fields(ModelOptions):
        if "float" in str(f.type):
            out[f"options.{f.name}"] = "-" if "emissivity" in f.name else key_unit(f.name)
    return out


def _material_keys(geometry) -> dict:
    out = {}
    for name in sorted({p.material for p in geometry.parts}):
        for prop in settable_properties(get_material(name)):
            out[f"materials.{name}.{prop}"] = PROPERTY_UNITS[prop]
    return out


def valid_keys(raw: dict, layout, scheme: str) -> dict:
    """Every key a sweep of ``scheme`` of this layout may set: dotted key -> unit."""
    keys = _layout_keys(raw, scheme)
    keys.update(_material_keys(build_geometry(layout, scheme)))
    keys.update(_options_keys())
    return keys


def unknown_key_error(key: str, valid) -> InputError:
    near = difflib.get_close_matches(key, list(valid), n=5, cutoff=0.5)
    if not near:  # nearest by the last component (a right field in the wrong table, or vice versa)
        last = key.rsplit(".", 1)[-1]
        near = [k for k in valid if k.rsplit(".", 1)[-1] == last][:5]
    hint = f"nearest valid: {', '.join(near)}" if near else f"valid keys start with: {', '.join(sorted({k.split('.')[0] for k in valid}))}"
    return InputError(f"--set: unknown key {key!r}; {hint}")


def _number(text: str, key: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise InputError(f"--set {key}: {text.strip()!r} is not a number") from None
    if not math.isfinite(v):
        raise InputError(f"--set {key}: values must be finite numbers, got {text.strip()!r}")
    return v


def tidy_value(v: float) -> float:
    """12 significant digits: linspace's 0.6000000000000001 becomes 0.6; every case uses the tidied value."""
    return float(f"{v:.12g}")


def parse_values(key: str, text: str, method: str) -> tuple:
    """(values, bounds) of one ``--set KEY=VALUES``.

    grid: a list ``0.5,1,2`` or ``lo:hi:n`` (n >= 2 evenly spaced values); lhs / morris: ``lo:hi`` with lo < hi.
    """
    text = text.strip()
    if not text:
        raise InputError(f"--set {key}=: no values; give a list 0.5,1,2 or a range lo:hi:n")
    if ":" in text:
        parts = text.split(":")
        if len(parts) not in (2, 3):
            raise InputError(f"--set {key}={text}: a range is lo:hi:n (grid) or lo:hi (lhs, morris)")
        lo, hi = _number(parts[0], key), _number(parts[1], key)
        if not lo < hi:
            raise InputError(f"--set {key}={text}: a range needs lo < hi")
        if method == "grid":
            if len(parts) != 3:
                raise InputError(f"--set {key}={text}: a grid range needs a count: lo:hi:n")
            try:
                n = int(parts[2])
            except ValueError:
                raise InputError(f"--set {key}={text}: n must be an integer >= 2, got {parts[2]!r}") from None
            if n < 2:
                raise InputError(f"--set {key}={text}: n must be an integer >= 2, got {n}")
            return tuple(tidy_value(v) for v in np.linspace(lo, hi, n)), (lo, hi)
        if len(parts) == 3:
            raise InputError(f"--set {key}={text}: with --method {method} give the range as lo:hi "
                             "(the number of cases comes from --samples)")
        return None, (lo, hi)
    if method != "grid":
        raise InputError(f"--set {key}={text}: --method {method} samples a range: give lo:hi, not a list")
    values = tuple(_number(v, key) for v in text.split(","))
    if len(set(values)) != len(values):
        raise InputError(f"--set {key}={text}: repeated value (each case would run twice)")
    return values, (min(values), max(values))


def split_set(item: str) -> tuple:
    if "=" not in item:
        raise InputError(f"--set {item!r}: expected KEY=VALUES, e.g. components.reg_5v.power_W=0.4,0.8,1.2")
    key, text = item.split("=", 1)
    key = key.strip()
    if not key:
        raise InputError(f"--set {item!r}: missing KEY before '='")
    return key, text


# ------------------------------------------------------------------ the keys a reduced model carries

#: the sweep's ``--surrogate`` choices: ``reduced`` cases on the scheme's reduced model
#: (:mod:`imutherm.studies.sweep.surrogate`), ``none`` the full FEM, ``auto`` the reduced model where every key
#: is a knob
SURROGATES = ("auto", "reduced", "none")
#: default number of cases re-run on the full FEM
VERIFY_DEFAULT = 5
#: largest site / hot-spot error [K] a verified case may show (the sweep's accuracy target: checked cases within 0.1 K)
VERIFY_TOL_K = 0.1
#: options keys the reduced model carries, with their kind
_OPTION_KEYS = {"options.mounting_conductance_W_m2K": "linear", "options.emissivity": "linear",
                "options.convection_scale": "linear", "options.h_fixed_W_m2K": "linear",
                "options.bond_contact_W_m2K": "contact", "options.standoff_contact_W_m2K": "contact",
                "options.cavity_emissivity": "cavity", "options.cavity_surface_emissivity": "cavity",
                "options.cavity_wall_emissivity": "cavity"}
_LAYOUT_KEYS = {"mounting.contact_conductance_W_m2K": "linear"}
_MATERIAL_KIND = {"k": "k", "k_in_plane": "k", "k_through": "k", "emissivity": "cavity"}

def key_kind(key: str) -> str | None:
    """``power``, ``linear``, ``contact``, ``k``, ``cavity``: how the reduced model carries ``key``; None if it
    cannot (the key moves the mesh, the ambient, a fixture temperature or the heat capacity)."""
    parts = key.split(".")
    if len(parts) == 3 and parts[0] in ("components", "parts") and parts[2] == "power_W":
        return "power"
    if key in _OPTION_KEYS:
        return _OPTION_KEYS[key]
    if key in _LAYOUT_KEYS:
        return _LAYOUT_KEYS[key]
    if len(parts) == 3 and parts[0] == "materials":
        return _MATERIAL_KIND.get(parts[2])
    return None


def surrogate_keys(factors, geometry) -> tuple:
    """(ok, reason): whether every factor is a knob of the reduced model of ``geometry``'s scheme."""
    from imutherm.unit.effects import power_part

    for f in factors:
        kind = key_kind(f.key)
        if kind is None:
            return False, (f"{f.key} is not a knob of the reduced model (it moves the mesh, the ambient, a "
                           "fixture temperature or the heat capacity); knobs are powers, conductivities, "
                           "contact and mounting conductances, convection factor and emissivities")
        if kind == "power":
            try:
                power_part(geometry, f.key.split(".")[1])
            except InputError:
                return False, f"{f.key}: the part has no power in the layout, so no die load to scale"
        if kind in ("contact", "k") and f.bounds[0] <= 0:
            return False, f"{f.key}: a conductance range must be > 0 for the reduced model, got {f.bounds[0]:g}"
    return True, ""
