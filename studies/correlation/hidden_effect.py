"""Synthetic "measured" data with one effect hidden, to prove the correlation workflow blind.

:func:`make_case` runs the full nonlinear model (a finer mesh than the inversion's, its own
adaptive time steps) for each experiment with

- one hidden effect of the library at a random magnitude within its physical bounds (or none, or
  an effect outside the library, :data:`OUT_OF_LIBRARY_KINDS`: a radiant heat load on the lid, the
  test chamber cycling under its thermostat, an unlogged power-mode change part way through the test),
- nuisance errors: the board conductivity, the convection coefficient and the mount conductance
  each off by a uniform ±``nuisance`` (default 10 %) from the unit's nominal values
  (:func:`imutherm.unit.knobs.nominal_values`: its layout and materials),
- probe noise (Gaussian, ``noise_K``) and a fixed offset per site (uniform ±``offset_K``),

and writes one measured file per experiment. Everything is drawn from the ``numpy.random.Generator``
given, so a case is reproducible from its seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from imutherm import InputError
from imutherm.geometry.build import build_geometry
from imutherm.geometry.layout import LayoutSpec, load_layout
from imutherm.geometry.mesh import DEFAULT_MIN_CELLS, build_mesh
from imutherm.measured import write_measured
from imutherm.unit import knobs
from imutherm.studies.thermal.forward import checked_rise, full_rise, switched_rise
from imutherm.unit.effects import EFFECTS, ModelVariant, effect_of, power_part, setting
from imutherm.unit.cavity_laws import cavity_law
from imutherm.unit.model import ModelOptions
from imutherm.thermal.problem import HeatFlux

#: an effect outside the library: a radiant load on the lid (a lamp or the sun), q [W/m^2]
OUT_OF_LIBRARY = "lid_heat_load"
OUT_OF_LIBRARY_RANGE = (150.0, 400.0)

#: outside the library: the chamber's air, walls and fixture cycle under its on/off thermostat,
#: a cos(2 pi t / period + phase), the unit having cycled with them before power-on (periodic steady
#: state). Assumed ranges: amplitude 0.5-1.5 K, period 200-600 s, the band of an oven or chamber
#: under on/off (bang-bang) control; a PID-controlled climatic chamber holds ±0.1-0.5 K (the
#: "temperature fluctuation" of chamber datasheets, measured as IEC 60068-3-5 describes). Period and
#: amplitude belong to the chamber (the same in both experiments of a case), the phase to the test.
#: The library has a linear ambient drift, not an oscillation.
CHAMBER_CYCLING = "chamber_cycling"
CHAMBER_AMPLITUDE_K = (0.5, 1.5)
CHAMBER_PERIOD_S = (200.0, 600.0)

#: outside the library: the DSP changes power mode (full rate <-> idle) at an unlogged time after
#: power-on, and its core current change dI flows through the cascade of linear regulators, so each
#: part's power changes by dI times its voltage drop [V = W/A] (the layout's power budget:
#: 9 V -> 5 V -> 3.3 V -> 1.8 V, the core at 1.8 V): 9 dI in all. |dI| 40-100 mA, sign random
#: (assumed: the order of a C28x-class DSP's run-vs-idle core current, ~150 mA at 100 MHz against a
#: few tens of mA idle), i.e. 0.36-0.9 W in all; the switch time uniform in 300-1000 s of the
#: 1500 s record (after the first time constant, before the last third), drawn per experiment.
#: The library's power errors are constant from power-on.
POWER_MODE_STEP = "power_mode_step"
POWER_MODE_CHAIN_V = {"processor": 1.8, "reg_1v8": 3.3 - 1.8, "reg_3v3": 5.0 - 3.3, "reg_5v": 9.0 - 5.0}
POWER_MODE_DI_A = (0.040, 0.100)
POWER_MODE_T_S = (300.0, 1000.0)

#: re-tune parameters hidden far from their nominal: not a library effect, a *finding* of the re-tune (a mount
#: conductance at 0.3-0.5x its layout's 500 W/m^2 K: a fixture bolted loosely or on a painted face; the
#: second blind campaign of the correlation had one at 0.42x)
FINDING_KINDS = ("mount_h_W_m2K",)
FINDING_FACTOR = (0.3, 0.5)

#: every kind of hidden effect outside the library the generator makes
OUT_OF_LIBRARY_KINDS = (OUT_OF_LIBRARY, CHAMBER_CYCLING, POWER_MODE_STEP)
#: the sites a generated file holds (the paper's IR points and the three gyros)
DEFAULT_SITES = ("tp1", "tp2", "tp3", "gyro_x", "gyro_y", "gyro_z")


@dataclass(frozen=True)
class HiddenCase:
    """One generated case: what was hidden and where its files are.

    hidden : str ('none', an effect name, or one of OUT_OF_LIBRARY_KINDS), value : float or None [unit]
    (lid load [W/m^2], chamber amplitude [K], core current change [A])
    nuisance : dict knob -> value, files : tuple of paths
    extra : dict, the out-of-library kinds' further draws (``period_s``, per-file ``phase_rad``,
    per-file ``t_switch_s``)
    """

    hidden: str
    value: float | None
    nuisance: dict
    files: tuple
    seed: int
    extra: dict = field(default_factory=dict)


#: the model-form paths of :func:`model_form_options`
MODEL_FORMS = ("cavity-law", "discretisation", "layered")
#: the ``discretisation`` path's s2s patches [mm] and rays per patch (the inversion's defaults: 5 mm, 400)
FORM_PATCH_MM, FORM_RAYS = 3.0, 1200


def model_form_options(inversion: ModelOptions | None = None, kind: str = "cavity-law") -> ModelOptions:
    """The generator's laws for a model-form case, given the inversion's.

    ``cavity-law``: the cavity-radiation law the inversion does not use (``s2s`` view factors and radiosity
    against the ``effective`` conductivity of the air, or the reverse), everything else as the inversion has
    it. The two laws differ in form, not by a parameter: on the reference unit the nominal air-scheme rise at
    tp1 is 24.1 K with s2s against 16.9 K effective (README, "The paper's own data"), more than any re-tune
    knob moves it alone. ``discretisation``: the same laws, the s2s cavity discretised otherwise (patches of
    :data:`FORM_PATCH_MM` with :data:`FORM_RAYS` rays each, against the inversion's; the generator's finer
    mesh does the rest), as an independent implementation of one law would be; the inversion must use s2s.
    """
    inv = inversion or ModelOptions()
    if kind == "cavity-law":
        return inv.with_(cavity_law=cavity_law(inv.cavity_law).form_partner or ModelOptions.cavity_law)
    if kind == "discretisation":
        if not cavity_law(inv.cavity_law).patches:
            raise InputError("model_form_options: the 'discretisation' path needs an s2s inversion")
        return inv.with_(cavity_patch_mm=FORM_PATCH_MM, cavity_max_patches=None, cavity_rays=FORM_RAYS)
    if kind == "layered":
        return inv.with_(contact_layers=True)
    raise InputError(f"model_form_options: unknown kind {kind!r}; valid: {', '.join(MODEL_FORMS)}")


def _is_part_power(name: str) -> bool:
    """Whether ``name`` is a library effect whose parameter is a part's extra power (not a kind outside it)."""
    e = EFFECTS.get(name.split("@", 1)[0])
    return e is not None and e.part_power


