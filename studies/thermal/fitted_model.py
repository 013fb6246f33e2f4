"""The model ``imutherm correlate`` fitted, read back from its ``updated_model.toml`` so that ``solve``,
``compare`` and ``sweep`` run on it (``--model FILE``).

The file holds ``[retune]`` (re-tune knob -> value, :data:`imutherm.unit.knobs.RETUNE` and the form knobs
:data:`~imutherm.unit.knobs.FORM_RETUNE`), ``[effects]``
(``"name@target" = { param = value }``, one entry per named effect), and, from this version on,
``[model]`` (the layout and the model switches correlate ran with) and ``[correlation]`` (verdict and
RMS before / after). A fitted model acts on a run as:

- ``power_scale`` and ``power@part`` effects: the layout's powers (every component and part x the scale,
  then the part's extra [W]); a power of the electrical design becomes explicit at its fitted value;
- the other re-tune knobs and the option-type effects (contacts, emissivities): the model options;
- ``fixture_leak`` (an extra boundary law): an effect of the run (:func:`fitted_effects`);
- signal effects (``probe_lag``, ``ambient_drift``) describe the measurement, not the unit: they are
  not applied to a design study (listed in :attr:`FittedModel.skipped`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

from imutherm import InputError
from imutherm.geometry.layout import LayoutSpec
from imutherm.geometry.materials import with_properties
from imutherm.textio import read_text
from imutherm.unit.effects import EFFECTS, apply_model_effects, effect_of, setting
from imutherm.unit.knobs import FORM_IN_DOUBT, FORM_RETUNE, RETUNE, effect_knob
from imutherm.unit.model import ModelOptions

try:  # Python >= 3.11
    import tomllib
except ModuleNotFoundError:  # pragma: no cover
    import tomli as tomllib

#: the model switches ``[model]`` may carry (the CLI's model options)
OPTION_FIELDS = {"exterior": str, "h_fixed_W_m2K": float, "radiation": bool, "emissivity": float,
                 "mounting_conductance_W_m2K": float, "cavity_radiation": bool, "cavity_law": str,
                 "cavity_patch_mm": float, "cavity_max_patches": int}
MAX_MODEL_BYTES = 2**16


@dataclass(frozen=True)
class FittedModel:
    """A correlated model.

    path : str, the file; layout : str or None, the layout file correlate ran on
    options : dict, model switches correlate ran with (``OPTION_FIELDS``)
    retune : dict, re-tune knob -> value (units of :data:`RETUNE`)
    effects : tuple of EffectSetting, the named effect(s)
    correlation : dict, ``verdict``, ``rms_before_K``, ``rms_after_K`` ... (empty for an older file)
    skipped : tuple of str, effects not applied to a design study (signal effects)
    """

    path: str
    layout: str | None
    options: dict
    retune: dict
    effects: tuple
    correlation: dict
    skipped: tuple

    def summary(self) -> dict:
        """What a report says about the model it ran on."""
        return {"file": self.path, "layout": self.layout, "retune": dict(self.retune),
                "effects": [e.text() for e in self.effects], "not_applied": list(self.skipped),
                "options": dict(self.options), **self.correlation}

    def line(self) -> str:
        """One line for page 1 of a report / stdout."""
        c = self.correlation
        rms = (f"; correlation RMS {c['rms_before_K']:.2f} -> {c['rms_after_K']:.2f} K"
               if c.get("rms_before_K") is not None and c.get("rms_after_K") is not None else "")
        eff = ", ".join(e.text() for e in self.effects) or "no named effect"
        return (f"model: {self.path} (correlated: {c.get('verdict', 'verdict not recorded')}; {eff}"
                f"{rms})")


def load_fitted_model(path) -> FittedModel:
    """Read and check an ``updated_model.toml``; InputError naming the file and the field."""
    p = Path(path)
    if not p.is_file():
        raise InputError(f"--model {path}: no such file (give the updated_model.toml that imutherm correlate wrote)")
    text = read_text(p, "model file", MAX_MODEL_BYTES)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
    unknown = sorted(set(data) - {"model", "correlation", "retune", "effects"})
    if unknown:
        raise InputError(f"{path}: unknown table(s) {', '.join(unknown)}; valid: model, correlation, retune, effects")
    bounds = {k.name: k for k, _ in RETUNE} | {n: effect_knob(n) for n in (*FORM_RETUNE, *FORM_IN_DOUBT)}
    retune = {}
    for name, v in data.get("retune", {}).items():
        if name not in bounds:
            raise InputError(f"{path}: [retune]: unknown knob {name!r}; valid: {', '.join(bounds)}")
        k = bounds[name]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not k.lo <= v <= k.hi:
            raise InputError(f"{path}: [retune]: {name} = {v!r} is outside its source's range {k.lo:g}..{k.hi:g} {k.unit}")
        retune[name] = float(v)
    effects, skipped = [], []
    for name, params in data.get("effects", {}).items():
        if not isinstance(params, dict):
            raise InputError(f"{path}: [effects]: {name!r} must be an inline table {{ param = value }}")
        try:
            s = setting(name, **params)
        except (InputError, TypeError) as exc:
            raise InputError(f"{path}: [effects]: {name!r}: {exc}") from None
        (skipped if EFFECTS[s.base].kind == "signal" else effects).append(s)
    model = data.get("model", {})
    options = {}
    for name, v in model.items():
        if name == "layout":
            continue
        if name not in OPTION_FIELDS:
            raise InputError(f"{path}: [model]: unknown field {name!r}; valid: layout, {', '.join(OPTION_FIELDS)}")
        options[name] = OPTION_FIELDS[name](v)
    try:
        ModelOptions(**options)
    except InputError as exc:
        raise InputError(f"{path}: [model]: {exc}") from None
    layout = model.get("layout")
    return FittedModel(str(path), str(layout) if layout else None, options, retune, tuple(effects),
                       dict(data.get("correlation", {})), tuple(s.text() for s in skipped))


def fitted_options(model: FittedModel, options: ModelOptions | None = None, layout: LayoutSpec | None = None,
                   geometry=None) -> ModelOptions:
    """``options`` (default: the model's own switches) with the fitted re-tune knobs and option-type effects.

    ``layout`` names the board materials for ``k_board_W_mK``; ``geometry`` (any scheme of the layout) is
    needed for the option-type effects other than the bond contact (lid, board joints, emissivities).
    """
    opts = options if options is not None else ModelOptions(**model.options)
    r = model.retune
    if "mount_h_W_m2K" in r:
        opts = opts.with_(mounting_conductance_W_m2K=r["mount_h_W_m2K"])
    if "convection_scale" in r:
        opts = opts.with_(convection_scale=r["convection_scale"])
    if "emissivity_ext" in r:
        opts = opts.with_(emissivity=r["emissivity_ext"])
    for name, v in r.items():  # the form knobs (knobs.FORM_RETUNE, FORM_IN_DOUBT): as each effect sets them
        e = EFFECTS.get(name)
        if e is not None and e.as_options is not None:
            opts = e.as_options(opts, v)
    if "k_board_W_mK" in r:
        if layout is None:
            raise InputError("fitted_options: k_board_W_mK needs the layout (its boards' materials)")
        mats = sorted({b.material for b in layout.boards})
        over = tuple(with_properties(opts.material(m), "fitted k_board_W_mK", k_in_plane=r["k_board_W_mK"])
                     for m in mats)
        opts = opts.with_(materials=tuple(m for m in opts.materials if m.name not in mats) + over)
    for s in model.effects:
        e = effect_of(s.name)
        if e.carried != "options":
            continue  # the layout's powers / a boundary law of the run
        if s.target in e.target_options:  # e.g. contact@bond: acts where there are bond lines, whatever the scheme
            opts = opts.with_(**{e.target_options[s.target]: s.value(e.params[0].name)})
            continue
        if geometry is None:
            raise InputError(f"fitted_options: effect {s.text()} needs the unit's geometry")
        opts = apply_model_effects(geometry, opts, (s,)).options
    return opts


def fitted_layout(model: FittedModel, layout: LayoutSpec) -> LayoutSpec:
    """The layout with the fitted powers: every power x ``power_scale``, then each ``power@part`` extra [W]."""
    scale = model.retune.get("power_scale", 1.0)
    extra = {s.target: s.value(effect_of(s.name).params[0].name) for s in model.effects
             if effect_of(s.name).carried == "layout"}
    names = {c.name for c in layout.components} | {p.name for p in layout.parts}
    for part in extra:
        if part not in names:
            raise InputError(f"{model.path}: effect power@{part}: the layout {layout.path} has no part {part!r}")
    if scale == 1.0 and not extra:
        return layout

    def fitted(x):
        w = x.power_W * scale + extra.get(x.name, 0.0)
        if w < 0:
            raise InputError(f"{model.path}: the fitted power of {x.name!r} is {w:g} W (< 0)")
        what = f"fitted ({model.path}): {x.power_W:.4g} W x {scale:g}" + (
            f" {extra[x.name]:+.4g} W" if x.name in extra else "")
        return replace(x, power_W=w, **({"power_source": what} if hasattr(x, "power_source") else {}))

    return replace(layout, components=tuple(fitted(c) for c in layout.components),
                   parts=tuple(fitted(p) for p in layout.parts))


def fitted_effects(model: FittedModel) -> tuple:
    """The effects a run on the fitted model switches on itself: the boundary-law ones (``fixture_leak``)."""
    return tuple(s for s in model.effects if effect_of(s.name).carried == "run")


def apply_fitted(model: FittedModel, layout: LayoutSpec, options: ModelOptions | None = None) -> tuple:
    """(layout, options, effects) of a run on ``model``: :func:`fitted_layout`, :func:`fitted_options` (on the
    layout's default scheme's geometry), :func:`fitted_effects`."""
    from imutherm.geometry.build import build_geometry

    geo = build_geometry(layout, None) if any(effect_of(s.name).carried == "options"
                                              for s in model.effects) else None
    return (fitted_layout(model, layout), fitted_options(model, options, layout, geo), fitted_effects(model))
