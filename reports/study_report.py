"""``report.pdf`` of the end-to-end study, drawn from the files of :func:`imutherm.studies.end_to_end.write_study`.

A design-review document, A4 landscape: the answer (attitude error per scheme,
compensation and filter) on page 1 as a figure with the seed spread, its table on page 2, then the
bare-calibration comparison and
the swing, the unit and each scheme pictured, temperature maps on one colour
scale, site curves, residual sensor errors and attitude error over the warm-up, the reference data the
layout declares beside the model (the reference unit: rise and settle time against the paper, the
paper-vs-model table with every difference explained; a user's unit: their bench readings; an imported
unit: none), and the parameters with their sources.
"""

from __future__ import annotations

import csv
import json
import os
import textwrap
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.backends.backend_pdf import PdfPages

from imutherm.imu.site_grades import grade_text
from imutherm.site_table import read_site_table

SCHEME_COLOURS = {"air": "#d62728", "grease": "#1f77b4", "potted": "#2ca02c"}
A4 = (11.69, 8.27)


def _colour(scheme: str, i: int = 0) -> str:
    return SCHEME_COLOURS.get(scheme, f"C{i + 3}")


def _read_csv(path: Path) -> tuple[list, np.ndarray]:
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    return rows[0], np.array([[float(v) for v in r] for r in rows[1:]], float)


def _fmt(stat, digits=2) -> str:
    if not stat:
        return "-"
    return f"{stat['mean']:.{digits}f}±{stat['std']:.{digits}f}"


def _title(fig, text: str, sub: str = "") -> float:
    """A page's title and subtitle; returns the figure height fraction just below the subtitle."""
    fig.text(0.03, 0.965, text, fontsize=14, weight="bold", va="top")
    if not sub:
        return 0.925
    fig.text(0.03, 0.925, sub, fontsize=8.5, va="top", color="0.25")
    line = 8.5 * 1.25 / 72 / fig.get_figheight()   # one subtitle line [figure fraction]
    return 0.925 - line * (sub.count("\n") + 1) - 0.008


def _table(ax, rows, cols, fontsize=7.0, col_widths=None, scale_y=1.25) -> None:
    ax.axis("off")
    tab = ax.table(cellText=rows, colLabels=cols, loc="upper center", cellLoc="center", colWidths=col_widths)
    tab.auto_set_font_size(False)
    tab.set_fontsize(fontsize)
    tab.scale(1, scale_y)
    for (r, _), cell in tab.get_celld().items():
        cell.set_linewidth(0.3)
        if r == 0:
            cell.set_facecolor("#e8e8e8")
            cell.set_text_props(weight="bold")
            n = max(str(c).count("\n") + 1 for c in cols)
            cell.set_height(cell.get_height() * (1.0 + 0.9 * (n - 1)))


def _attitude_rows(s: dict, tree_key: str, profile: str, comps, filters) -> list:
    rows = []
    for comp in comps:
        for f in filters:
            cells = []
            for ph in ("warmup", "steady"):
                m = s[tree_key].get(ph, {}).get(comp, {}).get(f, {}).get(profile)
                if m is None:
                    cells += ["-"] * 3
                    continue
                cells += [_fmt(m["roll_rms_deg"]), _fmt(m["pitch_rms_deg"]),
                          f"{m['roll_max_deg']['mean']:.1f} / {m['pitch_max_deg']['mean']:.1f}"]
            rows.append([comp, f] + cells)
    return rows


ATT_COLS = ["compensation", "filter", "warm-up roll\nRMS [deg]", "warm-up pitch\nRMS [deg]",
            "warm-up max\nroll/pitch [deg]", "steady roll\nRMS [deg]", "steady pitch\nRMS [deg]",
            "steady max\nroll/pitch [deg]"]


def _main_profile(st: dict) -> str:
    return "flight" if "flight" in st["profiles"] else st["profiles"][0]


def _settings_note(data: dict) -> str:
    fs = data.get("filter_settings") or {}
    if not fs.get("tuned"):
        return "filters at their defaults"
    seeds = ", ".join(map(str, fs.get("meta", {}).get("seeds", [])))
    return (f"every filter at its tuned settings ({Path(fs['file']).name}: one grid procedure for ours and the "
            f"peers, tuned on seeds {seeds}, not these)")


