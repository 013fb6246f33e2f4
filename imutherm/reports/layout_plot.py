"""``layout.png``: the unit in three orthographic views, parts and sites labelled."""

from __future__ import annotations

import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

from imutherm.geometry.build import MM, Geometry  # noqa: E402

COLOURS = {"housing": "#b0b4bc", "lid": "#d0d4dc", "board": "#2e8b57", "vias": "#8fbc8f", "box": "#e8e4d0", "component": "#333333",
           "die": "#c8402a", "pad": "#c88232", "bond": "#6fa8e6"}
VIEWS = (("top view (x, y)", 0, 1, 2), ("front view (x, z)", 0, 2, 1), ("side view (y, z)", 1, 2, 0))
_ORDER = ("housing", "lid", "box", "board", "vias", "bond", "component", "pad", "die")


def plot_layout(geometry: Geometry, path: str | os.PathLike) -> None:
    """Draw the unit of one scheme in three views and save a PNG [lengths in mm]."""
    fig, axes = plt.subplots(1, 3, figsize=(17, 6.2), gridspec_kw={"width_ratios": [70, 70, 48]})
    parts = sorted((p for p in geometry.parts if p.kind not in ("fill", "lid")), key=lambda p: _ORDER.index(p.kind))
    for ax, (title, a, b, depth) in zip(axes, VIEWS):
        for p in parts:
            lo, hi = p.lo, p.hi
            if p.kind == "housing":  # outline of the outer box and of the cavity
                ax.add_patch(Rectangle((lo[a] / MM, lo[b] / MM), (hi[a] - lo[a]) / MM, (hi[b] - lo[b]) / MM,
                                       fc=COLOURS["housing"], ec="k", lw=1.2))
                clo, chi = geometry.cavity
                ax.add_patch(Rectangle((clo[a] / MM, clo[b] / MM), (chi[a] - clo[a]) / MM, (chi[b] - clo[b]) / MM,
                                       fc="white", ec="k", lw=0.8))
                continue
            ax.add_patch(Rectangle((lo[a] / MM, lo[b] / MM), (hi[a] - lo[a]) / MM, (hi[b] - lo[b]) / MM,
                                   fc=COLOURS[p.kind], ec="k", lw=0.4, alpha=0.55 if p.kind == "board" else 0.85))
            if p.kind == "component" and a == 0 and b == 1:
                c = p.centroid / MM
                ax.annotate(p.name, (c[a], c[b]), fontsize=6.5, ha="center", va="center", color="white",
                            bbox=dict(boxstyle="round,pad=0.1", fc="black", alpha=0.4, lw=0))
        for name, pos in geometry.sites.items():
            ax.plot(pos[a] / MM, pos[b] / MM, marker="o" if name.startswith("tp") else "x", color="#ff00aa", ms=5)
            if name.startswith("tp") or a != 0 or b != 1:
                ax.annotate(name, (pos[a] / MM, pos[b] / MM), xytext=(3, 3), textcoords="offset points",
                            fontsize=7, color="#b0007a")
        ax.set_xlim(-1, geometry.outer[1][a] / MM + 1)
        ax.set_ylim(-1, geometry.outer[1][b] / MM + 1)
        ax.set_aspect("equal")
        ax.set_title(title)
        ax.set_xlabel(f"{'xyz'[a]} [mm]")
        ax.set_ylabel(f"{'xyz'[b]} [mm]")
    handles = [Rectangle((0, 0), 1, 1, fc=COLOURS[k], ec="k", lw=0.4) for k in _ORDER if k != "lid"]
    fig.legend(handles, [k for k in _ORDER if k != "lid"], loc="lower center", ncol=8, fontsize=8, frameon=False)
    lay = geometry.layout
    fig.suptitle(f"{lay.name}, scheme {geometry.scheme.name!r}: {geometry.scheme.description}\n"
                 f"mass {geometry.mass_kg * 1e3:.1f} g, power {geometry.total_power_W:.3f} W; "
                 f"x = sensor die site, o = test point", fontsize=10)
    fig.tight_layout(rect=(0, 0.05, 1, 0.93))
    fig.savefig(path, dpi=130)
    plt.close(fig)
