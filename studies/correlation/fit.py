"""One fitted model: the bounded least-squares fit of the re-tune knobs plus candidate effects, scored by AICc
(or the evidence, with the discrepancy term) and on held-out data.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from imutherm import InputError
from imutherm.unit import knobs
from imutherm.unit.effects import effect_of
from imutherm.thermal.reduced import Knob
from imutherm.studies.correlation.discrepancy import Discrepancy, residuals_with_term
from imutherm.studies.correlation.forward_model import ForwardModel


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


def effects_of(name) -> tuple:
    """'none' -> (); 'a' -> ('a',); 'a+b' or ('a', 'b') -> ('a', 'b')."""
    if isinstance(name, (tuple, list)):
        return tuple(name)
    return () if name == "none" else tuple(name.split("+"))


def _label(effects: tuple) -> str:
    return "+".join(effects) if effects else "none"


def _knobs_for(name, fwd: ForwardModel) -> list:
    """Re-tune knobs (with the form knobs, :data:`FORM_RETUNE`) plus the candidate's (none: re-tune only); an
    emissivity effect replaces the re-tune's, a form knob given as a candidate leaves the re-tune;
    a ``power@part`` candidate cannot take the part below zero power (:func:`~imutherm.unit.knobs.power_floor_W`).
    ``name``: one effect, 'none', or several ('a+b' or a tuple: one knob each, in that order)."""
    ks = [k for k, _ in knobs.RETUNE] + [knobs.effect_knob(n, fwd.options) for n in fwd.form]
    effects = effects_of(name)
    replaced = {effect_of(n).replaces for n in effects}  # an outer emissivity effect takes the re-tune's knob
    ks = [k for k in ks if k.name not in replaced]
    ks = [k for k in ks if k.name not in effects]
    for n in effects:
        e = effect_of(n)
        p = e.params[0]
        if e.kind == "signal":
            ks.append(Knob(n, p.unit, p.lo, p.hi, log=p.log))
            continue
        floor = (knobs.power_floor_W(fwd.geometries.values(), n, [r.power_scale for r in fwd.runs])
                 if e.part_power else None)
        ks.append(knobs.effect_knob(n, fwd.options, min_power_W=floor))
    return ks


class _Objective:
    """The least-squares problem of one fit in the knob coordinate u in [-1, 1]: the residual after the
    discrepancy term on ``train`` plus the re-tune knobs' weak prior ``prior_K`` (u - u0)
    (see :func:`fit_candidate`)."""

    def __init__(self, fwd: ForwardModel, ks: list, fixed: dict, train: dict, u0: np.ndarray, n_retune: int,
                 prior_K: float, label: str):
        self.fwd, self.ks, self.fixed, self.train = fwd, ks, fixed, train
        self.u0, self.n_retune, self.prior_K, self.label = u0, n_retune, prior_K, label

    def vals(self, u) -> dict:
        """Knob name -> value [unit] at ``u`` (the fixed knobs included)."""
        return {**self.fixed, **{k.name: float(k.from_u(x)) for k, x in zip(self.ks, u)}}

    def fun(self, u, d):
        res, pen, _ = residuals_with_term(self.fwd, self.vals(u), self.train, d)
        return np.concatenate([res, self.prior_K * (u[:self.n_retune] - self.u0[:self.n_retune]), pen])

    def solve(self, starts, d):
        """The best of bounded least-squares runs from ``starts`` (with the discrepancy term ``d`` or None)."""
        best = None
        for s in starts:
            try:
                r = least_squares(self.fun, s, bounds=(-1.0, 1.0), x_scale=1.0, xtol=1e-6, ftol=1e-8, max_nfev=200,
                                  args=(d,))
            except (np.linalg.LinAlgError, ValueError):
                continue
            if best is None or r.cost < best.cost:
                best = r
        if best is None:
            raise InputError(f"correlate: the fit of {self.label!r} failed")
        return best

    def prior_penalty(self, x) -> float:
        """Σ (prior_K (u - u0))² [K²] over the re-tune knobs at ``x``."""
        u_pen = self.prior_K * (x[:self.n_retune] - self.u0[:self.n_retune])
        return float(u_pen @ u_pen)


def _starts(ks: list, fwd: ForwardModel, n_retune: int, start: dict | None) -> tuple:
    """(u0, us): the re-tune knobs' nominal (or the layout's value) and the effects' mid-range in u [-1, 1],
    and the start point, ``start``'s values where given."""
    # start at the nominal (re-tune) / mid-range (effect) in the knob coordinate u in [-1, 1]
    u0 = np.array([float(k.to_u(knobs.RETUNE_NOMINAL[k.name])) if k.name in knobs.RETUNE_NOMINAL else 0.0
                   for k in ks])
    base = fwd.nominal
    for k in ks:
        if k.name in base:
            u0[ks.index(k)] = float(np.clip(k.to_u(base[k.name]), -1, 1))
    us = u0.copy()
    for k in ks[n_retune:]:
        if start and k.name in start:
            us[ks.index(k)] = float(np.clip(k.to_u(start[k.name]), -1, 1))
    if start:
        for idx, k in enumerate(ks[:n_retune]):
            if k.name in start:
                us[idx] = float(np.clip(k.to_u(start[k.name]), -1, 1))
    return u0, us


