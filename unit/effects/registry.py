"""The effect library's registry: what an effect is (:class:`Effect`, its :class:`Param`), the library
(:data:`EFFECTS`, filled by :func:`register_effect`), an effect switched on (:class:`EffectSetting`) and the
look-ups every user of the library reads (:func:`effect_of`, :func:`setting`, :func:`parse_effect`, ...).
The effects themselves are registered in :mod:`~imutherm.unit.effects.model_effects` and
:mod:`~imutherm.unit.effects.signal_effects`; :mod:`imutherm.unit.effects` imports both."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

from imutherm import InputError


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
    apply : callable, ``apply(variant, setting) -> ModelVariant`` (model effects)
    signal : callable, ``signal(times, rise_K, setting, lag_s) -> rise_K`` on the finite-time rows (signal effects)
    order : int, signal effects act in increasing order (0: on the temperature, 1: on the reading)
    knob : callable or None, ``knob(name, param, options, min_power_W) -> Knob``: the reduced model's knob of
        a one-parameter model effect; None: a law linear in the parameter (2 Chebyshev nodes)

    What the rest of the package reads instead of the effect's name:

    ambient_rate : callable or None, ``ambient_rate(setting) -> K/s``: a signal effect that moves the
        surroundings at this rate (it needs the sites' lag field and a transient run; a reduced model takes it
        as its ambient ramp); None: the effect acts on the reading
    carried : how a fitted model carries the effect into a run (:mod:`imutherm.studies.thermal.fitted_model`):
        'options' (the model options, by ``apply``), 'layout' (the layout's part powers) or 'run' (a boundary
        law the run switches on itself)
    target_options : target -> the :class:`~imutherm.unit.model.ModelOptions` field the parameter sets whatever
        the scheme (no geometry needed), e.g. contact@bond
    as_options : callable or None, ``as_options(options, value) -> options``: a form knob's fitted value as
        model options (under whichever cavity law)
    replaces : the re-tune knob the effect's parameter takes the place of in a fit (an outer emissivity
        replaces ``emissivity_ext``), or None
    part_power : the parameter is a part's extra power [W]: a fit keeps the part's power >= 0
    fit_cost : CPU cost of fitting the effect relative to the others [-], before it is measured (a probe lag's
        rises are computed on a dense time grid and filtered)
    draw : callable or None, ``draw(rng, param) -> value``: a hidden value for the generated test cases
        (:mod:`imutherm.studies.correlation.hidden_effect`); None: uniform over the parameter's range (log-uniform for a
        log parameter)
    """

    name: str
    kind: str
    params: tuple
    words: str
    targets: tuple = ()
    apply: Callable | None = None
    signal: Callable | None = None
    order: int = 0
    knob: Callable | None = None
    ambient_rate: Callable | None = None
    carried: str = "options"
    target_options: dict = field(default_factory=dict)
    as_options: Callable | None = None
    replaces: str | None = None
    part_power: bool = False
    fit_cost: float = 1.0
    draw: Callable | None = None


#: the library: effect name -> :class:`Effect`, in the order the effects were registered
EFFECTS: dict = {}


def register_effect(name: str, kind: str, params: tuple, words: str, targets: tuple = (), *, order: int = 0,
                    knob: Callable | None = None, **roles):
    """Decorator: add the effect ``name`` to :data:`EFFECTS`, applied by the decorated function.

    ``kind`` 'model': the function is ``apply(variant: ModelVariant, setting) -> ModelVariant``; 'signal': it
    is ``signal(times [s], rise_K, setting, lag_s) -> rise_K`` (see :class:`Effect` for ``order``, ``knob`` and
    the ``roles``: ``ambient_rate``, ``carried``, ``target_options``, ``as_options``, ``replaces``,
    ``part_power``, ``fit_cost``, ``draw``). A name already in the library is refused (ValueError): one effect
    is one entry.
    """
    if kind not in ("model", "signal"):
        raise ValueError(f"effect {name!r}: kind must be 'model' or 'signal', got {kind!r}")
    if name in EFFECTS:
        raise ValueError(f"effect {name!r} is already in the library")

    def add(fn):
        fns = {"apply": fn} if kind == "model" else {"signal": fn}
        EFFECTS[name] = Effect(name, kind, tuple(params), words, tuple(targets), order=order, knob=knob, **fns,
                               **roles)
        return fn
    return add


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


def is_signal(name: str) -> bool:
    """Whether ``name`` (``name`` or ``name@target``) is a signal effect of the library (False for any other
    name, a re-tune knob's for one)."""
    e = EFFECTS.get(name.split("@", 1)[0])
    return e is not None and e.kind == "signal"


def signal_effect_names() -> tuple:
    """The signal effects of the library, in registration order."""
    return tuple(n for n, e in EFFECTS.items() if e.kind == "signal")


def ambient_rate_K_s(settings) -> float:
    """The rate [K/s] at which ``settings``' signal effects move the surroundings (0: none does); the last
    setting of an effect wins, as in :func:`apply_signal_effects`."""
    rates = {}
    for s in settings:
        e = EFFECTS.get(s.base)
        if e is not None and e.ambient_rate is not None:
            rates[e.name] = e.ambient_rate(s)
    return float(sum(rates.values()))


def moves_ambient(settings) -> bool:
    """Whether any of ``settings`` moves the surroundings (needs the lag field and a transient run)."""
    return any(EFFECTS.get(s.base) is not None and EFFECTS[s.base].ambient_rate is not None for s in settings)


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
