"""Forward selection of library effects: each step fits every compatible candidate on top of the effects
chosen so far (in worker processes, longest first) and adds the best if the verdict names it.
"""

from __future__ import annotations

import time
from dataclasses import replace


from imutherm.unit import knobs
from imutherm.unit.effects import effect_of
from imutherm.studies.correlation.discrepancy import DISCREPANCY_PRIOR, build_discrepancy
from imutherm.studies.correlation.fit import Fit, effects_of, fit_candidate
from imutherm.studies.correlation.forward_model import FORM_IN_DOUBT, ForwardModel
from imutherm.studies.correlation.holdout import with_heldout, pooled_heldout
from imutherm.studies.correlation.models import worker_pool
from imutherm.studies.correlation.noise import n_eff_ratio
from imutherm.studies.correlation.verdict import rank_key, verdict


def _fit_candidate(fwd, name, full, folds, ratio: float, noise: float, disc=None, start=None, hint=None):
    """One candidate (or combination) fitted on all data, with its pooled held-out figures (a pure
    function: run in a worker). ``hint``: its values fitted without the discrepancy term (a further start)."""
    f = fit_candidate(fwd, name, full, None, ratio, noise, disc, start, hint)
    return with_heldout(f, pooled_heldout(fwd, name, folds, ratio, noise, disc and disc.with_prior(f.disc_priors),
                                          start))


#: forward selection stops after this many library effects
MAX_EFFECTS = 3


def _compatible(selected: tuple, name: str) -> bool:
    """Whether effect ``name`` can be added to ``selected``: not the same effect twice, and not two effects
    that each share a jointly-interpolated conductance with the same re-tune knob (the reduced model
    interpolates each :data:`~imutherm.unit.knobs.COUPLED` pair jointly, not a triple)."""
    if name in selected:
        return False
    partners = {a if b in selected else b for a, b in knobs.COUPLED if a in selected or b in selected}
    mine = {a if b == name else b for a, b in knobs.COUPLED if name in (a, b)}
    return not (partners & mine)


def _timed(fn, *a):
    """(``fn(*a)``, its CPU seconds in this process): a worker's task, timed where it runs."""
    c0 = time.process_time()
    out = fn(*a)
    return out, time.process_time() - c0


def _fit_full(fwd, name, full, folds, ratio: float, noise: float, disc=None, start=None, hint=None) -> Fit:
    """The fit on all data of :func:`_fit_candidate`, without the held-out figures (a task of its own)."""
    return fit_candidate(fwd, name, full, None, ratio, noise, disc, start, hint)


def _fit_heldout(fwd, name, full, folds, ratio: float, noise: float, disc=None, start=None, hint=None) -> tuple:
    """The hold-out figures of :func:`_fit_candidate` without the discrepancy term (they do not depend on the
    fit on all data then: a task of its own, run beside :func:`_fit_full`)."""
    return pooled_heldout(fwd, name, folds, ratio, noise, None, start)


def _fit_candidates(args, jobs: int, costs: dict | None = None) -> list:
    """:func:`_fit_candidate` of every ``a`` of ``args`` (their order kept), on ``jobs`` workers.

    A step of the forward selection waits for its slowest candidate, so the work is balanced: without the
    discrepancy term each candidate's fit on all data and its hold-out fit are two tasks (independent then),
    and the tasks are handed out longest first, by their CPU seconds of the step before (``costs``: last
    effect -> seconds, updated here) or the effect's guessed :attr:`~imutherm.unit.effects.Effect.fit_cost`
    (before any is measured: the first step). The same fits either way: the results equal the serial ones."""
    costs = {} if costs is None else costs
    pool = worker_pool(jobs, len(args))
    if pool is None:
        return [_fit_candidate(*a) for a in args]
    split = all(a[6] is None for a in args)
    kinds = (_fit_full, _fit_heldout) if split else (_fit_candidate,)
    tasks = [(k, fn) for k in range(len(args)) for fn in kinds]

    def cost(task):
        k, fn = task
        last = effects_of(args[k][1])[-1]
        if (fn.__name__, last) in costs:
            return costs[(fn.__name__, last)]
        if fn is _fit_candidate and ("_fit_full", last) in costs:  # the same candidate measured without the term
            return costs[("_fit_full", last)] + costs.get(("_fit_heldout", last), 0.0)
        return effect_of(last).fit_cost

    order = sorted(range(len(tasks)), key=lambda t: -cost(tasks[t]))  # stable: ties in the given order
    try:
        futs = {t: pool.submit(_timed, tasks[t][1], *args[tasks[t][0]]) for t in order}
        done = {t: f.result() for t, f in futs.items()}
    finally:
        pool.shutdown(cancel_futures=True)
    for t, (_, sec) in done.items():
        k, fn = tasks[t]
        costs[(fn.__name__, effects_of(args[k][1])[-1])] = sec
    if not split:
        return [done[t][0] for t in range(len(tasks))]
    out = []
    for k in range(len(args)):
        f, h = done[2 * k][0], done[2 * k + 1][0]
        out.append(with_heldout(f, h))
    return out


