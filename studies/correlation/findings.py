"""A re-tuned parameter that moved far is a finding: named, with its value, interval, nominal and source range.

The re-tune (:data:`imutherm.unit.knobs.RETUNE`, the cavity's emissivity of
:data:`~imutherm.unit.knobs.FORM_RETUNE`) fits the model's uncertain parameters within their sources' ranges. A
knob that lands far from its nominal value is not noise to carry quietly in ``retuned_parameters``: a mount
conductance at 194 W/m² K where the layout assumes 500, or a cavity emissivity of 0.14 where an anodised
housing gives 0.77, *is* what the correlation found (the blind campaign's cases, where such moves ended as
``discrepancy`` or under a wrong library name).

:func:`findings` tests each knob of the final model by the evidence rules a library effect meets
(:func:`imutherm.studies.correlation.verdict`): the model with the knob held at its nominal value (the others
and the named effects re-fitted) against the model with it free, fitted without the discrepancy term:

- **far**: the nominal value lies outside the knob's 95 % **profile** interval
  (:mod:`imutherm.studies.correlation.profile`: the knob held at each value, everything else re-fitted without
  the discrepancy term, at a residual floor of the noise and the model's stated form error). Issue 58: the
  Jacobian interval of a fit where other knobs or the term take over the knob's work spread to the whole source
  range ([0.02, 0.9] for a cavity emissivity re-tuned to 0.228), so the rule could never fire; the finding's
  ``ci95`` is the profile interval;
- **evidence**: ΔAICc >= :data:`~imutherm.studies.correlation.MARGIN_NONE` for the free knob, and it explains
  at least :data:`~imutherm.studies.correlation.EXPLAIN_MIN_NOISE` noise sigmas of RMS;
- **beyond the model's form**: the misfit it explains is at least ``FORM_SIGMAS`` (2) times the model's stated form
  error, reading by reading in the unit that error is stated in (a fraction of each site's rise, noise in
  quadrature; :func:`beyond_form`), the level within which
  :func:`~imutherm.studies.correlation.form_error.named_through_form` leaves a residue to the model's form. Issue 58's
  campaign (toy, seed 59): with the profile interval, ``k_board_W_mK`` moved by a 2-5 % form error was named a
  finding on 2 of 3 null cases at each level;
- **most of the gap**: the move alone (the nominal model with this knob at its fitted value) takes the RMS at the
  held-out readings at least :data:`GAP_SHARE` of the way from the nominal model's to the final model's, and
  the final model predicts held-out data better than the one with the knob held at nominal (on sparse files,
  without an information criterion, these two alone). The move alone, not the refit with the knob held: held
  at nominal, the other knobs take up part of its work (a cavity emissivity of 0.3 hidden in toy data: the
  refit closes 67 % of the gap by the others, the move alone 97 %).

Each finding is flagged ``contradicts_source`` when its value lies outside its source's range
(:func:`source_range`). A knob that meets the rules **at a bound of the re-tune** is not a finding: the data
push it past what its source allows, which is the model's form speaking (issue 58: a ``power_scale`` "finding"
at its bound took a probe lag's place); it is a :class:`Symptom`, reported with how far the re-tuned model is
off and where (scheme, site, phase; :func:`form_off`). Likewise a form knob (the cavity's emissivity) moved in a
fit that still leaves more than twice the stated form error (:func:`form_visibly_off`, the discrepancy term's
cap): such a knob takes up what it can of a form error it cannot match (issue 58's FEM campaign, seed 61: cavity
emissivity "findings" where a regulator's power was hidden), so it is a symptom (bound 'form') with how far the
model is off and where.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from imutherm.unit import knobs

#: a finding must explain at least this share of the held-out gap between the nominal model and the final one
#: (the blind campaign's reading: "that move explains most of the gap")
GAP_SHARE = 0.5
#: source ranges of the form knobs, where the re-tune's range is wider than the source's: the cavity's pair
#: emissivity is re-tuned over 0.02-0.9 because the inside finish is not stated, but the unit's stated finish
#: (anodised inner walls, solder-masked boards) gives 0.63-0.86 (studies/uncertainty/uncertainty.py: boards 0.80-0.95,
#: anodised walls 0.75-0.90, Incropera Table A.11, widened -> 1/(1/e1 + 1/e2 - 1))
FORM_SOURCE_RANGES = {"cavity_emissivity": (0.63, 0.86, "anodised inner walls 0.75-0.90 and solder-masked boards "
                                                         "0.80-0.95 (Incropera Table A.11, widened): pair 0.63-0.86")}


@dataclass(frozen=True)
class Finding:
    """A re-tuned parameter that moved far from its nominal value and explains most of the gap.

    parameter : knob name, unit : its unit; value : fitted [unit], ci95 : (lo, hi) [unit], nominal [unit]
    source_range : (lo, hi) [unit] and source : its words; contradicts_source : outside that range or at a bound
    at_bound : at a bound of the re-tune; delta_criterion : ΔAICc of freeing it [-] (NaN on sparse files)
    explained_K : RMS it explains [K]; heldout_fixed_K / heldout_free_K : held-out RMS held at nominal / free [K]
    gap_share : share of the nominal-to-final held-out gap it explains [-]
    """

    parameter: str
    unit: str
    value: float
    ci95: tuple
    nominal: float
    source_range: tuple
    source: str
    contradicts_source: bool
    at_bound: bool
    delta_criterion: float
    explained_K: float
    heldout_fixed_K: float
    heldout_free_K: float
    gap_share: float
    #: the profile interval's ends that the data do not close (at the re-tune's range): (lo, hi)
    open_ends: tuple = (False, False)
    #: the residual level σ [K] of the profile (the fit's, not below the noise and the stated form error)
    sigma_K: float = math.nan

    def words(self) -> str:
        """The finding in one line."""
        lo, hi = self.ci95
        flag = (" — outside its source's range " + f"{self.source_range[0]:.3g}-{self.source_range[1]:.3g}"
                + (", at a bound of the re-tune" if self.at_bound else "") + ": contradicts its source"
                if self.contradicts_source else "")
        u = "" if self.unit == "-" else f" {self.unit}"
        return (f"{self.parameter} = {self.value:.3g}{u} (95 %: {lo:.3g}-{hi:.3g}), nominal "
                f"{self.nominal:.3g}{flag}; explains {100 * self.gap_share:.0f} % of the held-out gap")

    def as_dict(self) -> dict:
        """For ``correlation.json``."""
        return {"parameter": self.parameter, "unit": self.unit, "value": self.value, "ci95": list(self.ci95),
                "nominal": self.nominal, "source_range": list(self.source_range), "source": self.source,
                "contradicts_source": self.contradicts_source, "at_bound": self.at_bound,
                "delta_criterion": self.delta_criterion, "explained_K": self.explained_K,
                "heldout_rms_fixed_K": self.heldout_fixed_K, "heldout_rms_K": self.heldout_free_K,
                "gap_share": self.gap_share, "ci95_from": "profile", "ci95_open": list(self.open_ends),
                "profile_sigma_K": self.sigma_K, "in_words": self.words()}


def source_range(name: str) -> tuple:
    """(lo, hi, words) of knob ``name``'s source: the re-tune's range for :data:`~imutherm.unit.knobs.RETUNE`
    (each is its source's), :data:`FORM_SOURCE_RANGES` for a form knob."""
    if name in FORM_SOURCE_RANGES:
        return FORM_SOURCE_RANGES[name]
    k = next((k for k, _ in knobs.RETUNE if k.name == name), None)
    if k is None:
        return (math.nan, math.nan, "")
    return (k.lo, k.hi, knobs.RETUNE_SOURCES[name])


def _unit(name: str) -> str:
    k = next((k for k, _ in knobs.RETUNE if k.name == name), None)
    if k is not None:
        return k.unit
    from imutherm.unit.effects import effect_of
    return effect_of(name).params[0].unit


def findings(fwd, free, full: dict, folds, ratio: float, noise: float, test: dict, band_K: float = math.nan) -> tuple:
    """The :class:`Finding` s of ``free`` (the final model's physics: re-tune and named effects, fitted without
    the discrepancy term, its held-out figures pooled), largest gap share first (see the module docstring);
    ``test``: the held-out readings (run index -> bool (n, m)). :func:`explain_knobs` with its symptoms dropped."""
    return explain_knobs(fwd, free, full, folds, ratio, noise, test, band_K)[0]


def explain_knobs(fwd, free, full: dict, folds, ratio: float, noise: float, test: dict,
                  band_K: float = math.nan) -> tuple:
    """(findings, symptoms) of ``free``: each re-tuned knob whose nominal value lies outside its profile interval
    (:func:`imutherm.studies.correlation.profile.profile_interval` at the residual floor
    :func:`~imutherm.studies.correlation.profile.residual_floor_K2` of the noise and ``band_K``, the model's
    stated form error at the readings [K]) and that meets the evidence and gap-share rules is a :class:`Finding`
    with that interval, unless it ended at a bound of the re-tune: then it is a :class:`Symptom` of the model's
    form (:func:`symptom`), never a finding."""
    from imutherm.studies.correlation.fit import fit_candidate
    from imutherm.studies.correlation.forward_model import FORM_IN_DOUBT
    from imutherm.studies.correlation.holdout import with_heldout, pooled_heldout
    from imutherm.studies.correlation.profile import CHI2_95, profile_interval, residual_floor_K2
    from imutherm.studies.correlation.verdict import EXPLAIN_MIN_NOISE, MARGIN_NONE
    from imutherm.studies.correlation.written_model import heldout_rms

    out, sym = [], []
    h_nom = heldout_rms(fwd, fwd.nominal, test)
    gap = h_nom - heldout_rms(fwd, free.values, test)
    sigma2 = residual_floor_K2(free.cost_K2, free.n, free.k, noise, band_K)
    for name, v in free.values.items():
        if name in free.effects or name not in fwd.nominal or name in FORM_IN_DOUBT:
            continue  # the cavity law's blend is the model's form as a weight (discrepancy section), not a finding
        nom = float(fwd.nominal[name])
        fixed = fit_candidate(fwd, free.effects, full, None, ratio, noise, None, free.values, fixed={name: nom})
        d_nom = ratio * (fixed.cost_K2 - free.cost_K2) / sigma2
        if not d_nom > CHI2_95:  # the nominal lies within the profile interval: not far
            continue
        fixed = with_heldout(fixed, pooled_heldout(fwd, free.effects, folds, ratio, noise, None, free.values,
                                                   {name: nom}))
        dC = fixed.aicc - free.aicc
        expl = math.sqrt(max(fixed.rms_K**2 - free.rms_K**2, 0.0))
        h0, h1 = fixed.heldout_rms_K, free.heldout_rms_K
        alone = heldout_rms(fwd, {**fwd.nominal, name: v}, test)
        share = (h_nom - alone) / gap if math.isfinite(gap) and gap > 0 and math.isfinite(alone) else math.nan
        evidence = (not math.isfinite(dC)) or (dC >= MARGIN_NONE and expl >= EXPLAIN_MIN_NOISE * noise)
        if name in free.at_bound:
            if evidence:
                sym.append(symptom(fwd, free, name, nom, float(dC)))
            continue
        if name in knobs.FORM_RETUNE and evidence and form_visibly_off(free, noise, band_K):
            sym.append(symptom(fwd, free, name, nom, float(dC), "form", band_K))
            continue
        if not (evidence and math.isfinite(share) and share >= GAP_SHARE and not h1 >= h0
                and beyond_form(fwd, fixed.values, free.values, full, noise, band_K)):
            continue
        k = knob_of(fwd, name)

        def cost(x, name=name):
            return fit_candidate(fwd, free.effects, full, None, ratio, noise, None, free.values,
                                 fixed={name: x}).cost_K2
        prof = profile_interval(cost, float(np.clip(v, k.lo, k.hi)), k.lo, k.hi, sigma2, ratio, log=k.log)
        lo, hi = prof["ci95"]
        s_lo, s_hi, words = source_range(name)
        outside = bool(np.isfinite(s_lo) and not (s_lo <= v <= s_hi))
        out.append(Finding(name, _unit(name), float(v), (float(lo), float(hi)), nom, (s_lo, s_hi), words,
                           outside, False, float(dC), float(expl), float(h0), float(h1),
                           float(min(share, 1.0)), prof["open"], math.sqrt(sigma2)))
    return tuple(sorted(out, key=lambda f: -f.gap_share)), tuple(sym)


def beyond_form(fwd, held: dict, free: dict, full: dict, noise: float, band_K: float) -> bool:
    """Whether what a knob explains (the model ``held`` at its nominal value, the others re-fitted, against ``free``)
    is beyond what the model's stated form error could make: at least
    :data:`~imutherm.studies.correlation.form_error.FORM_SIGMAS` times that error, **reading by reading in the unit it
    is stated in** (a fraction of each site's rise in each scheme, the noise in quadrature;
    :func:`~imutherm.studies.correlation.form_error.explained_in_form_units` >= 1). A form error of a given size can
    move a knob only as far as the misfit it takes; stated as a fraction of the rise, it is small where the rise is
    small, and the RMS pooled in kelvins lent the air's large allowance to the grease readings, where a mount
    conductance does most of its work (issue 58, FEM seed 63: a mount at 0.43x explained 2.4x the stated error in
    grease, 1.7x it pooled, and was no finding on any form). ``band_K`` NaN (no stated form error): True."""
    from imutherm.studies.correlation import form_error
    if not math.isfinite(band_K):
        return True
    scale = form_error.form_scale(r.scheme for r in fwd.runs)
    return not form_error.explained_in_form_units(fwd, scale, held, free, full, noise) < 1.0


def form_visibly_off(free, noise: float, band: float) -> bool:
    """Whether the re-tuned physics ``free`` leaves a residual (its RMS [K], the noise ``noise`` [K] removed in
    quadrature) above :data:`~imutherm.studies.correlation.form_error.FORM_SIGMAS` times ``band`` [K], the model's
    stated form error at the readings: the level a model right in every effect and knob still leaves (the
    discrepancy term's cap). A form knob (:data:`~imutherm.unit.knobs.FORM_RETUNE`) re-tuned in such a fit has
    taken up what it can of a form error it cannot match, and its move is not a finding (issue 58, FEM campaign
    seed 61: a cavity emissivity "finding" where a regulator's power was hidden on a grid 2x finer at 10 %)."""
    from imutherm.studies.correlation.form_error import FORM_SIGMAS
    if not (math.isfinite(band) and math.isfinite(free.rms_K)):
        return False
    return math.sqrt(max(free.rms_K**2 - noise**2, 0.0)) > FORM_SIGMAS * band


def knob_of(fwd, name: str):
    """The re-tune's :class:`~imutherm.thermal.reduced.Knob` ``name`` (a form knob's from the reduced models)."""
    k = next((k for k, _ in knobs.RETUNE if k.name == name), None)
    if k is not None:
        return k
    return next(iter(fwd.roms.values())).knobs[name]


@dataclass(frozen=True)
class Symptom:
    """A re-tuned knob that moved while the model's form speaks: a symptom of the model's form, not a finding.
    ``bound``: 'lower' / 'upper' (it ended at that bound of its source's range while the data pull it there) or
    'form' (a form knob moved in a fit whose residual is above twice the stated form error,
    :func:`form_visibly_off`; ``form_band_K`` that stated error at the readings [K]). ``form_off``: how far the
    re-tuned physics is off and where ({'rms_K', 'fraction_of_rise', 'where': [{'scheme', 'site', 'phase',
    'rms_K', 'mean_K'}], largest first})."""

    parameter: str
    unit: str
    value: float
    bound: str
    nominal: float
    delta_criterion: float
    form_off: dict
    form_band_K: float = math.nan

    def words(self) -> str:
        u = "" if self.unit == "-" else f" {self.unit}"
        fo = self.form_off
        where = ", ".join(f"{w['scheme']} {w['site']} {w['phase']} ({w['mean_K']:+.2f} K)" for w in fo["where"][:3])
        off = (f"the re-tuned model is off by {fo['rms_K']:.2f} K RMS ({100 * fo['fraction_of_rise']:.1f} % of the "
               f"rise), most at {where}")
        if self.bound == "form":
            return (f"{self.parameter} re-tuned to {self.value:.3g}{u} (nominal {self.nominal:.3g}) is not a finding: "
                    f"{off}, above twice the model's stated form error ({self.form_band_K:.2f} K): the model's form is "
                    f"off there, and a form knob takes up what it can of it")
        return (f"{self.parameter} ends at its {self.bound} bound {self.value:.3g}{u} (nominal {self.nominal:.3g}): "
                f"a symptom of the model's form, not a finding; {off}")

    def as_dict(self) -> dict:
        return {"parameter": self.parameter, "unit": self.unit, "value": self.value, "bound": self.bound,
                "nominal": self.nominal, "delta_criterion": self.delta_criterion, "form_off": self.form_off,
                "form_band_K": self.form_band_K, "in_words": self.words()}


def form_off(fwd, values: dict) -> dict:
    """How far the model at ``values`` is off the measured rises and where: RMS [K], as a fraction of the RMS rise,
    and the (scheme, site, phase) series by RMS residual, largest first (phase: 'rise' before the site's t63,
    'plateau' after it)."""
    where, res, rise = [], [], []
    for i, run in enumerate(fwd.runs):
        y = fwd.rise(i, values)
        r = y - run.rise_K
        t = run.times_s
        for j, s in enumerate(run.sites):
            ok = np.isfinite(r[:, j])
            if not ok.any():
                continue
            res.append(r[ok, j])
            rise.append(run.rise_K[ok, j])
            fin = y[np.isfinite(t), j]
            t63 = float(np.interp(0.632 * fin[-1], fin, t[np.isfinite(t)])) if len(fin) and fin[-1] > 0 else np.inf
            for phase, sel in (("rise", t <= t63), ("plateau", t > t63)):
                x = r[sel & ok, j]
                if len(x):
                    where.append({"scheme": run.scheme, "site": s, "phase": phase, "file": run.path,
                                  "rms_K": float(np.sqrt(np.mean(x**2))), "mean_K": float(x.mean())})
    e, y = np.concatenate(res), np.concatenate(rise)
    rms = float(np.sqrt(np.mean(e**2)))
    return {"rms_K": rms, "fraction_of_rise": rms / max(float(np.sqrt(np.mean(y**2))), 1e-12),
            "where": sorted(where, key=lambda w: -w["rms_K"])[:6]}


def symptom(fwd, free, name: str, nominal: float, dC: float, why: str = "bound", band: float = math.nan) -> Symptom:
    """The :class:`Symptom` of knob ``name`` of ``free``: at a bound (``why`` 'bound') or moved in a fit whose
    form is visibly off (``why`` 'form', ``band`` the stated form error [K])."""
    k = knob_of(fwd, name)
    v = float(free.values[name])
    bound = "form" if why == "form" else ("lower" if abs(v - k.lo) <= abs(v - k.hi) else "upper")
    return Symptom(name, _unit(name), v, bound, nominal, dC, form_off(fwd, free.values), band)
