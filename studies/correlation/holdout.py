"""The hold-out design (fit early, predict late; leave a file or a reading out) and the pooled held-out
figures of a fit, with the paired test of two fits' held-out errors.
"""

from __future__ import annotations

import math

import numpy as np

from imutherm import InputError
from imutherm.studies.correlation.fit import Fit, fit_candidate, fit_with
from imutherm.studies.correlation.forward_model import model_residuals, residual_series


#: a run with fewer readings than this is sparse (a paper's or a notebook's few figures)
SPARSE_READINGS = 8


def holdout_folds(runs, holdout: str | None):
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


def held_out_union(folds) -> dict:
    """run index -> bool (n, m): every reading some fold holds out."""
    out = {}
    for _, test in folds:
        for i, m in (test or {}).items():
            out[i] = out.get(i, np.zeros_like(m)) | m
    return out


def pooled_heldout(fwd, name, folds, ratio, prior, disc=None, start=None, fixed=None) -> tuple:
    """Held-out RMS and max over the folds (each fold fitted on its training set; with the discrepancy
    term, the held-out readings are predicted with the training fit's coefficients)."""
    errs, blocks = [], []
    for k, (train, test) in enumerate(folds):
        if test is None:
            return math.nan, math.nan, ()
        f = fit_candidate(fwd, name, train, None, ratio, prior, disc, start, fixed=fixed)
        for i, j, rows, r in residual_series(fwd, f.values, test):
            e = r[rows] - (disc.basis[(i, j)][rows] @ f.disc.get((i, j), np.zeros(2)) if disc is not None else 0.0)
            errs.append(e)
            blocks.append(((k, i, j), float(np.sum(e**2)), int(len(e))))
    e = np.concatenate(errs)
    return float(np.sqrt(np.mean(e**2))), float(np.abs(e).max()), tuple(blocks)


def with_heldout(f: Fit, h: tuple) -> Fit:
    """``f`` with the held-out figures of :func:`pooled_heldout`."""
    return fit_with(f, heldout_rms_K=h[0], heldout_max_K=h[1], heldout_blocks=h[2])


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


def heldout_nominal(fwd, folds, nominal) -> float:
    errs = [model_residuals(fwd, nominal, test) for _, test in folds if test is not None]
    if not errs:
        return math.nan
    e = np.concatenate(errs)
    return float(np.sqrt(np.mean(e**2))) if len(e) else math.nan
