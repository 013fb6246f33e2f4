"""The end-to-end study's settings and results: :class:`StudyConfig` (the IMU side), :class:`SchemeStudy`,
:class:`StudyResult`, and the configuration the answer quotes.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field

import numpy as np

from imutherm import InputError
from imutherm.geometry.layout import LayoutSpec
from imutherm.unit.model import ModelOptions


PHASES = ("warmup", "steady")


CALIBRATIONS = ("unit", "bare")


METRICS = ("roll_rms_deg", "pitch_rms_deg", "roll_max_deg", "pitch_max_deg")


RESIDUALS = ("accel_rms_mg", "accel_max_mg", "gyro_rms_dps", "gyro_max_dps")


def _study_filters() -> tuple:
    from imutherm.imu.filters.registry import study_filters

    return study_filters()


@dataclass(frozen=True)
class StudyConfig:
    """Settings of the IMU / attitude side of the study.

    grade : sensor grade name (:mod:`imutherm.imu.grades`)
    seeds : int, number of units / noise draws (seed0, seed0+1, ...); the same in every scheme
    profiles : motion profiles (``flight``, ``swing``; :mod:`imutherm.imu.motion`), default durations
    compensations : subset of none, conventional, improved
    filters : registered filters that need no GNSS (:mod:`imutherm.imu.filters.registry`); default the
        registry's ``study`` group (:func:`~imutherm.imu.filters.registry.study_filters`)
    tuned : True: each filter runs at its tuned settings for the profile (``studies/attitude/filter_settings.toml``,
        :mod:`imutherm.studies.attitude.filter_settings`: one grid procedure for ours and the peers, tuning seeds
        100-101, not the answer's); False: at its defaults
    out_of_range : compensation policy beyond the calibrated range (error|hold|linear)
    chamber_C : [°C] oven temperatures at which the self-heating is solved (linear between them). The
        compensation looks up *reported* temperatures, so the rise between the ends only moves where the
        calibration nodes fall; what matters is the top end, where the use case sits. Two points (one extra
        steady solve per scheme: 70 °C is the layout's ambient) are within 0.4 K of a three-point table at
        15 °C on the reference unit (air scheme, gyro_x 8.3 vs 7.9 K)
    residual_window_s : [s] averaging window of the residual sensor errors (white noise averaged out)
    calibrations : ``unit`` (calibrated assembled, with the self-heating) and/or ``bare`` (sensors alone)
    """

    grade: str = "adis16355"
    seeds: int = 3
    seed0: int = 0
    profiles: tuple = ("flight", "swing")
    compensations: tuple = ("none", "conventional", "improved")
    filters: tuple = field(default_factory=lambda: _study_filters())
    out_of_range: str = "linear"
    chamber_C: tuple = (-40.0, 70.0)
    residual_window_s: float = 5.0
    calibrations: tuple = CALIBRATIONS
    tuned: bool = True

    def __post_init__(self):
        from imutherm.imu.compensation import METHODS, OUT_OF_RANGE
        from imutherm.imu.filters.registry import filter_names
        from imutherm.imu.motion import PROFILES
        from imutherm.imu.sensor_model import load_grade

        load_grade(self.grade)
        if not (isinstance(self.seeds, (int, np.integer)) and 1 <= self.seeds <= 1000):
            raise InputError(f"--seeds: {self.seeds!r} is invalid; valid: an integer in 1..1000")
        if not (isinstance(self.seed0, (int, np.integer)) and self.seed0 >= 0):
            raise InputError(f"--seed: {self.seed0!r} is invalid; valid: an integer >= 0")
        for name, vals, valid in (("profiles", self.profiles, PROFILES), ("compensations", self.compensations, METHODS),
                                  ("filters", self.filters, filter_names(gnss=False))):
            bad = [v for v in vals if v not in valid]
            if bad or not vals:
                raise InputError(f"--{name}: {', '.join(bad) or 'none given'} invalid; valid: {', '.join(valid)}")
        if self.out_of_range not in OUT_OF_RANGE:
            raise InputError(f"--out-of-range: {self.out_of_range!r} is unknown; valid: {', '.join(OUT_OF_RANGE)}")
        if len(self.chamber_C) < 2 or any(not math.isfinite(c) for c in self.chamber_C):
            raise InputError(f"chamber_C: {self.chamber_C!r}; valid: at least two finite oven temperatures [°C]")
        if not self.calibrations or any(c not in CALIBRATIONS for c in self.calibrations):
            raise InputError(f"calibrations: {self.calibrations!r}; valid: {', '.join(CALIBRATIONS)}")
        if not (self.residual_window_s > 0):
            raise InputError(f"residual_window_s: {self.residual_window_s!r}; valid: > 0 [s]")


@dataclass(frozen=True)
class SchemeStudy:
    """One scheme's end-to-end result.

    scheme : str
    thermal : SchemeResult (geometry, grid, steady and transient results, metrics)
    summary : dict, the thermal ``result.json`` content (:func:`thermal_study.result_summary`)
    chamber_C : (k,) [°C]; rise_K : (k, 6) [K] sensor-die self-heating in the oven, SITES order
    imu : dict, :func:`reduce_cases` of the seeds: attitude, residuals, ranges, extrapolated fractions
    series : dict, first seed's curves for the files and the report (see :func:`imu_case`)
    oven_solves : tuple of dict, how each oven temperature other than the ambient was solved (full, or reduced
        with its check: :func:`self_heating_table`)
    """

    scheme: str
    thermal: object
    summary: dict
    chamber_C: np.ndarray
    rise_K: np.ndarray
    imu: dict
    series: dict = field(repr=False)
    oven_solves: tuple = ()


@dataclass(frozen=True)
class StudyResult:
    """The study of every scheme: ``schemes`` name -> SchemeStudy, the settings, ``wall_s`` [s]."""

    layout: LayoutSpec
    config: StudyConfig
    options: ModelOptions
    schemes: dict
    wall_s: float


def config_dict(config: StudyConfig) -> dict:
    """JSON-ready settings."""
    return {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(config).items()}


#: the configuration the answer sentences quote: the paper's chosen compensation and filter, on the flight
ANSWER_COMPENSATION, ANSWER_FILTER, ANSWER_PROFILE = "improved", "gated", "flight"


#: the filter the answer's uncertainty also runs, beside :data:`ANSWER_FILTER` (the study's second filter of ours)
ANSWER_SECOND_FILTER = "kf"
