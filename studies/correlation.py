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
   they act (leave the term there within 2 noise sigmas or halve it; :func:`explains_term`); when no effect qualifies and the data support the term, the verdict is ``discrepancy`` (the
   model's form is off, by so much, where, not explained by any library effect). Where the library names
   nothing and the re-tune already predicts held-out data within the noise standard, the term is still
   fitted on the re-tuned model: ``none`` only if the data do not support it. On sparse files the term cannot
   be fitted; the cavity law's form is reported as a prior band at each reading instead (:func:`form_band`).
   **Through the model's own error** (issue 43): the term's prior scale is capped at twice the model's known
   form error (:mod:`imutherm.studies.form_error`: the grid's and the reduced model's, per scheme), library
   effects that take the re-tuned model's held-out error from far beyond that level to within it are named
   without the term (:func:`imutherm.studies.form_error.named_through_form`), and on the term's path a further
   effect must halve the term the effects before it leave. A re-tuned parameter that moved far and explains
   most of the gap is named as a finding (:mod:`imutherm.studies.findings`; verdict ``finding`` when no library
   effect is named); the model written is never worse than the nominal one on held-out data without the term
   (:mod:`imutherm.studies.written_model`); implausible readings are refused before any fit
   (:mod:`imutherm.studies.plausibility`).
6. **Re-run**: the corrected model on the full model (:func:`rerun_full`) for the "after" figures: its full
   steady solve and its transient on the study's checked reduced model (the full adaptive FEM where the check
   fails, or with ``rerun_transient='full'``).

Forward runs use the reduced model of each (scheme, ambient) (:mod:`imutherm.thermal.reduced`),
built once per correlation.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import least_squares, minimize_scalar
from threadpoolctl import threadpool_limits

from imutherm import InputError
from imutherm.geometry.build import MM, build_geometry
from imutherm.geometry.layout import LayoutSpec, load_layout
from imutherm.geometry.mesh import DEFAULT_MAX_CELL_MM, DEFAULT_MIN_CELLS, build_mesh
from imutherm.measured import MeasuredRun
from imutherm.unit import knobs as K
from imutherm.unit.effects import EFFECTS, apply_signal_effects, effect_of, setting
from imutherm.studies import form_error as FE
from imutherm.unit.model import ModelOptions
from imutherm.thermal.reduced import Knob, build_reduced
from imutherm.studies.findings import findings as findings_of
from imutherm.studies.plausibility import check_plausible
from imutherm.studies.written_model import choose as choose_written

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
#: noise assumed for sparse series (fewer than 8 points) where it cannot be estimated [K]
SPARSE_NOISE_K = 0.5
#: signal effects handled outside the reduced model
SIGNAL = ("probe_lag", "ambient_drift")
#: the form knobs: re-tuned, never named (:data:`imutherm.unit.knobs.FORM_RETUNE`), and each one's value at
#: which the model is nominal (geometry, options) -> value
FORM_RETUNE = K.FORM_RETUNE
#: the form knobs opened where the model's form is in doubt (with the discrepancy term,
#: :data:`imutherm.unit.knobs.FORM_IN_DOUBT`): re-tuned then, never candidates
FORM_IN_DOUBT = K.FORM_IN_DOUBT
FORM_KNOBS = {**FORM_RETUNE, **FORM_IN_DOUBT}
_FORM_NOMINAL = {"cavity_emissivity": K.cavity_pair_nominal,
                 "cavity_law_blend": lambda geometry, options: float(options.cavity_law_blend)}
#: the times at which the model curve is evaluated for a probe lag (plus the measured ones) [s]
_DENSE = np.concatenate([[0.0], np.geomspace(0.5, 2.0e4, 240)])


@dataclass(frozen=True)
class Fit:
    """One fitted model: ``name`` ('none' or an effect), parameter values, training and held-out scores.

    values : dict knob -> value [unit] (re-tune knobs and the effect's parameter)
    rms_K : training RMS [K], n : points, n_eff : effective sample size, k : fitted parameters
    aicc : float, heldout_rms_K : float [K] (NaN if no hold-out), heldout_max_K : float [K]
    at_bound : tuple of knob names that ended at a bound
    """

    name: str
    values: dict
    rms_K: float
    max_K: float
    n: int
    n_eff: float
    k: int
    aicc: float
    heldout_rms_K: float
    heldout_max_K: float
    at_bound: tuple = ()
    ci: dict = field(default_factory=dict)
    #: the library effects of this fit, in the order they were added ('none': ())
    effects: tuple = ()
    #: the discrepancy term's coefficients (run index, site index) -> (2,) [-] (fractions of the site's rise),
    #: empty without it
    disc: dict = field(default_factory=dict)
    #: RMS change [K] the last-added effect makes at the readings (with it against without it, the other
    #: values as fitted); NaN for 'none'
    signature_K: float = math.nan
    #: 'aicc' or 'evidence' (with the discrepancy term: -2 log evidence up to a constant, see Discrepancy)
    criterion: str = "aicc"
    #: the fit's objective [K^2]: data residual, the knobs' prior and the discrepancy's prior terms
    cost_K2: float = math.nan
    #: with the discrepancy term: its prior scale [-] (fraction of each site's rise) estimated for this fit by
    #: type-II maximum likelihood (:meth:`Discrepancy.profile`); NaN without the term
    disc_prior: float = math.nan
    #: with the discrepancy term: the RMS [K] of the correction it makes over the fitted data; NaN without it
    disc_rms_K: float = math.nan
    #: with the discrepancy term: its prior scale per scheme (scheme -> [-]); ``disc_prior`` is the largest
    disc_priors: dict = field(default_factory=dict)
    #: with the discrepancy term: ``disc_rms_K`` per scheme (scheme -> [K])
    disc_rms_by: dict = field(default_factory=dict)
    #: ``signature_K`` per scheme (scheme -> [K]): where the last-added effect acts
    signature_by: dict = field(default_factory=dict)
    #: the held-out squared errors per series: ((fold, run index, site index), sum of squares [K^2], readings)
    heldout_blocks: tuple = ()


@dataclass(frozen=True)
class CorrelationResult:
    """What ``correlate`` found.

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
    #: re-tuned parameters that moved far and explain most of the gap (:mod:`imutherm.studies.findings`), first
    #: the largest share
    findings: tuple = ()
    #: which model ``updated_model.toml`` carries and why (:mod:`imutherm.studies.written_model`)
    written: dict | None = None
    #: the model's known form error (:mod:`imutherm.studies.form_error`): the term's cap, the band of the rules
    form_scale: dict | None = None
    #: the corrected model's physics alone: its effects and the re-tune fitted without the discrepancy term, with
    #: pooled held-out figures (``after`` itself where no term was fitted); its intervals are the findings'
    physics: Fit | None = None


# --------------------------------------------------------------------------- forward model

class _Forward:
    """Site rises of every run from knob values, through the runs' reduced models."""

    def __init__(self, runs, roms, geometries, options: ModelOptions | None = None, form=tuple(FORM_RETUNE)):
        self.runs, self.roms, self.geometries, self.options = runs, roms, geometries, options or ModelOptions()
        geo = next(iter(geometries.values())) if geometries else None
        #: the re-tune knobs' nominal values, from the layout and materials (every scheme shares them)
        self.nominal = K.nominal_values(geo, self.options) if geo is not None else {}
        #: the form knobs of ``form`` (:data:`FORM_RETUNE`) the reduced models carry, re-tuned beside the others
        self.form = tuple(n for n in form if roms and all(n in rom.knobs for rom in roms.values()))
        for n in self.form:
            self.nominal[n] = _FORM_NOMINAL[n](geo, self.options)

    def rise(self, i: int, values: dict, times=None) -> np.ndarray:
        """Model rise [K] of run ``i`` at its times (or ``times``), its sites (n, m)."""
        run = self.runs[i]
        rom = self.roms[(run.scheme, run.ambient_C)]
        t = run.times_s if times is None else np.asarray(times, float)
        model_vals = {k: v for k, v in values.items() if k.split("@")[0] not in SIGNAL and k in rom.knobs}
        model_vals["power_scale"] = values.get("power_scale", 1.0) * run.power_scale
        effects = [setting(k, **{effect_of(k).params[0].name: v}) for k, v in values.items()
                   if k.split("@")[0] in SIGNAL]
        cols = [rom.site_names.index(s) for s in run.sites]
        drift = next((s.value("rate_K_per_h") / 3600 for s in effects if s.base == "ambient_drift"), 0.0)
        lag = next((s.value("tau_s") for s in effects if s.base == "probe_lag"), None)
        if lag is None:
            return rom.rise(model_vals, t, drift)[:, cols]
        fin = np.isfinite(t)
        dense = np.union1d(_DENSE[_DENSE <= (t[fin].max() if fin.any() else 0.0)], t[fin])
        y = rom.rise(model_vals, dense, drift)[:, cols]
        y = apply_signal_effects(dense, y, [s for s in effects if s.base == "probe_lag"])
        out = np.empty((len(t), len(cols)))
        for j in range(len(cols)):
            out[fin, j] = np.interp(t[fin], dense, y[:, j])
        if (~fin).any():
            out[~fin] = rom.rise(model_vals, [np.inf])[:, cols]
        return out


def _residuals(fwd: _Forward, values: dict, mask: dict) -> np.ndarray:
    """Model minus measured rise [K] over the selected points (mask: run index -> bool (n, m))."""
    out = []
    for i, m in mask.items():
        if not m.any():
            continue
        r = fwd.rise(i, values) - fwd.runs[i].rise_K
        out.append(r[m])
    return np.concatenate(out) if out else np.zeros(0)


#: starting value of the discrepancy's prior scale [-] (fraction of each site's nominal rise), before the data
#: estimate it (:meth:`Discrepancy.profile`, type-II maximum likelihood per fit). From physics: two independent
#: models of one unit differ by 12-20 % of the rise before any effect (the cavity-radiation law and the grid)
#: and the paper's own FEM was 20 % under its measurement, but the re-tune takes the common part: what that
#: campaign's re-tune left was 2-12 % per site and scheme, so a typical form error of 5 %. A fixed 5 % (before)
#: let the term take real effects on data of the model's own form (a 0.35 W regulator error came out
#: ambiguous), since its Occam factor cancelled between the models it was shared by; estimated per fit, a
#: model whose effect explains the data needs no term (its scale goes to ~0) and pays no Occam factor.
DISCREPANCY_PRIOR = 0.05
#: the range [-] of the type-II maximum-likelihood search of the prior scale: from effectively off (its
#: Occam factor ~0) to half of each site's rise
DISCREPANCY_PRIOR_RANGE = (1e-6, 0.5)


