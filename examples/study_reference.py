"""The cooling study of one layout, as a script you can copy: here the built-in reference unit of the paper.

Copy this file, set LAYOUT to your own layout file (or a built-in name: imu_reference,
imu_cardguide) and run it with an output folder:

    python examples/study_reference.py out/reference                 # default mesh, steady + power-on transient
    python examples/study_reference.py out/quick --mesh-size 6 --min-cells 1 --steady-only   # a coarse first look

It solves the three cooling schemes (air, grease, potted) with the same mesh and model
options and writes into the folder: compare.json (every scheme's rises, hot spot, site
rises and settle times, energy balance), probes_<scheme>.csv (site curves, degC),
map_<scheme>.npz (main-board temperature map), layout.png and report.pdf; then prints
the answer table.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

from imutherm.geometry.layout import load_layout
from imutherm.studies.compare import compare_schemes, write_comparison

LAYOUT = "imu_reference"            # <- your layout: a path to a .toml file, or a built-in name
SCHEMES = ("air", "grease", "potted")
SENSORS = ("gyro_x", "gyro_y", "gyro_z", "accel_x", "accel_y", "accel_z")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", help="output folder (created; files of the same name are replaced)")
    parser.add_argument("--mesh-size", type=float, default=2.0, metavar="MM", help="largest cell edge [mm] (default 2)")
    parser.add_argument("--min-cells", type=int, default=2, help="fewest cells across any part (default 2)")
    parser.add_argument("--steady-only", action="store_true", help="skip the power-on transients")
    parser.add_argument("--quiet", action="store_true", help="no progress output")
    args = parser.parse_args(argv)

    layout = load_layout(LAYOUT)   # checks the file; a bad one stops here with a one-line message
    comp = compare_schemes(layout, SCHEMES, transient=not args.steady_only, t_end=2400.0, dt=2.0, dt_max=60.0,
                           mesh_size_mm=args.mesh_size, min_cells=args.min_cells, progress=not args.quiet)

    # write everything into a temporary folder first, then move it in: no half-written output
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=out))
    try:
        write_comparison(comp, tmp)
        from imutherm.reports.compare_report import write_compare_report
        from imutherm.reports.layout_plot import plot_layout

        plot_layout(comp.runs[SCHEMES[1]].geometry, tmp / "layout.png")
        write_compare_report(tmp, tmp / "report.pdf")
        for f in tmp.iterdir():
            f.replace(out / f.name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    # the answer: how hot the hottest chip and each sensor run above ambient, per scheme
    print(f"{layout.name}: {layout.description}")
    print(f"{'scheme':<8} {'max rise [K]':>12} {'hottest part':<14}" + "".join(f"{s:>9}" for s in SENSORS)
          + f" {'t95 max [s]':>11}")
    for scheme, r in comp.summaries.items():
        t95 = [v.get("t95_s") for v in r["sites"].values() if v.get("t95_s") is not None]
        print(f"{scheme:<8} {r['max_rise_K']:12.2f} {r['hottest_part']:<14}"
              + "".join(f"{r['sites'][s]['rise_K']:9.2f}" for s in SENSORS)
              + f" {max(t95) if t95 else float('nan'):11.0f}")
    print(f"sensor columns: rise [K] of each sensor die; wrote {out}/compare.json probes_*.csv map_*.npz "
          "layout.png report.pdf")
    return 0


if __name__ == "__main__":
    from imutherm import InputError

    try:
        sys.exit(main())
    except (InputError, OSError) as exc:   # bad layout, option or output folder: one line, exit status 1
        sys.exit(f"error: {exc}")
