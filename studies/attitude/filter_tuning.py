"""The one tuning procedure of the attitude filters, ours and the peers alike.

Each filter's axes are declared once, in the registry (:class:`imutherm.imu.filters.registry.Tuned`: a start
span, bounds, a mode value such as tau_acc 0); every value lies on one ladder, 10^(k/2) (a x3.16 step for
every parameter of every filter); the full product of the axes is tried, and while the best lies on the open
edge of an axis that axis grows a step (its product with the others tried too), up to the axis's bounds: the
chosen value is interior, a mode value, or at a stated bound, never at the edge of a span someone happened to
pick. The lowest score wins (ties: the first in grid order); the filter's published defaults are a candidate
too. :func:`search` is the procedure on any ``evaluate(point) -> score``; two users run it:

* the study's settings (:func:`tune`, ``benchmarks/tune_study_filters.py``, which writes
  ``studies/attitude/filter_settings.toml``): each point run on the motion profiles of :data:`PROFILES` (default
  durations, the study's lever arms and sensor grade) for the tuning seeds :data:`SEEDS` (100, 101: the
  study's answer uses seeds 0-2, so the settings are not fitted to the data they are scored on);
  score = mean over the seeds of (roll RMS + pitch RMS) / 2 [deg] over the whole record. The samples are
  those of the study: unit drawn from the seed, calibrated, improved compensation; the dies warm up as a
  first-order step of +10 K with tau = 85 s from 25 °C (the study's air scheme: +11.1 K at the dies,
  t95 = 255 s, i.e. tau ≈ t95 / 3), so the bias loops see a warm-up drift;
* the held-out benchmark (:func:`imutherm.studies.attitude.filter_benchmark.tune`, ``benchmarks/bench_attitude.py``) on
  its own disturbed training records.
"""

from __future__ import annotations

import dataclasses
import itertools
from dataclasses import replace

import numpy as np

from imutherm import InputError

#: the procedure in one line (written into the settings file)
PROCEDURE = ("the registry's tuning axes on one x3.16 ladder, the full product tried, an axis grown a step while "
             "the best lies on its open edge (up to its bounds); the published defaults a candidate too; lowest "
             "score wins")
#: the profiles tuned: the study's (flight, swing) and the attitude command's other motion profiles, whose
#: settings also serve the recorded-log platforms (:data:`imutherm.studies.attitude.recorded.PLATFORM_PROFILE`). Not
#: ``static``: at rest every setting holds and there is nothing to tune
PROFILES = ("flight", "swing", "vehicle", "handheld", "shake")
SEEDS = (100, 101)
GRADE = "adis16355"
WARMUP_K, WARMUP_TAU_S, T0_C = 10.0, 85.0, 25.0


def grid_points(grid: dict) -> list[dict]:
    """The product of a grid as a list of {field: value} (``a+b`` keys split into their fields)."""
    keys = list(grid)
    out = []
    for combo in itertools.product(*(grid[k] for k in keys)):
        pt = {}
        for k, v in zip(keys, combo):
            if "+" in k:
                pt.update(dict(zip(k.split("+"), v)))
            else:
                pt[k] = v
        out.append(pt)
    return out


def label(ax) -> str:
    """An axis's grid key: its field, and the fields moved with it joined by ``+``."""
    return "+".join((ax.field,) + tuple(ax.derived))


def _axis_values(ax, ks) -> list:
    """An axis's grid values in order: its mode values, then the ladder; a tuple where fields move together."""
    out = []
    for v in list(ax.off) + [ax.value(k) for k in ks]:
        pt = ax.point(v)
        out.append(tuple(pt.values()) if ax.derived else v)
    return out


def search(axes, evaluate, max_rounds: int = 20) -> dict:
    """The procedure of the module docstring on one filter's axes; ``evaluate(point) -> score`` [deg].

    Returns {values, grid, scores, score, at_bound, evaluations}: the best point, the final grid ({label:
    values}, as :func:`grid_points` reads it), the scores of its points in grid order, the axes whose best
    value sits at a bound, and how many points were run (each once)."""
    ks = [ax.start() for ax in axes]
    memo = {}
    for _ in range(max_rounds):
        grid = {label(ax): _axis_values(ax, k) for ax, k in zip(axes, ks)}
        pts = grid_points(grid)
        scores = []
        for pt in pts:
            key = tuple(sorted(pt.items()))
            if key not in memo:
                memo[key] = float(evaluate(pt))
            scores.append(memo[key])
        best = int(np.argmin(scores))
        grown, at_bound = False, []
        for ax, k in zip(axes, ks):
            v = pts[best][ax.field]
            if v in ax.off:
                continue
            kb = ax.rung(v)
            for edge, nxt in ((k[0], k[0] - 1), (k[-1], k[-1] + 1)):
                if kb != edge:
                    continue
                if ax.within(nxt):
                    k.insert(0, nxt) if nxt < edge else k.append(nxt)
                    grown = True
                else:
                    at_bound.append(ax.field)
        if not grown:
            break
    return {"values": pts[best], "grid": grid, "scores": scores, "score": scores[best], "at_bound": at_bound,
            "evaluations": len(memo)}


