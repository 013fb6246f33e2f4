"""Campaign: the correlation workflow on generated data with one effect hidden (the "proven blind" check).

For each hidden effect (and null cases with none, and an effect outside the library) it generates
``--cases`` cases (:func:`imutherm.studies.correlation.hidden_effect.make_case`: full model on a finer mesh,
±10 % nuisance on board conductivity, convection and mount, probe noise and offsets), runs
:func:`imutherm.studies.correlation.correlate` on each, and reports top-1 accuracy (on cases
whose signature, the RMS change the effect makes at the sites, is >= 5x the noise), the confusion
matrix, the false-positive rate on null cases, abstention on the out-of-library cases (per kind:
a radiant lid load, the chamber cycling under its thermostat, an unlogged power-mode change;
abstaining = ``not_in_library`` or ``ambiguous``, ``none`` counted apart) and the held-out RMS
after/before. Writes ``--out``/campaign.json and prints the summary.

    python benchmarks/bench_correlation.py --cases 3 --out /tmp/campaign

A campaign is split with --kinds (one process per core); generated cases are kept in --out and
re-inverted, not re-generated, on a second run.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
import zlib
from collections import Counter
from pathlib import Path

import numpy as np

from imutherm.io import write_json
from imutherm.measured import read_measured
from imutherm.studies.correlation import FORM_RETUNE, build_models, correlate, result_json
from imutherm.studies.correlation.forward_model import ForwardModel
from imutherm.studies.correlation.form_generator import generator_mesh_mm
from imutherm.studies.correlation.hidden_effect import (FINDING_KINDS, MODEL_FORMS, OUT_OF_LIBRARY_KINDS, HiddenCase, make_case,
                                           model_form_options)

DEFAULT_EFFECTS = ("contact@bond", "emissivity", "cavity_emissivity", "power@reg_5v", "fixture_leak",
                   "probe_lag", "contact@standoff")


def _seed(base: int, hidden: str, c: int) -> int:
    """A case's seed: stable across runs, shards and effect lists."""
    return base * 100000 + zlib.crc32(hidden.encode()) % 1000 * 100 + c


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cases", type=int, default=3, help="cases per hidden effect (and null, out-of-library)")
    ap.add_argument("--first-case", type=int, default=0, help="index of the first case (to add cases to a campaign)")
    ap.add_argument("--effects", nargs="*", default=list(DEFAULT_EFFECTS))
    ap.add_argument("--kinds", nargs="*", default=None,
                    help="run only these hidden kinds (effects, none, or the out-of-library kinds "
                         f"{', '.join(OUT_OF_LIBRARY_KINDS)}): to split a campaign")
    ap.add_argument("--mesh-size", type=float, default=4.0, help="inversion mesh [mm]")
    ap.add_argument("--min-cells", type=int, default=1, help="inversion: cells across the thinnest part")
    ap.add_argument("--gen-mesh-size", type=float, default=2.0, help="generator mesh [mm] (finer)")
    ap.add_argument("--gen-min-cells", type=int, default=1, help="generator: cells across the thinnest part")
    ap.add_argument("--no-generate", action="store_true",
                    help="re-invert the cases already generated in --out, skip the others")
    ap.add_argument("--generate-only", action="store_true",
                    help="generate the cases into --out and stop (invert them later with --no-generate: a new "
                         "inversion re-scored on the same cases)")
    ap.add_argument("--model-form", nargs="?", const="cavity-law", default=None, choices=MODEL_FORMS,
                    help="model-form cases (hidden_effect.model_form_options): 'cavity-law' (the default of the "
                         "flag) generates with the other cavity-radiation law than the inversion's, "
                         "'discretisation' with the s2s cavity discretised otherwise, 'layered' every "
                         "contact a thin solid layer, ±10 %% nuisance on every conductivity, contact and emissivity, "
                         "on a grid 1.5x coarser or 2x finer than the inversion's by turns (--gen-mesh-size "
                         "ignored; imutherm.studies.correlation.form_generator), so the data differ from the inverted model "
                         "in form")
    ap.add_argument("--discrepancy", action=argparse.BooleanOptionalAction, default=None,
                    help="the discrepancy term: default as correlate's ('auto': where the library does not explain "
                         "the data); --discrepancy always, --no-discrepancy never")
    ap.add_argument("--max-effects", type=int, default=3, help="forward selection's largest number of effects")
    ap.add_argument("--cavity-emissivity-as-effect", action="store_true",
                    help="offer the cavity's emissivity as a candidate effect (default: re-tuned, correlation.FORM_RETUNE)")
    ap.add_argument("--samples", type=int, default=40, help="readings per file")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", required=True)
    args = ap.parse_args(argv)
    layered = args.model_form == "layered"
    if args.gen_mesh_size >= args.mesh_size and not layered:
        ap.error("--gen-mesh-size must be finer (smaller) than --mesh-size: the data come from a finer model")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    kinds = args.kinds or (list(args.effects) + ["none", *OUT_OF_LIBRARY_KINDS, *FINDING_KINDS])
    experiments = (("air", 70.0), ("grease", 70.0))
    n_cases = len(kinds) * args.cases
    print(f"campaign: {n_cases} cases; each generates {len(experiments)} full transients on a {args.gen_mesh_size:g} mm "
          f"mesh (~1-3 min per case on one core); inversion on {args.mesh_size:g} mm", flush=True)
    t0 = time.perf_counter()
    # the inversion's reduced models depend only on the layout, mesh and experiments: built once, reused
    models = build_models(experiments, mesh_size_mm=args.mesh_size, min_cells=args.min_cells, progress=print)
    print(f"reduced models built in {time.perf_counter() - t0:.0f} s", flush=True)
    gen_options = model_form_options(models.options, args.model_form) if args.model_form else None
    form = f"model-form ({args.model_form})" if args.model_form else "same-model"
    tag = "" if args.kinds is None and not args.first_case else f"_{'_'.join(kinds)}_from{args.first_case}"
    form_tag = {"cavity-law": "mf", "discretisation": "mfd", "layered": "mfl", None: ""}[args.model_form]  # in file and case names
    tag += f"_{form_tag}" if form_tag else ""
    rows_path = out / f"campaign_rows{tag}.json"
    rows = []
    for hidden in kinds:
        for c in range(args.first_case, args.first_case + args.cases):
            seed = _seed(args.seed, hidden, c)
            d = out / f"{form_tag + '_' if form_tag else ''}{hidden.replace('@', '_')}_{c}"
            t0 = time.perf_counter()
            meta = d / "case.json"
            if not meta.exists() and args.no_generate:
                continue
            if meta.exists():  # generated before: re-invert only
                m = json.loads(meta.read_text())
                case = HiddenCase(m["hidden"], m["value"], m["nuisance"], tuple(m["files"]), m["seed"],
                                  m.get("extra", {}))
            else:
                gen_mm = generator_mesh_mm(args.mesh_size, c) if layered else args.gen_mesh_size
                case = make_case(d, hidden, np.random.default_rng(seed), experiments=experiments,
                                 mesh_size_mm=gen_mm, min_cells=args.gen_min_cells, seed=seed,
                                 options=gen_options, samples=args.samples, nuisance_all=layered)
                write_json(meta, {"hidden": case.hidden, "value": case.value, "nuisance": case.nuisance,
                                  "files": list(case.files), "seed": seed, "extra": case.extra})
            t_gen = time.perf_counter() - t0
            if args.generate_only:
                print(f"{hidden:<20} generated in {t_gen:.0f} s ({d})", flush=True)
                continue
            runs = [read_measured(f) for f in case.files]
            res = correlate(runs, models=models, rerun=False,
                            discrepancy="auto" if args.discrepancy is None else args.discrepancy,
                            max_effects=args.max_effects, form_retune=not args.cavity_emissivity_as_effect)  # held-out figures come from the reduced model
            j = result_json(res)
            write_json(d / "correlation.json", j)  # the case's whole verdict, for a look at why
            called = res.named_effect if res.verdict == "effect" else res.verdict
            sig = signature(models, runs, case, res.noise_K)
            shape = residual_shape(ForwardModel(tuple(runs), models.roms, models.geometries), res.retune.values)
            rows.append({"form": form, "named_effects": list(res.named_effects),
                         "findings": [f.parameter for f in res.findings], "named_first": j["named_first"],
                         "written_model": j["written_model"]["model"] if j["written_model"] else None,
                         "discrepancy_supported": bool(res.discrepancy and res.discrepancy["supported"]),
                         "discrepancy_rms_K": res.discrepancy["rms_K"] if res.discrepancy else None,
                         "heldout_retune_K": j["heldout_rms_retune_K"],
                         "hidden": hidden, "value": case.value, "extra": case.extra, "seed": seed, "verdict": res.verdict,
                         "called": called, "ambiguous_set": list(res.ambiguous_set), "signature_over_noise": sig,
                         "heldout_before_K": j["heldout_rms_before_K"], "heldout_after_K": j["heldout_rms_after_K"],
                         "rms_before_K": j["rms_before_K"], "rms_after_K": j["rms_after_K"], "noise_K": res.noise_K,
                         "gen_s": t_gen, "correlate_s": res.timings["total_s"],
                         "retune_values": dict(res.retune.values), "retune_rms_K": res.retune.rms_K,
                         "retune_residual": shape,
                         "named_values": dict(res.after.values) if res.verdict == "effect" else None})
            print(f"{hidden:<20} {case.value!s:<12.8} sig {sig if sig is None else round(sig, 1)!s:<6} -> "
                  f"{called:<20} {'+'.join([f.parameter for f in res.findings] + list(res.named_effects)) or '-':<30} "
                  f"disc {'yes' if rows[-1]['discrepancy_supported'] else 'no'} ({time.perf_counter() - t0:.0f} s)",
                  flush=True)
            write_json(rows_path, rows)
    if args.generate_only:
        return 0
    form = () if args.cavity_emissivity_as_effect else tuple(FORM_RETUNE)
    summary = summarise(rows, [k for k in kinds if k not in ("none", *OUT_OF_LIBRARY_KINDS, *form, *FINDING_KINDS)],
                        form)
    write_json(out / f"campaign{tag}.json",
               {"rows": rows, "summary": summary, "args": vars(args)})
    print(json.dumps(summary, indent=1))
    return 0


