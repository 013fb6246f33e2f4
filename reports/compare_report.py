"""``report.pdf``: the thermal comparison of the schemes, drawn from the files of ``write_comparison``."""

from __future__ import annotations

import json
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.backends.backend_pdf import PdfPages

SCHEME_COLOURS = {"air": "#d62728", "grease": "#1f77b4", "potted": "#2ca02c"}


def _read_probes(path: Path) -> tuple:
    """(header with ``time_s`` first, data (M, 1 + sites)) of a site-temperature table."""
    from imutherm.site_table import TIME, read_site_table

    t, T, names = read_site_table(path, None)
    return [TIME, *names], np.column_stack([t, T])


def _table_page(pdf, data: dict) -> None:
    fig = plt.figure(figsize=(11.7, 8.3))
    fig.text(0.05, 0.94, "imutherm: the cooling schemes of the unit", fontsize=16, weight="bold")
    any_s = next(iter(data["schemes"].values()))
    paper = data.get("paper")
    fig.text(0.05, 0.90, f"layout {any_s['layout']}, ambient {any_s['ambient_C']:.0f} C, power {any_s['power_W']:.3f} W, "
             f"mesh {any_s['mesh']['nodes']} nodes; rises in K over ambient"
             + (f"; paper = {paper['source']}" if paper else ""), fontsize=10)
    from imutherm.studies.compare import thermal_table

    cols, rows = thermal_table(data)
    ax = fig.add_axes([0.03, 0.55, 0.94, 0.3])
    ax.axis("off")
    tab = ax.table(cellText=rows, colLabels=cols, loc="center", cellLoc="center")
    tab.auto_set_font_size(False)
    tab.set_fontsize(8.5)
    tab.scale(1, 2.2)
    lines = ["Sensor-site rises [K] (final state of the power-on transient):"]
    for s, r in data["schemes"].items():
        lines.append(f"  {s:<7} " + "  ".join(f"{n} {v['rise_K']:.2f}" for n, v in r["sites"].items()
                                               if not n.startswith("tp")))
    opts = [f"{k}={v}" for k, v in any_s["model_options"].items() if k != "interfaces"]
    lines += ["", "Model: " + ", ".join(opts[:4]), "       " + ", ".join(opts[4:]),
              "Interfaces: " + "; ".join(f"{i['part_a']}/{i['part_b']} {i['conductance_W_m2K']:.0f} W/m^2K"
                                         for i in any_s["model_options"]["interfaces"])]
    fig.text(0.05, 0.47, "\n".join(lines), fontsize=9, family="monospace", va="top")
    pdf.savefig(fig)
    plt.close(fig)


def _rise_page(pdf, data: dict) -> None:
    fig, (a, b) = plt.subplots(1, 2, figsize=(11.7, 5.5))
    schemes = list(data["schemes"])
    x = np.arange(len(schemes))
    a.bar(x - 0.2, [data["schemes"][s]["max_rise_K"] for s in schemes], 0.4, label="imutherm",
          color=[SCHEME_COLOURS.get(s, "grey") for s in schemes])
    if data.get("paper"):  # only for a layout that declares the paper's figures (the reference unit)
        a.bar(x + 0.2, [data["paper"]["simulated_max_rise_K"].get(s, np.nan) for s in schemes], 0.4,
              label="paper (simulated)", color="white", edgecolor="k", hatch="//")
    a.set_xticks(x, schemes)
    a.set_ylabel("maximum rise over ambient [K]")
    a.set_title("hot spot")
    a.legend()
    names = list(next(iter(data["schemes"].values()))["sites"])
    w = 0.8 / len(schemes)
    for i, s in enumerate(schemes):
        b.bar(np.arange(len(names)) + (i - 1) * w, [data["schemes"][s]["sites"][n]["rise_K"] for n in names], w,
              label=s, color=SCHEME_COLOURS.get(s, "grey"))
    b.set_xticks(np.arange(len(names)), names, rotation=45)
    b.set_ylabel("rise over ambient [K]")
    b.set_title("sensor dies and test points")
    b.legend()
    fig.tight_layout()
    pdf.savefig(fig)
    plt.close(fig)


def _transient_page(pdf, folder: Path, data: dict) -> None:
    schemes = [s for s in data["schemes"] if (folder / f"probes_{s}.csv").exists()]
    fig, axes = plt.subplots(1, len(schemes), figsize=(11.7, 4.8), sharey=True, squeeze=False)
    for ax, s in zip(axes[0], schemes):
        header, d = _read_probes(folder / f"probes_{s}.csv")
        if len(d) < 2:
            continue
        for j, name in enumerate(header[1:], start=1):
            ax.plot(d[:, 0], d[:, j], lw=2 if name.startswith("tp") else 1, ls="-" if name.startswith("tp") else "--",
                    label=name)
        t95 = data["schemes"][s]["sites"].get("tp1", {}).get("t95_s")
        if t95:
            ax.axvline(t95, color="k", lw=0.8, ls=":")
            ax.annotate(f"tp1 t95 {t95:.0f} s", (t95, ax.get_ylim()[0]), rotation=90, fontsize=7, va="bottom")
        ax.set_title(f"{s}: power-on from {data['schemes'][s]['ambient_C']:.0f} C")
        ax.set_xlabel("time [s]")
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("temperature [C]")
    axes[0][-1].legend(fontsize=7, ncol=2)
    fig.tight_layout()
    pdf.savefig(fig)
    plt.close(fig)


def _map_page(pdf, folder: Path, data: dict) -> None:
    schemes = [s for s in data["schemes"] if (folder / f"map_{s}.npz").exists()]
    fig, axes = plt.subplots(1, len(schemes), figsize=(11.7, 4.6), squeeze=False)
    for ax, s in zip(axes[0], schemes):
        m = np.load(folder / f"map_{s}.npz")
        im = ax.pcolormesh(m["u_mm"], m["v_mm"], m["T_C"].T, shading="gouraud", cmap="inferno")
        ax.set_aspect("equal")
        ax.set_title(f"{s}: main-board plane {m['normal']} = {float(m['at_mm']):.2f} mm (steady)", fontsize=9)
        ax.set_xlabel(f"{str(m['axes'])[0]} [mm]")
        ax.set_ylabel(f"{str(m['axes'])[1]} [mm]")
        fig.colorbar(im, ax=ax, label="T [C]", shrink=0.8)
    fig.tight_layout()
    pdf.savefig(fig)
    plt.close(fig)


def write_compare_report(folder: str | os.PathLike, path: str | os.PathLike) -> None:
    """Draw ``report.pdf`` from ``compare.json``, ``probes_*.csv`` and ``map_*.npz`` in ``folder``."""
    folder = Path(folder)
    data = json.loads((folder / "compare.json").read_text())
    with PdfPages(path) as pdf:
        _table_page(pdf, data)
        _rise_page(pdf, data)
        if any(r["mode"] == "transient" for r in data["schemes"].values()):
            _transient_page(pdf, folder, data)
        _map_page(pdf, folder, data)
        if data.get("reference"):  # the bench readings the layout declares, beside the model
            from imutherm.reports.study_report import bench_page

            bench_page(pdf, data["reference"])
        if (folder / "layout.png").exists():
            fig = plt.figure(figsize=(11.7, 4.6))
            ax = fig.add_axes([0, 0, 1, 1])
            ax.imshow(plt.imread(folder / "layout.png"))
            ax.axis("off")
            pdf.savefig(fig)
            plt.close(fig)