def default_values(name: str) -> dict:
    """The defaults of a filter's tuned fields (its registry ``params_cls``'s field defaults)."""
    from imutherm.imu.filters.registry import REGISTRY

    d = {f.name: f.default for f in dataclasses.fields(REGISTRY[name].params_cls)}
    return {k: d[k] for ax in REGISTRY[name].tuning for k in (ax.field, *ax.derived)}


def tune_filter(name: str, evaluate) -> dict:
    """:func:`search` on ``name``'s registry axes, then its defaults (``evaluate(None)``) as a candidate: the
    result of :func:`search` plus ``default_score``, ``chosen`` ('grid' | 'defaults') and ``why`` (the axes'
    spans in words). InputError for a filter without axes."""
    from imutherm.imu.filters.registry import REGISTRY, tuned_filters

    if name not in tuned_filters():
        raise InputError(f"tune: filter {name!r} is unknown or declares no tuning axes; valid: "
                         f"{', '.join(tuned_filters())}")
    axes = REGISTRY[name].tuning
    r = search(axes, evaluate)
    r["default_score"] = float(evaluate(None))
    r["chosen"] = "grid"
    if r["default_score"] < r["score"]:  # the published defaults are a candidate too
        r.update(values=default_values(name), score=r["default_score"], chosen="defaults")
    r["why"] = "; ".join(ax.why for ax in axes)
    return r


# --------------------------------------------------------------------------- the study's settings
def tuning_samples(profile: str, seed: int):
    """(traj, samples, lever arm, GateConfig, FusionParams) of one tuning run: the study's chain at a first-order
    warm-up; the fusion peer's gyro range is the grade's full scale, as in the study."""
    from imutherm.imu import motion
    from imutherm.imu.calibration import calibrate_unit
    from imutherm.imu.compensation import compensate
    from imutherm.imu.filters.fusion_peer import fusion_params_of_grade
    from imutherm.imu.sensor_model import draw_unit, load_grade, simulate_imu
    from imutherm.imu.filters.run import GateConfig
    from imutherm.imu.motion import DEFAULT_LEVER_ARM
    from imutherm.studies.attitude.attitude_study import leveling_window_s

    g = load_grade(GRADE)
    d = DEFAULT_LEVER_ARM[profile]
    traj = motion.make_profile(profile, None, g.sample_rate_hz, lever_arm=d)
    rng = np.random.default_rng(seed)
    unit = draw_unit(g, rng)
    cal = calibrate_unit(unit, rng)
    temp = np.tile((T0_C + WARMUP_K * (1.0 - np.exp(-traj.t / WARMUP_TAU_S)))[:, None], (1, 6))
    raw = simulate_imu(unit, traj.t, traj.omega_b, traj.f_b, temp, rng)
    samp = compensate(raw, cal, "improved", out_of_range="linear")
    gate = replace(GateConfig(), init_s=leveling_window_s(traj, GateConfig()))
    return traj, samp, d, gate, fusion_params_of_grade(g)


def score(traj, est) -> float:
    """(roll RMS + pitch RMS) / 2 [deg], whole record."""
    from imutherm.studies.attitude.attitude_study import error_metrics

    m = error_metrics(est.roll - traj.roll, est.pitch - traj.pitch, {"all": np.ones(traj.t.size, bool)})["all"]
    return 0.5 * (m["roll_rms_deg"] + m["pitch_rms_deg"])


def tune(profiles=PROFILES, seeds=SEEDS, filters=None, log=print) -> dict:
    """The study's settings: {profile: {filter: :func:`tune_filter` result}} (filters None: every one with
    axes, :func:`~imutherm.imu.filters.registry.tuned_filters`)."""
    from imutherm.imu.filters.registry import tuned_filters
    from imutherm.imu.filters.run import run_filters

    filters = tuned_filters() if filters is None else filters
    out = {}
    for prof in profiles:
        runs = [tuning_samples(prof, s) for s in seeds]
        out[prof] = {}
        for name in filters:
            def evaluate(pt, name=name):
                vals = []
                for traj, samp, d, gate, fusion in runs:
                    est, _ = run_filters(samp.gyro, samp.accel, float(traj.t[1] - traj.t[0]), d, gate,
                                         design={"fusion": fusion}, names=(name,),
                                         settings=None if pt is None else {name: pt})
                    vals.append(score(traj, est[name]))
                return float(np.mean(vals))

            r = tune_filter(name, evaluate)
            out[prof][name] = r
            log(f"{prof:8s} {name:9s} best {r['values']} {r['score']:.3f} deg (defaults {r['default_score']:.3f}); "
                f"{r['evaluations']} points, grid {r['grid']}" + (f"; at bound {r['at_bound']}" if r["at_bound"] else ""))
    return out
