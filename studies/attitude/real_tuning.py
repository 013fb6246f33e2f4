"""The filters' real-motion settings: the one tuning procedure on the real development files, cross-validated by
file.

Data: every file of :func:`imutherm.studies.attitude.real_benchmark.data_files` (six RepoIMU pendulum trials, three
BROAD trials), prepared and scored as :mod:`imutherm.studies.attitude.real_benchmark` does (inclination RMS per file).

Procedure, the same for every filter with tuning axes, ours and the peers (:func:`tune`):

* the search is :func:`imutherm.studies.attitude.filter_tuning.tune_filter`: the registry's axes on one x3.16 ladder,
  the product grown while the best lies on an open edge, the library defaults a candidate too;
* a point runs the filter at ``BASE`` (physical settings of our low-pass modes that are not tuned) plus the point;
  the defaults candidate runs the library defaults alone;
* objective: the mean over the training files of ln(RMS) (a geometric mean: the files' RMS span 0.3-8°, and an
  arithmetic mean would let the hardest file choose for all); the arithmetic mean is what the benchmark reports;
* guard: a point that makes any training file worse than the library defaults by more than that file's noise
  (:func:`imutherm.studies.attitude.real_benchmark.score`'s ``noise_deg``, the standard error of its RMS over ten
  blocks) is not eligible: its score is raised by :data:`GUARD_PENALTY` plus its excess (the sum of ln(RMS / (default +
  noise)) over the files it breaks), so it ranks behind every eligible point and behind the defaults (which are
  eligible by definition), while the search still knows which ineligible points come nearer;
* development figures (:func:`tune` ``dev``): tuned on all files, scored on the same files: a fitted figure;
* cross-validated figures (``cv``): leave one file out: for each file, the procedure run on the other files
  (both data sets in every training set), the chosen setting scored on the file it never saw.

Runs are cached by (filter, point, file), so the folds share the runs they have in common.
"""

from __future__ import annotations

import math

import numpy as np

#: settings of our low-pass modes fixed by the sensor, not tuned: the kf measures every sample in its low-pass mode
#: (the low-pass replaces the KF paper's window mean), and the kf and aekf add the gyro scale-factor uncertainty of a
#: consumer MEMS gyro to their process noise (±3 % sensitivity tolerance, e.g. InvenSense MPU-6000/6050 product
#: specification, at 25 °C): fast motion makes the gyro-only prediction worse
BASE = {"kf": {"n_window": 1, "sf_std": 0.03}, "aekf": {"sf_std": 0.03}}
OBJECTIVE = ("mean over the training files of ln(inclination RMS) (geometric mean); a point making a training "
             "file worse than the library defaults by more than that file's noise is not eligible")
#: added to the score of a point the guard excludes (an ln-RMS mean is a few units at most)
GUARD_PENALTY = 100.0


def folds(names_of_files) -> list:
    """Leave-one-file-out folds: [(train (file names), test file name)], one per file; never a file in both."""
    files = list(names_of_files)
    return [([f for f in files if f != g], g) for g in files]


class Runs:
    """Cached runs of one filter on the records: ``rms(point, file)`` and ``noise(file)`` (of the defaults).
    point None: the library defaults; else a {field: value} dict run on top of :data:`BASE`."""

    def __init__(self, name, recs, log=None):
        self.name = name
        self.recs = {r.name: r for r in recs}
        self.memo = {}
        self.log = log

    def settings(self, point) -> dict:
        return {} if point is None else {self.name: {**BASE.get(self.name, {}), **point}}

    def score(self, point, file) -> dict:
        from imutherm.studies.attitude.real_benchmark import run

        key = (None if point is None else tuple(sorted(point.items())), file)
        if key not in self.memo:
            self.memo[key] = run([self.name], self.recs[file], self.settings(point))[self.name]
        return self.memo[key]

    def rms(self, point, file) -> float:
        return self.score(point, file)["rms_deg"]

    def objective(self, point, files) -> float:
        """The procedure's score of ``point`` on ``files`` (module docstring; inf where the guard excludes it)."""
        vals, excess = [], 0.0
        for f in files:
            r, d = self.rms(point, f), self.score(None, f)
            if point is not None and r > d["rms_deg"] + d["noise_deg"]:
                excess += math.log(r / (d["rms_deg"] + d["noise_deg"]))
            vals.append(math.log(r))
        return float(np.mean(vals)) + (GUARD_PENALTY + excess if excess > 0 else 0.0)


def chosen_settings(name: str, r: dict) -> dict:
    """The settings {field: value} a :func:`~imutherm.studies.attitude.filter_tuning.tune_filter` result stands for ({}:
    the library defaults)."""
    return {} if r["chosen"] == "defaults" else {**BASE.get(name, {}), **r["values"]}


def tune(name: str, recs, log=print) -> dict:
    """The module docstring's procedure for filter ``name`` on ``recs``: {"dev": {values, settings, chosen, grid,
    scores, at_bound, evaluations, files {file: rms}}, "cv": {file: {settings, rms}}, "defaults": {file: {rms,
    noise}}, "evaluations": runs made}."""
    from imutherm.studies.attitude.filter_tuning import tune_filter

    runs = Runs(name, recs)
    files = [r.name for r in recs]
    defaults = {f: {"rms": runs.rms(None, f), "noise": runs.score(None, f)["noise_deg"]} for f in files}

    def fit(train):
        r = tune_filter(name, lambda pt: runs.objective(pt, train))
        return r, chosen_settings(name, r)

    r, s = fit(files)
    pt = None if r["chosen"] == "defaults" else r["values"]
    dev = {"values": r["values"], "settings": s, "chosen": r["chosen"], "grid": r["grid"], "scores": r["scores"],
           "at_bound": r["at_bound"], "objective": r["score"], "default_objective": r["default_score"],
           "files": {f: runs.rms(pt, f) for f in files}}
    cv = {}
    for train, test in folds(files):
        rf, sf = fit(train)
        ptf = None if rf["chosen"] == "defaults" else rf["values"]
        cv[test] = {"settings": sf, "rms": runs.rms(ptf, test)}
        log(f"  {name}: fold without {test}: {sf or 'library defaults'} -> {cv[test]['rms']:.3f} deg")
    log(f"{name}: dev {s or 'library defaults'}: mean {np.mean(list(dev['files'].values())):.3f} deg; cross-validated "
        f"mean {np.mean([c['rms'] for c in cv.values()]):.3f} deg; {len(runs.memo)} runs")
    return {"dev": dev, "cv": cv, "defaults": defaults, "evaluations": len(runs.memo)}


def tune_all(names, recs, log=print) -> dict:
    """{name: :func:`tune`} for ``names``."""
    return {n: tune(n, recs, log=log) for n in names}
