"""``layout.png``: the unit in three orthographic views, boards, parts and sites labelled.

Each component is labelled once, in the view that sees its board face-on (top
view: the main board; front and side views: the boards standing across them);
each site likewise (a sensor-die site named like its component is labelled by
the component's label). Every board is labelled in every view, along its edge
at the free spot nearest its start.
"""

from __future__ import annotations

import os

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Rectangle

from imutherm.geometry.build import MM, Geometry
from imutherm.geometry.layout import AXES

COLOURS = {"housing": "#b0b4bc", "lid": "#d0d4dc", "board": "#2e8b57", "vias": "#8fbc8f", "box": "#e8e4d0", "component": "#333333",
           "die": "#c8402a", "pad": "#c88232", "bond": "#6fa8e6"}
ALPHA = {"housing": 1.0, "board": 0.55}  # every other kind: _ALPHA_DEFAULT
_ALPHA_DEFAULT = 0.85
VIEWS = (("top view (x, y)", 0, 1, 2), ("front view (x, z)", 0, 2, 1), ("side view (y, z)", 1, 2, 0))
_ORDER = ("housing", "lid", "box", "board", "vias", "bond", "component", "pad", "die")
SITE_COLOUR, SITE_TEXT = "#ff00aa", "#b0007a"
BOARD_TEXT = "#0b3d20"


def _alpha(kind: str) -> float:
    return ALPHA.get(kind, _ALPHA_DEFAULT)


def _rect(p, a: int, b: int) -> tuple:
    """(x0, y0, x1, y1) [mm] of a part's box projected on view axes a, b."""
    return p.lo[a] / MM, p.lo[b] / MM, p.hi[a] / MM, p.hi[b] / MM


def _face_on_view(geometry: Geometry, part_name: str) -> int:
    """Index in VIEWS of the view that sees ``part_name``'s board face-on (the top view if it has none)."""
    boards = {b.name: b for b in geometry.layout.boards}
    comps = {c.name: c for c in geometry.layout.components}
    p = geometry.part(part_name)
    owner = p.parent if p.kind in ("die", "pad", "bond") else p.name
    if p.kind == "vias":
        owner = p.parent
    normal = comps[owner].board if owner in comps else owner
    n = AXES.index(boards[normal].normal) if normal in boards else 2
    return next(i for i, v in enumerate(VIEWS) if v[3] == n)


def _overlap(r, s) -> float:
    return max(0.0, min(r[2], s[2]) - max(r[0], s[0])) * max(0.0, min(r[3], s[3]) - max(r[1], s[1]))


def _text_rect(ax, text, renderer) -> tuple:
    """Data-coordinate (x0, y0, x1, y1) of a drawn text (its box included)."""
    bb = text.get_window_extent(renderer)
    (x0, y0), (x1, y1) = ax.transData.inverted().transform([[bb.x0, bb.y0], [bb.x1, bb.y1]])
    return min(x0, x1), min(y0, y1), max(x0, x1), max(y0, y1)


def _label_boards(fig, axes, geometry: Geometry) -> None:
    """Name every board in every view: along a strip seen edge-on, inside a board seen face-on,
    at the candidate spot covering the least of the other parts, labels and site markers."""
    renderer = fig.canvas.get_renderer()
    boards = [p for p in geometry.parts if p.kind == "board"]
    others = [p for p in geometry.parts if p.kind not in ("housing", "lid", "fill", "board")]
    for ax, (_, a, b, _) in zip(axes, VIEWS):
        ax.apply_aspect()
        taken = [_rect(p, a, b) for p in others]
        taken += [_text_rect(ax, t, renderer) for t in ax.texts]
        taken += [(pos[a] / MM - 0.8, pos[b] / MM - 0.8, pos[a] / MM + 0.8, pos[b] / MM + 0.8)
                  for pos in geometry.sites.values()]   # keep the site markers visible
        for board in boards:
            x0, y0, x1, y1 = _rect(board, a, b)
            w, h = x1 - x0, y1 - y0
            strip = min(w, h) < 3.0   # seen edge-on: a thin strip
            vertical = strip and h > w
            t = ax.text(0, 0, board.name, fontsize=7, fontstyle="italic", fontweight="bold", color=BOARD_TEXT,
                        rotation=90 if vertical else 0, rotation_mode="anchor", ha="left", va="center",
                        bbox=dict(boxstyle="round,pad=0.15", fc="white", ec=COLOURS["board"], lw=0.6, alpha=0.85),
                        zorder=6)
            tx0, ty0, tx1, ty1 = _text_rect(ax, t, renderer)
            tw, th = tx1 - tx0, ty1 - ty0   # extent in data units, rotation included
            pad = 0.5
            if strip and vertical:
                cx = x0 + w / 2
                spots = [(cx - tw / 2, y) for y in np.linspace(y0 + pad, max(y0 + pad, y1 - pad - th), 7)]
            elif strip:
                cy = y0 + h / 2
                spots = [(x, cy - th / 2) for x in np.linspace(x0 + pad, max(x0 + pad, x1 - pad - tw), 7)]
            else:   # face-on: inside, along the top and bottom edges
                xs = (x0 + pad, x0 + (w - tw) / 2, x1 - pad - tw)
                spots = [(x, y1 - pad - th) for x in xs] + [(x, y0 + pad) for x in xs]
            # least covered spot; ties go to the first (the board's start)
            best = min(spots, key=lambda s: sum(_overlap((s[0], s[1], s[0] + tw, s[1] + th), r) for r in taken))
            # place the text so its box's lower left corner lands on the spot
            x, y = t.get_position()
            t.set_position((x + best[0] - tx0, y + best[1] - ty0))
            taken.append((best[0], best[1], best[0] + tw, best[1] + th))


