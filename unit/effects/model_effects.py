"""The model effects of the library, one entry each: a contact conductance, an outer and a cavity
emissivity, the cavity law's blend, a part's extra power, a heat leak to the fixture. Each is registered
(:func:`~imutherm.unit.effects.registry.register_effect`) on the function that applies it to a
:class:`~imutherm.unit.effects.variant.ModelVariant`, beside its parameter's bounds and their source."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from imutherm import InputError
from imutherm.thermal.problem import Contact
from imutherm.thermal.reduced import Knob
from imutherm.unit.cavity_laws import LAW_BLEND, cavity_law_of
from imutherm.unit.effects.registry import EffectSetting, Param, register_effect
from imutherm.unit.effects.variant import ModelVariant, power_part
from imutherm.unit.model import Interface


def _conductance_param(lo: float, hi: float, why: str) -> Param:
    return Param("h_W_m2K", "W/m^2 K", lo, hi, True, why)


#: Chebyshev nodes of the knobs whose law is not linear in the parameter (contacts: series resistance)
CONTACT_NODES = 6

#: Chebyshev nodes of ``cavity_emissivity`` under the s2s cavity law: the radiosity exchange is nearly linear in
#: the pair emissivity, not exactly (reference unit, 6 mm mesh: the exchange matrix X interpolated over
#: 0.02..0.9 from 2 / 3 / 4 / 5 nodes is off by 4.4 % / 0.3 % / 0.03 % / 0.005 % of its norm)
S2S_EMISSIVITY_NODES = 4


def _contact_knob(name: str, p: Param, options, min_power_W) -> Knob:
    return Knob(name, p.unit, p.lo, p.hi, log=True, nodes=CONTACT_NODES)


@register_effect("contact", "model", (_conductance_param(
        20.0, 2.0e4, "Incropera & DeWitt Table 3.1: contact conductance of dry to greased metal joints "
        "1e3..5e4 W/m^2 K, poor or partly open joints and dried grease down to ~1e2; 20 covers a joint "
        "that barely touches"),),
        "a poor thermal contact at a named interface (a thin resistance R'' = 1/h between the parts): "
        "bond = both faces of every grease bond line, standoff = where the standoffs touch the housing "
        "and the main board, lid = the lid joint, board = the right-angle joints of the x/y boards on "
        "the main board", targets=("bond", "standoff", "lid", "board"), knob=_contact_knob,
        target_options={"bond": "bond_contact_W_m2K"},   # acts where there are bond lines, whatever the scheme
        # hidden in the generated cases: 2x to 100x the lower bound, log-uniform (a poor joint, well resolved)
        draw=lambda rng, p: float(np.exp(rng.uniform(math.log(p.lo * 2), math.log(p.lo * 100)))))
def _contact(variant: ModelVariant, s: EffectSetting) -> ModelVariant:
    geometry, options = variant.geometry, variant.options
    h = s.value("h_W_m2K")
    t = s.target
    if t == "bond":
        if not any(p.kind == "bond" for p in geometry.parts):
            raise InputError(f"effect contact@bond: scheme {geometry.scheme.name!r} has no bond lines")
        options = options.with_(bond_contact_W_m2K=h)
    elif t == "standoff":
        options = options.with_(standoff_contact_W_m2K=h)
    elif t == "lid":
        itfs = tuple(i for i in options.interfaces if {i.part_a, i.part_b} != {"housing", "lid"})
        options = options.with_(interfaces=itfs + (Interface("housing", "lid", h, "effect contact@lid"),))
    else:  # board: the right-angle joints of the boards standing on the main board
        names = [p.name for p in geometry.parts]
        joints = [Interface("main", b, h, "effect contact@board") for b in ("xboard", "yboard")
                  if b in names and "main" in names]
        if not joints:
            raise InputError("effect contact@board: the layout has no boards named main, xboard, yboard")
        options = options.with_(interfaces=options.interfaces + tuple(joints))
    return replace(variant, options=options)


@register_effect("emissivity", "model", (Param("eps", "-", 0.02, 0.95, False,
                                               "Incropera Table A.11: polished Al 0.03-0.05, bare machined "
                                               "0.05-0.1, anodised 0.82-0.84, black paint ~0.95"),),
                 "the housing's outside radiates with a different emissivity than its finish's handbook value "
                 "(bare or polished instead of anodised, or painted)", replaces="emissivity_ext",
                 draw=lambda rng, p: float(rng.uniform(p.lo, 0.3)))  # hidden: a bare or polished finish
def _emissivity(variant: ModelVariant, s: EffectSetting) -> ModelVariant:
    return replace(variant, options=variant.options.with_(emissivity=s.value("eps")))


#: emissivity of the surfaces facing the housing's inside: boards and moulded packages (materials library,
#: FR-4 solder mask and epoxy moulding compound 0.9; Incropera Table A.11 paints and plastics ~0.9)
PAIR_PARTNER_EMISSIVITY = 0.9


def wall_emissivity_for_pair(eps_pair: float) -> float:
    """Emissivity [-] of a wall whose pair emissivity 1/(1/e1 + 1/e2 - 1) with a
    :data:`PAIR_PARTNER_EMISSIVITY` surface is ``eps_pair`` [-] (Incropera eq. 13.24, parallel plates):
    0.77 -> 0.84 (anodised), 0.05 -> 0.05 (bare Al), 0.9 -> 1."""
    return float(min(1.0, 1.0 / (1.0 / eps_pair - 1.0 / PAIR_PARTNER_EMISSIVITY + 1.0)))


def _cavity_emissivity_knob(name: str, p: Param, options, min_power_W) -> Knob:
    if options is not None and cavity_law_of(options).patches:  # the radiosity exchange: nearly linear in eps
        return Knob(name, p.unit, p.lo, p.hi, nodes=S2S_EMISSIVITY_NODES)
    return Knob(name, p.unit, p.lo, p.hi, nodes=2)  # the effective law: linear in the parameter


@register_effect("cavity_emissivity", "model", (Param("eps", "-", 0.02, 0.9, False,
                                                      "pair emissivity 1/(1/e1+1/e2-1) of board (~0.9) and wall: "
                                                      "bare Al wall (0.05) -> 0.05, anodised (0.84) -> 0.77"),),
                 "radiation inside the cavity is weaker or stronger than assumed (e.g. a bare, shiny inside "
                 "of the housing instead of an anodised one); scales the cavity's effective radiative "
                 "conductivity, or under the s2s cavity law sets the housing's inner emissivity",
                 knob=_cavity_emissivity_knob, as_options=lambda o, v: o.with_(
                     cavity_emissivity=v, cavity_wall_emissivity=wall_emissivity_for_pair(v)),
                 draw=lambda rng, p: float(rng.uniform(p.lo, 0.3)))  # hidden: a bare or polished inside
def _cavity_emissivity(variant: ModelVariant, s: EffectSetting) -> ModelVariant:
    # each cavity law reads its own option
    return replace(variant, options=variant.options.with_(
        cavity_emissivity=s.value("eps"), cavity_wall_emissivity=wall_emissivity_for_pair(s.value("eps"))))


def _cavity_law_knob(name: str, p: Param, options, min_power_W) -> Knob:
    return Knob(name, p.unit, p.lo, p.hi, nodes=2)  # the operator is linear in w: (1 - w) X and w k_rad


@register_effect(LAW_BLEND, "model", (Param("w", "-", 0.0, 1.0, False,
                                                     "weight of the effective-conductivity law in a blend with "
                                                     "the s2s exchange: 0 s2s, 1 effective; the two verified laws "
                                                     "differ by 40 % of the reference unit's air rise (tp1 24.1 K "
                                                     "s2s, 16.9 K effective) and an independent finite-volume "
                                                     "model of the unit lies between them"),),
                 "the cavity's radiation follows neither law exactly but lies between the surface-to-surface "
                 "exchange and the effective conductivity of the air (a model-form parameter: re-tuned by a "
                 "correlation whose model's own form does not explain the data, never named as an effect)",
                 knob=_cavity_law_knob, as_options=lambda o, v: o.with_(cavity_law_blend=v))
def _cavity_law_blend(variant: ModelVariant, s: EffectSetting) -> ModelVariant:
    o = variant.options
    if not cavity_law_of(o).blendable:
        raise InputError("effect cavity_law_blend: blends the effective law into the s2s cavity law; the model "
                         f"uses cavity_law {o.cavity_law!r}"
                         + ("" if o.cavity_radiation else " with no cavity radiation"))
    return replace(variant, options=o.with_(cavity_law_blend=s.value("w")))


def _power_knob(name: str, p: Param, options, min_power_W) -> Knob:
    lo = p.lo if min_power_W is None else max(p.lo, -float(min_power_W))
    return Knob(name, p.unit, lo, p.hi, part=name.split("@", 1)[1])


@register_effect("power", "model", (Param("extra_W", "W", -1.0, 1.0, False,
                                          "a missing or wrong power at a part: from switched off (-its power) up "
                                          "to +1 W, a second regulator's worth of loss"),),
                 "a part dissipates a different power than the budget says (a missing load, a wrong supply "
                 "voltage, a part switched off)",
                 targets=("processor", "reg_5v", "reg_3v3", "reg_1v8", "adc"), knob=_power_knob, carried="layout",
                 part_power=True,
                 # hidden in the generated cases: 0.1 to 0.5 W either way
                 draw=lambda rng, p: float(rng.choice([-1, 1]) * rng.uniform(0.1, 0.5)))
def _power(variant: ModelVariant, s: EffectSetting) -> ModelVariant:
    geometry = variant.geometry
    part = power_part(geometry, s.target)
    new = part.power_W + s.value("extra_W")
    if new < 0:
        raise InputError(f"effect power@{s.target}: extra_W = {s.value('extra_W'):g} W would make the "
                         f"part's power negative (it is {part.power_W:g} W)")
    parts = tuple(replace(p, power_W=new) if p.name == part.name else p for p in geometry.parts)
    return replace(variant, geometry=replace(geometry, parts=parts))


#: the face a fixture leak leaves by (the connector end of the housing; assumed)
LEAK_FACE = "xmin"


@register_effect("fixture_leak", "model", (Param("G_W_K", "W/K", 1e-3, 0.3, True,
                                                 "a harness or bracket at the connector end (x = 0 face): ten "
                                                 "0.2 mm^2 copper leads of 0.3 m give 0.003 W/K, an aluminium "
                                                 "bracket 0.3 W/K"),),
                 "heat leaks to the surroundings through a cable harness or bracket at the connector end of "
                 "the housing (an extra conductance G from the x = 0 face to ambient)", carried="run")
def _fixture_leak(variant: ModelVariant, s: EffectSetting) -> ModelVariant:
    geometry = variant.geometry
    (x0, y0, z0), (x1, y1, z1) = geometry.outer
    area = (y1 - y0) * (z1 - z0)
    law = Contact(s.value("G_W_K") / area, geometry.layout.ambient_C)
    extra = dict(variant.extra_laws)
    extra[LEAK_FACE] = extra.get(LEAK_FACE, ()) + (law,)
    return replace(variant, extra_laws=extra)
