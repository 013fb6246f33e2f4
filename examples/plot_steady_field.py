"""
A steady temperature field, for ParaView and as a slice
=======================================================

One cooling scheme of the reference unit solved steady with ``imutherm solve``: the field is written
to ``field.vtu`` (open it in ParaView: point data ``temperature_C``, cell data ``part``), and here read
back with meshio to draw two slices through the hot spot.

The mesh is coarse (6 mm cells, one cell across the thinnest part) so that the example runs in seconds;
its maximum rise, printed below, is a few tenths of a kelvin under the default mesh's (2 mm cells, two
across the thinnest part), which the answer table of ``imutherm compare`` in :doc:`/getting-started` gives.
"""

# %%
# Solve one scheme, steady
# ------------------------
# The command line is the main interface; ``imutherm.cli.main`` runs the same command in this process
# and returns its exit status. Every example writes under the system's temporary folder.
import json
import os
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import meshio
import numpy as np

from imutherm.cli import main as imutherm

OUT = Path(os.environ.get("IMUTHERM_EXAMPLES_OUT", tempfile.gettempdir())) / "imutherm-examples" / "steady_field"
COARSE = ["--mesh-size", "6", "--min-cells", "1", "--no-progress"]

status = imutherm(["solve", "--scheme", "grease", *COARSE, "--out", str(OUT)])
assert status == 0, status
result = json.loads((OUT / "result.json").read_text())
print(f"max rise {result['max_rise_K']:.2f} K in {result['hottest_part']} at {result['max_at_mm']} mm")
print(sorted(p.name for p in OUT.iterdir()))

# %%
# Read the VTU file back
# ----------------------
# The mesh is a tensor-product grid of boxes, so the points are the product of three sorted lists of
# grid lines, and the field is a 3-D array on them.
mesh = meshio.read(OUT / "field.vtu")
lines = [np.unique(mesh.points[:, i]) for i in range(3)]
index = tuple(np.searchsorted(lines[i], mesh.points[:, i]) for i in range(3))
field = np.full([len(v) for v in lines], np.nan)
field[index] = mesh.point_data["temperature_C"]
x, y, z = (1e3 * v for v in lines)      # [mm]
hot = np.array(result["max_at_mm"])
k = np.argmin(abs(z - hot[2]))
j = np.argmin(abs(y - hot[1]))

# %%
# Two slices through the hot spot
# -------------------------------
# Left: the horizontal plane at the hot spot's height (the 5 V regulator's die under the main board);
# right: the vertical plane through it. One colour scale for both.
fig, (a, b) = plt.subplots(1, 2, figsize=(10, 3.6), gridspec_kw={"width_ratios": [70, 70]})
vmin, vmax = np.nanmin(field), np.nanmax(field)
im = a.pcolormesh(x, y, field[:, :, k].T, shading="gouraud", vmin=vmin, vmax=vmax, cmap="inferno")
a.set(title=f"z = {z[k]:.1f} mm", xlabel="x [mm]", ylabel="y [mm]", aspect="equal")
b.pcolormesh(x, z, field[:, j, :].T, shading="gouraud", vmin=vmin, vmax=vmax, cmap="inferno")
b.set(title=f"y = {y[j]:.1f} mm", xlabel="x [mm]", ylabel="z [mm]", aspect="equal")
for ax in (a, b):
    ax.plot(hot[0], hot[1] if ax is a else hot[2], "c+", ms=12, mew=2)
fig.colorbar(im, ax=(a, b), label="temperature [°C]", shrink=0.9)
fig.suptitle(f"imu_reference / grease, steady: max rise {result['max_rise_K']:.1f} K above {result['ambient_C']:.0f} °C")
plt.show()
