"""What the model does not know, carried to the study's answer: ``imutherm compare --uncertainty``.

Start with :func:`imutherm.studies.uncertainty.uncertainty.run_uncertainty`: the thermal model's uncertain inputs
(:func:`~imutherm.studies.uncertainty.uncertainty.inputs`, each with its range and source) drawn by SALib's
Saltelli design through each scheme's reduced model, giving the sensor dies' rises with their quantiles and Sobol'
indices, checked against the full FEM at a few draws; with the nominal end-to-end study, some of the draws also run
through the full IMU chain (:mod:`~imutherm.studies.uncertainty.uncertainty_imu`) to the attitude error.
"""
