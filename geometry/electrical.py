"""The unit's power from its electrical design: the supply voltage and each rail's regulator and loads.

A layout may state (all optional; without them every component's ``power_W`` is given explicitly)::

    [electrical]
    supply_V = 9.0                  # nominal input voltage [V]
    supply_range_V = [6.5, 12.0]    # its uncertain range [V] when the source does not state it

    [[rails]]
    name = "rail_5v"
    regulator = "reg_5v"            # the component that dissipates the rail's regulator loss
    kind = "linear"                 # linear (LDO) or switching
    input = "supply"                # "supply" or the name of the rail that feeds this one
    output_V = 5.0
    dropout_V = 1.2                 # linear: the least V_in - V_out it regulates at
    quiescent_A = 0.005             # linear: ground-pin current, drawn from the input
    efficiency = 0.85               # switching: P_out / P_in
    loads_A = { gyro_x = 0.006 }    # component name -> current drawn from the rail [A]

A rail's load current is the sum of its ``loads_A`` and the input currents of the rails it feeds.
A linear regulator dissipates (V_in - V_out) I_load + V_in I_q and draws I_load + I_q; a switching
one dissipates P_out (1/eta - 1) and draws P_out / (eta V_in). :func:`rail_losses` gives every
regulator's loss at any supply voltage, so the supply can be an uncertain input.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from imutherm import InputError

#: the input a rail is fed from when it is not another rail
SUPPLY = "supply"
RAIL_KINDS = ("linear", "switching")
#: largest supply or rail voltage [V] of a small IMU (aircraft buses are 28 V; 60 V is the SELV limit)
MAX_VOLTAGE_V = 60.0
#: largest current of one load or rail [A] (the reference unit draws ~0.2 A in all)
MAX_CURRENT_A = 10.0


@dataclass(frozen=True)
class RailSpec:
    """One regulated rail: its regulator component, kind, input, output [V], and loads [A]."""

    name: str
    regulator: str
    kind: str
    input: str
    output_V: float
    dropout_V: float
    quiescent_A: float
    efficiency: float | None
    loads_A: tuple  # ((component name, current [A]), ...)


@dataclass(frozen=True)
class ElectricalSpec:
    """The supply [V] (nominal and uncertain range) and the rails, in file order."""

    supply_V: float
    supply_range_V: tuple
    rails: tuple


@dataclass(frozen=True)
class RailLoss:
    """A regulator's operating point: input voltage [V], load and input currents [A], loss [W] and its formula."""

    rail: str
    regulator: str
    input_V: float
    load_A: float
    input_A: float
    loss_W: float
    formula: str


def parse_electrical(path: str, top, table_cls, components: dict) -> ElectricalSpec | None:
    """``[electrical]`` and ``[[rails]]`` of a layout, checked (InputError naming the file, rail and field).

    ``top``: the layout's top-level table reader; ``table_cls``: its reader class (``layout._Table``);
    ``components``: component name -> ComponentSpec. None if the layout states no electrical design.
    """
    raw_e, raw_r = top.get("electrical", None), top.get("rails", None)
    if raw_e is None and raw_r is None:
        return None
    if raw_e is None or raw_r is None:
        top.fail("electrical" if raw_e is None else "rails",
                 "an electrical design needs both [electrical] (the supply) and [[rails]] (its regulators)")
    e = table_cls(path, "[electrical]", raw_e, {"supply_V": "V", "supply_range_V": "[lo, hi] V"})
    vbounds = (0.0, MAX_VOLTAGE_V, "V")
    supply = e.number("supply_V", positive=True, bounds=vbounds)
    rng = e.get("supply_range_V", [supply, supply])
    if not (isinstance(rng, list) and len(rng) == 2 and all(
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in rng)):
        e.fail("supply_range_V", f"must be a list of 2 voltages [lo, hi] [V], got {rng!r}")
    for v in rng:
        e.bounded("supply_range_V", v, 1e-3, MAX_VOLTAGE_V, "V")
    if not rng[0] <= supply <= rng[1]:
        e.fail("supply_range_V", f"{list(rng)} must hold the nominal supply_V {supply:g} V (lo <= supply_V <= hi)")
    if not isinstance(raw_r, list) or not raw_r:
        top.fail("rails", "must be an array of tables ([[rails]]), at least one")
    rails, names, regulators = [], set(), set()
    for i, t in enumerate(raw_r):
        r = table_cls(path, f"rails[{i}]", t, {"name": "str", "regulator": "component name", "kind": "linear|switching",
                                                "input": "supply or a rail name", "output_V": "V",
                                                "dropout_V": "V", "quiescent_A": "A", "efficiency": "0..1",
                                                "loads_A": "table: component -> A"})
        name = r.string("name")
        r.where = f"rail {name!r}"
        if name in names or name == SUPPLY:
            r.fail("name", f"duplicate or reserved rail name {name!r}")
        names.add(name)
        kind = r.string("kind", choices=RAIL_KINDS)
        reg = r.string("regulator")
        if reg not in components:
            r.fail("regulator", f"unknown component {reg!r}; valid: {', '.join(components)}")
        if reg in regulators:
            r.fail("regulator", f"component {reg!r} already regulates another rail")
        regulators.add(reg)
        linear = kind == "linear"
        dropout = r.number("dropout_V", ... if linear else 0.0, nonneg=True, bounds=vbounds)
        iq = r.number("quiescent_A", ... if linear else 0.0, nonneg=True, bounds=(0.0, MAX_CURRENT_A, "A"))
        eff = r.number("efficiency", None if linear else ..., positive=True)
        if linear and eff is not None:
            r.fail("efficiency", "a linear regulator's loss follows from its voltages and currents; "
                                 "give efficiency only for kind = 'switching'")
        if eff is not None and not 0.0 < eff <= 1.0:
            r.fail("efficiency", f"{eff!r} is outside the valid range 0..1 (exclusive of 0)")
        loads = r.get("loads_A", {})
        if not isinstance(loads, dict):
            r.fail("loads_A", f"must be a table of component = current [A], got {type(loads).__name__}")
        for comp, amps in loads.items():
            if comp not in components:
                r.fail("loads_A", f"unknown component {comp!r}; valid: {', '.join(components)}")
            if isinstance(amps, bool) or not isinstance(amps, (int, float)) or not math.isfinite(amps) \
                    or not 0.0 <= amps <= MAX_CURRENT_A:
                r.fail("loads_A", f"{comp}: {amps!r} is not a current in 0..{MAX_CURRENT_A:g} A")
        rails.append(RailSpec(name, reg, kind, r.string("input"), r.number("output_V", positive=True, bounds=vbounds),
                              dropout, iq, eff, tuple((c, float(a)) for c, a in loads.items())))
    for rail in rails:
        if rail.input != SUPPLY and rail.input not in names:
            top.fail("rails", f"rail {rail.name!r}: field 'input': unknown rail {rail.input!r}; "
                              f"valid: {SUPPLY}, {', '.join(n for n in names if n != rail.name)}")
    spec = ElectricalSpec(float(supply), (float(rng[0]), float(rng[1])), tuple(rails))
    _order(spec, path)
    for v in sorted({rng[0], supply, rng[1]}):  # every supply in the stated range must be regulated
        rail_losses(spec, v, path)
    return spec


