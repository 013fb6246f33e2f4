"""How far a generator of "measured" data is from the inversion's nominal model, on a null case (no effect hidden).

The size of a model-form path of the correlation campaign (``bench_correlation.py --model-form``): the
generator (:func:`imutherm.studies.correlation.hidden_effect.make_case`, full nonlinear model, its ±10 % nuisance, no
noise) against the inversion's reduced model at its nominal values, both schemes at 70 °C. Paths: the
campaign's own (``--model-form cavity-law`` / ``discretisation``), or the inversion's laws on another
generator mesh (``--gen-mesh-size``) or with a fixed exterior h (``--exterior-h``)::

    python benchmarks/bench_model_form_gap.py --model-form cavity-law
    python benchmarks/bench_model_form_gap.py --gen-mesh-size 14
    python benchmarks/bench_model_form_gap.py --exterior-h 10

Prints, per scheme, the RMS of nominal model minus data [K] and the relative plateau difference per site.
"""

from __future__ import annotations

import argparse
import tempfile
import time

import numpy as np

from imutherm.measured import read_measured
from imutherm.studies.correlation import build_models
from imutherm.studies.correlation.forward_model import ForwardModel
from imutherm.studies.correlation.hidden_effect import MODEL_FORMS, make_case, model_form_options

EXPERIMENTS = (("air", 70.0), ("grease", 70.0))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--model-form", choices=MODEL_FORMS, help="a campaign path (default: the inversion's laws)")
    ap.add_argument("--gen-mesh-size", type=float, default=3.0, help="generator mesh [mm] (default 3)")
    ap.add_argument("--exterior-h", type=float, help="generate with a fixed exterior h [W/m^2 K] on every free face")
    ap.add_argument("--mesh-size", type=float, default=6.0, help="inversion mesh [mm] (default 6)")
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    t0 = time.process_time()
    models = build_models(EXPERIMENTS, mesh_size_mm=a.mesh_size, min_cells=1)
    opts = model_form_options(models.options, a.model_form) if a.model_form else models.options
    if a.exterior_h is not None:
        opts = opts.with_(exterior="fixed", h_fixed_W_m2K=a.exterior_h)
    with tempfile.TemporaryDirectory() as tmp:
        case = make_case(tmp, "none", np.random.default_rng(a.seed), experiments=EXPERIMENTS,
                         mesh_size_mm=a.gen_mesh_size, min_cells=1, seed=a.seed, options=opts, samples=40)
        runs = [read_measured(f) for f in case.files]
    fwd = ForwardModel(tuple(runs), models.roms, models.geometries)
    print(f"generator: {a.model_form or 'the inversion laws'}, mesh {a.gen_mesh_size:g} mm"
          + (f", fixed exterior h {a.exterior_h:g} W/m^2 K" if a.exterior_h is not None else "")
          + f"; inversion mesh {a.mesh_size:g} mm; nuisance {case.nuisance}")
    for i, r in enumerate(runs):
        y = fwd.rise(i, dict(fwd.nominal))
        ok = np.isfinite(r.values_C)
        rms = float(np.sqrt(np.mean((y - r.rise_K)[ok] ** 2)))
        rel = (y[-1] - r.rise_K[-1]) / r.rise_K[-1]
        print(f"{r.name}: nominal minus data RMS {rms:.3f} K; plateau (model - data) / data per site "
              + ", ".join(f"{s} {v:+.3f}" for s, v in zip(r.sites, rel)))
    print(f"{time.process_time() - t0:.0f} CPU-s")


if __name__ == "__main__":
    main()
