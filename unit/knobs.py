"""The scalar parameters a correlation varies: the model's uncertain parameters and the library's effects.

*Re-tune* knobs are parameters the model already has, each bounded by what its source allows
(:data:`RETUNE`); *effect* knobs are the one-parameter effects of :mod:`imutherm.unit.effects`
(``contact@bond:h_W_m2K`` ...), over their physical bounds. :func:`variant` turns a dict of knob
values into the model (:class:`~imutherm.unit.effects.ModelVariant`); the reduced model and the
full model are built from the same function, so they cannot disagree on what a knob means.
"""

from __future__ import annotations

from dataclasses import replace

from imutherm import InputError
from imutherm.geometry.build import Geometry
from imutherm.geometry.materials import with_properties
from imutherm.unit.effects import (CONTACT_NODES, EFFECTS, S2S_EMISSIVITY_NODES, ModelVariant,  # noqa: F401
                                   apply_model_effects, candidate_names, effect_of, power_part, setting)
from imutherm.unit.cavity_laws import cavity_law
from imutherm.unit.model import ModelOptions
from imutherm.thermal.reduced import Knob

#: the model's uncertain parameters and the range their sources allow
RETUNE = (
    (Knob("power_scale", "-", 0.85, 1.15, scale_power=True),
     "every power x p: datasheet typical vs worst-case currents (layout power budget; the supply "
     "voltage's own range is supply_power_knob's)"),
    (Knob("mount_h_W_m2K", "W/m^2 K", 150.0, 3000.0, nodes=2),
     "base-to-fixture contact (layout: 500 assumed, 'to be calibrated'); lightly bolted dry Al joints "
     "~1e2..3e3, Incropera Table 3.1"),
    (Knob("convection_scale", "-", 0.75, 1.25, nodes=2),
     "factor on the natural-convection correlation C: laminar correlations scatter by ~±25 % "
     "(Holman Table 7-2 vs Churchill-Chu)"),
    (Knob("emissivity_ext", "-", 0.75, 0.90, nodes=2),
     "anodised aluminium 0.82-0.84 (Incropera Table A.11), widened for finish and batch"),
    (Knob("k_board_W_mK", "W/m K", 10.0, 40.0, nodes=3),
     "in-plane conductivity of the 4-layer board: measured 10-40 W/m K (Azar & Graebner, SEMI-THERM 1996)"),
)
RETUNE_SOURCES = {k.name: src for k, src in RETUNE}

#: effect knobs the re-tune carries as uncertain parameters (fitted beside :data:`RETUNE`,
#: never named as a missing effect), with the reason their value is not known well enough to name a change:
#: the cavity's radiation is known only as well as its law's form. Our two verified laws differ by 40 % of the
#: air-scheme rise at one emissivity (tp1 16.9 K effective, 24.1 K s2s: the thermal solver reference of the docs), an independent
#: finite-volume model of the unit, made outside this package, lies between them, and the paper states neither the inside finish of the
#: housing (bare 0.05 .. anodised 0.84, Incropera Table A.11) nor the boards' solder mask. A change of it
#: is what a model-form mismatch looks like (last campaign: named 7 times, right once), so, as in spacecraft
#: thermal correlation practice, where internal emissivities are correlation parameters, it is re-tuned over
#: its source range and reported with the re-tuned values (``retuned_parameters`` of ``correlation.json``,
#: ``[retune]`` of ``updated_model.toml``), not named.
FORM_RETUNE = {
    "cavity_emissivity": "cavity pair emissivity, re-tuned over its source range 0.02..0.9 (inside finish not "
                         "stated: bare Al 0.05 .. anodised 0.84, Incropera Table A.11) because the cavity "
                         "radiation's law is itself uncertain (effective vs s2s: 40 % of the air rise)",
}
#: form knobs the re-tune opens only where the model's own form is in doubt: when the library and the re-tune
#: do not explain the data, the correlation judges again with the model's discrepancy term
#: (:class:`imutherm.studies.correlation.Discrepancy`) and these knobs beside the others. Never named as an
#: effect (not candidates), reported with the re-tuned values. The cavity's radiation law: our two verified
#: laws bracket it (the independent finite-volume model lies between them), so the blend's weight is the
#: model-form uncertainty as a parameter (competing model forms weighted: the alternate-hypotheses formulation
#: of Zio & Apostolakis, Reliab. Eng. Syst. Saf. 54, 225-241, 1996, the weight here fitted and the blend made in
#: the operator), where a per-site discrepancy alone would take a law's error and any real effect at the same
#: sites together.
FORM_IN_DOUBT = {
    "cavity_law_blend": "weight of the effective law in a blend with the s2s cavity law, 0..1 (the two verified "
                        "laws differ by 40 % of the air rise; an independent model lies between them)",
}
RETUNE_NOMINAL = {"power_scale": 1.0, "convection_scale": 1.0}