def answer_figure(fig, rect, data: dict) -> None:
    """The answer as bars: warm-up roll (top) and pitch (bottom) RMS [deg] of each filter per scheme (x) and
    compensation (columns), calibrated in the unit, main profile; error bars the seed std."""
    from imutherm.imu.filters.registry import color

    st = data["study"]
    prof = _main_profile(st)
    schemes, comps, filters = list(data["schemes"]), st["compensations"], st["filters"]
    left, bottom, width, height = rect
    gs = fig.add_gridspec(2, len(comps), left=left, right=left + width, bottom=bottom, top=bottom + height,
                          wspace=0.08, hspace=0.12)
    x = np.arange(len(schemes))
    w = 0.8 / max(len(filters), 1)
    axes = []
    for r, axis in enumerate(("roll", "pitch")):
        for c, comp in enumerate(comps):
            ax = fig.add_subplot(gs[r, c], sharey=axes[0] if axes else None)
            axes.append(ax)
            for k, f in enumerate(filters):
                ms = [data["schemes"][s]["attitude"]["warmup"].get(comp, {}).get(f, {}).get(prof) for s in schemes]
                mean = [m[f"{axis}_rms_deg"]["mean"] if m else np.nan for m in ms]
                std = [m[f"{axis}_rms_deg"]["std"] if m else 0.0 for m in ms]
                ax.bar(x + (k - (len(filters) - 1) / 2) * w, mean, w, yerr=std, capsize=1.5, color=color(f) or f"C{k}",
                       label=f, error_kw={"lw": 0.6})
            ax.set_yscale("log")
            ax.grid(alpha=0.3, axis="y", which="both")
            ax.set_xticks(x, schemes if r == 1 else [""] * len(schemes), fontsize=7.5)
            ax.tick_params(labelsize=7)
            if r == 0:
                ax.set_title(f"compensation: {comp}", fontsize=8.5)
            if c == 0:
                ax.set_ylabel(f"{axis} RMS [deg], warm-up", fontsize=8)
            else:
                plt.setp(ax.get_yticklabels(), visible=False)
    axes[len(comps) - 1].legend(fontsize=6.5, ncol=min(len(filters), 3), loc="upper right")


def boards_line(data: dict) -> str:
    """Where each board comes from: ``boards: main from openuav.kicad_pcb (KiCad 7 ...)``, or "" if all are
    the layout file's own."""
    imported = [b for b in data.get("boards", []) if b.get("source")]
    if not imported:
        return ""
    # the file's name and format; the full path is on the parameters page
    short = lambda src: src.replace("\\", "/").rsplit("/", 1)[-1]  # noqa: E731
    return "board " + "; ".join(f"{b['name']} from {short(b['source'])}" for b in imported) + "; "


def _answer_page(pdf, data: dict) -> None:
    """Page 1: the answer sentences and the answer as a figure (the tables follow)."""
    st = data["study"]
    prof = _main_profile(st)
    fig = plt.figure(figsize=A4)
    below = _title(fig, f"Which cooling scheme, and what it does to attitude accuracy: {data['layout']}", textwrap.fill(
           f"{boards_line(data)}ambient {data['ambient_C']:.0f} C, {data['power_W']:.2f} W; {grade_text(data)}, seeds "
           f"{data['seeds'][0]}..{data['seeds'][-1]} (bars: mean, whiskers: std over the seeds, the same seeds in "
           f"every scheme); calibrated in the unit (oven -40..70 C with each scheme's self-heating); out-of-range "
           f"policy '{data['out_of_range_policy']}'; {prof} profile, attitude error RMS through the warm-up; "
           f"{_settings_note(data)}", 165))
    y = min(0.88, below)
    model = data.get("model")
    if model:  # the study ran on a correlated model: name it and its correlation's before/after
        rms = (f"; correlation RMS {model['rms_before_K']:.2f} -> {model['rms_after_K']:.2f} K"
               if model.get("rms_before_K") is not None and model.get("rms_after_K") is not None else "")
        text = (f"Model: {model['file']} (correlated, verdict {model.get('verdict', 'not recorded')}{rms}); "
                f"re-tuned {', '.join(f'{k} {v:.4g}' for k, v in model['retune'].items()) or 'nothing'}; "
                f"effects {', '.join(model['effects']) or 'none'}"
                + (f"; not applied (measurement effects): {', '.join(model['not_applied'])}"
                   if model.get("not_applied") else ""))
        lines = textwrap.wrap(text, 190)
        fig.text(0.03, y, "\n".join(lines), fontsize=7.6, va="top", weight="bold")
        y -= 0.022 * len(lines) + 0.008
    for name, s in data["schemes"].items():
        lines = textwrap.wrap(s["answer"], 190)
        fig.text(0.03, y, "\n".join(lines), fontsize=7.6, va="top", color=_colour(name))
        y -= 0.022 * len(lines) + 0.008
    imu = (data.get("uncertainty") or {}).get("imu")
    if imu:  # compare --uncertainty: is each scheme's attitude advantage larger than what the model does not know?
        lines = textwrap.wrap("Under the model's uncertainty (pages 'Residual sensor errors and attitude error'): "
                              + " ".join(a for a in imu["answer"] if " roll RMS" in a), 190)
        fig.text(0.03, y, "\n".join(lines), fontsize=7.6, va="top")
        y -= 0.022 * len(lines) + 0.008
    answer_figure(fig, (0.07, 0.06, 0.9, y - 0.1), data)
    pdf.savefig(fig)
    plt.close(fig)