@dataclass(frozen=True)
class Discrepancy:
    """The model's own error as a term of the fit (model discrepancy, Kennedy & O'Hagan 2001).

    Per measured series (run i, site j) a smooth correction of the model's rise, d_ij(t) = Φ_ij(t) c_ij with
    two basis functions of the site's *nominal normalised response* s(t) = θ_nom(t) / θ_nom(∞), scaled
    with its nominal rise ΔT = θ_nom(∞):  ΔT s(t) (a gain error: a wrong conductance path or power share
    scales the whole curve) and ΔT 4 s (1 - s) (a time-constant error: a wrong heat capacity or coupling
    moves the curve mid-rise and vanishes at power-on and on the plateau). It cannot follow anything
    faster than the model's own response (a chamber cycle, a step part way) and it is zero at power-on.
    Prior: each coefficient of a run of scheme g ~ N(0, p_g²), one scale **per cooling scheme**: the model's
    form error is a property of the scheme's heat paths (the independent model of issue 22 ran 12-20 %
    warmer in air and grease, within a few % potted), so a scheme the model gets right keeps a tight term
    that an effect acting there must explain, whatever the form error of another scheme. Given the knobs,
    the coefficients are the posterior mean (a ridge fit, closed form per series), so the data update the
    prior. The fit's objective adds λ_g |c|², λ_g = (n / n_eff) σ² / p_g² [K²] (σ: the residual level,
    ``sigma_K``), so that (n_eff / n) J / σ² is -2 log of the posterior density up to a constant and
    comparisons of models that share the term are comparisons of their evidence.

    basis : dict (i, j) -> (n_i, 2) [K] at run i's times; prior: p [-] for every scheme, or dict scheme -> p;
    sigma_K [K]; ratio n_eff / n [-]; groups : tuple, run i -> its scheme (the prior's group)
    """

    basis: dict
    prior: float | dict
    sigma_K: float
    ratio: float
    groups: tuple = ()
    #: scheme -> the largest prior scale [-] the type-II search may reach: the model's known form error
    #: (:meth:`imutherm.studies.form_error.FormScale.cap`); empty: :data:`DISCREPANCY_PRIOR_RANGE` alone
    caps: dict = field(default_factory=dict)

    def group(self, i: int) -> str:
        """The prior's group (the scheme) of run ``i``."""
        return self.groups[i] if self.groups else ""

    def prior_of(self, i: int) -> float:
        """Prior scale p [-] of run ``i``'s coefficients."""
        p = self.prior
        return float(p.get(self.group(i), max(p.values()))) if isinstance(p, dict) else float(p)

    def lam_of(self, i: int) -> float:
        """Ridge weight λ [K²] of run ``i``'s coefficients."""
        return self.sigma_K**2 / max(self.ratio, 1e-6) / self.prior_of(i)**2

    @property
    def lam(self) -> float:
        """Ridge weight λ [K²] (of the largest scale, with one per scheme)."""
        p = max(self.prior.values()) if isinstance(self.prior, dict) else self.prior
        return self.sigma_K**2 / max(self.ratio, 1e-6) / float(p)**2

    @property
    def priors(self) -> dict:
        """scheme -> p [-] of every group."""
        keys = sorted(set(self.groups)) or [""]
        return {g: (float(self.prior.get(g, max(self.prior.values()))) if isinstance(self.prior, dict)
                    else float(self.prior)) for g in keys}

    def coefficients(self, r: np.ndarray, i: int, j: int, rows: np.ndarray) -> np.ndarray:
        """Posterior mean of c_ij [-] from the residual r (model - measured) [K] at ``rows`` of run i."""
        F = self.basis[(i, j)][rows]
        return np.linalg.solve(F.T @ F + self.lam_of(i) * np.eye(F.shape[1]), F.T @ r[rows])

    def with_prior(self, prior) -> "Discrepancy":
        """The same term at another prior scale [-] (a float: every scheme; a dict scheme -> p)."""
        return replace(self, prior=dict(prior) if isinstance(prior, dict) else float(prior))

    def profile(self, fwd: "_Forward", values: dict, mask: dict) -> tuple:
        """(p, C): the prior scales p (dict scheme -> [-]) that maximise the evidence of the residual at
        ``values`` over ``mask`` (type-II maximum likelihood, each scheme's searched over
        :data:`DISCREPANCY_PRIOR_RANGE`; the evidence is a sum over the schemes, so each is found apart), and
        C(p) = (n_eff / n) Σ min_c (|r - Φc|² + λ|c|²) / σ² + Σ log det(I + ΦᵀΦ / λ), λ = σ² n / (n_eff p²),
        -2 log of the evidence up to a constant (the data term with the coefficients integrated out).
        Closed form per series from the eigen-decomposition of ΦᵀΦ (2 x 2), so the search is cheap."""
        per = {}
        for i, j, rows, r in _series(fwd, values, mask):
            F, x = self.basis[(i, j)][rows], r[rows]
            w, Q = np.linalg.eigh(F.T @ F)
            acc = per.setdefault(self.group(i), [0.0, [], []])
            acc[0] += float(x @ x)
            acc[1].append(np.maximum(w, 0.0))
            acc[2].append((Q.T @ (F.T @ x)) ** 2)
        if not per:
            return self.priors, 0.0
        s2 = self.sigma_K**2 / max(self.ratio, 1e-6)  # the white residual's variance per reading [K²]
        lo, hi = (math.log10(x) for x in DISCREPANCY_PRIOR_RANGE)
        out, total = dict(self.priors), 0.0
        for g, (rr, lam_g, proj) in per.items():
            ev, b = np.concatenate(lam_g), np.concatenate(proj)
            grid = np.linspace(lo, min(hi, math.log10(self.caps[g])), 57) if g in self.caps else np.linspace(lo, hi, 57)

            def C(logp, ev=ev, b=b, rr=rr):
                lam = s2 / (10.0 ** (2 * logp))
                return (rr - float(np.sum(b / (ev + lam)))) / s2 + float(np.sum(np.log1p(ev / lam)))

            vals = np.array([C(x) for x in grid])
            k = int(np.argmin(vals))
            a, b_ = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
            best = minimize_scalar(C, bounds=(a, b_), method="bounded", options={"xatol": 1e-3}) if b_ > a else None
            x = float(best.x) if best is not None and best.fun < vals[k] else float(grid[k])
            out[g] = 10.0**x
            total += float(min(C(x), vals[k]))
        return out, total

    def occam(self, mask: dict) -> float:
        """Σ log det(I + Φᵀ Φ / λ) over the series with data in ``mask``: the term's own cost in -2 log evidence."""
        out = 0.0
        for (i, j), F in self.basis.items():
            rows = mask[i][:, j] if i in mask else None
            if rows is None or not rows.any():
                continue
            out += float(np.linalg.slogdet(np.eye(F.shape[1]) + F[rows].T @ F[rows] / self.lam_of(i))[1])
        return out


def build_discrepancy(fwd: _Forward, values: dict, sigma_K: float, ratio: float,
                      prior: float = DISCREPANCY_PRIOR, caps: dict | None = None) -> Discrepancy:
    """The :class:`Discrepancy` basis of every series from the model at ``values`` (the nominal one); ``caps``:
    scheme -> the prior scale's largest value [-] (the model's known form error), the start prior within it."""
    basis = {}
    for i, run in enumerate(fwd.runs):
        y = fwd.rise(i, values)
        y_inf = fwd.rise(i, values, [np.inf])[0]
        for j in range(len(run.sites)):
            dT = float(y_inf[j])
            s = np.clip(y[:, j] / dT, 0.0, 1.0) if dT > 0 else np.zeros(len(y))
            basis[(i, j)] = dT * np.column_stack([s, 4 * s * (1 - s)])
    caps = dict(caps or {})
    groups = tuple(r.scheme for r in fwd.runs)
    if caps:
        prior = {g: min(float(prior), caps.get(g, float(prior))) for g in sorted(set(groups))}
    return Discrepancy(basis, prior, float(sigma_K), float(ratio), groups, caps)


def _series(fwd: _Forward, values: dict, mask: dict):
    """(run i, site j, rows of run i with data in ``mask``, residual model - measured [K] of site j at every
    reading of run i) for every series with data."""
    for i, m in mask.items():
        if not m.any():
            continue
        r = fwd.rise(i, values) - fwd.runs[i].rise_K
        for j in range(r.shape[1]):
            if m[:, j].any():
                yield i, j, m[:, j], r[:, j]


def _residuals_disc(fwd: _Forward, values: dict, mask: dict, disc: Discrepancy | None, coefs=None):
    """(residual after the discrepancy [K] over ``mask``, its prior term sqrt(λ) c [K], coefficients).

    ``coefs`` None: the coefficients are fitted here (posterior mean on ``mask``); else taken as given
    (a held-out prediction with the training fit's)."""
    if disc is None:
        return _residuals(fwd, values, mask), np.zeros(0), {}
    out, pen, cs = [], [], {}
    for i, j, rows, r in _series(fwd, values, mask):
        c = disc.coefficients(r, i, j, rows) if coefs is None else coefs.get((i, j), np.zeros(2))
        cs[(i, j)] = c
        out.append(r[rows] - disc.basis[(i, j)][rows] @ c)
        pen.append(math.sqrt(disc.lam_of(i)) * c)
    return (np.concatenate(out) if out else np.zeros(0)), (np.concatenate(pen) if pen else np.zeros(0)), cs


def _effects_of(name) -> tuple:
    """'none' -> (); 'a' -> ('a',); 'a+b' or ('a', 'b') -> ('a', 'b')."""
    if isinstance(name, (tuple, list)):
        return tuple(name)
    return () if name == "none" else tuple(name.split("+"))


def _label(effects: tuple) -> str:
    return "+".join(effects) if effects else "none"


def _knobs_for(name, fwd: _Forward) -> list:
    """Re-tune knobs (with the form knobs, :data:`FORM_RETUNE`) plus the candidate's (none: re-tune only); an
    emissivity effect replaces the re-tune's, a form knob given as a candidate leaves the re-tune;
    a ``power@part`` candidate cannot take the part below zero power (:func:`~imutherm.unit.knobs.power_floor_W`).
    ``name``: one effect, 'none', or several ('a+b' or a tuple: one knob each, in that order)."""
    ks = [k for k, _ in K.RETUNE] + [K.effect_knob(n, fwd.options) for n in fwd.form]
    effects = _effects_of(name)
    if "emissivity" in effects:
        ks = [k for k in ks if k.name != "emissivity_ext"]
    ks = [k for k in ks if k.name not in effects]
    for n in effects:
        e = effect_of(n)
        p = e.params[0]
        if e.kind == "signal":
            ks.append(Knob(n, p.unit, p.lo, p.hi, log=p.log))
            continue
        floor = (K.power_floor_W(fwd.geometries.values(), n, [r.power_scale for r in fwd.runs])
                 if e.name == "power" else None)
        ks.append(K.effect_knob(n, fwd.options, min_power_W=floor))
    return ks


