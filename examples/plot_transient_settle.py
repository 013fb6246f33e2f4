"""
A power-on transient and its settle times
=========================================

The reference unit's air scheme (no fill: the main board on its standoffs in air) switched on at the
ambient (70 °C) and solved in time with
``imutherm solve --transient``: adaptive TR-BDF2 steps under a local error tolerance at the sensor sites.
Each site's rise, its t63 and its t95 (the times to 63 % and 95 % of its steady rise) are in
``result.json``; the curves are in ``probes.csv`` (``time_s`` and one column per site, °C).

Coarse mesh and a loose tolerance (0.05 K, five times the default) to keep the example short; the run
stops once every site has settled (``--until-settled``).
"""

# %%
# The transient
# -------------
import csv
import json
import os
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from imutherm.cli import main as imutherm

OUT = Path(os.environ.get("IMUTHERM_EXAMPLES_OUT", tempfile.gettempdir())) / "imutherm-examples" / "transient"
COARSE = ["--mesh-size", "6", "--min-cells", "1", "--no-progress"]
SCHEMES = ("air",)   # add "grease", "potted" to compare the schemes (about a minute each here)

results, curves = {}, {}
for scheme in SCHEMES:
    out = OUT / scheme
    status = imutherm(["solve", "--scheme", scheme, "--transient", "--t-end", "1500", "--time-tol", "0.05",
                       "--until-settled", *COARSE, "--out", str(out)])
    assert status == 0, status
    results[scheme] = json.loads((out / "result.json").read_text())
    with open(out / "probes.csv", newline="") as f:
        rows = list(csv.reader(f))
    curves[scheme] = (rows[0], np.array(rows[1:], dtype=float))

# %%
# The settle times
# ----------------
# The rise and t95 of every sensor site (``None``: not settled by the end).
sites = [s for s in results["air"]["sites"] if s.startswith(("gyro", "accel"))]
print("site     " + "  ".join(f"{s:>14}" for s in SCHEMES))
for site in sites:
    cells = []
    for s in SCHEMES:
        r = results[s]["sites"][site]
        cells.append(f"{r['rise_K']:5.2f} K " + (f"{r['t95_s']:4.0f} s" if r["t95_s"] is not None else "not settled"))
    print(f"{site:8} " + "  ".join(f"{c:>14}" for c in cells))

# %%
# The curves, t95 marked
# ----------------------
fig, axes = plt.subplots(1, len(SCHEMES), figsize=(5 + 3 * len(SCHEMES), 4), sharey=True, squeeze=False)
axes = axes[0]
for ax, scheme in zip(axes, SCHEMES):
    header, data = curves[scheme]
    t = data[:, 0]
    for site in sites:
        col = header.index(site)
        line, = ax.plot(t, data[:, col] - results[scheme]["ambient_C"], label=site)
        t95 = results[scheme]["sites"][site]["t95_s"]
        if t95 is not None:
            ax.plot(t95, np.interp(t95, t, data[:, col]) - results[scheme]["ambient_C"], "o", color=line.get_color())
    ax.set(title=f"{scheme}: max rise {results[scheme]['max_rise_K']:.1f} K", xlabel="time after power-on [s]")
    ax.grid(alpha=0.3)
axes[0].set_ylabel("rise above ambient [K]")
axes[-1].legend(ncol=2, fontsize=8, title="dots: t95")
plt.show()
