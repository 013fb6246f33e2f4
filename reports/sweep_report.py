"""``sweep.pdf`` of ``imutherm sweep``: the ranking of the inputs' influence, then each output against each input.

Page 1: the design in words and a bar chart of each input's influence on the
largest rise (Morris mu* for a Morris design, Sobol' first-order and total
indices with their 95 % confidence for a Sobol' design, else the standardised
regression coefficient with its R^2; the page says which), and for a sweep on
the reduced model its check against the full FEM. Page 2: the same measure for
every output as a table of numbers. Then one page per input: every output
against it, one scatter panel per output. Axis labels carry units; A4
landscape, fonts >= 8 pt.
"""

from __future__ import annotations

import os

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.backends.backend_pdf import PdfPages

from imutherm.io import atomic_write
from imutherm.studies.sweep.keys import key_unit

A4_LANDSCAPE = (11.69, 8.27)
_UNIT_TEXT = {"degC": "°C", "W/m^2 K": "W/m² K", "kg/m^3": "kg/m³"}


def _label(name: str) -> str:
    unit = key_unit(name)
    return f"{name} [{_UNIT_TEXT.get(unit, unit)}]"


def _output_title(name: str) -> str:
    if name.startswith("rise_") and name.endswith("_K"):
        return f"steady rise of {name[5:-2]}"
    if name.endswith("_rms_deg"):  # <phase>_<compensation>_<filter>_<profile>_<roll|pitch>_rms_deg
        ph, comp, filt, prof, angle = name[: -len("_rms_deg")].split("_", 4)
        return f"{angle} RMS error, {filt}, {prof}, {ph}"
    return {"max_rise_K": "largest steady rise", "t95_s": "t95 of the hottest site",
            "extrapolated_fraction": "share of samples beyond calibration"}.get(name, name)


def _measure(sens: dict) -> tuple:
    """(metric key in by_key, long name)."""
    if sens["measure"] == "morris_mu_star":
        return "mu_star", "Morris mu* (mean |elementary effect|, output units per input range)"
    if sens["measure"] == "sobol":
        return "ST", "Sobol' total-order index ST (first-order S1 beside it; share of the output's variance)"
    return "src", "standardised regression coefficient (linear least squares on standardised values)"


def _ranking_page(pdf, result) -> None:
    plan, sens = result.plan, result.sensitivity
    d = plan.design
    metric, mname = _measure(sens)
    fig = plt.figure(figsize=A4_LANDSCAPE)
    ok = sum(r["status"] == "ok" for r in result.rows)
    lines = [f"Parameter sweep: layout {os.path.basename(d['layout'])}, scheme {d['scheme']}, method {d['method']}"
             + (f" (samples {d['samples']}, seed {d['seed']})" if d["method"] != "grid" else ""),
             f"{len(result.rows)} of {d['cases']} cases recorded: {ok} ok, {result.failed} failed; "
             f"mesh {d['mesh_size_mm']:g} mm, {'steady + power-on transient' if d['transient'] else 'steady'}",
             "inputs: " + "; ".join(f"{f['key']} " + (f"in {f['values']}" if f["values"] else f"in [{f['bounds'][0]:g}, {f['bounds'][1]:g}]")
                                    for f in d["factors"]),
             f"influence measure: {mname}"]
    if sens.get("note"):
        lines.append(f"note: {sens['note']}")
    if result.verification is not None:
        from imutherm.studies.sweep.surrogate import verify_words

        t = result.timings or {}
        lines.append(f"cases evaluated on the scheme's reduced model (built in {t.get('build_s', 0):.0f} s, "
                     f"{len(result.rows)} cases in {t.get('evaluate_s', 0):.1f} s); proof against the full FEM:")
        lines.append("  " + verify_words(result.verification))
    fig.text(0.04, 0.96, "\n".join(lines), va="top", fontsize=10, wrap=True)
    ax = fig.add_axes([0.34, 0.1, 0.6, 0.6])
    primary = sens["outputs"].get("max_rise_K")
    if primary:
        keys = sens["ranking"][::-1]
        vals = [primary["by_key"][k][metric] for k in keys]
        colors = ["tab:red" if v > 0 else "tab:blue" for v in vals]
        if metric == "ST":
            y = np.arange(len(keys))
            by = primary["by_key"]
            ax.barh(y + 0.2, [by[k]["ST"] for k in keys], 0.4, xerr=[by[k]["ST_conf"] for k in keys],
                    color="tab:red", capsize=3, label="total order ST")
            ax.barh(y - 0.2, [by[k]["S1"] for k in keys], 0.4, xerr=[by[k]["S1_conf"] for k in keys],
                    color="tab:orange", capsize=3, label="first order S1")
            ax.legend(fontsize=9, loc="lower right")
        else:
            ax.barh(range(len(keys)), vals, color=colors)
        if metric == "mu_star":
            conf = [primary["by_key"][k]["mu_star_conf"] for k in keys]
            ax.errorbar(vals, range(len(keys)), xerr=conf, fmt="none", ecolor="k", capsize=3, lw=1)
        ax.set_yticks(range(len(keys)))
        ax.set_yticklabels([_label(k) for k in keys], fontsize=9)
        ax.axvline(0, color="k", lw=0.8)
        xl = {"mu_star": "Morris mu* of max_rise_K [K]",
              "ST": "Sobol' index of max_rise_K [-] (bars: 95 % confidence)"}.get(
            metric, "SRC of max_rise_K [-] (red: raises, blue: lowers)")
        ax.set_xlabel(xl, fontsize=10)
        title = "Influence of each input on the largest steady rise, most influential on top"
        if metric == "src":
            title += f" (R² of the linear fit {primary['r2']:.3f})"
        ax.set_title(title, fontsize=11)
        ax.grid(True, axis="x", alpha=0.3)
    else:
        ax.axis("off")
        ax.text(0.5, 0.5, "no influence measure: too few ok cases or no variation", ha="center", fontsize=11)
    pdf.savefig(fig)
    plt.close(fig)


