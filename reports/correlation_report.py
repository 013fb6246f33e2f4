"""``correlation.pdf`` of ``imutherm correlate``.

Page 1, read in ten seconds: what was found (the named finding or effect, its fitted value and 95 % interval,
its nominal and source range), the held-out gap before and after, and the share of the gap the model-form term
takes, in one picture. Page 2: the verdict in words, before/after figures, the ranking (ΔAICc over the re-tuned
model, held-out RMS). Page 3: residuals per site and phase of the nominal model.
Then one page per measured file: measured, before and after curves per site. A4 landscape.
"""

from __future__ import annotations

import math
import textwrap

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.backends.backend_pdf import PdfPages

from imutherm.studies.correlation import MARGIN_NONE, SPARSE_FRACTION

A4_LANDSCAPE = (11.69, 8.27)


def _fmt(v, unit="K"):
    return "n/a" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.2f} {unit}"


def _headline(res) -> tuple:
    """(headline, second line) of the first page: the first thing named with its value and interval."""
    if res.findings:
        f = res.findings[0]
        lo, hi = f.ci95
        u = "" if f.unit == "-" else f" {f.unit}"
        head = f"Found: {f.parameter} = {f.value:.3g}{u}  (95 %: {lo:.3g} to {hi:.3g}; nominal {f.nominal:.3g})"
        sub = (f"source range {f.source_range[0]:.3g}–{f.source_range[1]:.3g}{u}"
               + (" — CONTRADICTS ITS SOURCE" + (" (at a bound of the re-tune)" if f.at_bound else "")
                  if f.contradicts_source else "") + f"; explains {100 * f.gap_share:.0f} % of the held-out gap")
        if res.named_effects:
            sub += "; then " + ", ".join(res.named_effects)
        return head, sub
    if res.named_effects:
        n = res.named_effects[0]
        fit = res.after if n in res.after.ci or res.physics is None else res.physics
        v = fit.values.get(n)
        lo, hi = fit.ci.get(n, (math.nan, math.nan))
        from imutherm.unit.effects import effect_of
        p = effect_of(n).params[0]
        head = f"Found: {n}  {p.name} = {v:.3g} {p.unit}  (95 %: {lo:.3g} to {hi:.3g})"
        return head, ("then " + ", ".join(res.named_effects[1:]) + "; " if len(res.named_effects) > 1 else "") + \
            effect_of(n).words
    if res.verdict == "ambiguous" and res.explanations:
        amb = [e for e in res.explanations if e.get("ambiguous")]
        sub = "fitted: " + "; ".join(f"{e['name']} = {e['value']:.3g} {e['unit']} (moves the readings up to "
                                     f"{e.get('change_K', math.nan):.2f} K)" for e in amb[:3])
        return "Ambiguous: the data fit " + " or ".join(e["name"] for e in amb) + " equally", sub
    what = {"none": "Nothing to name: the re-tuned model predicts the held-out data within the noise",
            "discrepancy": "No effect named: the model's form is off (discrepancy), no library effect explains it",
            "not_in_library": "No effect named: something outside the library (not_in_library)",
            "ambiguous": "No effect named: ambiguous between " + ", ".join(res.ambiguous_set)}
    return what.get(res.verdict, res.verdict), ""


