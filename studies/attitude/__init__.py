"""The attitude studies: the IMU chain and every attitude filter, on simulated profiles and on recorded motion.

Start with :func:`imutherm.studies.attitude.attitude_study.run_attitude_study` (trajectory -> unit -> calibration ->
samples -> compensation -> filters -> roll/pitch errors, ``imutherm attitude``) or, for a user's log,
:func:`imutherm.studies.attitude.recorded.run_recorded` (``imutherm attitude --imu-csv``). The filters' settings
are read from the TOML files beside their modules (:mod:`~imutherm.studies.attitude.filter_settings` for the
simulated profiles, :mod:`~imutherm.studies.attitude.real_settings` for real motion), written by one tuning
procedure (:mod:`~imutherm.studies.attitude.filter_tuning`; :mod:`~imutherm.studies.attitude.real_tuning` on the
real development files). The comparisons: :mod:`~imutherm.studies.attitude.filter_benchmark` (simulated, fair
tuning), :mod:`~imutherm.studies.attitude.real_benchmark` (recordings with an optical reference),
:mod:`~imutherm.studies.attitude.filter_stress` (attitudes far from level). The sensor-calibration studies:
:mod:`~imutherm.studies.attitude.calibration_study` (``imutherm calibrate``) and
:mod:`~imutherm.studies.attitude.overload_study` (the overload table carried to attitude).
"""
