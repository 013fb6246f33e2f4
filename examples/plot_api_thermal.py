"""
The thermal model through the API: a layout solved steady and in time
======================================================================

What ``imutherm solve`` does, as library calls, one stage each: the layout file is read and checked, its
parts placed for one cooling scheme, meshed on a tensor-product grid whose lines fall on every part face,
turned into a :class:`~imutherm.thermal.problem.ThermalProblem` (conductivity, heat capacity and power per
cell, the boundary laws per outer face), and solved steady and from power-on. The FEM core
(:mod:`imutherm.thermal`) knows nothing about layouts: any ``ThermalProblem`` on a
:class:`~imutherm.geometry.grid.TensorGrid` goes to the same two solvers.

The reference unit's potted scheme (the free interior filled, so no cavity radiation to set up) on a coarse
mesh, one cell across the thinnest part, so that the example runs in well under a minute; the numbers printed
are this mesh's (the default mesh's are in ``imutherm compare``'s table, :doc:`/getting-started`).
"""

# %%
# Layout -> geometry -> mesh -> problem -> solve
# ----------------------------------------------
# ``geometry.sites`` are the sensor sites' positions [m]; given as probes, each solve records their
# temperature. The transient stops once every site has settled (within half a percent of its steady rise), so it
# is given the steady temperatures.
import os
import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from imutherm.geometry.build import build_geometry
from imutherm.geometry.layout import load_layout
from imutherm.geometry.mesh import build_mesh
from imutherm.thermal import solve_steady, solve_transient, thermal_metrics, write_vtu
from imutherm.unit.model import build_problem

OUT = Path(os.environ.get("IMUTHERM_EXAMPLES_OUT", tempfile.gettempdir())) / "imutherm-examples" / "api_thermal"
OUT.mkdir(parents=True, exist_ok=True)

layout = load_layout("imu_reference")                      # a built-in name, or your own TOML file
geometry = build_geometry(layout, "potted")                # parts placed and checked
grid = build_mesh(geometry, max_cell_mm=6, min_cells=1)    # coarse (default: 2 mm, two cells)
problem = build_problem(geometry, grid)                    # the unit's laws: unit.model.ModelOptions
steady = solve_steady(problem, probes=geometry.sites)
final_C = dict(zip(steady.probe_names, steady.probe_C))
transient = solve_transient(problem, 1500.0, scheme="trbdf2", tol_K=0.05, error_control="probes",
                            probes=geometry.sites, settle_C=final_C)
metrics = thermal_metrics(transient, final_rise_K={n: T - problem.ambient_C for n, T in final_C.items()})
write_vtu(OUT / "steady.vtu", grid, steady.T_C)           # for ParaView: point data temperature_C

print(f"{grid.n_nodes} nodes; steady: {steady.newton_iterations} Newton steps, energy balance "
      f"{steady.energy_balance_rel_error:.1e}; transient: {transient.steps} steps to {transient.times[-1]:.0f} s")
print(f"max rise {metrics.max_rise_K:.2f} K in {metrics.max_part}")
print("site      rise [K]  t63 [s]  t95 [s]")
for site in ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z"):
    print(f"{site:8s} {metrics.probe_rise_K[site]:9.2f} {metrics.t63_s[site]:8.0f} {metrics.t95_s[site]:8.0f}")

# %%
# The steady field and the sites' warm-up
# ---------------------------------------
# ``steady.T_C`` holds one temperature per grid node, in C order over (x, y, z): a 3-D array on the grid
# lines. Left, the plane through the hottest point; right, each sensor site's rise over the power-on,
# t95 marked.
field = steady.T_C.reshape(len(grid.xs), len(grid.ys), len(grid.zs))
k = int(np.argmin(abs(grid.zs - metrics.max_at_m[2])))
fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4), gridspec_kw={"width_ratios": [1.2, 1]})
im = a.pcolormesh(1e3 * grid.xs, 1e3 * grid.ys, field[:, :, k].T - problem.ambient_C, shading="gouraud",
                  cmap="inferno")
a.set(title=f"steady rise at z = {1e3 * grid.zs[k]:.1f} mm", xlabel="x [mm]", ylabel="y [mm]", aspect="equal")
fig.colorbar(im, ax=a, label="rise above ambient [K]")
for j, site in enumerate(transient.probe_names[:6]):
    line, = b.plot(transient.times, transient.probe_C[:, j] - problem.ambient_C, label=site)
    t95 = metrics.t95_s[site]
    b.plot(t95, np.interp(t95, transient.times, transient.probe_C[:, j]) - problem.ambient_C, "o",
           color=line.get_color())
b.set(title="power-on from the ambient (dots: t95)", xlabel="time [s]", ylabel="rise above ambient [K]")
b.grid(alpha=0.3)
b.legend(ncol=2, fontsize=8)
plt.show()
