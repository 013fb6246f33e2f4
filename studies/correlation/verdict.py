"""The verdict rules: when a candidate effect is named, when the data say ``none``, ``ambiguous``,
``not_in_library`` or ``discrepancy``, with the margins and their sources.
"""

from __future__ import annotations

import math

import numpy as np

from imutherm.unit.effects import effect_of
from imutherm.studies.correlation.discrepancy import Discrepancy, term_curve
from imutherm.studies.correlation.fit import Fit
from imutherm.studies.correlation.holdout import heldout_worse_z


#: ΔAICc a candidate must gain over the re-tuned model (Burnham & Anderson 2002: > 10, essentially
#: no support for the worse model)
MARGIN_NONE = 10.0


#: ΔAICc between the best candidate and the runner-up for a named effect (B&A: 4-7 "considerably less")
MARGIN_RUNNER_UP = 6.0


#: the re-tuned model "closes the gap" when its held-out RMS is below this many noise sigmas
NONE_NOISE_FACTOR = 2.0


#: the best candidate "explains" the data when its held-out RMS is below this many noise sigmas,
#: or below this fraction of the re-tuned model's
EXPLAIN_NOISE_FACTOR = 3.0


EXPLAIN_FRACTION = 0.5


#: a named effect must explain at least this many noise sigmas of RMS over the re-tuned model,
#: sqrt(rms_none^2 - rms_effect^2): with hundreds of readings a change far below the noise can still
#: win on AICc by fitting the model's own discretisation error. Set on the campaign's first four cases
#: per kind (null and hidden-effect-free cases explained 0.25-0.8 sigma, regulator power errors 1.7-3.6;
#: 2 sigma missed half the power errors); the campaign's later cases are the check
EXPLAIN_MIN_NOISE = 1.0


#: without AICc (sparse data): a candidate must cut the re-tuned model's held-out RMS to this fraction,
#: and the runner-up's must be at least this factor above the best's
SPARSE_FRACTION = 0.5


SPARSE_RUNNER_UP = 1.5


def explained_K(none: Fit, f: Fit) -> float:
    """RMS [K] a candidate explains over the re-tuned model: sqrt(rms_none^2 - rms^2) on the training data.

    With the discrepancy term (``f.criterion == 'evidence'``) the term would take up part of any change, so
    the measure is the RMS change the effect itself makes at the readings (``f.signature_K``)."""
    if f.criterion == "evidence" and math.isfinite(f.signature_K):
        return f.signature_K
    return math.sqrt(max(none.rms_K**2 - f.rms_K**2, 0.0))


#: with the discrepancy term, an effect may leave the current model's held-out RMS up to this fraction worse
#: and still be named on its evidence where the held-out series are too few for :func:`heldout_worse_z`: the
#: term, fitted on the rise, predicts the plateau about as well as a real effect does (both at the noise; toy
#: case: a 0.3 W regulator error, held-out 0.053 K with the effect, 0.052 K with the term alone, ΔC 30 for the
#: effect). Without the term the same tolerance applies from forward selection's second step on, provided the
#: effect beats the first step's base.
HELDOUT_TOL = 0.02


#: with the discrepancy term, a candidate that predicts held-out data *worse* than the current model at all
#: must gain this much evidence (twice :data:`MARGIN_NONE`) and its held-out loss must be unresolved
#: (:func:`heldout_worse_z` <= :data:`HELDOUT_Z_MAX`); one that predicts them no worse needs
#: :data:`MARGIN_NONE`. Under a form error the in-sample evidence of a wrong effect inflates, and then the
#: held-out data lean against it: on the toy with a 12 % gain error in air (the default setting, the cavity's
#: emissivity re-tuned) a poor bond line, not hidden, reached ΔC 10.7 and 11.0, held-out 1-2 % worse (z 1.3,
#: 1.7), and was named under the fixed 2 % tolerance; the hidden effects there gain ΔC 70-205 and predict
#: better. On the gross FEM path (the effective law's data, s2s inverted) a hidden 0.20 W regulator error gains
#: ΔC 28.9 at 2.2 % worse (z 1.1), unresolved by 12 held-out series, and was left ambiguous by the fixed
#: tolerance. Development figures: both cases were seen when the rule was set.
HELDOUT_WORSE_MARGIN = 2.0 * MARGIN_NONE


