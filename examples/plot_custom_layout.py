"""
Your own layout: a modified TOML file
=====================================

A layout is a TOML file (``layouts/imu_reference.toml`` is the paper's unit): the housing, the mounting,
the boards, the parts and components with their powers, the sensor sites and the cooling schemes, every
number with its source. Here a copy of the reference layout is changed in one place — its
``[electrical]`` supply: 6.5 V instead of the assumed 9 V, so the 5 V linear regulator drops
(6.5 − 5) V × 213.1 mA + 6.5 V × 5 mA = 0.352 W instead of 0.897 W (the regulators' losses follow from the
supply and the rails' load currents) — and both units are drawn (``imutherm geometry``) and solved steady
(``imutherm solve``).

Any layout file, or a built-in name (``imu_reference``, ``imu_cardguide``), is the first argument of
``geometry``, ``solve``, ``compare``, ``sweep`` and ``correlate``. A layout that fails a check (a part
outside its board, a power beyond 100 W, a typo in a key) is refused in one line naming the file, the part
and the field.
"""

# %%
# Copy the reference layout and change it
# ---------------------------------------
import json
import os
import re
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from imutherm.cli import main as imutherm
from imutherm.geometry.electrical import rail_losses
from imutherm.geometry.layout import default_layout_path, load_layout

OUT = Path(os.environ.get("IMUTHERM_EXAMPLES_OUT", tempfile.gettempdir())) / "imutherm-examples" / "custom_layout"
OUT.mkdir(parents=True, exist_ok=True)
COARSE = ["--mesh-size", "6", "--min-cells", "1"]

text = default_layout_path().read_text(encoding="utf-8")
text = text.replace('name = "imu_reference"', 'name = "imu_6v_supply"', 1)
text, n = re.subn(r"^supply_V = 9\.0 .*$", "supply_V = 6.5   # a 6.5 V supply", text, flags=re.M)
assert n == 1
mine = OUT / "imu_6v_supply.toml"
mine.write_text(text, encoding="utf-8")
for layout in ("imu_reference", mine):   # the 5 V regulator's loss, as the layout's [electrical] gives it
    loss = rail_losses(load_layout(layout).electrical)["reg_5v"]
    print(f"{Path(layout).stem}: reg_5v dissipates {loss.formula} = {loss.loss_W:.3f} W")

# %%
# Draw it and solve both units
# ----------------------------
assert imutherm(["geometry", str(mine), "--scheme", "grease", *COARSE, "--out", str(OUT / "geometry")]) == 0
rises = {}
for name, layout in (("reference (9 V)", "imu_reference"), ("6.5 V supply", str(mine))):
    out = OUT / ("solve_" + Path(layout).stem)
    assert imutherm(["solve", layout, "--scheme", "grease", *COARSE, "--no-progress", "--out", str(out)]) == 0
    rises[name] = json.loads((out / "result.json").read_text())

# %%
# The unit, as ``imutherm geometry`` draws it
# -------------------------------------------
fig, ax = plt.subplots(figsize=(10, 5))
ax.imshow(plt.imread(OUT / "geometry" / "layout.png"))
ax.set_axis_off()

# %%
# What the change does at the sensor sites
# ----------------------------------------
sites = list(rises["6.5 V supply"]["sites"])
fig, ax = plt.subplots(figsize=(9, 3.6))
width = 0.4
for i, (name, res) in enumerate(rises.items()):
    ax.bar(np.arange(len(sites)) + (i - 0.5) * width, [res["sites"][s]["rise_K"] for s in sites], width,
           label=f"{name}: max {res['max_rise_K']:.1f} K ({res['hottest_part']}), {res['power_W']:.2f} W")
ax.set_xticks(np.arange(len(sites)), sites)
ax.set(ylabel="steady rise [K]", title="grease scheme, steady, at 70 °C")
ax.legend()
plt.show()