def _answer_table_page(pdf, data: dict) -> None:
    """Page 2: the answer as a table (RMS and max, warm-up and steady)."""
    st = data["study"]
    prof = _main_profile(st)
    fig = plt.figure(figsize=A4)
    below = _title(fig, "The answer in numbers: attitude error per scheme, compensation and filter", textwrap.fill(
           f"{prof} profile, calibrated in the unit, mean±std over seeds {data['seeds'][0]}..{data['seeds'][-1]}; "
           f"{_settings_note(data)}", 165))
    y = min(0.88, below)
    schemes = list(data["schemes"])
    rows = []
    for name in schemes:
        for r in _attitude_rows(data["schemes"][name], "attitude", prof, st["compensations"], st["filters"]):
            rows.append([name] + r)
    ax = fig.add_axes([0.02, 0.02, 0.96, y - 0.03])
    _table(ax, rows, ["scheme"] + ATT_COLS, fontsize=6.4, scale_y=0.92 * min(1.3, 30.0 / max(len(rows), 1)))
    pdf.savefig(fig)
    plt.close(fig)


def _bare_page(pdf, data: dict) -> None:
    st = data["study"]
    comps = [c for c in st["compensations"] if c != "none"]
    prof = _main_profile(st)
    fig = plt.figure(figsize=A4)
    _title(fig, "Calibrated in the unit vs calibrated as bare sensors; the swing test",
           f"{prof}: roll/pitch RMS [deg] with each calibration (mean±std over seeds); 'bare' = the same sensors "
           "calibrated on their own over -40..70 C die temperature, so in the unit they run beyond it; "
           "extrapolated = share of sample-sensor pairs outside the calibrated range")
    rows = []
    for name, s in data["schemes"].items():
        for comp in comps:
            for f in st["filters"]:
                cells = [name, comp, f]
                for key in ("attitude", "attitude_bare_calibration"):
                    for ph in ("warmup", "steady"):
                        m = s[key].get(ph, {}).get(comp, {}).get(f, {}).get(prof)
                        cells.append("-" if m is None else
                                     f"{m['roll_rms_deg']['mean']:.2f} / {m['pitch_rms_deg']['mean']:.2f}")
                rows.append(cells)
    cols = ["scheme", "compensation", "filter", "unit cal.\nwarm-up", "unit cal.\nsteady", "bare cal.\nwarm-up",
            "bare cal.\nsteady"]
    ax = fig.add_axes([0.02, 0.40, 0.55, 0.50])
    _table(ax, rows, cols, fontsize=6.2, scale_y=0.9 * min(1.3, 24.0 / max(len(rows), 1)))
    ext = [[n, f"{s['extrapolated_fraction']['mean']:.1%}", f"{s['extrapolated_fraction_bare_calibration']['mean']:.1%}",
            f"{s['max_reported_C_over_bare']:.1f}"] for n, s in data["schemes"].items()]
    ax = fig.add_axes([0.60, 0.70, 0.38, 0.2])
    _table(ax, ext, ["scheme", "extrapolated\n(unit cal.)", "extrapolated\n(bare cal.)", "max beyond bare\nrange [K]"],
           fontsize=7)
    if "swing" in st["profiles"] and prof != "swing":
        rows = []
        for name, s in data["schemes"].items():
            for r in _attitude_rows(s, "attitude", "swing", [c for c in st["compensations"] if c != "none"][-1:],
                                    st["filters"]):
                rows.append([name] + r)
        fig.text(0.02, 0.37, "swing (80 deg, 200 deg/s turntable), calibrated in the unit", fontsize=9, weight="bold")
        ax = fig.add_axes([0.02, 0.02, 0.96, 0.33])
        _table(ax, rows, ["scheme"] + ATT_COLS, fontsize=6.4, scale_y=1.0)
    pdf.savefig(fig)
    plt.close(fig)