def layout_figure(geometry: Geometry):
    """The three-view figure of one scheme [lengths in mm] (the caller saves and closes it)."""
    fig, axes = plt.subplots(1, 3, figsize=(17, 6.2), gridspec_kw={"width_ratios": [70, 70, 48]})
    parts = sorted((p for p in geometry.parts if p.kind not in ("fill", "lid")), key=lambda p: _ORDER.index(p.kind))
    comp_view = {p.name: _face_on_view(geometry, p.name) for p in parts if p.kind == "component"}
    site_view, site_labelled = {}, {}
    site_marker = {s.name: "x" if s.part else "o" for s in geometry.layout.sites}
    for s in geometry.layout.sites:
        if s.part:
            p = geometry.part(s.part)
            site_view[s.name] = _face_on_view(geometry, s.part)
            owner = p.parent if p.kind in ("die", "pad") else p.name
            site_labelled[s.name] = s.name == owner and owner in comp_view   # the component's label names it
        else:
            site_view[s.name] = _face_on_view(geometry, s.board)
            site_labelled[s.name] = False
    for iv, (ax, (title, a, b, depth)) in enumerate(zip(axes, VIEWS)):
        for p in parts:
            x0, y0, x1, y1 = _rect(p, a, b)
            if p.kind == "housing":  # outline of the outer box and of the cavity
                ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fc=COLOURS["housing"], ec="k", lw=1.2))
                clo, chi = geometry.cavity
                ax.add_patch(Rectangle((clo[a] / MM, clo[b] / MM), (chi[a] - clo[a]) / MM, (chi[b] - clo[b]) / MM,
                                       fc="white", ec="k", lw=0.8))
                continue
            ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fc=COLOURS[p.kind], ec="k", lw=0.4,
                                   alpha=_alpha(p.kind)))
        for p in parts:   # component names along the package's upper edge, clear of the die and its site
            if p.kind == "component" and comp_view[p.name] == iv:
                x0, y0, x1, y1 = _rect(p, a, b)
                ax.annotate(p.name, ((x0 + x1) / 2, y1), xytext=(0, -2), textcoords="offset points",
                            fontsize=6.5, ha="center", va="top", color="white", zorder=5,
                            bbox=dict(boxstyle="round,pad=0.1", fc="black", alpha=0.45, lw=0))
        for name, pos in geometry.sites.items():
            ax.plot(pos[a] / MM, pos[b] / MM, marker=site_marker[name], color=SITE_COLOUR, ms=5, zorder=4)
            if site_view[name] == iv and not site_labelled[name]:
                ax.annotate(name, (pos[a] / MM, pos[b] / MM), xytext=(7, 6), textcoords="offset points",
                            fontsize=7, color=SITE_TEXT, zorder=5,
                            bbox=dict(boxstyle="round,pad=0.1", fc="white", alpha=0.7, lw=0),
                            arrowprops=dict(arrowstyle="-", color=SITE_TEXT, lw=0.6, shrinkA=0, shrinkB=2))
        ax.set_xlim(-1, geometry.outer[1][a] / MM + 1)
        ax.set_ylim(-1, geometry.outer[1][b] / MM + 1)
        ax.set_aspect("equal")
        ax.set_title(title)
        ax.set_xlabel(f"{'xyz'[a]} [mm]")
        ax.set_ylabel(f"{'xyz'[b]} [mm]")
    kinds = [k for k in _ORDER if k != "lid"]
    handles = [Rectangle((0, 0), 1, 1, fc=COLOURS[k], ec="k", lw=0.4, alpha=_alpha(k)) for k in kinds]
    fig.legend(handles, kinds, loc="lower center", ncol=len(kinds), fontsize=8, frameon=False)
    lay = geometry.layout
    fig.suptitle(f"{lay.name}, scheme {geometry.scheme.name!r}: {geometry.scheme.description}\n"
                 f"mass {geometry.mass_kg * 1e3:.1f} g, power {geometry.total_power_W:.3f} W; "
                 f"x = site at a part's centroid (sensor die), o = test point on a board; "
                 f"each part and site is named in the view that sees its board face-on", fontsize=10)
    fig.tight_layout(rect=(0, 0.05, 1, 0.93))
    _label_boards(fig, axes, geometry)
    return fig


def plot_layout(geometry: Geometry, path: str | os.PathLike) -> None:
    """Draw the unit of one scheme in three views and save a PNG [lengths in mm]."""
    fig = layout_figure(geometry)
    try:
        fig.savefig(path, dpi=130)
    finally:
        plt.close(fig)
