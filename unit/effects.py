"""Candidate effects: optional extensions of the unit model, each with one or two physical parameters.

A correlation workflow (issue 11) is to name the effect a measurement shows and the model
lacks; ``imutherm solve --effect NAME[@TARGET]:PARAM=VALUE`` switches the same effects on in a
forward run (which is also how hidden-effect test data are made). Every parameter has a unit,
physical bounds and a source for them.

Two kinds of effect:

- ``model`` effects change the thermal problem (a contact conductance, an emissivity, a part's
  power, an extra heat path): :func:`apply_model_effects` returns the changed geometry, options and
  extra boundary laws; :func:`effect_problem` builds the problem from them.
- ``signal`` effects change what a sensor reports, not the field: a first-order probe lag
  (:func:`first_order_lag`) and an ambient that drifts during the test (:func:`ambient_drift_rise`,
  the linear response of the unit to a ramp of its surroundings).

``cavity_emissivity`` acts on whichever cavity law the model uses: with the effective conductivity
(:func:`imutherm.unit.model.cavity_radiation_conductivity`, the default) it is the pair emissivity
that scales it; with surface-to-surface exchange (``cavity_law 's2s'``) it sets the emissivity of the
housing's and lid's inner faces to the value whose pair emissivity with the boards' 0.9 is the
parameter (:func:`wall_emissivity_for_pair`), and the radiosity exchange follows.

Not in the library (said here so nobody looks for it): a temperature-dependent conductivity (at the 10-20 K
rises of this unit, FR-4 and aluminium change by < 2 %, below what the workflow can separate from a
conductivity re-tune).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from imutherm import InputError
from imutherm.geometry.build import Geometry
from imutherm.geometry.grid import TensorGrid
from imutherm.unit.model import Interface, ModelOptions, build_problem
from imutherm.thermal.problem import Contact, ThermalProblem


@dataclass(frozen=True)
class Param:
    """One parameter of an effect.

    name : str, unit : str
    lo, hi : float, physical bounds [unit]
    log : bool, search the parameter on a log scale (conductances, time constants)
    source : str, where the bounds come from
    """

    name: str
    unit: str
    lo: float
    hi: float
    log: bool = False
    source: str = ""


@dataclass(frozen=True)
class Effect:
    """A candidate effect.

    name : str, targets : tuple of str (empty: no target; else the effect is ``name@target``)
    kind : 'model' or 'signal'
    params : tuple of Param
    words : str, the effect in words a person understands
    """

    name: str
    kind: str
    params: tuple
    words: str
    targets: tuple = ()


def _conductance_param(lo: float, hi: float, why: str) -> Param:
    return Param("h_W_m2K", "W/m^2 K", lo, hi, True, why)


EFFECTS = {e.name: e for e in (
    Effect("contact", "model", (_conductance_param(
        20.0, 2.0e4, "Incropera & DeWitt Table 3.1: contact conductance of dry to greased metal joints "
        "1e3..5e4 W/m^2 K, poor or partly open joints and dried grease down to ~1e2; 20 covers a joint "
        "that barely touches"),),
        "a poor thermal contact at a named interface (a thin resistance R'' = 1/h between the parts): "
        "bond = both faces of every grease bond line, standoff = where the standoffs touch the housing "
        "and the main board, lid = the lid joint, board = the right-angle joints of the x/y boards on "
        "the main board", targets=("bond", "standoff", "lid", "board")),
    Effect("emissivity", "model", (Param("eps", "-", 0.02, 0.95, False,
                                         "Incropera Table A.11: polished Al 0.03-0.05, bare machined "
                                         "0.05-0.1, anodised 0.82-0.84, black paint ~0.95"),),
           "the housing's outside radiates with a different emissivity than its finish's handbook value "
           "(bare or polished instead of anodised, or painted)"),
    Effect("cavity_emissivity", "model", (Param("eps", "-", 0.02, 0.9, False,
                                                "pair emissivity 1/(1/e1+1/e2-1) of board (~0.9) and wall: "
                                                "bare Al wall (0.05) -> 0.05, anodised (0.84) -> 0.77"),),
           "radiation inside the cavity is weaker or stronger than assumed (e.g. a bare, shiny inside "
           "of the housing instead of an anodised one); scales the cavity's effective radiative "
           "conductivity, or under the s2s cavity law sets the housing's inner emissivity"),
    Effect("power", "model", (Param("extra_W", "W", -1.0, 1.0, False,
                                    "a missing or wrong power at a part: from switched off (-its power) up "
                                    "to +1 W, a second regulator's worth of loss"),),
           "a part dissipates a different power than the budget says (a missing load, a wrong supply "
           "voltage, a part switched off)",
           targets=("processor", "reg_5v", "reg_3v3", "reg_1v8", "adc")),
    Effect("fixture_leak", "model", (Param("G_W_K", "W/K", 1e-3, 0.3, True,
                                           "a harness or bracket at the connector end (x = 0 face): ten "
                                           "0.2 mm^2 copper leads of 0.3 m give 0.003 W/K, an aluminium "
                                           "bracket 0.3 W/K"),),
           "heat leaks to the surroundings through a cable harness or bracket at the connector end of "
           "the housing (an extra conductance G from the x = 0 face to ambient)"),
    Effect("probe_lag", "signal", (Param("tau_s", "s", 2.0, 300.0, True,
                                         "first-order sensor lag: an IR thermometer or thermocouple "
                                         "taped on a board responds in seconds to a few minutes"),),
           "the probe reads late: a first-order lag with time constant tau between the site and the "
           "reading"),
    Effect("ambient_drift", "signal", (Param("rate_K_per_h", "K/h", -20.0, 20.0, False,
                                             "a lab room or an oven without closed-loop control drifts "
                                             "by up to ~20 K per hour"),),
           "the surroundings (air and fixture) warm or cool at a steady rate during the test, so the "
           "reading keeps moving after the unit has settled"),
)}


@dataclass(frozen=True)
class EffectSetting:
    """One effect switched on: ``name`` (``name@target`` for targeted effects) and its parameter values."""

    name: str
    values: tuple  # ((param, value), ...)

    @property
    def base(self) -> str:
        return self.name.split("@", 1)[0]

    @property
    def target(self) -> str | None:
        return self.name.split("@", 1)[1] if "@" in self.name else None

    def value(self, param: str) -> float:
        return dict(self.values)[param]

    def text(self) -> str:
        return f"{self.name}:" + ",".join(f"{k}={v:g}" for k, v in self.values)


def candidate_names() -> tuple:
    """Every effect name the library offers: ``name`` or ``name@target``."""
    out = []
    for e in EFFECTS.values():
        out += [f"{e.name}@{t}" for t in e.targets] if e.targets else [e.name]
    return tuple(out)


def effect_of(name: str) -> Effect:
    """The :class:`Effect` of ``name`` or ``name@target`` (InputError naming the valid ones)."""
    base, _, target = name.partition("@")
    e = EFFECTS.get(base)
    if e is None or (bool(e.targets) != bool(target)) or (target and target not in e.targets):
        raise InputError(f"unknown effect {name!r}; valid: {', '.join(candidate_names())}")
    return e


def setting(name: str, **values) -> EffectSetting:
    """A checked :class:`EffectSetting`: every parameter given, finite and within its bounds."""
    e = effect_of(name)
    names = [p.name for p in e.params]
    unknown = [k for k in values if k not in names]
    if unknown:
        raise InputError(f"effect {name!r}: unknown parameter {unknown[0]!r}; valid: {', '.join(names)}")
    out = []
    for p in e.params:
        if p.name not in values:
            raise InputError(f"effect {name!r}: parameter {p.name!r} [{p.unit}] is missing "
                             f"(bounds {p.lo:g}..{p.hi:g})")
        v = values[p.name]
        if not (isinstance(v, (int, float)) and math.isfinite(v)) or not p.lo <= v <= p.hi:
            raise InputError(f"effect {name!r}: {p.name} = {v!r} [{p.unit}] is outside its physical bounds "
                             f"{p.lo:g}..{p.hi:g} ({p.source})")
        out.append((p.name, float(v)))
    return EffectSetting(name, tuple(out))


def parse_effect(text: str) -> EffectSetting:
    """``NAME[@TARGET]:PARAM=VALUE[,PARAM=VALUE]`` -> :class:`EffectSetting` (InputError if malformed)."""
    name, sep, rest = str(text).partition(":")
    if not sep or not rest:
        raise InputError(f"--effect {text!r}: expected NAME[@TARGET]:PARAM=VALUE[,PARAM=VALUE]; "
                         f"effects: {', '.join(candidate_names())}")
    values = {}
    for item in rest.split(","):
        k, eq, v = item.partition("=")
        k = k.strip()
        if k in values:  # a dict would silently keep the last value
            raise InputError(f"--effect {text!r}: {k} is given twice; give each parameter once")
        try:
            values[k] = float(v)
        except ValueError:
            raise InputError(f"--effect {text!r}: {item!r} is not PARAM=NUMBER") from None
        if not eq:
            raise InputError(f"--effect {text!r}: {item!r} is not PARAM=NUMBER")
    return setting(name.strip(), **values)


def list_effects() -> str:
    """The library as text, one block per effect (``imutherm solve --list-effects``)."""
    lines = []
    for e in EFFECTS.values():
        name = e.name + (f"@{{{','.join(e.targets)}}}" if e.targets else "")
        lines.append(f"{name}  [{e.kind}]")
        lines.append(f"    {e.words}")
        for p in e.params:
            lines.append(f"    {p.name} [{p.unit}] {p.lo:g}..{p.hi:g}{' (log)' if p.log else ''}: {p.source}")
    return "\n".join(lines)


# --------------------------------------------------------------------------- model effects

#: the face a fixture leak leaves by (the connector end of the housing; assumed)
LEAK_FACE = "xmin"


#: emissivity of the surfaces facing the housing's inside: boards and moulded packages (materials library,
#: FR-4 solder mask and epoxy moulding compound 0.9; Incropera Table A.11 paints and plastics ~0.9)
PAIR_PARTNER_EMISSIVITY = 0.9


def wall_emissivity_for_pair(eps_pair: float) -> float:
    """Emissivity [-] of a wall whose pair emissivity 1/(1/e1 + 1/e2 - 1) with a
    :data:`PAIR_PARTNER_EMISSIVITY` surface is ``eps_pair`` [-] (Incropera eq. 13.24, parallel plates):
    0.77 -> 0.84 (anodised), 0.05 -> 0.05 (bare Al), 0.9 -> 1."""
    return float(min(1.0, 1.0 / (1.0 / eps_pair - 1.0 / PAIR_PARTNER_EMISSIVITY + 1.0)))


@dataclass(frozen=True)
class ModelVariant:
    """The unit model with some model effects switched on.

    geometry : Geometry (part powers changed by ``power`` effects)
    options : ModelOptions (contacts, emissivities)
    extra_laws : dict face -> tuple of boundary laws added to the problem's
    """

    geometry: Geometry
    options: ModelOptions
    extra_laws: dict = field(default_factory=dict)

    def problem(self, grid: TensorGrid) -> ThermalProblem:
        """The thermal problem of this variant on ``grid`` (:func:`effect_problem`)."""
        return effect_problem(self, grid)

    def power_part(self, component: str):
        """The part that carries component ``component``'s power (:func:`power_part`)."""
        return power_part(self.geometry, component)