def _image_pages(pdf, folder: Path, data: dict) -> None:
    for b in data.get("boards", []):
        png = folder / f"board_{b['name']}.png"
        if png.exists():  # an imported board: its true outline, every part with its reference
            fig = plt.figure(figsize=A4)
            _title(fig, f"Board {b['name']}, imported from its board file", f"{b['source']}; "
                   f"{b['merged_parts']} small unpowered parts merged into the board material ({b['material']})")
            ax = fig.add_axes([0.02, 0.02, 0.96, 0.86])
            ax.imshow(plt.imread(png))
            ax.axis("off")
            pdf.savefig(fig)
            plt.close(fig)
    for name, s in data["schemes"].items():
        png = folder / f"layout_{name}.png"
        if not png.exists():
            continue
        fig = plt.figure(figsize=A4)
        below = _title(fig, f"The unit, scheme {name}", textwrap.fill(s["description"], 165))
        ax = fig.add_axes([0.02, 0.02, 0.96, min(0.86, below - 0.03)])
        ax.imshow(plt.imread(png))
        ax.axis("off")
        pdf.savefig(fig)
        plt.close(fig)


def _map_page(pdf, folder: Path, data: dict) -> None:
    schemes = [s for s in data["schemes"] if (folder / f"maps_{s}.npz").exists()]
    maps = {s: np.load(folder / f"maps_{s}.npz") for s in schemes}
    tags = [t for t in ("main", "sensor") if all(f"{t}_T_C" in maps[s] for s in schemes)]
    if not schemes or not tags:
        return
    vals = np.concatenate([maps[s][f"{t}_T_C"].ravel() for s in schemes for t in tags])
    vmin, vmax = float(vals.min()), float(vals.max())
    fig, axes = plt.subplots(len(tags), len(schemes), figsize=A4, squeeze=False)
    fig.subplots_adjust(left=0.05, right=0.88, top=0.86, bottom=0.07, wspace=0.3, hspace=0.35)
    _title(fig, "Steady temperature through the main board and a sensor board (one colour scale)",
           f"grid plane nearest each board's mid-plane; ambient {data['ambient_C']:.0f} C")
    im = None
    for i, t in enumerate(tags):
        for j, s in enumerate(schemes):
            m = maps[s]
            ax = axes[i][j]
            im = ax.pcolormesh(m[f"{t}_u_mm"], m[f"{t}_v_mm"], m[f"{t}_T_C"].T, shading="gouraud", cmap="inferno",
                               vmin=vmin, vmax=vmax)
            ax.set_aspect("equal")
            axn = str(m[f"{t}_axes"])
            ax.set_title(f"{s}: {str(m[f'{t}_board'])} ({m[f'{t}_normal']} = {float(m[f'{t}_at_mm']):.1f} mm)",
                         fontsize=9)
            ax.set_xlabel(f"{axn[0]} [mm]")
            ax.set_ylabel(f"{axn[1]} [mm]")
    cax = fig.add_axes([0.91, 0.15, 0.015, 0.65])
    fig.colorbar(im, cax=cax, label="temperature [C]")
    pdf.savefig(fig)
    plt.close(fig)