#: the largest :func:`heldout_worse_z` of a held-out loss that counts as unresolved (about a 2-sigma test)
HELDOUT_Z_MAX = 2.0


def verdict(none: Fit, ranking, noise_K: float, reference: Fit | None = None) -> tuple:
    """(verdict, named effect or None, ambiguous set, reason) from the fits (see the module docstring).

    ``none``: the current model (the re-tuned one, or the effects chosen so far); ``reference``: forward
    selection's first base, given from the second step on (see :data:`HELDOUT_TOL`)."""
    if not math.isfinite(none.aicc):
        return _verdict_sparse(none, ranking, noise_K)
    gap = none.heldout_rms_K if math.isfinite(none.heldout_rms_K) else none.rms_K
    later = reference is not None and reference is not none
    ref_gap = reference.heldout_rms_K if later and math.isfinite(reference.heldout_rms_K) else gap

    def held_ok(f):
        if not math.isfinite(f.heldout_rms_K):
            return True
        if none.criterion == "evidence":  # both at the noise: the held-out test guards, the evidence decides
            if f.heldout_rms_K <= gap:
                return True
            z = heldout_worse_z(f, none)
            unresolved = z <= HELDOUT_Z_MAX if math.isfinite(z) else f.heldout_rms_K <= gap * (1 + HELDOUT_TOL)
            return none.aicc - f.aicc >= HELDOUT_WORSE_MARGIN and unresolved
        if later:
            return f.heldout_rms_K <= gap * (1 + HELDOUT_TOL) and f.heldout_rms_K < ref_gap
        return f.heldout_rms_K < gap

    good = [f for f in ranking if none.aicc - f.aicc >= MARGIN_NONE and
            explained_K(none, f) >= EXPLAIN_MIN_NOISE * noise_K and held_ok(f)]
    if not good:
        if gap <= NONE_NOISE_FACTOR * noise_K:
            return "none", None, (), (f"the re-tuned model predicts held-out data within {gap:.2f} K "
                                      f"(noise {noise_K:.2f} K) and no candidate explains {EXPLAIN_MIN_NOISE:g} "
                                      f"noise sigmas more")
        return "not_in_library", None, (), "no candidate improves on the re-tuned model by the required margin"
    best = good[0]
    bgap = best.heldout_rms_K if math.isfinite(best.heldout_rms_K) else best.rms_K
    if not later and bgap > EXPLAIN_NOISE_FACTOR * noise_K and bgap > EXPLAIN_FRACTION * gap:
        return "not_in_library", None, (), (f"the best candidate {best.name} leaves {bgap:.2f} K held out "
                                            f"(noise {noise_K:.2f} K, re-tuned {gap:.2f} K)")
    if later and none.criterion != "evidence" and gap <= NONE_NOISE_FACTOR * noise_K and bgap > EXPLAIN_FRACTION * gap:
        # the effects named so far already meet the none standard: a further one must explain at least half of
        # what they leave, else its gain is of the size the model's form leaves (the first step's standard,
        # plain_explains; mild campaign of 2026-12-03: a bond line named right at 0.097 K held out, noise
        # 0.05 K, then power@reg_3v3, not hidden, for 0.083 K)
        return "none", None, (), (f"the effects named so far predict held-out data within {gap:.3f} K (noise "
                                  f"{noise_K:.3f} K); the best further candidate, {best.name}, takes it to {bgap:.3f} "
                                  f"K, less than halving it: a gain the model's form error could give")
    # a candidate the rules refused that fits better than the best one: the best one is not named in its place
    refused = [f for f in ranking if f.aicc < best.aicc and f not in good]
    close = [f for f in ranking if f is not best and f not in refused and f.aicc - best.aicc < MARGIN_RUNNER_UP]
    if refused or close:
        why = "; ".join(f"{f.name} fits better (ΔAICc {best.aicc - f.aicc:.1f}) but was refused: "
                        + _refusal(f, none, gap, noise_K) for f in refused)
        amb = tuple(f.name for f in sorted(refused + [best] + close, key=rank_key))
        tied = ", ".join([best.name] + [f"{f.name} (+{f.aicc - best.aicc:.1f})" for f in sorted(close, key=rank_key)])
        return "ambiguous", None, amb, "; ".join(x for x in (why, f"{len(close) + 1} candidate(s) within ΔAICc "
                                                               f"{MARGIN_RUNNER_UP:g}: {tied}" if close else "") if x)
    return "effect", best.name, (), (f"{best.name}: ΔAICc {none.aicc - best.aicc:.1f} over none, "
                                     f"{(ranking[1].aicc - best.aicc) if len(ranking) > 1 else math.inf:.1f} over "
                                     f"the runner-up; explains {explained_K(none, best):.2f} K RMS")


