"""A footprint's dissipated power from its fields: read only from a field whose name says *dissipation*.

Board files carry two kinds of power field, and only one is what a part dissipates:

* a **dissipation**: ``Power_W`` (this project's field), ``Pd`` / ``P_d`` / ``Pdiss``, ``Dissipation``,
  ``Power_Dissipation``, ``Dissipated_Power``, ``Power_Loss``, ``Heat_W``, IDF's ``POWER_OPR`` (the IDF 3.0
  library's operating power, which Flotherm and Icepak read as the dissipation); read, with the field named
  as its source;
* a **rating**: ``POWER``, ``Power``, ``Rating``, ``Power_Rating``, ``Wattage``, ``Pmax`` (what a resistor
  or a diode can take, as Altium-style libraries write ``POWER = 0.1W``). Never read as a dissipation: a board
  of 0.1 W resistors would otherwise dissipate their ratings (1.5 W instead of 0.05 W on one real board).
  The import names the parts whose rating it left out.

Values are numbers with an optional unit: ``0.046``, ``46mW``, ``0.046 W``, ``46 mW``, ``150uW``; a decimal comma
is read as a point. An empty field is no power given; text that is not a power is noted and left out.
"""

from __future__ import annotations

import math
import re

#: field names (lower case, without ``_ - . space``) that state a dissipated power
DISSIPATION_NAMES = {"powerw", "powermw", "pd", "pdw", "pdmw", "pdiss", "pdis", "pdissw", "dissipation",
                     "dissipationw", "dissipationmw", "powerdissipation", "powerdissipationw", "powerdissipated",
                     "dissipatedpower", "dissipatedpowerw", "powerloss", "powerlossw", "ploss", "heatw",
                     "heatdissipation", "poweropr", "thermalpower", "thermalpowerw"}
#: field names that state a power rating (never a dissipation)
RATING_NAMES = {"power", "rating", "powerrating", "ratedpower", "ratingw", "wattage", "pmax", "powermax",
                "maxpower", "pratedw", "prated", "powerratingw"}
#: a dissipation above this [W] on a part of a small IMU board is not believed (the layout's bound)
MAX_POWER_W = 100.0

_UNITS = {"": 1.0, "w": 1.0, "mw": 1e-3, "uw": 1e-6, "µw": 1e-6, "kw": 1e3}
_VALUE = re.compile(r"^\s*([-+]?(?:\d+(?:[.,]\d*)?|[.,]\d+)(?:[eE][-+]?\d+)?)\s*([kmuµ]?w?)\s*$", re.I)


def field_key(name: str) -> str:
    """A field name as matched: lower case without ``_``, ``-``, ``.``, spaces and brackets."""
    return re.sub(r"[\s_\-.()\[\]]", "", str(name)).lower()


def parse_power(text: str) -> float | None:
    """A power [W] from text with an optional unit (W, mW, uW, kW); None if it is not one."""
    m = _VALUE.match(str(text))
    if m is None:
        return None
    number, unit = m.group(1), m.group(2).lower()
    if "," in number and "." not in number:
        number = number.replace(",", ".")
    try:
        value = float(number) * _UNITS[unit if unit.endswith("w") or not unit else unit + "w"]
    except (ValueError, KeyError):
        return None
    return value if math.isfinite(value) else None


def power_from_fields(ref: str, fields: dict) -> tuple:
    """(power [W] or None, source, note) from a footprint's fields (see the module docstring).

    The note (or "") says what was left out: a rating field, or a dissipation field that holds no power."""
    notes = []
    value, source = None, ""
    for name, text in fields.items():
        key = field_key(name)
        if key in RATING_NAMES and str(text).strip():
            notes.append(f"field {name} is a power rating, not a dissipation: not read as its power")
        elif key in DISSIPATION_NAMES and value is None and str(text).strip():
            v = parse_power(text)
            if v is None or not 0 <= v <= MAX_POWER_W:
                notes.append(f"field {name} {str(text)[:30]!r} is not a power in 0..{MAX_POWER_W:g} W: left out")
                continue
            value, source = v, f"the footprint's {name} field"
    return value, source, "; ".join(notes)