def power_part(geometry: Geometry, component: str):
    """The part that carries component ``component``'s power (its ``_die`` if it has one)."""
    names = [p.name for p in geometry.parts]
    for cand in (component + "_die", component):
        if cand in names:
            p = geometry.part(cand)
            if p.power_W or cand.endswith("_die"):
                return p
    raise InputError(f"effect power@{component}: the layout has no powered part {component!r}")


def apply_model_effects(geometry: Geometry, options: ModelOptions, settings=()) -> ModelVariant:
    """Geometry, options and extra laws of the model with the ``model`` effects of ``settings`` on.

    Signal effects in ``settings`` are ignored here (see :func:`apply_signal_effects`). An effect
    whose target the scheme lacks (``contact@bond`` without bond lines) is refused.
    """
    extra = {}
    for s in settings:
        e = effect_of(s.name)
        if e.kind != "model":
            continue
        if e.name == "contact":
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
        elif e.name == "emissivity":
            options = options.with_(emissivity=s.value("eps"))
        elif e.name == "cavity_emissivity":  # each cavity law reads its own option
            options = options.with_(cavity_emissivity=s.value("eps"),
                                    cavity_wall_emissivity=wall_emissivity_for_pair(s.value("eps")))
        elif e.name == "power":
            part = power_part(geometry, s.target)
            new = part.power_W + s.value("extra_W")
            if new < 0:
                raise InputError(f"effect power@{s.target}: extra_W = {s.value('extra_W'):g} W would make the "
                                 f"part's power negative (it is {part.power_W:g} W)")
            parts = tuple(replace(p, power_W=new) if p.name == part.name else p for p in geometry.parts)
            geometry = replace(geometry, parts=parts)
        elif e.name == "fixture_leak":
            (x0, y0, z0), (x1, y1, z1) = geometry.outer
            area = (y1 - y0) * (z1 - z0)
            law = Contact(s.value("G_W_K") / area, geometry.layout.ambient_C)
            extra[LEAK_FACE] = extra.get(LEAK_FACE, ()) + (law,)
    return ModelVariant(geometry, options, extra)


