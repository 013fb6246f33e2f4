"""What a correlation writes: ``correlation.json`` (:func:`result_json`), ``updated_model.toml``
(:func:`updated_model_toml`) and the readings side by side (:func:`reading_rows`).
"""

from __future__ import annotations

import math

import numpy as np

from imutherm.unit import knobs
from imutherm.unit.effects import effect_of
from imutherm.unit.model import ModelOptions
from imutherm.studies.correlation.discrepancy import DISCREPANCY_PRIOR, DISCREPANCY_PRIOR_RANGE
from imutherm.studies.correlation.fit import Fit
from imutherm.studies.correlation.forward_model import FORM_KNOBS
from imutherm.studies.correlation.holdout import heldout_worse_z
from imutherm.studies.correlation.noise import SPARSE_NOISE_K
from imutherm.studies.correlation.selection import MAX_EFFECTS
from imutherm.studies.correlation.verdict import (EXPLAIN_FRACTION, EXPLAIN_NOISE_FACTOR, MARGIN_NONE, MARGIN_RUNNER_UP,
                                                  NONE_NOISE_FACTOR, effect_words)
from imutherm.studies.correlation.workflow import CorrelationResult


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
    profiled = {x.parameter for x in res.findings}

    def params(f: Fit):
        out = {}
        for name, v in f.values.items():
            k = next((kk for kk, _ in knobs.RETUNE if kk.name == name), None)
            unit = k.unit if k is not None else effect_of(name).params[0].unit
            form = name in FORM_KNOBS and name not in res.named_effects and name not in f.effects
            out[name] = {"value": v, "unit": unit, "ci95": list(f.ci.get(name, (None, None))),
                         "ci95_from": "profile" if name in profiled and f is res.after else "jacobian",
                         "kind": "retune" if k is not None or form else "effect",
                         "source": knobs.RETUNE_SOURCES.get(name) or (FORM_KNOBS[name] if form else
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
        # knobs at a bound the data pull them to: the model's form, not findings (how far off and where)
        "symptoms": [x.as_dict() for x in res.symptoms],
        # verdict 'ambiguous': the bench design that best separates the candidates (scheme, power_scale, ambient_C,
        # duration_s, probes, separation_K, separation_sigmas, in_words); null otherwise
        "next_experiment": res.next_experiment,
        # named effects, findings and ambiguous candidates on one basis (the physics without the term), best first
        "explanations": [{k: v for k, v in e.items() if k != "values"} for e in res.explanations],
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
    name it (:mod:`imutherm.studies.thermal.fitted_model`)."""
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
            from imutherm.studies.thermal.fitted_model import OPTION_FIELDS
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
    for k, _ in knobs.RETUNE:
        if k.name in values:
            lines.append(f"{k.name} = {values[k.name]:.6g}   # {knobs.RETUNE_SOURCES[k.name]}")
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
        lines += ["", f"# discrepancy term (prior scale {res.discrepancy['prior_fraction']:.3g} of each site's rise, "
                      f"estimated from the data; "
                      f"{'supported' if res.discrepancy['supported'] else 'not supported'} by the data, "
                      f"RMS {res.discrepancy['rms_K']:.3g} K): {res.discrepancy['words']}"]
    return "\n".join(lines) + "\n"
