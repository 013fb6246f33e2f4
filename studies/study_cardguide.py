"""The end-to-end study of the built-in card-guide unit: :mod:`imutherm.studies.study` with the layout fixed.

Copy this file and set LAYOUT to your own layout file (or a built-in name: imu_reference, imu_cardguide),
or run :mod:`imutherm.studies.study` with ``--layout``. Run it with an output folder:

    python studies/study_cardguide.py out/cardguide                            # default mesh, 3 seeds
    python studies/study_cardguide.py out/quick --mesh-size 6 --min-cells 1 --seeds 1   # a coarse first look
"""

from __future__ import annotations

import sys

from imutherm.studies import study

LAYOUT = "imu_cardguide"            # <- your layout: a path to a .toml file, or a built-in name


def main(argv=None) -> int:
    """The study of LAYOUT with the options in ``argv`` (see :func:`imutherm.studies.study.main`)."""
    return study.main(argv, layout=LAYOUT)


if __name__ == "__main__":
    from imutherm import InputError

    try:
        sys.exit(main())
    except (InputError, OSError) as exc:   # bad layout, option or output folder: one line, exit status 1
        sys.exit(f"error: {exc}")