def first_page_figure(res):
    """The first page (a matplotlib Figure): the finding, the held-out gap before and after, the model-form
    term's share."""
    fig = plt.figure(figsize=A4_LANDSCAPE)
    head, sub = _headline(res)
    fig.text(0.05, 0.92, head, fontsize=19, weight="bold")
    fig.text(0.05, 0.875, sub, fontsize=11, color="firebrick" if "CONTRADICTS" in sub else "black")
    w = res.written or {}
    h_nom = res.before.get("heldout_rms_K", math.nan)
    h_re = res.retune_plain.heldout_rms_K if res.retune_plain is not None else res.retune.heldout_rms_K
    h_phys = w.get("corrected_heldout_rms_K", math.nan)
    h_term = res.after.heldout_rms_K if res.after.criterion == "evidence" else math.nan
    bars = [("nominal\nmodel", h_nom, "tab:red"), ("re-tuned\nonly", h_re, "tab:orange"),
            ("corrected\n(physics)", h_phys, "tab:green")]
    if math.isfinite(h_term):
        bars.append(("corrected\n+ form term", h_term, "tab:olive"))
    tall = 0.56 if getattr(res, "next_experiment", None) else 0.62  # room for the next experiment's sentence
    ax = fig.add_axes([0.07, 0.14, 0.5, tall])
    names = [b[0] for b in bars]
    vals = [b[1] if math.isfinite(b[1]) else 0.0 for b in bars]
    ax.bar(names, vals, color=[b[2] for b in bars])
    for i, v in enumerate(vals):
        ax.text(i, v, f"{v:.2f} K", ha="center", va="bottom", fontsize=12, weight="bold")
    ax.axhspan(0, 2 * res.noise_K, color="0.85", zorder=0)
    fs = (res.form_scale or {}).get("fraction_by_scheme", {})
    ax.set_ylabel("held-out RMS error [K]", fontsize=11)
    ax.set_title(f"Held-out gap: {h_nom:.2f} K before → {h_phys:.2f} K after (grey: 2 noise σ, "
                 f"{2 * res.noise_K:.2f} K)", fontsize=12)
    ax.tick_params(labelsize=10)
    # the gap's shares: what the named finding/effects and re-tune explain, what the form term takes, what is left
    ax2 = fig.add_axes([0.62, 0.14, 0.18, tall])
    gap = h_nom if math.isfinite(h_nom) and h_nom > 0 else math.nan
    physics = max(gap - h_phys, 0.0) if math.isfinite(h_phys) else 0.0
    term = max(h_phys - h_term, 0.0) if math.isfinite(h_term) else 0.0
    left = max(gap - physics - term, 0.0)
    parts = [("explained by the corrected physics", physics, "tab:green"),
             ("taken by the model-form term", term, "tab:olive"), ("left", left, "0.7")]
    bottom = 0.0
    for label, x, col in parts:
        share = x / gap if math.isfinite(gap) else math.nan
        ax2.bar([0], [share], bottom=bottom, color=col, width=0.6)
        if share > 0.12:
            ax2.text(0, bottom + share / 2, f"{label}\n{100 * share:.0f} %", ha="center", va="center", fontsize=10)
        elif share > 0.0:  # a thin slice: its label beside the bar
            ax2.text(0.32, bottom + share / 2, f"{label}: {100 * share:.0f} %", ha="left", va="center", fontsize=9)
        bottom += share if math.isfinite(share) else 0.0
    ax2.set_xlim(-0.6, 0.6)
    ax2.set_ylim(0, 1)
    ax2.set_xticks([])
    ax2.set_ylabel("share of the held-out gap [-]", fontsize=11)
    ax2.set_title("Where the gap went", fontsize=12)
    foot = [f"verdict: {res.verdict}; noise {res.noise_K:.3f} K; known form error "
            + ", ".join(f"{100 * v:.1f} % of the rise ({g})" for g, v in fs.items())]
    nxt = getattr(res, "next_experiment", None)
    if nxt:
        for j, part in enumerate(textwrap.wrap(nxt["in_words"], 120)):
            fig.text(0.05, 0.835 - 0.025 * j, part, fontsize=11, color="navy", weight="bold")
    for x in getattr(res, "symptoms", ()):
        foot.append(f"symptom: {x.words()}")
    if w.get("model") and w["model"] != "corrected":
        foot.append(f"written model: {w['model']} — {w['reason']}")
    for i, line in enumerate(foot):
        for j, part in enumerate(textwrap.wrap(line, 170)):
            fig.text(0.05, 0.06 - 0.022 * (i + j), part, fontsize=8.5)
    return fig


def _first_page(pdf, res):
    fig = first_page_figure(res)
    pdf.savefig(fig)
    plt.close(fig)


def _summary_page(pdf, res):
    fig = plt.figure(figsize=A4_LANDSCAPE)
    head = f"Correlation verdict: {res.verdict}" + (f" — {' + '.join(res.named_effects)}" if res.named_effects else "")
    if res.ambiguous_set:
        head += f" — one of {', '.join(res.ambiguous_set)}"
    fig.text(0.05, 0.94, head, fontsize=15, weight="bold")
    reason = res.timings.get("reason", "")
    body = [res.words] + ([reason] if reason != res.words else []) + [
            f"RMS {_fmt(res.before['rms_K'])} before -> {_fmt(res.after.rms_K)} after; "
            f"max {_fmt(res.before['max_K'])} -> {_fmt(res.after.max_K)} (reduced model); "
            + (f"the corrected model re-run on the full FEM: RMS {_fmt(res.full['rms_K'])}, max {_fmt(res.full['max_K'])}; "
               if res.full else "") + "held-out RMS "
            f"{_fmt(res.before['heldout_rms_K'])} -> {_fmt(res.after.heldout_rms_K)}; noise {_fmt(res.noise_K)}; "
            f"{res.after.n} readings, effective sample size {res.after.n_eff:.1f}.",
            "Files: " + ", ".join(f"{r.name} ({r.scheme}, {r.ambient_C:g} °C)" for r in res.runs)]
    y = 0.88
    for para in body:
        for line in textwrap.wrap(para, 150):
            fig.text(0.05, y, line, fontsize=9)
            y -= 0.028
    ax = fig.add_axes([0.3, 0.08, 0.65, 0.5])
    fits = list(res.ranking)[:15]
    names = [f.name for f in fits][::-1]
    colors = ["tab:green" if n == res.named_effect else "tab:gray" for n in names]
    if math.isfinite(res.retune.aicc):
        ax.barh(names, [res.retune.aicc - f.aicc for f in fits][::-1], color=colors)
        ax.axvline(MARGIN_NONE, color="k", lw=0.8, ls="--")
        ax.set_xlabel("ΔAICc over the re-tuned model (dashed: required margin) [-]")
    else:  # sparse data: no information criterion, ranked by held-out RMS
        ax.barh(names, [f.heldout_rms_K for f in fits][::-1], color=colors)
        ax.axvline(res.retune.heldout_rms_K, color="k", lw=0.8, ls="--")
        ax.axvline(SPARSE_FRACTION * res.retune.heldout_rms_K, color="k", lw=0.8, ls=":")
        ax.set_xlabel("held-out RMS, leave one reading out [K] (dashed: re-tuned model; dotted: half of it, "
                      "the bar to clear)")
    for i, f in enumerate(fits[::-1]):
        ax.text(ax.get_xlim()[1], i, f"  held-out {_fmt(f.heldout_rms_K)}", va="center", fontsize=7)
    pdf.savefig(fig)
    plt.close(fig)