def retune_with_term(runs, models, form, form_retune: bool, nominal: dict, noise: float, ratio: float, full, folds,
                     caps: dict | None = None):
    """The re-tuned model with the discrepancy term: (forward model, :class:`Discrepancy`, its Fit with
    held-out figures, n_eff ratio). Where the model's form is in doubt the form knobs of :data:`FORM_IN_DOUBT`
    (the cavity law's blend) are re-tuned too; the residual level σ of the evidence is what the re-tune with
    the term leaves, not below the noise, and the re-tuned model's own scales start every candidate's. ``caps``:
    scheme -> the term's largest prior scale [-] (the model's known form error,
    :mod:`imutherm.studies.correlation.form_error`)."""
    fwd = ForwardModel(runs, models.roms, models.geometries, models.options,
                       form + (tuple(FORM_IN_DOUBT) if form_retune else ()))
    disc = build_discrepancy(fwd, nominal, noise, ratio, DISCREPANCY_PRIOR, caps)
    first = fit_candidate(fwd, "none", full, None, ratio, noise, disc)
    ratio = n_eff_ratio(fwd, first.values, disc, first.disc)  # the term takes the smooth, correlated part
    disc = replace(disc, prior=dict(first.disc_priors), sigma_K=max(noise, first.rms_K), ratio=ratio)
    none_fit = fit_candidate(fwd, "none", full, None, ratio, noise, disc)
    disc = disc.with_prior(none_fit.disc_priors)
    return fwd, disc, with_heldout(none_fit, pooled_heldout(fwd, "none", folds, ratio, noise, disc)), ratio


def truncate_selection(steps, chosen, k: int, verdict: str, why: str, say) -> tuple:
    """(steps, chosen) of a forward selection cut to its first ``k`` effects, step k's verdict replaced by
    ``verdict`` with the reason '<effect k> <why>'."""
    say(f"named: {', '.join(c.effects[-1] for c in chosen[:k])}; not {chosen[k].effects[-1]}, which {why}")
    steps = steps[:k] + [dict(steps[k], verdict=verdict, named=None, reason=f"{chosen[k].effects[-1]} {why}")]
    return steps, chosen[:k]


def gain_words(f: Fit, retune: Fit) -> str:
    """'the library's choice (NAME) takes the re-tuned model's held-out error from A to B K'."""
    return (f"the library's choice ({f.name}) takes the re-tuned model's held-out error from "
            f"{retune.heldout_rms_K:.3f} to {f.heldout_rms_K:.3f} K")


def forward_select(fwd, base: Fit, candidates, full, folds, ratio: float, noise: float, disc=None, jobs: int = 1,
                   max_effects: int = MAX_EFFECTS, say=None, hints: dict | None = None,
                   costs: dict | None = None) -> tuple:
    """Forward selection of library effects on top of ``base`` (the re-tuned model, with the discrepancy
    term if ``disc``): at each step every compatible candidate is fitted on top of the effects chosen so
    far (their values and the re-tune's as the start), ranked, and the best added only if :func:`verdict`
    names it against the current model (the same margins: information criterion, runner-up, held-out RMS
    better than the current model's, and at least :data:`EXPLAIN_MIN_NOISE` noise sigmas of change).
    Stops at the first step that names nothing, or after ``max_effects``. ``hints``: effects tuple -> values
    of the same selection fitted without the term (the plain selection's fits), a further start of each fit.
    ``costs``: the candidates' measured CPU seconds, which order the next step's tasks (:func:`_fit_candidates`;
    shared by the selections of one correlation).

    Returns (steps, chosen fits): steps a list of dicts (``base``, ``ranking``, ``verdict``, ``named``,
    ``ambiguous_set``, ``reason``), chosen the Fit after each added effect.
    """
    say = say or (lambda s: None)
    costs = {} if costs is None else costs
    steps, chosen, cur = [], [], base
    while len(chosen) < max_effects:
        sel = cur.effects
        names = [n for n in candidates if _compatible(sel, n)]
        if not names:
            break
        say(f"step {len(chosen) + 1}: {len(names)} candidate(s) on top of {cur.name}, fitted on all data and on "
            f"each hold-out fold")
        ranking = sorted(_fit_candidates([(fwd, sel + (n,), full, folds, ratio, noise, disc, cur.values,
                                           (hints or {}).get(sel + (n,))) for n in names], jobs, costs),
                         key=rank_key)
        v, named, amb, reason = verdict(cur, ranking, noise, base)
        steps.append({"base": cur, "ranking": tuple(ranking), "verdict": v, "named": named and named.split("+")[-1],
                      "ambiguous_set": tuple(a.split("+")[-1] for a in amb), "reason": reason})
        if v != "effect":
            break
        cur = next(f for f in ranking if f.name == named)
        chosen.append(cur)
    return steps, chosen
