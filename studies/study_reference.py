"""The end-to-end study of the built-in reference unit of the paper: :mod:`imutherm.studies.study` with the layout fixed.

Copy this file and set LAYOUT to your own layout file (or a built-in name: imu_reference, imu_cardguide),
or run :mod:`imutherm.studies.study` with ``--layout``. Run it with an output folder:

    python studies/study_reference.py out/reference                            # default mesh, 3 seeds
    python studies/study_reference.py out/quick --mesh-size 6 --min-cells 1 --seeds 1   # a coarse first look
"""

from __future__ import annotations

from imutherm.studies import study

LAYOUT = "imu_reference"            # <- your layout: a path to a .toml file, or a built-in name


def main(argv=None) -> int:
    """The study of LAYOUT with the options in ``argv`` (see :func:`imutherm.studies.study.main`)."""
    return study.main(argv, layout=LAYOUT)


if __name__ == "__main__":
    study.run_as_script(main)
