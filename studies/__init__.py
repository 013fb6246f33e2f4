"""The studies: the package's stages chained into answers, one subpackage per kind of work.

Start with :mod:`~imutherm.studies.compare` (``imutherm compare``: the cooling schemes of a layout side by side,
and with the IMU chain the end-to-end answer), or run the end-to-end study as a script
(:mod:`~imutherm.studies.study`; ``study_reference.py`` beside it is a copyable
example). The subpackages: :mod:`~imutherm.studies.thermal` (one scheme's thermal chain, ``imutherm solve``; the
mesh study, the full model's site rises, a fitted model read back), :mod:`~imutherm.studies.end_to_end` (scheme ->
sensor temperatures -> calibration -> attitude error), :mod:`~imutherm.studies.attitude` (the attitude filters on
simulated and recorded motion, their tuning and settings; the calibration and overload studies),
:mod:`~imutherm.studies.correlation` (the model against measured temperatures, ``imutherm correlate``, and its
blind campaign's synthetic data), :mod:`~imutherm.studies.sweep` (parameter sweeps, ``imutherm sweep``) and
:mod:`~imutherm.studies.uncertainty` (``imutherm compare --uncertainty``). Beside them: :mod:`~imutherm.studies.cost`
(what a study will cost, checked before it runs) and :mod:`~imutherm.studies.paper` (the reference data a layout
declares: the paper's figures, a user's bench readings).
"""