def _fit(fwd: _Forward, name, train: dict, test: dict | None, n_eff_ratio: float, prior_K: float,
         disc: Discrepancy | None = None, start: dict | None = None, hint: dict | None = None,
         fixed: dict | None = None) -> Fit:
    """Bounded fit of the re-tune knobs plus candidate(s) ``name`` on ``train``; scored on ``test``.

    The re-tune knobs carry a weak prior towards their nominal values: a residual ``prior_K`` (u - u0)
    per knob (u in [-1, 1] across the source's range), so a knob at its bound costs one noise
    sigma squared. It decides only where the data do not (sparse files); the effects' own parameters
    have none (uniform within their bounds). ``name``: 'none', one effect or several ('a+b'): the last
    one is started from three points of its range, the others (and the re-tune) from ``start`` (the
    previous forward-selection step's values) where given. ``disc``: the model's discrepancy term
    (:class:`Discrepancy`), its coefficients fitted with the knobs (their posterior mean given the knobs),
    held-out data predicted with the training fit's coefficients; the criterion is then the evidence
    form (n_eff / n) J / σ² + 2k (AICc's small-sample term kept) instead of AICc; ``hint``: the same
    effects' values fitted without the term, a further start (the better evidence of the two is kept).
    ``fixed``: re-tune knobs held at the given values (not fitted; :mod:`imutherm.studies.findings`).
    """
    effects = _effects_of(name)
    fixed = dict(fixed or {})
    ks = [k for k in _knobs_for(effects, fwd) if k.name not in fixed]
    # start at the nominal (re-tune) / mid-range (effect) in the knob coordinate u in [-1, 1]
    u0 = np.array([float(k.to_u(K.RETUNE_NOMINAL[k.name])) if k.name in K.RETUNE_NOMINAL else 0.0 for k in ks])
    base = fwd.nominal
    for k in ks:
        if k.name in base:
            u0[ks.index(k)] = float(np.clip(k.to_u(base[k.name]), -1, 1))
    n_retune = len(ks) - len(effects)
    us = u0.copy()
    for k in ks[n_retune:]:
        if start and k.name in start:
            us[ks.index(k)] = float(np.clip(k.to_u(start[k.name]), -1, 1))
    if start:
        for idx, k in enumerate(ks[:n_retune]):
            if k.name in start:
                us[idx] = float(np.clip(k.to_u(start[k.name]), -1, 1))

    def vals(u):
        return {**fixed, **{k.name: float(k.from_u(x)) for k, x in zip(ks, u)}}

    def fun(u, d):
        res, pen, _ = _residuals_disc(fwd, vals(u), train, d)
        return np.concatenate([res, prior_K * (u[:n_retune] - u0[:n_retune]), pen])

    def solve(starts, d):
        best = None
        for s in starts:
            try:
                r = least_squares(fun, s, bounds=(-1.0, 1.0), x_scale=1.0, xtol=1e-6, ftol=1e-8, max_nfev=200,
                                  args=(d,))
            except (np.linalg.LinAlgError, ValueError):
                continue
            if best is None or r.cost < best.cost:
                best = r
        if best is None:
            raise InputError(f"correlate: the fit of {_label(effects)!r} failed")
        return best

    starts = [us] if not effects else [np.where(np.arange(len(ks)) == len(ks) - 1, s, us) for s in (-0.6, 0.0, 0.6)]
    best = solve(starts, disc)
    p_hat, C_hat = {}, math.nan
    if disc is not None:
        # the term's prior scales for this fit, by type-II maximum likelihood at the fitted knobs; the knobs
        # re-fitted once at them when one moved by more than 2x (so a model an effect explains fits without a term)
        def refit(r, d):
            p, _ = d.profile(fwd, vals(r.x), train)
            if any(abs(math.log(p[g] / d.priors.get(g, p[g]))) > math.log(2.0) for g in p):
                d = d.with_prior(p)
                r = solve([r.x], d)
            p, C = d.profile(fwd, vals(r.x), train)
            return r, p, C

        def score(r, C):  # -2 log evidence up to the terms every fit of this name shares
            return C + n_eff_ratio * prior_K**2 * float(np.sum((r.x[:n_retune] - u0[:n_retune]) ** 2)) / disc.sigma_K**2

        best, p_hat, C_hat = refit(best, disc)
        if effects and hint:
            # also from the effect's fit without the term (``hint``): at a large common scale the term takes what
            # the effect would explain and the effect's knob does not move from its start (the search stalls)
            uh = us.copy()
            for idx, k in enumerate(ks):
                if k.name in hint:
                    uh[idx] = float(np.clip(k.to_u(hint[k.name]), -1, 1))
            p0, _ = disc.profile(fwd, vals(uh), train)
            alt = refit(solve([uh], disc.with_prior(p0)), disc.with_prior(p0))
            if score(alt[0], alt[2]) < score(best, C_hat):
                best, p_hat, C_hat = alt
        disc = disc.with_prior(p_hat)
    v = vals(best.x)
    res, pen, coefs = _residuals_disc(fwd, v, train, disc)
    n = len(res)
    rss = float(res @ res)
    k_par = len(ks) + 1  # + the noise variance
    ne = min(n * n_eff_ratio, n)
    if disc is None:
        # AICc is defined for n_eff > k + 1; sparse data (a paper's few figures) rank by held-out prediction only
        aicc = (ne * math.log(max(rss / n, 1e-12)) + 2 * k_par + 2 * k_par * (k_par + 1) / (ne - k_par - 1)
                if ne > k_par + 1 else math.nan)
    else:
        # -2 log evidence: the data with the term's coefficients integrated out at its estimated scale (its
        # Occam factor included, so models that need less of the term are preferred), the knobs' prior, 2k
        u_pen = prior_K * (best.x[:n_retune] - u0[:n_retune])
        aicc = (C_hat + n_eff_ratio * float(u_pen @ u_pen) / disc.sigma_K**2 + 2 * k_par
                + 2 * k_par * (k_par + 1) / (ne - k_par - 1) if ne > k_par + 1 else math.nan)
    hr, hm = math.nan, math.nan
    if test is not None and any(m.any() for m in test.values()):
        rt, _, _ = _residuals_disc(fwd, v, test, disc, coefs if disc is not None else None)
        hr, hm = float(np.sqrt(np.mean(rt**2))), float(np.abs(rt).max())
    at_bound = tuple(k.name for k, x in zip(ks, best.x) if abs(x) > 0.995)
    ci = {}
    J_ = best.jac[:n]
    try:
        cov = np.linalg.pinv(J_.T @ J_) * rss / max(n - len(ks), 1) * (n / max(ne, 1.0))
        sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
        for j, (k, x) in enumerate(zip(ks, best.x)):
            lo, hi = float(k.from_u(max(x - 1.96 * sd[j], -1))), float(k.from_u(min(x + 1.96 * sd[j], 1)))
            ci[k.name] = (lo, hi)
    except np.linalg.LinAlgError:
        pass
    def rms_by(parts):  # [(run i, values)] -> RMS [K] over all, and per scheme
        by = {}
        for i, x in parts:
            by.setdefault(fwd.runs[i].scheme, []).append(x)
        every = np.concatenate([x for _, x in parts]) if parts else np.zeros(0)
        return (float(np.sqrt(np.mean(every**2))) if len(every) else math.nan,
                {g: float(np.sqrt(np.mean(np.concatenate(xs) ** 2))) for g, xs in by.items()})

    sig, sig_by = math.nan, {}
    if effects:  # what the last-added effect changes at the readings, the rest as fitted
        rest = {kk: x for kk, x in v.items() if kk != effects[-1]}
        sig, sig_by = rms_by([(i, (fwd.rise(i, v) - fwd.rise(i, rest))[m]) for i, m in train.items() if m.any()])
    d_rms, disc_by = math.nan, {}
    if disc is not None:
        d_rms, disc_by = rms_by([(i, disc.basis[(i, j)][train[i][:, j]] @ c) for (i, j), c in coefs.items()])
        d_rms = 0.0 if not coefs else d_rms
    return Fit(_label(effects), v, float(np.sqrt(rss / n)), float(np.abs(res).max()), n, float(ne), k_par,
               float(aicc), hr, hm, at_bound, ci, effects, coefs, sig, "aicc" if disc is None else "evidence",
               float(best.fun @ best.fun), max(p_hat.values()) if p_hat else math.nan, d_rms, dict(p_hat),
               disc_by, sig_by)


# --------------------------------------------------------------------------- statistics

#: the noise estimate uses the second differences' spectrum above this angular frequency [rad/sample]
#: (where the second difference passes a white noise at >= its own power; a smooth residual lives below)
NOISE_OMEGA_MIN = math.pi / 3


def noise_sigma(run: MeasuredRun) -> float:
    """Probe noise [K] of a run, robust to smooth and periodic residuals (median over its dense series).

    Per series (>= 8 finite readings): the second differences d of the readings (a smooth curve's are
    small; a power-on kink or a step gives a few large ones), their Hann-windowed periodogram divided by
    the second difference's gain |2 - 2 cos ω|² at the frequencies above :data:`NOISE_OMEGA_MIN`, and
    the median of these ordinates over ln 2 (a white noise's normalised ordinates are σ² times an
    exponential variable, whose median is ln 2): a cycle, however it is sampled, is a peak in one or two
    ordinates and moves a median little, where it moved the MAD of the second differences by its whole
    amplitude (the last campaign: a 203 s cycle sampled ~5 times per period counted as noise, 0.10 K
    against 0.05 K). Series with fewer than 8 readings: :data:`SPARSE_NOISE_K` (stated, not estimated).
    The readings are taken as evenly spaced (the estimate is per reading).
    """
    sig = []
    for j in range(len(run.sites)):
        y = run.values_C[:, j]
        t = run.times_s
        ok = np.isfinite(y) & np.isfinite(t)
        if ok.sum() < 8:
            continue
        sig.append(_noise_of_series(y[ok]))
    return float(np.median(sig)) if sig else SPARSE_NOISE_K


def _noise_of_series(y: np.ndarray) -> float:
    d = np.diff(np.asarray(y, float), 2)
    n = len(d)
    w = np.hanning(n + 2)[1:-1]
    X = np.fft.rfft((d - np.median(d)) * w)
    P = np.abs(X) ** 2 / float(w @ w)
    om = 2 * np.pi * np.arange(len(P)) / n
    sel = (om > NOISE_OMEGA_MIN) & (np.arange(len(P)) < len(P) - (n % 2 == 0))  # no Nyquist bin (real)
    gain = (2 - 2 * np.cos(om[sel])) ** 2
    return float(math.sqrt(np.median(P[sel] / gain) / math.log(2)))


def n_eff_ratio(fwd: _Forward, values: dict, disc=None, coefs=None) -> float:
    """n_eff / n from the lag-1 autocorrelation of the residuals of each series (>= 4 points); with a
    discrepancy term (``disc`` and its ``coefs``), of the residuals it leaves."""
    n_tot, ne_tot = 0, 0.0
    for i, run in enumerate(fwd.runs):
        r = fwd.rise(i, values) - run.rise_K - _disc_curve(disc, coefs or {}, i, run)
        for j in range(len(run.sites)):
            x = r[np.isfinite(r[:, j]) & np.isfinite(run.times_s), j]
            n = len(x)
            if n == 0:
                continue
            n_tot += n
            if n <= 3:
                ne_tot += n
                continue
            x = x - x.mean()
            den = float(x @ x)
            rho = float(x[1:] @ x[:-1]) / den if den > 0 else 0.0
            rho = min(max(rho, 0.0), 0.99)
            ne_tot += max(n * (1 - rho) / (1 + rho), 1.0)
    return ne_tot / n_tot if n_tot else 1.0


def _phase_stats(r: np.ndarray, t: np.ndarray, t63: float, t95: float) -> dict:
    out = {}
    for phase, sel in (("rise", t <= t63), ("plateau", t >= t95)):
        x = r[sel & np.isfinite(r)]
        out[phase] = {"n": int(len(x)), "mean_K": float(x.mean()) if len(x) else None,
                      "rms_K": float(np.sqrt(np.mean(x**2))) if len(x) else None}
    return out


def _lag_s(t, model, meas) -> float | None:
    """Shift [s] of the model curve that best matches the measured one (positive: measured lags)."""
    ok = np.isfinite(t) & np.isfinite(meas)
    if ok.sum() < 6:
        return None
    tt, mm, yy = t[ok], model[ok], meas[ok]
    shifts = np.linspace(-0.3 * tt.max(), 0.3 * tt.max(), 121)
    err = [np.mean((np.interp(tt - s, tt, mm, left=0.0) - yy) ** 2) for s in shifts]
    return float(shifts[int(np.argmin(err))])


def localise(fwd: _Forward, values: dict) -> tuple:
    """Per run and site: residual mean/RMS/max, per phase, lag; and the fingerprint correlations."""
    out, rows = {}, []
    for i, run in enumerate(fwd.runs):
        rom = fwd.roms[(run.scheme, run.ambient_C)]
        model = fwd.rise(i, values)
        r = model - run.rise_K
        geo = fwd.geometries[run.scheme]
        z0 = geo.outer[0][2]
        site_stats = {}
        for j, s in enumerate(run.sites):
            x = r[:, j]
            ok = np.isfinite(x)
            if not ok.any():
                continue
            steady = float(rom.nominal_rise_K[rom.site_names.index(s)])
            t = run.times_s
            fine = np.geomspace(1.0, 2.0e4, 400)
            curve = fwd.rise(i, values, fine)[:, j]
            fin = curve[-1] if curve[-1] > 0 else steady
            t63 = float(np.interp(0.632 * fin, curve, fine)) if fin > 0 else math.nan
            t95 = float(np.interp(0.95 * fin, curve, fine)) if fin > 0 else math.nan
            site_stats[s] = {"n": int(ok.sum()), "mean_K": float(x[ok].mean()),
                             "rms_K": float(np.sqrt(np.mean(x[ok] ** 2))), "max_abs_K": float(np.abs(x[ok]).max()),
                             "phases": _phase_stats(x, t, t63, t95), "lag_s": _lag_s(t, model[:, j], run.rise_K[:, j]),
                             "model_t63_s": t63, "model_t95_s": t95}
            pos = np.asarray(geo.sites[s])
            Tm = model[ok, j] + run.ambient_C + 273.15
            Ta = run.ambient_C + 273.15
            tt = np.where(np.isfinite(t[ok]), t[ok], 1e9)
            dTdt = np.gradient(model[ok, j], tt) if ok.sum() > 1 else np.zeros(ok.sum())
            for k in range(int(ok.sum())):
                rows.append((x[ok][k], model[ok, j][k], Tm[k] ** 4 - Ta**4, dTdt[k], (pos[2] - z0) / MM))
        out[run.name] = site_stats
    fp = {}
    if len(rows) >= 3:
        R = np.array(rows)
        for col, name in ((1, "rise (power map, dT)"), (2, "T^4 - T_amb^4 (radiation)"), (3, "dT/dt (heat capacity, lag)"),
                          (4, "height above the mount face")):
            a, b = R[:, 0], R[:, col]
            fp[name] = float(np.corrcoef(a, b)[0, 1]) if a.std() > 0 and b.std() > 0 else None
    return out, fp


