"""The uncertainty pages of the study report (``imutherm compare --uncertainty``).

Page 1: each scheme's largest sensor-die rise and settle time with their 5-95 % intervals, the
differences between schemes, the answer in words (is each advantage larger than the model's
uncertainty?), the reduced model's check against the full FEM, and what was not propagated.
With the IMU draws (end-to-end study): a page of the residual sensor errors and the attitude error over
the draws through the full IMU chain, each difference between schemes taken draw by draw, beside the
nominal study's figures. Then the inputs' Sobol' indices (total and first order, 95 % confidence) for each of those
outputs: which unknowns drive each figure. Page 3: the inputs with their ranges and sources.
"""

from __future__ import annotations

import textwrap

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.backends.backend_pdf import PdfPages

from imutherm.io import atomic_write

A4_LANDSCAPE = (11.69, 8.27)


def _fmt(v, f="{:.2f}"):
    return "-" if v is None else f.format(v)


def _key_outputs(unc: dict) -> list:
    """(label, stats key, unit, format) of the headline outputs, schemes first, then differences."""
    out = []
    for key in unc["stats"]:
        name, what = key.split(":", 1)
        if name == "max_die_rise_K":
            out.append((f"hottest die rise, {what}", key, "K", "{:.2f}"))
        elif name == "t95_s":
            out.append((f"t95 hottest die, {what}", key, "s", "{:.0f}"))
        elif name == "diff_max_die_rise_K":
            out.append((f"die rise {what}", key, "K", "{:.2f}"))
        elif name == "diff_t95_s":
            out.append((f"t95 {what}", key, "s", "{:.0f}"))
    return out


def _summary_page(pdf, unc: dict) -> None:
    fig = plt.figure(figsize=A4_LANDSCAPE)
    fig.text(0.04, 0.96, "What the model does not know: the answer's uncertainty", fontsize=14, va="top",
             weight="bold")
    fig.text(0.04, 0.92, textwrap.fill(
        f"{len(unc['inputs'])} uncertain inputs (ranges and sources on the page after next), {unc['draws']} draws "
        f"({unc['method']}). Intervals are the 5th to 95th percentile over the draws.", 150), fontsize=9, va="top")
    ax = fig.add_axes([0.04, 0.42, 0.92, 0.44])
    ax.axis("off")
    rows = []
    for label, key, unit, f in _key_outputs(unc):
        s = unc["stats"][key]
        rows.append([label, unit, _fmt(s["q05"], f), _fmt(s["q50"], f), _fmt(s["q95"], f),
                     ", ".join(s.get("drivers", [])[:3]) or "-"])
    if rows:
        t = ax.table(cellText=rows, colLabels=["output", "unit", "5 %", "median", "95 %", "driven most by (Sobol' ST)"],
                     loc="upper center", cellLoc="center", colWidths=[0.22, 0.05, 0.08, 0.08, 0.08, 0.45])
        t.auto_set_font_size(False)
        t.set_fontsize(8)
        t.scale(1.0, 1.3)
    words = list(unc.get("answer", []))
    chk = unc.get("max_check_error_K")
    ncheck = sum(len(v) for v in unc.get("checks", {}).values())
    if chk is not None:
        t95 = unc.get("max_check_t95_rel_error")
        curve = unc.get("max_check_curve_error_K")
        words.append(f"Check of the reduced model against the full FEM at {ncheck} drawn point(s): largest steady "
                     f"site error {chk:.3f} K" + (f", largest transient site error {curve:.3f} K" if curve is not None
                                                   else "") + (f", t95 within {100 * t95:.2f} %" if t95 is not None
                                                               else "") + ".")
    oven = unc.get("max_check_oven_error_K")
    if oven is not None:
        words.append(f"The IMU draws' oven self-heating map (the study's cold-oven rise scaled by the reduced model's "
                     f"steady ratio) against the full FEM at the same point(s): within {oven:.3f} K.")
    words.extend(unc.get("notes", []))
    if unc.get("not_propagated"):
        words.append("Not propagated: " + unc["not_propagated"] + ".")
    fig.text(0.04, 0.38, "\n".join(textwrap.fill(w, 165) for w in words), fontsize=8.5, va="top")
    pdf.savefig(fig)
    plt.close(fig)


#: (output, label, unit, format) of the IMU page's rows
_IMU_ROWS = (("residual gyro RMS", "gyro_rms_dps", "deg/s", "{:.4f}"),
             ("residual accel RMS", "accel_rms_mg", "mg", "{:.2f}"))


