"""
Correlation on data with a hidden effect
========================================

``imutherm correlate`` compares measured site temperatures with the model, re-tunes the model's uncertain
parameters within their sources' ranges, fits each candidate effect of its library on top, ranks them by
held-out prediction (and AICc with an effective sample size) and names the missing effect — or says that
none is missing, or that it is not in the library.

To see it work blind, "measured" data are generated here by the full nonlinear model with one effect
hidden (:func:`imutherm.studies.correlation.hidden_effect.make_case`): 0.35 W more in the 5 V regulator than the
layout says, ±10 % nuisance errors on the board conductivity, the convection and the mount conductance,
0.05 K probe noise and a fixed offset per site. The generator's mesh (3 mm) is finer than the
inversion's (6 mm), so the inversion does not see its own discretisation. One experiment (the air scheme at
70 °C) keeps it short; the full model is not re-run for the "after" figures (``--no-rerun``).
"""

# %%
# Generate the "measured" file
# ----------------------------
import json
import os
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from imutherm.cli import main as imutherm
from imutherm.measured import read_measured
from imutherm.studies.correlation.hidden_effect import make_case

OUT = Path(os.environ.get("IMUTHERM_EXAMPLES_OUT", tempfile.gettempdir())) / "imutherm-examples" / "correlation"
case = make_case(OUT / "case", "power@reg_5v", np.random.default_rng(3), experiments=(("air", 70.0),),
                 mesh_size_mm=3.0, min_cells=1, value=0.35, noise_K=0.05, samples=30)
print(f"hidden: {case.hidden} = {case.value} W; nuisance {case.nuisance}; files {[Path(f).name for f in case.files]}")
print(Path(case.files[0]).read_text().splitlines()[:4])

# %%
# Correlate it
# ------------
assert imutherm(["correlate", "--measured", *map(str, case.files), "--mesh-size", "6", "--min-cells", "1",
                 "--jobs", "1", "--no-rerun", "--no-report", "--out", str(OUT / "corr")]) == 0
res = json.loads((OUT / "corr" / "correlation.json").read_text())
print(f"verdict {res['verdict']}: {res['named_effect']}")
for name, p in res["parameters"].items():
    print(f"  {name:22} {p['value']:.4g} {p['unit']}  95 % interval {p['ci95']}")
print((OUT / "corr" / "updated_model.toml").read_text())

# %%
# The measured curves and the candidates' held-out error
# ------------------------------------------------------
run = read_measured(case.files[0])
fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4))
for j, site in enumerate(run.sites):
    a.plot(run.times_s, run.values_C[:, j], ".-", label=site)
a.set(xlabel="time after power-on [s]", ylabel="measured [°C]", title=f"{Path(run.path).name} ({run.scheme})")
a.legend(fontsize=8)
ranking = sorted(res["ranking"], key=lambda r: r["heldout_rms_K"])[:8]
b.barh([r["name"] for r in ranking][::-1], [r["heldout_rms_K"] for r in ranking][::-1])
b.axvline(res["noise_K"], color="k", ls="--", lw=0.8, label=f"noise estimate {res['noise_K']:.3f} K")
b.set(xlabel="held-out RMS [K]", title=f"verdict: {res['verdict']} {res['named_effect'] or ''}")
b.legend(fontsize=8)
fig.tight_layout()
plt.show()
