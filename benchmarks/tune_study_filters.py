"""Tune every attitude filter of the study by the one procedure and write ``studies/attitude/filter_settings.toml``.

The procedure and the tuning records are :mod:`imutherm.studies.attitude.filter_tuning` (the registry's axes on one
x3.16 ladder, grown while the best lies on an open edge, the published defaults a candidate too; the study's
chain at a warm-up, tuning seeds 100, 101, disjoint from the answer's 0-2); this script runs it and writes the
file with the provenance of every entry (grid, scores, seeds, the command).

Usage::

    python benchmarks/tune_study_filters.py [--out studies/attitude/filter_settings.toml]
        [--seeds 100,101] [--profiles flight,swing] [--filters gated,kf,...]

Prints each filter's grid scores and the choice; CPU time at the end.
"""

from __future__ import annotations

import argparse
import datetime as _dt
import sys
import time
from pathlib import Path

import numpy as np

from imutherm.imu.filters.registry import tuned_filters
from imutherm.studies.attitude.filter_tuning import GRADE, PROCEDURE, PROFILES, SEEDS, T0_C, WARMUP_K, WARMUP_TAU_S, tune


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
    lines = ["# Tuned attitude-filter settings of the study (imutherm.studies.attitude.filter_settings).",
             "# Written by benchmarks/tune_study_filters.py; do not edit by hand, rerun the command below.", "",
             "[meta]",
             f"procedure = {_toml_value(PROCEDURE)}",
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
            lines.append(f"spans = {_toml_value(r['why'])}")
            lines.append(f"at_bound = {_toml_value(list(r['at_bound']))}")
            lines.append(f"chosen = {_toml_value(r['chosen'])}")
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
    ap.add_argument("--out", default=str(root / "studies" / "attitude" / "filter_settings.toml"))
    ap.add_argument("--seeds", default=",".join(map(str, SEEDS)))
    ap.add_argument("--profiles", default=",".join(PROFILES))
    ap.add_argument("--filters", default=",".join(tuned_filters()))
    a = ap.parse_args(argv)
    seeds = tuple(int(s) for s in a.seeds.split(","))
    if set(seeds) & {0, 1, 2}:
        print("tune_study_filters: --seeds must not include the answer's seeds 0, 1, 2", file=sys.stderr)
        return 2
    filters = tuple(f for f in a.filters.split(",") if f)
    bad = [f for f in filters if f not in tuned_filters()]
    if bad:
        print(f"tune_study_filters: --filters {', '.join(bad)} unknown or not tuned; valid: "
              f"{', '.join(tuned_filters())}", file=sys.stderr)
        return 2
    t0 = time.process_time()
    res = tune(tuple(a.profiles.split(",")), seeds, filters)
    cpu = time.process_time() - t0
    cmd = "python benchmarks/tune_study_filters.py" + "".join(
        f" --{k} {v}" for k, v in (("seeds", a.seeds), ("profiles", a.profiles), ("filters", a.filters))
        if v != {"seeds": ",".join(map(str, SEEDS)), "profiles": ",".join(PROFILES),
                 "filters": ",".join(tuned_filters())}[k])
    write_settings(Path(a.out), res, seeds=seeds, command=cmd, cpu_s=cpu)
    print(f"wrote {a.out} (CPU {cpu:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
