"""The end-to-end study: cooling scheme -> sensor temperatures -> calibration in the unit -> attitude error.

For each scheme of a layout, with one set of model options:

1. **Thermal** (:func:`imutherm.studies.thermal.thermal_study.run_scheme`): the steady
   field and the power-on transient from the layout's ambient; each site's
   curve, t63/t95 and the spread inside each sensor triad.
2. **Self-heating in the calibration oven** (:func:`self_heating_table`): the
   paper calibrates the *assembled* unit in an oven from -40 to 70 °C, so each
   sensor's die sits above the chamber by its self-heating in that scheme. The
   steady model is solved again with the chamber as ambient (and as the
   fixture temperature: the unit is assumed bolted to the oven table) at
   ``StudyConfig.chamber_C`` and interpolated linearly between them; the
   rise changes with the chamber temperature through the radiation laws.
3. **Two calibrations per unit**: ``unit`` (calibrated assembled, with that
   self-heating: each scheme its own) and ``bare`` (the same sensors calibrated
   on their own over -40..70 °C die temperature, scheme-independent).
4. **IMU and attitude**: each sensor's die-temperature curve drives the truth
   model (its internal temperature sensor reports through its lag and
   offset); compensation ``none | conventional | improved`` with the
   out-of-range policy ``StudyConfig.out_of_range`` (samples it acted on are
   counted); filters on the ``flight`` and ``swing`` profiles, both during the
   warm-up (motion starts at power-on: the die temperatures follow the
   transient) and at steady state (the steady site temperatures).
   Common random numbers: seed ``k`` draws the same unit, calibration noise and
   motion noise in every scheme, so a difference between schemes is the
   cooling's; the seed-to-seed spread is reported as ``std``.

The thermal side of one scheme (:func:`thermal_case`) and the IMU side of one
(scheme, seed) (:func:`imu_case`, a pure function of small arrays) are the
units of work: with ``jobs`` > 1 the schemes' thermal solves run side by side
in worker processes and the IMU cases are queued behind them.

The package: :mod:`~imutherm.studies.end_to_end.config` (settings and results),
:mod:`~imutherm.studies.end_to_end.thermal` (one scheme's thermal side),
:mod:`~imutherm.studies.end_to_end.imu` (one seed's IMU side), :mod:`~imutherm.studies.end_to_end.run`
(:func:`run_study`) and :mod:`~imutherm.studies.end_to_end.summary` (the answer and the files); the names
below import from here.
"""

from imutherm.studies.end_to_end.config import (ANSWER_COMPENSATION, ANSWER_FILTER, ANSWER_PROFILE,  # noqa: F401
                                                ANSWER_SECOND_FILTER, CALIBRATIONS, METRICS, PHASES, RESIDUALS,
                                                SchemeStudy, StudyConfig, StudyResult, config_dict)
from imutherm.studies.end_to_end.imu import (bare_calibration, imu_case, reduce_cases,  # noqa: F401
                                             scheme_attitude_metrics, sweep_config)
from imutherm.studies.end_to_end.run import run_study  # noqa: F401
from imutherm.studies.end_to_end.summary import (answer_sentences, map_boards, paper_comparison,  # noqa: F401
                                                 study_summary, write_scheme_files, write_study)
from imutherm.studies.end_to_end.thermal import (longest_first, self_heating_table,  # noqa: F401
                                                 site_curves, thermal_case)
