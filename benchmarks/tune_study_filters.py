"""Tune every attitude filter of the study by one procedure and write ``studies/filter_settings.toml``.

The procedure (the same for ours and the peers): a small stated grid per filter over its main gain /
time-constant parameters (:data:`GRIDS`); each point is run on the study's profiles (``flight``, ``swing``,
default durations, the study's lever arms and sensor grade) for the tuning seeds (default 100, 101: the study's
answer uses seeds 0-2, so the settings are not fitted to the data they are scored on); score = mean over the
seeds of (roll RMS + pitch RMS) / 2 [deg] over the whole record; the lowest score wins (ties: the first in
grid order). The samples are those of the study: unit drawn from the seed, calibrated, improved compensation;
the dies warm up as a first-order step of +10 K with tau = 85 s from 25 °C (the study's air scheme: +11.1 K
at the dies, t95 = 255 s, i.e. tau ≈ t95 / 3), so the bias loops see a warm-up drift.

Usage::

    .venv/bin/python benchmarks/tune_study_filters.py [--out studies/filter_settings.toml]
        [--seeds 100,101] [--profiles flight,swing] [--filters gated,kf,...]

Prints each filter's grid scores and the choice; CPU time at the end.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import itertools
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

#: filter -> {field: grid values}; the full product is tried. Pairs that move together are given as one
#: tuple-valued field name "a+b" (values: tuples).
GRIDS = {
    "gated": {"tau_acc": [0.0, 1.0, 3.0, 10.0, 30.0], "kp": [0.03, 0.1, 0.3, 1.0]},
    "kf": {"tau_acc": [0.0, 1.0, 3.0], "q": [2e-7, 2e-6, 2e-5, 2e-4]},
    "ungated": {"kp+ki": [(k, k * k / 30.0) for k in (0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0)]},
    "fusion": {"gain": [0.005, 0.02, 0.1, 0.5], "rejection_timeout": [5.0, 30.0, 120.0, 600.0]},
    "vqf": {"tauAcc": [1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0]},
    "aekf": {"tau_acc": [0.0, 1.0], "memory_s": [2.0, 5.0, 20.0]},
    "madgwick": {"gain": [0.0003, 0.001, 0.003, 0.01, 0.033, 0.1]},
    "mahony": {"k_P+k_I": [(k, 0.3 * k * k) for k in (0.003, 0.01, 0.03, 0.1, 0.3, 1.0)]},
    "ekf": {"var_acc": [0.25, 2.5, 25.0, 250.0, 2500.0, 25000.0]},
}
#: what the grid spans, per filter (written into the file)
WHY = {
    "gated": "tau_acc 0 = the seed's per-sample gate; kp the correction gain (kp_lp in the low-pass mode)",
    "kf": "tau_acc 0 = the seed's window mean and gate 1; q the process noise of the gravity direction",
    "ungated": "(kp [1/s], ki [1/s^2]) along the seed's ratio ki = kp^2 / 30 (0.3, 0.003), the gate always open",
    "fusion": "gain and the acceleration-rejection timeout [s] of x-io Fusion",
    "vqf": "tauAcc [s], VQF's accelerometer low-pass time constant (its main tuning parameter)",
    "aekf": "tau_acc 0 = block mean; memory_s the fading memory of the adaptation laws",
    "madgwick": "gain [rad/s] (published default 0.033)",
    "mahony": "(k_P [1/s], k_I [1/s^2]) along k_I = 0.3 k_P^2 (published default (1, 0.3))",
    "ekf": "var_acc [-] of the unit gravity vector (published default 0.25)",
}
PROFILES = ("flight", "swing")
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


def tuning_samples(profile: str, seed: int):
    """(traj, samples, lever arm, GateConfig, FusionParams) of one tuning run: the study's chain at a first-order
    warm-up; the fusion peer's gyro range is the grade's full scale, as in the study."""
    from imutherm.imu import motion
    from imutherm.imu.calibration import calibrate_unit
    from imutherm.imu.compensation import compensate
    from imutherm.imu.filters.fusion_peer import fusion_params_of_grade
    from imutherm.imu.sensor_model import draw_unit, load_grade, simulate_imu
    from imutherm.studies.attitude_study import DEFAULT_LEVER_ARM, GateConfig, leveling_window_s

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
    from imutherm.studies.attitude_study import error_metrics

    m = error_metrics(est.roll - traj.roll, est.pitch - traj.pitch, {"all": np.ones(traj.t.size, bool)})["all"]
    return 0.5 * (m["roll_rms_deg"] + m["pitch_rms_deg"])


def tune(profiles=PROFILES, seeds=SEEDS, filters=tuple(GRIDS), log=print) -> dict:
    """{profile: {filter: {values, grid, scores, score, default_score}}}."""
    from imutherm.studies.attitude_study import run_filters

    out = {}
    for prof in profiles:
        runs = [tuning_samples(prof, s) for s in seeds]
        out[prof] = {}
        for name in filters:
            pts = grid_points(GRIDS[name])
            scores = []
            for pt in pts:
                vals = []
                for traj, samp, d, gate, fusion in runs:
                    est, _ = run_filters(samp.gyro, samp.accel, float(traj.t[1] - traj.t[0]), d, gate,
                                         fusion=fusion, names=(name,), settings={name: pt})
                    vals.append(score(traj, est[name]))
                scores.append(float(np.mean(vals)))
            dflt = []
            for traj, samp, d, gate, fusion in runs:
                est, _ = run_filters(samp.gyro, samp.accel, float(traj.t[1] - traj.t[0]), d, gate, fusion=fusion,
                                     names=(name,))
                dflt.append(score(traj, est[name]))
            best = int(np.argmin(scores))
            out[prof][name] = {"values": pts[best], "grid": GRIDS[name], "scores": scores, "score": scores[best],
                               "default_score": float(np.mean(dflt))}
            log(f"{prof:7s} {name:9s} best {pts[best]} {scores[best]:.3f} deg (defaults {np.mean(dflt):.3f}); "
                f"grid {', '.join(f'{s:.3f}' for s in scores)}")
    return out


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float, np.floating)):
        return repr(float(v)) if isinstance(v, (float, np.floating)) else str(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {v!r} to TOML")


def write_settings(path: Path, result: dict, *, seeds, command: str, cpu_s: float) -> None:
    """The settings file: [meta] and one [profile.filter] table per tuned filter."""
    data = (f"{GRADE}, default-duration profiles, study lever arms, improved compensation calibrated in the unit, "
            f"first-order warm-up +{WARMUP_K:g} K tau {WARMUP_TAU_S:g} s from {T0_C:g} C")
    lines = ["# Tuned attitude-filter settings of the study (imutherm.studies.filter_settings).",
             "# Written by benchmarks/tune_study_filters.py; do not edit by hand, rerun the command below.", "",
             "[meta]",
             f"procedure = {_toml_value('one grid per filter (grid), the full product tried; lowest score wins')}",
             f"objective = {_toml_value('mean over seeds of (roll RMS + pitch RMS) / 2 [deg], whole record')}",
             f"data = {_toml_value(data)}",
             f"seeds = {_toml_value(list(seeds))}",
             f"answer_seeds = {_toml_value('0, 1, 2 (imutherm compare): disjoint from the tuning seeds')}",
             f"command = {_toml_value(command)}",
             f"date = {_toml_value(_dt.date.today().isoformat())}",
             f"cpu_s = {cpu_s:.1f}", ""]
    for prof, by in result.items():
        for name, r in by.items():
            lines.append(f"[{prof}.{name}]")
            lines.append("values = { " + ", ".join(f"{k} = {_toml_value(v)}" for k, v in r["values"].items()) + " }")
            lines.append("grid = { " + ", ".join(f'"{k}" = {_toml_value(v)}' for k, v in r["grid"].items()) + " }")
            lines.append(f"spans = {_toml_value(WHY[name])}")
            lines.append(f"seeds = {_toml_value(list(seeds))}")
            lines.append(f"score = {r['score']:.4f}")
            lines.append(f"default_score = {r['default_score']:.4f}")
            lines.append("scores = " + _toml_value([round(s, 4) for s in r["scores"]]))
            lines.append(f"command = {_toml_value(command)}")
            lines.append("")
    path.write_text("\n".join(lines))


def main(argv=None) -> int:
    root = Path(__file__).resolve().parent.parent
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(root / "studies" / "filter_settings.toml"))
    ap.add_argument("--seeds", default=",".join(map(str, SEEDS)))
    ap.add_argument("--profiles", default=",".join(PROFILES))
    ap.add_argument("--filters", default=",".join(GRIDS))
    a = ap.parse_args(argv)
    seeds = tuple(int(s) for s in a.seeds.split(","))
    if set(seeds) & {0, 1, 2}:
        print("tune_study_filters: --seeds must not include the answer's seeds 0, 1, 2", file=sys.stderr)
        return 2
    filters = tuple(f for f in a.filters.split(",") if f)
    bad = [f for f in filters if f not in GRIDS]
    if bad:
        print(f"tune_study_filters: --filters {', '.join(bad)} unknown; valid: {', '.join(GRIDS)}", file=sys.stderr)
        return 2
    t0 = time.process_time()
    res = tune(tuple(a.profiles.split(",")), seeds, filters)
    cpu = time.process_time() - t0
    cmd = "python benchmarks/tune_study_filters.py" + "".join(
        f" --{k} {v}" for k, v in (("seeds", a.seeds), ("profiles", a.profiles), ("filters", a.filters))
        if v != {"seeds": ",".join(map(str, SEEDS)), "profiles": ",".join(PROFILES),
                 "filters": ",".join(GRIDS)}[k])
    write_settings(Path(a.out), res, seeds=seeds, command=cmd, cpu_s=cpu)
    print(f"wrote {a.out} (CPU {cpu:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
