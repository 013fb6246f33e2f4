"""The radiation laws inside the cavity (``ModelOptions.cavity_law``), one entry each, with what each can do.

A :class:`CavityLaw` says how the unit model applies it: its build hook (:attr:`CavityLaw.build`, default
:func:`standard_terms`) gives what it adds to an air-filled cavity's problem (:class:`CavityTerms`: a share of the
air's effective radiative conductivity, Rosseland-style, :func:`~imutherm.thermal.cavity_radiation.
cavity_radiation_conductivity`, and interior exchange laws), read by :func:`imutherm.unit.model.build_problem`.
Its fields say what it can do: whether it exchanges between patches of the cavity's faces (the surface-to-surface
law: view factors and a radiosity solve, sized by ``cavity_patch_mm``; a problem with an interior exchange does
not export to CalculiX) and whether ``cavity_law_blend`` mixes the effective law into it.
:func:`register_cavity_law` adds one (a new law is that one call, with its hook if the standard terms do not
describe it); the CLI's ``--cavity-law`` choices, the option checks, the cost model and the reduced models' knobs
read these fields, never the law's name.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


@dataclass(frozen=True)
class CavityTerms:
    """What a cavity law adds to the unit's thermal problem when the cavity is air.

    conductivity_share : weight [-] of the air's effective radiative conductivity added to the air's k;
    exchanges : interior exchange laws (:attr:`imutherm.thermal.ThermalProblem.exchanges`, e.g.
    :class:`~imutherm.thermal.cavity_radiation.CavityExchange`)
    """

    conductivity_share: float = 0.0
    exchanges: tuple = ()


@dataclass(frozen=True)
class CavitySetting:
    """What a law's build hook reads: the unit's ``geometry``, ``grid`` and ``options``, the ``blend`` w [-] of
    ``cavity_law_blend`` (0 unless the law is ``blendable``) and ``exchange()``, the unit's patch exchange on
    this mesh (:func:`imutherm.unit.model.cavity_exchange_law`, built at the first call)."""

    geometry: object
    grid: object
    options: object
    blend: float
    exchange: Callable[[], object]


def standard_terms(law: "CavityLaw", setting: CavitySetting) -> CavityTerms:
    """The registered laws' build hook: the law's ``conductivity_share`` plus the blend w, and with ``patches``
    the unit's patch exchange times 1 - w (kept at w = 1, exchanging nothing: a reduced model's knob changes
    its G)."""
    exchanges = ()
    if law.patches:
        ex = setting.exchange()
        exchanges = (ex.scaled(1.0 - setting.blend) if setting.blend else ex,)
    return CavityTerms(law.conductivity_share + setting.blend, exchanges)


@dataclass(frozen=True)
class CavityLaw:
    """One cavity radiation law.

    name; words : the law in words; conductivity_share : its weight [-] of the air's effective radiative
    conductivity (1: the effective law; 0: none of it); patches : it exchanges between patches of the cavity's
    faces (view factors, a radiosity solve: its cost grows with the patches); blendable : ``cavity_law_blend`` w
    mixes the effective law into it (the exchange times 1 - w plus w times the effective conductivity);
    form_partner : the other verified law, with which a model-form case generates its data
    (:func:`imutherm.studies.correlation.hidden_effect.model_form_options`);
    build : ``(law, CavitySetting) -> CavityTerms``, what it adds to an air-filled cavity's problem (None:
    :func:`standard_terms`)
    """

    name: str
    words: str
    conductivity_share: float = 0.0
    patches: bool = False
    blendable: bool = False
    form_partner: str | None = None
    build: Callable | None = None

    def terms(self, setting: CavitySetting) -> CavityTerms:
        """What this law adds to the problem of ``setting`` (its build hook)."""
        return (self.build or standard_terms)(self, setting)


#: the laws: name -> :class:`CavityLaw`, in the order they were registered
CAVITY_LAWS: dict = {}


def register_cavity_law(name: str, words: str, *, conductivity_share: float = 0.0, patches: bool = False,
                        blendable: bool = False, form_partner: str | None = None,
                        build: Callable | None = None) -> CavityLaw:
    """Add the cavity law ``name`` to :data:`CAVITY_LAWS` (a name already there is refused: ValueError)."""
    if name in CAVITY_LAWS:
        raise ValueError(f"cavity law {name!r} is already registered")
    law = CavityLaw(name, words, conductivity_share=float(conductivity_share), patches=patches, blendable=blendable,
                    form_partner=form_partner, build=build)
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
                    "a radiosity solve)", patches=True, blendable=True, form_partner="effective")
register_cavity_law(NO_CAVITY_RADIATION, "no radiation inside the cavity")