def _refusal(f: Fit, none: Fit, gap: float, noise_K: float) -> str:
    """Why :func:`verdict`'s rules refused a candidate ``f`` against the current model ``none`` (words)."""
    if none.aicc - f.aicc < MARGIN_NONE:
        return f"ΔAICc {none.aicc - f.aicc:.1f} over the current model, below {MARGIN_NONE:g}"
    if explained_K(none, f) < EXPLAIN_MIN_NOISE * noise_K:
        return f"explains {explained_K(none, f):.3f} K, below {EXPLAIN_MIN_NOISE:g} noise sigma"
    z = heldout_worse_z(f, none)
    return (f"predicts held-out data {100 * (f.heldout_rms_K / gap - 1):+.1f} % against the current model "
            f"({f.heldout_rms_K:.4f} K, z {z:.1f})")


def plain_explains(selection, noise_K: float, retune: Fit | None = None) -> bool:
    """Whether forward selection without the discrepancy term explains the data: it names effects that predict
    held-out data within :data:`NONE_NOISE_FACTOR` noise sigmas (the standard the re-tuned model is held to
    for ``none``) **and** at most :data:`EXPLAIN_FRACTION` of the re-tuned model's held-out error (``retune``,
    when given), or finds the re-tuned model within it (``none``). ``correlate(discrepancy='auto')`` (the
    default) uses the term only otherwise: where the library explains the data the term has nothing to take
    (and, fitted, it takes a share of each of two effects hidden together, so neither alone wins: the slow
    two-effect test came out ``ambiguous``). Campaign of 2026-12-02: right names on data of a mildly different
    form left 1.3-1.7 sigmas held out, wrong ones on a grossly different form 6-12.

    The fraction: effects that take the re-tuned model's held-out error down by less than half explain an
    error of the size a model's form leaves (the re-tune already within a few noise sigmas), and a form error
    and a library effect are confounded there (Brynjarsdóttir & O'Hagan 2014); the term is asked, as where
    the library does not explain the data. Gross campaign of 2026-12-03 (the effective law's data on 3 mm,
    s2s on 6 mm): the two weaker cavity emissivities, re-tuned within 2.5 and 3.2 sigmas held out, were then
    named ``contact@board`` (0.128 -> 0.076 K held out) and ``power@reg_3v3+power@reg_1v8`` (0.173 -> 0.090 K),
    neither hidden; the same fraction is the verdict's test of a best candidate (:func:`verdict`)."""
    steps, chosen = selection
    if chosen:
        h = chosen[-1].heldout_rms_K
        if not (math.isfinite(h) and h <= NONE_NOISE_FACTOR * noise_K):
            return False
        g = retune.heldout_rms_K if retune is not None else math.nan
        return not math.isfinite(g) or h <= EXPLAIN_FRACTION * g
    return not steps or steps[0]["verdict"] == "none"