# --------------------------------------------------------------------------- the workflow

@dataclass(frozen=True)
class Models:
    """The reduced models a correlation runs on: ``roms`` (scheme, ambient_C) -> ReducedModel,
    ``geometries`` scheme -> Geometry, ``build_s`` [s] to build them all."""

    roms: dict
    geometries: dict
    build_s: float
    keyed_geometries: dict = field(default_factory=dict)
    mesh_size_mm: float = DEFAULT_MAX_CELL_MM
    min_cells: int = DEFAULT_MIN_CELLS
    options: ModelOptions | None = None


def _pool(jobs: int, n: int):
    """A process pool of min(jobs, n) workers with one BLAS thread each, or None for one job."""
    if min(jobs, n) <= 1:
        return None
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from imutherm.studies.end_to_end import _one_blas_thread
    method = "fork" if "fork" in multiprocessing.get_all_start_methods() else "spawn"
    return ProcessPoolExecutor(max_workers=min(jobs, n), mp_context=multiprocessing.get_context(method),
                               initializer=_one_blas_thread)


def _map(fn, args, jobs: int) -> list:
    """``[fn(*a) for a in args]``, on min(``jobs``, len(args)) worker processes (:func:`_pool`)."""
    pool = _pool(jobs, len(args))
    if pool is None:
        return [fn(*a) for a in args]
    try:
        return [f.result() for f in [pool.submit(fn, *a) for a in args]]
    finally:
        pool.shutdown(cancel_futures=True)


def _build_one(layout: LayoutSpec, scheme: str, amb: float, mesh_size_mm: float, min_cells: int,
               options: ModelOptions, use_cache: bool = True):
    """(geometry, reduced model, from the cache: bool) of one (scheme, ambient [degC]); a pure function, run in
    a worker. The model is kept in the disk cache (:mod:`imutherm.cache`) under the key of everything it
    depends on: the layout's content, the scheme, the ambient, the mesh, the model options, the knob set and
    the sites (and the code version of the model)."""
    from dataclasses import replace

    from imutherm.cache import cached
    lay = replace(layout, ambient_C=amb, mounting=replace(layout.mounting, temperature_C=amb))
    geo = build_geometry(lay, scheme)
    ks = [k for k, _ in K.RETUNE] + [K.effect_knob(n, options) for n in K.model_effect_names()
                                     if K.applicable(n, geo, options)]
    names = {k.name for k in ks}
    pairs = K.coupled_pairs(names)

    def build():
        grid = build_mesh(geo, mesh_size_mm, min_cells)
        return build_reduced(lambda v: K.variant(geo, options, v), grid, ks, dict(geo.sites), pairs=pairs)
    parts = (replace(lay, path=""), scheme, float(amb), float(mesh_size_mm), int(min_cells), options, ks, pairs,
             dict(geo.sites))
    rom, hit = cached("reduced_model", parts, build, use_cache=use_cache)
    return geo, rom, hit


#: a file is refused before the reduced models are built if it ends before this fraction of its sites'
#: slowest t63 in the pre-check's knobless reduced model (its basis is the nominal Krylov space alone, a
#: few % off the full model's t63; the exact check after the build stays)
PRECHECK_T63_FRACTION = 0.9
#: the pre-check's mesh [mm] (at least; min cells 1): the reference unit's t63 there are within 2 % of the
#: 2 mm mesh's (gyro_x 94 / 96 s, tp1 27 / 27 s, accel_z 104 / 106 s) at a third of the CPU (12 / 33 s)
PRECHECK_MESH_MM = 6.0


def model_t63_s(layout: LayoutSpec, scheme: str, amb: float, sites, mesh_size_mm: float, min_cells: int,
                options: ModelOptions, use_cache: bool = True) -> dict:
    """Nominal t63 [s] of ``sites`` of one (scheme, ambient [degC]): a reduced model without knobs (one
    nonlinear steady solve and the nominal Krylov basis: a small part of a full build), rise to 2e4 s.
    Kept in the disk cache (:mod:`imutherm.cache`) under the key of everything it depends on."""
    from dataclasses import replace

    from imutherm.cache import cached
    lay = replace(layout, ambient_C=amb, mounting=replace(layout.mounting, temperature_C=amb))
    geo = build_geometry(lay, scheme)
    probes = {s: geo.sites[s] for s in sites}

    def build():
        grid = build_mesh(geo, mesh_size_mm, min_cells)
        rom = build_reduced(lambda v: K.variant(geo, options, v), grid, [], probes)
        fine = np.geomspace(1.0, 2.0e4, 400)
        curves = rom.rise({}, fine)
        out = {}
        for j, s in enumerate(rom.site_names):
            fin = curves[-1, j]
            out[s] = float(np.interp(0.632 * fin, curves[:, j], fine)) if fin > 0 else math.nan
        return out
    parts = (replace(lay, path=""), scheme, float(amb), float(mesh_size_mm), int(min_cells), options, probes)
    return cached("model_t63", parts, build, use_cache=use_cache)[0]


def check_inputs(runs, layout: LayoutSpec, holdout: str | None, *, mesh_size_mm: float, min_cells: int,
                 options: ModelOptions, say=None, use_cache: bool = True) -> None:
    """Everything about the measured files that can be refused before the reduced models are built:
    a ``holdout`` naming no file, and a file without a steady row that ends before
    :data:`PRECHECK_T63_FRACTION` of its slowest site's t63 (:func:`model_t63_s` on a mesh of at least
    :data:`PRECHECK_MESH_MM`, once per (scheme, ambient)). ``mesh_size_mm``, ``min_cells``: the run's mesh."""
    if holdout not in (None, "auto") and not any(r.path == holdout or r.name == holdout for r in runs):
        raise InputError(f"--holdout {holdout!r}: not one of the measured files ({', '.join(r.path for r in runs)})")
    t63 = {}
    for run in runs:
        if np.isinf(run.times_s).any():
            continue
        key = (run.scheme, run.ambient_C)
        if key not in t63:
            if say:
                say(f"time constants of {run.scheme} at {run.ambient_C:g} C (a reduced model without knobs)")
            sites = sorted({s for r in runs if (r.scheme, r.ambient_C) == key for s in r.sites})
            t63[key] = model_t63_s(layout, run.scheme, run.ambient_C, sites, max(mesh_size_mm, PRECHECK_MESH_MM),
                                   1, options, use_cache=use_cache)
        slowest = max(t63[key][s] for s in run.sites)
        last = float(run.times_s.max())
        if last < PRECHECK_T63_FRACTION * slowest:
            raise InputError(f"{run.path}:{run.lines[-1]}: the file ends at {last:g} s, before the model's time "
                             f"constant (~{slowest:.0f} s, t63 of its slowest site): nothing to correlate the "
                             f"plateau with; add later readings or a steady row (time_s = inf)")


def build_models(keys, layout: LayoutSpec | str | None = None, *, mesh_size_mm: float = DEFAULT_MAX_CELL_MM,
                 min_cells: int = DEFAULT_MIN_CELLS, options: ModelOptions | None = None, jobs: int = 1,
                 progress=None, use_cache: bool = True) -> Models:
    """The reduced model of each (scheme, ambient [degC]) in ``keys``, with every re-tune knob and every
    model effect that applies to the scheme (:func:`imutherm.thermal.reduced.build_reduced`).

    ``use_cache``: read and keep the models in the disk cache (:mod:`imutherm.cache`); a model found there
    costs a file read instead of its build.

    Each costs one nonlinear steady solve, ~35 preconditioned CG solves and ~60 assemblies of the full
    model: about a minute at the default 2 mm mesh on one core; ``jobs`` builds that many at once.
    """
    t0 = time.perf_counter()
    say = progress or (lambda s: None)
    if not isinstance(layout, LayoutSpec):
        layout = load_layout(layout)
    options = options or ModelOptions()
    keys = list(keys)
    for scheme, _ in keys:
        if scheme not in layout.schemes:
            raise InputError(f"correlate: scheme {scheme!r} is not in layout {layout.name!r}; "
                             f"valid: {', '.join(layout.schemes)}")
    n_nodes = build_mesh(build_geometry(layout, keys[0][0]), mesh_size_mm, min_cells).n_nodes if keys else 0
    # measured at the default mesh (1.75e5 unknowns, 16-17 knobs, two coupled pairs; effective cavity law):
    # three builds on two workers of the idle 2-core machine 112 s, i.e. ~56 s each; 1.0 GB peak per worker
    # (benchmarks/bench_correlation_speed.py, 2026-12-01)
    each, gb = n_nodes / 175e3 * 60.0, n_nodes / 175e3 * 1.1
    say(f"{len(keys)} reduced model(s), ~{n_nodes} unknowns each: about {each:.0f} s and {gb:.1f} GB each on one "
        f"core, {len(keys)} on {max(1, min(jobs, len(keys)))} worker(s)")
    pool = _pool(jobs, len(keys))
    try:
        if pool is None:
            built = []
            for scheme, amb in keys:
                say(f"reduced model of {scheme} at {amb:g} C")
                built.append(_build_one(layout, scheme, amb, mesh_size_mm, min_cells, options, use_cache))
        else:
            futs = [pool.submit(_build_one, layout, sc, amb, mesh_size_mm, min_cells, options, use_cache)
                    for sc, amb in keys]
            built = []
            for (scheme, amb), f in zip(keys, futs):
                built.append(f.result())
                say(f"reduced model of {scheme} at {amb:g} C: " + ("from the cache" if built[-1][2] else "done"))
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
    roms, geometries, keyed = {}, {}, {}
    for (scheme, amb), (geo, rom, _) in zip(keys, built):
        geometries.setdefault(scheme, geo)
        keyed[(scheme, amb)] = geo
        roms[(scheme, amb)] = rom
    return Models(roms, geometries, time.perf_counter() - t0, keyed, mesh_size_mm, min_cells, options)


def _rerun_one(geo, values: dict, run: MeasuredRun, mesh_size_mm: float, min_cells: int, options: ModelOptions,
               use_cache: bool = True, transient: str = "reduced"):
    """(site rises [K] of the corrected model at the run's times, how its transient was computed: dict) on
    the full model: its steady solve and, ``transient`` 'reduced', the transient on the checked reduced model
    (:func:`imutherm.studies.forward.checked_rise`: the full adaptive FEM where the check fails), 'full' the
    full adaptive FEM. Kept in the disk cache under the key of the layout's content, scheme, options, values,
    sites, times, mesh and ``transient``."""
    from dataclasses import replace

    from imutherm.cache import cached
    from imutherm.studies.forward import checked_rise
    if transient not in ("reduced", "full"):
        raise InputError(f"correlate: the re-run's transient is 'reduced' or 'full', not {transient!r}")
    model_vals, signal = {}, []
    for k, v in values.items():
        if k in SIGNAL:
            signal.append(setting(k, **{effect_of(k).params[0].name: v}))
        elif k in K.RETUNE_SOURCES or K.applicable(k, geo):
            model_vals[k] = v
    model_vals["power_scale"] = values.get("power_scale", 1.0) * run.power_scale
    # the study's CG tolerance: the same t95 to 0.1 s as 1e-6, 18 % fewer iterations (see STUDY_CG_RTOL)
    from imutherm.studies.thermal_study import STUDY_CG_RTOL
    probes = {s: geo.sites[s] for s in run.sites}

    def build():
        variant = K.variant(geo, options, model_vals)
        grid = build_mesh(variant.geometry, mesh_size_mm, min_cells)
        return checked_rise(variant, grid, probes, run.times_s, signal, rtol=STUDY_CG_RTOL, full=transient == "full")
    parts = (replace(geo.layout, path=""), geo.scheme.name, options, model_vals, signal, probes,
             np.asarray(run.times_s, float), float(mesh_size_mm), int(min_cells), STUDY_CG_RTOL, transient)
    rises, info = cached("full_rerun", parts, build, use_cache=use_cache)[0]
    return rises, {"file": run.path, **info}


