"""Draw the docs' picture of the filters on real motion, from ``studies/attitude/real_settings.toml``.

Usage (the figure in the repository was made so)::

    python benchmarks/bench_real_motion.py --write        # tunes and cross-validates (3-4 CPU-minutes)
    python docs/make_real_motion_figure.py                  # writes docs/_static/real_motion.png

The panels are :func:`imutherm.reports.real_motion_plots.real_motion_figure`'s.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")

import matplotlib.pyplot as plt  # noqa: E402

from imutherm.reports.real_motion_plots import real_motion_figure  # noqa: E402
from imutherm.studies.attitude.real_settings import load_real_settings  # noqa: E402

OUT = Path(__file__).resolve().parent / "_static" / "real_motion.png"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--settings", type=Path, default=None, help="a real_settings.toml (default: the package's)")
    parser.add_argument("--out", type=Path, default=OUT, help=f"PNG to write (default {OUT})")
    parser.add_argument("--dpi", type=int, default=150)
    args = parser.parse_args(argv)
    rs = load_real_settings(args.settings)
    fig = plt.figure(figsize=(9.0, 4.0))
    fig.suptitle(f"attitude filters on {len(rs.meta.get('files', []))} real development files (RepoIMU pendulum, "
                 f"BROAD): inclination RMS; {rs.meta.get('date', '')}, {rs.meta.get('command', '')}", fontsize=8)
    real_motion_figure(fig, rs)
    fig.tight_layout(rect=(0, 0, 1, 0.94))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=args.dpi)
    plt.close(fig)
    print(f"wrote {args.out} ({args.out.stat().st_size / 1024:.0f} KiB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