def _curves_page(pdf, folder: Path, data: dict) -> None:
    schemes = [s for s in data["schemes"] if (folder / f"curves_{s}.csv").exists()]
    fig, axes = plt.subplots(1, len(schemes), figsize=A4, sharey=True, squeeze=False)
    fig.subplots_adjust(left=0.07, right=0.98, top=0.85, bottom=0.2, wspace=0.08)
    _title(fig, "Sensor-site temperatures after power-on (the warm-up the IMU sees)",
           "die centroids of the six sensors, test points tp1-3 on the main board; markers: t95 of each sensor")
    for ax, s in zip(axes[0], schemes):
        t, T, names = read_site_table(folder / f"curves_{s}.csv", None)
        header, d = ["time_s", *names], np.column_stack([t, T])
        for j, name in enumerate(header[1:], start=1):
            tp = name.startswith("tp")
            line, = ax.plot(d[:, 0], d[:, j], lw=1.6 if tp else 1.1, ls=":" if tp else "-", label=name)
            t95 = data["schemes"][s]["sites"].get(name, {}).get("t95_s")
            if t95 is not None and not tp:
                ax.plot([t95], [np.interp(t95, d[:, 0], d[:, j])], "o", ms=3, color=line.get_color())
        ax.set_title(f"{s}: t95 {data['schemes'][s]['t95_s']:.0f} s ({data['schemes'][s]['hottest_site']})",
                     fontsize=10)
        ax.set_xlabel("time since power-on [s]")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("temperature [C]")
    axes[0][-1].legend(fontsize=7, ncol=2)
    from imutherm.studies.end_to_end.summary import numerical_error_lines

    notes = [line for s in schemes for line in numerical_error_lines({"schemes": {s: data["schemes"][s]}})]
    if notes:   # the curves' numerical errors: the reduced transient's check and the mesh's (corrected) error
        fig.text(0.03, 0.11, "\n".join(textwrap.fill(n, 200) for n in notes), fontsize=6.5, va="top")
    pdf.savefig(fig)
    plt.close(fig)


def _paper_bars_page(pdf, data: dict) -> None:
    schemes = list(data["schemes"])
    figs = data["paper"]["figures"]["thermal"]
    sim = {"air": figs["simulated"]["scheme1_air_max_rise_K"], "grease": figs["simulated"]["scheme2_grease_max_rise_K"],
           "potted": figs["simulated"]["scheme3_potted_max_rise_K"]}
    settle = {"air": figs["measured"]["no_grease_near_steady_s"], "grease": figs["measured"]["grease_steady_s"]}
    fig, (a, b) = plt.subplots(1, 2, figsize=A4)
    fig.subplots_adjust(left=0.08, right=0.97, top=0.84, bottom=0.12, wspace=0.25)
    _title(fig, "Maximum rise and settle time against the paper (Liu et al. 2012)",
           "paper: FEM max rise 16 / 8 / 4 K; measured (IR, main board) > 20 K near steady at ~800 s without "
           "grease, <= 8 K steady at ~300 s with grease")
    x = np.arange(len(schemes))
    a.bar(x - 0.2, [data["schemes"][s]["max_rise_K"] for s in schemes], 0.4, label="this model: hot spot",
          color=[_colour(s, i) for i, s in enumerate(schemes)])
    a.bar(x + 0.2, [sim.get(s, np.nan) for s in schemes], 0.4, label="paper FEM", color="white", edgecolor="k",
          hatch="//")
    a.plot(x, [data["schemes"][s]["sites"].get("tp1", {}).get("rise_K", np.nan) for s in schemes], "kD",
           label="this model: tp1")
    a.plot([0], [figs["measured"]["no_grease_rise_K_at_least"]], "k^", ms=9, label="paper measured, air (>=)")
    if "grease" in schemes:
        a.plot([schemes.index("grease")], [figs["measured"]["grease_rise_K_at_most"]], "kv", ms=9,
               label="paper measured, grease (<=)")
    a.set_xticks(x, schemes)
    a.set_ylabel("rise over ambient [K]")
    a.legend(fontsize=8)
    a.grid(axis="y", alpha=0.3)
    b.bar(x - 0.2, [data["schemes"][s]["sites"].get("tp1", {}).get("t95_s") or np.nan for s in schemes], 0.4,
          color=[_colour(s, i) for i, s in enumerate(schemes)], label="this model: t95 at tp1")
    b.bar(x + 0.2, [settle.get(s, np.nan) for s in schemes], 0.4, color="white", edgecolor="k", hatch="//",
          label="paper measured: settled")
    b.set_xticks(x, schemes)
    b.set_ylabel("time to settle [s]")
    b.legend(fontsize=8)
    b.grid(axis="y", alpha=0.3)
    pdf.savefig(fig)
    plt.close(fig)