def rerun_full(runs, values: dict, models: Models, jobs: int = 1, progress=None, use_cache: bool = True,
               transient: str = "reduced") -> tuple:
    """The corrected model re-run on the full model: (site rises [K] of each run at its times (n, m), one
    dict per run saying how its transient was computed).

    values : knob name -> value (re-tune knobs and the named effect), as fitted; the runs' own
    ``power_scale`` multiplies the fitted one; a model effect whose target a scheme lacks is off there.
    ``jobs``: runs re-run at once; ``use_cache``: a re-run of the same corrected model on the same data
    (the next correlation of the same unit) is read from the disk cache (:mod:`imutherm.cache`).
    ``transient``: 'reduced' (default) the full steady solve and the transient on the study's checked reduced
    model, the full adaptive FEM where its check fails (:func:`imutherm.studies.forward.checked_rise`);
    'full' the full adaptive FEM (``--full``).
    """
    say = progress or (lambda s: None)
    how = ("the transient on a reduced model checked against the full one" if transient == "reduced"
           else "the full adaptive transient")
    say(f"full-model re-run of {len(runs)} file(s) (one steady solve each, {how})")
    args = [(models.keyed_geometries[(r.scheme, r.ambient_C)], values, r, models.mesh_size_mm, models.min_cells,
             models.options or ModelOptions(), use_cache, transient) for r in runs]
    out = _map(_rerun_one, args, jobs)
    return [o[0] for o in out], [o[1] for o in out]


#: a run with fewer readings than this is sparse (a paper's or a notebook's few figures)
SPARSE_READINGS = 8


def _masks(runs, holdout: str | None):
    """[(train, test)] folds. holdout None/'auto': fit each file's first 60 % of its time and predict the
    rest (an effect seen in one scheme only cannot be predicted from another, so leaving a file out is
    asked for by name: ``holdout=FILE``); when every run is sparse (< :data:`SPARSE_READINGS`
    readings): leave one reading out."""
    full = {i: np.isfinite(r.values_C) for i, r in enumerate(runs)}
    if holdout not in (None, "auto"):
        names = [r.path for r in runs]
        idx = [i for i, r in enumerate(runs) if r.path == holdout or r.name == holdout]
        if not idx:
            raise InputError(f"--holdout {holdout!r}: not one of the measured files ({', '.join(names)})")
        h = idx[0]
        return [({i: m if i != h else np.zeros_like(m) for i, m in full.items()},
                 {i: m if i == h else np.zeros_like(m) for i, m in full.items()})]
    if all(r.n_values < SPARSE_READINGS for r in runs) and sum(r.n_values for r in runs) >= 3:
        folds = []
        for i, m in full.items():
            for a, b in zip(*np.nonzero(m)):
                one = np.zeros_like(m)
                one[a, b] = True
                folds.append(({j: (mm & ~one if j == i else mm) for j, mm in full.items()},
                              {j: (one if j == i else np.zeros_like(mm)) for j, mm in full.items()}))
        return folds
    train, test = {}, {}
    for i, r in enumerate(runs):  # fit early, predict late: each file's first 60 % of its time
        t = r.times_s
        fin = t[np.isfinite(t)]
        early = (t <= 0.6 * (fin.max() if len(fin) else 0.0))[:, None]
        train[i], test[i] = early & full[i], ~early & full[i]
    if sum(int(m.sum()) for m in train.values()) < 3 or not any(m.any() for m in test.values()):
        return [(full, None)]
    return [(train, test)]


def _test_union(folds) -> dict:
    """run index -> bool (n, m): every reading some fold holds out."""
    out = {}
    for _, test in folds:
        for i, m in (test or {}).items():
            out[i] = out.get(i, np.zeros_like(m)) | m
    return out


def _pooled(fwd, name, folds, ratio, prior, disc=None, start=None, fixed=None) -> tuple:
    """Held-out RMS and max over the folds (each fold fitted on its training set; with the discrepancy
    term, the held-out readings are predicted with the training fit's coefficients)."""
    errs, blocks = [], []
    for k, (train, test) in enumerate(folds):
        if test is None:
            return math.nan, math.nan, ()
        f = _fit(fwd, name, train, None, ratio, prior, disc, start, fixed=fixed)
        for i, j, rows, r in _series(fwd, f.values, test):
            e = r[rows] - (disc.basis[(i, j)][rows] @ f.disc.get((i, j), np.zeros(2)) if disc is not None else 0.0)
            errs.append(e)
            blocks.append(((k, i, j), float(np.sum(e**2)), int(len(e))))
    e = np.concatenate(errs)
    return float(np.sqrt(np.mean(e**2))), float(np.abs(e).max()), tuple(blocks)


def _held(f: Fit, h: tuple) -> Fit:
    """``f`` with the held-out figures of :func:`_pooled`."""
    return _with(f, heldout_rms_K=h[0], heldout_max_K=h[1], heldout_blocks=h[2])


def heldout_worse_z(f: Fit, base: Fit) -> float:
    """How many standard errors [-] ``f``'s held-out mean squared error lies above ``base``'s: a paired test of
    predictive accuracy (Diebold & Mariano 1995) with the held-out series (a file's site) as the independent
    blocks, since one series' late readings are one smooth curve, not independent points. Reported beside
    each candidate (``selection_steps`` of ``correlation.json``: is a held-out difference resolved?); the
    verdict's guard is :data:`HELDOUT_TOL`. NaN without matching held-out series (or fewer than 3)."""
    a = {key: (s, n) for key, s, n in f.heldout_blocks}
    b = {key: (s, n) for key, s, n in base.heldout_blocks}
    keys = [k for k in a if k in b and a[k][1] == b[k][1] and a[k][1] > 0]
    if len(keys) < 3:
        return math.nan
    n = np.array([a[k][1] for k in keys], float)
    d = np.array([(a[k][0] - b[k][0]) / a[k][1] for k in keys])  # per series: the difference of mean squares
    w = n / n.sum()
    mean = float(w @ d)
    se = math.sqrt(float(np.sum(w**2 * (d - mean) ** 2)) * len(keys) / (len(keys) - 1))
    if se == 0.0:
        return math.inf if mean > 0 else (-math.inf if mean < 0 else 0.0)
    return mean / se


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
        # _plain_explains; mild campaign of 2026-12-03: a bond line named right at 0.097 K held out, noise
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
        amb = tuple(f.name for f in sorted(refused + [best] + close, key=_rank_key))
        return "ambiguous", None, amb, "; ".join(x for x in (why, f"{len(close) + 1} candidate(s) within ΔAICc "
                                                               f"{MARGIN_RUNNER_UP:g}" if close else "") if x)
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


def _plain_explains(selection, noise_K: float, retune: Fit | None = None) -> bool:
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


def explains_term(f: Fit, none: Fit, noise_K: float, chosen=()) -> bool:
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
    rise). Judged on the set, not per step: two effects hidden together each leave the other in the term."""
    if not (math.isfinite(none.disc_rms_K) and math.isfinite(f.disc_rms_K)):
        return True

    def ok(left, before):
        return left <= max(NONE_NOISE_FACTOR * noise_K, EXPLAIN_FRACTION * before)

    acting = {g for c in (chosen or (f,)) for g, x in c.signature_by.items() if x >= EXPLAIN_NOISE_FACTOR * noise_K}
    acting &= set(f.disc_rms_by) & set(none.disc_rms_by)
    if not acting:
        return ok(f.disc_rms_K, none.disc_rms_K)
    return all(ok(f.disc_rms_by[g], none.disc_rms_by[g]) for g in acting)


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


def _fit_candidate(fwd, name, full, folds, ratio: float, noise: float, disc=None, start=None, hint=None):
    """One candidate (or combination) fitted on all data, with its pooled held-out figures (a pure
    function: run in a worker). ``hint``: its values fitted without the discrepancy term (a further start)."""
    f = _fit(fwd, name, full, None, ratio, noise, disc, start, hint)
    return _held(f, _pooled(fwd, name, folds, ratio, noise, disc and disc.with_prior(f.disc_priors), start))


#: forward selection stops after this many library effects
MAX_EFFECTS = 3


def _compatible(selected: tuple, name: str) -> bool:
    """Whether effect ``name`` can be added to ``selected``: not the same effect twice, and not two effects
    that each share a jointly-interpolated conductance with the same re-tune knob (the reduced model
    interpolates each :data:`~imutherm.unit.knobs.COUPLED` pair jointly, not a triple)."""
    if name in selected:
        return False
    partners = {a if b in selected else b for a, b in K.COUPLED if a in selected or b in selected}
    mine = {a if b == name else b for a, b in K.COUPLED if name in (a, b)}
    return not (partners & mine)


def _timed(fn, *a):
    """(``fn(*a)``, its CPU seconds in this process): a worker's task, timed where it runs."""
    c0 = time.process_time()
    out = fn(*a)
    return out, time.process_time() - c0


def _fit_full(fwd, name, full, folds, ratio: float, noise: float, disc=None, start=None, hint=None) -> Fit:
    """The fit on all data of :func:`_fit_candidate`, without the held-out figures (a task of its own)."""
    return _fit(fwd, name, full, None, ratio, noise, disc, start, hint)


def _fit_heldout(fwd, name, full, folds, ratio: float, noise: float, disc=None, start=None, hint=None) -> tuple:
    """The hold-out figures of :func:`_fit_candidate` without the discrepancy term (they do not depend on the
    fit on all data then: a task of its own, run beside :func:`_fit_full`)."""
    return _pooled(fwd, name, folds, ratio, noise, None, start)


#: the guessed CPU cost of a candidate's fits relative to the others, before any is measured (the first
#: forward-selection step): a probe lag's rises are computed on a dense time grid and filtered, ~3x the CPU
#: of any other candidate (measured: 3.0-3.8 s against 0.3-1.5 s per candidate, 2026-12-02)
_COST_GUESS = {"probe_lag": 3.0}


def _fit_candidates(args, jobs: int, costs: dict | None = None) -> list:
    """:func:`_fit_candidate` of every ``a`` of ``args`` (their order kept), on ``jobs`` workers.

    A step of the forward selection waits for its slowest candidate, so the work is balanced: without the
    discrepancy term each candidate's fit on all data and its hold-out fit are two tasks (independent then),
    and the tasks are handed out longest first, by their CPU seconds of the step before (``costs``: last
    effect -> seconds, updated here) or :data:`_COST_GUESS`. The same fits either way: the results equal
    the serial ones."""
    costs = {} if costs is None else costs
    pool = _pool(jobs, len(args))
    if pool is None:
        return [_fit_candidate(*a) for a in args]
    split = all(a[6] is None for a in args)
    kinds = (_fit_full, _fit_heldout) if split else (_fit_candidate,)
    tasks = [(k, fn) for k in range(len(args)) for fn in kinds]

    def cost(task):
        k, fn = task
        last = _effects_of(args[k][1])[-1]
        if (fn.__name__, last) in costs:
            return costs[(fn.__name__, last)]
        if fn is _fit_candidate and ("_fit_full", last) in costs:  # the same candidate measured without the term
            return costs[("_fit_full", last)] + costs.get(("_fit_heldout", last), 0.0)
        return _COST_GUESS.get(last.split("@")[0], 1.0)

    order = sorted(range(len(tasks)), key=lambda t: -cost(tasks[t]))  # stable: ties in the given order
    try:
        futs = {t: pool.submit(_timed, tasks[t][1], *args[tasks[t][0]]) for t in order}
        done = {t: f.result() for t, f in futs.items()}
    finally:
        pool.shutdown(cancel_futures=True)
    for t, (_, sec) in done.items():
        k, fn = tasks[t]
        costs[(fn.__name__, _effects_of(args[k][1])[-1])] = sec
    if not split:
        return [done[t][0] for t in range(len(tasks))]
    out = []
    for k in range(len(args)):
        f, h = done[2 * k][0], done[2 * k + 1][0]
        out.append(_held(f, h))
    return out


