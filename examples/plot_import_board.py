"""
Your own board: a KiCad file into a unit, solved
================================================

A real open-hardware flight controller (MarkSherstan/Drone, KiCad 5, 78 footprints, 2 copper layers; MIT
licensed, ``examples/boards/``) read from its ``.kicad_pcb`` and turned into a single-board unit by the
library calls behind ``imutherm import``: every footprint modelled, merged into the board or skipped with
its reason, the board's conductivity from its stack-up, the heights from the package classes (and, for the
board's custom and connector footprints, from ``drone-fc_heights.csv``), the powers from
``drone-fc_powers.csv`` (each with its source), the ICM-20689 as the sensor site. The unit is drawn over the
board's true outline and solved steady in each cooling scheme.

The same from the command line: ``imutherm import drone-fc.kicad_pcb --powers drone-fc_powers.csv
--heights drone-fc_heights.csv --site U2=imu --out my_unit.toml``, then ``imutherm compare my_unit.toml``.
"""

# %%
# Read the board and decide each footprint's fate
# -----------------------------------------------
import gzip
import os
import tempfile
from collections import Counter
from pathlib import Path

import matplotlib.pyplot as plt

from imutherm.ecad.read import read_board
from imutherm.ecad.to_layout import ImportOptions, import_board
from imutherm.ecad.user_tables import read_value_csv
from imutherm.geometry.build import build_geometry
from imutherm.reports.board_plot import board_figure
from imutherm.studies.thermal.thermal_study import run_scheme

BOARDS = Path(__file__).resolve().parent / "boards" if "__file__" in globals() else Path("boards")
OUT = Path(os.environ.get("IMUTHERM_EXAMPLES_OUT", tempfile.gettempdir())) / "imutherm-examples" / "import_board"
OUT.mkdir(parents=True, exist_ok=True)

pcb = OUT / "drone-fc.kicad_pcb"
pcb.write_bytes(gzip.decompress((BOARDS / "drone-fc.kicad_pcb.gz").read_bytes()))
board = read_board(pcb)
print(f"{board.format}: {board.width_mm:.1f} x {board.height_mm:.1f} x {board.thickness_mm} mm, "
      f"{board.copper_layers} copper layers, {len(board.footprints)} footprints")

options = ImportOptions(powers=read_value_csv(BOARDS / "drone-fc_powers.csv", "power_W"),
                        heights=read_value_csv(BOARDS / "drone-fc_heights.csv", "height_mm"),
                        sites={"U2": "imu"})
unit = import_board(board, options)
print(dict(Counter(d.fate for d in unit.decisions)))
for d in unit.decisions:
    if d.fate == "skipped":
        print(f"skipped {d.footprint.ref}: {d.reason}")
(OUT / "drone_fc_unit.toml").write_text(unit.text, encoding="utf-8")   # an ordinary layout file

# %%
# The board over its true outline, every part with its reference
# ---------------------------------------------------------------
# Modelled parts filled (dies red), the parts merged into the board outlined, the standoffs under the
# mounting holes dashed. ``imutherm geometry my_unit.toml`` writes the same as ``board_main.png``.
geometry = build_geometry(unit.spec, "grease")
fig = board_figure(geometry, "main")
plt.show()

# %%
# Solve each cooling scheme (steady, a coarse mesh) and compare the IMU die
# -------------------------------------------------------------------------
rises = {}
for scheme in unit.spec.schemes:
    run = run_scheme(unit.spec, scheme, mesh_size_mm=4.0, min_cells=1)
    steady = run.steady
    gyro = steady.probe_C[list(steady.probe_names).index("gyro_x")] - unit.spec.ambient_C
    rises[scheme] = (gyro, steady.T_C.max() - unit.spec.ambient_C)
    print(f"{scheme:7s} IMU die +{gyro:.2f} K, hot spot +{rises[scheme][1]:.2f} K")

fig, ax = plt.subplots(figsize=(7, 3.5))
names = list(rises)
ax.bar([n + "\nIMU die" for n in names], [rises[n][0] for n in names], color="#2e8b57")
ax.bar([n + "\nhot spot" for n in names], [rises[n][1] for n in names], color="#c8402a")
ax.set_ylabel("steady rise above the 70 C ambient [K]")
ax.set_title(f"{unit.spec.name}: {unit.spec.components[0].board} board, {len(unit.spec.components)} modelled parts")
fig.tight_layout()
plt.show()