def signature(models, runs, case, noise_K: float) -> float | None:
    """RMS [K] over the readings of what the hidden effect changes (reduced model, at the case's nuisance
    values, with and without it), over the noise: how visible the effect is. None: not in the library."""
    if case.hidden in ("none", *OUT_OF_LIBRARY_KINDS) or not noise_K:
        return None
    fwd = ForwardModel(tuple(runs), models.roms, models.geometries)
    base = dict(case.nuisance)
    if case.hidden in FINDING_KINDS:  # a re-tune parameter moved far: against its nominal value
        base[case.hidden] = fwd.nominal[case.hidden]
    d = [fwd.rise(i, {**base, case.hidden: case.value}) - fwd.rise(i, base) for i in range(len(runs))]
    d = np.concatenate([x.ravel() for x in d])
    return float(np.sqrt(np.mean(d**2)) / noise_K)


def residual_shape(fwd, values: dict) -> dict:
    """What the re-tuned model leaves: the site-mean residual (model - measured) [K] of each dense run,
    its RMS, its mean before and after mid-record, and the period (100-1500 s scan, one phase per run)
    of the sinusoid that explains most of it, with the fraction explained."""
    res, times = [], []
    for i, run in enumerate(fwd.runs):
        fin = np.isfinite(run.times_s)
        r = fwd.rise(i, values) - run.rise_K
        if fin.sum() >= 8:
            res.append(np.nanmean(r[fin], axis=1))
            times.append(run.times_s[fin])
    if not res:
        return {}
    best = (None, 0.0)
    tot = sum(float(np.sum((x - x.mean()) ** 2)) for x in res)
    for period in np.geomspace(100.0, 1500.0, 120):
        w = 2 * np.pi / period
        expl = 0.0
        for t, x in zip(times, res):
            X = np.column_stack([np.ones_like(t), np.cos(w * t), np.sin(w * t)])
            c, *_ = np.linalg.lstsq(X, x, rcond=None)
            expl += float(np.sum((x - x.mean()) ** 2) - np.sum((X @ c - x) ** 2))
        if expl > best[1]:
            best = (float(period), expl)
    half = [(float(np.mean(x[t <= t.max() / 2])), float(np.mean(x[t > t.max() / 2]))) for t, x in zip(times, res)]
    return {"rms_K": [float(np.sqrt(np.mean(x ** 2))) for x in res], "mean_first_second_half_K": half,
            "best_period_s": best[0], "period_explains": best[1] / tot if tot else None}


