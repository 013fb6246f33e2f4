"""Parameter sweeps of one cooling scheme: design, sampling, running (local or Dask), resume, sensitivity.

A sweep varies numeric inputs named by dotted keys:

- ``<table>.<field>`` and ``<array>.<name>.<field>[.<index>]`` of the layout file, e.g.
  ``environment.ambient_C``, ``mounting.contact_conductance_W_m2K``, ``components.reg_5v.power_W``,
  ``boards.main.min_mm.2`` (an element of a vector);
- ``materials.<material>.<property>`` of a material the scheme uses (``k`` or ``k_in_plane`` /
  ``k_through``, ``density``, ``specific_heat``, ``emissivity``): a changed copy of the library entry is
  handed to the model (``ModelOptions.materials``), the library is not touched;
- ``options.<field>`` of the numeric :class:`~imutherm.unit.model.ModelOptions`, e.g. ``options.emissivity``.

:func:`plan_sweep` checks every key and every case before anything runs (each case's values are
applied to the layout file's dict, which is re-parsed and built, so the layout's own checks run);
:func:`run_sweep` runs the missing cases and appends one row per case to ``results.csv`` as each
finishes (flushed and fsynced), so a killed sweep loses only the cases in flight and ``resume``
runs exactly the missing case ids. Designs (grid, Latin hypercube, Morris) and the Morris
measures come from SALib; for grid and LHS the influence measure is the standardised regression
coefficient (SRC) of a linear least-squares fit, reported with its R^2.

The package, one purpose a module: :mod:`~imutherm.studies.sweep.keys` (the dotted keys and their values),
:mod:`~imutherm.studies.sweep.plan` (designs, the checked plan, the cost estimate),
:mod:`~imutherm.studies.sweep.case` (one case on the full FEM and its outputs),
:mod:`~imutherm.studies.sweep.run` (local or Dask running, resume),
:mod:`~imutherm.studies.sweep.results` (the resumable ``results.csv`` and ``sweep.json``) and
:mod:`~imutherm.studies.sweep.influence` (the influence measures, :func:`sensitivity`). The public names
are re-exported here (no ``__all__``: the API reference documents each name once, in its home).
"""

from imutherm.studies.sweep.case import attitude_columns, case_outputs, run_case  # noqa: F401  (re-exported)
from imutherm.studies.sweep.keys import key_unit, parse_values, valid_keys
from imutherm.studies.sweep.plan import (MAX_CASES, MAX_CPU_HOURS, METHODS, MORRIS_LEVELS, REDUCED_BUILD_S_PER_UNKNOWN,
                                         REDUCED_CASE_S, REDUCED_TRANSIENT_FACTOR, STEADY_S_PER_UNKNOWN,
                                         TRANSIENT_FACTOR, Case, CaseSettings, CostEstimate, Factor, SweepPlan,
                                         case_model, count_cases, estimate_cost, full_case, plan_sweep)
from imutherm.studies.sweep.results import RESULTS_CSV, SWEEP_JSON, read_results
from imutherm.studies.sweep.run import SweepResult, run_sweep
from imutherm.studies.sweep.influence import sensitivity

