"""The thermal studies of one cooling scheme: the chain layout -> geometry -> mesh -> problem -> solve -> metrics.

Start with :func:`imutherm.studies.thermal.thermal_study.run_scheme` (what ``imutherm solve`` and every study
call; ``result_summary`` gives its ``result.json``). Beside it: :mod:`~imutherm.studies.thermal.mesh_convergence`
(the mesh-refinement study, ``imutherm verify``), :mod:`~imutherm.studies.thermal.forward` (the full model's site
rises for one experiment with effects switched on, shared by the correlation and the uncertainty study) and
:mod:`~imutherm.studies.thermal.fitted_model` (the model ``imutherm correlate`` fitted, read back so that
``solve``, ``compare`` and ``sweep`` run on it: ``--model FILE``).
"""
