"""Synthetic "measured" data with one effect hidden, to prove the correlation workflow blind.

:func:`make_case` runs the full nonlinear model (a finer mesh than the inversion's, its own
adaptive time steps) for each experiment with

- one hidden effect of the library at a random magnitude within its physical bounds (or none, or
  an effect outside the library: a radiant heat load on the lid, :data:`OUT_OF_LIBRARY`),
- nuisance errors: the board conductivity, the convection coefficient and the mount conductance
  each off by a uniform ±``nuisance`` (default 10 %),
- probe noise (Gaussian, ``noise_K``) and a fixed offset per site (uniform ±``offset_K``),

and writes one measured file per experiment. Everything is drawn from the ``numpy.random.Generator``
given, so a case is reproducible from its seed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from imutherm.geometry.build import build_geometry
from imutherm.geometry.layout import LayoutSpec, load_layout
from imutherm.geometry.mesh import DEFAULT_MIN_CELLS, build_mesh
from imutherm.measured import write_measured
from imutherm.thermal import knobs as K
from imutherm.studies.forward import full_rise
from imutherm.thermal.effects import EFFECTS, ModelVariant, effect_of, setting
from imutherm.thermal.model import ModelOptions
from imutherm.thermal.problem import HeatFlux

#: the effect outside the library: a radiant load on the lid (a lamp or the sun), q [W/m^2]
OUT_OF_LIBRARY = "lid_heat_load"
OUT_OF_LIBRARY_RANGE = (150.0, 400.0)
#: the sites a generated file holds (the paper's IR points and the three gyros)
DEFAULT_SITES = ("tp1", "tp2", "tp3", "gyro_x", "gyro_y", "gyro_z")


@dataclass(frozen=True)
class HiddenCase:
    """One generated case: what was hidden and where its files are.

    hidden : str ('none', an effect name, or OUT_OF_LIBRARY), value : float or None [unit]
    nuisance : dict knob -> value, files : tuple of paths
    """

    hidden: str
    value: float | None
    nuisance: dict
    files: tuple
    seed: int


def draw_value(name: str, rng: np.random.Generator) -> float:
    """A random magnitude of effect ``name`` within its bounds (log-uniform for log parameters).

    Contacts are drawn from their lower two decades (a joint that matters), powers as a missing or
    extra 0.1..0.5 W.
    """
    if name == OUT_OF_LIBRARY:
        return float(rng.uniform(*OUT_OF_LIBRARY_RANGE))
    p = effect_of(name).params[0]
    if name.startswith("contact@"):
        return float(np.exp(rng.uniform(math.log(p.lo * 2), math.log(p.lo * 100))))
    if name.startswith("power@"):
        return float(rng.choice([-1, 1]) * rng.uniform(0.1, 0.5))
    if name in ("emissivity", "cavity_emissivity"):
        return float(rng.uniform(p.lo, 0.3))
    if name == "ambient_drift":
        return float(rng.choice([-1, 1]) * rng.uniform(4.0, p.hi))
    if p.log:
        return float(np.exp(rng.uniform(math.log(p.lo), math.log(p.hi))))
    return float(rng.uniform(p.lo, p.hi))


def make_case(out_dir, hidden: str, rng: np.random.Generator, *, layout: LayoutSpec | str | None = None,
              experiments=(("air", 70.0), ("grease", 70.0)), sites=DEFAULT_SITES, mesh_size_mm: float = 1.5,
              min_cells: int = DEFAULT_MIN_CELLS, t_end: float = 1500.0, samples: int = 40,
              noise_K: float = 0.05, offset_K: float = 0.1, nuisance: float = 0.10, value: float | None = None,
              seed: int = 0) -> HiddenCase:
    """Generate the measured files of one case into ``out_dir`` (see the module docstring)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    if not isinstance(layout, LayoutSpec):
        layout = load_layout(layout)
    if hidden != "none" and hidden != OUT_OF_LIBRARY:
        effect_of(hidden)
    v = value if value is not None or hidden == "none" else draw_value(hidden, rng)
    nz = {"k_board_W_mK": 17.7 * (1 + rng.uniform(-nuisance, nuisance)),
          "convection_scale": 1 + rng.uniform(-nuisance, nuisance),
          "mount_h_W_m2K": 500.0 * (1 + rng.uniform(-nuisance, nuisance))}
    files = []
    for scheme, amb in experiments:
        lay = replace(layout, ambient_C=amb, mounting=replace(layout.mounting, temperature_C=amb))
        geo = build_geometry(lay, scheme)
        values = dict(nz)
        is_model = hidden not in ("none", OUT_OF_LIBRARY) and EFFECTS[hidden.split("@")[0]].kind == "model"
        if is_model and K.applicable(hidden, geo):  # a bond contact exists only where there is a bond line
            values[hidden] = v
        variant = K.variant(geo, ModelOptions(), values)
        if hidden == OUT_OF_LIBRARY:
            extra = dict(variant.extra_laws)
            extra["zmax"] = extra.get("zmax", ()) + (HeatFlux(v),)
            variant = ModelVariant(variant.geometry, variant.options, extra)
        grid = build_mesh(variant.geometry, mesh_size_mm, min_cells)
        sig = [setting(hidden, **{effect_of(hidden).params[0].name: v})] if (
            hidden not in ("none", OUT_OF_LIBRARY) and not is_model) else []
        times = np.linspace(0.0, t_end, samples)
        rise = full_rise(variant, grid, {s: geo.sites[s] for s in sites}, times, sig)
        meas = amb + rise + rng.normal(0.0, noise_K, rise.shape) + rng.uniform(-offset_K, offset_K, len(sites))
        path = out_dir / f"{scheme}_{amb:g}C.csv"
        write_measured(path, {"scheme": scheme, "ambient_C": amb}, sites, times, meas)
        files.append(str(path))
    return HiddenCase(hidden, v, nz, tuple(files), seed)
