"""The radiation laws inside the cavity (``ModelOptions.cavity_law``), one entry each, with what each can do.

A :class:`CavityLaw` says how the unit model applies it (:func:`imutherm.unit.model.build_problem`): its share of
the air's effective radiative conductivity (Rosseland-style, :func:`~imutherm.thermal.cavity_radiation.
cavity_radiation_conductivity`), whether it exchanges between patches of the cavity's faces (the
surface-to-surface law: view factors and a radiosity solve, sized by ``cavity_patch_mm``), whether a problem
with it exports to CalculiX (an interior exchange does not), and whether ``cavity_law_blend`` mixes the
effective law into it. :func:`register_cavity_law` adds one; the CLI's ``--cavity-law`` choices, the option
checks, the cost model, the reduced models' knobs and the exports read these fields, never the law's name.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class CavityLaw:
    """One cavity radiation law.

    name; words : the law in words; conductivity_share : its weight [-] of the air's effective radiative
    conductivity (1: the effective law; 0: none of it); patches : it exchanges between patches of the cavity's
    faces (view factors, a radiosity solve: its cost grows with the patches); calculix : a problem with it
    exports to CalculiX (no interior exchange); blendable : ``cavity_law_blend`` w mixes the effective law into it
    (the exchange times 1 - w plus w times the effective conductivity); form_partner : the other verified law,
    with which a model-form case generates its data (:func:`imutherm.studies.hidden_effect.model_form_options`)
    """

    name: str
    words: str
    conductivity_share: float = 0.0
    patches: bool = False
    calculix: bool = True
    blendable: bool = False
    form_partner: str | None = None


#: the laws: name -> :class:`CavityLaw`, in the order they were registered
CAVITY_LAWS: dict = {}


def register_cavity_law(name: str, words: str, *, conductivity_share: float = 0.0, patches: bool = False,
                        calculix: bool = True, blendable: bool = False, form_partner: str | None = None) -> CavityLaw:
    """Add the cavity law ``name`` to :data:`CAVITY_LAWS` (a name already there is refused: ValueError)."""
    if name in CAVITY_LAWS:
        raise ValueError(f"cavity law {name!r} is already registered")
    law = CavityLaw(name, words, float(conductivity_share), patches, calculix, blendable, form_partner)
    CAVITY_LAWS[name] = law
    return law


def cavity_law(name: str) -> CavityLaw:
    """The registered law ``name`` (KeyError if there is none: :class:`~imutherm.unit.model.ModelOptions` checks
    the name first)."""
    return CAVITY_LAWS[name]


def cavity_law_of(options) -> CavityLaw:
    """The law a model with ``options`` applies: its ``cavity_law``, or ``none`` without cavity radiation."""
    return CAVITY_LAWS[options.cavity_law if options.cavity_radiation else NO_CAVITY_RADIATION]


#: the law of a cavity without radiation (``cavity_radiation`` off)
NO_CAVITY_RADIATION = "none"
#: the effect (and reduced-model knob) that weights the effective law into a ``blendable`` law, w in [0, 1]
#: (:mod:`imutherm.unit.effects`; the model option ``cavity_law_blend``)
LAW_BLEND = "cavity_law_blend"

#: the law a model applies unless told otherwise (``ModelOptions.cavity_law``, the CLI's ``--cavity-law``)
DEFAULT_CAVITY_LAW = "s2s"

register_cavity_law("effective", "the air's effective radiative conductivity between facing walls (Rosseland-style "
                    "diffusion, one linearisation temperature), faster than s2s but it runs the air scheme ~7 K "
                    "cool at tp1 (docs/benchmarks/cavity_radiation)", conductivity_share=1.0, form_partner="s2s")
register_cavity_law("s2s", "surface-to-surface exchange between patches of the cavity's faces (view factors, "
                    "a radiosity solve)", patches=True, calculix=False, blendable=True, form_partner="effective")
register_cavity_law(NO_CAVITY_RADIATION, "no radiation inside the cavity")
