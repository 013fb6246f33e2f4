"""The unit model: a layout's parts and laws -> a :class:`~imutherm.thermal.problem.ThermalProblem`.

The layer between the FEM core (:mod:`imutherm.thermal`, which knows nothing about layouts or part
names) and the studies. :mod:`~imutherm.unit.model` builds the problem of one cooling scheme from the
geometry, each law a switch of :class:`~imutherm.unit.model.ModelOptions`;
:mod:`~imutherm.unit.effects` is the library of candidate effects a correlation names (one entry each,
its apply function beside its data); :mod:`~imutherm.unit.knobs` turns re-tune and effect parameters
into model variants for the reduced models.
"""