def explains_term(f: Fit, none: Fit, noise_K: float, chosen=(), plain_gap_K: float = math.nan) -> bool:
    """With the discrepancy term: whether the effects of ``f`` (forward selection's choice, together) explain
    the model's error, by the standard the re-tuned model is held to for ``none`` (:data:`NONE_NOISE_FACTOR`)
    or the verdict's fraction (:data:`EXPLAIN_FRACTION`): **in every scheme where they act** (a chosen effect's
    signature there at least :data:`EXPLAIN_NOISE_FACTOR` noise sigmas; ``chosen``: the fits after each added
    effect), the term they leave (RMS of its correction) within 2 noise sigmas, or at most half the re-tuned
    model's. Otherwise nothing is named. (It was 3 sigmas, the verdict's standard for a candidate's held-out
    error, until the gross campaign of 2026-12-03: a lid heat load, outside the library, was named
    ``contact@bond`` at 1740 W/m² K leaving 2.96 sigmas of term in grease, where the right names left 0.5-1.6
    sigmas in every scheme and the null cases with the term alone 0.7-1.3; what is left unexplained is now held
    to what ``none`` is held to.) An effect is judged where it acts because the model's form error is a property of each
    scheme: a bond line (grease only) is not asked to explain the air scheme's cavity-law error, but an
    effect that acts in both must explain the term in both. Without per-scheme figures: over all data.

    With the term every candidate predicts held-out data at the noise, so the term's size is what measures
    what is left unexplained; and the term and a library effect are not separately identifiable when both fit
    (Brynjarsdóttir & O'Hagan 2014, Inverse Problems 30, 114007): on data of a grossly different form (the
    effective cavity law's, 4.4 K RMS off the s2s model) a -0.9 W regulator error takes the term from 1.9 to
    1.2 K (25 noise sigmas left) and wins on the evidence through the term's smaller Occam factor, while a real
    effect on data of the model's form takes nearly all of it (toy: its scale falls from 3 % to 0.09 % of the
    rise). Judged on the set, not per step: two effects hidden together each leave the other in the term.

    Or, in a scheme, **far beyond the term left** there, where the effects explain the model's error in another:
    every chosen effect acting there changes the readings by at least
    :data:`~imutherm.studies.correlation.form_error.FAR_FACTOR` (3) times the term it leaves (the factor by which
    a residue is "far beyond" a form error, :func:`~imutherm.studies.correlation.form_error.named_through_form`),
    **provided** they meet the standard above in at least one scheme where they act (an anchor: the effect
    explains the model's error where the model's form lets it) and the plain re-tune (no effect, no term;
    ``plain_gap_K``, its held-out RMS) misses held-out data by more than :data:`NONE_NOISE_FACTOR` noise sigmas
    (there is an error to explain). Why the far test: where one scheme's form error is larger than an effect's
    share of the term (issue 58's FEM campaign, seed 61, grid 2x finer at 5 % of the rise: a processor power named
    first with ΔAICc 62.6, its signature 2.5 K in air, halved the term there only to 0.53 of it and was refused),
    halving cannot be asked of it there. Why the anchor: an effect that explains the error in no scheme is the
    form error handed on, however large (slow null case on the other cavity law: a -0.28 W regulator, 2.4 K
    signature in air, took the term 0.28 -> 0.24 K in air and 0.14 -> 0.10 K in grease, neither halved nor within
    2 noise sigmas of 0.04 K; the toy's real 0.15 W regulator under a 12 % form error takes the grease term
    0.13 -> 0.06 K, within 2 noise sigmas of 0.055 K, and is far beyond it in air, 0.86 K against 0.25 K). The
    plain re-tune's gap does not tell those two apart (0.23 K at noise 0.04 K in the null, 0.22 K at 0.055 K in
    the toy); it is the principle's floor. Without ``plain_gap_K`` the far test is not used."""
    if not (math.isfinite(none.disc_rms_K) and math.isfinite(f.disc_rms_K)):
        return True
    from imutherm.studies.correlation.form_error import FAR_FACTOR
    chosen = tuple(chosen or (f,))
    gap_open = math.isfinite(plain_gap_K) and plain_gap_K > NONE_NOISE_FACTOR * noise_K

    def far(g, left):
        # every chosen effect acting in g changes the readings there by FAR_FACTOR times the term left, or more
        sig = [c.signature_by.get(g, 0.0) for c in chosen
               if c.signature_by.get(g, 0.0) >= EXPLAIN_NOISE_FACTOR * noise_K]
        return gap_open and bool(sig) and math.isfinite(left) and min(sig) >= FAR_FACTOR * left

    def ok(left, before):
        return left <= max(NONE_NOISE_FACTOR * noise_K, EXPLAIN_FRACTION * before)

    acting = {g for c in chosen for g, x in c.signature_by.items() if x >= EXPLAIN_NOISE_FACTOR * noise_K}
    acting &= set(f.disc_rms_by) & set(none.disc_rms_by)
    if not acting:
        return ok(f.disc_rms_K, none.disc_rms_K)
    std = {g: ok(f.disc_rms_by[g], none.disc_rms_by[g]) for g in acting}
    if all(std.values()):
        return True
    return any(std.values()) and all(std[g] or far(g, f.disc_rms_by[g]) for g in acting)