#: knob pairs whose changes of the operator do not add: both change the same conductances (a contact's
#: series resistance 1/h + d/k includes the board's half-cell conductance), so the reduced model
#: interpolates each pair jointly (found when a fit with a low board conductivity and a board-joint
#: contact made the summed reduced operator indefinite)
#: The cavity's emissivity and its law's blend: both set the exchange and the air's radiative conductivity
#: ((1 - w) X(eps), w k_rad(eps)); interpolated apart, the reduced model was 12 % of the rise off the full model
#: at w 0.5, eps 0.4 (jointly 0.7 %: tests/test_reduced.py)
COUPLED = (("k_board_W_mK", "contact@board"), ("k_board_W_mK", "contact@standoff"),
           ("cavity_emissivity", "cavity_law_blend"))


def coupled_pairs(names) -> list[tuple[str, str]]:
    """The :data:`COUPLED` pairs both of whose knobs are among ``names`` (a reduced model's knob set)."""
    names = set(names)
    return [p for p in COUPLED if set(p) <= names]


def nominal_values(geometry: Geometry, options: ModelOptions | None = None) -> dict:
    """The re-tune knobs' nominal values for a unit, read from its layout and materials.

    ``power_scale``, ``convection_scale`` 1 [-] (factors on the layout's powers and the convection
    correlation); ``mount_h_W_m2K`` [W/m^2 K] the layout's mounting contact conductance (or the
    ``options`` override); ``emissivity_ext`` [-] the housing material's emissivity (or the override;
    0 for a material without one, as the model takes it); ``k_board_W_mK`` [W/m K] the boards'
    in-plane conductivity (volume-weighted mean if the boards' materials differ: the knob sets them
    all to one value). Material overrides in ``options.materials`` are honoured.
    """
    options = options or ModelOptions()
    mount = geometry.layout.mounting
    h = options.mounting_conductance_W_m2K
    eps = options.emissivity
    if eps is None:
        eps = options.material(geometry.part("housing").material).emissivity or 0.0
    boards = [p for p in geometry.parts if p.kind == "board"]
    if not boards:
        raise InputError(f"layout {geometry.layout.name!r}: no board, so no board conductivity to re-tune")
    ks = [options.material(p.material).k_in_plane for p in boards]
    vol = [geometry.volumes.get(p.name, 0.0) or 1.0 for p in boards]
    k = ks[0] if len(set(ks)) == 1 else sum(w * x for w, x in zip(vol, ks)) / sum(vol)
    return {"power_scale": 1.0, "convection_scale": 1.0,
            "mount_h_W_m2K": float(mount.contact_conductance_W_m2K if h is None else h),
            "emissivity_ext": float(eps), "k_board_W_mK": float(k)}




def effect_knob(name: str, options: ModelOptions | None = None, min_power_W: float | None = None) -> Knob:
    """The :class:`Knob` of a one-parameter model effect ``name`` (``name@target``); ``options``: the model's
    laws (the s2s cavity law makes ``cavity_emissivity`` nonlinear in its parameter); ``min_power_W``
    [W]: for a ``power@part`` knob, the lowest part power the fit may reach (the part switched off), so its
    lower bound is ``max(-1 W, -min_power_W)`` (:func:`power_floor_W`)."""
    e = effect_of(name)
    if e.kind != "model" or len(e.params) != 1:
        raise InputError(f"effect {name!r} is not a one-parameter model effect")
    p = e.params[0]
    if e.knob is not None:  # declared with the effect in imutherm.unit.effects
        return e.knob(name, p, options, min_power_W)
    return Knob(name, p.unit, p.lo, p.hi, nodes=2)  # linear in the parameter


def cavity_pair_nominal(geometry: Geometry, options: ModelOptions | None = None) -> float:
    """The ``cavity_emissivity`` knob's value [-] at which the model is nominal: under the ``effective`` law its
    ``cavity_emissivity`` option; under ``s2s`` the pair emissivity 1/(1/e1 + 1/e2 - 1) of a
    :data:`~imutherm.unit.effects.PAIR_PARTNER_EMISSIVITY` board and the housing's inner wall (the
    ``cavity_wall_emissivity`` option, or ``cavity_surface_emissivity``, or the housing material's emissivity:
    0.84 anodised -> 0.766), the inverse of :func:`~imutherm.unit.effects.wall_emissivity_for_pair`."""
    from imutherm.unit.effects import PAIR_PARTNER_EMISSIVITY
    options = options or ModelOptions()
    if not cavity_law(options.cavity_law).patches:  # the effective law reads the pair emissivity itself
        return float(options.cavity_emissivity)
    wall = options.cavity_wall_emissivity
    if wall is None:
        wall = options.cavity_surface_emissivity
    if wall is None:
        wall = options.material(geometry.part("housing").material).emissivity or 0.0
    if wall <= 0:
        return 0.0
    return float(1.0 / (1.0 / PAIR_PARTNER_EMISSIVITY + 1.0 / wall - 1.0))