def summarise(rows, effects, form=()) -> dict:
    """The campaign's figures. ``form``: hidden kinds the inversion re-tunes (correlation.FORM_RETUNE) rather
    than names: scored apart, by whether the re-tuned value moved from the nominal towards the hidden one and
    no library effect was named."""
    eff_rows = [r for r in rows if r["hidden"] in effects]
    form_rows = [r for r in rows if r["hidden"] in form]
    strong = [r for r in eff_rows if (r["signature_over_noise"] or 0) >= 5]
    # strong library effects and strong re-tune moves (a form knob or a FINDING_KINDS parameter hidden far from
    # its nominal) together: the first thing named (a finding or a library effect) must be the hidden one
    found_rows = [r for r in rows if (r["hidden"] in form or r["hidden"] in FINDING_KINDS)
                  and (r["signature_over_noise"] or 0) >= 5 and "named_first" in r]
    strong_all = strong + found_rows
    conf = {}
    for r in rows:
        conf.setdefault(r["hidden"], Counter())[r["called"]] += 1
    nulls = [r for r in rows if r["hidden"] == "none"]
    ool = [r for r in rows if r["hidden"] in OUT_OF_LIBRARY_KINDS]
    abstain = {}
    for kind in OUT_OF_LIBRARY_KINDS:
        rk = [r for r in ool if r["hidden"] == kind]
        if rk:
            abstain[kind] = {"cases": len(rk),
                             "abstained": sum(r["verdict"] in ("not_in_library", "ambiguous") for r in rk),
                             "none": sum(r["verdict"] == "none" for r in rk),
                             "named": dict(Counter(r["called"] for r in rk if r["verdict"] == "effect"))}
    ratios = [r["heldout_after_K"] / r["heldout_before_K"] for r in eff_rows
              if r["called"] == r["hidden"] and r["heldout_before_K"]]
    named = [r for r in strong if r.get("named_effects") is not None]
    return {
        # the figures on data the model did not make: the hidden effect among the named ones, first; nulls
        # naming no library effect; out-of-library kinds abstained or discrepancy-only
        "hidden_among_named_strong": (sum(r["hidden"] in r["named_effects"] for r in named) / len(named))
        if named else None,
        "hidden_first_strong": (sum(r["named_effects"][:1] == [r["hidden"]] for r in named) / len(named))
        if named else None,
        "null_no_library_effect": (sum(r["verdict"] != "effect" for r in nulls) / len(nulls)) if nulls else None,
        "null_discrepancy": sum(r["verdict"] == "discrepancy" for r in nulls),
        "null_verdicts": dict(Counter(r["verdict"] for r in nulls)),
        # cases of any kind that name a library effect that was not hidden (first or later in named_effects)
        "cases_naming_an_effect_not_hidden": sum(any(n != r["hidden"] for n in r.get("named_effects") or ())
                                                 for r in rows),
        "out_of_library_abstained_or_discrepancy": (sum(r["verdict"] in ("not_in_library", "ambiguous", "discrepancy")
                                                        for r in ool) / len(ool)) if ool else None,
        "heldout_after_over_before_median_named": float(np.median(
            [r["heldout_after_K"] / r["heldout_before_K"] for r in strong
             if r.get("named_effects") and r["hidden"] in r["named_effects"] and r["heldout_before_K"]]))
        if any(r.get("named_effects") and r["hidden"] in r["named_effects"] for r in strong) else None,
        "top1_accuracy_strong": (sum(r["called"] == r["hidden"] for r in strong) / len(strong)) if strong else None,
        "strong_cases": len(strong),
        "top1_accuracy_all": (sum(r["called"] == r["hidden"] for r in eff_rows) / len(eff_rows)) if eff_rows else None,
        "false_positive_rate_null": (sum(r["verdict"] == "effect" for r in nulls) / len(nulls)) if nulls else None,
        "abstention_out_of_library": (sum(r["verdict"] in ("not_in_library", "ambiguous") for r in ool) / len(ool))
        if ool else None,
        "abstention_by_kind": abstain,
        "heldout_after_over_before_median": float(np.median(ratios)) if ratios else None,
        "confusion": {k: dict(v) for k, v in conf.items()},
        "form_knob_cases": [{"hidden": r["hidden"], "value": r["value"],
                             "retuned": r["retune_values"].get(r["hidden"]), "verdict": r["verdict"],
                             "named_effects": r["named_effects"]} for r in form_rows],
        "median_correlate_s": float(np.median([r["correlate_s"] for r in rows])) if rows else None,
        # the blind campaign's scores: strong effects and strong re-tune moves named first; null cases with no library
        # name; out-of-library cases abstained or discrepancy (above); the written model never worse than nominal
        "strong_named_first_incl_findings": (sum(r.get("named_first") == r["hidden"] for r in strong_all)
                                             / len(strong_all)) if strong_all else None,
        "strong_cases_incl_findings": len(strong_all),
        "strong_named_first_by_kind": {k: f"{sum(r.get('named_first') == r['hidden'] for r in strong_all if r['hidden'] == k)}"
                                          f"/{sum(r['hidden'] == k for r in strong_all)}"
                                       for k in sorted({r['hidden'] for r in strong_all})},
        "heldout_after_over_before_median_named_first": float(np.median(
            [r["heldout_after_K"] / r["heldout_before_K"] for r in strong_all
             if r.get("named_first") == r["hidden"] and r["heldout_before_K"]]))
        if any(r.get("named_first") == r["hidden"] for r in strong_all) else None,
        "null_no_library_name": (sum(not r.get("named_effects") for r in nulls) / len(nulls)) if nulls else None,
        "written_nominal_or_term_free": dict(Counter(r.get("written_model") for r in rows)),
    }


if __name__ == "__main__":
    import _record  # benchmarks/_record.py: --write records what the run printed in docs/benchmarks/tables/
    sys.exit(_record.run(main, lambda args: "correlation_model_form" if "--model-form" in args else "correlation",
                         "the blind correlation campaign"))
