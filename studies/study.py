"""The end-to-end study of one layout, as a script: the built-in reference unit of the paper by default.

Give it your own layout file (or a built-in name: imu_reference, imu_cardguide) and an output folder::

    python -m imutherm.studies.study out/reference                                  # default mesh, 3 seeds
    python -m imutherm.studies.study out/cardguide --layout imu_cardguide
    python -m imutherm.studies.study out/mine --layout my_unit.toml --mesh-size 6 --min-cells 1 --seeds 1

For each cooling scheme (air, grease, potted) it solves the steady field and the power-on
transient, calibrates the assembled unit in the oven with its own self-heating, and carries
each sensor's die temperature through the IMU error model, compensation and the attitude
filters (imutherm.studies.end_to_end.run_study, the same study as ``imutherm compare``). It
writes into the folder ``summary.json``, ``curves_<scheme>.csv``, ``residuals_<scheme>.csv``,
``attitude_<scheme>.csv``, ``steady_<scheme>.vtu``, ``maps_<scheme>.npz``, ``layout_<scheme>.png``
and ``report.pdf``, then prints
the answer: how hot each scheme runs and what that does to the attitude error.
``studies/study_reference.py`` is this script with the layout fixed, a template to copy.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

from imutherm.geometry.layout import builtin_layouts, load_layout
from imutherm.io import move_staged
from imutherm.studies.end_to_end import StudyConfig, run_study, write_study

DEFAULT_LAYOUT = "imu_reference"
SCHEMES = ("air", "grease", "potted")


def main(argv=None, layout: str | None = None) -> int:
    """Run the study of ``layout`` (a TOML path or a built-in name; None: ``--layout``, default the
    reference unit) with the options in ``argv``; returns the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out", help="output folder (created; files of the same name are replaced)")
    parser.add_argument("--mesh-size", type=float, default=2.0, metavar="MM", help="largest cell edge [mm] (default 2)")
    parser.add_argument("--min-cells", type=int, default=2, help="fewest cells across any part (default 2)")
    parser.add_argument("--seeds", type=int, default=3, help="simulated units / noise draws per scheme (default 3)")
    parser.add_argument("--t-end", type=float, default=2400.0, metavar="S",
                        help="latest end of the power-on transient [s]; it stops once every site has settled "
                             "(default 2400)")
    parser.add_argument("--quiet", action="store_true", help="no progress output")
    if layout is None:
        parser.add_argument("--layout", default=DEFAULT_LAYOUT,
                            help=f"a layout TOML file or a built-in name ({', '.join(builtin_layouts())}; default "
                                 f"{DEFAULT_LAYOUT})")
    args = parser.parse_args(argv)

    layout = load_layout(layout or args.layout)   # checks the file; a bad one stops here with a one-line message
    config = StudyConfig(seeds=args.seeds)   # sensor grade, profiles, filters, compensations: the defaults
    # the power-on transient: error-controlled TR-BDF2 steps, stopped once every site has settled
    result = run_study(layout, SCHEMES, config=config, mesh_size_mm=args.mesh_size, min_cells=args.min_cells,
                       t_end=args.t_end, until_settled=True, progress=not args.quiet)

    # write everything into a temporary folder first, then move it in: no half-written output
    from imutherm.reports.layout_plot import plot_layout
    from imutherm.reports.study_report import write_study_report

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(dir=out))
    try:
        summary = write_study(result, tmp)
        for name, st in result.schemes.items():
            plot_layout(st.thermal.geometry, tmp / f"layout_{name}.png")
        write_study_report(tmp, tmp / "report.pdf")
        move_staged(tmp, out)   # each file replaces its namesake in one rename
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    # the answer: hot spot, sensor-die rises, the hottest sensor's settle time (t95) and the attitude
    # error (flight profile, improved compensation calibrated in the unit, gated filter; mean over seeds)
    print(f"{layout.name}: {layout.description}")
    print(f"{'scheme':<8} {'max rise [K]':>12} {'sensor dies [K]':>15} {'t95 [s]':>8}   "
          "roll/pitch RMS [deg] warm-up   steady")
    for name, s in summary["schemes"].items():
        dies = [v["rise_K"] for k, v in s["sites"].items() if k.startswith(("gyro", "accel"))]
        warm = s["attitude"]["warmup"]["improved"]["gated"]["flight"]
        steady = s["attitude"]["steady"]["improved"]["gated"]["flight"]
        t95 = "-" if s["t95_s"] is None else f"{s['t95_s']:.0f}"   # None: not settled within --t-end
        print(f"{name:<8} {s['max_rise_K']:12.2f} {min(dies):7.2f}..{max(dies):<6.2f} {t95:>8}   "
              f"{warm['roll_rms_deg']['mean']:13.2f}/{warm['pitch_rms_deg']['mean']:.2f}   "
              f"{steady['roll_rms_deg']['mean']:.2f}/{steady['pitch_rms_deg']['mean']:.2f}")
    for s in summary["schemes"].values():
        print(s["answer"])
    print(f"wrote {out}/summary.json report.pdf curves_*.csv residuals_*.csv attitude_*.csv steady_*.vtu "
          "maps_*.npz layout_*.png")
    return 0


def run_as_script(main_fn=main) -> None:
    """Exit with ``main_fn()``'s status; a bad layout, option or output folder ends in one line, exit status 1."""
    from imutherm import InputError

    try:
        sys.exit(main_fn())
    except (InputError, OSError) as exc:
        sys.exit(f"error: {exc}")


if __name__ == "__main__":
    run_as_script()