def _fit_term(obj: _Objective, best, disc: Discrepancy, us, hint: dict | None, n_eff_ratio: float) -> tuple:
    """(best least-squares result, prior scales p_hat, C(p_hat), the term at p_hat) of a fit with the term;
    ``hint``: the effects' values fitted without the term, a further start (None: none)."""
    fwd, train, prior_K = obj.fwd, obj.train, obj.prior_K

    # the term's prior scales for this fit, by type-II maximum likelihood at the fitted knobs; the knobs
    # re-fitted once at them when one moved by more than 2x (so a model an effect explains fits without a term)
    def refit(r, d):
        p, _ = d.profile(fwd, obj.vals(r.x), train)
        if any(abs(math.log(p[g] / d.priors.get(g, p[g]))) > math.log(2.0) for g in p):
            d = d.with_prior(p)
            r = obj.solve([r.x], d)
        p, C = d.profile(fwd, obj.vals(r.x), train)
        return r, p, C

    def score(r, C):  # -2 log evidence up to the terms every fit of this name shares
        return C + n_eff_ratio * prior_K**2 * float(np.sum((r.x[:obj.n_retune] - obj.u0[:obj.n_retune]) ** 2)) \
            / disc.sigma_K**2

    best, p_hat, C_hat = refit(best, disc)
    if hint:
        # also from the effect's fit without the term (``hint``): at a large common scale the term takes what
        # the effect would explain and the effect's knob does not move from its start (the search stalls)
        uh = us.copy()
        for idx, k in enumerate(obj.ks):
            if k.name in hint:
                uh[idx] = float(np.clip(k.to_u(hint[k.name]), -1, 1))
        p0, _ = disc.profile(fwd, obj.vals(uh), train)
        alt = refit(obj.solve([uh], disc.with_prior(p0)), disc.with_prior(p0))
        if score(alt[0], alt[2]) < score(best, C_hat):
            best, p_hat, C_hat = alt
    return best, p_hat, C_hat, disc.with_prior(p_hat)


def _intervals(ks: list, best, n: int, rss: float, ne: float) -> dict:
    """Knob name -> 95 % interval (lo, hi) [unit] from the Jacobian at the fit, inflated by n / n_eff."""
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
    return ci


def _rms_by(fwd: ForwardModel, parts) -> tuple:
    """[(run i, values)] -> RMS [K] over all, and per scheme."""
    by = {}
    for i, x in parts:
        by.setdefault(fwd.runs[i].scheme, []).append(x)
    every = np.concatenate([x for _, x in parts]) if parts else np.zeros(0)
    return (float(np.sqrt(np.mean(every**2))) if len(every) else math.nan,
            {g: float(np.sqrt(np.mean(np.concatenate(xs) ** 2))) for g, xs in by.items()})


def fit_candidate(fwd: ForwardModel, name, train: dict, test: dict | None, n_eff_ratio: float, prior_K: float,
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
    ``fixed``: re-tune knobs held at the given values (not fitted; :mod:`imutherm.studies.correlation.findings`).
    """
    effects = effects_of(name)
    fixed = dict(fixed or {})
    ks = [k for k in _knobs_for(effects, fwd) if k.name not in fixed]
    n_retune = len(ks) - len(effects)
    u0, us = _starts(ks, fwd, n_retune, start)
    obj = _Objective(fwd, ks, fixed, train, u0, n_retune, prior_K, _label(effects))
    starts = [us] if not effects else [np.where(np.arange(len(ks)) == len(ks) - 1, s, us) for s in (-0.6, 0.0, 0.6)]
    best = obj.solve(starts, disc)
    p_hat, C_hat = {}, math.nan
    if disc is not None:
        best, p_hat, C_hat, disc = _fit_term(obj, best, disc, us, hint if effects else None, n_eff_ratio)
    v = obj.vals(best.x)
    res, pen, coefs = residuals_with_term(fwd, v, train, disc)
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
        aicc = (C_hat + n_eff_ratio * obj.prior_penalty(best.x) / disc.sigma_K**2 + 2 * k_par
                + 2 * k_par * (k_par + 1) / (ne - k_par - 1) if ne > k_par + 1 else math.nan)
    hr, hm = math.nan, math.nan
    if test is not None and any(m.any() for m in test.values()):
        rt, _, _ = residuals_with_term(fwd, v, test, disc, coefs if disc is not None else None)
        hr, hm = float(np.sqrt(np.mean(rt**2))), float(np.abs(rt).max())
    at_bound = tuple(k.name for k, x in zip(ks, best.x) if abs(x) > 0.995)
    ci = _intervals(ks, best, n, rss, ne)
    sig, sig_by = math.nan, {}
    if effects:  # what the last-added effect changes at the readings, the rest as fitted
        rest = {kk: x for kk, x in v.items() if kk != effects[-1]}
        sig, sig_by = _rms_by(fwd, [(i, (fwd.rise(i, v) - fwd.rise(i, rest))[m]) for i, m in train.items() if m.any()])
    d_rms, disc_by = math.nan, {}
    if disc is not None:
        d_rms, disc_by = _rms_by(fwd, [(i, disc.basis[(i, j)][train[i][:, j]] @ c) for (i, j), c in coefs.items()])
        d_rms = 0.0 if not coefs else d_rms
    return Fit(_label(effects), v, float(np.sqrt(rss / n)), float(np.abs(res).max()), n, float(ne), k_par,
               float(aicc), hr, hm, at_bound, ci, effects, coefs, sig, "aicc" if disc is None else "evidence",
               float(best.fun @ best.fun), max(p_hat.values()) if p_hat else math.nan, d_rms, dict(p_hat),
               disc_by, sig_by)


def fit_with(f: Fit, **changes) -> Fit:
    from dataclasses import replace
    return replace(f, **changes)
