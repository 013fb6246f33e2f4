"""A name settled by a file it was not fitted to: the proposed experiment read as the prediction it was designed for.

With the discrepancy term, an effect is named only where it explains the model's error
(:func:`~imutherm.studies.correlation.verdict.explains_term`): where the term and an effect both fit, they are not
separately identifiable (Brynjarsdóttir & O'Hagan 2014), and a form error is handed on to a library name. But an
effect smaller than the model's form error can never halve the term, however well a designed experiment separates
it: issue 58's seed 63 (nuisance form, 5 %): after the proposed file (air, 0.5x power) was added, the board joint
ranked first by ΔAICc 47 over the re-tune and 45 over the runner-up, fitted at 1697 W/m² K (1620 hidden), and was
refused because it took the air term only 0.35 -> 0.22 K; its signature there, 0.29 K, is smaller than the form
error.

What identifies an effect apart from the term is a **prediction**: :func:`settled_by_file` holds out in turn each
file whose scheme and ambient another file shares (a bench's repeat at another power, duration or probe set: the
proposed experiment), fits the effect and its rivals (the re-tuned model and every candidate of the step that
beat it on the evidence) on the other files, with the term, and predicts the held-out file. The term's coefficients
are fractions of each site's nominal rise (:class:`~imutherm.studies.correlation.discrepancy.Discrepancy`), so at a
site the sibling file measures they are carried over: the model's form error, a property of the scheme's heat
paths, is the same fraction of the rise whatever power the bench sets (exact for a linear model; conduction is
linear and the radiation and convection of a 10-20 K rise nearly so). A form error handed on to a name does not
predict a file made at another design better than the term carried over does; a real effect does. The effect is
named when, on the held-out file, it meets against every rival the standard the effect was refused by (rule 2,
:func:`~imutherm.studies.correlation.verdict.explains_term`): the rival misses the file by more than
:data:`~imutherm.studies.correlation.verdict.NONE_NOISE_FACTOR` noise sigmas (RMS) and the effect leaves at most
:data:`~imutherm.studies.correlation.verdict.EXPLAIN_FRACTION` of that or those 2 sigmas, and it explains at least
:data:`~imutherm.studies.correlation.verdict.EXPLAIN_MIN_NOISE` noise sigmas of the file over the re-tuned model
(the verdict's own standards, no new margin). A paired test over the file's series (Diebold & Mariano 1995,
:func:`~imutherm.studies.correlation.holdout.heldout_worse_z`) was tried first: with 6 series and an effect at one
or two sites it resolves nothing (toy, 0.25 W at the 5 V regulator and a half-power air file added: with the air
file held out the re-tuned model misses it by 1.0 K RMS, the regulator by 0.33 K, z 1.1). With one file per scheme
and ambient (a first correlation) nothing is held out and the verdict is unchanged.
"""

from __future__ import annotations

import math

import numpy as np

from imutherm.studies.correlation.fit import Fit, fit_candidate

#: the largest number of rival candidates (besides the re-tuned model) fitted again for the test, best first
MAX_RIVALS = 3


def _siblings(runs, i: int) -> list:
    """Indices of the other runs of run ``i``'s scheme and ambient that share a site with it."""
    r = runs[i]
    return [k for k, x in enumerate(runs) if k != i and x.scheme == r.scheme and x.ambient_C == r.ambient_C
            and set(x.sites) & set(r.sites)]


def predict_file(fwd, disc, f: Fit, i: int, full: dict, ratio: float, noise_K: float) -> tuple:
    """(per-series squared-error sums [K²], readings) of run ``i`` predicted by ``f``'s model fitted on the other
    runs with the term ``disc``; each site's term carried over from the sibling runs' same site (their mean
    coefficient; none at a site no sibling measures)."""
    train = {k: (m if k != i else np.zeros_like(m)) for k, m in full.items()}
    d = disc.with_prior(f.disc_priors) if f.disc_priors else disc
    g = fit_candidate(fwd, f.effects or "none", train, None, ratio, noise_K, d, f.values)
    run, sib = fwd.runs[i], _siblings(fwd.runs, i)
    r = fwd.rise(i, g.values) - run.rise_K
    sums, counts = [], []
    for j, site in enumerate(run.sites):
        rows = full[i][:, j]
        if not rows.any():
            continue
        cs = [g.disc[(k, fwd.runs[k].sites.index(site))] for k in sib
              if site in fwd.runs[k].sites and (k, fwd.runs[k].sites.index(site)) in g.disc]
        c = np.mean(cs, axis=0) if cs else np.zeros(2)
        e = r[rows, j] - disc.basis[(i, j)][rows] @ c
        sums.append(float(e @ e))
        counts.append(int(rows.sum()))
    return np.array(sums), np.array(counts, float)


def settled_by_file(fwd, disc, f: Fit, none: Fit, ranking, full: dict, ratio: float, noise_K: float) -> dict | None:
    """The evidence that ``f`` (one effect on the re-tuned model ``none``) is settled by a file it was not fitted
    to (see the module docstring), or None: {'file', 'rms_K' (name -> held-out RMS [K] of the file), 'words'}.
    ``ranking``: the step's candidates; rivals are those that beat ``none`` on the evidence."""
    from imutherm.studies.correlation.verdict import EXPLAIN_FRACTION, EXPLAIN_MIN_NOISE, NONE_NOISE_FACTOR
    if disc is None or len(f.effects) != 1:
        return None
    files = [i for i in range(len(fwd.runs)) if _siblings(fwd.runs, i)]
    if not files:
        return None
    rivals = [none] + [g for g in ranking if g.effects and g.effects != f.effects and g.aicc < none.aicc][:MAX_RIVALS]
    for i in files:
        mine, n = predict_file(fwd, disc, f, i, full, ratio, noise_K)
        if not len(n):
            continue
        rms = {f.name: math.sqrt(mine.sum() / n.sum())}
        ok = True
        for g in rivals:
            other, _ = predict_file(fwd, disc, g, i, full, ratio, noise_K)
            rms[g.name] = math.sqrt(other.sum() / n.sum())
            floor = NONE_NOISE_FACTOR * noise_K
            if not (rms[g.name] > floor and rms[f.name] <= max(floor, EXPLAIN_FRACTION * rms[g.name])):
                ok = False
                break
        gain = math.sqrt(max(rms[none.name] ** 2 - rms[f.name] ** 2, 0.0))
        if ok and gain >= EXPLAIN_MIN_NOISE * noise_K:
            name = fwd.runs[i].name
            others = ", ".join(f"{g} {x:.3f} K" for g, x in rms.items() if g != f.name)
            return {"file": name, "rms_K": rms,
                    "words": (f"{f.name} predicts {name}, not fitted to it, within {rms[f.name]:.3f} K against "
                              f"{others}: settled by that file")}
    return None
