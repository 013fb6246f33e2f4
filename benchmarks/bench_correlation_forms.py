"""Campaign at model-form errors of 2, 5 and 10 % of the rise (issue 58 item 3), with the rules set first.

RULES, set on 2026-12-07 before any case of this campaign was run, not changed after:

- **strong case**: a hidden library effect or a re-tune knob moved far whose signature (RMS change it makes at
  the readings, truth model with and without it) is >= :data:`STRONG_SIGMAS` noise sigmas;
- **named right**: the first thing named (``named_first`` of correlation.json: a finding or a library effect) is
  the hidden one; for an ambiguous verdict the proposed next experiment is made by the same generator (same
  truth, same form error), the file added and correlate run again: **settled right** when the hidden one is then
  named first; a strong case counts as named right if named right directly or settled right;
- **null**: any library name or finding where nothing was hidden is a false name;
- **written model**: its held-out RMS must not exceed the nominal model's;
- the **form error level**: a smooth error of the model's form, its RMS over a file's readings set to the level
  times the file's RMS rise; probe noise 0.05 K added after.

Targets (issue 58): strong named right >= 80 %; false names on nulls <= 5 %; ambiguous settled right >= 70 %;
written model never worse than nominal.

Generator: ``toy`` only (tests/_toy_reduced.py's closed-form rises as the truth, the correlation on the same toy
as its reduced models): the form error of each scheme is a per-site gain error of random sign and size with a
random first-order response (50-400 s), not any knob's or effect's pattern; seconds a case. These are
**development figures** (the toy is the rules' own test bed), not a blind set: a campaign on the finite-element
generator's other forms (layered contacts, the other cavity law, a grid 2-4x coarser or finer, nuisance on every
conductivity; ``benchmarks/bench_correlation.py --model-form``) takes 15-30 min a case on this machine and was
not run for this script.

    python benchmarks/bench_correlation_forms.py --cases 4 --out /tmp/forms
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))  # the toy reduced models

from imutherm.io import write_json  # noqa: E402
from imutherm.measured import MeasuredRun  # noqa: E402
from imutherm.studies.correlation import correlate, result_json  # noqa: E402

STRONG_SIGMAS = 5.0
LEVELS = (0.02, 0.05, 0.10)
NOISE_K = 0.05
CANDIDATES = ("power@reg_5v", "power@processor", "contact@bond")
#: hidden kinds and the range each value is drawn from [unit]: two regulator powers, a bond line, and two knobs
#: moved far (a finding each): the cavity's emissivity and the mount's conductance (0.35-0.5 of its nominal 500)
KINDS = {"none": None, "power@reg_5v": (0.3, 0.8), "power@processor": (0.3, 0.8), "contact@bond": (80.0, 250.0),
         "cavity_emissivity": (0.2, 0.45), "mount_h_W_m2K": (175.0, 250.0)}
SCHEMES = ("air", "grease")


def _truth(kind: str, rng) -> tuple:
    """(truth values, hidden value): ±5 % nuisance on the board, mount and convection, and the hidden value."""
    nz = {"k_board_W_mK": 17.7 * rng.uniform(0.95, 1.05), "mount_h_W_m2K": 500.0 * rng.uniform(0.95, 1.05),
          "convection_scale": rng.uniform(0.95, 1.05)}
    if KINDS[kind] is None:
        return nz, None
    v = float(rng.uniform(*KINDS[kind]))
    if kind == "power@processor":  # a missing power leaves the part at least 20 % of its own 0.35 W (the layout's)
        v = max(v * rng.choice([-1.0, 1.0]), -0.8 * 0.35)
    return {**nz, kind: v}, v


def _form(rng) -> dict:
    """scheme -> (per-site relative gain error (6,) [-], response time [s]): the form error's shape."""
    return {s: (rng.uniform(-1.0, 1.0, 6), float(rng.uniform(50.0, 400.0))) for s in SCHEMES}


def _run(truth: dict, form: dict, level: float, rng, scheme: str, sites, times, power_scale=1.0,
         name=None) -> MeasuredRun:
    """A measured file of the toy: the truth's rise, the form error at ``level`` of its RMS rise, the noise."""
    from _toy_reduced import SITES, ToyReduced
    idx = [SITES.index(s) for s in sites]
    y = ToyReduced(scheme).rise({**truth, "power_scale": truth.get("power_scale", 1.0) * power_scale}, times)
    a, tau = form[scheme]
    shape = a[None, :] * y * (1.0 - np.exp(-np.asarray(times)[:, None] / tau))
    # the level is set on the campaign's standard file (all sites, 1500 s, nominal power) and kept for any other
    t0 = np.linspace(0.0, 1500.0, 40)
    y0 = ToyReduced(scheme).rise(truth, t0)
    s0 = a[None, :] * y0 * (1.0 - np.exp(-t0[:, None] / tau))
    k = level * np.sqrt(np.mean(y0**2)) / max(np.sqrt(np.mean(s0**2)), 1e-12)
    y = (y + k * shape)[:, idx] + rng.normal(0.0, NOISE_K, (len(times), len(idx)))
    return MeasuredRun(name or f"{scheme}.csv", scheme, 70.0, power_scale, 0.0, "die", tuple(sites),
                       np.asarray(times, float), 70.0 + y, tuple(range(len(times))))