def _table_page(pdf, result) -> None:
    plan, sens = result.plan, result.sensitivity
    metric, mname = _measure(sens)
    outs = [o for o in plan.outputs if o in sens["outputs"]]
    if not outs:
        return
    fig = plt.figure(figsize=A4_LANDSCAPE)
    fig.text(0.04, 0.95, f"Influence of every input on every output: {mname}", fontsize=11, va="top")
    ax = fig.add_axes([0.04, 0.05, 0.92, 0.82])
    ax.axis("off")
    cells = []
    for o in outs:
        by = sens["outputs"][o]["by_key"]
        if metric == "ST":
            row = [_label(o)] + [f"S1 {by[k]['S1']:.2f}±{by[k]['S1_conf']:.2f}\nST {by[k]['ST']:.2f}±{by[k]['ST_conf']:.2f}"
                                 if k in by else "-" for k in plan.keys]
        else:
            row = [_label(o)] + [f"{by[k][metric]:+.3g}" if k in by else "-" for k in plan.keys]
        if metric == "src":
            row.append(f"{sens['outputs'][o]['r2']:.3f}")
        cells.append(row)
    cols = ["output"] + [_label(k) for k in plan.keys] + (["R² of fit"] if metric == "src" else [])
    first = 0.22
    rest = (1.0 - first) / (len(cols) - 1)
    table = ax.table(cellText=cells, colLabels=cols, loc="upper center", cellLoc="center",
                     colWidths=[first] + [rest] * (len(cols) - 1))
    table.auto_set_font_size(False)
    table.set_fontsize(8)
    table.scale(1.0, 2.4 if metric == "ST" else 1.4)
    pdf.savefig(fig)
    plt.close(fig)


def _scatter_pages(pdf, result) -> None:
    plan = result.plan
    ok = [r for r in result.rows if r["status"] == "ok"]
    outs = list(plan.outputs)
    ncol = 5 if len(outs) > 16 else 4 if len(outs) > 9 else 3
    nrow = int(np.ceil(len(outs) / ncol))
    for key in plan.keys:
        fig, axes = plt.subplots(nrow, ncol, figsize=A4_LANDSCAPE, constrained_layout=True, squeeze=False)
        x = np.array([r[key] for r in ok], float)
        for ax, name in zip(axes.flat, outs):
            y = np.array([np.nan if r[name] is None else r[name] for r in ok], float)
            many = len(ok) > 500  # thousands of cases (a reduced-model sweep): small points, drawn as an image
            ax.plot(x, y, "o", ms=1 if many else 4, color="tab:blue", alpha=0.3 if many else 0.7, rasterized=many)
            ax.set_xlabel(_label(key), fontsize=8)
            ax.set_ylabel(_label(name), fontsize=8)
            ax.set_title(_output_title(name), fontsize=9)
            ax.tick_params(labelsize=8)
            ax.grid(True, alpha=0.3)
        for ax in list(axes.flat)[len(outs):]:
            ax.axis("off")
        failed = len(result.rows) - len(ok)
        fig.suptitle(f"Each output against {key}" + (f" ({failed} failed case(s) not shown)" if failed else ""),
                     fontsize=11)
        pdf.savefig(fig)
        plt.close(fig)


def write_sweep_pdf(result, path) -> None:
    """Write ``sweep.pdf`` from a :class:`~imutherm.studies.sweep.SweepResult` (atomically: :func:`imutherm.io.atomic_write`)."""
    def write(tmp):
        with PdfPages(tmp) as pdf:
            _ranking_page(pdf, result)
            _table_page(pdf, result)
            _scatter_pages(pdf, result)

    atomic_write(path, write)