def power_floor_W(geometries, name: str, power_scales=(1.0,)) -> float:
    """The smallest power [W] part ``name`` (``power@part``) can have in a fit: its layout power times the
    re-tune's lowest ``power_scale`` times the smallest measured run's ``power_scale``, over ``geometries``.

    A ``power@part`` extra above minus this keeps the part's power non-negative in every run at every
    re-tune (an extra of -1 W on the 0.04 W ADC is not a power error, it is a heat sink).
    """
    component = name.split("@", 1)[1]
    lo_scale = next(k.lo for k, _ in RETUNE if k.name == "power_scale") * min(power_scales)
    watts = []
    for geo in geometries:
        try:
            watts.append(power_part(geo, component).power_W)
        except InputError:
            continue
    return lo_scale * min(watts) if watts else 0.0


#: where the supply voltage's range comes from when a layout's [electrical] states one (the reference unit's)
SUPPLY_SOURCE = ("supply voltage: the paper states none; the layout's supply_range_V (reference unit: 9 V assumed, "
                 "6.2 V = the 5 V LDO's output + its 1.2 V dropout (LM1117 datasheet) .. 12 V, a common supply)")


def supply_power_knob(geometry: Geometry) -> tuple:
    """(Knob, source): the supply voltage's uncertainty as the extra power [W] of the linear regulator it feeds.

    A linear regulator on the supply dissipates (V - V_out) I_load + V I_q: linear in the supply V with
    slope its input current I_load + I_q, so the layout's ``supply_range_V`` maps exactly onto a
    ``power@<regulator>`` knob over [(V_lo - V_nom) I_in, (V_hi - V_nom) I_in] (the rails it feeds run
    from its fixed output and do not move). InputError if the layout states no electrical design, or
    the supply feeds more than one linear regulator (one knob would then move several parts together).
    """
    from imutherm.geometry.electrical import supply_sensitivity

    spec = geometry.layout.electrical
    if spec is None:
        raise InputError(f"layout {geometry.layout.name!r}: no [electrical] table, so no supply voltage to vary")
    slopes = {reg: s for reg, s in supply_sensitivity(spec).items() if s > 0}
    if len(slopes) != 1:
        raise InputError(f"layout {geometry.layout.name!r}: the supply feeds {len(slopes)} linear regulators "
                         f"({', '.join(slopes) or 'none'}); supply_power_knob maps it onto exactly one")
    (reg, slope), = slopes.items()
    lo, hi = ((v - spec.supply_V) * slope for v in spec.supply_range_V)
    return (Knob(f"power@{reg}", "W", lo, hi, part=reg),
            f"{SUPPLY_SOURCE}: {spec.supply_range_V[0]:g}..{spec.supply_range_V[1]:g} V around {spec.supply_V:g} V "
            f"x {slope * 1e3:.4g} mA drawn by {reg}")


def uncertain_inputs(geometry: Geometry) -> tuple:
    """Every uncertain input of the unit's model as ((Knob, source), ...): the re-tune knobs (:data:`RETUNE`)
    and, if the layout states an electrical design with one linear regulator on the supply, the supply
    voltage's range as that regulator's ``power@`` knob (:func:`supply_power_knob`)."""
    out = tuple(RETUNE)
    if geometry.layout.electrical is not None:
        try:
            out += (supply_power_knob(geometry),)
        except InputError:
            pass  # no single linear regulator on the supply: its voltage moves no one part's power alone
    return out


def model_effect_names() -> tuple:
    return tuple(n for n in candidate_names() if EFFECTS[n.split("@")[0]].kind == "model")


def applicable(name: str, geometry: Geometry, options: ModelOptions | None = None) -> bool:
    """False if the effect's target is missing in this scheme (``contact@bond`` without bond lines) or the
    model's laws (``options``, default the defaults) have nothing for it to act on (``cavity_law_blend`` without
    the s2s cavity law)."""
    try:
        e = effect_of(name)
        if e.kind == "model":
            p = e.params[0]
            apply_model_effects(geometry, options or ModelOptions(), (setting(name, **{p.name: (p.lo + p.hi) / 2}),))
        return True
    except InputError:
        return False


def variant(geometry: Geometry, options: ModelOptions, values: dict) -> ModelVariant:
    """The model with re-tune and effect knobs set (``values``: knob name -> value; absent: nominal/off)."""
    geo, opts, effects = geometry, options, []
    for name, v in values.items():
        if name == "power_scale":
            geo = replace(geo, parts=tuple(replace(p, power_W=p.power_W * v) for p in geo.parts))
        elif name == "mount_h_W_m2K":
            opts = opts.with_(mounting_conductance_W_m2K=v)
        elif name == "convection_scale":
            opts = opts.with_(convection_scale=v)
        elif name == "emissivity_ext":
            opts = opts.with_(emissivity=v)
        elif name == "k_board_W_mK":
            mats = {p.material for p in geo.parts if p.kind == "board"}
            over = tuple(with_properties(opts.material(m), "knob k_board_W_mK", k_in_plane=v) for m in sorted(mats))
            opts = opts.with_(materials=tuple(m for m in opts.materials if m.name not in mats) + over)
        else:
            e = effect_of(name)
            effects.append(setting(name, **{e.params[0].name: v}))
    return apply_model_effects(geo, opts, effects)
