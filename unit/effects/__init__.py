"""Candidate effects: optional extensions of the unit model, each with one or two physical parameters.

A correlation (``imutherm correlate``, the correlation page of the docs) names the effect a measurement
shows and the model lacks; ``imutherm solve --effect NAME[@TARGET]:PARAM=VALUE`` switches the same effects
on in a forward run (which is also how hidden-effect test data are made). Every parameter has a unit,
physical bounds and a source for them.

One effect is one entry of :data:`EFFECTS`, made in one place: :func:`register_effect` decorates the
function that applies it, beside its data (as meshio's ``register_format`` declares a format's reader and
writer together). Everything else (:func:`candidate_names`, :func:`list_effects`, :func:`parse_effect`,
:func:`apply_model_effects`, :func:`apply_signal_effects`, the reduced model's knob of the effect) reads the
entry. Two kinds of effect:

- ``model`` effects change the thermal problem (a contact conductance, an emissivity, a part's
  power, an extra heat path): the decorated function takes a :class:`ModelVariant` and the
  :class:`EffectSetting` and returns the changed variant; :func:`apply_model_effects` applies each setting
  in turn and :func:`effect_problem` builds the problem from the result.
- ``signal`` effects change what a sensor reports, not the field: the decorated function takes the
  finite-time rows ``(times, rises, setting, lag_s)`` and returns the rises as read; a first-order probe
  lag (:func:`first_order_lag`) and an ambient that drifts during the test (:func:`ambient_drift_rise`,
  the linear response of the unit to a ramp of its surroundings). Their ``order`` says which acts first
  (the surroundings change the temperature before a probe reads it).

For example, a new model effect, with no other edit::

    @register_effect("glue", "model", (Param("h_W_m2K", "W/m^2 K", 50.0, 5e3, True, "adhesive datasheets"),),
                     "a glued lid instead of a screwed one")
    def _glue(variant, s):
        lid = Interface("housing", "lid", s.value("h_W_m2K"), "effect glue")
        return replace(variant, options=variant.options.with_(interfaces=variant.options.interfaces + (lid,)))

``cavity_emissivity`` acts on whichever cavity law the model uses: with the effective conductivity
(:func:`imutherm.unit.model.cavity_radiation_conductivity`) it is the pair emissivity that scales it; with
surface-to-surface exchange (``cavity_law 's2s'``, the default) it sets the emissivity of the housing's and
lid's inner faces to the value whose pair emissivity with the boards' 0.9 is the parameter
(:func:`wall_emissivity_for_pair`), and the radiosity exchange follows.

Not in the library (said here so nobody looks for it): a temperature-dependent conductivity (at the 10-20 K
rises of this unit, FR-4 and aluminium change by < 2 %, below what the workflow can separate from a
conductivity re-tune).

The package: :mod:`~imutherm.unit.effects.registry` (what an effect is, the library and its look-ups),
:mod:`~imutherm.unit.effects.variant` (the model they change, the readings they change),
:mod:`~imutherm.unit.effects.model_effects` and :mod:`~imutherm.unit.effects.signal_effects` (the library,
one entry each, registered in this order on import); the names below import from here.
"""

from imutherm.unit.effects.registry import (EFFECTS, Effect, EffectSetting, Param, ambient_rate_K_s,  # noqa: F401
                                            candidate_names, effect_of, is_signal, list_effects, moves_ambient,
                                            parse_effect, register_effect, setting, signal_effect_names)
from imutherm.unit.effects.variant import (ModelVariant, apply_model_effects, apply_signal_effects,  # noqa: F401
                                           effect_problem, power_part)
from imutherm.unit.effects.model_effects import (CONTACT_NODES, LEAK_FACE, PAIR_PARTNER_EMISSIVITY,  # noqa: F401
                                                 S2S_EMISSIVITY_NODES, wall_emissivity_for_pair)
from imutherm.unit.effects.signal_effects import ambient_drift_rise, first_order_lag  # noqa: F401