def _residual_page(pdf, folder: Path, data: dict) -> None:
    schemes = [s for s in data["schemes"] if (folder / f"residuals_{s}.csv").exists()]
    fig, axes = plt.subplots(2, len(schemes), figsize=A4, sharex=True, sharey="row", squeeze=False)
    fig.subplots_adjust(left=0.08, right=0.98, top=0.85, bottom=0.09, wspace=0.08, hspace=0.15)
    _title(fig, "Residual sensor errors over the warm-up (flight, first seed)",
           f"compensated output minus truth, {data['study']['residual_window_s']:g} s means (white noise averaged "
           "out), largest axis; solid: calibrated in the unit, dashed: calibrated bare")
    for j, s in enumerate(schemes):
        header, d = _read_csv(folder / f"residuals_{s}.csv")
        for row, (kind, unit) in enumerate((("accel", "mg"), ("gyro", "dps"))):
            ax = axes[row][j]
            for ci, comp in enumerate(("conventional", "improved")):
                for cal, ls in (("unit", "-"), ("bare", "--")):
                    cols = [header.index(f"{cal}_{comp}_{kind}_{a}_{unit}") for a in "xyz"
                            if f"{cal}_{comp}_{kind}_{a}_{unit}" in header]
                    if cols:
                        ax.plot(d[:, 0], np.abs(d[:, cols]).max(axis=1), ls=ls, color=f"C{ci}", lw=1,
                                label=f"{comp}, {cal}")
            ax.grid(alpha=0.3)
            if j == 0:
                ax.set_ylabel("accelerometer residual [mg]" if kind == "accel" else "gyro residual [deg/s]")
            if row == 0:
                ax.set_title(s)
            else:
                ax.set_xlabel("time since power-on [s]")
    axes[0][-1].legend(fontsize=7)
    pdf.savefig(fig)
    plt.close(fig)


def _attitude_page(pdf, folder: Path, data: dict) -> None:
    from imutherm.imu.filters.registry import color, linestyle

    schemes = [s for s in data["schemes"] if (folder / f"attitude_{s}.csv").exists()]
    fig, axes = plt.subplots(2, len(schemes), figsize=A4, sharex=True, sharey=True, squeeze=False)
    fig.subplots_adjust(left=0.08, right=0.98, top=0.85, bottom=0.09, wspace=0.08, hspace=0.15)
    comp = data["study"]["compensations"][-1]
    _title(fig, "Attitude error over the warm-up (flight, first seed, calibrated in the unit)",
           f"compensation '{comp}'; estimate minus truth; {_settings_note(data)}")
    for j, s in enumerate(schemes):
        header, d = _read_csv(folder / f"attitude_{s}.csv")
        for row, axis in enumerate(("roll", "pitch")):
            ax = axes[row][j]
            for f in data["study"]["filters"]:  # colour and line style: the registry's
                name = f"{f}_{axis}_err_deg"
                if name in header:
                    ax.plot(d[:, 0], d[:, header.index(name)], ls=linestyle(f), color=color(f), lw=0.9, label=f)
            ax.set_ylim(-3, 3)
            ax.grid(alpha=0.3)
            if j == 0:
                ax.set_ylabel(f"{axis} error [deg]")
            if row == 0:
                ax.set_title(s)
            else:
                ax.set_xlabel("time since power-on [s]")
    axes[0][-1].legend(fontsize=7)
    pdf.savefig(fig)
    plt.close(fig)


def _study_rise_at(folder: Path, data: dict, scheme: str, site: str, time_s) -> float:
    """This study's rise [K] of ``site`` in ``scheme`` at ``time_s`` [s] (None/inf: steady), or NaN."""
    sc = data["schemes"].get(scheme)
    if sc is None or site not in sc["sites"]:
        return float("nan")
    if time_s is None or not np.isfinite(time_s):
        return float(sc["sites"][site]["rise_K"])
    path = folder / f"curves_{scheme}.csv"
    if not path.exists():
        return float("nan")
    t, T, names = read_site_table(path, None)
    if site not in names or time_s > t[-1]:
        return float("nan")
    return float(np.interp(time_s, t, T[:, list(names).index(site)])) - data["ambient_C"]


