"""The unit model with model effects on (:class:`ModelVariant`), and the signal effects applied to the rises
a run reads (:func:`apply_signal_effects`): each effect applies itself through its registry entry."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from imutherm import InputError
from imutherm.geometry.build import Geometry
from imutherm.geometry.grid import TensorGrid
from imutherm.thermal.problem import ThermalProblem
from imutherm.unit.effects.registry import EFFECTS, effect_of
from imutherm.unit.model import ModelOptions, build_problem


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

    Each setting's effect applies itself (its :attr:`Effect.apply`), in the order given. Signal effects in
    ``settings`` are ignored here (see :func:`apply_signal_effects`). An effect whose target the scheme
    lacks (``contact@bond`` without bond lines) is refused.
    """
    variant = ModelVariant(geometry, options, {})
    for s in settings:
        e = effect_of(s.name)
        if e.kind == "model":
            variant = e.apply(variant, s)
    return variant


def effect_problem(variant: ModelVariant, grid: TensorGrid) -> ThermalProblem:
    """The thermal problem of a :class:`ModelVariant` on ``grid``."""
    pb = build_problem(variant.geometry, grid, variant.options)
    if not variant.extra_laws:
        return pb
    boundary = {f: tuple(laws) + tuple(variant.extra_laws.get(f, ())) for f, laws in pb.boundary.items()}
    for f, laws in variant.extra_laws.items():
        boundary.setdefault(f, tuple(laws))
    return replace(pb, boundary=boundary)


def apply_signal_effects(times, rise_K, settings, lag_s=None) -> np.ndarray:
    """Site rises [K] (n, m) as read with the ``signal`` effects of ``settings``, each by its
    :attr:`Effect.signal`, in their :attr:`Effect.order` (drift, then probe lag); the last setting of an
    effect wins.

    ``lag_s`` (m,) [s] is needed for an ambient drift (see :func:`ambient_drift_rise`); the rise is
    against the ambient at power-on. A steady row (time inf) is returned unchanged.
    """
    chosen = {}
    for s in settings:
        e = EFFECTS.get(s.base)
        if e is not None and e.kind == "signal":
            chosen[e.name] = (e, s)
    t = np.asarray(times, float)
    y = np.array(rise_K, float)
    fin = np.isfinite(t)
    for e, s in sorted(chosen.values(), key=lambda es: es[0].order):
        y[fin] = e.signal(t[fin], y[fin], s, lag_s)
    return y