def _verdict_sparse(none: Fit, ranking, noise_K: float) -> tuple:
    """Verdict by held-out RMS alone (too few readings for an information criterion)."""
    gap = none.heldout_rms_K
    if not math.isfinite(gap):
        return "ambiguous", None, tuple(f.name for f in ranking), "too few readings for a held-out test or AICc"
    if gap <= NONE_NOISE_FACTOR * noise_K:
        return "none", None, (), f"the re-tuned model predicts the held-out experiment within {gap:.2f} K"
    order = sorted([f for f in ranking if math.isfinite(f.heldout_rms_K)], key=lambda f: f.heldout_rms_K)
    good = [f for f in order if f.heldout_rms_K <= SPARSE_FRACTION * gap]
    if not good:
        return "not_in_library", None, (), (f"no candidate halves the re-tuned model's held-out error {gap:.2f} K "
                                            f"(best {order[0].name}: {order[0].heldout_rms_K:.2f} K)" if order else "")
    best = good[0]
    close = [f for f in order if f is not best and f.heldout_rms_K < SPARSE_RUNNER_UP * max(best.heldout_rms_K,
                                                                                            noise_K)]
    if close:
        return "ambiguous", None, tuple([best.name] + [f.name for f in close]), (
            f"held-out RMS (no AICc: too few readings): {best.name} {best.heldout_rms_K:.2f} K, "
            + ", ".join(f"{f.name} {f.heldout_rms_K:.2f} K" for f in close) + f"; re-tuned {gap:.2f} K")
    return "effect", best.name, (), (f"held-out RMS {best.heldout_rms_K:.2f} K against {gap:.2f} K re-tuned "
                                     f"(no AICc: too few readings)")


def effect_words(name: str | None, values: dict) -> str:
    """The named effect in words, with its fitted value."""
    if name is None:
        return ""
    e = effect_of(name)
    p = e.params[0]
    v = values.get(name)
    where = f" at {name.split('@')[1]}" if "@" in name else ""
    return f"{e.name}{where}: {e.words}; fitted {p.name} = {v:.4g} {p.unit}"


def rank_key(f: Fit):
    return (f.aicc if math.isfinite(f.aicc) else math.inf,
            f.heldout_rms_K if math.isfinite(f.heldout_rms_K) else math.inf)