def _signature(truth: dict, kind: str) -> float:
    """RMS [K] / noise of what the hidden one changes at the standard files' readings."""
    from _toy_reduced import ToyReduced
    base = dict(truth)
    base.pop(kind, None)
    t = np.linspace(0.0, 1500.0, 40)
    d = np.concatenate([(ToyReduced(s).rise(truth, t) - ToyReduced(s).rise(base, t)).ravel() for s in SCHEMES])
    return float(np.sqrt(np.mean(d**2)) / NOISE_K)


def one_case(kind: str, level: float, seed: int, models) -> dict:
    """Generate, correlate, and for an ambiguous verdict run the proposed experiment: one row."""
    from _toy_reduced import SITES
    rng = np.random.default_rng(seed)
    truth, value = _truth(kind, rng)
    form = _form(rng)
    t = np.linspace(0.0, 1500.0, 40)
    runs = [_run(truth, form, level, rng, s, SITES, t) for s in SCHEMES]
    t0 = time.perf_counter()
    res = correlate(runs, models=models, candidates=CANDIDATES, rerun=False)
    j = result_json(res)
    w = j["written_model"] or {}
    row = {"kind": kind, "value": value, "level": level, "seed": seed, "verdict": res.verdict,
           "named_first": j["named_first"], "named_effects": list(res.named_effects),
           "findings": [f.parameter for f in res.findings], "symptoms": [x.parameter for x in res.symptoms],
           "ambiguous_set": list(res.ambiguous_set),
           "signature_sigmas": None if value is None else _signature(truth, kind),
           "written_heldout_K": w.get("heldout_rms_K"), "nominal_heldout_K": w.get("nominal_heldout_rms_K"),
           "next_experiment": res.next_experiment and {k: res.next_experiment[k] for k in
                                                       ("scheme", "power_scale", "duration_s", "probes",
                                                        "separation_K", "separation_sigmas")},
           "settled_first": None}
    if res.verdict == "ambiguous" and res.next_experiment:
        nx = res.next_experiment
        tn = np.linspace(0.0, nx["duration_s"], 40)
        extra = _run(truth, form, level, rng, nx["scheme"], nx["probes"], tn, nx["power_scale"], "next.csv")
        again = correlate(runs + [extra], models=models, candidates=CANDIDATES, rerun=False)
        row["settled_first"] = result_json(again)["named_first"]
        row["settled_verdict"] = again.verdict
    row["seconds"] = time.perf_counter() - t0
    return row


def summarise(rows: list) -> dict:
    """The campaign's figures per level, by the rules of the module docstring."""
    out = {}
    for level in sorted({r["level"] for r in rows}):
        rs = [r for r in rows if r["level"] == level]
        strong = [r for r in rs if r["value"] is not None and r["signature_sigmas"] >= STRONG_SIGMAS]
        right = [r for r in strong if r["named_first"] == r["kind"] or r["settled_first"] == r["kind"]]
        nulls = [r for r in rs if r["value"] is None]
        false = [r for r in nulls if r["named_effects"] or r["findings"]]
        amb = [r for r in rs if r["verdict"] == "ambiguous" and r["value"] is not None]
        settled = [r for r in amb if r["settled_first"] == r["kind"]]
        worse = [r for r in rs if r["written_heldout_K"] is not None and r["nominal_heldout_K"] is not None
                 and r["written_heldout_K"] > r["nominal_heldout_K"] * (1 + 1e-9)]
        out[f"{100 * level:g}%"] = {
            "strong_named_right": f"{len(right)}/{len(strong)}", "null_false_names": f"{len(false)}/{len(nulls)}",
            "ambiguous_settled_right": f"{len(settled)}/{len(amb)}", "written_worse_than_nominal": f"{len(worse)}/{len(rs)}",
            "misses": [(r["kind"], r["verdict"], r["named_first"], r["settled_first"]) for r in strong if r not in right]}
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", type=int, default=4, help="cases per hidden kind and level")
    ap.add_argument("--seed", type=int, default=58)
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    from _toy_reduced import toy_models
    models = toy_models()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows = []
    for level in LEVELS:
        for kind in KINDS:
            for c in range(args.cases):
                seed = args.seed * 10000 + list(KINDS).index(kind) * 100 + c  # the same truth at every level
                r = one_case(kind, level, seed, models)
                rows.append(r)
                print(f"{100 * level:>4g}% {kind:<18} sig {r['signature_sigmas'] or 0:6.1f} -> {r['verdict']:<14} "
                      f"{r['named_first'] or '-':<18} settled {r['settled_first'] or '-'} ({r['seconds']:.0f} s)",
                      flush=True)
                write_json(out / "forms_rows.json", rows)
    summary = summarise(rows)
    write_json(out / "forms_campaign.json", {"rows": rows, "summary": summary, "args": vars(args)})
    print(json.dumps(summary, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
