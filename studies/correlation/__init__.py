"""Correlation of the unit model with measured site temperatures: localise, re-tune, name the missing effect.

``correlate(runs, layout)`` with one or more :class:`~imutherm.measured.MeasuredRun`:

1. **Localise**: residuals of the nominal model per site and phase (rise: before the site's t63;
   plateau: after its t95), the lag (time shift that best aligns the curves) and the correlation
   of the residual with physical fingerprints (the site's rise = power map / ΔT, its dT/dt, its
   T^4 - T_amb^4, its distance to the mount face).
2. **Re-tune**: a bounded least-squares fit of the model's uncertain parameters
   (:data:`imutherm.unit.knobs.RETUNE`, each within its source's range), and of the parameter whose
   value is uncertain because the model's form is (:data:`FORM_RETUNE`: the cavity's emissivity, since
   the cavity radiation's law is): re-tuned, reported, never named as a missing effect.
3. **Candidates**: each effect of the library (:mod:`imutherm.unit.effects`) fitted on top of
   the re-tune parameters.
4. **Rank**: held-out RMS (default: fit each file's first 60 % of its time, predict the rest;
   ``holdout=FILE`` leaves that file out; sparse files: leave one reading out) and AICc with an
   effective sample size n_eff = Σ over series of n (1 - ρ1) / (1 + ρ1) (ρ1: lag-1 autocorrelation
   of the re-tuned model's residuals; a series of three or fewer points counts fully).
5. **Verdict** (:func:`verdict`): ``effect`` for a candidate with a clear margin (ΔAICc >=
   :data:`MARGIN_NONE` over ``none`` and >= :data:`MARGIN_RUNNER_UP` over the runner-up, held-out
   RMS better than ``none``, and explaining >= :data:`EXPLAIN_MIN_NOISE` noise sigmas of RMS);
   ``ambiguous`` (several within the margin); ``none`` if no candidate qualifies and the re-tuned
   model predicts held-out data within the noise; else ``not_in_library`` (also when the best
   candidate leaves a held-out residual well above the noise).
   **Several effects** (:func:`forward_select`): the verdict's rules are applied again with the named
   effect's model as the new base, every other compatible candidate fitted on top; effects are added
   while one qualifies (at most ``max_effects``); ``named_effects`` in order, ``named_effect`` the first.
   **The model's own error** (:class:`Discrepancy`; ``discrepancy='auto'``, the default: used where the
   library's choice does not predict held-out data within the noise): every fit carries a smooth per-site,
   per-run discrepancy with a Gaussian prior whose scale, one per cooling scheme, the data estimate for that
   fit (type-II maximum likelihood, :meth:`Discrepancy.profile`), so every candidate is judged against the
   re-tuned model *with* the term by the evidence (the term's Occam factor at each fit's own scales included)
   and held-out error, and the chosen effects together must explain the model's error in every scheme where
   they act (leave the term there within 2 noise sigmas or halve it; :func:`explains_term`); when no effect
   qualifies and the data support the term, the verdict is ``discrepancy`` (the model's form is off, by so
   much, where, not explained by any library effect). Where the library names
   nothing and the re-tune already predicts held-out data within the noise standard, the term is still
   fitted on the re-tuned model: ``none`` only if the data do not support it. On sparse files the term cannot
   be fitted; the cavity law's form is reported as a prior band at each reading instead (:func:`form_band`).
   **Through the model's own error**: the term's prior scale is capped at twice the model's known
   form error (:mod:`imutherm.studies.correlation.form_error`: the grid's and the reduced model's, per scheme), library
   effects that take the re-tuned model's held-out error from far beyond that level to within it are named
   without the term (:func:`imutherm.studies.correlation.form_error.named_through_form`), and on the term's path a
   further effect must halve the term the effects before it leave. A re-tuned parameter that moved far and explains
   most of the gap is named as a finding (:mod:`imutherm.studies.correlation.findings`; verdict ``finding``
   when no library effect is named); the model written is never worse than the nominal one on held-out data
   without the term (:mod:`imutherm.studies.correlation.written_model`); implausible readings are refused before any fit
   (:mod:`imutherm.studies.correlation.plausibility`).
6. **Re-run**: the corrected model on the full model (:func:`rerun_full`) for the "after" figures: its full
   steady solve and its transient on the study's checked reduced model (the full adaptive FEM where the check
   fails, or with ``rerun_transient='full'``).

Forward runs use the reduced model of each (scheme, ambient) (:mod:`imutherm.thermal.reduced`),
built once per correlation.

The package, one module per stage: :mod:`~imutherm.studies.correlation.forward_model` (site rises from knob
values), :mod:`~imutherm.studies.correlation.discrepancy` (the term), :mod:`~imutherm.studies.correlation.fit`
(one fit), :mod:`~imutherm.studies.correlation.noise` (noise, n_eff, localisation),
:mod:`~imutherm.studies.correlation.models` (reduced models, input checks, re-runs),
:mod:`~imutherm.studies.correlation.holdout` (the hold-out design), :mod:`~imutherm.studies.correlation.verdict`
(the rules), :mod:`~imutherm.studies.correlation.selection` (forward selection),
:mod:`~imutherm.studies.correlation.workflow` (:func:`correlate`) and :mod:`~imutherm.studies.correlation.output`
(what is written). The names below are its API, importable from here.
"""

from imutherm.studies.correlation.discrepancy import (DISCREPANCY_PRIOR, DISCREPANCY_PRIOR_RANGE, Discrepancy,
                                                     build_discrepancy, form_band)
from imutherm.studies.correlation.fit import Fit
from imutherm.studies.correlation.forward_model import FORM_IN_DOUBT, FORM_KNOBS, FORM_RETUNE
from imutherm.studies.correlation.holdout import SPARSE_READINGS, heldout_worse_z
from imutherm.studies.correlation.models import (PRECHECK_MESH_MM, PRECHECK_T63_FRACTION, Models, build_models,
                                                check_inputs, model_t63_s, refuse_duplicates, rerun_full)
from imutherm.studies.correlation.noise import SPARSE_NOISE_K, localise, n_eff_ratio, noise_sigma
from imutherm.studies.correlation.output import MAX_TOML_READINGS, reading_rows, result_json, updated_model_toml
from imutherm.studies.correlation.selection import MAX_EFFECTS, forward_select
from imutherm.studies.correlation.verdict import (EXPLAIN_FRACTION, EXPLAIN_MIN_NOISE, EXPLAIN_NOISE_FACTOR,
                                                 HELDOUT_TOL, HELDOUT_WORSE_MARGIN, HELDOUT_Z_MAX, MARGIN_NONE,
                                                 MARGIN_RUNNER_UP, NONE_NOISE_FACTOR, SPARSE_FRACTION,
                                                 SPARSE_RUNNER_UP, discrepancy_summary, effect_words, explained_K,
                                                 explains_term, verdict)
from imutherm.studies.correlation.workflow import CorrelationResult, correlate