def _imu_page(pdf, unc: dict) -> None:
    imu = unc.get("imu")
    if not imu:
        return
    fig = plt.figure(figsize=A4_LANDSCAPE)
    fig.text(0.04, 0.96, "Residual sensor errors and attitude error under the model's uncertainty", fontsize=13,
             va="top", weight="bold")
    fig.text(0.04, 0.92, textwrap.fill(imu["method"] + ".", 170), fontsize=8.5, va="top")
    schemes = list(unc["applicable"])
    rows = []
    f0 = imu["filters"][0]  # the answer's filter (the others are in uncertainty.json)
    att = [(f"{ph} {f0} {ax} RMS", f"{ph}_{f0}_{ax}_rms_deg", "deg", "{:.3f}")
           for ph in ("warmup", "steady") for ax in ("roll", "pitch")]
    for label, name, unit, f in att + list((lab, n, u, fm) for lab, n, u, fm in _IMU_ROWS):
        for s in schemes:
            st, nom = imu["stats"][f"{name}:{s}"], imu["nominal"].get(f"{name}:{s}", {})
            rows.append([f"{label}, {s}", unit, st["interval"] or "-", _fmt(st["lo"], f), _fmt(st["q50"], f),
                         _fmt(st["hi"], f), _fmt(nom.get("mean"), f) + " +/- " + _fmt(nom.get("std"), f)])
        for i, a in enumerate(schemes):
            for b in schemes[i + 1:]:
                st = imu["stats"][f"diff_{name}:{a}-{b}"]
                rows.append([f"{label}, {a} - {b}", unit, st["interval"] or "-", _fmt(st["lo"], f),
                             _fmt(st["q50"], f), _fmt(st["hi"], f), "-"])
    ax = fig.add_axes([0.04, 0.2, 0.92, 0.62])
    ax.axis("off")
    t = ax.table(cellText=rows, colLabels=["output", "unit", "interval", "low", "median", "high",
                                           "study (mean +/- seed std)"],
                 loc="upper center", cellLoc="center", colWidths=[0.3, 0.06, 0.08, 0.09, 0.09, 0.09, 0.17])
    t.auto_set_font_size(False)
    t.set_fontsize(6.5 if len(rows) > 24 else 7.5)
    t.scale(1.0, 0.85 if len(rows) > 24 else 1.2)
    words = list(imu["answer"])
    if imu["failed"]:
        words.append(f"{len({f['draw'] for f in imu['failed']})} draw(s) failed in the IMU chain and are left out in "
                     f"every scheme: " + "; ".join(sorted({f['error'] for f in imu['failed']}))[:400])
    fig.text(0.04, 0.17, "\n".join(textwrap.fill(w, 175) for w in words), fontsize=8, va="top")
    pdf.savefig(fig)
    plt.close(fig)


def _sobol_page(pdf, unc: dict) -> None:
    outs = [(label, key) for label, key, _, _ in _key_outputs(unc) if unc["stats"][key].get("sobol")]
    if not outs:
        return
    names = [i["name"] for i in unc["inputs"]]
    ncol = 3
    nrow = int(np.ceil(len(outs) / ncol))
    fig, axes = plt.subplots(nrow, ncol, figsize=A4_LANDSCAPE, constrained_layout=True, squeeze=False)
    y = np.arange(len(names))
    for ax, (label, key) in zip(axes.flat, outs):
        sob = unc["stats"][key]["sobol"]
        st = [sob[n]["ST"] for n in names]
        s1 = [sob[n]["S1"] for n in names]
        ax.barh(y + 0.2, st, 0.4, xerr=[sob[n]["ST_conf"] for n in names], color="tab:red", capsize=2,
                label="total ST")
        ax.barh(y - 0.2, s1, 0.4, xerr=[sob[n]["S1_conf"] for n in names], color="tab:orange", capsize=2,
                label="first order S1")
        ax.set_yticks(y)
        ax.set_yticklabels(names, fontsize=7)
        ax.invert_yaxis()
        ax.set_xlim(-0.05, 1.05)
        ax.set_title(label, fontsize=8)
        ax.tick_params(labelsize=7)
        ax.grid(True, axis="x", alpha=0.3)
    axes.flat[0].legend(fontsize=7)
    for ax in list(axes.flat)[len(outs):]:
        ax.axis("off")
    fig.suptitle("Which unknowns drive each figure: Sobol' indices [-] (share of the output's variance; bars: 95 % "
                 "confidence)", fontsize=10)
    pdf.savefig(fig)
    plt.close(fig)


def _inputs_page(pdf, unc: dict) -> None:
    fig = plt.figure(figsize=A4_LANDSCAPE)
    fig.text(0.04, 0.96, "Uncertain inputs, their ranges and sources", fontsize=12, va="top", weight="bold")
    lines = []
    for i in unc["inputs"]:
        lo, hi = i["range"]
        lines.append(textwrap.fill(f"{i['name']} [{i['unit']}]: {lo:g} .. {hi:g}, {i['distribution']}. {i['source']}",
                                   160, subsequent_indent="    "))
    lines.extend(unc.get("notes", []))
    app = unc.get("applicable", {})
    for s, names in app.items():
        missing = [i["name"] for i in unc["inputs"] if i["name"] not in names]
        if missing:
            lines.append(f"scheme {s}: {', '.join(missing)} does not apply (no such part or interface)")
    fig.text(0.04, 0.9, "\n".join(lines), fontsize=8.5, va="top")
    pdf.savefig(fig)
    plt.close(fig)


def uncertainty_pages(pdf, unc: dict) -> None:
    """Append the uncertainty pages of ``unc`` (:func:`imutherm.studies.uncertainty.uncertainty.run_uncertainty`) to
    ``pdf``."""
    _summary_page(pdf, unc)
    _imu_page(pdf, unc)
    _sobol_page(pdf, unc)
    _inputs_page(pdf, unc)


def write_uncertainty_pdf(unc: dict, path) -> None:
    """``uncertainty.pdf``: the uncertainty pages alone (atomically: :func:`imutherm.io.atomic_write`)."""
    def write(tmp):
        with PdfPages(tmp) as pdf:
            uncertainty_pages(pdf, unc)
    atomic_write(path, write)