def _order(spec: ElectricalSpec, path: str = "<layout>") -> list:
    """The rails fed before the rails they feed (supply first); InputError on a loop."""
    by_name = {r.name: r for r in spec.rails}
    order, state = [], {}

    def visit(name, chain):
        if state.get(name) == "done":
            return
        if state.get(name) == "open":
            raise InputError(f"{path}: rails: the rails feed each other in a loop: {' -> '.join(chain + [name])}")
        state[name] = "open"
        r = by_name[name]
        if r.input != SUPPLY:
            visit(r.input, chain + [name])
        state[name] = "done"
        order.append(r)

    for r in spec.rails:
        visit(r.name, [])
    return order


def rail_losses(spec: ElectricalSpec, supply_V: float | None = None, path: str = "<layout>") -> dict:
    """Every regulator's :class:`RailLoss` at ``supply_V`` [V] (default: the nominal), by regulator name.

    InputError naming the rail and its regulator if an input is below its output plus the dropout
    (a linear regulator cannot regulate there; a switching one here only steps down).
    """
    v_supply = spec.supply_V if supply_V is None else float(supply_V)
    order = _order(spec, path)
    fed = {r.name: [c for c in spec.rails if c.input == r.name] for r in spec.rails}
    input_A, out = {}, {}
    for r in reversed(order):  # the rails fed by r come before r: their input currents are known
        load = sum(a for _, a in r.loads_A) + sum(input_A[c.name] for c in fed[r.name])
        vin = v_supply if r.input == SUPPLY else next(x.output_V for x in spec.rails if x.name == r.input)
        if vin < r.output_V + r.dropout_V:
            what = f"its {r.dropout_V:g} V dropout" if r.kind == "linear" else "(a switching regulator steps down)"
            src = f"the supply at {v_supply:g} V" if r.input == SUPPLY else f"rail {r.input!r}"
            raise InputError(f"{path}: rail {r.name!r}: regulator {r.regulator!r} is fed {vin:g} V from {src}, "
                             f"below its output {r.output_V:g} V + {what}; valid: an input >= "
                             f"{r.output_V + r.dropout_V:g} V")
        if r.kind == "linear":
            loss = (vin - r.output_V) * load + vin * r.quiescent_A
            i_in = load + r.quiescent_A
            formula = (f"({vin:g} - {r.output_V:g}) V x {load * 1e3:.4g} mA + {vin:g} V x "
                       f"{r.quiescent_A * 1e3:.4g} mA quiescent")
        else:
            p_out = r.output_V * load
            loss = p_out * (1.0 / r.efficiency - 1.0)
            i_in = p_out / r.efficiency / vin
            formula = f"{r.output_V:g} V x {load * 1e3:.4g} mA x (1/{r.efficiency:g} - 1)"
        input_A[r.name] = i_in
        out[r.regulator] = RailLoss(r.name, r.regulator, vin, load, i_in, loss, formula)
    return out


def supply_sensitivity(spec: ElectricalSpec) -> dict:
    """d(loss)/d(supply_V) [W/V] of every regulator fed by the supply (linear: its input current; a switching
    regulator's loss does not depend on its input voltage at a fixed efficiency), by regulator name."""
    losses = rail_losses(spec)
    return {r.regulator: (losses[r.regulator].input_A if r.kind == "linear" else 0.0)
            for r in spec.rails if r.input == SUPPLY}
