"""Draw the README's picture of the answer: page 1's bar figure of ``report.pdf``, from a ``summary.json``.

Usage (the figure in the repository was made so; the study takes several CPU-minutes)::

    imutherm compare --jobs 1 --out /tmp/compare
    python docs/make_answer_figure.py /tmp/compare/summary.json          # writes docs/_static/answer.png

The bars are those of ``imutherm.reports.study_report.answer_figure``: warm-up roll (top) and pitch (bottom)
RMS [deg] of each filter per scheme and compensation, calibrated in the unit, on the study's main profile,
whiskers the std over the seeds.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")

import matplotlib.pyplot as plt  # noqa: E402

from imutherm.reports.study_report import answer_figure  # noqa: E402

OUT = Path(__file__).resolve().parent / "_static" / "answer.png"


def title(data: dict) -> str:
    """One line naming what the bars show: layout, ambient [°C], power [W], grade, seeds, profile."""
    st = data["study"]
    seeds = data["seeds"]
    return (f"{data['layout']}: attitude error through the warm-up per cooling scheme, calibrated in the unit\n"
            f"ambient {data['ambient_C']:.0f} C, {data['power_W']:.2f} W, grade {st['grade']}; bars the mean, "
            f"whiskers the std of seeds {seeds[0]}..{seeds[-1]}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("summary", type=Path, help="summary.json written by imutherm compare")
    parser.add_argument("--out", type=Path, default=OUT, help=f"PNG to write (default {OUT})")
    parser.add_argument("--dpi", type=int, default=150)
    args = parser.parse_args(argv)
    try:
        data = json.loads(args.summary.read_text(encoding="utf-8"))
        missing = [key for key in ("study", "schemes", "layout", "seeds") if key not in data]
        if missing:
            raise KeyError(", ".join(missing))
    except (OSError, ValueError, KeyError) as exc:
        print(f"make_answer_figure: {args.summary}: not a summary.json of imutherm compare ({exc})",
              file=sys.stderr)
        return 2
    fig = plt.figure(figsize=(9.0, 4.6))
    fig.suptitle(title(data), fontsize=8.5)
    answer_figure(fig, (0.07, 0.08, 0.91, 0.78), data)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=args.dpi)
    plt.close(fig)
    print(f"wrote {args.out} ({args.out.stat().st_size / 1024:.0f} KiB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