def _readings_page(pdf, folder: Path, data: dict) -> None:
    """The readings the model was correlated on, side by side: measured, nominal, corrected (the correlation's
    figures) and this study on the corrected model; with the paper's own FEM where the study has it."""
    model = data.get("model") or {}
    rows_in = model.get("readings") or []
    if not rows_in:
        return
    rows = []
    for r in rows_in:
        t = r.get("time_s")
        steady = t is None or not np.isfinite(t)
        full = r.get("corrected_full_K")
        rows.append([r["file"], r["site"], "steady" if steady else f"{t:g}", f"{r['measured_K']:.1f}",
                     f"{r['nominal_K']:.1f}", f"{r['corrected_K']:.1f}", "-" if full is None else f"{full:.1f}",
                     f"{_study_rise_at(folder, data, r['scheme'], r['site'], t):.1f}"])
    mesh = ", ".join(f"{k} {v['nodes']:,} nodes" for k, v in data["mesh"].items())
    fig = plt.figure(figsize=A4)
    _title(fig, "The readings this model was correlated on, side by side",
           textwrap.fill(f"{model['file']}: rises over the ambient [K]; nominal and corrected from the correlation "
                         f"(reduced model; full: the corrected model re-run on the full FEM at the correlation's "
                         f"mesh), this study: the corrected model on this study's own mesh "
                         f"({mesh}). Verdict {model.get('verdict', 'not recorded')}; "
                         f"effects {', '.join(model.get('effects', [])) or 'none'}.", 150))
    ax = fig.add_axes([0.04, 0.08, 0.92, 0.72])
    ax.axis("off")
    tab = ax.table(cellText=rows, colLabels=["file", "site", "time [s]", "measured", "nominal", "corrected",
                                             "corrected, full FEM", "this study"], loc="upper center",
                   cellLoc="center")
    tab.auto_set_font_size(False)
    tab.set_fontsize(7.5)
    figs = (data.get("paper") or {}).get("figures", {}).get("thermal", {}).get("simulated", {})
    if figs:
        fig.text(0.04, 0.815, textwrap.fill(
            "The paper's own FEM (maximum rise of the unit, not at a site): "
            f"{figs.get('scheme1_air_max_rise_K', float('nan')):g} K air, "
            f"{figs.get('scheme2_grease_max_rise_K', float('nan')):g} K grease; this study's maximum rise: "
            + ", ".join(f"{k} {v['max_rise_K']:.1f} K" for k, v in data["schemes"].items()) + ".", 150), fontsize=8)
    pdf.savefig(fig)
    plt.close(fig)


def _paper_table_page(pdf, data: dict) -> None:
    fig = plt.figure(figsize=A4)
    _title(fig, "The paper vs this model", data["paper"]["figures"].get("source", ""))
    rows = [[textwrap.fill(r["quantity"], 34), r["paper"], textwrap.fill(r["model"], 22),
             textwrap.fill(r["difference"], 95)] for r in data["paper"]["comparison"]]
    ax = fig.add_axes([0.02, 0.02, 0.96, 0.86])
    ax.axis("off")
    tab = ax.table(cellText=rows, colLabels=["quantity", "paper", "this model", "difference, explained"],
                   loc="upper center", cellLoc="left", colWidths=[0.2, 0.09, 0.13, 0.58])
    tab.auto_set_font_size(False)
    tab.set_fontsize(6.6)
    for (r, _), cell in tab.get_celld().items():
        cell.set_linewidth(0.3)
        n = max(1, max(str(c).count("\n") + 1 for c in (rows[r - 1] if r > 0 else ["x"])))
        cell.set_height(0.022 * n + 0.008)
    pdf.savefig(fig)
    plt.close(fig)


def bench_page(pdf, bench: dict) -> None:
    """The bench readings a layout declares (``[reference_data] measured``) beside the model, one row each."""
    rows = [[r["file"], r["scheme"], r["site"], "steady" if r["time_s"] is None else f"{r['time_s']:g}",
             r.get("probe", "die"), f"{r['measured_K']:.2f}", f"{r['model_K']:.2f}", f"{r['difference_K']:+.2f}",
             textwrap.fill(r["note"], 60)] for r in bench["rows"]]
    d = np.array([r["difference_K"] for r in bench["rows"]]) if bench["rows"] else np.zeros(0)
    fig = plt.figure(figsize=A4)
    _title(fig, "Your reference data beside this model", textwrap.fill(
        f"{bench['source']} ({', '.join(bench['files'])}); rises over each run's ambient [K]; model: this study's "
        "site curve at the reading's time (steady: its settled value)"
        + (f"; RMS difference {np.sqrt(np.mean(d ** 2)):.2f} K, mean {d.mean():+.2f} K over {d.size} readings"
           if d.size else "; no reading of a scheme this study ran")
        + ("; not compared: " + ", ".join(bench["not_compared"]) if bench.get("not_compared") else ""), 165))
    ax = fig.add_axes([0.02, 0.02, 0.96, 0.84])
    _table(ax, rows[:40], ["file", "scheme", "site", "time [s]", "probe", "measured\n[K]", "model\n[K]",
                           "model -\nmeasured [K]", "note"], fontsize=6.6, col_widths=[0.12, 0.06, 0.07, 0.06, 0.06,
                                                                                  0.07, 0.07, 0.08, 0.41])
    pdf.savefig(fig)
    plt.close(fig)