def draw_value(name: str, rng: np.random.Generator) -> float:
    """A random magnitude of effect ``name`` within its bounds (log-uniform for log parameters).

    Contacts are drawn from their lower two decades (a joint that matters), powers as a missing or
    extra 0.1..0.5 W (make_case keeps a missing power above 10 % of the part's own).
    """
    if name == OUT_OF_LIBRARY:
        return float(rng.uniform(*OUT_OF_LIBRARY_RANGE))
    if name == CHAMBER_CYCLING:
        return float(rng.uniform(*CHAMBER_AMPLITUDE_K))
    if name == POWER_MODE_STEP:
        return float(rng.choice([-1, 1]) * rng.uniform(*POWER_MODE_DI_A))
    e = effect_of(name)
    p = e.params[0]
    if e.draw is not None:  # the effect's own hidden range (beside its entry in imutherm.unit.effects)
        return e.draw(rng, p)
    if p.log:
        return float(np.exp(rng.uniform(math.log(p.lo), math.log(p.hi))))
    return float(rng.uniform(p.lo, p.hi))


def make_case(out_dir, hidden: str, rng: np.random.Generator, *, layout: LayoutSpec | str | None = None,
              experiments=(("air", 70.0), ("grease", 70.0)), sites=DEFAULT_SITES, mesh_size_mm: float = 1.5,
              min_cells: int = DEFAULT_MIN_CELLS, t_end: float = 1500.0, samples: int = 40,
              noise_K: float = 0.05, offset_K: float = 0.1, nuisance: float = 0.10, value: float | None = None,
              seed: int = 0, options: ModelOptions | None = None, also: dict | None = None,
              nuisance_all: bool = False, power_scale: float = 1.0) -> HiddenCase:
    """Generate the measured files of one case into ``out_dir`` (see the module docstring).

    also : further library model effects hidden beside ``hidden``, name -> value [unit] (two effects at once:
        ``hidden='power@reg_5v', also={'contact@bond': 150.0}``); recorded in ``extra['also']``
    power_scale : the unit run at this fraction of its nominal power [-] (written in the files' header): a
        proposed next experiment (:mod:`imutherm.studies.correlation.next_experiment`)
    options : the generator's model laws (default: the library's defaults). A *model-form* case takes laws
        the inversion does not use (:func:`model_form_options`: the other cavity-radiation law), so the
        data differ from the inversion's model in form, not only in mesh and nuisance values.
    """
    options = options or ModelOptions()
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if not isinstance(layout, LayoutSpec):
        layout = load_layout(layout)
    if hidden != "none" and hidden not in OUT_OF_LIBRARY_KINDS and hidden not in FINDING_KINDS:
        effect_of(hidden)
    if hidden in FINDING_KINDS:
        v = value if value is not None else float(knobs.nominal_values(build_geometry(layout, experiments[0][0]),
                                                                   options)[hidden] * rng.uniform(*FINDING_FACTOR))
    else:
        v = value if value is not None or hidden == "none" else draw_value(hidden, rng)
    extra = {}
    if hidden == CHAMBER_CYCLING:
        extra = {"period_s": float(rng.uniform(*CHAMBER_PERIOD_S)),
                 "phase_rad": [float(rng.uniform(0, 2 * np.pi)) for _ in experiments]}
    elif hidden == POWER_MODE_STEP:
        extra = {"t_switch_s": [float(rng.uniform(*POWER_MODE_T_S)) for _ in experiments]}
    if value is None and _is_part_power(hidden):  # a drawn missing power leaves the part >= 10 % of its own
        v = max(v, -0.9 * power_part(build_geometry(layout, experiments[0][0]), hidden.split("@", 1)[1]).power_W)
    # nuisance about the unit's own nominal values (its layout and materials), not the reference's
    nom = knobs.nominal_values(build_geometry(layout, experiments[0][0]), options)
    nz = {"k_board_W_mK": nom["k_board_W_mK"] * (1 + rng.uniform(-nuisance, nuisance)),
          "convection_scale": nom["convection_scale"] * (1 + rng.uniform(-nuisance, nuisance)),
          "mount_h_W_m2K": nom["mount_h_W_m2K"] * (1 + rng.uniform(-nuisance, nuisance))}
    if hidden in FINDING_KINDS:  # the hidden value replaces the parameter's nuisance draw
        nz[hidden] = v
    if nuisance_all:
        from imutherm.studies.correlation.form_generator import nuisance_options
        options, factors = nuisance_options(options, build_geometry(layout, experiments[0][0]), rng, nuisance)
        extra = {**extra, "nuisance_factors": factors}
    files = []
    for e, (scheme, amb) in enumerate(experiments):
        lay = replace(layout, ambient_C=amb, mounting=replace(layout.mounting, temperature_C=amb))
        geo = build_geometry(lay, scheme)
        values = dict(nz)
        if power_scale != 1.0:
            values["power_scale"] = float(power_scale)
        is_model = (hidden not in ("none", *OUT_OF_LIBRARY_KINDS, *FINDING_KINDS)
                    and EFFECTS[hidden.split("@")[0]].kind == "model")
        if is_model and knobs.applicable(hidden, geo):  # a bond contact exists only where there is a bond line
            values[hidden] = v
        for name, x in (also or {}).items():
            if EFFECTS[name.split("@")[0]].kind != "model":
                raise ValueError(f"make_case: also={name!r}: only model effects can be hidden beside another")
            if knobs.applicable(name, geo):
                values[name] = float(x)
        variant = knobs.variant(geo, options, values)
        if hidden == OUT_OF_LIBRARY:
            laws = dict(variant.extra_laws)  # (not ``extra``: that is the case's record)
            laws["zmax"] = laws.get("zmax", ()) + (HeatFlux(v),)
            variant = ModelVariant(variant.geometry, variant.options, laws)
        grid = build_mesh(variant.geometry, mesh_size_mm, min_cells)
        if variant.options.contact_layers:
            from imutherm.studies.correlation.form_generator import refine_contact_layers
            grid = refine_contact_layers(grid, variant.geometry, variant.options)
        sig = [setting(hidden, **{effect_of(hidden).params[0].name: v})] if (
            hidden not in ("none", *OUT_OF_LIBRARY_KINDS, *FINDING_KINDS) and not is_model) else []
        times = np.linspace(0.0, t_end, samples)
        probes = {s: geo.sites[s] for s in sites}
        if hidden == POWER_MODE_STEP:
            after = knobs.variant(geo, options, {**values, **{f"power@{p}": v * volts
                                                                 for p, volts in POWER_MODE_CHAIN_V.items()}})
            rise = switched_rise(variant, after, extra["t_switch_s"][e], grid, probes, times)
        else:
            cyc = (v, extra["period_s"], extra["phase_rad"][e]) if hidden == CHAMBER_CYCLING else None
            if variant.options.contact_layers and cyc is None:
                # the layered path: its own checked reduced transient (within 0.01 K of a tight full TR-BDF2 run
                # on the re-run's cases, in a third of the time: studies/thermal/forward.checked_rise), the full
                # adaptive one where the check fails
                rise = checked_rise(variant, grid, probes, times, sig)[0]
            else:
                rise = full_rise(variant, grid, probes, times, sig, ambient_cycle=cyc)
        meas = amb + rise + rng.normal(0.0, noise_K, rise.shape) + rng.uniform(-offset_K, offset_K, len(sites))
        path = out_dir / f"{scheme}_{amb:g}C.csv"
        meta = {"scheme": scheme, "ambient_C": amb, **({"power_scale": power_scale} if power_scale != 1.0 else {})}
        write_measured(path, meta, sites, times, meas)
        files.append(str(path))
    if also:
        extra = {**extra, "also": {k: float(x) for k, x in also.items()}}
    if options.contact_layers:
        extra = {**extra, "mesh_size_mm": float(mesh_size_mm), "contact_layers": True}
    return HiddenCase(hidden, v, nz, tuple(files), seed, extra)