def _residual_page(pdf, res):
    rows = [(run, s, st) for run, sites in res.localise.items() for s, st in sites.items()]
    if not rows:
        return
    fig, ax = plt.subplots(figsize=A4_LANDSCAPE)
    labels = [f"{run}:{s}" for run, s, _ in rows]
    x = np.arange(len(rows))
    for off, phase, col in ((-0.2, "rise", "tab:orange"), (0.2, "plateau", "tab:blue")):
        v = [st["phases"][phase]["mean_K"] if st["phases"][phase]["mean_K"] is not None else np.nan for _, _, st in rows]
        ax.bar(x + off, v, width=0.4, color=col, label=f"mean residual, {phase}")
    ax.plot(x, [st["rms_K"] for _, _, st in rows], "k_", ms=14, label="RMS (all)")
    ax.set_xticks(x, labels, rotation=60, fontsize=7, ha="right")
    ax.set_ylabel("model − measured [K]")
    ax.set_title("Nominal model: residuals per site and phase (rise: before t63; plateau: after t95)")
    fp = ", ".join(f"{k}: {v:+.2f}" for k, v in res.fingerprints.items() if v is not None)
    ax.text(0.01, 0.97, "correlation of the residual with " + fp, transform=ax.transAxes, fontsize=8, va="top")
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    pdf.savefig(fig)
    plt.close(fig)


def _curve_pages(pdf, res):
    for name, c in res.curves.items():
        sites = c["sites"]
        n = len(sites)
        cols = min(3, n)
        rows = int(math.ceil(n / cols))
        fig, axes = plt.subplots(rows, cols, figsize=A4_LANDSCAPE, squeeze=False)
        t = np.asarray(c["times_s"], float)
        fin = np.isfinite(t)
        tplot = np.where(fin, t, (t[fin].max() * 1.15 if fin.any() else 1.0))
        for j, s in enumerate(sites):
            ax = axes[j // cols][j % cols]
            ax.plot(tplot, c["measured_K"][:, j], "k.", ms=3, label="measured")
            ax.plot(tplot, c["before_K"][:, j], "-", color="tab:red", label="before")
            ax.plot(tplot, c["after_K"][:, j], "-", color="tab:green", label="after (reduced model fit)")
            if "discrepancy_K" in c and np.any(c["discrepancy_K"][:, j]):
                ax.plot(tplot, c["after_K"][:, j] - c["discrepancy_K"][:, j], ":", color="tab:green",
                        label="after, without the discrepancy term")
            if "after_full_K" in c:
                ax.plot(tplot, c["after_full_K"][:, j], "s", mfc="none", color="tab:green", ms=5,
                        label="after, full-model re-run")
            ax.set_title(s, fontsize=9)
            ax.set_xlabel("time since power-on [s] (last point right of the axis: steady)", fontsize=7)
            ax.set_ylabel("rise [K]", fontsize=8)
            ax.tick_params(labelsize=7)
        for j in range(n, rows * cols):
            axes[j // cols][j % cols].axis("off")
        axes[0][0].legend(fontsize=7)
        fig.suptitle(f"{name}: measured, nominal model (before) and corrected model (after)")
        fig.tight_layout()
        pdf.savefig(fig)
        plt.close(fig)


def write_report(path, res) -> None:
    """Write ``correlation.pdf`` for a :class:`~imutherm.studies.correlation.CorrelationResult`."""
    with PdfPages(path) as pdf:
        _first_page(pdf, res)
        _summary_page(pdf, res)
        _residual_page(pdf, res)
        _curve_pages(pdf, res)