def effect_problem(variant: ModelVariant, grid: TensorGrid) -> ThermalProblem:
    """The thermal problem of a :class:`ModelVariant` on ``grid``."""
    pb = build_problem(variant.geometry, grid, variant.options)
    if not variant.extra_laws:
        return pb
    boundary = {f: tuple(laws) + tuple(variant.extra_laws.get(f, ())) for f, laws in pb.boundary.items()}
    for f, laws in variant.extra_laws.items():
        boundary.setdefault(f, tuple(laws))
    return replace(pb, boundary=boundary)


# --------------------------------------------------------------------------- signal effects

def first_order_lag(times, values, tau_s: float, initial=None) -> np.ndarray:
    """The reading of a first-order sensor (time constant ``tau_s`` [s]) of a signal.

    tau dy/dt = x - y, y(t0) = ``initial`` (default x(t0)), with x linear between the samples
    (exact for piecewise-linear x). ``times`` [s] increasing, ``values`` (n,) or (n, m).
    """
    t = np.asarray(times, float)
    x = np.asarray(values, float)
    y = np.empty_like(x)
    y[0] = x[0] if initial is None else initial
    for i in range(1, len(t)):
        h = t[i] - t[i - 1]
        a = math.exp(-h / tau_s)
        # exact step for x linear on [t_{i-1}, t_i]
        slope = (x[i] - x[i - 1]) / h if h > 0 else 0.0 * x[i]
        y[i] = a * y[i - 1] + (1 - a) * x[i - 1] + slope * (h - tau_s * (1 - a))
    return y