def _with_term(runs, models, form, form_retune: bool, nominal: dict, noise: float, ratio: float, full, folds,
               caps: dict | None = None):
    """The re-tuned model with the discrepancy term: (forward model, :class:`Discrepancy`, its Fit with
    held-out figures, n_eff ratio). Where the model's form is in doubt the form knobs of :data:`FORM_IN_DOUBT`
    (the cavity law's blend) are re-tuned too; the residual level σ of the evidence is what the re-tune with
    the term leaves, not below the noise, and the re-tuned model's own scales start every candidate's. ``caps``:
    scheme -> the term's largest prior scale [-] (the model's known form error, :mod:`imutherm.studies.form_error`)."""
    fwd = _Forward(runs, models.roms, models.geometries, models.options,
                   form + (tuple(FORM_IN_DOUBT) if form_retune else ()))
    disc = build_discrepancy(fwd, nominal, noise, ratio, DISCREPANCY_PRIOR, caps)
    first = _fit(fwd, "none", full, None, ratio, noise, disc)
    ratio = n_eff_ratio(fwd, first.values, disc, first.disc)  # the term takes the smooth, correlated part
    disc = replace(disc, prior=dict(first.disc_priors), sigma_K=max(noise, first.rms_K), ratio=ratio)
    none_fit = _fit(fwd, "none", full, None, ratio, noise, disc)
    disc = disc.with_prior(none_fit.disc_priors)
    return fwd, disc, _held(none_fit, _pooled(fwd, "none", folds, ratio, noise, disc)), ratio


def _truncate(steps, chosen, k: int, verdict: str, why: str, say) -> tuple:
    """(steps, chosen) of a forward selection cut to its first ``k`` effects, step k's verdict replaced by
    ``verdict`` with the reason '<effect k> <why>'."""
    say(f"named: {', '.join(c.effects[-1] for c in chosen[:k])}; not {chosen[k].effects[-1]}, which {why}")
    steps = steps[:k] + [dict(steps[k], verdict=verdict, named=None, reason=f"{chosen[k].effects[-1]} {why}")]
    return steps, chosen[:k]


def _gain_words(f: Fit, retune: Fit) -> str:
    """'the library's choice (NAME) takes the re-tuned model's held-out error from A to B K'."""
    return (f"the library's choice ({f.name}) takes the re-tuned model's held-out error from "
            f"{retune.heldout_rms_K:.3f} to {f.heldout_rms_K:.3f} K")


def _rank_key(f: Fit):
    return (f.aicc if math.isfinite(f.aicc) else math.inf, f.heldout_rms_K if math.isfinite(f.heldout_rms_K) else math.inf)


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
                         key=_rank_key)
        v, named, amb, reason = verdict(cur, ranking, noise, base)
        steps.append({"base": cur, "ranking": tuple(ranking), "verdict": v, "named": named and named.split("+")[-1],
                      "ambiguous_set": tuple(a.split("+")[-1] for a in amb), "reason": reason})
        if v != "effect":
            break
        cur = next(f for f in ranking if f.name == named)
        chosen.append(cur)
    return steps, chosen


