"""The correlation workflow, :func:`correlate`: refuse bad input, build the reduced models, re-tune, select
effects (with the discrepancy term where needed), decide the verdict, re-run the corrected model.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from imutherm import InputError
from imutherm.geometry.layout import LayoutSpec, load_layout
from imutherm.geometry.mesh import DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS
from imutherm.unit import knobs
from imutherm.unit.effects import EFFECTS, effect_of, signal_effect_names
from imutherm.studies.correlation import form_error
from imutherm.unit.model import ModelOptions
from imutherm.studies.correlation.findings import explain_knobs
from imutherm.studies.correlation.in_place import named_in_place
from imutherm.studies.correlation.file_test import settled_by_file
from imutherm.studies.correlation.plausibility import check_plausible
from imutherm.workers import thread_limit
from imutherm.studies.correlation.written_model import choose as choose_written
from imutherm.studies.correlation.discrepancy import term_curve, form_band
from imutherm.studies.correlation.explain import explanations as explanations_of, knob_entry
from imutherm.studies.correlation.next_experiment import next_experiment as next_experiment_of
from imutherm.studies.correlation.fit import Fit, fit_candidate, fit_with
from imutherm.studies.correlation.forward_model import FORM_IN_DOUBT, FORM_RETUNE, ForwardModel, model_residuals
from imutherm.studies.correlation.holdout import (SPARSE_READINGS, held_out_union, heldout_nominal, holdout_folds,
                                                  pooled_heldout, with_heldout)
from imutherm.studies.correlation.models import (Models, build_models, check_inputs, map_jobs, refuse_duplicates,
                                                 rerun_full)
from imutherm.studies.correlation.noise import localise, n_eff_ratio, noise_sigma
from imutherm.studies.correlation.selection import (MAX_EFFECTS, forward_select, gain_words, retune_with_term,
                                                    truncate_selection)
from imutherm.studies.correlation.verdict import (EXPLAIN_FRACTION, NONE_NOISE_FACTOR, plain_explains,
                                                  verdict_discrepancy, discrepancy_summary, effect_words,
                                                  explains_term)


@dataclass(frozen=True, kw_only=True)
class CorrelationResult:
    """What ``correlate`` found (built by keyword only: 28 fields).

    verdict : 'effect' | 'finding' | 'none' | 'ambiguous' | 'not_in_library' | 'discrepancy'
    named_effect : str or None (the first of ``named_effects``), ambiguous_set : tuple
    before : dict (rms/max over all data, nominal model), after : Fit of the chosen model on all data
    retune : Fit ('none'), ranking : tuple of Fit (candidates, best first)
    localise : dict per run -> per site statistics; fingerprints : dict
    noise_K : float, curves : dict run -> {times, measured, before, after}
    timings : dict [s]
    """

    verdict: str
    named_effect: str | None
    ambiguous_set: tuple
    before: dict
    after: Fit
    retune: Fit
    ranking: tuple
    localise: dict
    fingerprints: dict
    noise_K: float
    curves: dict
    runs: tuple
    reduced: dict
    timings: dict
    words: str
    full: dict = field(default_factory=dict)
    #: the library effects named, in the order forward selection added them (``named_effect`` is the first)
    named_effects: tuple = ()
    #: one dict per forward-selection step: candidates tried, verdict of the step, held-out gain [K]
    steps: tuple = ()
    #: what the discrepancy term says (None without it): see :func:`discrepancy_summary`
    discrepancy: dict | None = None
    #: the re-tuned model without the discrepancy term (with it: ``retune``)
    retune_plain: Fit | None = None
    #: on sparse files, where the term cannot be fitted: the cavity law's form as a prior band (:func:`form_band`)
    form_band: dict | None = None
    #: re-tuned parameters that moved far and explain most of the gap
    #: (:mod:`imutherm.studies.correlation.findings`), first the largest share
    findings: tuple = ()
    #: which model ``updated_model.toml`` carries and why (:mod:`imutherm.studies.correlation.written_model`)
    written: dict | None = None
    #: the model's known form error (:mod:`imutherm.studies.correlation.form_error`): the term's cap, the rules' band
    form_scale: dict | None = None
    #: the corrected model's physics alone: its effects and the re-tune fitted without the discrepancy term, with
    #: pooled held-out figures (``after`` itself where no term was fitted); its intervals are the findings'
    physics: Fit | None = None
    #: re-tuned knobs that ended at a bound while the data pull them there: symptoms of the model's form, never
    #: findings (:class:`imutherm.studies.correlation.findings.Symptom`: how far the form is off and where)
    symptoms: tuple = ()
    #: one ranked list of the explanations: named effects, findings and ambiguous candidates scored alike
    #: (:mod:`imutherm.studies.correlation.explain`), best first
    explanations: tuple = ()
    #: verdict 'ambiguous': the bench design that best separates the candidates left
    #: (:func:`imutherm.studies.correlation.next_experiment.next_experiment`), else None
    next_experiment: dict | None = None


def correlate(runs, layout: LayoutSpec | str | None = None, *, holdout: str | None = "auto",
              mesh_size_mm: float = DEFAULT_MAX_CELL_MM, min_cells: int = DEFAULT_MIN_CELLS,
              candidates=None, options: ModelOptions | None = None, models: "Models | None" = None,
              rerun: bool = True, jobs: int = 1, progress=None, use_cache: bool = True,
              discrepancy: bool | str = "auto", max_effects: int = MAX_EFFECTS,
              form_retune: bool = True, rerun_transient: str = "reduced") -> CorrelationResult:
    """Run the correlation workflow on measured runs (see the module docstring).

    discrepancy : 'auto' (default): the library first (the re-tune, its form knobs and forward selection); where
        its choice does not predict held-out data within :data:`NONE_NOISE_FACTOR` noise sigmas
        (:func:`plain_explains`), the selection again with the model's own error as a term
        (:class:`Discrepancy`, its scale estimated per fit), whose verdict stands; where it names nothing and
        the re-tune is within that standard, the term is fitted on the re-tuned model alone and the verdict is
        'discrepancy' if the data support it (:func:`verdict_discrepancy`), else 'none'. True: always with
        the term; False: never. The term is not fitted on sparse files (:func:`form_band` instead).
    max_effects : forward selection names at most this many library effects (1: one effect, as before)
    form_retune : re-tune the form knobs (:data:`FORM_RETUNE`: the cavity's emissivity) beside the others
        instead of offering them as candidate effects (default); False: offered as candidates
        (``--cavity-emissivity-as-effect``)
    candidates : names to consider (default: every effect applicable to at least one run's scheme)
    rerun : re-run the corrected model on the full FEM (:func:`rerun_full`) for the after figures
    rerun_transient : 'reduced' (default): the re-run's transients on the study's checked reduced model (the
        full adaptive FEM where the check fails); 'full': the full adaptive FEM (``--full``)
    jobs : worker processes for the reduced models' builds, the candidates' fits and the re-runs
    models : :class:`Models` built beforehand (:func:`build_models`; a campaign reuses them across
        cases); default: built here for the runs' (scheme, ambient) pairs
    progress : callable(str) or None, told what is being done
    use_cache : keep the reduced models and the re-run in the disk cache (:mod:`imutherm.cache`) and read
        them from it: the next correlation of the same unit skips their builds
    """
    t0 = time.perf_counter()
    say = progress or (lambda s: None)
    runs = tuple(runs)
    layout, options, models = _inputs_and_models(runs, layout, holdout, mesh_size_mm, min_cells, options, models,
                                                 jobs, say, use_cache)
    fscale = form_error.form_scale(r.scheme for r in runs)
    caps = {g: fscale.cap(g) for g in fscale.fraction}
    roms, geometries = models.roms, models.geometries
    t_rom = time.perf_counter() - t0
    # a form knob asked for as a candidate (or every one, without form_retune) is not re-tuned
    form = tuple(n for n in FORM_RETUNE if form_retune and n not in (candidates or ()))
    fwd = ForwardModel(runs, roms, geometries, models.options, form)
    _check_time_constants(runs, roms, geometries)
    noise = float(np.median([noise_sigma(r) for r in runs]))
    nominal = dict(fwd.nominal)
    before_res = model_residuals(fwd, nominal, {i: np.isfinite(r.values_C) for i, r in enumerate(runs)})
    loc, fp = localise(fwd, nominal)
    say("re-tune")
    # the fits' small dense algebra (reduced models of ~40 unknowns) on one BLAS thread, as in the workers:
    # OpenBLAS's two threads on matrices that small cost more than they give (measured at load 5: a re-tune
    # 0.13 s on one thread, 0.23-0.30 s on two; at load ~9 the three re-tune fits took 12 s of CPU, not 1 s),
    # and the results are the same
    with thread_limit(1):
        sel = _select(runs, models, fwd, form, form_retune, candidates, holdout, discrepancy, nominal, noise, caps,
                      fscale, jobs, max_effects, say)
    t_fits = time.perf_counter() - t0 - t_rom
    v, named, amb_set, reason, named_effects = _decide(sel, noise, say)
    after, none_fit, disc = (sel.chosen[-1] if sel.chosen else sel.none_fit), sel.none_fit, sel.disc
    dsum = None
    if disc is not None:
        dsum = discrepancy_summary(sel.fwd, disc, sel.plain, none_fit, after, sel.full, noise, loc)
        if v in ("none", "not_in_library"):  # the rules again, now between the re-tune alone and with the term
            v, reason = verdict_discrepancy(sel.plain, none_fit, dsum, noise, v, reason)
    if sel.disc_note:
        reason += f" ({sel.disc_note})"
    if sel.term_check and v == "none":  # the term was asked and is not needed: the re-tuned model stands as it is
        after, none_fit, disc = sel.plain, sel.plain, None
    free, found, symptoms, written = _physics(sel, after, disc, noise, nominal, fscale)
    in_place = named_in_place(sel.fwd, free, symptoms, sel.full, noise,
                              form_error.band_K(sel.fwd, fscale, free.values, sel.full)) if named_effects else {}
    leading = None
    if in_place:  # a library effect named merely in the place of a knob at its bound: both ambiguous, no name
        v, named, amb_set, reason, named_effects, leading = _in_place(sel, in_place, named_effects, reason, say)
        after, none_fit = (sel.chosen[-1] if sel.chosen else sel.none_fit), sel.none_fit
        free, found, symptoms, written = _physics(sel, after, disc, noise, nominal, fscale)
        if disc is not None:
            dsum = discrepancy_summary(sel.fwd, disc, sel.plain, none_fit, after, sel.full, noise, loc)
    if found:
        # a knob that explains the data is the explanation: the physics it was found in (no term) is the corrected
        # model, so the verdict, the words, page 1, updated_model.toml and `parameters` carry the same value
        after, disc = free, None
    expl = explanations_of(sel.fwd, free, found, amb_set, sel.full, sel.folds, sel.ratio0, noise, symptoms)
    if v == "ambiguous" and leading is None and symptoms and not found:
        amb_set, leading, expl, joined = _knobs_join(sel, free, amb_set, expl, symptoms, noise, fscale, say)
        reason += "".join(f"; {w}" for w in joined)
    nxt = None
    if amb_set and not found:
        step = next((st for st in reversed(sel.steps) if st["verdict"] == "ambiguous"), None)
        fits = [f for f in (step["ranking"] if step else ()) if f.effects and f.effects[-1] in amb_set]
        base = step["base"] if step else sel.none_fit  # the re-tuned model: the model's own error, to be told apart
        against = [f.effects[-1] for f in fits if sel.disc is not None  # from candidates the term's standard refuses
                   and not explains_term(f, base, noise, (f,), sel.plain.heldout_rms_K)]
        nxt = next_experiment_of(sel.fwd, leading or [(f.effects[-1], f.values, f.disc) for f in fits], noise,
                                 fscale.fraction, ("the re-tuned model", base.values, base.disc), against)
        if nxt is not None:
            say(nxt["in_words"])
    if symptoms:
        reason += "; " + "; ".join(x.words() for x in symptoms)
        say("; ".join(x.words() for x in symptoms))
    if found:
        fw = "; ".join(f.words() for f in found)
        if v == "effect":
            reason = f"finding: {fw}; then the library: {reason}"
        else:
            reason = f"finding: {fw} (without it: {v}, {reason})"
            v, named, amb_set = "finding", None, ()
        say(f"finding: {fw}")
    if written["model"] != "corrected":
        say(written["reason"])
    curves = _curves(sel.fwd, runs, nominal, after, disc)
    before = {"rms_K": float(np.sqrt(np.mean(before_res**2))), "max_K": float(np.abs(before_res).max()),
              "heldout_rms_K": heldout_nominal(sel.fwd, sel.folds, nominal)}
    words = "; ".join([f.words() for f in found] + [effect_words(n, after.values) for n in named_effects]
                      + [x.words() for x in symptoms]) or reason
    if dsum is not None and dsum["supported"]:
        words += f"; {dsum['words']}"
    band = form_band(sel.fwd, after.values, sel.full, named_effects) if sel.sparse_term else None
    if band is not None:
        words += f"; {band['words']}"
    if nxt is not None:
        words += f"; {nxt['in_words']}"
    t1 = time.perf_counter()
    rerun_stats = (_rerun(runs, after, disc, models, curves, jobs, say, use_cache, rerun_transient) if rerun
                   else {})
    reduced = {f"{s}@{a:g}C": {"basis": r.basis_size, "unknowns": r.unknowns, "build_s": r.build_s,
                                "solves": r.solves} for (s, a), r in roms.items()}
    return CorrelationResult(
        verdict=v, named_effect=named, ambiguous_set=amb_set, before=before, after=after, retune=none_fit,
        ranking=tuple(sel.ranking), localise=loc, fingerprints=fp, noise_K=noise, curves=curves, runs=runs,
        reduced=reduced,
        timings={"reduced_models_s": t_rom, "fits_s": t_fits, "full_rerun_s": time.perf_counter() - t1,
                 "total_s": time.perf_counter() - t0, "reason": reason},
        words=words, full=rerun_stats, named_effects=named_effects, steps=tuple(sel.steps), discrepancy=dsum,
        retune_plain=sel.plain, form_band=band, findings=found, written=written, form_scale=fscale.summary(),
        physics=free, symptoms=symptoms, explanations=tuple(expl), next_experiment=nxt)


def _inputs_and_models(runs: tuple, layout, holdout, mesh_size_mm: float, min_cells: int, options, models,
                       jobs: int, say, use_cache: bool) -> tuple:
    """(layout, options, models) of a correlation, the measured files refused first where they must be (no
    file, duplicates, implausible readings, :func:`check_inputs` before the reduced models are built)."""
    if not runs:
        raise InputError("correlate: no measured files")
    refuse_duplicates(runs)
    check_plausible(runs)
    if not isinstance(layout, LayoutSpec):
        layout = load_layout(layout)
    options = options or ModelOptions()
    if models is None:
        check_inputs(runs, layout, holdout, mesh_size_mm=mesh_size_mm, min_cells=min_cells, options=options, say=say,
                     use_cache=use_cache)
        models = build_models(sorted({(r.scheme, r.ambient_C) for r in runs}), layout, mesh_size_mm=mesh_size_mm,
                              min_cells=min_cells, options=options, jobs=jobs, progress=say, use_cache=use_cache)
    missing = sorted({(r.scheme, r.ambient_C) for r in runs} - set(models.roms))
    if missing:
        raise InputError(f"correlate: no reduced model for {', '.join(f'{s} at {a:g} C' for s, a in missing)}")
    return layout, options, models


def _check_time_constants(runs: tuple, roms: dict, geometries: dict) -> None:
    """A file must reach the model's time constant (t63 of its slowest site) or give a steady row."""
    for run in runs:
        if not np.isinf(run.times_s).any():
            loc, _ = localise(ForwardModel((run,), roms, geometries), {})
            t63 = max(s["model_t63_s"] for s in loc[run.name].values())
            last = float(run.times_s[np.isfinite(run.times_s)].max())
            if last < t63:
                raise InputError(f"{run.path}:{run.lines[-1]}: the file ends at {last:g} s, before the model's "
                                 f"time constant ({t63:.0f} s, t63 of its slowest site): nothing to correlate "
                                 f"the plateau with; add later readings or a steady row (time_s = inf)")


def _candidates(candidates, roms: dict, fwd: ForwardModel) -> list:
    """The candidate effects to fit: ``candidates`` (default: every model effect some reduced model carries, and
    the signal effects), each checked to be a library effect; the form knobs re-tuned are not candidates."""
    if candidates is None:
        candidates = [n for n in knobs.model_effect_names() if any(n in rom.knobs for rom in roms.values())]
        candidates += list(signal_effect_names())
    for name in candidates:
        effect_of(name)
    return [n for n in candidates if (EFFECTS[n.split("@")[0]].kind != "model"
            or any(n in rom.knobs for rom in roms.values())) and n not in fwd.form and n not in FORM_IN_DOUBT]


@dataclass
class _Selection:
    """What the re-tune and the forward selection of :func:`correlate` leave (internal)."""

    fwd: ForwardModel
    full: dict
    folds: list
    plain: Fit
    ratio0: float
    none_fit: Fit = None
    disc: object = None
    ratio: float = 1.0
    steps: list = field(default_factory=list)
    chosen: list = field(default_factory=list)
    ranking: list = field(default_factory=list)
    disc_note: str = ""
    sparse_term: bool = False
    term_check: bool = False


def _select(runs, models, fwd, form, form_retune, candidates, holdout, discrepancy, nominal, noise, caps, fscale,
            jobs, max_effects, say) -> _Selection:
    """The re-tune, the candidates and the forward selection, with the discrepancy term where it is asked
    (``discrepancy``, see :func:`correlate`)."""
    full = {i: np.isfinite(r.values_C) for i, r in enumerate(runs)}
    folds = holdout_folds(runs, holdout)
    none0 = fit_candidate(fwd, "none", full, None, 1.0, noise)
    ratio = ratio0 = n_eff_ratio(fwd, none0.values)
    plain = fit_candidate(fwd, "none", full, None, ratio, noise)
    plain = with_heldout(plain, pooled_heldout(fwd, "none", folds, ratio, noise))
    candidates = _candidates(candidates, models.roms, fwd)
    if discrepancy not in (True, False, "auto"):
        raise InputError(f"correlate: discrepancy={discrepancy!r}; valid: True, False, 'auto'")
    sel = _Selection(fwd, full, folds, plain, ratio0, none_fit=plain, ratio=ratio)
    if discrepancy and all(len(r.times_s) < SPARSE_READINGS for r in runs):
        # two coefficients per series fit a sparse file's few readings exactly: nothing is left to judge by
        sel.disc_note = (f"discrepancy term not fitted: every file has fewer than {SPARSE_READINGS} readings per "
                         f"site, which its two coefficients per site would fit exactly")
        say(sel.disc_note)
        discrepancy = False
        sel.sparse_term = True
    plain_sel, costs = None, {}
    if discrepancy == "auto":  # the library first; the term only where the library does not explain the data
        plain_sel = forward_select(fwd, plain, candidates, full, folds, ratio, noise, None, jobs, max_effects, say,
                                   costs=costs)
        discrepancy = _term_asked(sel, plain_sel, fscale, noise, say)
    if discrepancy:
        sel.fwd, sel.disc, sel.none_fit, sel.ratio = retune_with_term(runs, models, form, form_retune, nominal, noise,
                                                                      sel.ratio, full, folds, caps)
    if discrepancy or plain_sel is None:
        if plain_sel is None and sel.disc is not None:  # the library's fits without the term: starts of those with it
            plain_sel = ([{"ranking": tuple(map_jobs(fit_candidate, [(sel.fwd, (n,), full, None, sel.ratio, noise)
                                                                     for n in candidates], jobs))}], [])
        hints = {f.effects: f.values for st in (plain_sel[0] if plain_sel else ()) for f in st["ranking"]}
        sel.steps, sel.chosen = forward_select(sel.fwd, sel.none_fit, candidates, full, folds, sel.ratio, noise,
                                               sel.disc, jobs, max_effects, say, hints, costs)
    else:
        sel.steps, sel.chosen = plain_sel
    sel.ranking = list(sel.steps[0]["ranking"]) if sel.steps else []
    if sel.term_check:
        sel.fwd, sel.disc, sel.none_fit, sel.ratio = retune_with_term(runs, models, form, form_retune, nominal, noise,
                                                                      sel.ratio, full, folds, caps)
    return sel


def _term_asked(sel: _Selection, plain_sel: tuple, fscale, noise: float, say) -> bool:
    """``discrepancy='auto'``: whether the selection is run again with the discrepancy term, after the library's
    own (``plain_sel``); sets ``sel.disc_note`` and ``sel.term_check`` (the term fitted on the re-tuned model
    alone, to ask whether the data support it)."""
    plain = sel.plain
    band = form_error.band_K(sel.fwd, fscale, plain.values, held_out_union(sel.folds))
    if plain_sel[1] and form_error.named_through_form(plain.heldout_rms_K, plain_sel[1][-1].heldout_rms_K, band,
                                                      noise, NONE_NOISE_FACTOR):
        sel.disc_note = (gain_words(plain_sel[1][-1], plain) + f", within the model's known form error ({band:.3f} "
                         f"K held out, {form_error.FORM_SIGMAS:g} sigmas {form_error.FORM_SIGMAS * band:.3f} K; noise "
                         f"{noise:.3f} K): named through the form error, no discrepancy term asked")
        say(sel.disc_note)
        return False
    if plain_explains(plain_sel, noise, plain):
        # nothing named and the re-tune within the noise standard: is a smooth residual left that the
        # data support all the same (the model's form, or an effect outside the library the re-tune hid)?
        sel.term_check = not plain_sel[1]
        return False
    if plain_explains(plain_sel, noise):  # within the noise, but no more than a form error's gain
        sel.disc_note = (gain_words(plain_sel[1][-1], plain) + f", less than {1 / EXPLAIN_FRACTION:g}x: a gain "
                         f"the model's form error could give; judged with the discrepancy term")
    else:
        sel.disc_note = ("the library effects and the re-tune do not predict held-out data within "
                         f"{NONE_NOISE_FACTOR:g} noise sigmas: judged with the discrepancy term")
    say(sel.disc_note)
    return True


def _decide(sel: _Selection, noise: float, say) -> tuple:
    """(verdict, named effect, ambiguous set, reason, named effects) of the selection; with the discrepancy term
    the chosen effects are cut where they do not explain the model's error (``sel.steps``, ``sel.chosen`` set)."""
    steps, chosen, disc, none_fit = sel.steps, sel.chosen, sel.disc, sel.none_fit
    unexplained = ""
    pg = sel.plain.heldout_rms_K  # the plain re-tune's held-out error: is there an error to explain at all
    if disc is not None and len(chosen) > 1:
        # with the term capped at the model's known form error, a further effect must itself explain what the
        # effects before it leave of the term, where it acts (halve it or leave it within 2 noise sigmas): the
        # halving rule of the plain path, for the term. Else a form error beyond the known one is handed, piece by
        # piece, to further library effects (toy, 6 % form error and a 0.5 W regulator error: power@processor named
        # second, not hidden)
        k = next((k for k in range(1, len(chosen)) if not explains_term(chosen[k], chosen[k - 1], noise,
                                                                       chosen[k:k + 1], pg)), None)
        if k is not None:
            steps, chosen = truncate_selection(steps, chosen, k, "none", "does not halve the discrepancy the "
                                               "effects before it leave where it acts", say)
    if disc is not None and chosen and not explains_term(chosen[-1], none_fit, noise, chosen, pg):
        # the longest first part of the selection that does explain it (a later step may add an effect that
        # acts where the form error is and explains it not)
        keep = next((k for k in range(len(chosen) - 1, 0, -1)
                     if explains_term(chosen[k - 1], none_fit, noise, chosen[:k], pg)), 0)
        if keep:
            steps, chosen = truncate_selection(steps, chosen, keep, "not_in_library",
                                               "does not explain the model's error where it acts", say)
    settled = (settled_by_file(sel.fwd, disc, chosen[0], none_fit, steps[0]["ranking"], sel.full, sel.ratio, noise)
               if disc is not None and chosen and not explains_term(chosen[-1], none_fit, noise, chosen, pg) else None)
    if settled:  # refused by the term's standard, but it predicts a file it was not fitted to (file_test.py)
        say(settled["words"])
        steps, chosen = (truncate_selection(steps, chosen, 1, "none", "is not settled by a file", say)
                         if len(chosen) > 1 else (steps, chosen))
        steps[0] = dict(steps[0], reason=f"{steps[0]['reason']}; {settled['words']}")
    elif disc is not None and chosen and not explains_term(chosen[-1], none_fit, noise, chosen, pg):
        f = chosen[-1]
        unexplained = (f"no candidate explains the model's error: the best, {f.name}, leaves a discrepancy of "
                       f"{f.disc_rms_K:.2f} K of the re-tuned model's {none_fit.disc_rms_K:.2f} K (more than "
                       f"{EXPLAIN_FRACTION:g} of it and {NONE_NOISE_FACTOR:g} noise sigmas)")
        say(unexplained)
        chosen = []
    sel.steps, sel.chosen = steps, chosen
    named_effects = tuple(f.effects[-1] for f in chosen)
    if unexplained:
        return "not_in_library", None, (), unexplained, named_effects
    if chosen:
        reason = "; ".join(st["reason"] for st in steps if st["verdict"] == "effect")
        if len(steps) > len(chosen):
            reason += f"; then stopped: {steps[len(chosen)]['reason']}"
        return "effect", named_effects[0], (), reason, named_effects
    if steps:
        return steps[0]["verdict"], None, steps[0]["ambiguous_set"], steps[0]["reason"], named_effects
    return "none", None, (), "no candidate effect applies", named_effects


def _in_place(sel: _Selection, in_place: dict, named_effects: tuple, reason: str, say) -> tuple:
    """(verdict, named, ambiguous set, reason, named effects, leading candidates) once the first effect named in
    the place of a knob at its bound (:func:`named_in_place`) is cut with every effect after it; ``sel.steps``
    and ``sel.chosen`` cut. The ambiguous set: that effect and the knob, the knob's candidate the model without
    the effect (the knob at its bound); the leading candidates, (name, fitted values), for the next experiment."""
    k = min(named_effects.index(e) for e in in_place)
    e, x = named_effects[k], in_place[named_effects[k]]
    why = (f"{e} was named in the place of {x['knob']}, at its {x['bound']} bound: {x['words']}, and freed past it "
           f"the re-tune takes {e}'s signature ({x['signature_K']:.2f} K RMS) to within {x['left_free_K']:.2f} K (held at "
           f"the bound {x['left_held_K']:.2f} K; the level a right model leaves {x['level_K']:.2f} K): ambiguous")
    say(why)
    amb = (e, x["knob"])
    base = sel.chosen[k - 1] if k else sel.none_fit
    leading = [(e, sel.chosen[k].values), (x["knob"], base.values)]
    sel.steps = sel.steps[:k] + [dict(sel.steps[k], verdict="ambiguous", named=None, ambiguous_set=amb, reason=why)]
    sel.chosen = sel.chosen[:k]
    kept = named_effects[:k]
    if kept:
        return "effect", kept[0], (), f"{reason}; then {why}", kept, leading
    return "ambiguous", None, amb, why, kept, leading


def _knobs_join(sel: _Selection, free: Fit, amb_set: tuple, expl: list, symptoms: tuple, noise: float, fscale,
                say) -> tuple:
    """(ambiguous set, leading candidates or None, explanations, words) of an ambiguous verdict with knobs at a bound: a
    knob whose move past its bound would take an ambiguous candidate's signature (:func:`named_in_place`, on the
    physics with that candidate, ``expl``'s fit of it) joins the set as a candidate of its own, its predicted
    readings the physics without the candidates (the knob at its bound), so the next experiment separates it too."""
    band = form_error.band_K(sel.fwd, fscale, free.values, sel.full)
    joined = {}
    for e in expl:
        if e.get("ambiguous") and e["kind"] == "effect" and "values" in e:
            alt = fit_with(free, values=e["values"], effects=free.effects + (e["name"],))
            x = named_in_place(sel.fwd, alt, symptoms, sel.full, noise, band).get(e["name"])
            if x is not None and x["knob"] not in joined:
                joined[x["knob"]] = (f"{e['name']} shares its evidence with {x['knob']} at its {x['bound']} bound "
                                     f"({x['words']}): the knob joins the ambiguous set")
                say(joined[x["knob"]])
    if not joined:
        return amb_set, None, expl, ()
    step = next((st for st in reversed(sel.steps) if st["verdict"] == "ambiguous"), None)
    fits = [f for f in (step["ranking"] if step else ()) if f.effects and f.effects[-1] in amb_set]
    leading = [(f.effects[-1], f.values) for f in fits] + [(k, free.values) for k in joined]
    sym = {s.parameter: s for s in symptoms}
    expl = list(expl) + [knob_entry(sym[k], noise) for k in joined]
    return tuple(amb_set) + tuple(joined), leading, expl, tuple(joined.values())


def _physics(sel: _Selection, after: Fit, disc, noise: float, nominal: dict, fscale) -> tuple:
    """(the corrected physics without the term, findings, symptoms, the model to write): the re-tune's far moves
    (profile intervals at the noise and the known form error ``fscale``; knobs at a bound are symptoms) and the
    written model, both on the physics without the discrepancy term. With findings the physics is the model
    written (no worse than the nominal model, else the nominal), and the findings' intervals are its ``ci``."""
    fwd, full, folds, ratio0 = sel.fwd, sel.full, sel.folds, sel.ratio0
    with thread_limit(1):
        free = after
        if disc is not None:
            free = with_heldout(fit_candidate(fwd, after.effects, full, None, ratio0, noise, None, after.values),
                                pooled_heldout(fwd, after.effects, folds, ratio0, noise, None, after.values))
        held_out = held_out_union(folds) if folds[0][1] is not None else full
        band = form_error.band_K(fwd, fscale, free.values, full)
        found, symptoms = explain_knobs(fwd, free, full, folds, ratio0, noise, held_out, band)
        if found:
            free = fit_with(free, ci={**free.ci, **{f.parameter: f.ci95 for f in found}})
            written = choose_written(fwd, nominal, free.values, None, held_out)
        else:
            written = choose_written(fwd, nominal, after.values, free.values if disc is not None else None, held_out)
    return free, found, symptoms, written


def _curves(fwd: ForwardModel, runs: tuple, nominal: dict, after: Fit, disc) -> dict:
    """run name -> its sites, times [s], measured, nominal and corrected rises [K] and the term's part [K]."""
    curves = {}
    for i, run in enumerate(runs):
        d = term_curve(disc, after.disc, i, run)
        curves[run.name] = {"sites": run.sites, "times_s": run.times_s, "measured_K": run.rise_K,
                            "before_K": fwd.rise(i, nominal), "after_K": fwd.rise(i, after.values) - d,
                            "discrepancy_K": -d}
    return curves


def _rerun(runs: tuple, after: Fit, disc, models: Models, curves: dict, jobs: int, say, use_cache: bool,
           rerun_transient: str) -> dict:
    """The corrected model re-run on the full model (:func:`rerun_full`): its RMS / max [K] with and without the
    term's correction, how each transient was computed; each run's curve gets ``after_full_K``."""
    rises, transients = rerun_full(runs, after.values, models, jobs, say, use_cache, rerun_transient)
    res_full = np.concatenate([(y - r.rise_K)[np.isfinite(r.values_C)] for y, r in zip(rises, runs)])
    res_disc = np.concatenate([(y - term_curve(disc, after.disc, i, r) - r.rise_K)[np.isfinite(r.values_C)]
                               for i, (y, r) in enumerate(zip(rises, runs))])
    for i, (y, r) in enumerate(zip(rises, runs)):
        curves[r.name]["after_full_K"] = y - term_curve(disc, after.disc, i, r)
    return {"rms_K": float(np.sqrt(np.mean(res_disc**2))), "max_K": float(np.abs(res_disc).max()),
            "rms_physics_K": float(np.sqrt(np.mean(res_full**2))),
            "max_physics_K": float(np.abs(res_full).max()), "transients": transients}