def ambient_drift_rise(times, lag_s, rate_K_per_s: float) -> np.ndarray:
    """Temperature change [K] of sites whose surroundings drift at ``rate_K_per_s`` [K/s] from t = 0.

    ``lag_s`` (m,) [s]: each site's lag behind a ramp of the surroundings, the field
    tau = A^-1 M 1 of the linear(ised) model (A conduction + boundary, M heat capacity). The response
    r (t - tau (1 - exp(-t / tau))) is exact at t -> 0 (to first order) and on the settled ramp,
    and one-mode in between. Returns (n, m).
    """
    t = np.asarray(times, float)[:, None]
    tau = np.maximum(np.asarray(lag_s, float)[None, :], 1e-9)
    return rate_K_per_s * (t - tau * (1.0 - np.exp(-t / tau)))


def signal_settings(settings) -> dict:
    """{'probe_lag': tau_s or None, 'ambient_drift': rate [K/s] or None} of ``settings``."""
    out = {"probe_lag": None, "ambient_drift": None}
    for s in settings:
        if s.base == "probe_lag":
            out["probe_lag"] = s.value("tau_s")
        elif s.base == "ambient_drift":
            out["ambient_drift"] = s.value("rate_K_per_h") / 3600.0
    return out


def apply_signal_effects(times, rise_K, settings, lag_s=None) -> np.ndarray:
    """Site rises [K] (n, m) as read with the ``signal`` effects of ``settings`` (drift, then probe lag).

    ``lag_s`` (m,) [s] is needed for an ambient drift (see :func:`ambient_drift_rise`); the rise is
    against the ambient at power-on. A steady row (time inf) is returned unchanged.
    """
    sig = signal_settings(settings)
    t = np.asarray(times, float)
    y = np.array(rise_K, float)
    fin = np.isfinite(t)
    if sig["ambient_drift"] is not None:
        if lag_s is None:
            raise InputError("effect ambient_drift needs the sites' lag field (lag_s)")
        y[fin] += ambient_drift_rise(t[fin], lag_s, sig["ambient_drift"])
    if sig["probe_lag"] is not None and fin.sum() > 1:
        y[fin] = first_order_lag(t[fin], y[fin], sig["probe_lag"])
    return y