def correlate(runs, layout: LayoutSpec | str | None = None, *, holdout: str | None = "auto",
              mesh_size_mm: float = DEFAULT_MAX_CELL_MM, min_cells: int = DEFAULT_MIN_CELLS,
              candidates=None, options: ModelOptions | None = None, models: "Models | None" = None,
              rerun: bool = True, jobs: int = 1, progress=None, use_cache: bool = True,
              discrepancy: bool | str = "auto", max_effects: int = MAX_EFFECTS,
              form_retune: bool = True, rerun_transient: str = "reduced") -> CorrelationResult:
    """Run the correlation workflow on measured runs (see the module docstring).

    discrepancy : 'auto' (default): the library first (the re-tune, its form knobs and forward selection); where
        its choice does not predict held-out data within :data:`NONE_NOISE_FACTOR` noise sigmas
        (:func:`_plain_explains`), the selection again with the model's own error as a term
        (:class:`Discrepancy`, its scale estimated per fit), whose verdict stands; where it names nothing and
        the re-tune is within that standard, the term is fitted on the re-tuned model alone and the verdict is
        'discrepancy' if the data support it (:func:`_verdict_discrepancy`), else 'none'. True: always with
        the term; False: never. The term is not fitted on sparse files (:func:`form_band` instead).
    max_effects : forward selection names at most this many library effects (1: one effect, as before)
    form_retune : re-tune the form knobs (:data:`FORM_RETUNE`: the cavity's emissivity) beside the others
        instead of offering them as candidate effects (default); False: offered as candidates (``--cavity-emissivity-as-effect``)
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
    if not runs:
        raise InputError("correlate: no measured files")
    refuse_duplicates(runs)
    check_plausible(runs)
    if not isinstance(layout, LayoutSpec):
        layout = load_layout(layout)
    options = options or ModelOptions()
    fscale = FE.form_scale(r.scheme for r in runs)
    caps = {g: fscale.cap(g) for g in fscale.fraction}
    if models is None:
        check_inputs(runs, layout, holdout, mesh_size_mm=mesh_size_mm, min_cells=min_cells, options=options, say=say,
                     use_cache=use_cache)
        models = build_models(sorted({(r.scheme, r.ambient_C) for r in runs}), layout, mesh_size_mm=mesh_size_mm,
                              min_cells=min_cells, options=options, jobs=jobs, progress=say, use_cache=use_cache)
    missing = sorted({(r.scheme, r.ambient_C) for r in runs} - set(models.roms))
    if missing:
        raise InputError(f"correlate: no reduced model for {', '.join(f'{s} at {a:g} C' for s, a in missing)}")
    roms, geometries = models.roms, models.geometries
    t_rom = time.perf_counter() - t0
    # a form knob asked for as a candidate (or every one, without form_retune) is not re-tuned
    form = tuple(n for n in FORM_RETUNE if form_retune and n not in (candidates or ()))
    fwd = _Forward(runs, roms, geometries, models.options, form)
    for i, run in enumerate(runs):  # a file must reach the model's time constant (or give a steady row)
        if not np.isinf(run.times_s).any():
            loc, _ = localise(_Forward((run,), roms, geometries), {})
            t63 = max(s["model_t63_s"] for s in loc[run.name].values())
            last = float(run.times_s[np.isfinite(run.times_s)].max())
            if last < t63:
                raise InputError(f"{run.path}:{run.lines[-1]}: the file ends at {last:g} s, before the model's "
                                 f"time constant ({t63:.0f} s, t63 of its slowest site): nothing to correlate "
                                 f"the plateau with; add later readings or a steady row (time_s = inf)")
    noise = float(np.median([noise_sigma(r) for r in runs]))
    nominal = dict(fwd.nominal)
    before_res = _residuals(fwd, nominal, {i: np.isfinite(r.values_C) for i, r in enumerate(runs)})
    loc, fp = localise(fwd, nominal)
    say("re-tune")
    # the fits' small dense algebra (reduced models of ~40 unknowns) on one BLAS thread, as in the workers:
    # OpenBLAS's two threads on matrices that small cost more than they give (measured at load 5: a re-tune
    # 0.13 s on one thread, 0.23-0.30 s on two; at load ~9 the three re-tune fits took 12 s of CPU, not 1 s),
    # and the results are the same
    with threadpool_limits(1):
        full = {i: np.isfinite(r.values_C) for i, r in enumerate(runs)}
        folds = _masks(runs, holdout)
        none0 = _fit(fwd, "none", full, None, 1.0, noise)
        ratio = ratio0 = n_eff_ratio(fwd, none0.values)
        plain = _fit(fwd, "none", full, None, ratio, noise)
        plain = _held(plain, _pooled(fwd, "none", folds, ratio, noise))
        if candidates is None:
            candidates = [n for n in K.model_effect_names() if any(n in rom.knobs for rom in roms.values())]
            candidates += [n for n in SIGNAL]
        for name in candidates:
            effect_of(name)
        candidates = [n for n in candidates if (EFFECTS[n.split("@")[0]].kind != "model"
                      or any(n in rom.knobs for rom in roms.values())) and n not in fwd.form
                      and n not in FORM_IN_DOUBT]
        if discrepancy not in (True, False, "auto"):
            raise InputError(f"correlate: discrepancy={discrepancy!r}; valid: True, False, 'auto'")
        disc, none_fit = None, plain
        disc_note, sparse_term, term_check = "", False, False
        if discrepancy and all(len(r.times_s) < SPARSE_READINGS for r in runs):
            # two coefficients per series fit a sparse file's few readings exactly: nothing is left to judge by
            disc_note = (f"discrepancy term not fitted: every file has fewer than {SPARSE_READINGS} readings per "
                         f"site, which its two coefficients per site would fit exactly")
            say(disc_note)
            discrepancy = False
            sparse_term = True
        plain_sel, costs = None, {}
        if discrepancy == "auto":  # the library first; the term only where the library does not explain the data
            plain_sel = forward_select(fwd, plain, candidates, full, folds, ratio, noise, None, jobs, max_effects, say,
                                       costs=costs)
            band = FE.band_K(fwd, fscale, plain.values, _test_union(folds))
            if plain_sel[1] and FE.named_through_form(plain.heldout_rms_K, plain_sel[1][-1].heldout_rms_K, band,
                                                      noise, NONE_NOISE_FACTOR):
                discrepancy = False
                disc_note = (_gain_words(plain_sel[1][-1], plain) + f", within the model's known form error ({band:.3f} "
                             f"K held out, {FE.FORM_SIGMAS:g} sigmas {FE.FORM_SIGMAS * band:.3f} K; noise "
                             f"{noise:.3f} K): named through the form error, no discrepancy term asked")
                say(disc_note)
            elif _plain_explains(plain_sel, noise, plain):
                discrepancy = False
                # nothing named and the re-tune within the noise standard: is a smooth residual left that the
                # data support all the same (the model's form, or an effect outside the library the re-tune hid)?
                term_check = not plain_sel[1]
            elif _plain_explains(plain_sel, noise):  # within the noise, but no more than a form error's gain
                disc_note = (_gain_words(plain_sel[1][-1], plain) + f", less than {1 / EXPLAIN_FRACTION:g}x: a gain "
                             f"the model's form error could give; judged with the discrepancy term")
                say(disc_note)
            else:
                disc_note = ("the library effects and the re-tune do not predict held-out data within "
                             f"{NONE_NOISE_FACTOR:g} noise sigmas: judged with the discrepancy term")
                say(disc_note)
        if discrepancy:
            fwd, disc, none_fit, ratio = _with_term(runs, models, form, form_retune, nominal, noise, ratio, full, folds,
                                                    caps)
        if discrepancy or plain_sel is None:
            if plain_sel is None and disc is not None:  # the library's fits without the term: starts of those with it
                plain_sel = ([{"ranking": tuple(_map(_fit, [(fwd, (n,), full, None, ratio, noise) for n in candidates],
                                                      jobs))}], [])
            hints = {f.effects: f.values for st in (plain_sel[0] if plain_sel else ()) for f in st["ranking"]}
            steps, chosen = forward_select(fwd, none_fit, candidates, full, folds, ratio, noise, disc, jobs,
                                           max_effects, say, hints, costs)
        else:
            steps, chosen = plain_sel
        ranking = list(steps[0]["ranking"]) if steps else []
        if term_check:
            fwd, disc, none_fit, ratio = _with_term(runs, models, form, form_retune, nominal, noise, ratio, full,
                                                    folds, caps)
    t_fits = time.perf_counter() - t0 - t_rom
    unexplained = ""
    if disc is not None and len(chosen) > 1:
        # with the term capped at the model's known form error, a further effect must itself explain what the
        # effects before it leave of the term, where it acts (halve it or leave it within 2 noise sigmas): the
        # halving rule of the plain path, for the term. Else a form error beyond the known one is handed, piece by
        # piece, to further library effects (toy, 6 % form error and a 0.5 W regulator error: power@processor named
        # second, not hidden)
        k = next((k for k in range(1, len(chosen)) if not explains_term(chosen[k], chosen[k - 1], noise,
                                                                       chosen[k:k + 1])), None)
        if k is not None:
            steps, chosen = _truncate(steps, chosen, k, "none", "does not halve the discrepancy the effects before it "
                                      "leave where it acts", say)
    if disc is not None and chosen and not explains_term(chosen[-1], none_fit, noise, chosen):
        # the longest first part of the selection that does explain it (a later step may add an effect that
        # acts where the form error is and explains it not)
        keep = next((k for k in range(len(chosen) - 1, 0, -1)
                     if explains_term(chosen[k - 1], none_fit, noise, chosen[:k])), 0)
        if keep:
            steps, chosen = _truncate(steps, chosen, keep, "not_in_library", "does not explain the model's error "
                                      "where it acts", say)
    if disc is not None and chosen and not explains_term(chosen[-1], none_fit, noise, chosen):
        f = chosen[-1]
        unexplained = (f"no candidate explains the model's error: the best, {f.name}, leaves a discrepancy of "
                       f"{f.disc_rms_K:.2f} K of the re-tuned model's {none_fit.disc_rms_K:.2f} K (more than "
                       f"{EXPLAIN_FRACTION:g} of it and {NONE_NOISE_FACTOR:g} noise sigmas)")
        say(unexplained)
        chosen = []
    named_effects = tuple(f.effects[-1] for f in chosen)
    if unexplained:
        v, named, amb_set, reason = "not_in_library", None, (), unexplained
    elif chosen:
        v, named, amb_set = "effect", named_effects[0], ()
        reason = "; ".join(st["reason"] for st in steps if st["verdict"] == "effect")
        if len(steps) > len(chosen):
            reason += f"; then stopped: {steps[len(chosen)]['reason']}"
    elif steps:
        v, named, amb_set, reason = steps[0]["verdict"], None, steps[0]["ambiguous_set"], steps[0]["reason"]
    else:
        v, named, amb_set, reason = "none", None, (), "no candidate effect applies"
    after = chosen[-1] if chosen else none_fit
    dsum = None
    if disc is not None:
        dsum = discrepancy_summary(fwd, disc, plain, none_fit, after, full, noise, loc)
        if v in ("none", "not_in_library"):  # the rules again, now between the re-tune alone and with the term
            v, reason = _verdict_discrepancy(plain, none_fit, dsum, noise, v, reason)
    if disc_note:
        reason += f" ({disc_note})"
    if term_check and v == "none":  # the term was asked and is not needed: the re-tuned model stands as it is
        after, none_fit, disc = plain, plain, None
    # the re-tune's far moves (findings) and the model to write, both on the physics without the term
    with threadpool_limits(1):
        free = after
        if disc is not None:
            free = _held(_fit(fwd, after.effects, full, None, ratio0, noise, None, after.values),
                         _pooled(fwd, after.effects, folds, ratio0, noise, None, after.values))
        held_out = _test_union(folds) if folds[0][1] is not None else full
        found = findings_of(fwd, free, full, folds, ratio0, noise, held_out)
        written = choose_written(fwd, nominal, after.values, free.values if disc is not None else None, held_out)
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
    curves = {}
    for i, run in enumerate(runs):
        d = _disc_curve(disc, after.disc, i, run)
        curves[run.name] = {"sites": run.sites, "times_s": run.times_s, "measured_K": run.rise_K,
                            "before_K": fwd.rise(i, nominal), "after_K": fwd.rise(i, after.values) - d,
                            "discrepancy_K": -d}
    before = {"rms_K": float(np.sqrt(np.mean(before_res**2))), "max_K": float(np.abs(before_res).max()),
              "heldout_rms_K": _heldout_nominal(fwd, folds, nominal)}
    words = "; ".join([f.words() for f in found] + [effect_words(n, after.values) for n in named_effects]) or reason
    if dsum is not None and dsum["supported"]:
        words += f"; {dsum['words']}"
    band = form_band(fwd, after.values, full, named_effects) if sparse_term else None
    if band is not None:
        words += f"; {band['words']}"
    rerun_stats = {}
    t1 = time.perf_counter()
    if rerun:
        rises, transients = rerun_full(runs, after.values, models, jobs, say, use_cache, rerun_transient)
        res_full = np.concatenate([(y - r.rise_K)[np.isfinite(r.values_C)] for y, r in zip(rises, runs)])
        res_disc = np.concatenate([(y - _disc_curve(disc, after.disc, i, r) - r.rise_K)[np.isfinite(r.values_C)]
                                   for i, (y, r) in enumerate(zip(rises, runs))])
        rerun_stats = {"rms_K": float(np.sqrt(np.mean(res_disc**2))), "max_K": float(np.abs(res_disc).max()),
                       "rms_physics_K": float(np.sqrt(np.mean(res_full**2))),
                       "max_physics_K": float(np.abs(res_full).max()), "transients": transients}
        for i, (y, r) in enumerate(zip(rises, runs)):
            curves[r.name]["after_full_K"] = y - _disc_curve(disc, after.disc, i, r)
    return CorrelationResult(v, named, amb_set, before, after, none_fit, tuple(ranking), loc, fp, noise, curves,
                             runs, {f"{s}@{a:g}C": {"basis": r.basis_size, "unknowns": r.unknowns,
                                                    "build_s": r.build_s, "solves": r.solves}
                                    for (s, a), r in roms.items()},
                             {"reduced_models_s": t_rom, "fits_s": t_fits, "full_rerun_s": time.perf_counter() - t1,
                              "total_s": time.perf_counter() - t0, "reason": reason},
                             words, rerun_stats, named_effects, tuple(steps), dsum, plain, band, found, written,
                             fscale.summary(), free)


def _disc_curve(disc: Discrepancy | None, coefs: dict, i: int, run) -> np.ndarray:
    """Φ c [K] (n, m) of run i: the discrepancy term's part of the fitted model - measured (0 without it)."""
    out = np.zeros((len(run.times_s), len(run.sites)))
    if disc is None:
        return out
    for j in range(len(run.sites)):
        if (i, j) in coefs:
            out[:, j] = disc.basis[(i, j)] @ coefs[(i, j)]
    return out


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
        d = -_disc_curve(disc, after.disc, i, run)
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
    rms = float(np.sqrt(np.mean(np.concatenate([(-_disc_curve(disc, after.disc, i, r))[full[i]]
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


def form_band(fwd, values: dict, full: dict, effects=()) -> dict | None:
    """The model's form uncertainty as a prior band at each reading, for files too sparse to fit the
    discrepancy term (a paper's or a notebook's few figures): the change of each reading [K] when the cavity's
    radiation law goes from the s2s exchange to the effective conductivity (``cavity_law_blend`` 0 -> 1,
    :data:`FORM_IN_DOUBT`; the two verified laws bracket the unit, an independent model lies between them) at
    the fitted ``values``, beside the residual the fit leaves (model - measured) [K]. A residual within the band
    is what the model's form alone could leave: the data cannot say more. ``effects``: the named effects, whose
    change of the readings (with and without them, the rest as fitted) is set beside the band too: an effect
    that changes them by less than the law's form does could be the model's form instead. None where the
    reduced models do not carry the blend (the effective law: no s2s exchange to blend)."""
    if not fwd.roms or not all("cavity_law_blend" in rom.knobs for rom in fwd.roms.values()):
        return None
    lo, hi = {**values, "cavity_law_blend": 0.0}, {**values, "cavity_law_blend": 1.0}
    rest = {k: v for k, v in values.items() if k not in effects}
    rows, change = [], []
    for i, run in enumerate(fwd.runs):
        y, a, b = fwd.rise(i, values), fwd.rise(i, lo), fwd.rise(i, hi)
        if effects:
            change.append((y - fwd.rise(i, rest))[full[i]])
        for j, site in enumerate(run.sites):
            for k, t in enumerate(run.times_s):
                if full[i][k, j]:
                    rows.append({"file": run.path, "scheme": run.scheme, "site": site, "time_s": float(t),
                                 "steady": not math.isfinite(t),
                                 "residual_K": float(y[k, j] - run.rise_K[k, j]), "form_span_K": float(b[k, j] - a[k, j])})
    if not rows:
        return None
    res = np.array([r["residual_K"] for r in rows])
    span = np.array([r["form_span_K"] for r in rows])
    res_rms, span_rms = float(np.sqrt(np.mean(res**2))), float(np.sqrt(np.mean(span**2)))
    within = bool(res_rms <= span_rms)
    by = {}
    for r in rows:
        by.setdefault(r["scheme"], []).append(abs(r["form_span_K"]))
    spans = ", ".join(f"{max(v):.2g} K in {g}" for g, v in by.items())
    words = (f"too few readings to fit the model's own error; the cavity law's form alone moves them by up to "
             f"{spans} (s2s to the effective law, at the fitted values): the {res_rms:.2g} K RMS the fit leaves is "
             + ("within that band: these readings say nothing more"
                if within else f"beyond that band ({span_rms:.2g} K RMS): more than the model's form explains"))
    effect_rms = float(np.sqrt(np.mean(np.concatenate(change) ** 2))) if change else None
    if effect_rms is not None:
        words += (f"; the named effect{'s' if len(effects) > 1 else ''} change{'' if len(effects) > 1 else 's'} them "
                  f"by {effect_rms:.2g} K RMS, " + ("more than the law's form does" if effect_rms > span_rms else
                                                    "no more than the law's form does: it may be the model's form instead")
                  + f" ({span_rms:.2g} K RMS)")
    return {"kind": "prior band: the cavity law's form (cavity_law_blend 0 -> 1)", "residual_rms_K": res_rms,
            "form_span_rms_K": span_rms, "within": within, "effects": list(effects), "effect_change_rms_K": effect_rms,
            "readings": rows, "words": words}


def _verdict_discrepancy(plain: Fit, with_term: Fit, dsum: dict, noise: float, v: str, reason: str) -> tuple:
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


def _content_key(run: MeasuredRun) -> tuple:
    """What a measured file says, whatever its path, comments or number formatting: its experiment (scheme,
    ambient, power scale, power-on time) and its readings, by site."""
    order = np.argsort(run.sites)
    vals = np.round(run.values_C[:, order], 9)
    return (run.scheme, round(run.ambient_C, 9), round(run.power_scale, 9), round(run.t_power_on_s, 9),
            tuple(np.asarray(run.sites)[order]), np.round(run.times_s, 9).tobytes(), np.nan_to_num(vals, nan=-1e300).tobytes())


def refuse_duplicates(runs) -> None:
    """Refuse two measured files with the same content (the same experiment given twice counts its
    readings twice: a false confidence, and no held-out test between them), by content, not by path."""
    seen = {}
    for r in runs:
        key = _content_key(r)
        if key in seen:
            other = seen[key]
            same = "the same file" if other.path == r.path else f"the same readings as {other.path}"
            raise InputError(f"{r.path}: {same} (scheme {r.scheme}, {r.n_values} readings): a measured file given "
                             f"twice; give each experiment once")
        seen[key] = r


def _heldout_nominal(fwd, folds, nominal) -> float:
    errs = [_residuals(fwd, nominal, test) for _, test in folds if test is not None]
    if not errs:
        return math.nan
    e = np.concatenate(errs)
    return float(np.sqrt(np.mean(e**2))) if len(e) else math.nan


def _with(f: Fit, **changes) -> Fit:
    from dataclasses import replace
    return replace(f, **changes)


#: readings kept in ``updated_model.toml``'s ``[correlation]`` for a report (a test's few points, a paper's figures);
#: more (a dense record) go to ``readings.csv`` only
MAX_TOML_READINGS = 64


def reading_rows(res: CorrelationResult) -> list:
    """Every reading side by side, as rises over the file's ambient [K] (rows of a table, file order).

    ``measured_K``; ``nominal_K`` the nominal model; ``corrected_K`` the corrected model's physics (re-tuned
    values and named effects, reduced model, without the discrepancy term); ``corrected_with_term_K`` with the
    term (only where one was fitted); ``corrected_full_K`` the corrected model re-run on the full FEM (only if it
    was). Also ``file``, ``scheme``, ``ambient_C`` [degC], ``site``, ``time_s`` [s] (inf: the steady reading).
    """
    rows = []
    for run in res.runs:
        c = res.curves[run.name]
        term = np.asarray(c.get("discrepancy_K", np.zeros_like(c["after_K"])), float)
        has_term = bool(np.any(term))
        for k, t in enumerate(c["times_s"]):
            for j, site in enumerate(c["sites"]):
                if not np.isfinite(c["measured_K"][k, j]):
                    continue
                row = {"file": run.name, "scheme": run.scheme, "ambient_C": float(run.ambient_C), "site": site,
                       "time_s": float(t), "measured_K": float(c["measured_K"][k, j]),
                       "nominal_K": float(c["before_K"][k, j]), "corrected_K": float(c["after_K"][k, j] - term[k, j])}
                if has_term:
                    row["corrected_with_term_K"] = float(c["after_K"][k, j])
                if "after_full_K" in c:
                    row["corrected_full_K"] = float(c["after_full_K"][k, j] - term[k, j])
                rows.append(row)
    return rows


def _toml_value(v) -> str:
    import json

    if isinstance(v, float):
        return ("inf" if v > 0 else "-inf") if math.isinf(v) else f"{v:.6g}"
    return json.dumps(v)


def result_json(res: CorrelationResult) -> dict:
    """The ``correlation.json`` content."""
    def params(f: Fit):
        out = {}
        for name, v in f.values.items():
            k = next((kk for kk, _ in K.RETUNE if kk.name == name), None)
            unit = k.unit if k is not None else effect_of(name).params[0].unit
            form = name in FORM_KNOBS and name not in res.named_effects and name not in f.effects
            out[name] = {"value": v, "unit": unit, "ci95": list(f.ci.get(name, (None, None))),
                         "kind": "retune" if k is not None or form else "effect",
                         "source": K.RETUNE_SOURCES.get(name) or (FORM_KNOBS[name] if form else
                                                                  effect_of(name).params[0].source),
                         "at_bound": name in f.at_bound}
        return out

    def named(k: int) -> dict:
        f = next(st for st in res.steps if st["verdict"] == "effect" and st["named"] == res.named_effects[k])
        fit = next(x for x in f["ranking"] if x.effects and x.effects[-1] == res.named_effects[k])
        base = f["base"]
        p = params(fit)
        phys = res.physics.ci.get(res.named_effects[k]) if res.physics is not None else None
        return {"name": res.named_effects[k], "step": k + 1, "parameters": {n: p[n] for n in fit.effects},
                # the corrected physics fitted without the discrepancy term: the effect's value and 95 % interval
                "without_term": ({"value": res.physics.values.get(res.named_effects[k]), "ci95": list(phys)}
                                 if phys is not None else None),
                "in_words": effect_words(res.named_effects[k], fit.values),
                "heldout_rms_before_K": base.heldout_rms_K, "heldout_rms_K": fit.heldout_rms_K,
                "heldout_gain_K": base.heldout_rms_K - fit.heldout_rms_K,
                "delta_criterion_vs_previous": base.aicc - fit.aicc, "change_K": fit.signature_K}

    return {
        "verdict": res.verdict, "named_effect": res.named_effect, "ambiguous_set": list(res.ambiguous_set),
        "named_effects": [named(k) for k in range(len(res.named_effects))],
        "selection_steps": [{"base": st["base"].name, "verdict": st["verdict"], "named": st["named"],
                             "ambiguous_set": list(st["ambiguous_set"]), "reason": st["reason"],
                             "ranking": [{"name": f.name, "delta_criterion": st["base"].aicc - f.aicc,
                                          "heldout_rms_K": f.heldout_rms_K, "change_K": f.signature_K,
                                          "heldout_worse_z": heldout_worse_z(f, st["base"])}
                                         for f in st["ranking"][:8]]} for st in res.steps],
        # re-tuned parameters that moved far and explain most of the gap, the largest share first; the first thing
        # named is the first finding if there is one, else the first library effect
        "findings": [f.as_dict() for f in res.findings],
        "named_first": (res.findings[0].parameter if res.findings else res.named_effect),
        "written_model": ({k: v for k, v in res.written.items() if k != "values"} if res.written else None),
        "form_scale": res.form_scale,
        "discrepancy": res.discrepancy,
        "form_band": res.form_band,
        "criterion": res.retune.criterion,
        "reason": res.timings["reason"], "in_words": res.words,
        "parameters": params(res.after),
        "retuned_parameters": params(res.retune),
        "ranking": [{"name": f.name, "aicc": f.aicc, "delta_aicc_vs_none": res.retune.aicc - f.aicc,
                     "rms_K": f.rms_K, "heldout_rms_K": f.heldout_rms_K, "heldout_max_K": f.heldout_max_K,
                     "n": f.n, "n_eff": f.n_eff, "k": f.k, "at_bound": list(f.at_bound),
                     "values": f.values} for f in (res.retune,) + res.ranking],
        # after: the corrected model re-run on the full FEM (if it was), else the reduced model's fit
        "rms_before_K": res.before["rms_K"], "rms_after_K": res.full.get("rms_K", res.after.rms_K),
        "max_before_K": res.before["max_K"], "max_after_K": res.full.get("max_K", res.after.max_K),
        "after_from": "full model re-run" if res.full else "reduced model",
        "rms_after_reduced_K": res.after.rms_K, "max_after_reduced_K": res.after.max_K,
        # the full re-run without the discrepancy term's correction (the physics alone)
        "rms_after_physics_K": res.full.get("rms_physics_K"), "max_after_physics_K": res.full.get("max_physics_K"),
        # each file's re-run transient: 'reduced' (checked against the full model: its estimate) or 'full'
        "rerun_transients": res.full.get("transients"),
        "heldout_rms_retune_K": res.retune_plain.heldout_rms_K if res.retune_plain else res.retune.heldout_rms_K,
        "heldout_rms_before_K": res.before["heldout_rms_K"], "heldout_rms_after_K": res.after.heldout_rms_K,
        "noise_K": res.noise_K, "n_points": res.after.n, "n_eff": res.after.n_eff,
        "localise": res.localise, "fingerprints": res.fingerprints,
        "runs": [{"file": r.path, "scheme": r.scheme, "ambient_C": r.ambient_C, "power_scale": r.power_scale,
                  "probe": r.probe, "sites": list(r.sites), "readings": r.n_values} for r in res.runs],
        "reduced_models": res.reduced, "timings_s": {k: v for k, v in res.timings.items() if k != "reason"},
        "thresholds": {"margin_vs_none_aicc": MARGIN_NONE, "margin_vs_runner_up_aicc": MARGIN_RUNNER_UP,
                       "none_noise_factor": NONE_NOISE_FACTOR, "explain_noise_factor": EXPLAIN_NOISE_FACTOR,
                       "explain_fraction": EXPLAIN_FRACTION, "sparse_noise_K": SPARSE_NOISE_K,
                       "discrepancy_prior_start_fraction": DISCREPANCY_PRIOR,
                       "discrepancy_prior_range_fraction": list(DISCREPANCY_PRIOR_RANGE), "max_effects": MAX_EFFECTS},
    }


def updated_model_toml(res: CorrelationResult, layout_path: str | None = None,
                       options: ModelOptions | None = None) -> str:
    """``updated_model.toml``: the fitted re-tune values and the named effect, as ``imutherm solve`` takes them;
    ``[model]`` the layout and model switches the fit ran with (``layout_path``, ``options``), ``[correlation]``
    its verdict, RMS before / after and (up to :data:`MAX_TOML_READINGS`) the readings side by side
    (:func:`reading_rows`), so that ``solve`` / ``compare`` / ``sweep --model FILE`` run on it and
    name it (:mod:`imutherm.studies.fitted_model`)."""
    import json
    from pathlib import Path

    lines = ["# imutherm correlate: the model after correlation", f"# verdict = {res.verdict}",
             f"# {res.words}", "# run a study on it: imutherm compare --model THIS_FILE (also solve, sweep)", ""]
    written = res.written or {"model": "corrected", "values": res.after.values, "reason": ""}
    values = written["values"]
    effects = () if written["model"] == "nominal" else res.named_effects
    if written["model"] != "corrected":
        lines[3:3] = [f"# written: {written['model']}: {written['reason']}"]
    if layout_path is not None or options is not None:
        lines.append("[model]")
        if layout_path is not None:
            lines.append(f"layout = {json.dumps(str(Path(layout_path).resolve()))}")
        if options is not None:
            from imutherm.studies.fitted_model import OPTION_FIELDS
            for name in OPTION_FIELDS:
                v = getattr(options, name)
                if v is not None:
                    lines.append(f"{name} = {json.dumps(v)}")
        lines.append("")
    data = result_json(res)
    lines.append("[correlation]")
    lines.append(f"verdict = {json.dumps(res.verdict)}")
    lines.append(f"written_model = {json.dumps(written['model'])}")
    for key in ("rms_before_K", "rms_after_K", "heldout_rms_before_K", "heldout_rms_after_K", "noise_K"):
        v = data.get(key)
        if v is not None and np.isfinite(v):
            lines.append(f"{key} = {float(v):.6g}")
    lines.append(f"after_from = {json.dumps(data['after_from'])}")
    rows = reading_rows(res)
    if len(rows) <= MAX_TOML_READINGS:  # the readings side by side, for the report of a study run on this model
        lines.append("readings = [  # rises over the ambient [K]: measured, nominal, corrected (see readings.csv)")
        lines += ["    {" + ", ".join(f"{k} = {_toml_value(v)}" for k, v in r.items()) + "}," for r in rows]
        lines.append("]")
    lines += ["", "[retune]"]
    for k, _ in K.RETUNE:
        if k.name in values:
            lines.append(f"{k.name} = {values[k.name]:.6g}   # {K.RETUNE_SOURCES[k.name]}")
    for name, why in FORM_KNOBS.items():
        if name in values and name not in effects:
            lines.append(f"{name} = {values[name]:.6g}   # {why}")
    lines += ["", "# the named effects, in the order forward selection added them (one line each)", "[effects]"]
    for name in effects:
        e = effect_of(name)
        lines.append(f'"{name}" = {{ {e.params[0].name} = {values[name]:.6g} }}')
    if effects:
        lines.append("# imutherm solve " + " ".join(f"--effect {n}:{effect_of(n).params[0].name}="
                                                     f"{values[n]:.6g}" for n in effects))
    if res.discrepancy is not None:  # a statistical term of the fit, not a model input: recorded, not applied
        lines += ["", f"# discrepancy term (prior scale {res.discrepancy['prior_fraction']:.3g} of each site's rise, estimated "
                      f"from the data; "
                      f"{'supported' if res.discrepancy['supported'] else 'not supported'} by the data, "
                      f"RMS {res.discrepancy['rms_K']:.3g} K): {res.discrepancy['words']}"]
    return "\n".join(lines) + "\n"