def discrepancy_summary(fwd, disc: Discrepancy, plain: Fit, with_term: Fit, after: Fit, full: dict, noise: float,
                        loc: dict) -> dict:
    """What the discrepancy term says: whether the data support it (evidence against the re-tune alone),
    and the model's form error d = measured - model it carries [K] per run, site and phase (rise: before
    the site's nominal t63; plateau: after its t95), in words for the sites where it exceeds the noise.

    Support: ΔC = (n_eff / n)(J_plain - J_term) / σ² - Σ log det(I + ΦᵀΦ / λ) >= :data:`MARGIN_NONE`, the
    evidence of the re-tuned model with the term over the re-tune alone (the log det: the term's Occam factor).
    """
    gain = disc.ratio * (plain.cost_K2 - with_term.cost_K2) / disc.sigma_K**2 - disc.with_prior(
        with_term.disc_priors).occam(full)
    rows, per = [], {}
    for i, run in enumerate(fwd.runs):
        d = -term_curve(disc, after.disc, i, run)
        t = run.times_s
        for j, s in enumerate(run.sites):
            st = loc.get(run.name, {}).get(s)
            if st is None:
                continue
            ok = np.isfinite(run.values_C[:, j])
            for phase, sel in (("rise", t <= st["model_t63_s"]), ("plateau", t >= st["model_t95_s"])):
                x = d[sel & ok, j]
                if not len(x):
                    continue
                mean = float(np.mean(x))
                per.setdefault(run.name, {}).setdefault(s, {})[phase] = {"mean_K": mean,
                                                                         "rms_K": float(np.sqrt(np.mean(x**2)))}
                if abs(mean) > noise:
                    rows.append((run.scheme, phase, s, mean))
    rms = float(np.sqrt(np.mean(np.concatenate([(-term_curve(disc, after.disc, i, r))[full[i]]
                                                  for i, r in enumerate(fwd.runs)]) ** 2)))
    groups = {}
    for scheme, phase, s, mean in rows:
        groups.setdefault((scheme, phase, mean > 0), []).append((s, mean))
    parts = []
    for (scheme, phase, warmer), xs in sorted(groups.items(), key=lambda kv: -max(abs(m) for _, m in kv[1])):
        mag = float(np.median([abs(m) for _, m in xs]))
        parts.append(f"~{mag:.2g} K too {'cool' if warmer else 'warm'} at {', '.join(s for s, _ in xs)} "
                     f"({scheme}, {phase})")
    words = ("the model's form is off by " + "; ".join(parts) + ", not explained by any library effect"
             if parts else "the discrepancy term is within the noise at every site")
    return {"supported": bool(gain >= MARGIN_NONE), "evidence_gain": float(gain),
            "prior_fraction": with_term.disc_prior, "prior_fraction_after": after.disc_prior,
            "prior_fraction_by_scheme": dict(with_term.disc_priors),
            "prior_fraction_after_by_scheme": dict(after.disc_priors),
            "rms_by_scheme_K": dict(after.disc_rms_by),
            "sigma_K": disc.sigma_K, "rms_K": rms, "per_site": per, "words": words,
            "basis": "per run and site: dT s(t), dT 4 s(1 - s), s the nominal normalised response"}


def verdict_discrepancy(plain: Fit, with_term: Fit, dsum: dict, noise: float, v: str, reason: str) -> tuple:
    """No library effect named: 'none' if the re-tune alone predicts held-out data within
    :data:`NONE_NOISE_FACTOR` noise sigmas and the data do not support the discrepancy term (or the term does
    not predict them better); 'discrepancy' if the data support the term and with it the re-tuned model
    predicts held-out data better (within the none standard already) or within :data:`EXPLAIN_NOISE_FACTOR`
    sigmas or half the re-tune's error (outside it); else 'not_in_library'.

    Why a re-tune within the none standard is still asked: on data of a mildly different form with a radiant
    lid load of 378 W/m² hidden (outside the library; campaign of 2026-12-03), the re-tune absorbed the load
    into the powers (x1.06) and predicted held-out data within 0.084 K (noise 0.054 K: 1.6 sigmas), so the verdict
    was 'none'; the term, fitted, took it to 0.052 K with an evidence gain of 450: a smooth residual the data
    resolve, which 'none' hid."""
    gap = plain.heldout_rms_K if math.isfinite(plain.heldout_rms_K) else plain.rms_K
    gap_d = with_term.heldout_rms_K if math.isfinite(with_term.heldout_rms_K) else with_term.rms_K
    if gap <= NONE_NOISE_FACTOR * noise:
        if dsum["supported"] and gap_d < gap:
            return "discrepancy", (f"no library effect qualifies and the re-tuned model predicts held-out data within "
                                   f"{gap:.2f} K (noise {noise:.2f} K), but the data support a smooth discrepancy "
                                   f"(evidence {dsum['evidence_gain']:.0f}, {dsum['rms_K']:.2f} K RMS), with which it "
                                   f"predicts them within {gap_d:.2f} K")
        return "none", (f"the re-tuned model predicts held-out data within {gap:.2f} K (noise {noise:.2f} K) and no "
                        f"candidate qualifies")
    if dsum["supported"] and (gap_d <= EXPLAIN_NOISE_FACTOR * noise or gap_d <= EXPLAIN_FRACTION * gap):
        why = f" ({reason})" if reason.startswith("no candidate explains") else ""
        return "discrepancy", (f"no library effect qualifies{why}; the discrepancy term takes the re-tuned model's "
                               f"held-out error {gap:.2f} -> {gap_d:.2f} K (noise {noise:.2f} K)")
    return "not_in_library", reason + f" (re-tuned held-out {gap:.2f} K, with the discrepancy term {gap_d:.2f} K)"
