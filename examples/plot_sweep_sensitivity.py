"""
A parameter sweep and its sensitivity
=====================================

``imutherm sweep`` runs one scheme over a design of inputs, each named by a dotted key into the layout
(``components.reg_5v.power_W``), a material of the scheme (``materials.silicone_grease.k``) or the model
options (``options.emissivity``). It writes ``results.csv`` (a row per case, appended as cases finish, so
``--resume`` after a kill runs only the missing ones), ``sweep.json`` (the design and the ranking of the
inputs' influence) and ``sweep.pdf``.

Here a small Latin hypercube (SALib) over three inputs on a coarse mesh, one local process. The influence
measure of an LHS or grid design is the standardised regression coefficient (SRC) of a linear fit, with
its R²; a Morris design (``--method morris``) gives Morris μ* and σ. Add ``--jobs N`` for local worker
processes or ``--dask tcp://host:port`` for a Dask cluster.
"""

# %%
# Run the sweep
# -------------
import csv
import json
import os
import shutil
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from imutherm.cli import main as imutherm

OUT = Path(os.environ.get("IMUTHERM_EXAMPLES_OUT", tempfile.gettempdir())) / "imutherm-examples" / "sweep"
shutil.rmtree(OUT, ignore_errors=True)     # a folder holding a sweep is refused without --resume
INPUTS = {"components.reg_5v.power_W": "0.2:1.2", "materials.silicone_grease.k": "0.3:1.5",
          "mounting.contact_conductance_W_m2K": "200:2000"}
args = ["sweep", "--scheme", "grease", "--method", "lhs", "--samples", "6", "--seed", "1", "--jobs", "1",
        "--mesh-size", "6", "--min-cells", "1", "--no-progress", "--out", str(OUT)]
for key, values in INPUTS.items():
    args += ["--set", f"{key}={values}"]
assert imutherm(args) == 0

# %%
# The results and the ranking
# ---------------------------
with open(OUT / "results.csv", newline="") as f:
    rows = [r for r in csv.DictReader(f) if r["status"] == "ok"]
sweep = json.loads((OUT / "sweep.json").read_text())
sens = sweep["sensitivity"]            # measure (src or morris), ranking, per output: r2 and by_key
hot = sens["outputs"]["max_rise_K"]
print(f"{len(rows)} cases ok; influence on max_rise_K ({sens['measure']}, R^2 {hot['r2']:.3f}):")
for key in sens["ranking"]:
    print(f"  {key:36} {hot['by_key'][key]['src']:+.3f}")

# %%
# Each input against the hot spot, and the influence ranking
# ----------------------------------------------------------
rise = np.array([float(r["max_rise_K"]) for r in rows])
fig, axes = plt.subplots(1, len(INPUTS) + 1, figsize=(13, 3.4))
for ax, key in zip(axes, INPUTS):
    ax.plot([float(r[key]) for r in rows], rise, "o")
    ax.set(xlabel=key.split(".", 1)[1], ylabel="max rise [K]" if ax is axes[0] else None)
    ax.grid(alpha=0.3)
names = list(INPUTS)
axes[-1].barh([k.split(".", 1)[1] for k in names], [hot["by_key"][k]["src"] for k in names])
axes[-1].axvline(0, color="k", lw=0.8)
axes[-1].set(title=f"SRC on max rise (R² {hot['r2']:.2f})", xlabel="standardised regression coefficient")
fig.tight_layout()
plt.show()