def estimated_height_lines(data: dict) -> list:
    """The parameters page's lines naming each imported part whose height was estimated, with the rule."""
    out = []
    for name, (h, source) in (data.get("estimated_heights") or {}).items():
        out += textwrap.wrap(f"  height of {name} {h:g} mm ESTIMATED ({source})", 200, subsequent_indent="      ")
    return out


def _parameters_page(pdf, data: dict) -> None:
    fig = plt.figure(figsize=A4)
    _title(fig, "Parameters used and their sources",
           f"layout file {data['layout_path']} (every power, size and placement carries its source or 'assumed' "
           f"beside it); " + ("; ".join(f"board {b['name']} from {b['source']}" for b in data.get("boards", [])
                                        if b.get("source")) or "every board from the layout file"))
    lines = ["Materials:"]
    for name, m in data["materials"].items():
        k = f"k {m['k_in_plane']:g}" + ("" if m["k_through"] == m["k_in_plane"] else f"/{m['k_through']:g}")
        lines += textwrap.wrap(f"  {name}: {k} W/m K, rho {m['density']:g} kg/m3, c {m['specific_heat']:g} J/kg K"
                               + (f", eps {m['emissivity']:g}" if m.get("emissivity") is not None else "")
                               + f". Source: {m['source']}", 200, subsequent_indent="      ")
    lines += ["", "Powers [W]: " + ", ".join(f"{k} {v:.3f}" for k, v in data["powers_W"].items())]
    lines += estimated_height_lines(data)
    opts = data["model_options"]
    lines += ["", "Thermal model options: " + ", ".join(f"{k}={v}" for k, v in opts.items() if k != "interfaces")]
    lines += textwrap.wrap("Interfaces: " + "; ".join(f"{i['part_a']}/{i['part_b']} {i['conductance_W_m2K']:.0f} "
                                                      f"W/m2K ({i['source']})" for i in opts["interfaces"]), 200)
    lines += ["  exterior natural convection: Holman Table 7-2 laminar correlations; radiation eps sigma (T^4 - "
              "Tamb^4); contact conductances: Incropera Table 3.1b; cavity radiation: Incropera eq. 13.24"]
    st = data["study"]
    lines += ["", "IMU study: " + ", ".join(f"{k}={v}" for k, v in st.items())]
    lines += ["  sensor grade: imu/grades.py (datasheet values tagged [DS], assumed ones [ASSUMED]); "
              "calibration rig: the two-step oven procedure of imu/calibration.py (its source named there)"]
    lines += ["  mesh: " + ", ".join(f"{s} {m['nodes']} nodes" for s, m in data["mesh"].items())
              + f"; study wall time {data['wall_s']:.0f} s"]
    fig.text(0.03, 0.9, "\n".join(lines), fontsize=6.8, va="top", family="monospace")
    pdf.savefig(fig)
    plt.close(fig)


def write_study_report(folder: str | os.PathLike, path: str | os.PathLike, *, files_ready=None) -> None:
    """Draw ``report.pdf`` from ``summary.json`` and the CSV / NPZ / PNG files in ``folder``.

    ``files_ready``: called once the pages drawn from ``summary.json`` alone are done, before the first page
    that reads another file (the command writes those files beside the first pages, in another process)."""
    folder = Path(folder)
    data = json.loads((folder / "summary.json").read_text())
    with PdfPages(path) as pdf:
        _answer_page(pdf, data)
        _answer_table_page(pdf, data)
        if data.get("uncertainty"):  # imutherm compare --uncertainty
            from imutherm.reports.uncertainty_report import uncertainty_pages

            uncertainty_pages(pdf, data["uncertainty"])
        _bare_page(pdf, data)
        if files_ready is not None:
            files_ready()
        _image_pages(pdf, folder, data)
        _map_page(pdf, folder, data)
        _curves_page(pdf, folder, data)
        if data.get("paper"):  # only for a layout that declares the paper's figures (the reference unit)
            _paper_bars_page(pdf, data)
        _readings_page(pdf, folder, data)
        _residual_page(pdf, folder, data)
        _attitude_page(pdf, folder, data)
        if data.get("paper"):
            _paper_table_page(pdf, data)
        if data.get("reference"):  # the user's bench readings the layout declares
            bench_page(pdf, data["reference"])
        _parameters_page(pdf, data)
